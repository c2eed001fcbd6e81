"""Exceptions a user can cause and fix.

Every :class:`PendtrackError` is reported by the CLI as one line ``error: <message>``
with exit code 2. Its message must name the file (when there is one) and the problem.
Programming errors are ordinary exceptions and keep their traceback.
"""

from __future__ import annotations

from pathlib import Path


class PendtrackError(Exception):
    """A problem with the user's input, files or configuration."""

    def __init__(self, message: str, *, path: str | Path | None = None) -> None:
        self.path = None if path is None else Path(path)
        text = message if path is None else f"{path}: {message}"
        super().__init__(text)


class ConfigError(PendtrackError):
    """A configuration file or option is invalid."""


class ArtifactError(PendtrackError):
    """A Parquet/JSON artifact is missing, malformed or violates its schema."""


class VideoError(PendtrackError):
    """A video cannot be opened, decoded or is empty."""


class TrackingError(PendtrackError):
    """The marker cannot be found or followed."""


class ModelError(PendtrackError):
    """Unknown model or term, or parameters out of their physical range."""


class FitError(PendtrackError):
    """The data cannot support a fit (too few samples, no oscillation, ...)."""
