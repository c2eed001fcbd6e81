"""Data-derived starting values for a new term's parameters (never a truth).

The fitting package already starts every parameter from an equation-error fit of the data
(:mod:`pendtrack.fitting.leastsq.equation_error`); on a noisy acceleration that can leave a weak term at
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
    if out:
        out.extend(reseated_starts(current, cur, accepted, out[-1], th, om, t, memory_s=memory_s))
    return out


def reseated_starts(current, cur: Mapping[str, float], accepted: Sequence[str], start: Mapping[str, float],
                    th: np.ndarray, om: np.ndarray, t: np.ndarray, *, memory_s: float) -> list[dict[str, float]]:
    """``start`` with each kept term that has a shape (:data:`SHAPES`) put back at its plain shape.

    A term kept earlier may have bent its shape to stand in for the one now tried: on a record
    with an added mass and memory (beta 0.38, p_f 1.6), memory alone fits at beta 0.93 and p_f 2.9,
    partly an added mass, and the added mass then started beside that memory stays near 0 (held-out
    gain 0.003 mrad). From the plain shape the extended fit can reach the other basin. The kept
    term's coefficient is scaled to keep the size of its current contribution to the acceleration
    on the training samples (data-derived).

    Parameters
    ----------
    current : Model
        The current model (baseline + accepted).
    cur : mapping
        Its training fit's parameters.
    accepted : sequence of str
        The terms kept so far.
    start : mapping
        The new term's scaled start (complete).
    th, om, t : ndarray
        The training samples [rad, rad/s, s].
    memory_s : float
        Grunwald-Letnikov memory [s].
    """
    from pendtrack.errors import PendtrackError

    out = []
    for term in accepted:
        coef = COEFFICIENT.get(term)
        if coef is None or coef not in cur or term not in SHAPES:
            continue
        try:  # the term's current share of the acceleration
            now = current.accel(cur, th, om, t, memory_s=memory_s) - current.accel(
                {**cur, coef: 0.0}, th, om, t, memory_s=memory_s)
        except PendtrackError:
            continue
        size_now = float(np.sqrt(np.mean(now ** 2)))
        for shape in SHAPES[term]:
            shape = dict(shape)
            if "t0" in shape:
                shape["t0"] = float(t[0]) + shape["t0"]
            try:
                unit = current.accel({**cur, **shape, coef: 1.0}, th, om, t, memory_s=memory_s) - current.accel(
                    {**cur, **shape, coef: 0.0}, th, om, t, memory_s=memory_s)
            except PendtrackError:
                continue
            size_unit = float(np.sqrt(np.mean(unit ** 2)))
            if not (size_now > 0 and size_unit > 0 and np.isfinite(size_now / size_unit)):
                continue
            out.append({**start, **shape, coef: size_now / size_unit})
    return out


def measurement_starts(term: str, warm: Mapping[str, float], data: AnalysisData,
                       prediction: np.ndarray) -> list[dict[str, float]]:
    """Starts for ``current + term`` with a measurement term: the current fit plus the term at
    0 (the current optimum: nested models) and at its least-squares size on the current
    model's training residual (data-derived, never a truth).

    ``offset``: ``theta_off`` = the residual's mean; ``angle_scale``: ``k_scale`` = the
    regression of the residual on ``prediction^3`` (``theta (1 + k theta^2) - theta = k theta^3``).

    Parameters
    ----------
    term : str
        ``"offset"`` or ``"angle_scale"`` (others: no starts).
    warm : mapping
        The current model's training fit (parameters and ``theta0``/``omega0``).
    data : AnalysisData
    prediction : ndarray
        The current training fit's observed angle over the record [rad].
    """
    keep = ~data.heldout & np.isfinite(prediction)
    if np.count_nonzero(keep) < 10:
        return []
    r = data.theta[keep] - prediction[keep]
    if term == "offset":
        return [{**warm, "theta_off": 0.0}, {**warm, "theta_off": float(np.mean(r))}]
    if term == "angle_scale":
        th3 = prediction[keep] ** 3
        den = float(np.sum(th3 * th3))
        k = float(np.sum(r * th3) / den) if den > 0 else 0.0
        return [{**warm, "k_scale": 0.0}, {**warm, "k_scale": k}]
    return []


def combination_starts(terms: Sequence[str], singles: Mapping[str, Mapping[str, float]],
                       scaled: Mapping[str, Sequence[Mapping[str, float]]]) -> list[dict[str, float]]:
    """Starts for a combination of effects: each single effect's training fit, with the other
    effects' terms at their scaled starts (:func:`scaled_starts`, the :data:`SHARE` one); then each
    single's fit again with the others at their :data:`TINY` starts, that single's optimum itself (the
    models are nested, so the combination's training fit cannot end far above any single's).

    Parameters
    ----------
    terms : sequence of str
        The effects combined.
    singles : mapping
        Effect -> its single training fit (``warm_start`` of it: parameters, ``theta0``,
        ``omega0``); missing when it could not be fitted.
    scaled : mapping
        Effect -> its scaled starts on the current model (complete dicts).
    """
    from pendtrack.models import CATALOGUE

    out = []
    for which in (-1, 0):  # the SHARE starts, then the TINY ones (the nested starts)
        for a in terms:
            if a not in singles:
                continue
            start = dict(singles[a])
            complete = True
            for b in terms:
                if b == a:
                    continue
                if not scaled.get(b):
                    complete = False
                    break
                src = scaled[b][which]
                start.update({p: float(src[p]) for p in CATALOGUE[b].params})
            if complete and start not in out:
                out.append(start)
    return out
