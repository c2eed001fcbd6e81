"""Data-derived starting values for a new term's parameters (never a truth).

The fitting package already starts every parameter from an equation-error fit of the data
(:mod:`pendtrack.fitting.estimates`); on a noisy acceleration that can leave a weak term at
zero, its shape parameters at the edge of their grid, or the old parameters far from their
optimum. So each candidate also gets a few *scaled* starts from the current model's fit:
the term's shape parameters at plain values (memory: beta, p_f around the
middle of their usual range; power drag: p = 1.5; time-varying damping: t0 ten seconds
before the record) and its coefficient scaled so that, evaluated on the measured
(theta, omega) of the training part, the new term is :data:`SHARE` of the RMS of the current
model's non-gravitational acceleration -- a small, data-derived size -- plus one start at
:data:`TINY` of it, which is the current optimum itself: since the models are nested, the
extended fit then cannot end worse than the current one on the training data.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from pendtrack.discovery.data import AnalysisData

SHARE = 0.3  # the new term starts at 30 % of the current model's dissipation/inertia RMS
TINY = 0.01  # ... and at 1 %: the current fit itself, so the extended fit can only improve on it

COEFFICIENT = {"added_mass": "Ca", "time_varying_damping": "C4", "memory": "G2", "power_drag": "C3",
               "viscous": "C1", "coulomb": "C0", "quadratic_drag": "C2"}
SHAPES: dict[str, tuple[dict[str, float], ...]] = {
    "memory": ({"beta": 0.5, "p_f": 1.5},),
    "power_drag": ({"p": 1.5},),
    "time_varying_damping": ({"t0": -10.0},),  # relative to the record's start [s]
}


def scaled_starts(baseline: str, accepted: Sequence[str], effect: str, warm: Mapping[str, float],
                  data: AnalysisData, *, memory_s: float) -> list[dict[str, float]]:
    """Starts for ``baseline + accepted + effect``: the current fit plus the scaled new term.

    Parameters
    ----------
    baseline : str
    accepted : sequence of str
        Terms already added.
    effect : str
        The new term.
    warm : mapping
        The current model's training fit (parameters and ``theta0``/``omega0``).
    data : AnalysisData
    memory_s : float
        Grunwald-Letnikov memory [s].

    Returns
    -------
    list of dict
        Full starting dicts (may be empty if the term has no scalable coefficient).
    """
    from pendtrack.errors import PendtrackError
    from pendtrack.models import compose, get_model

    coef = COEFFICIENT.get(effect)
    if coef is None:
        return []
    current = compose(baseline, list(accepted)) if accepted else get_model(baseline)
    model = compose(baseline, [*accepted, effect])
    keep = ~data.heldout
    t, th, om = data.t[keep], data.theta[keep], data.omega[keep]
    cur = {k: float(warm[k]) for k in current.param_names}
    try:
        a_cur = current.accel(cur, th, om, t, memory_s=memory_s)
    except PendtrackError:
        return []
    w0 = cur["Omega0"]
    scale = float(np.sqrt(np.mean((a_cur + w0 * w0 * np.sin(th)) ** 2)))
    out = []
    for shape in SHAPES.get(effect, ({},)):
        shape = dict(shape)
        if "t0" in shape:
            shape["t0"] = float(t[0]) + shape["t0"]
        base = {**cur, **shape}
        try:
            one = model.accel({**base, coef: 1.0}, th, om, t, memory_s=memory_s)
            zero = model.accel({**base, coef: 0.0}, th, om, t, memory_s=memory_s)
        except PendtrackError:
            continue
        size = float(np.sqrt(np.mean((one - zero) ** 2)))
        if not (size > 0 and np.isfinite(size) and scale > 0):
            continue
        if not out:  # one start at the current optimum (nested models: the cost can only go down)
            out.append({**warm, **shape, coef: TINY * scale / size})
        out.append({**warm, **shape, coef: SHARE * scale / size})
    return out
