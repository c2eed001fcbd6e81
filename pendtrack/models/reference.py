"""Accurate reference integration (scipy ``solve_ivp``) for models without memory.

DOP853 at ``rtol = 1e-12``, ``atol = 1e-14``. The ``sgn(omega)`` discontinuity is an
event: the integration runs with the direction of motion frozen, stops where omega
crosses zero (terminal event), and restarts from there with the direction the forces
push towards -- or, if static friction exceeds them (``accel(+1) <= 0 <= accel(-1)``),
the pendulum sticks (omega = alpha = 0 afterwards; the memory-free terms cannot unstick
it). This is the same semantics as the fast RK4 kernel, so the two converge to the same
solution. Slow (pure Python right-hand side): a check, not a workhorse.
"""

from __future__ import annotations

import math

import numpy as np

from pendtrack.models.kernels import accel_free, direction

RTOL = 1e-12  # measured: 1e-10 leaves 7e-6 rad after 60 s near the separatrix (theta0 = 3)
ATOL = 1e-14
_EMPTY = np.zeros(0)


def integrate_reference(coeffs: np.ndarray, t: np.ndarray, theta0: float, omega0: float, *,
                        rtol: float = RTOL, atol: float = ATOL) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate a memory-free packed model and sample it at times ``t``.

    Parameters
    ----------
    coeffs : numpy.ndarray
        Packed model (:meth:`pendtrack.models.Model.pack`); the memory term is ignored.
    t : numpy.ndarray
        Strictly increasing output times [s]; the state at ``t[0]`` is the initial state.
    theta0, omega0 : float
        Initial angle [rad] and angular velocity [rad/s].
    rtol, atol : float
        solve_ivp tolerances.

    Returns
    -------
    theta, omega, alpha : numpy.ndarray
        At ``t`` [rad], [rad/s], [rad/s^2].
    """
    from scipy.integrate import solve_ivp

    c = np.asarray(coeffs, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    n = t.size
    theta = np.empty(n)
    omega = np.empty(n)
    alpha = np.empty(n)
    t_now, th, om = float(t[0]), float(theta0), float(omega0)
    t_end = float(t[-1])
    s = direction(th, om, t_now, c, 0.0)
    filled = 0  # samples [0, filled) are done
    stalled = 0
    while filled < n:
        if s == 0.0:  # stuck for good (memory-free forces do not depend on omega history)
            theta[filled:] = th
            omega[filled:] = 0.0
            alpha[filled:] = 0.0
            break

        def rhs(tt: float, y: np.ndarray, s: float = s) -> list[float]:
            return [y[1], accel_free(y[0], math.sin(y[0]), y[1], tt, s, c)]

        def crossing(tt: float, y: np.ndarray, s: float = s) -> float:
            return s * y[1]

        crossing.terminal = True  # type: ignore[attr-defined]
        crossing.direction = -1  # type: ignore[attr-defined]
        if t_now >= t_end:
            sol_end = t_now
            dense = None
        else:
            sol = solve_ivp(rhs, (t_now, t_end), [th, om], method="DOP853", rtol=rtol, atol=atol,
                            dense_output=True, events=crossing)
            if sol.status == -1:
                raise RuntimeError(f"reference integration failed: {sol.message}")  # programming error
            sol_end = float(sol.t[-1])
            dense = sol.sol
        stop = int(np.searchsorted(t, sol_end, side="right")) if sol_end < t_end else n
        if dense is not None and stop > filled:
            y = dense(t[filled:stop])
            theta[filled:stop] = y[0]
            omega[filled:stop] = y[1]
            alpha[filled:stop] = [accel_free(a, math.sin(a), b, tt, s, c) for a, b, tt in zip(y[0], y[1], t[filled:stop])]
        elif stop > filled:  # t_now == t_end: the last sample is the current state
            theta[filled:stop] = th
            omega[filled:stop] = om
            alpha[filled:stop] = accel_free(th, math.sin(th), om, t_now, s, c)
        filled = stop
        if filled >= n:
            break
        # restart at the crossing with omega = 0 and the new direction
        stalled = stalled + 1 if sol_end <= t_now else 0
        t_now = sol_end
        th = float(sol.y[0, -1])
        om = 0.0
        s = direction(th, om, t_now, c, 0.0)
        if stalled > 8:  # direction flips without any progress: numerically stuck
            s = 0.0
    return theta, omega, alpha
