"""Several models fitted jointly to a series of runs, and every decision about what the joint fit writes.

:func:`fit_joint_models` is the one core function behind ``pendtrack fit A B C``, ``batch --joint``
and ``pt.fit([...])`` (the joint twin of :func:`pendtrack.fitting.models_fit.fit_models`): it
takes each run's :class:`~pendtrack.fitting.leastsq.samples.Record` and its zero of theta, fits
each model with :func:`~pendtrack.fitting.joint.fit_joint`, and returns a :class:`JointModelFits`
holding everything the stage writes -- each model's fit_<model>.json, fit.json's content, the
curves of fit_runs.parquet and the stage's facts. The decisions made here:

* the ``offset`` term: added to every model when any run's zero of theta was not measured
  (:func:`~pendtrack.fitting.models_fit.fits_offset` over the runs' zeros), so each run keeps its
  own ``theta_off``;
* the selected model: the converged joint fit with the lowest BIC (same records and cost).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pendtrack.config import FitConfig, ModelsConfig
from pendtrack.fitting.joint.curves import joint_curves
from pendtrack.fitting.joint.outcome import JointFit
from pendtrack.fitting.joint.solve import fit_joint
from pendtrack.fitting.leastsq.samples import Record
from pendtrack.fitting.models_fit import FitFiles, check_models, fits_offset, model_json_name

#: How fit.json's container of joint fits chooses its ``selected`` model.
SELECTED_BY = "lowest bic among converged joint fits (same records and cost)"


@dataclass(frozen=True)
class JointModelFits(FitFiles):
    """The joint fits of several models to a series of runs, and what the stage writes of them (:class:`FitFiles`).

    Attributes
    ----------
    fits : mapping
        Model name (as asked) -> its :class:`~pendtrack.fitting.joint.outcome.JointFit`, in the order fitted.

    ``combined`` is one model's record or ``{"models", "files", "selected", "selected_by",
    "all_converged"}``; ``curves`` are fit_runs.parquet's columns
    (:func:`~pendtrack.fitting.joint.joint_curves`); ``facts``: joint, runs, files, selected,
    not_converged, flagged, models.
    """

    fits: Mapping[str, JointFit]


def fit_joint_models(models: Sequence[str], records: Mapping[str, Record], *, zeros: Mapping[str, str | None],
                     sharing: Mapping[str, str] | None = None, labels: Mapping[str, Mapping[str, str]] | None = None,
                     options: FitConfig = FitConfig(), model_options: ModelsConfig = ModelsConfig(),
                     source: object = None) -> JointModelFits:
    """Fit each model jointly to every run: the joint fit stage's work, files excepted.

    Parameters
    ----------
    models : sequence of str
        Registry names (checked by :func:`~pendtrack.fitting.models_fit.check_models`).
    records : mapping
        Run id -> its record (times [s], angle [rad], angular velocity [rad/s], filter, usable
        samples); at least two.
    zeros : mapping
        Run id -> its zero of theta (the kinematics' ``zero_reference``; None = not recorded).
    sharing : mapping, optional
        Parameter name -> scope, overriding the defaults (:mod:`pendtrack.fitting.joint.scopes`).
    labels : mapping, optional
        Run id -> its run-code labels (``tile``, ``launched``, ``alley``).
    options, model_options : FitConfig, ModelsConfig
        ``[fit]`` (each run's own fit, ``joint_starts``, ``offset``, ``workers``, ...) and ``[models]``.
    source : object, optional
        What a model error names (e.g. the first record's path).

    Returns
    -------
    JointModelFits

    Raises
    ------
    FitError
        No model, a model twice, a bad sharing, a record a fit refuses.
    ModelError
        Unknown model name.
    """
    from pendtrack.fitting.leastsq.ladder import search_pool
    from pendtrack.models import compose

    names = tuple(models)
    model_objs = check_models(names, source=source)
    if any(fits_offset(options.offset, str(zeros.get(run) or "unknown")) for run in records):
        model_objs = {n: m if "offset" in m.terms else compose(m, ["offset"]) for n, m in model_objs.items()}
    fits: dict[str, JointFit] = {}
    workers = search_pool(options.workers)  # one set of worker processes for every model's runs
    try:
        for name, model in model_objs.items():
            fits[name] = fit_joint(model, records, sharing=sharing, labels=labels, options=options,
                                   model_options=model_options, pool=workers)
    finally:
        if workers is not None:
            workers.shutdown(wait=True, cancel_futures=True)
    curves = joint_curves(fits, {r: (rec.t, rec.theta) for r, rec in records.items()})
    return JointModelFits(fits=fits, **joint_payloads(fits, runs=list(records)), curves=curves)


def joint_payloads(fits: Mapping[str, JointFit], *, runs: Sequence[str]) -> dict[str, Any]:
    """fit_<model>.json of each model (``records``, ``files``), fit.json (``combined``) and the stage's ``facts``."""
    records = {n: {**f.to_dict(), "model": n, "fitted_model": f.model} for n, f in fits.items()}
    files = {n: model_json_name(n) for n in fits}
    converged = [n for n, f in fits.items() if f.converged]
    selected = min(converged, key=lambda n: fits[n].bic) if converged else None
    if len(fits) == 1:
        combined = next(iter(records.values()))
    else:
        combined = {"models": records, "files": files, "selected": selected, "selected_by": SELECTED_BY,
                    "all_converged": len(converged) == len(fits)}
    facts = {"joint": True, "runs": list(runs), "files": files, "selected": selected,
             "not_converged": [n for n, f in fits.items() if not f.converged],
             "flagged": {n: dict(f.flags) for n, f in fits.items() if f.flags},
             "models": {n: {"converged": f.converged, "trustworthy": f.trustworthy, "flags": dict(f.flags),
                            "xi2_min": f.xi2_min, "rms": f.rms, "bic": f.bic, "runtime_s": f.runtime_s,
                            "fitted_model": f.model, "message": f.message,
                            "shared": {k: [v.value, v.stderr] for k, v in f.shared.items()}}
                        for n, f in fits.items()}}
    return {"records": records, "files": files, "combined": combined, "facts": facts}
