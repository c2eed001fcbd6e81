"""The coordinates the Levenberg-Marquardt steps take: the damping terms' trade-offs decorrelated.

Three groups of the paper's parameters trade off along long valleys of the cost, where a
Levenberg-Marquardt fit crawls (many short steps; on the 60-s bench record most starts used to
stop on their budget short of the minimum):

* **power-law drag** ``C3 |omega/Omega0|^p``: a change of ``p`` at fixed ``C3`` changes the drag
  at every speed except ``|omega/Omega0| = 1``, although the data mostly see the speeds where the
  swing loses its energy. The fit steps in ``D = C3 x_ref^p`` (the drag at the reference speed
  ``x_ref``) and ``p``, where ``ln x_ref`` is the mean of ``ln |omega/Omega0_hat|`` over the
  samples weighted by the dissipated power ``|omega|^(p_hat + 1)`` (``p_hat`` the start ranges'
  centre): at fixed ``D`` a change of ``p`` then leaves the energy lost over the record unchanged
  to first order;
* **memory term** ``G2 D^beta_{t*}(A |A|^(p_f - 1))``: the same for its amplitude, taken at the
  swing's frequency (``|D^beta|`` of an oscillation of angular frequency 1/2 in ``t* = 2 Omega0 t``
  is ``0.5^beta``) and at the reference ``a_ref`` of ``|A_omega|`` (weights ``|A|^(p_f_hat + 1)``):
  the fit steps in ``G2 0.5^beta a_ref^p_f``, ``beta`` and ``p_f``;
* **time-varying damping** ``C4 omega/(t - t0)`` with ``t0`` far before the record: the data
  fix the damping rate ``C4/(t - t0)`` near the record, so ``C4`` and ``t0`` move together
  (``C4 / |t0|`` constant). The fit steps in ``gamma = C4 kappa`` (the rate at ``t_ref``) and
  ``kappa = 1/(t_ref - t0)`` (its relative change per second), ``t_ref`` the mean time weighted
  by ``omega^2``.

Only the path of each Levenberg-Marquardt fit changes: its start points, end points, costs and
every result are in the model's own parameters (:func:`pendtrack.fitting.leastsq.local_fits.fit_window`
converts at the window's ends), and the minimum is the same one. A map is used only when its
amplitude and at least one of its exponents (or ``C4`` and ``t0``) are fitted, not held.
Measured on the 60-s bench record: ``pendtrack/fitting/README.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Coordinates", "BoundCoordinates", "fit_coordinates"]

DRAG = ("C3", "p")  # amplitude, exponent of the power-law drag
MEMORY = ("G2", "beta", "p_f")  # amplitude, order, exponent of the memory term
TIME_VARYING = ("C4", "t0")  # amplitude, time origin of C4 omega/(t - t0)
P_HAT_DEFAULT = 1.5  # exponent of the weights when the start centre has no finite p
#: ln of the swing's angular frequency in the memory term's time t* = 2 Omega0 t: Omega0/(2 Omega0)
LOG_MEMORY_FREQUENCY = math.log(0.5)

EXP_LIMIT = 700.0  # |argument| of the references' exponentials: beyond it a value is inf or 0 in float64

Scaled = tuple[str, tuple[tuple[str, float], ...]]  # amplitude name, ((exponent name, ln reference), ...)


@dataclass(frozen=True)
class Coordinates:
    """The decorrelated coordinates of a problem (by parameter name; :meth:`bind` resolves them).

    Attributes
    ----------
    scaled : tuple
        Amplitudes taken at a reference: ``(a, ((e1, l1), ...))`` steps in
        ``a exp(e1 l1 + ...)`` instead of ``a`` (``l = ln`` of the reference the exponent ``e``
        acts on).
    t_ref : float or None
        Reference time of the time-varying damping [s]; None: no such pair.
    """

    scaled: tuple[Scaled, ...] = ()
    t_ref: float | None = None

    def bind(self, names: Sequence[str]) -> "BoundCoordinates | None":
        """The maps of the parameters in ``names`` (the fitted vector; a held amplitude drops its map,
        a held exponent its factor); None if none is left."""
        index = {n: i for i, n in enumerate(names)}
        scaled = []
        for amp, exps in self.scaled:
            used = tuple((index[e], float(lg)) for e, lg in exps if e in index)
            if amp in index and used:
                scaled.append((index[amp], used))
        tv = None
        if self.t_ref is not None and all(n in index for n in TIME_VARYING):
            tv = (index[TIME_VARYING[0]], index[TIME_VARYING[1]], float(self.t_ref))
        if not scaled and tv is None:
            return None
        return BoundCoordinates(scaled=tuple(scaled), tv=tv)


@dataclass(frozen=True)
class BoundCoordinates:
    """The maps between a fitted vector ``x`` (the model's parameters) and the steps' ``y``.

    ``scaled = ((i, ((j, l_j), ...)), ...)``: ``y_i = x_i exp(sum_j x_j l_j)`` (e.g. ``D = C3 x_ref^p``).
    ``tv = (i, j, t_ref)``: ``y_j = 1/(t_ref - x_j)`` (``kappa``), ``y_i = x_i y_j`` (``gamma``).
    Every other ``y_k = x_k``. Each map is monotone in its amplitude and in ``t0``, so a box of
    ``x`` (amplitudes in ``[0, inf)``) maps onto a box of ``y``.
    """

    scaled: tuple[tuple[int, tuple[tuple[int, float], ...]], ...] = ()
    tv: tuple[int, int, float] | None = None

    def to_internal(self, x: np.ndarray) -> np.ndarray:
        """``y`` of a point ``x`` (a copy)."""
        y = np.array(x, dtype=float)
        for i, exps in self.scaled:
            y[i] = _times_exp(float(x[i]), sum(x[j] * lg for j, lg in exps))
        if self.tv is not None:
            i, j, t_ref = self.tv
            kappa = 1.0 / (t_ref - x[j])
            y[i], y[j] = x[i] * kappa, kappa
        return y

    def to_natural(self, y: np.ndarray) -> np.ndarray:
        """``x`` of a point ``y`` (a copy)."""
        x = np.array(y, dtype=float)
        for i, exps in self.scaled:
            x[i] = _times_exp(float(y[i]), -sum(y[j] * lg for j, lg in exps))
        if self.tv is not None:
            i, j, t_ref = self.tv
            x[i], x[j] = y[i] / y[j], t_ref - 1.0 / y[j]
        return x

    def jacobian(self, jac_x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """``d r/d y = (d r/d x)(d x/d y)`` from the Jacobian in ``x`` at the point ``y`` (columns
        contiguous; ``jac_x`` is overwritten)."""
        jac = np.asfortranarray(jac_x)
        for i, exps in self.scaled:
            scale = _exp(-sum(y[j] * lg for j, lg in exps))  # d x_i/d y_i; d x_i/d y_j = -x_i l_j
            amp = float(y[i]) * scale  # Python floats: inf past float64's range, without a warning
            # a trial point at an amplitude past float64's range gives inf entries, as _times_exp gives inf:
            # the same numbers, without numpy's warning printed to the user
            with np.errstate(over="ignore", invalid="ignore"):
                for j, lg in exps:
                    jac[:, j] -= (amp * lg) * jac[:, i]
                jac[:, i] *= scale
        if self.tv is not None:
            i, j, _ = self.tv
            gamma, kappa = y[i], y[j]  # C4 = gamma/kappa, t0 = t_ref - 1/kappa
            col_c4 = jac[:, i].copy()
            jac[:, i] = col_c4 / kappa
            jac[:, j] = jac[:, j] / (kappa * kappa) - (gamma / (kappa * kappa)) * col_c4
        return jac

    def bounds(self, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The box of ``y`` that the box ``[lower, upper]`` of ``x`` maps onto.

        A scaled amplitude must have the bounds ``[0, inf)`` (every damping amplitude has), which it
        keeps; the time origin's bounds must be finite and before ``t_ref``.
        """
        lo, hi = np.array(lower, dtype=float), np.array(upper, dtype=float)
        for i, _ in self.scaled:
            if not (lower[i] == 0.0 and math.isinf(upper[i])):
                raise ValueError("an amplitude taken at a reference must have the bounds [0, inf)")
        if self.tv is not None:
            i, j, t_ref = self.tv
            if not (lower[i] == 0.0 and math.isinf(upper[i])) or not (upper[j] < t_ref and math.isfinite(lower[j])):
                raise ValueError("the time-varying damping's coordinates need C4 in [0, inf) and a finite t0 < t_ref")
            lo[j], hi[j] = 1.0 / (t_ref - lower[j]), 1.0 / (t_ref - upper[j])
        return lo, hi


def _exp(v: float) -> float:
    """``exp(v)`` with ``v`` clipped to +-:data:`EXP_LIMIT`: an exponent far outside the data's range (a
    step to p = 1e4) maps to a huge but finite value, whose residuals are the fit's penalty, instead of
    an OverflowError."""
    return math.exp(min(max(v, -EXP_LIMIT), EXP_LIMIT))


def _times_exp(a: float, v: float) -> float:
    """``a exp(v)`` (:func:`_exp`) in Python floats: a product past float64's range is inf, as numpy's is, but
    without numpy's overflow warning, which reached the user on a 140-s Tracker record at 30 fps (a step to an
    amplitude of 1e10 with a large exponent; the point's residuals are then not finite and the step is
    rejected)."""
    return a * _exp(v)


def _log_reference(x: np.ndarray, power: float) -> float | None:
    """The mean of ``ln |x|`` over the samples weighted by ``|x|^power`` (None: no sample is non-zero)."""
    x = np.abs(np.asarray(x, dtype=float))
    x = x[np.isfinite(x) & (x > 0.0)]
    if not x.size:
        return None
    lx = np.log(x)
    w = np.exp(power * (lx - lx.max()))  # |x|^power, scaled: no overflow
    return float(np.sum(w * lx) / np.sum(w))


def _exponent(value: float) -> float:
    return value if math.isfinite(value) and value > 0.0 else P_HAT_DEFAULT


def fit_coordinates(names: Sequence[str], t: np.ndarray, omega: np.ndarray, *, omega0_hat: float,
                    center: Mapping[str, float] | None = None) -> Coordinates | None:
    """The decorrelated coordinates of a model's fit from its data (None: the model has no such term).

    Parameters
    ----------
    names : sequence of str
        The model's parameter names.
    t, omega : ndarray
        Times [s] and measured angular velocities [rad/s] of the samples in the cost.
    omega0_hat : float
        The data-derived Omega0 [rad/s] (the speed scale of the drag and of the memory term).
    center : mapping, optional
        The start ranges' centre: its ``p`` and ``p_f`` are the weights' exponents
        (:data:`P_HAT_DEFAULT` where missing or not finite).
    """
    center = center or {}
    scaled: list[Scaled] = []
    if all(n in names for n in DRAG):
        p = _exponent(float(center.get("p", math.nan)))
        log_x = _log_reference(np.asarray(omega, dtype=float) / omega0_hat, p + 1.0)
        if log_x is not None:
            scaled.append(("C3", (("p", log_x),)))
    if all(n in names for n in MEMORY):
        p_f = _exponent(float(center.get("p_f", math.nan)))
        log_a = _log_reference(np.asarray(omega, dtype=float) / (2.0 * omega0_hat), p_f + 1.0)
        if log_a is not None:
            scaled.append(("G2", (("beta", LOG_MEMORY_FREQUENCY), ("p_f", log_a))))
    t_ref = None
    if all(n in names for n in TIME_VARYING):
        w = np.square(np.asarray(omega, dtype=float))
        tt = np.asarray(t, dtype=float)
        good = np.isfinite(w) & np.isfinite(tt)
        if np.sum(w[good]) > 0.0:
            t_ref = float(np.sum(w[good] * tt[good]) / np.sum(w[good]))
    if not scaled and t_ref is None:
        return None
    return Coordinates(scaled=tuple(scaled), t_ref=t_ref)
