"""The paper's relations between the classic and the fractional fits of one run.

Dividing the classic model (eq. classicmodel) by ``(2 Omega0)^2`` and writing it in
``A_omega = omega/(2 Omega0)`` and ``t* = 2 Omega0 t`` (eq. ourfinalmodel) gives, term by term,

* ``G1 ~ C0 / (4 Omega0^2)``            (Coulomb friction, caption of fig. paramsfractional);
* ``G2 ~ C3 / (2^(2-p) Omega0^2)``      (power-law drag: ``|omega/Omega0|^p = 2^p |A_omega|^p``);
* ``p_f - beta ~ p``                      (eq. pubetapproxptwo: a derivative of order beta
  lowers the degree of ``A|A|^(p_f-1)`` by beta).

They are approximations (the fractional friction is ``|A|^(1/4)``, not constant), so the
numbers are reported with their uncertainties and a z-score, not tested. Uncertainties are
propagated with each fit's sandwich covariance (delta method); the two fits share the data,
so the z-score, which treats them as independent, is indicative only. The right-hand sides
use the classic fit's Omega0.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from pendtrack.errors import FitError
from pendtrack.fitting.result import FitResult, _num

CLASSIC_NEEDS = ("Omega0", "C0", "C3", "p")
FRACTIONAL_NEEDS = ("G1", "G2", "beta", "p_f")


@dataclass(frozen=True)
class Relation:
    """``lhs ~ rhs`` with both sides' standard errors.

    Attributes
    ----------
    name : str
        The relation as text.
    lhs, lhs_stderr : float
        Fractional-model side and its standard error [1].
    rhs, rhs_stderr : float
        Classic-model side and its standard error [1].
    """

    name: str
    lhs: float
    lhs_stderr: float
    rhs: float
    rhs_stderr: float

    @property
    def ratio(self) -> float:
        """lhs / rhs [1]."""
        return self.lhs / self.rhs if self.rhs != 0 and math.isfinite(self.rhs) else math.nan

    @property
    def z(self) -> float:
        """(lhs - rhs) / sqrt(se_lhs^2 + se_rhs^2), treating the two fits as independent [1]."""
        se = math.hypot(self.lhs_stderr, self.rhs_stderr)
        return (self.lhs - self.rhs) / se if se > 0 else math.nan

    def to_dict(self) -> dict[str, Any]:
        return {"relation": self.name, "lhs": _num(self.lhs), "lhs_stderr": _num(self.lhs_stderr),
                "rhs": _num(self.rhs), "rhs_stderr": _num(self.rhs_stderr), "ratio": _num(self.ratio),
                "z": _num(self.z)}


@dataclass(frozen=True)
class CrossModel:
    """The three relations, and whether both fits converged (otherwise they mean little)."""

    relations: tuple[Relation, ...]
    both_converged: bool

    def __getitem__(self, key: str) -> Relation:
        for r in self.relations:
            if r.name.startswith(key):
                return r
        raise KeyError(key)

    def to_dict(self) -> dict[str, Any]:
        return {"both_converged": self.both_converged,
                "relations": {r.name.split(" ")[0]: r.to_dict() for r in self.relations}}


def _propagate(result: FitResult, grads: Mapping[str, float]) -> float:
    """sqrt(g^T C g) over the fitted parameters (fixed ones contribute nothing) [unit of f]."""
    names = list(result.fitted_names)
    cov = np.asarray(result.covariance, dtype=float)
    g = np.zeros(len(names))
    for k, v in grads.items():
        if k in names:
            g[names.index(k)] = v
    var = float(g @ cov @ g) if cov.shape == (len(names), len(names)) else math.nan
    return math.sqrt(var) if var >= 0 else math.nan


def _pow2(x: float) -> float:
    """2**x, ``inf`` where it overflows (a drag exponent far out on a fit that failed)."""
    try:
        return 2.0**x
    except OverflowError:
        return math.inf


def cross_model_relations(classic: FitResult, fractional: FitResult) -> CrossModel:
    """G1 vs C0/(4 Omega0^2), G2 vs C3/(2^(2-p) Omega0^2), p_f - beta vs p.

    Parameters
    ----------
    classic : FitResult
        Fit of a model with ``Omega0, C0, C3, p`` (the classic model).
    fractional : FitResult
        Fit of a model with ``G1, G2, beta, p_f`` (the fractional model).

    Returns
    -------
    CrossModel

    Raises
    ------
    FitError
        A fit lacks one of the parameters.
    """
    for res, needs in ((classic, CLASSIC_NEEDS), (fractional, FRACTIONAL_NEEDS)):
        missing = [n for n in needs if n not in res.params]
        if missing:
            raise FitError(f"model '{res.model}' has no parameter '{missing[0]}' for the cross-model relations")
    c = classic.values
    f = fractional.values
    w0, c0, c3, p = c["Omega0"], c["C0"], c["C3"], c["p"]
    se = {k: v.stderr for k, v in fractional.params.items()}

    g1_rhs = c0 / (4 * w0**2)
    g1_se = _propagate(classic, {"C0": 1 / (4 * w0**2), "Omega0": -2 * g1_rhs / w0})
    scale = _pow2(p - 2.0) / w0**2
    g2_rhs = c3 * scale
    g2_se = _propagate(classic, {"C3": scale, "p": g2_rhs * math.log(2.0),
                                 "Omega0": -2 * g2_rhs / w0})
    pf_beta = f["p_f"] - f["beta"]
    pf_beta_se = _propagate(fractional, {"p_f": 1.0, "beta": -1.0})
    relations = (
        Relation("G1 ~ C0/(4 Omega0^2)", f["G1"], se["G1"], g1_rhs, g1_se),
        Relation("G2 ~ C3/(2^(2-p) Omega0^2)", f["G2"], se["G2"], g2_rhs, g2_se),
        Relation("p_f-beta ~ p", pf_beta, pf_beta_se, p, classic.params["p"].stderr),
    )
    return CrossModel(relations=relations, both_converged=bool(classic.converged and fractional.converged))
