"""A rendered series of runs of one rig, named by run codes (for the joint-fit tests and benchmark).

One physical pendulum (the paper's bar) filmed run after run, as the paper's series is: each run
has a tile at the bar's end (``03``, ``06``, ``09`` cm: Omega0 from the two-cuboid formula of
the renderer), is run with or without the alley's slabs, and is released from rest near the top
or launched from near the bottom. The classic model drives every run:

* ``C0``, the axle's Coulomb friction, is the rig's: the same in every run;
* the drag (``C3``, ``p``) and the added mass ``Ca`` depend on the tile (a longer tile moves more
  air) and the alley (the slabs near the bottom of the swing add drag and entrained air).

These are the defaults of a joint fit of run-coded records (``Omega0`` per tile, ``C0`` shared,
drag and added mass per tile and alley, the initial state per run), so the fit is told nothing
but the run codes. Videos are 640x360 so that a series renders in minutes on 2 cores.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from pendtrack.config import Config
from pendtrack.stages.render import render_stage

C0_RIG = 0.012  # the axle's Coulomb friction [rad/s^2], every run
RELEASE_THETA0 = 2.7  # released from rest near the top [rad]
LAUNCH = (0.3, 8.5)  # launched: theta0 [rad], omega0 [rad/s] (amplitude about 2.0 rad)


@dataclass(frozen=True)
class SeriesRun:
    """One run of the series: its run code, how it starts and the classic model's true values."""

    code: str
    tile_cm: int
    alley: bool
    launched: bool
    truth: dict[str, float]

    @property
    def theta0(self) -> float:
        return LAUNCH[0] if self.launched else RELEASE_THETA0

    @property
    def omega0(self) -> float:
        return LAUNCH[1] if self.launched else 0.0


def group_truth(tile_cm: int, alley: bool) -> dict[str, float]:
    """The drag and added mass of a tile and alley [C3 in rad/s^2, p and Ca in 1], and the shared C0."""
    return {"C0": C0_RIG,
            "C3": 0.014 + 0.001 * tile_cm + (0.006 if alley else 0.0),
            "p": 1.6 if alley else 1.4,
            "Ca": 0.004 + 0.001 * tile_cm + (0.004 if alley else 0.0)}


def plan_series(n_runs: int) -> list[SeriesRun]:
    """``n_runs`` (a multiple of 4, at most 12) runs: tiles 3, 6, 9 cm in turn, each with and without
    the alley, each of those released and launched."""
    if n_runs % 4 or not 4 <= n_runs <= 12:
        raise ValueError(f"a series has 4, 8 or 12 runs, not {n_runs}")
    runs = []
    for tile in (3, 6, 9)[: n_runs // 4]:
        for alley in (False, True):
            for launched in (False, True):
                code = f"{tile:02d}{'l' if launched else 'n'}{'a' if alley else 'n'}1"
                runs.append(SeriesRun(code, tile, alley, launched, group_truth(tile, alley)))
    return runs


def render_series(folder: str | Path, n_runs: int, *, seconds: float = 20.0, fps: float = 120.0,
                  size: tuple[int, int] = (640, 360)) -> list[SeriesRun]:
    """Render :func:`plan_series` into ``folder`` as ``<code>.mp4`` + ``<code>.truth.parquet``.

    Each run has its own seed (texture and sensor noise). Omega0 is the renderer's two-cuboid value
    for the tile, read back from each truth file's provenance by the caller if needed.
    """
    folder = Path(folder)
    runs = plan_series(n_runs)
    for i, run in enumerate(runs):
        params = tuple(f"{k}={v!r}" for k, v in run.truth.items())
        cfg = Config().replace("render", model="classic", params=params, seconds=seconds, fps=fps,
                               width=size[0], height=size[1], theta0=run.theta0, omega0=run.omega0,
                               tile_length_m=run.tile_cm / 100.0, alley=run.alley, trial=1, seed=100 + i)
        render_stage(out_dir=folder, config=cfg, progress=False, name_by_run_code=True)
    return runs
