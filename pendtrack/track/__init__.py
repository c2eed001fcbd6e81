"""Marker tracking core: colour features, detection, template matching, circle fit, the swing plane's tilt, angle.

Pure functions and small classes over numpy arrays; no files, no printing. Image
coordinates in px, x right, y down, pixel centres at integer coordinates.
"""
