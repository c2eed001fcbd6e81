"""One output-error fitting problem: data on a window, a model, and the residual function.

The fitted vector is the model's parameters (in ``model.param_names`` order) followed by the
initial state ``theta0`` [rad] and ``omega0`` [rad/s] at the start of the fit window. The
model is simulated on a uniform grid starting at the window's first sample, mapped through its
measurement terms (e.g. ``theta_obs = theta + theta_off``), observed the way the data were
(:class:`~pendtrack.fitting.leastsq.cost.Observation`) and compared at the data samples.

A :class:`FitProblem` holds only plain arrays, scalars and the model object, so it pickles
cheaply into worker processes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np

from pendtrack.errors import PendtrackError
from pendtrack.fitting.leastsq.coordinates import Coordinates
from pendtrack.fitting.leastsq.cost import Observation, residual_vector

STATE_NAMES = ("theta0", "omega0")
PENALTY = 10.0  # residual value returned where the simulation fails (cost >> any real Xi^2)
FD_REL = 1e-5  # relative finite-difference step (see FitProblem.fd_steps)
JACOBIANS = ("sensitivity", "fd")  # FitProblem.jacobian's methods ([fit] jacobian)

Simulator = Callable[..., Any]


class SimState(NamedTuple):
    """A simulated trajectory before it is observed (:meth:`FitProblem.simulate_state`)."""

    theta: np.ndarray  #: the model's angle on the grid [rad]
    omega: np.ndarray  #: its angular velocity [rad/s]
    params: dict  #: the model's parameters it was simulated with (validated), measurement parameters included


def _simulate_packed(model: Any, params: Mapping[str, float], n: int, h: float, t_start: float, theta0: float,
                     omega0: float, memory_s: float, full_history: bool,
                     max_step_s: float | None = None, substep_phase: float = 0.0,
                     validated: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The models package's unchecked hot path (no SimResult, no time-axis checks).

    ``validated``: ``params`` is already ``model.validate``'s output.

    A model with memory runs the predictor-corrector with ``pc_substeps(h, max_step_s)``
    internal sub-steps (none at 120 fps) and its memory as the duration ``memory_s``; the
    others RK4 with sub-steps of ``Omega h_sub <= substep_phase`` [rad] (0: the simulation's own,
    :data:`pendtrack.models.simulate.SUBSTEP_PHASE`).
    """
    from pendtrack.models.simulate import default_substeps, memory_steps_for, pc_substeps, simulate_packed

    coeffs = model.pack(params, validated=validated)  # validates the physical ranges (ModelError)
    if model.has_memory:
        k = pc_substeps(h, max_step_s)
    else:
        k = default_substeps(coeffs, h, substep_phase) if substep_phase > 0 else 0
    mem = memory_steps_for(memory_s, h / k, full_history=full_history) if model.has_memory else -1
    theta = np.empty(n)
    omega = np.empty(n)
    alpha = np.empty(n if model.has_memory else 0)  # not wanted: the RK4 kernel then skips it
    with np.errstate(all="ignore"):
        simulate_packed(coeffs, n - 1, h, float(theta0), float(omega0), mem, theta, omega, alpha, t_start=t_start,
                        substeps=k)
    return theta, omega


