"""One model fitted jointly to several runs of one pendulum.

Public API::

    fit_joint(model, records, *, sharing, labels, options, model_options, seed, workers, pool) -> JointFit
    resolve_scopes(model, sharing, *, labels) -> {name: scope}      # the defaults, overridden, checked
    sharing_from_lists(shared=..., per_run=..., per_group=...) -> {name: scope text}
    joint_curves(fits, records, *, models) -> fit_runs.parquet's columns   # each run's fitted curves
    fit_joint_models(models, records, *, zeros, sharing, labels, options, model_options, source) -> JointModelFits

The runs share parameters across all runs, per group of runs (by the run codes' tile, launch and
alley) or per run (:mod:`~pendtrack.fitting.joint.scopes`); the joint residual stacks each run's
single-run problem (:mod:`~pendtrack.fitting.joint.stacked`); the steps are the single fit's
(:mod:`~pendtrack.fitting.joint.solve`); the result and fit_<model>.json's shape are in
:mod:`~pendtrack.fitting.joint.outcome`; each run's fitted curves in :mod:`~pendtrack.fitting.joint.curves`;
several models fitted to the same runs (the offset term, the selection, what the stage writes) in
:mod:`~pendtrack.fitting.joint.series`.
"""

from __future__ import annotations

from pendtrack.fitting.joint.curves import joint_curves
from pendtrack.fitting.joint.outcome import JointFit, JointRun
from pendtrack.fitting.joint.scopes import default_scopes, parse_scope, resolve_scopes, sharing_from_lists
from pendtrack.fitting.joint.series import JointModelFits, fit_joint_models
from pendtrack.fitting.joint.solve import fit_joint

__all__ = ["JointFit", "JointModelFits", "JointRun", "default_scopes", "fit_joint", "fit_joint_models", "joint_curves",
           "parse_scope", "resolve_scopes", "sharing_from_lists"]
