"""The curves of joint fits: each run's jointly fitted model on that run's times (``fit_runs.parquet``).

Each run is simulated from its own fitted initial state at the start of its window with the
values it takes at the joint optimum (:meth:`~pendtrack.fitting.joint.outcome.JointFit.run_result`),
through the model's measurement terms (a run's ``theta_off``): the curves a single fit's
fit.parquet holds (:func:`pendtrack.fitting.models_fit.fit_curves`), one block per model and run.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from pendtrack.fitting.joint.outcome import JointFit
from pendtrack.fitting.models_fit import fit_curves


def joint_curves(fits: Mapping[str, JointFit], records: Mapping[str, tuple[np.ndarray, np.ndarray]], *,
                 models: Mapping[str, Any] | None = None) -> dict[str, np.ndarray]:
    """fit_runs.parquet's columns: per model and run, the jointly fitted curves on the run's times, stacked.

    Parameters
    ----------
    fits : mapping
        Model name -> its :class:`~pendtrack.fitting.joint.outcome.JointFit`.
    records : mapping
        Run id -> (times [s], measured angle [rad]) of that run; every run of every fit.
    models : mapping, optional
        Model name -> the fitted model (its measurement terms included); default
        :func:`pendtrack.models.get_model` of each fit's ``model``.

    Returns
    -------
    dict
        Columns ``t`` [s], ``theta``, ``theta_model`` [rad], ``omega_model`` [rad/s], ``residual``
        [rad], ``model`` and ``run`` (object arrays). A model whose curve cannot be integrated and
        whose joint fit did not converge gets NaN curves (as in fit.parquet).
    """
    from pendtrack.models import get_model

    blocks: list[dict[str, np.ndarray]] = []
    for name, fit in fits.items():
        model = models[name] if models is not None else get_model(fit.model)
        for run in fit.runs:
            t, theta = (np.asarray(a, dtype=float) for a in records[run])
            cols = fit_curves({name: fit.run_result(run)}, {name: model}, t, theta)
            blocks.append({**cols, "run": np.full(t.size, run, dtype=object)})
    keys = ("t", "theta", "theta_model", "omega_model", "residual", "model", "run")
    return {k: np.concatenate([b[k] for b in blocks]) if blocks else np.zeros(0) for k in keys}