def parameter_bounds(model: Any, t_start: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of a model's parameters for the optimiser, in ``param_names`` order.

    The physical ranges of :mod:`pendtrack.models` made usable: open bounds at 0 (``Omega0``,
    ``p``, ``p_f``, ``beta``) moved in by 1e-6, and ``t0`` of the
    ``C4 omega/(t - t0)`` term kept at least 1 ms before the first simulated time.
    """
    lo = []
    hi = []
    for name in model.param_names:
        a, b = (float(v) for v in model.bounds[name])
        if name == "t0":
            a, b = t_start - 1e4, t_start - 1e-3
        if name in ("Omega0", "p", "p_f", "beta"):
            a = max(a, 1e-6)
        lo.append(a)
        hi.append(b)
    return np.array(lo), np.array(hi)


@dataclass(frozen=True, eq=False)
class FitProblem:
    """Data, model and options of one fit; :meth:`residuals` is what least squares minimises.

    Attributes
    ----------
    model : object
        A model from :mod:`pendtrack.models` (``name``, ``param_names``, ``bounds``).
    t_start : float
        Time of the initial state and of the first grid point [s].
    h : float
        Simulation step = data sampling interval [s].
    n_grid : int
        Number of grid points simulated.
    index : ndarray of int
        Grid index of every data sample used in the cost.
    theta, omega : ndarray
        Measured angle [rad] and angular velocity [rad/s] at those samples.
    cost : str
        ``"xi2"`` or ``"theta"`` (:mod:`pendtrack.fitting.leastsq.cost`).
    omega_scale : float
        ``1/(2 Omega0_hat)`` [s/rad].
    observation : Observation
        How the data were filtered.
    memory_s : float
        Fractional-derivative memory passed to the simulator [s].
    method : str
        Simulator method (``"auto"``, ``"fast"``, ``"reference"``).
    lower, upper : ndarray
        Bounds of the fitted vector.
    fixed : dict
        Parameters held at a value (removed from the fitted vector).
    simulator : callable or None
        ``simulate(model, params, t, *, theta0, omega0, memory_s, method)``; None means the
        models package's numba hot path (:func:`pendtrack.models.simulate_packed`).
    full_history : bool
        The Grunwald-Letnikov sum runs over the whole record instead of ``memory_s``.
    typical : ndarray or None
        Typical magnitude of each fitted parameter (sets finite-difference steps); None: from
        the point itself with floors (1 rad for theta0, Omega0_hat for omega0).
    max_step_s : float or None
        Largest predictor-corrector step of a model with memory [s] (``[models] max_step_s``;
        None: its default, the paper's 1/120 s): a coarser grid is sub-stepped.
    jacobian_method : str
        How :meth:`jacobian` differentiates by default (``[fit] jacobian``): ``"sensitivity"``
        (forward sensitivity equations, for the models without memory on the built-in simulator;
        the others fall back to finite differences) or ``"fd"`` (finite differences).
    substep_phase : float
        RK4 sub-step of :meth:`simulate` for the models without memory: ``Omega h_sub <=
        substep_phase`` [rad] (``[fit] substep_phase``); 0 = the simulation's own
        (:data:`pendtrack.models.simulate.SUBSTEP_PHASE`).
    steer_phase : float
        The same for the sensitivities that *steer* the Levenberg-Marquardt iterations
        (:meth:`jacobian_sensitivity` with ``steer=True``; ``[fit] steer_phase``); 0 = as :meth:`simulate`.
    rung_phase : float
        The ``substep_phase`` of the ladder's shorter windows (:meth:`rung`; ``[fit] rung_phase``); 0 = the same.
    coordinates : Coordinates or None
        The coordinates the Levenberg-Marquardt steps take (``[fit] coordinates``;
        :mod:`pendtrack.fitting.leastsq.coordinates`); None: the parameters themselves. Never changes
        :meth:`residuals` or any value outside a window's fit.
    """

    model: Any
    t_start: float
    h: float
    n_grid: int
    index: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    cost: str
    omega_scale: float
    observation: Observation
    memory_s: float
    method: str
    lower: np.ndarray
    upper: np.ndarray
    fixed: Mapping[str, float] = field(default_factory=dict)
    simulator: Simulator | None = None
    full_history: bool = False
    typical: np.ndarray | None = None
    max_step_s: float | None = None
    jacobian_method: str = "fd"
    substep_phase: float = 0.0
    steer_phase: float = 0.0
    rung_phase: float = 0.0
    coordinates: Coordinates | None = None

    # ---- names -------------------------------------------------------------------------
    @cached_property  # asked for on every evaluation (the fields are frozen)
    def all_names(self) -> tuple[str, ...]:
        """Model parameter names then the initial state, fixed ones included."""
        return tuple(self.model.param_names) + STATE_NAMES

    @cached_property
    def names(self) -> tuple[str, ...]:
        """Names of the fitted vector (fixed parameters left out)."""
        return tuple(n for n in self.all_names if n not in self.fixed)

    @property
    def n(self) -> int:
        """Number of data samples in the cost."""
        return int(self.index.size)

    @property
    def t(self) -> np.ndarray:
        """Times of the data samples in the cost [s]."""
        return self.t_start + self.h * self.index

    @property
    def t_end(self) -> float:
        """Time of the last grid point [s]."""
        return self.t_start + self.h * (self.n_grid - 1)

    def full(self, x: np.ndarray) -> dict[str, float]:
        """Every parameter by name (fitted vector plus fixed values)."""
        values = dict(zip(self.names, (float(v) for v in x)))
        values.update(self.fixed)
        return {name: values[name] for name in self.all_names}

    # ---- simulation --------------------------------------------------------------------
    def grid(self) -> np.ndarray:
        """The simulation's uniform time grid [s]."""
        return self.t_start + self.h * np.arange(self.n_grid)

    def simulate(self, x: np.ndarray, *, n_grid: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Simulate the model on the grid (optionally a longer one) and observe it.

        The model's angle goes through its measurement terms first (``Model.observe_state``:
        ``theta_obs = f(theta)``, ``omega_obs = f'(theta) omega``), then through the data's
        filter (:class:`~pendtrack.fitting.leastsq.cost.Observation`): the camera measures the observed
        angle, and the pipeline filters what it measured.

        Returns
        -------
        theta, omega : ndarray
            Observed model angle [rad] and angular velocity [rad/s] on the grid; NaN-free
            or an exception (:class:`FloatingPointError`) if the solution blew up.
        """
        return self.observe(self.simulate_state(x, n_grid=n_grid))

    def simulate_state(self, x: np.ndarray, *, n_grid: int | None = None) -> SimState:
        """The model's own ``(theta, omega)`` on the grid [rad], [rad/s], before it is observed, with ``x``'s parameters.

        It does not depend on the measurement parameters (:attr:`measurement_columns`): the same
        state observed at points that differ only in those gives their residuals
        (:meth:`residuals_at_state`) without simulating again.

        Raises
        ------
        FloatingPointError
            The solution blew up; :class:`~pendtrack.errors.PendtrackError` or ValueError for
            parameters outside the model's ranges.
        """
        p = self.full(x)
        n = self.n_grid if n_grid is None else n_grid
        params = {k: v for k, v in p.items() if k not in STATE_NAMES}
        if self.simulator is None:
            params = self.model.validate(params)  # the physical ranges (ModelError)
            theta, omega = _simulate_packed(self.model, params, n, self.h, self.t_start, p["theta0"], p["omega0"],
                                            self.memory_s, self.full_history, self.max_step_s, self.substep_phase,
                                            validated=True)
        else:
            t = self.t_start + self.h * np.arange(n)
            res = self.simulator(self.model, params, t, theta0=p["theta0"], omega0=p["omega0"],
                                 memory_s=self.memory_s, method=self.method)
            theta = np.asarray(res.theta, dtype=float)
            omega = np.asarray(res.omega, dtype=float)
        if theta.shape != (n,) or not (np.isfinite(theta).all() and np.isfinite(omega).all()):
            raise FloatingPointError("simulation did not return finite values on the grid")
        return SimState(theta, omega, params)

    def observe(self, state: SimState, x: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """A simulated state (:meth:`simulate_state`) seen as the data were: through the model's measurement
        terms, then the data's filter (:meth:`simulate`); with the measurement parameters of ``x`` if given,
        else those of the state's own point."""
        theta, omega = state.theta, state.omega
        if getattr(self.model, "measurement_terms", ()):  # the camera measures theta_obs; the pipeline then filters it
            params = state.params
            if x is not None:
                p = self.full(x)
                params = {k: v for k, v in p.items() if k not in STATE_NAMES}
                if self.simulator is None:
                    params = self.model.validate(params)
            theta, omega = self.model.observe_state(theta, omega, params, validated=self.simulator is None)
        return self.observation.apply(theta, omega, self.h)

    @cached_property
    def measurement_columns(self) -> tuple[int, ...]:
        """Positions in :attr:`names` of the measurement terms' parameters: the simulated state does not depend on them."""
        from pendtrack.models.terms import CATALOGUE

        measured = {n for t in getattr(self.model, "measurement_terms", ()) for n in CATALOGUE[t].params}
        return tuple(j for j, name in enumerate(self.names) if name in measured)

    def model_at_data(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Observed model angle [rad] and angular velocity [rad/s] at the data samples."""
        theta, omega = self.simulate(x)
        rows = self.rows
        return theta[rows], omega[rows]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """Residual vector (sum of squares = cost); a large constant where the model fails."""
        try:
            state = self.simulate_state(x)
        except (PendtrackError, ValueError, ArithmeticError):
            return self.penalty()
        return self.residuals_at_state(state)

    def residuals_at_state(self, state: SimState, x: np.ndarray | None = None) -> np.ndarray:
        """:meth:`residuals` at the state's own point, or at ``x`` if it differs from that point at most in the
        measurement parameters (:attr:`measurement_columns`): the same vector, bit for bit, without simulating."""
        try:
            theta, omega = self.observe(state, x)
        except (PendtrackError, ValueError, ArithmeticError):
            return self.penalty()
        rows = self.rows
        return residual_vector(theta[rows], omega[rows], self.theta, self.omega, cost=self.cost,
                               omega_scale=self.omega_scale, a_theta_exp=self.a_theta_exp)

    def penalty(self) -> np.ndarray:
        """The residual vector of a point where the model fails (cost ``PENALTY**2`` per channel, far above any real one)."""
        size = self.n * (2 if self.cost == "xi2" else 1)
        return np.full(size, PENALTY / math.sqrt(self.n))

    @cached_property
    def rows(self) -> slice | np.ndarray:
        """:attr:`index` as a slice when it is a contiguous run (the usual case: views, no copies), else itself."""
        idx = self.index
        if idx.size and np.all(np.diff(idx) == 1):
            return slice(int(idx[0]), int(idx[-1]) + 1)
        return idx

    @cached_property
    def a_theta_exp(self) -> np.ndarray:
        """``sin(theta / 2)`` of the data (the Xi^2 angle amplitude, eq. amplitudes), computed once."""
        return np.sin(0.5 * self.theta)

    def cost_value(self, x: np.ndarray) -> float:
        """The cost (Xi^2 [1] or mean squared angle residual [rad^2])."""
        r = self.residuals(x)
        return float(np.einsum("i,i->", r, r))

    # ---- derivatives -------------------------------------------------------------------
    def fd_steps(self, x: np.ndarray, rel: float | None = None) -> np.ndarray:
        """Finite-difference step of each fitted parameter at ``x`` [parameter units].

        ``rel * max(|x_j|, typical_j)``. Not smaller: the solvers' sgn(omega) handling and the
        quarter-power friction make the residuals rough on scales below ~1e-6 relative (and
        non-differentiable in omega0 at omega0 = 0), so tiny steps give noise, not slopes.
        """
        typ = np.abs(np.asarray(x, dtype=float))
        if self.typical is not None:
            typ = np.maximum(typ, self.typical)
        floors = {"theta0": 1.0, "omega0": 0.5 / self.omega_scale, "t0": 1.0}
        for j, name in enumerate(self.names):
            typ[j] = max(typ[j], floors.get(name, 1e-12))
        return (FD_REL if rel is None else rel) * typ

    @property
    def has_sensitivities(self) -> bool:
        """True if :meth:`jacobian_sensitivity` applies: the built-in simulator, a model without memory."""
        return self.simulator is None and not self.model.has_memory

    def uses_sensitivities(self, method: str | None = None) -> bool:
        """True if :meth:`jacobian` with ``method`` (default :attr:`jacobian_method`) integrates sensitivities."""
        m = self.jacobian_method if method is None else method
        if m not in JACOBIANS:
            raise ValueError(f"unknown Jacobian method {m!r}; expected one of {JACOBIANS}")
        return m == "sensitivity" and self.has_sensitivities

    def jacobian(self, x: np.ndarray, *, r0: np.ndarray | None = None, central: bool = False,
                 rel: float | None = None, steps: np.ndarray | None = None, method: str | None = None) -> np.ndarray:
        """Jacobian of :meth:`residuals` at ``x``, shape ``(m, p)``.

        ``method`` (default :attr:`jacobian_method`): ``"sensitivity"`` -- the forward
        sensitivity equations (:meth:`jacobian_sensitivity`; ``r0``, ``central``, ``rel``,
        ``steps`` are then unused) where :attr:`has_sensitivities`, else finite differences;
        ``"fd"`` -- finite differences (steps kept inside the bounds): forward (reusing
        ``r0 = residuals(x)`` if given) or, with ``central``, central ones; steps
        :meth:`fd_steps` (``rel``) unless given.
        """
        x = np.asarray(x, dtype=float)
        if self.uses_sensitivities(method):
            jac = self.jacobian_sensitivity(x)
            if jac is not None:
                return jac
        steps = self.fd_steps(x, rel) if steps is None else np.asarray(steps, dtype=float)
        state = None  # the state at x, observed again for the measurement parameters' columns
        if self.measurement_columns:
            try:
                state = self.simulate_state(x)
            except (PendtrackError, ValueError, ArithmeticError):
                pass
        if r0 is None and not central:
            r0 = self.residuals(x) if state is None else self.residuals_at_state(state)
        cols = []
        for j in range(x.size):
            if state is not None and j in self.measurement_columns:
                cols.append(self._shift_column(state, x, j, steps[j], central=central, r0=r0))
                continue
            up = self.upper[j] - x[j] if self.upper.size else np.inf
            down = x[j] - self.lower[j] if self.lower.size else np.inf
            h = steps[j]
            if central:
                hp, hm = min(h, up), min(h, down)
                if hp <= 0 and hm <= 0:
                    raise ValueError(f"parameter {self.names[j]!r} has zero-width bounds")
                xp, xm = x.copy(), x.copy()
                xp[j] += hp
                xm[j] -= hm
                cols.append((self.residuals(xp) - self.residuals(xm)) / (hp + hm))
            else:
                if h > up:
                    h = -min(h, down)
                xp = x.copy()
                xp[j] += h
                cols.append((self.residuals(xp) - r0) / h)
        return np.column_stack(cols)

    def _shift_column(self, state: SimState, x: np.ndarray, j: int, h: float, *,
                      central: bool, r0: np.ndarray | None) -> np.ndarray:
        """:meth:`jacobian`'s finite-difference column of measurement parameter ``j`` from the state at ``x``:
        the same steps and arithmetic as the other columns, the residuals observed instead of simulated."""
        up = self.upper[j] - x[j]
        down = x[j] - self.lower[j]
        if central:
            hp, hm = min(h, up), min(h, down)
            xp, xm = x.copy(), x.copy()
            xp[j] += hp
            xm[j] -= hm
            return (self.residuals_at_state(state, xp) - self.residuals_at_state(state, xm)) / (hp + hm)
        if h > up:
            h = -min(h, down)
        xp = x.copy()
        xp[j] += h
        return (self.residuals_at_state(state, xp) - r0) / h

    def simulate_sensitivities(self, x: np.ndarray, *, steer: bool = False
                               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`simulate` and the derivatives of its observed curves by the fitted vector.

        The model (no memory) is integrated with its forward sensitivities
        (:func:`pendtrack.models.simulate_sensitivities`: RK4 with the same sub-steps and
        sign-change events as the simulation); the derivatives of the packed coefficients by
        the parameters come from the declarations (complex steps of their ``pack``). Both
        observation steps are then applied to the sensitivities: the measurement terms by the
        chain rule (:meth:`_observe_sensitivities`) and the Savitzky-Golay filter, which is
        linear, column by column (:meth:`Observation.apply_columns`). The RK4 sub-steps are
        :meth:`simulate`'s (then ``theta``, ``omega`` are its values), or with ``steer`` those of
        :attr:`steer_phase`.

        Returns
        -------
        theta, omega : ndarray
            ``(n_grid,)``, as :meth:`simulate` [rad], [rad/s].
        dtheta, domega : ndarray
            ``(n_grid, p)``: their derivatives by each fitted parameter (:attr:`names` order).

        Raises
        ------
        FloatingPointError
            The solution or its sensitivities are not finite.
        """
        from pendtrack.models.simulate import simulate_sensitivities
        from pendtrack.models.terms import LAYOUT

        p = self.full(x)
        model = self.model
        params = model.validate({k: v for k, v in p.items() if k not in STATE_NAMES})  # the physical ranges (ModelError)
        coeffs = model.pack(params, validated=True)
        names = self.names
        phys = [n for n in names if n in params]
        dpack = LAYOUT.pack_jacobian(model.terms, params, phys)
        dcoeffs = np.zeros((coeffs.size, len(names)))
        d_theta0 = np.zeros(len(names))
        d_omega0 = np.zeros(len(names))
        for j, name in enumerate(names):
            if name == "theta0":
                d_theta0[j] = 1.0
            elif name == "omega0":
                d_omega0[j] = 1.0
            else:
                dcoeffs[:, j] = dpack[:, phys.index(name)]
        theta, omega, dth, dom = simulate_sensitivities(coeffs, dcoeffs, self.n_grid - 1, self.h, p["theta0"],
                                                        p["omega0"], d_theta0, d_omega0, t_start=self.t_start,
                                                        substeps=self._substeps(coeffs, steer))
        if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(omega)) and np.all(np.isfinite(dth))
                and np.all(np.isfinite(dom))):
            raise FloatingPointError("simulation or its sensitivities did not return finite values on the grid")
        if getattr(model, "measurement_terms", ()):
            theta, omega, dth, dom = self._observe_sensitivities(theta, omega, dth, dom, params)
        theta, omega = self.observation.apply(theta, omega, self.h)
        dth, dom = self.observation.apply_columns(dth, dom, self.h)
        return theta, omega, dth, dom

    def _substeps(self, coeffs: np.ndarray, steer: bool) -> int:
        """RK4 sub-steps of the sensitivities (0: the models package's default)."""
        from pendtrack.models.simulate import default_substeps

        phase = self.steer_phase if steer and self.steer_phase > 0 else self.substep_phase
        return default_substeps(coeffs, self.h, phase) if phase > 0 else 0

    def _observe_sensitivities(self, theta: np.ndarray, omega: np.ndarray, dth: np.ndarray, dom: np.ndarray,
                               params: Mapping[str, float]) -> tuple[np.ndarray, ...]:
        """The measurement terms applied to the state and, by the chain rule, to its sensitivities.

        ``Model.observe_state``: ``theta_obs = F(theta, q)``, ``omega_obs = S(theta, q) omega``
        with ``S`` the central difference of ``F`` over +-``OBSERVE_FD_STEP`` (differentiated as
        it is computed, so this is the derivative of what :meth:`residuals` sees). The
        derivatives of ``F`` by theta and by the measurement parameters ``q`` are complex steps
        of the declared formulas (arithmetic, so analytic). Where every measurement term is a shift
        (``Term.shift``) these are exactly 1: ``dth`` gains 1 in the shifts' columns, in place.
        """
        from pendtrack.models.registry import OBSERVE_FD_STEP
        from pendtrack.models.terms import CATALOGUE

        model = self.model
        p = params  # validated by the caller
        th_obs, om_obs = model.observe_state(theta, omega, p, validated=True)
        measured = {n for t in model.measurement_terms for n in CATALOGUE[t].params}
        if model._observes_by_shifts:  # noqa: SLF001 - F = theta + sum of shifts: dF/dtheta = S = dF/dq = 1
            for j, name in enumerate(self.names):
                if name in measured:
                    dth[:, j] += 1.0
            return th_obs, om_obs, dth, dom
        d = OBSERVE_FD_STEP
        eps = 1e-30

        def f(th: np.ndarray, pp: Mapping[str, complex]) -> np.ndarray:
            return model._observe(th, pp)  # noqa: SLF001 - the composed declared observation

        th_c = theta.astype(complex)
        slope = (f(theta + d, p) - f(theta - d, p)) / (2.0 * d)
        df_dth = f(th_c + 1j * eps, p).imag / eps
        dslope_dth = (f(th_c + d + 1j * eps, p).imag - f(th_c - d + 1j * eps, p).imag) / (eps * 2.0 * d)
        out_th = df_dth[:, None] * dth
        out_om = (dslope_dth * omega)[:, None] * dth + slope[:, None] * dom
        for j, name in enumerate(self.names):
            if name not in measured:
                continue
            pc: dict[str, complex] = {k: complex(v) for k, v in p.items()}
            pc[name] = pc[name] + 1j * eps
            out_th[:, j] += f(th_c, pc).imag / eps
            out_om[:, j] += (f(th_c + d, pc).imag - f(th_c - d, pc).imag) / (eps * 2.0 * d) * omega
        return th_obs, om_obs, out_th, out_om

    def jacobian_sensitivity(self, x: np.ndarray, *, steer: bool = False) -> np.ndarray | None:
        """Jacobian of :meth:`residuals` from the forward sensitivities, shape ``(m, p)`` (columns contiguous).

        ``steer``: integrated with :attr:`steer_phase`'s RK4 sub-steps, the cheaper Jacobian that
        steers the Levenberg-Marquardt iterations. Where the iterations end is set by the residuals
        alone (their gradient, with a Jacobian off by a relative ``e``, vanishes within ~``e``
        standard errors of the minimum); 1 sub-step at 120 fps is within 5e-6 (relative, column
        norms) of central differences on 60-s records and 9e-5 for the added-mass-only model,
        against 1e-5 and 1e-5 for the simulation's 3 sub-steps (tests/fitting/test_sensitivity.py).

        The observed curves' derivatives (:meth:`simulate_sensitivities`) at the data samples,
        through the cost's chain rule (:func:`pendtrack.fitting.leastsq.cost.residual_vector`): for
        ``"xi2"`` ``d r_theta = cos(theta/2)/2 d theta / sqrt(N)`` (``A_theta = sin(theta/2)``) and
        ``d r_omega = omega_scale d omega / sqrt(N)``; ``omega_scale = 1/(2 Omega0_hat)`` is the
        fixed, data-derived scale (not the fitted Omega0: no term by Omega0 through the scale);
        for ``"theta"`` ``d theta / sqrt(N)``. None where the simulation fails (the caller then
        differentiates :meth:`residuals`, whose penalty is constant, by finite differences).
        """
        try:
            theta, omega, dth, dom = self.simulate_sensitivities(x, steer=steer)
        except (PendtrackError, ValueError, ArithmeticError):
            return None
        idx = self.rows
        n = self.n
        norm = 1.0 / math.sqrt(n)
        p = dth.shape[1]
        if self.cost == "xi2":
            jac = np.empty((2 * n, p), order="F")
            np.multiply(((0.5 * norm) * np.cos(0.5 * theta[idx]))[:, None], dth[idx], out=jac[:n])
            np.multiply(self.omega_scale * norm, dom[idx], out=jac[n:])
            return jac
        if self.cost == "theta":
            return np.asfortranarray(norm * dth[idx])
        raise ValueError(f"unknown cost {self.cost!r}")

    # ---- windows -----------------------------------------------------------------------
    def restrict(self, t_end: float) -> "FitProblem":
        """The same problem on the shorter window ``[t_start, t_end]``."""
        n_grid = min(self.n_grid, int(math.floor((t_end - self.t_start) / self.h + 1e-6)) + 1)
        keep = self.index <= n_grid - 1 - self.observation.trim
        if n_grid == self.n_grid:
            return self
        return replace(self, n_grid=n_grid, index=self.index[keep], theta=self.theta[keep],
                       omega=self.omega[keep])

    def rung(self, t_end: float) -> "FitProblem":
        """The problem on the shorter window ``[t_start, t_end]`` of a start's ladder: :meth:`restrict`,
        its residuals integrated with :attr:`rung_phase`'s sub-steps (they only carry a start onwards)."""
        sub = self.restrict(t_end)
        if self.rung_phase > 0 and self.rung_phase != sub.substep_phase:
            sub = replace(sub, substep_phase=self.rung_phase)
        return sub

    def with_fixed(self, fixed: Mapping[str, float]) -> "FitProblem":
        """The same problem with some parameters held at given values."""
        names = self.all_names
        unknown = [k for k in fixed if k not in names]
        if unknown:
            raise ValueError(f"cannot fix unknown parameter {unknown[0]!r}")
        merged = dict(self.fixed) | {k: float(v) for k, v in fixed.items()}
        typical = None if self.typical is None else self._sub(self.typical, merged)
        return replace(self, fixed=merged, lower=self._sub(self.lower, merged), upper=self._sub(self.upper, merged),
                       typical=typical)

    def _sub(self, arr: np.ndarray, merged: Mapping[str, float]) -> np.ndarray:
        full = dict(zip(self.names, arr))
        return np.array([full[n] for n in self.all_names if n not in merged])
