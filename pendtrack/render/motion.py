"""The pendulum's motion sampled for filming: frame times and motion-blur sub-samples.

Time convention: frame ``k`` is exposed over ``[t_k - e/2, t_k + e/2]`` with
``t_k = k / fps`` (so ``t = 0`` is the first frame's mid-exposure) and ``e`` the exposure;
the initial conditions ``(theta0, omega0)`` hold at ``t = 0``. The few sub-samples of the
first frame before ``t = 0`` use ``theta0 + omega0 t`` (the pendulum is released or
launched at ``t = 0``; this differs from the model by ``O(alpha e^2)``, well under 1e-4 rad).

A hand may hold the bob until ``release_s > 0``: before it, ``theta = theta0`` and
``omega = 0`` (the truth says so), and the motion is the model's from ``(theta0, omega0)``
at ``t = release_s`` (released, or launched by the hand when ``omega0 != 0``);
:attr:`Motion.hand` is the share of each frame's exposure during which the hand holds.

The dynamics come from a callable ``simulate(t) -> (theta, omega)`` evaluated at
ascending times ``t`` starting at 0 (see :func:`pendtrack.render.physics.model_simulator`),
so this module knows nothing of the models.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

Simulator = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]

MAX_SUBSAMPLES = 64  # upper bound of sub-samples per exposure
SPEED_MARGIN = 1.25  # the frame's mid-exposure speed times this bounds its speed during the exposure


@dataclass(frozen=True)
class Motion:
    """Truth at the frame times and the angles to render for each frame.

    Attributes
    ----------
    t : ndarray, shape (n_frames,)
        Frame (mid-exposure) times [s], ``k / fps``.
    theta, omega : ndarray, shape (n_frames,)
        True angle [rad] and angular velocity [rad/s] at ``t``.
    sub_theta : ndarray
        Sub-sample angles [rad], frame after frame.
    sub_start : ndarray, shape (n_frames + 1,), int64
        Frame ``k`` renders ``sub_theta[sub_start[k]:sub_start[k + 1]]``.
    hand : ndarray, shape (n_frames,), optional
        Share of each frame's exposure during which a hand holds the bob, in [0, 1]
        (None: no hand).
    release_s : float
        When the hand lets go [s]; 0 without a hand.
    """

    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    sub_theta: np.ndarray
    sub_start: np.ndarray
    hand: np.ndarray | None = None
    release_s: float = 0.0

    @property
    def n_frames(self) -> int:
        return int(self.t.size)

    def frame_thetas(self, k: int) -> np.ndarray:
        """Sub-sample angles [rad] of frame ``k`` (evenly spread over its exposure)."""
        return self.sub_theta[self.sub_start[k]:self.sub_start[k + 1]]

    def frame_hand(self, k: int) -> float:
        """Share of frame ``k``'s exposure during which the hand holds the bob (0: no hand)."""
        return 0.0 if self.hand is None else float(self.hand[k])


def subsample_counts(omega: np.ndarray, *, exposure_s: float, px_per_rad: float, step_px: float,
                     max_subsamples: int = MAX_SUBSAMPLES) -> np.ndarray:
    """Sub-samples per frame so that the spot moves at most ``step_px`` between two.

    Parameters
    ----------
    omega : ndarray
        Angular velocity at each frame's mid-exposure [rad/s].
    exposure_s : float
        Exposure [s]; 0 gives one sample (no blur).
    px_per_rad : float
        Upper bound of the spot's image speed per angular speed [px/rad].
    step_px : float
        Largest spot travel between sub-samples [px].
    """
    if exposure_s <= 0:
        return np.ones(np.shape(omega), dtype=np.int64)
    travel = SPEED_MARGIN * np.abs(omega) * exposure_s * px_per_rad
    return np.clip(np.ceil(travel / step_px), 1, max_subsamples).astype(np.int64)


def sample_motion(simulate: Simulator, *, n_frames: int, fps: float, exposure_s: float, theta0: float,
                  omega0: float, px_per_rad: float, step_px: float, release_s: float = 0.0) -> Motion:
    """Evaluate the motion at the frame times and at the exposure sub-samples.

    Parameters
    ----------
    simulate : callable
        ``simulate(t) -> (theta, omega)`` for ascending ``t`` [s] with ``t[0] == 0``.
    n_frames : int
        Number of frames, >= 1.
    fps : float
        Frame rate [1/s].
    exposure_s : float
        Shutter open time [s], ``0 <= exposure_s <= 1 / fps``.
    theta0, omega0 : float
        Initial angle [rad] and angular velocity [rad/s] at ``t = 0``.
    px_per_rad, step_px : float
        See :func:`subsample_counts`.
    release_s : float
        A hand holds the bob at ``theta0`` until this time [s]; 0: no hand (the motion
        starts at ``t = 0``).
    """
    t = np.arange(n_frames, dtype=float) / fps
    tau = t - release_s if release_s > 0 else t  # time since the motion started [s]
    moving = tau >= 0
    if moving.all():
        _, omega_est = simulate(tau)
    else:  # held frames count as moving at omega0 (one may straddle the release)
        omega_est = np.full(n_frames, float(omega0))
        if moving.any():
            after = tau[moving & (tau > 0)]
            omega_est[n_frames - after.size:] = np.asarray(simulate(np.concatenate(([0.0], after)))[1])[1:]
    counts = subsample_counts(omega_est, exposure_s=exposure_s, px_per_rad=px_per_rad, step_px=step_px)
    start = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)
    frame_of = np.repeat(np.arange(n_frames), counts)
    j = np.arange(start[-1]) - start[frame_of]
    sub_tau = tau[frame_of] + exposure_s * ((j + 0.5) / counts[frame_of] - 0.5)

    grid = np.unique(np.concatenate(([0.0], tau[moving], sub_tau[sub_tau > 0])))  # ascending, grid[0] == 0
    theta_g, omega_g = simulate(grid)
    theta_g = np.asarray(theta_g, dtype=float)
    omega_g = np.asarray(omega_g, dtype=float)
    before = theta0 if release_s > 0 else theta0 + omega0 * sub_tau  # held, or extrapolated back from t = 0
    sub_theta = np.where(sub_tau > 0, theta_g[np.searchsorted(grid, np.maximum(sub_tau, 0.0))], before)
    at_frames = np.searchsorted(grid, np.maximum(tau, 0.0))
    theta = np.where(moving, theta_g[at_frames], theta0)
    omega = np.where(moving, omega_g[at_frames], 0.0)
    hand = None
    if release_s > 0:
        hand = np.bincount(frame_of, weights=(sub_tau < 0).astype(float), minlength=n_frames) / counts
    return Motion(t=t, theta=theta, omega=omega, sub_theta=sub_theta, sub_start=start, hand=hand,
                  release_s=float(release_s))


def run_code(*, tile_length_m: float, omega0: float, alley: bool, trial: int) -> str | None:
    """The paper's run code, e.g. ``"06na1"``, or None when one cannot be formed.

    Two digits of tile length in cm (``00`` = no tile), ``l``/``n`` launched
    (``omega0 != 0``) or not, ``a``/``n`` with or without alley, the trial number (>= 1).
    """
    cm = tile_length_m * 100
    if not (0 <= cm < 99.5 and abs(cm - round(cm)) < 1e-6 and trial >= 1):
        return None
    return f"{round(cm):02d}{'l' if omega0 != 0 else 'n'}{'a' if alley else 'n'}{trial}"
