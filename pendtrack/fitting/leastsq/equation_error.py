"""Initial estimates from the data alone: Omega0, the oscillation's timing, every model parameter.

Nothing here ever sees a true parameter. The chain is:

1. :func:`summarize` -- model-free facts: usable samples, the oscillation's turning points
   and a model-free Omega0 (eq. straightline), both from :mod:`pendtrack.kinematics`, the
   initial state from the first usable sample. Raises :class:`~pendtrack.errors.FitError` for records that
   cannot support a fit (too few samples, no oscillation).
2. :func:`equation_error_estimates` -- the model's own parameters by an *equation-error* fit:
   the change of the measured omega over short spans against the integral of ``model.accel`` on
   the measured (theta, omega) series, which needs no simulation. Every damping coefficient of
   the catalogue enters linearly, so for each
   point of a small grid over the shape parameters (``p``, ``beta``, ``p_f``, ``t0``) the
   coefficients come from a non-negative linear least squares at the model-free Omega0; the
   best grid point is then polished by a nonlinear least squares over every parameter. This is
   the modern stand-in for the paper's "initial estimates guided by the classic model".
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from itertools import product
from typing import Any

import numpy as np
from scipy.optimize import least_squares, lsq_linear

from pendtrack.errors import FitError, PendtrackError
from pendtrack.fitting.leastsq.problem import parameter_bounds

MIN_SAMPLES = 60  # below ~0.5 s at 120 fps no model can be told from another
MIN_HALF_SWINGS = 4  # at least two full periods
MIN_AMPLITUDE = 0.02  # [rad] half peak-to-peak: 20 mrad is ~7x the paper's tracking noise

# grid of the shape parameters for the equation-error start (physically plausible ranges)
SHAPE_GRID: dict[str, tuple[float, ...]] = {
    "p": (1.0, 1.5, 2.0, 2.5, 3.0),
    "beta": (0.2, 0.5, 0.8),
    "p_f": (1.0, 1.5, 2.0, 2.5),
}
T0_OFFSETS = (0.5, 2.0, 8.0, 30.0)  # t_start - t0 for the C4/(t - t0) term [s]
INTEGRAL_LAG_PERIODS = 1.0  # span of the integrated equation of motion, in periods 2 pi/Omega0_hat
# On a gappy record (samples not ok in runs) few spans of a whole period are gap-free: the span is
# then halved, down to this share of a period (shorter spans only lose damping signal to noise: the
# estimates are start centres, which the output-error fit refines) ...
MIN_LAG_PERIODS = 1.0 / 16
# ... until at least this many gap-free spans per parameter (a least-squares fit of k parameters
# from fewer equations is undetermined, and its standard errors divide by m - k)
MIN_ROWS_PER_PARAM = 4
# exponents are kept in these ranges by the equation-error polish (noise can push them far out)
SHAPE_LIMITS = {"p": (0.2, 6.0), "p_f": (0.2, 6.0), "beta": (0.02, 1.0)}


@dataclass(frozen=True)
class DataSummary:
    """Model-free facts about a record.

    Attributes
    ----------
    omega0_hat : float
        Model-free natural angular frequency [rad/s].
    omega0_source : str
        Where it came from (``"kinematics"``: eq. straightline on the turning points).
    turning_times : ndarray
        Times where omega changes sign (turning points) [s].
    amplitude : float
        Half the peak-to-peak angle [rad].
    theta_init, omega_init : float
        Angle [rad] and angular velocity [rad/s] at the first usable sample.
    n : int
        Usable samples.
    theta_center : float
        Centre of the oscillation [rad]: the median over consecutive turning-point triples of
        ``(theta_i + 2 theta_{i+1} + theta_{i+2})/4`` (a decay linear in the swing count cancels);
        the data-derived zero of theta (the start of a fitted ``theta_off``).
    theta_center_se : float
        Its standard error [rad] (scaled MAD of the triples over sqrt of their number; NaN
        with fewer than 3 triples).
    """

    omega0_hat: float
    omega0_source: str
    turning_times: np.ndarray
    amplitude: float
    theta_init: float
    omega_init: float
    n: int
    theta_center: float = 0.0
    theta_center_se: float = math.nan

    def first_window_end(self, t_start: float, half_swings: int = 6) -> float:
        """End of the first window of the ladder: ``half_swings`` turning points after ``t_start`` [s]."""
        after = self.turning_times[self.turning_times > t_start]
        if after.size >= half_swings:
            return float(after[half_swings - 1])
        return float("inf")


def _dedupe(times: np.ndarray, min_gap: float) -> np.ndarray:
    """Indices of the crossings kept: those not closer than ``min_gap`` to the previous kept one
    (noise near a turning point)."""
    kept: list[int] = []
    for i, x in enumerate(times):
        if not kept or x - times[kept[-1]] >= min_gap:
            kept.append(i)
    return np.asarray(kept, dtype=np.int64)


def oscillation_center(turn_theta: np.ndarray) -> tuple[float, float]:
    """Centre [rad] of an oscillation from its successive turning angles, and its standard error [rad].

    Each triple of consecutive turning points (max, min, max or min, max, min) gives
    ``(theta_i + 2 theta_{i+1} + theta_{i+2})/4``: the mean of the two midpoints, in which an
    amplitude decay linear over the three (Coulomb friction exactly, any slow damping nearly)
    cancels. The median over the triples is robust to a spurious turning point; its standard
    error is ``1.4826 MAD / sqrt(m)`` (NaN for fewer than 3 triples). With fewer than 3 turning
    points: the midpoint of the extremes, NaN error.
    """
    th = np.asarray(turn_theta, dtype=float)
    th = th[np.isfinite(th)]
    if th.size < 3:
        return (0.5 * float(np.max(th) + np.min(th)) if th.size else 0.0), math.nan
    c = 0.25 * (th[:-2] + 2.0 * th[1:-1] + th[2:])
    center = float(np.median(c))
    se = 1.4826 * float(np.median(np.abs(c - center))) / math.sqrt(c.size) if c.size >= 3 else math.nan
    return center, se


def summarize(t: np.ndarray, theta: np.ndarray, omega: np.ndarray, alpha: np.ndarray, *,
              sg_moments: tuple[float, float] | None = None, source: str = "the data") -> DataSummary:
    """Model-free facts of the usable samples; FitError if they cannot support a fit.

    Turning points and Omega0 come from :mod:`pendtrack.kinematics` (eq. straightline, with
    the Savitzky-Golay bias correction when ``sg_moments`` is given).

    Parameters
    ----------
    t, theta, omega, alpha : ndarray
        Usable samples only: time [s], angle [rad], angular velocity [rad/s], angular
        acceleration [rad/s^2].
    sg_moments : (float, float), optional
        :func:`pendtrack.kinematics.analysis.savgol_bias_moments` of the filter that made the data.
    source : str
        Name of the data in error messages (e.g. the file).

    Raises
    ------
    FitError
        Fewer than :data:`MIN_SAMPLES` samples, an amplitude below :data:`MIN_AMPLITUDE`, fewer
        than :data:`MIN_HALF_SWINGS` turning points, or no restoring torque.
    """
    from pendtrack.kinematics import estimate_omega0, turning_points

    n = t.size
    if n < MIN_SAMPLES:
        raise FitError(f"too few usable samples to fit ({n}, need at least {MIN_SAMPLES})", path=source)
    amplitude = 0.5 * float(np.max(theta) - np.min(theta))
    tp = turning_points(t, theta, omega, alpha)
    if amplitude < MIN_AMPLITUDE or len(tp) < MIN_HALF_SWINGS:
        raise FitError(f"no oscillation to fit (amplitude {amplitude:.3g} rad, {len(tp)} turning points; "
                       f"need > {MIN_AMPLITUDE} rad and >= {MIN_HALF_SWINGS})", path=source)
    try:
        est = estimate_omega0(tp.theta, tp.alpha, sg_moments=sg_moments)
    except FitError as exc:
        raise FitError(f"no oscillation to fit: {exc}", path=source) from None
    w0 = float(est.omega0)
    if not (math.isfinite(w0) and w0 > 0):
        raise FitError("cannot estimate Omega0 from the turning points", path=source)
    kept = _dedupe(tp.t, 0.1 * math.pi / w0)
    turns = np.asarray(tp.t, dtype=float)[kept]
    center, center_se = oscillation_center(np.asarray(tp.theta, dtype=float)[kept])
    if turns.size < MIN_HALF_SWINGS:
        raise FitError(f"no oscillation to fit ({turns.size} distinct turning points, need at least {MIN_HALF_SWINGS})",
                       path=source)
    return DataSummary(omega0_hat=w0, omega0_source="kinematics", turning_times=turns, amplitude=amplitude,
                       theta_init=float(theta[0]), omega_init=float(omega[0]), n=n, theta_center=center,
                       theta_center_se=center_se)


@dataclass(frozen=True)
class Estimates:
    """Data-derived estimates of a model's parameters.

    Attributes
    ----------
    values : dict
        Parameter name -> estimate [its unit].
    scales : dict
        Parameter name -> naive equation-error standard error [its unit], a data-derived
        scale for the spread of the starts.
    rms : float
        Rms of the equation-error residual [rad/s].
    """

    values: Mapping[str, float]
    scales: Mapping[str, float]
    rms: float


def _coefficient_names(model: Any) -> tuple[str, ...]:
    """Parameters that enter the right-hand side linearly (damping / added-mass amplitudes)."""
    return tuple(n for n in model.param_names if n in {"C0", "C1", "C2", "C3", "C4", "C5", "Ca", "G1", "G2"})


def _shape_names(model: Any) -> tuple[str, ...]:
    return tuple(n for n in model.param_names if n in SHAPE_GRID or n == "t0")


def _accel(model: Any, params: Mapping[str, float], theta: np.ndarray, omega: np.ndarray, t: np.ndarray,
           memory_s: float, full_history: bool = False) -> np.ndarray:
    kw = {"full_history": True} if full_history else {}
    with np.errstate(all="ignore"):
        return np.asarray(model.accel(params, theta, omega, t, memory_s=memory_s, **kw), dtype=float)


def _lag_integral(v: np.ndarray, h: float, lag: int) -> np.ndarray:
    """``int_{t_i}^{t_{i+lag}} v dt`` (trapezoid) for every i [unit of v times s]."""
    c = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * h)))
    return c[lag:] - c[:-lag]


def equation_error_estimates(model: Any, t: np.ndarray, theta: np.ndarray, omega: np.ndarray,
                             *, omega0_hat: float, memory_s: float, full_history: bool = False,
                             use: np.ndarray | None = None, lag_s: float | None = None) -> Estimates:
    """Estimate every parameter of ``model`` by an integral equation-error fit.

    The residual is ``omega(t + L) - omega(t) - int_t^{t+L} model.accel(theta, omega, t) dt`` for
    every t: the equation of motion integrated over ``L = lag_s`` (default one period
    ``2 pi/Omega0_hat``). The integral form avoids the measured alpha, whose Savitzky-Golay bias
    (several % at the fast bottom passage of a swing released near the top) would otherwise bias
    the estimates badly (measured: beta 1.0 instead of 0.5 for the fractional model). A span of
    a period lets the damping accumulate above the noise of the two omega end points (with
    0.1 s the power-law exponent p scattered between 1.3 and 6.2 over noise seeds, with one
    period between 1.6 and 2.6 for a true 2.0).

    Parameters
    ----------
    model : Model
        Needs ``param_names``, ``bounds`` and ``accel(params, theta, omega, t, memory_s=)``.
    t, theta, omega : ndarray
        Uniformly sampled record (gaps filled by interpolation): time [s], angle [rad],
        angular velocity [rad/s].
    omega0_hat : float
        Model-free Omega0 [rad/s].
    memory_s : float
        Fractional-derivative memory [s].
    full_history : bool
        Grunwald-Letnikov sum over the whole record.
    use : ndarray of bool, optional
        Samples that are real data (default all); an integral enters only if all its samples are.
    lag_s : float, optional
        Integration span L [s].

    Returns
    -------
    Estimates
    """
    use = np.ones(t.size, bool) if use is None else np.asarray(use, bool)
    if getattr(model, "measurement_terms", ()):
        # the physics on the model's angle: the data's less the oscillation's centre (theta_off's
        # estimate); a scale error's k_scale starts at 0 (no correction of the angle)
        return _with_measurement(model, t, theta, omega, omega0_hat=omega0_hat, memory_s=memory_s,
                                 full_history=full_history, use=use, lag_s=lag_s)
    names = tuple(model.param_names)
    if t.size < 3 or not t[-1] > t[0]:
        raise FitError(f"record too short for the initial estimates of model '{model.name}'")
    h = float((t[-1] - t[0]) / (t.size - 1))
    period = 2.0 * math.pi / omega0_hat
    span = INTEGRAL_LAG_PERIODS * period if lag_s is None else lag_s
    lag, rows = _gap_free_spans(use, h, span, min_span=min(span, MIN_LAG_PERIODS * period),
                                min_rows=MIN_ROWS_PER_PARAM * max(len(names), 1))
    if lag is None:
        raise FitError(f"too few gap-free stretches for the initial estimates of model '{model.name}': fewer than "
                       f"{MIN_ROWS_PER_PARAM * max(len(names), 1)} spans of {MIN_LAG_PERIODS * period:.3g} s "
                       f"without a missing sample ({100 * use.mean():.0f} % of the samples usable)")
    d_omega = (omega[lag:] - omega[:-lag])[rows]

    def integ(a: np.ndarray) -> np.ndarray:
        return _lag_integral(a, h, lag)[rows]

    coef_names = _coefficient_names(model)
    shape_names = _shape_names(model)
    t_first = float(t[0])

    def shape_values(name: str) -> tuple[float, ...]:
        if name == "t0":
            return tuple(t_first - d for d in T0_OFFSETS)
        return SHAPE_GRID[name]

    base: dict[str, float] = {n: 0.0 for n in names}
    base["Omega0"] = omega0_hat
    best: tuple[float, dict[str, float]] | None = None
    for combo in product(*(shape_values(n) for n in shape_names)):
        p = dict(base) | dict(zip(shape_names, combo))
        try:
            a0 = _accel(model, p, theta, omega, t, memory_s, full_history)
            cols = [integ(_accel(model, p | {c: 1.0}, theta, omega, t, memory_s, full_history) - a0)
                    for c in coef_names]
        except PendtrackError:
            continue
        y = d_omega - integ(a0)
        if not np.all(np.isfinite(y)) or not all(np.all(np.isfinite(c)) for c in cols):
            continue
        if cols:
            a = np.column_stack(cols)
            lo = np.array([model.bounds[c][0] for c in coef_names])
            # a grid point where a term's column is ~0 makes scipy's bounded trf warn on a 0/0 it then discards
            with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
                sol = lsq_linear(a, y, bounds=(lo, np.full(len(coef_names), np.inf)))
            coef = sol.x
            resid = y - a @ coef
        else:
            coef = np.zeros(0)
            resid = y
        rss = float(resid @ resid)
        if best is None or rss < best[0]:
            best = (rss, p | dict(zip(coef_names, (float(v) for v in coef))))
    if best is None:
        raise FitError(f"no initial estimate of model '{model.name}' could be evaluated on the data")

    def resid_fn(x: np.ndarray) -> np.ndarray:
        try:
            a = _accel(model, dict(zip(names, x)), theta, omega, t, memory_s, full_history)
        except PendtrackError:
            return np.full(d_omega.size, 1e3)
        r = d_omega - integ(a)
        return np.where(np.isfinite(r), r, 1e3)

    lo, hi = parameter_bounds(model, t_first)
    for j, name in enumerate(names):
        if name in SHAPE_LIMITS:
            lo[j] = max(lo[j], SHAPE_LIMITS[name][0])
            hi[j] = min(hi[j], SHAPE_LIMITS[name][1])
    return _polish(names, best[1], resid_fn, (lo, hi))


def _with_measurement(model: Any, t: np.ndarray, theta: np.ndarray, omega: np.ndarray, *, omega0_hat: float,
                      memory_s: float, full_history: bool, use: np.ndarray, lag_s: float | None) -> Estimates:
    """:func:`equation_error_estimates` of a model with measurement terms (its physics on theta - theta_off)."""
    from pendtrack.kinematics import turning_points

    ok = use & np.isfinite(theta) & np.isfinite(omega)
    tp = turning_points(t, theta, omega, ok=ok)
    kept = _dedupe(np.asarray(tp.t, dtype=float), 0.1 * math.pi / omega0_hat) if len(tp) else np.zeros(0, np.int64)
    center, center_se = oscillation_center(np.asarray(tp.theta, dtype=float)[kept])
    values: dict[str, float] = {}
    scales: dict[str, float] = {}
    if "theta_off" in model.param_names:
        values["theta_off"], scales["theta_off"] = center, center_se
    else:
        center = 0.0
    if "k_scale" in model.param_names:
        values["k_scale"], scales["k_scale"] = 0.0, math.nan
    est = equation_error_estimates(model.physics(), t, theta - center, omega, omega0_hat=omega0_hat,
                                   memory_s=memory_s, full_history=full_history, use=use, lag_s=lag_s)
    return Estimates(values={**est.values, **values}, scales={**est.scales, **scales}, rms=est.rms)


def _gap_free_spans(use: np.ndarray, h: float, span: float, *, min_span: float,
                    min_rows: int) -> tuple[int | None, np.ndarray]:
    """The longest lag (from ``span`` [s], halved down to ``min_span`` [s]) with ``min_rows`` gap-free spans.

    Returns the lag [samples] and the mask of the spans ``[i, i + lag]`` whose samples are all
    real, or ``(None, empty)`` if even ``min_span`` leaves fewer than ``min_rows``.
    """
    bad = np.concatenate(([0], np.cumsum(~use)))
    while True:
        lag = max(1, int(round(span / h)))
        if use.size > lag + 1:
            rows = (bad[lag + 1:] - bad[:-lag - 1]) == 0  # every sample of [i, i + lag] is real
            if int(rows.sum()) >= min_rows:
                return lag, rows
        if span <= min_span or lag == 1:
            return None, np.zeros(0, bool)
        span = max(0.5 * span, min_span)


def _polish(names: tuple[str, ...], start: Mapping[str, float], resid: Any,
            bounds: tuple[np.ndarray, np.ndarray]) -> Estimates:
    """Nonlinear equation-error least squares over every parameter from ``start``.

    Every division is guarded: no residual (no gap-free span) or no more residuals than
    parameters give NaN scales and rms, never a ZeroDivisionError (the caller checks the spans).
    """
    lo, hi = bounds
    x0 = np.clip(np.array([start[n] for n in names]), lo, hi)
    r0 = resid(x0)
    m, k = r0.size, x0.size
    if m == 0:
        return Estimates(values=dict(zip(names, (float(v) for v in x0))), scales=dict.fromkeys(names, math.nan),
                         rms=math.nan)
    res = least_squares(resid, x0, bounds=(lo, hi), method="trf", x_scale="jac", max_nfev=200 * len(names))
    x = res.x if res.cost <= 0.5 * float(r0 @ r0) else x0
    r = resid(x)
    scale = np.full(k, np.nan)
    if m > k:
        s2 = float(r @ r) / (m - k)
        try:
            cov = s2 * np.linalg.pinv(res.jac.T @ res.jac)
            scale = np.sqrt(np.abs(np.diag(cov)))
        except (np.linalg.LinAlgError, ValueError):
            pass
    return Estimates(values=dict(zip(names, (float(v) for v in x))),
                     scales=dict(zip(names, (float(v) for v in scale))), rms=math.sqrt(float(r @ r) / m))
