"""pendtrack: from a fisheye video of a physical pendulum to fitted physical models.

Importing the package does no work: no numba compilation, no file access.
"""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("pendtrack")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
