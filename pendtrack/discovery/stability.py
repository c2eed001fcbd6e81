"""How stable a keep/drop decision is: the share of block-bootstrap records that decide alike.

In the spirit of ensemble-SINDy's inclusion probabilities: a decision of
:mod:`pendtrack.discovery.rules` is re-made on :data:`N_RESAMPLES` records resampled from
the one measured, and its *stability* is the share of them that make the same decision.
Resampling refits nothing: the two models being compared (current and candidate) are
held at their fits, and their residuals are resampled together, by circular blocks as long
as the residual's correlation time (``n / n_eff``, :func:`~pendtrack.discovery.residuals.effective_n`)
so that a resampled record keeps the structure of the measured one. On each resample:

* the test gain and z (held-out or interleaved, :func:`~pendtrack.discovery.residuals.heldout_test`)
  from the resampled test samples (``n_eff`` as measured);
* ``Delta BIC`` shifted by what the resampled whole-record residuals change in
  ``n ln(Xi^2)``: ``dBIC* = dBIC + n (ln(ms_b*/ms_a*) - ln(ms_b/ms_a))`` with ``ms`` the mean
  squared angle residual;
* the whole-record residual RMS lowered or not.

Rules that do not depend on the samples (a flagged fit, a failed fit) decide alike on every
resample. A candidate not refitted on the whole record (it failed the test) has no
``Delta BIC``: a resample on which it passes the test counts as deciding otherwise (its
BIC is unknown), so its stability is a lower bound.

A decision whose stability is below :data:`BORDERLINE` is called borderline.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pendtrack.discovery.residuals import effective_n

N_RESAMPLES = 200  # 1/200 resolution; a stability of 80 % is known to +-3 % (binomial)
BORDERLINE = 0.8  # below this share of resamples deciding alike a verdict is called borderline


@dataclass(frozen=True)
class Rules:
    """The thresholds a decision is made by (``[discover]``)."""

    heldout_z_min: float
    min_gain: float
    delta_bic_max: float


def _blocks(n: int, block: int, n_resamples: int, rng: np.random.Generator) -> np.ndarray:
    """Indices ``(n_resamples, n)`` of circular block-bootstrap records of ``n`` samples."""
    block = int(min(max(block, 1), max(n // 4, 1)))
    n_blocks = -(-n // block)
    starts = rng.integers(0, n, size=(n_resamples, n_blocks))
    idx = (starts[:, :, None] + np.arange(block)[None, None, :]) % n
    return idx.reshape(n_resamples, -1)[:, :n]


def _block_length(residual: np.ndarray) -> int:
    return int(math.ceil(residual.size / effective_n(residual)))


def _test_passes(theta: np.ndarray, a: np.ndarray, b: np.ndarray, rms_ref: float, rules: Rules,
                 idx: np.ndarray) -> np.ndarray:
    """The test of :func:`~pendtrack.discovery.rules.passes_heldout` on each resample."""
    e_a, e_b, d = theta - a, theta - b, b - a
    n_eff = effective_n(e_b)
    ms_a = np.mean(e_a[idx] ** 2, axis=1)
    ms_b = np.mean(e_b[idx] ** 2, axis=1)
    md2 = np.mean(d[idx] ** 2, axis=1)
    gain = np.sqrt(ms_a) - np.sqrt(ms_b)
    sd = 2.0 * np.sqrt(ms_b * md2 / n_eff)
    z = np.where(md2 > 0, (ms_a - ms_b) / np.where(sd > 0, sd, np.inf), 0.0)
    return (gain > 0) & (z > rules.heldout_z_min) & (gain >= rules.min_gain * rms_ref)


def decision_stability(*, kept: bool, test: tuple[np.ndarray, np.ndarray, np.ndarray] | None, test_rms_ref: float,
                       whole: tuple[np.ndarray, np.ndarray, np.ndarray] | None, delta_bic: float, n_bic: int,
                       rules: Rules, fixed: bool = False, seed: int = 0,
                       n_resamples: int = N_RESAMPLES) -> float:
    """Share of block-bootstrap records on which the decision comes out as ``kept``.

    Parameters
    ----------
    kept : bool
        The decision made on the record.
    test : (theta, pred_a, pred_b) or None
        The test samples (held-out part, or the interleaved folds' pooled predictions) and the
        current and candidate predictions there [rad].
    test_rms_ref : float
        The current model's test RMS (the base of the minimum gain) [rad].
    whole : (theta, traj_a, traj_b) or None
        The whole-record data and both whole-record fits [rad]; None when the candidate was not
        refitted on the whole record.
    delta_bic : float
        BIC of the candidate minus the current model's (NaN when not refitted).
    n_bic : int
        The ``n`` of the BIC (samples in the cost).
    rules : Rules
    fixed : bool
        The decision does not depend on the samples (a flagged or failed fit): stability 1.
    seed : int
    n_resamples : int

    Returns
    -------
    float
        In [0, 1].
    """
    if fixed or test is None:
        return 1.0
    theta, a, b = (np.asarray(x, dtype=float) for x in test)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return 1.0
    rng = np.random.default_rng([seed, theta.size, n_resamples])
    idx = _blocks(theta.size, _block_length(theta - b), n_resamples, rng)
    ok = _test_passes(theta, a, b, test_rms_ref, rules, idx)
    if whole is None or not math.isfinite(delta_bic):
        same = ~ok if not kept else np.zeros(n_resamples, dtype=bool)
        return float(np.mean(same))
    th, ta, tb = (np.asarray(x, dtype=float) for x in whole)
    ra2, rb2 = (th - ta) ** 2, (th - tb) ** 2
    widx = _blocks(th.size, _block_length(th - tb), n_resamples, rng)
    ms_a, ms_b = np.mean(ra2[widx], axis=1), np.mean(rb2[widx], axis=1)
    shift = n_bic * (np.log(ms_b / ms_a) - math.log(float(np.mean(rb2)) / float(np.mean(ra2))))
    decided = ok & (delta_bic + shift < rules.delta_bic_max) & (ms_b < ms_a)
    return float(np.mean(decided == kept))
