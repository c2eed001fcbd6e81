"""A Levenberg-Marquardt least-squares solver that spends few model evaluations in long valleys.

Pendulum models are "sloppy": amplitudes and exponents of the damping terms (C0, C3, p; G2,
beta, p_f) trade off along narrow curved valleys of the cost where any Levenberg-Marquardt
takes many short steps. Each step of MINPACK's ``lmdif`` costs a fresh finite-difference
Jacobian (p + 1 simulations); here, between fresh Jacobians, the Jacobian is updated by
Broyden's rank-one secant formula from the step just taken (no extra simulation), and a
fresh one is computed every :data:`REFRESH` accepted steps, after a rejected step, and
before declaring convergence. In a valley this cuts the simulations per step from p + 1 to
about 2.

Plain callables: ``fun(x) -> r`` and ``jac(x, r) -> J`` (finite differences supplied by the
caller); bounds by projection onto the box, a parameter on a bound that the gradient pushes
outwards being held there for the step; Marquardt scaling ``D = diag(J^T J)`` (running
maximum) so the result does not depend on the parameters' units; Nielsen's damping update.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

REFRESH = 4  # accepted Broyden steps between fresh finite-difference Jacobians


def sumsq(v: np.ndarray) -> float:
    """``v @ v`` without BLAS: a threaded BLAS dot on a long vector costs milliseconds of thread
    wake-ups on a busy machine, more than the simulation it follows."""
    return float(np.einsum("i,i->", v, v))


def _matvec(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("ij,j->i", a, v)


def _fortran(jac: np.ndarray) -> np.ndarray:
    """The Jacobian with contiguous columns (a copy only if it is not): the products with a
    tall, narrow J (N x p, p ~ 5) are ~3x faster, and the secant update is in place."""
    return np.asfortranarray(jac, dtype=np.float64)


def _rank_one_update(jac: np.ndarray, u: np.ndarray, w: np.ndarray) -> None:
    """``jac += outer(u, w)`` in place, column by column (no N x p temporary)."""
    for j in range(jac.shape[1]):
        jac[:, j] += w[j] * u


@dataclass(frozen=True)
class LMResult:
    """Outcome of :func:`levenberg_marquardt`.

    Attributes
    ----------
    x : ndarray
        Final point (inside the bounds).
    r : ndarray
        Residuals there.
    cost : float
        ``r @ r``.
    iterations : int
        Accepted steps.
    jacobians : int
        Fresh finite-difference Jacobians computed.
    status : int
        1 cost converged, 2 step converged, 3 gradient converged, 4 no step lowers the cost
        with a fresh Jacobian (the minimum to the precision of the residuals, or a kink),
        -1 iteration cap or non-finite cost.
    message : str
    """

    x: np.ndarray
    r: np.ndarray
    cost: float
    iterations: int
    jacobians: int
    status: int
    message: str

    @property
    def success(self) -> bool:
        return self.status > 0


def _tiny(step: np.ndarray, x: np.ndarray, scale: np.ndarray, xtol: float) -> bool:
    # a step that overflowed (inf x 0 scale) is no tiny step, and no warning for the user
    with np.errstate(invalid="ignore", over="ignore"):
        return float(np.linalg.norm(step * scale)) <= xtol * (float(np.linalg.norm(x * scale)) + xtol)


ACC_MAX = 0.75  # largest accepted ratio 2 |a| / |v| of geodesic acceleration to velocity (Transtrum)
ACC_H = 0.1  # second-difference step along v, as a fraction of v


def _acceleration(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray, r: np.ndarray, v: np.ndarray,
                  J: np.ndarray, jtj: np.ndarray, lam: float, d: np.ndarray, free: np.ndarray,
                  lower: np.ndarray, upper: np.ndarray) -> np.ndarray | None:
    """Geodesic acceleration ``a`` for the velocity ``v``, or None if ``2|a| > ACC_MAX |v|``.

    ``r_vv = (r(x + h v) - 2 r + r(x - h v)) / h^2`` (h = ACC_H), then
    ``(J^T J + lam D) a = -J^T r_vv`` on the free parameters.
    """
    h = ACC_H
    rp = fun(np.clip(x + h * v, lower, upper))
    rm = fun(np.clip(x - h * v, lower, upper))
    r_vv = (rp - 2.0 * r + rm) / (h * h)
    a = np.zeros_like(x)
    sub = np.ix_(free, free)
    try:
        a[free] = np.linalg.solve(jtj[sub] + lam * np.diag(d[free]), -np.einsum("ij,i->j", J, r_vv)[free])
    except np.linalg.LinAlgError:
        return None
    scale = np.sqrt(d)
    if not np.all(np.isfinite(a)) or 2.0 * float(np.linalg.norm(a * scale)) > ACC_MAX * float(np.linalg.norm(v * scale)):
        return None
    return a


def levenberg_marquardt(fun: Callable[[np.ndarray], np.ndarray],
                        jac: Callable[[np.ndarray, np.ndarray], np.ndarray], x0: np.ndarray, *,
                        lower: np.ndarray, upper: np.ndarray, ftol: float = 1e-8, xtol: float = 1e-8,
                        gtol: float = 1e-10, max_iterations: int = 1000, geodesic: bool = False) -> LMResult:
    """Minimise ``sum(fun(x)**2)`` inside the box ``[lower, upper]``.

    Parameters
    ----------
    fun : callable
        Residual vector of x. A budget is best enforced inside it (raise to stop).
    jac : callable
        ``jac(x, r)`` -> finite-difference Jacobian at x given ``r = fun(x)``, a new array
        each call: the secant steps update it in place.
    x0 : ndarray
        Start (clipped into the box).
    lower, upper : ndarray
        Bounds.
    ftol : float
        Converged when two successive accepted steps, the last with a fresh Jacobian, each
        lower the cost by less than ``ftol`` relative.
    xtol : float
        Converged when, with a fresh Jacobian, both the accepted step and the undamped
        Gauss-Newton step are below ``xtol`` relative to x (Marquardt-scaled norms).
    gtol : float
        Converged when the scaled gradient is below ``gtol`` relative to the cost.
    max_iterations : int
        Cap on trial steps.
    geodesic : bool
        Geodesic acceleration (Transtrum, Machta & Sethna, Phys. Rev. E 83, 036701 (2011)):
        each step ``v`` is followed along the curvature of the residuals,
        ``x + v + a/2`` with ``(J^T J + lam D) a = -J^T r_vv`` and ``r_vv`` the second directional
        derivative along ``v`` (central difference, two evaluations, independent of the
        Jacobian's accuracy); a step whose acceleration is large (``2|a| > ACC_MAX |v|``,
        Marquardt-scaled) is rejected like an uphill one. In the curved valleys of sloppy
        models this replaces hundreds of tiny damped steps by a few long ones.

    Returns
    -------
    LMResult
    """
    x = np.clip(np.asarray(x0, dtype=float), lower, upper)
    r = fun(x)
    cost = sumsq(r)
    J = _fortran(jac(x, r))
    n_jac = 1
    fresh = True
    since_fresh = 0
    d = np.maximum(np.einsum("ij,ij->j", J, J), 1e-300)
    lam = 1e-3 * float(d.max())
    nu = 2.0
    iterations = 0
    small = 0
    status, message = -1, "iteration cap reached"
    moved = True  # J or r changed since J^T J and the gradient were formed (a rejected step changes neither)
    for _ in range(max_iterations):
        if moved:  # on a long record J^T J and J^T r cost ~0.15 ms, a tenth of an evaluation
            # far out on a steep term (p near its bound) J^T J can overflow: the step it gives is not finite,
            # so its trial is rejected like an uphill one, without a warning to the user
            with np.errstate(over="ignore", invalid="ignore"):
                jtj = J.T @ J
                g = np.einsum("ij,i->j", J, r)
            moved = False
        d = np.maximum(d, np.diag(jtj))
        scale = np.sqrt(d)
        pushing = ~(((x <= lower) & (g > 0)) | ((x >= upper) & (g < 0)))
        g_scaled = float(np.max(np.abs(g[pushing]) / scale[pushing], initial=0.0))
        if fresh and g_scaled <= gtol * math.sqrt(max(cost, 1e-300)):
            status, message = 3, "gradient converged"
            break
        # parameters on a bound that the gradient pushes outwards stay there this step
        free = ~(((x <= lower) & (g > 0)) | ((x >= upper) & (g < 0)))
        v = np.zeros_like(x)
        try:
            sub = np.ix_(free, free)
            with np.errstate(over="ignore", invalid="ignore"):
                v[free] = np.linalg.solve(jtj[sub] + lam * np.diag(d[free]), -g[free])
        except np.linalg.LinAlgError:
            lam *= nu
            nu *= 2.0
            continue
        if geodesic and np.any(v):
            a = _acceleration(fun, x, r, v, J, jtj, lam, d, free, lower, upper)
            if a is None:  # the path bends too much for this step: damp more
                lam *= nu
                nu *= 2.0
                continue
            v = v + 0.5 * a
        x_new = np.clip(x + v, lower, upper)
        step = x_new - x
        r_new = fun(x_new)
        cost_new = sumsq(r_new)
        lin = r + _matvec(J, step)
        predicted = cost - sumsq(lin)
        rho = (cost - cost_new) / predicted if predicted > 0 else -1.0
        if cost_new < cost and rho > 0:
            rel = (cost - cost_new) / cost
            tiny = _tiny(step, x, scale, xtol)
            if tiny and fresh:  # a small step may only mean heavy damping: test the Gauss-Newton step
                try:
                    gn = np.linalg.solve(jtj, -g)
                except np.linalg.LinAlgError:
                    gn = np.zeros_like(x)
                tiny = _tiny(np.clip(x + gn, lower, upper) - x, x, scale, xtol)
            was_fresh = fresh
            iterations += 1
            lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            nu = 2.0
            small = small + 1 if rel < ftol else 0
            if was_fresh and small >= 2:
                x, r, cost = x_new, r_new, cost_new
                status, message = 1, "cost converged"
                break
            if was_fresh and tiny:
                x, r, cost = x_new, r_new, cost_new
                status, message = 2, "step converged"
                break
            since_fresh += 1
            if since_fresh >= REFRESH or small >= 1 or tiny:
                J = _fortran(jac(x_new, r_new))
                n_jac += 1
                fresh, since_fresh = True, 0
            else:  # Broyden rank-one secant update
                with np.errstate(over="ignore"):  # a step out to float64's range: no secant from it
                    s2 = float(step @ step)
                if 0 < s2 < math.inf:
                    _rank_one_update(J, r_new - r - _matvec(J, step), step / s2)
                fresh = False
            x, r, cost = x_new, r_new, cost_new
            moved = True
        elif not fresh:  # the secant model failed: refresh it before damping more
            J = _fortran(jac(x, r))
            n_jac += 1
            fresh, since_fresh = True, 0
            moved = True
        else:
            lam *= nu
            nu *= 2.0
            if lam > 1e16 * float(d.max()):  # J is fresh here: no step lowers the cost any more
                status, message = 4, "no descent left: minimum to the solver's precision"
                break
    if not math.isfinite(cost):
        status, message = -1, "non-finite cost"
    return LMResult(x=x, r=r, cost=cost, iterations=iterations, jacobians=n_jac, status=status, message=message)
