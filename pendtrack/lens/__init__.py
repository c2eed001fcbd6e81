"""Lens models: Tracker-compatible fisheye correction of points and images (pure core)."""
