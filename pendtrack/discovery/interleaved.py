"""Interleaved-block cross-validation: a test that is not an extrapolation.

Two uses: a measurement term (:func:`interleaved_test`, below) and an effect that acts early in
the run and fades (:func:`refit_folds`, :func:`out_of_fold_test`: the models are refitted on each fold
by :meth:`pendtrack.discovery.exchange.Context.refit_test`; the first block, the release, is in
both folds, so each fold's fit starts where the record does).

A measurement term (theta's zero offset, an angle-scale error) shifts every sample of the
record, early and late alike. Judging it by how a training fit on the first part of the
record extrapolates into the rest (the effects' held-out test,
:mod:`pendtrack.discovery.rules`) mixes it with the baseline's dephasing, which grows
with time: on lab1 the baseline's held-out error is 20.7 mrad of dephasing against a 10 mrad
offset, and whether the offset's held-out z came out 0.7 or 4 turned on the rounding of
the physics fits. This test asks instead whether the term, estimated on one half of the
record, predicts the other half:

* the record is cut into ``n_blocks`` blocks of equal length; the even blocks are fold A, the
  odd ones fold B, so each fold spans the whole run (a zero that drifts, 12.9 mrad early and
  7.3 mrad late on lab1, is seen alike by both);
* the physics is held at the current model's whole-record fit (the same for the model with
  and without the term, so it favours neither), and the term's parameter, linear in the
  observation to first order (``theta_off``: a constant; ``k_scale``: ``theta^3``), is
  estimated by least squares on the residual of one fold and predicts the other;
* the pooled out-of-fold predictions are judged by the same gain and z as the held-out test
  (:func:`pendtrack.discovery.residuals.heldout_test`, the autocorrelation-corrected standard
  error) against the current model.

A record without the artefact gives a term estimated from noise (and from structure the
physics misses, which the other fold does not share in sign) that predicts the other fold
no better: a gain below 0 on average, z > 3 with p ~ 0.0014.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pendtrack.discovery.residuals import heldout_test

N_BLOCKS = 10  # 5 blocks per fold: each spans the record; a 60-s record's blocks hold ~5 oscillations


@dataclass(frozen=True, eq=False)
class FoldTest:
    """The interleaved test of one measurement term against the current model.

    Attributes
    ----------
    term : str
    gain : float
        RMS of the current model's residual minus that of the out-of-fold prediction [rad].
    z : float
        Significance of the mean-square gain (:func:`~pendtrack.discovery.residuals.heldout_test`) [1].
    rms_before, rms_after : float
        Residual RMS of the current model and of the out-of-fold prediction [rad].
    estimates : tuple of float
        The term's parameter estimated on fold A and on fold B [its unit].
    prediction : ndarray
        The out-of-fold prediction over the record [rad].
    """

    term: str
    gain: float
    z: float
    rms_before: float
    rms_after: float
    estimates: tuple[float, float]
    prediction: np.ndarray
    reference: np.ndarray | None = None  # the current model's prediction it is judged against (None: its fit)
    mask: np.ndarray | None = None  # the samples judged (None: all)
    name: str = "interleaved"  # the test: "interleaved" (a measurement term) or "refit_folds" (an effect)


def folds(n: int, n_blocks: int = N_BLOCKS) -> np.ndarray:
    """Fold (0 or 1) of each of ``n`` samples: blocks of equal length, alternating."""
    block = np.minimum((np.arange(n) * n_blocks) // max(n, 1), n_blocks - 1)
    return (block % 2).astype(np.int8)


def refit_folds(n: int, n_blocks: int = N_BLOCKS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Training masks of the two folds of a refit test, and the samples it judges.

    The record is cut into ``n_blocks + 1`` blocks of equal length. The first block is in both
    training folds and judged in neither: a model refitted on a fold is simulated from the
    record's start, so each fold must see the release (the initial state and the first
    oscillations); the other blocks alternate, so each fold spans the run.

    Returns
    -------
    fold_a, fold_b, judged : ndarray of bool
    """
    block = np.minimum((np.arange(n) * (n_blocks + 1)) // max(n, 1), n_blocks)
    first = block == 0
    return first | (block % 2 == 1), first | ((block % 2 == 0) & ~first), ~first


def out_of_fold_test(theta: np.ndarray, reference: np.ndarray, prediction: np.ndarray, judged: np.ndarray,
                     term: str) -> FoldTest:
    """The refit test's numbers: the out-of-fold predictions of the model with ``term`` against
    those of the current model, on the ``judged`` samples (:func:`refit_folds`).

    Parameters
    ----------
    theta : ndarray
        The record's angle [rad].
    reference, prediction : ndarray
        Out-of-fold predictions over the record of the current model and of the model with the
        term (each fold's fit simulated over the record, read on the other fold) [rad].
    judged : ndarray of bool
    term : str
    """
    gain, z = heldout_test(theta[judged], reference[judged], prediction[judged])
    rms = lambda p: float(np.sqrt(np.mean((theta[judged] - p[judged]) ** 2)))  # noqa: E731
    return FoldTest(term=term, gain=gain, z=z, rms_before=rms(reference), rms_after=rms(prediction),
                    estimates=(math.nan, math.nan), prediction=prediction, reference=reference, mask=judged,
                    name="refit_folds")


def column(term: str, trajectory: np.ndarray) -> np.ndarray | None:
    """The observation's first-order change per unit of the term's parameter, or None.

    The observation is ``(theta + theta_off)(1 + k_scale (theta + theta_off)^2)``
    (:meth:`pendtrack.models.Model.observe`): ``offset`` -> 1 (the scale, if kept, is a
    higher-order correction); ``angle_scale`` -> the observed angle cubed (``k_scale`` = 0 in
    a model without the term, whose observation is ``theta + theta_off``).
    """
    if term == "offset":
        return np.ones_like(trajectory)
    if term == "angle_scale":
        return trajectory**3
    return None


def interleaved_test(theta: np.ndarray, trajectory: np.ndarray, term: str, *, n_blocks: int = N_BLOCKS) -> FoldTest | None:
    """Estimate ``term`` on each fold of the current model's residual, predict the other fold.

    Parameters
    ----------
    theta : ndarray
        The record's angle [rad].
    trajectory : ndarray
        The current model's whole-record fit as observed (its measurement terms applied) [rad].
    term : str
        ``"offset"`` or ``"angle_scale"``.
    n_blocks : int
        Blocks the record is cut into (alternating folds).

    Returns
    -------
    FoldTest or None
        None for a term without a first-order column, or a trajectory that is not finite.
    """
    x = column(term, trajectory)
    if x is None or not np.all(np.isfinite(trajectory)):
        return None
    r = theta - trajectory
    fold = folds(theta.size, n_blocks)
    pred = np.array(trajectory, dtype=float)
    est = []
    for f in (0, 1):
        fit_on = fold == f
        den = float(np.sum(x[fit_on] ** 2))
        c = float(np.sum(x[fit_on] * r[fit_on]) / den) if den > 0 else 0.0
        est.append(c)
        pred[~fit_on] += c * x[~fit_on]
    gain, z = heldout_test(theta, trajectory, pred)
    return FoldTest(term=term, gain=gain, z=z, rms_before=float(np.sqrt(np.mean(r * r))),
                    rms_after=float(np.sqrt(np.mean((theta - pred) ** 2))), estimates=(est[0], est[1]),
                    prediction=pred)
