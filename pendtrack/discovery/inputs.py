"""What discovery reads: an angle series ``theta(t)`` from a Parquet artifact or a text table.

Accepted inputs (the video case is handled by :mod:`pendtrack.stages.discover`, which runs
the video stages first and then reads their ``angle.parquet`` through this module):

* an ``angle.parquet`` or ``kinematics.parquet`` artifact, or any Parquet file with float
  columns ``t`` [s] and ``theta`` [rad] and an optional boolean ``ok`` (rows with
  ``ok = false`` are dropped);
* a CSV or whitespace-separated text table whose first two columns are ``t`` [s] and
  ``theta`` [rad]; further columns are ignored, as are blank lines and lines starting with
  ``#``; a first line that is not numeric is taken as a header.

Any sampling rate is accepted; the samples must have strictly increasing, finite times.
Every problem is an :class:`~pendtrack.errors.ArtifactError` whose message names the file.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendtrack.config import VIDEO_SUFFIXES
from pendtrack.errors import ArtifactError

PARQUET_SUFFIXES = frozenset({".parquet", ".pq"})
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
    """

    t: np.ndarray
    theta: np.ndarray
    source: Path
    kind: str
    smoothed: bool = False

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
                "duration_s": self.duration, "smoothed": self.smoothed}


def is_video(path: str | Path) -> bool:
    """True if ``path`` looks like a video file (by its suffix)."""
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


def read_angle_series(path: str | Path) -> AngleSeries:
    """Read ``t`` and ``theta`` from a Parquet artifact or a text table.

    Parameters
    ----------
    path : path
        Parquet file (angle, kinematics or any with ``t``/``theta`` columns) or text table.

    Returns
    -------
    AngleSeries

    Raises
    ------
    ArtifactError
        The file is missing, unreadable, lacks the columns, or its times are not finite and
        strictly increasing; the message names the file.
    """
    path = Path(path)
    if not path.is_file():
        raise ArtifactError("file not found", path=path)
    if is_video(path):
        raise ArtifactError("is a video: run the video stages first (`pendtrack discover` does)", path=path)
    if path.suffix.lower() in PARQUET_SUFFIXES:
        t, theta, kind = _read_parquet(path)
    else:
        t, theta = _read_table(path)
        kind = "table"
    return _checked(t, theta, path, kind)


def _read_parquet(path: Path) -> tuple[np.ndarray, np.ndarray, str]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from pendtrack.artifacts import read_artifact, read_metadata

    meta = read_metadata(path) or {}
    kind = meta.get("artifact")
    if kind in ("angle", "kinematics"):
        df = read_artifact(path, kind).data
    else:
        try:
            df = pq.read_table(path).to_pandas()
        except (OSError, pa.ArrowException) as exc:
            raise ArtifactError(f"not a readable Parquet file ({exc})", path=path) from None
        kind = "parquet"
    for col in ("t", "theta"):
        if col not in df.columns:
            raise ArtifactError(f"missing column '{col}' (discovery needs t [s] and theta [rad])", path=path)
        if df[col].dtype.kind not in "fiu":
            raise ArtifactError(f"column '{col}' has dtype {df[col].dtype}, expected a number", path=path)
    keep = np.ones(len(df), dtype=bool)
    if "ok" in df.columns:
        if df["ok"].dtype.kind != "b":
            raise ArtifactError(f"column 'ok' has dtype {df['ok'].dtype}, expected bool", path=path)
        keep = df["ok"].to_numpy(dtype=bool)
    t = df["t"].to_numpy(dtype=float)[keep]
    theta = df["theta"].to_numpy(dtype=float)[keep]
    return t, theta, kind


def _read_table(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ArtifactError("not a text table (not UTF-8): expected columns t [s], theta [rad]", path=path) from None
    ts: list[float] = []
    thetas: list[float] = []
    first_data = True
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = line.replace(",", " ").replace(";", " ").split()
        try:
            if len(fields) < 2:
                raise ValueError
            t_val, th_val = float(fields[0]), float(fields[1])
        except ValueError:
            if first_data and not _numeric(fields[0]):
                first_data = False  # a header line
                continue
            raise ArtifactError(f"line {lineno}: expected two numbers t [s], theta [rad], got {raw.strip()[:60]!r}",
                                path=path) from None
        first_data = False
        ts.append(t_val)
        thetas.append(th_val)
    return np.asarray(ts, dtype=float), np.asarray(thetas, dtype=float)


def _numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _checked(t: np.ndarray, theta: np.ndarray, path: Path, kind: str) -> AngleSeries:
    if t.size < MIN_SAMPLES:
        raise ArtifactError(f"only {t.size} usable samples; discovery needs at least {MIN_SAMPLES}", path=path)
    bad = ~(np.isfinite(t) & np.isfinite(theta))
    if bad.any():
        raise ArtifactError(f"sample {int(np.argmax(bad))} has a non-finite t or theta", path=path)
    steps = np.diff(t)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        raise ArtifactError(f"times must increase strictly (t[{i + 1}] = {t[i + 1]:g} s after t[{i}] = {t[i]:g} s)",
                            path=path)
    return AngleSeries(t=t - 0.0, theta=theta, source=path, kind=kind, smoothed=(kind == "kinematics"))
