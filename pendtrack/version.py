"""The installed package's version (``pendtrack.__version__``), for the provenance and ``--version``."""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("pendtrack")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"
