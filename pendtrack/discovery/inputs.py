"""What discovery reads: an angle series ``theta(t)``, through the shared table reader.

Every input format (angle, kinematics or other Parquet files, CSV/whitespace tables of t,
theta or t, x, y, ``--columns``, units, resampling of slightly uneven time stamps, the
degrees/position warnings) is :mod:`pendtrack.tables`'; the video case is handled by
:mod:`pendtrack.stages.discover`, which runs the video stages first and then reads their
``angle.parquet``. Discovery keeps the usable rows (``ok``) only, and needs at least
:data:`MIN_SAMPLES` of them. Every problem is an :class:`~pendtrack.errors.ArtifactError`
whose message names the file.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from pendtrack.kinematics import swing_centre_shift
from pendtrack.kinematics.free_swing import free_swing
from pendtrack.tables import PivotFit, Record, TableSpec, is_video, read_record, turning_values

__all__ = ["MIN_SAMPLES", "AngleSeries", "is_video", "read_angle_series", "series_from_record"]

MIN_SAMPLES = 100  # fewer samples cannot hold the few periods a fit and a held-out part need


@dataclass(frozen=True, eq=False)
class AngleSeries:
    """A measured angle series, ready for discovery.

    Attributes
    ----------
    t : ndarray
        Sample times [s], strictly increasing.
    theta : ndarray
        Angle [rad] (0 hanging down, see docs/architecture.md).
    source : Path
        The file it was read from.
    kind : str
        ``"angle"``, ``"kinematics"``, ``"parquet"`` (a Parquet file without pendtrack
        metadata) or ``"table"`` (a text file).
    smoothed : bool
        True when ``theta`` is already Savitzky-Golay smoothed (a kinematics artifact).
    zero_shift : float
        Subtracted from the file's angle [rad]: the swing's centre when the file's zero is far from it
        (:meth:`centred`), else 0.
    marker_radius_px : float or None
        The tracked marker's distance from the axle [px] (a tracked video's angle or kinematics file), from
        which its slow frames are found (:func:`pendtrack.fitting.leastsq.samples.slow_frames`); None: not
        tracked from a video.
    """

    t: np.ndarray
    theta: np.ndarray
    source: Path
    kind: str
    smoothed: bool = False
    zero_shift: float = 0.0
    marker_radius_px: float | None = None

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.size)

    @property
    def dt(self) -> float:
        """Median sampling interval [s]."""
        return float(np.median(np.diff(self.t)))

    @property
    def rate_hz(self) -> float:
        """Median sampling rate [1/s]."""
        return 1.0 / self.dt

    @property
    def duration(self) -> float:
        """Record length [s]."""
        return float(self.t[-1] - self.t[0])

    def to_dict(self) -> dict[str, object]:
        return {"source": str(self.source), "kind": self.kind, "n": self.n, "rate_hz": self.rate_hz,
                "duration_s": self.duration, "smoothed": self.smoothed, "zero_shift_rad": self.zero_shift}

    def centred(self) -> AngleSeries:
        """The series about its swing's centre when the file's zero is far from it (a sensor's atan2 angle,
        an angle from the x axis: :func:`pendtrack.kinematics.swing_centre_shift` of its turning angles).

        Every model's physics needs theta = 0 hanging down; the ``offset`` term, judged on a physics fitted
        about a zero 1.5 rad away, cannot show its worth. What remains of the zero is the offset's to judge.
        """
        shift = swing_centre_shift(turning_values(self.theta))
        if shift == 0.0:
            return self
        return replace(self, theta=self.theta - shift, zero_shift=self.zero_shift + shift)


def series_from_record(rec: Record) -> AngleSeries:
    """The usable rows of a :class:`pendtrack.tables.Record` as an :class:`AngleSeries`, from the release on
    to a catch (neither is a free swing: :func:`pendtrack.kinematics.free_swing.free_swing`)."""
    ok = rec.ok if rec.kind == "kinematics" else free_swing(rec.t, rec.theta, rec.ok, source=rec.source)[0]
    return AngleSeries(t=rec.t[ok], theta=rec.theta[ok], source=rec.source, kind=rec.kind,
                       smoothed=(rec.kind == "kinematics"), marker_radius_px=rec.marker_radius_px)


def read_angle_series(path: str | Path, *, table: TableSpec | None = None,
                      pivot_fit: PivotFit | None = None) -> AngleSeries:
    """Read ``t`` and ``theta`` from a Parquet artifact or a text table (:func:`pendtrack.tables.read_record`).

    Parameters
    ----------
    path : path
        Parquet file (angle, kinematics or any with ``t``/``theta`` columns) or text table.
    table : TableSpec, optional
        ``--columns`` and ``--pivot`` of a table.
    pivot_fit : callable, optional
        Fits the pivot of x, y columns when ``table.pivot`` is not given (the discover stage
        passes :func:`pendtrack.track.axle.fitted_pivot`).

    Returns
    -------
    AngleSeries
        The usable rows (``ok``).

    Raises
    ------
    ArtifactError
        The file is missing, unreadable, lacks the columns, has fewer than :data:`MIN_SAMPLES`
        usable rows, or its times are not finite and strictly increasing; the message names the file.
    """
    rec = read_record(path, spec=table, pivot_fit=pivot_fit, min_samples=MIN_SAMPLES, purpose="discovery")
    return series_from_record(rec)
