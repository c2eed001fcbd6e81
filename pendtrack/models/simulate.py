"""One entry point to simulate any model: :func:`simulate` (checked) and :func:`simulate_packed` (raw).

Methods
-------
``"fast"``  numba kernels (:mod:`pendtrack.models.kernels`). Models without memory: RK4
            with ``substeps`` sub-steps per output step and sgn(omega) events (agrees
            with the reference to ~5e-8 rad over 60 s at 120 fps). Models with memory: the
            paper's predictor-corrector at the data step h, or -- where h exceeds
            ``max_step_s`` (``[models]``, the paper's 1/120 s) -- at ``h/k`` with
            ``k = ceil(h/max_step_s)`` internal sub-steps (:func:`pc_substeps`), outputs at the
            samples; GL memory ``N = round(memory_s/(h/k))`` internal steps (the memory is a
            duration), or the full history. The scheme is second order: at 30 fps (h = 1/30 s,
            Omega0 h ~ 0.17) without sub-steps its phase error shortened the period by ~6e-3
            (measured, Omega0 = 5 rad/s), 8.6e-4 at 60 fps, 1.6e-4 at 120 fps.
``"reference"`` scipy DOP853 at rtol 1e-12 with sgn(omega) events; models without memory only.
``"auto"``  ``"fast"``.

Time grids: uniform ``t`` (spacing equal to within 1e-6 relative) is the fast case, the
kernels run on it directly. For a non-uniform ``t`` the fast path integrates on a
uniform grid from ``t[0]`` -- with the mean spacing for models with memory (so
``memory_s`` and the GL discretisation keep their meaning), a 4x finer one otherwise --
and interpolates to ``t``: theta and omega by cubic Hermite (with omega and alpha as
derivatives), alpha linearly. Near a turning point alpha jumps by the Coulomb terms, so
the interpolated omega there is only good to ~C0 h. The reference method samples its dense output at ``t``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pendtrack.config import ModelsConfig
from pendtrack.errors import ModelError
from pendtrack.models import kernels
from pendtrack.models.registry import Model, get_model
from pendtrack.models.terms import K_HAS_MEMORY, K_LIN, K_SIN
from pendtrack.models.timegrid import UNIFORM_RTOL, check_time, is_uniform, memory_steps_for

__all__ = ["SimResult", "simulate", "simulate_packed", "simulate_sensitivities", "default_substeps", "pc_substeps", "check_time", "is_uniform",
           "memory_steps_for", "UNIFORM_RTOL"]

_EMPTY = np.zeros(0)
NONUNIFORM_REFINE = 4  # memory-free models on a non-uniform t: grid step = mean spacing / this
SUBSTEP_PHASE = 0.015  # RK4 sub-step: Omega0 h_sub <= this [rad]; 3 sub-steps at 120 fps (measured <= 5e-8 rad
#                        against the reference over 60 s, 2e-7 near the separatrix)


@dataclass(frozen=True)
class SimResult:
    """A simulated trajectory sampled at the requested times.

    Attributes
    ----------
    t : numpy.ndarray
        Times [s] (the ones requested).
    theta, omega, alpha : numpy.ndarray
        Angle [rad], angular velocity [rad/s] and acceleration [rad/s^2] at ``t``.
    model : str
        Model name.
    params : dict
        Parameters used (validated floats).
    theta0, omega0 : float
        Initial state at ``t[0]`` [rad], [rad/s].
    method : str
        ``"fast-rk4"``, ``"fast-pc"`` or ``"reference"``.
    step : float
        Integration output step [s] (fast methods; 0 for reference).
    substeps : int
        Sub-steps per output step: RK4 (fast-rk4) or predictor-corrector (fast-pc).
    memory_steps : int or None
        GL memory length N in (internal) steps, -1 for the full history, None without memory.
    """

    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    model: str
    params: Mapping[str, float] = field(default_factory=dict)
    theta0: float = 0.0
    omega0: float = 0.0
    method: str = ""
    step: float = 0.0
    substeps: int = 1
    memory_steps: int | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"t": self.t.tolist(), "theta": self.theta.tolist(), "omega": self.omega.tolist(),
                "alpha": self.alpha.tolist(), "model": self.model, "params": dict(self.params),
                "theta0": self.theta0, "omega0": self.omega0, "method": self.method, "step": self.step,
                "substeps": self.substeps, "memory_steps": self.memory_steps}


def default_substeps(coeffs: np.ndarray, h: float, phase: float = SUBSTEP_PHASE) -> int:
    """RK4 sub-steps per output step so that ``Omega * h_sub <= phase`` [rad] (default :data:`SUBSTEP_PHASE`)."""
    w = math.sqrt(max(coeffs[K_SIN], 0.0) + max(coeffs[K_LIN], 0.0))
    return max(1, int(math.ceil(w * h / phase)))


def pc_substeps(h: float, max_step_s: float | None = None) -> int:
    """Predictor-corrector sub-steps per output step: the fewest ``k`` with ``h/k <= max_step_s``.

    ``max_step_s=None`` takes :attr:`ModelsConfig.max_step_s` (the paper's 1/120 s). A step
    within 1e-6 (relative) of the maximum counts as equal to it (120 fps: no sub-step).
    """
    m = ModelsConfig().max_step_s if max_step_s is None else float(max_step_s)
    if not (math.isfinite(m) and m > 0):
        raise ModelError(f"max_step_s must be a positive duration in seconds, got {max_step_s!r}")
    return max(1, int(math.ceil(h / m - UNIFORM_RTOL)))


def simulate_packed(coeffs: np.ndarray, n_steps: int, h: float, theta0: float, omega0: float, memory_steps: int,
                    out_theta: np.ndarray, out_omega: np.ndarray, out_alpha: np.ndarray, *, t_start: float = 0.0,
                    substeps: int = 0, forcing: np.ndarray | None = None, python: bool = False) -> None:
    """Low-level simulation into preallocated arrays (the fitting hot path).

    Only the array lengths and ``memory_steps`` are checked (numba does not bounds-check);
    the coefficients are trusted (make them with :meth:`Model.pack`).

    Parameters
    ----------
    coeffs : numpy.ndarray
        float64 packed model from :meth:`Model.pack` (must be C-contiguous float64).
    n_steps : int
        Number of steps; samples ``0 .. n_steps`` at ``t_start + i h`` are written.
    h : float
        Step [s].
    theta0, omega0 : float
        Initial state [rad], [rad/s].
    memory_steps : int
        GL memory N in (internal) steps (>= 1) or -1 for the full history; ignored without memory.
    out_theta, out_omega, out_alpha : numpy.ndarray
        float64 arrays of length >= n_steps + 1, overwritten [rad], [rad/s], [rad/s^2]; for a model
        without memory ``out_alpha`` may be empty (the acceleration is then not computed).
    t_start : float
        Time of sample 0 [s] (matters for the C4/(t - t0) term).
    substeps : int
        RK4 sub-steps for models without memory; 0 chooses :func:`default_substeps`. For models
        with memory, predictor-corrector sub-steps (:func:`pc_substeps`); 0 or 1: none (the
        step h). With ``k > 1`` sub-steps the kernel runs ``k n_steps`` steps of ``h/k`` and every
        k-th sample is written; ``memory_steps`` then counts those internal steps, and a
        ``forcing`` is interpolated linearly between the samples.
    forcing : numpy.ndarray, optional
        External acceleration at the samples [rad/s^2], length n_steps + 1.
    python : bool
        Run the pure-Python twin instead of the numba kernel (slow; for tests).

    Notes
    -----
    Models with the memory term (``coeffs[K_HAS_MEMORY] == 1``) use the paper's
    predictor-corrector at step h (or h/substeps); the others RK4 with sgn events.
    """
    # cheap guards: numba does not bounds-check, a short array would be written past its end
    no_alpha = out_alpha.shape[0] == 0 and coeffs[K_HAS_MEMORY] == 0.0
    if min(out_theta.shape[0], out_omega.shape[0], n_steps + 1 if no_alpha else out_alpha.shape[0]) < n_steps + 1:
        raise ModelError(f"output arrays must hold n_steps + 1 = {n_steps + 1} samples")
    f = _EMPTY if forcing is None else forcing
    if 0 < f.shape[0] < n_steps + 1:
        raise ModelError(f"forcing must hold n_steps + 1 = {n_steps + 1} samples, got {f.shape[0]}")
    if coeffs[K_HAS_MEMORY] != 0.0:
        if memory_steps == 0 or memory_steps < -1:
            raise ModelError(f"memory_steps must be >= 1 or -1 (full history), got {memory_steps}")
        kern = kernels.pc_kernel_py if python else kernels.pc_kernel_nb()
        k = max(int(substeps), 1)
        if k == 1:
            kern(coeffs, n_steps, h, t_start, theta0, omega0, memory_steps, f, out_theta, out_omega, out_alpha)
            return
        n_fine = n_steps * k
        fine = np.empty((3, n_fine + 1))
        if f.shape[0]:
            f = np.interp(np.arange(n_fine + 1) / k, np.arange(n_steps + 1), f[:n_steps + 1])
        kern(coeffs, n_fine, h / k, t_start, theta0, omega0, memory_steps, f, fine[0], fine[1], fine[2])
        out_theta[:n_steps + 1] = fine[0, ::k]
        out_omega[:n_steps + 1] = fine[1, ::k]
        out_alpha[:n_steps + 1] = fine[2, ::k]
    else:
        k = substeps if substeps > 0 else default_substeps(coeffs, h)
        kern = kernels.rk_kernel_py if python else kernels.rk_kernel_nb()
        kern(coeffs, n_steps, h, t_start, theta0, omega0, k, f, out_theta, out_omega, out_alpha)


def simulate_sensitivities(coeffs: np.ndarray, dcoeffs: np.ndarray, n_steps: int, h: float, theta0: float,
                           omega0: float, dtheta0: np.ndarray, domega0: np.ndarray, *, t_start: float = 0.0,
                           substeps: int = 0, python: bool = False
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A memory-free simulation and its forward sensitivities (:func:`kernels.rk_sens_kernel_py`).

    Parameters
    ----------
    coeffs : numpy.ndarray
        float64 packed model without the memory term (:meth:`Model.pack`).
    dcoeffs : numpy.ndarray
        ``(N_COEFFS, P)``: ``d coeffs / d p_j`` for the P parameters differentiated by
        (:meth:`pendtrack.models.declare.Layout.pack_jacobian`; zero columns for the initial state).
    n_steps, h, theta0, omega0, t_start, substeps
        As :func:`simulate_packed` (``substeps=0``: :func:`default_substeps`).
    dtheta0, domega0 : numpy.ndarray
        ``(P,)``: derivatives of the initial angle [rad] and angular velocity [rad/s] by each parameter.
    python : bool
        Run the pure-Python twin (slow; for tests).

    Returns
    -------
    theta, omega : numpy.ndarray
        ``(n_steps + 1,)`` [rad], [rad/s], identical to :func:`simulate_packed`'s.
    dtheta, domega : numpy.ndarray
        ``(n_steps + 1, P)``: d theta/d p_j [rad/unit of p_j], d omega/d p_j [rad/s/unit of p_j].
    """
    if coeffs[K_HAS_MEMORY] != 0.0:
        raise ModelError("sensitivities are computed for models without memory only")
    dcoeffs = np.asarray(dcoeffs, dtype=np.float64)
    d_th0 = np.asarray(dtheta0, dtype=np.float64)
    d_om0 = np.asarray(domega0, dtype=np.float64)
    # a parameter that moves neither a coefficient nor the initial state (a measurement term's)
    # has sensitivities 0 all along: not integrated
    live = np.flatnonzero(np.any(dcoeffs != 0.0, axis=0) | (d_th0 != 0.0) | (d_om0 != 0.0))
    used = np.flatnonzero(np.any(dcoeffs != 0.0, axis=1)).astype(np.int64)
    dc = np.ascontiguousarray(dcoeffs[np.ix_(used, live)])
    n_p = dcoeffs.shape[1]
    k = substeps if substeps > 0 else default_substeps(coeffs, h)
    th = np.empty(n_steps + 1)
    om = np.empty(n_steps + 1)
    dth_live = np.empty((n_steps + 1, live.size))
    dom_live = np.empty((n_steps + 1, live.size))
    kern = kernels.rk_sens_kernel_py if python else kernels.rk_sens_kernel_nb()
    with np.errstate(all="ignore"):  # the Python twin on numpy scalars: absent terms' 0/0 are never used
        kern(np.ascontiguousarray(coeffs, dtype=np.float64), used, dc, n_steps, h, t_start, float(theta0),
             float(omega0), k, _EMPTY, d_th0[live].copy(), d_om0[live].copy(), th, om, _EMPTY, dth_live, dom_live)
    if live.size == n_p:
        return th, om, dth_live, dom_live
    dth = np.zeros((n_steps + 1, n_p))
    dom = np.zeros((n_steps + 1, n_p))
    dth[:, live] = dth_live
    dom[:, live] = dom_live
    return th, om, dth, dom


def simulate(model: Model | str, params: Mapping[str, float], t: Any, *, theta0: float, omega0: float,
             memory_s: float | None = None, full_history: bool = False, method: str = "auto",
             substeps: int | None = None, max_step_s: float | None = None) -> SimResult:
    """Simulate ``model`` with ``params`` from ``(theta0, omega0)`` at ``t[0]``, sampled at ``t``.

    Parameters
    ----------
    model : Model or str
        A model or a registry name.
    params : mapping
        Parameter values by the paper's names (``model.param_names``).
    t : array_like
        Strictly increasing times [s]; uniform spacing is the fast case.
    theta0, omega0 : float
        Initial angle [rad] and angular velocity [rad/s] at ``t[0]``.
    memory_s : float, optional
        GL memory as a duration [s] (default :attr:`ModelsConfig.memory_s` = 100/120 s);
        ``N = round(memory_s / h)`` steps, so the physics does not depend on the frame rate.
    full_history : bool
        The GL sum runs over the whole record (constant unknown past before ``t[0]``).
    method : {"auto", "fast", "reference"}
    substeps : int, optional
        RK4 sub-steps per step (models without memory); default from :func:`default_substeps`.
        For models with memory: predictor-corrector sub-steps; default :func:`pc_substeps`.
    max_step_s : float, optional
        Largest predictor-corrector step [s] (models with memory); default
        :attr:`ModelsConfig.max_step_s` (the paper's 1/120 s).

    Returns
    -------
    SimResult

    Raises
    ------
    ModelError
        Unknown model, bad parameters, bad time axis, t0 >= t[0], bad memory, or the
        reference method asked for a model with memory.
    """
    m = get_model(model) if isinstance(model, str) else model
    if not isinstance(m, Model):
        raise ModelError(f"model must be a Model or a model name, got {type(model).__name__}")
    tt = check_time(t)
    p = m.validate(params)
    coeffs = m.pack(p)
    try:
        th0 = float(theta0)
        om0 = float(omega0)
    except (TypeError, ValueError):
        raise ModelError(f"theta0 and omega0 must be numbers, got {theta0!r}, {omega0!r}") from None
    if not (math.isfinite(th0) and math.isfinite(om0)):
        raise ModelError(f"initial state must be finite, got theta0={th0!r}, omega0={om0!r}")
    m.check_domain(p, float(tt[0]))
    if method not in ("auto", "fast", "reference"):
        raise ModelError(f"unknown method '{method}' (use auto, fast or reference)")
    if substeps is not None and (not isinstance(substeps, (int, np.integer)) or substeps < 1):
        raise ModelError(f"substeps must be a positive integer, got {substeps!r}")
    n = tt.size
    h_mean = (tt[-1] - tt[0]) / (n - 1)
    k_pc = (substeps or pc_substeps(h_mean, max_step_s)) if m.has_memory else 1
    mem_steps = memory_steps_for(memory_s, h_mean / k_pc, full_history=full_history) if m.has_memory else None
    if memory_s is not None and not m.has_memory:
        memory_steps_for(memory_s, h_mean)  # still reject nonsense

    if method == "reference":
        if m.has_memory:
            raise ModelError(f"model '{m.name}' has memory: no reference integrator, use method='fast'")
        from pendtrack.models.reference import integrate_reference

        th, om, al = integrate_reference(coeffs, tt, th0, om0)
        return SimResult(*_frozen(tt, th, om, al), model=m.name, params=p, theta0=th0, omega0=om0,
                         method="reference", step=0.0, substeps=1, memory_steps=mem_steps)

    uniform = is_uniform(tt)
    # non-uniform t: memory models keep the mean step (the GL discretisation is physics),
    # memory-free ones use a 4x finer grid so that interpolation is not the error
    h = h_mean if (uniform or m.has_memory) else h_mean / NONUNIFORM_REFINE
    k = k_pc if m.has_memory else (substeps or default_substeps(coeffs, h))
    n_steps = n - 1 if uniform else int(math.ceil((tt[-1] - tt[0]) / h - 1e-9))
    th = np.empty(n_steps + 1)
    om = np.empty(n_steps + 1)
    al = np.empty(n_steps + 1)
    simulate_packed(coeffs, n_steps, h, th0, om0, -1 if mem_steps is None else mem_steps, th, om, al,
                    t_start=float(tt[0]), substeps=k)
    if not uniform:
        th, om, al = _resample(tt[0] + h * np.arange(n_steps + 1), th, om, al, tt)
    return SimResult(*_frozen(tt, th, om, al), model=m.name, params=p, theta0=th0, omega0=om0,
                     method="fast-pc" if m.has_memory else "fast-rk4", step=float(h),
                     substeps=k, memory_steps=mem_steps)


def _resample(grid: np.ndarray, th: np.ndarray, om: np.ndarray, al: np.ndarray,
              t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from scipy.interpolate import CubicHermiteSpline

    x = np.clip(t, grid[0], grid[-1])
    return (CubicHermiteSpline(grid, th, om)(x), CubicHermiteSpline(grid, om, al)(x), np.interp(x, grid, al))


def _frozen(t: np.ndarray, *owned: np.ndarray) -> tuple[np.ndarray, ...]:
    """Read-only float64 arrays: a copy of ``t`` (the caller's array stays writable), the
    ``owned`` arrays (made here, no other reference) as they are."""
    out = [np.array(t, dtype=np.float64)]
    out.extend(np.asarray(a, dtype=np.float64) for a in owned)
    for a in out:
        a.setflags(write=False)
    return tuple(out)
