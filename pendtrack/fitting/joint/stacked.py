"""Several runs' fitting problems as one least-squares problem over a joint parameter vector.

Each run keeps its own :class:`~pendtrack.fitting.leastsq.problem.FitProblem` (its grid, its
filter, its Xi^2 scale, its simulator); the joint vector holds one entry per parameter and group
(:mod:`pendtrack.fitting.joint.scopes`), and :attr:`StackedProblem.columns` maps each run's fitted
vector onto it. The joint residual is the runs' residual vectors stacked, run ``i``'s scaled by
``sqrt(n_i / N)`` (``n_i`` its samples, ``N`` all of them): every sample weighs the same and the
joint cost is the Xi^2 of all samples pooled.

A :class:`StackedProblem` offers what the single-run local fit uses (:func:`pendtrack.fitting.
leastsq.local_fits.local_fit`: residuals, bounds, the ladder's shorter windows, a Jacobian), so
the joint search runs the very same Levenberg-Marquardt ladder. Its time axis is the time since
each run's first fitted sample: a window ``[0, L]`` is the first ``L`` seconds of every run.
Its Jacobian is assembled from the runs' own (sensitivity equations where the run's problem has
them, finite differences otherwise): one simulation set per run, never one per joint column.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from pendtrack.fitting.leastsq.coordinates import Coordinates
from pendtrack.fitting.leastsq.cost import Observation
from pendtrack.fitting.leastsq.problem import FitProblem


@dataclass(frozen=True, eq=False)
class StackedProblem:
    """The runs' problems over one joint vector.

    Attributes
    ----------
    runs : tuple of str
        Run ids, in order.
    problems : tuple of FitProblem
        Each run's problem (its fitted vector: ``problem.names``).
    names : tuple of str
        Labels of the joint vector (:func:`pendtrack.fitting.joint.scopes.column_label`).
    columns : tuple of ndarray of int
        Per run, the joint column of each of its fitted names.
    lower, upper : ndarray
        Bounds of the joint vector (the tightest of the runs' bounds on each column).
    """

    runs: tuple[str, ...]
    problems: tuple[FitProblem, ...]
    names: tuple[str, ...]
    columns: tuple[np.ndarray, ...]
    lower: np.ndarray
    upper: np.ndarray
    coordinates: Coordinates | None = None  # the steps' coordinates over the joint labels (joint_coordinates)

    t_start = 0.0  # time since each run's first fitted sample [s]

    @property
    def t_end(self) -> float:
        """The longest run's fitted duration [s]."""
        return max(p.t_end - p.t_start for p in self.problems)

    @property
    def n(self) -> int:
        """Samples of every run in the cost."""
        return sum(p.n for p in self.problems)

    @property
    def h(self) -> float:
        """The coarsest sampling step of the runs [s]."""
        return max(p.h for p in self.problems)

    @property
    def observation(self) -> Observation:
        """The filter with the widest trim (what a warm-up window must hold)."""
        return max((p.observation for p in self.problems), key=lambda o: o.trim)

    @cached_property
    def weights(self) -> np.ndarray:
        """``sqrt(n_i / N)`` of each run."""
        n = np.array([p.n for p in self.problems], dtype=float)
        return np.sqrt(n / n.sum())

    @cached_property
    def rows(self) -> tuple[slice, ...]:
        """Each run's rows of the stacked residual vector."""
        out, start = [], 0
        for p in self.problems:
            size = p.n * (2 if p.cost == "xi2" else 1)
            out.append(slice(start, start + size))
            start += size
        return tuple(out)

    def run_x(self, x: np.ndarray, i: int) -> np.ndarray:
        """Run ``i``'s fitted vector (its ``problem.names`` order) from the joint vector."""
        return np.asarray(x, dtype=float)[self.columns[i]]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """The runs' residual vectors, stacked and weighted (sum of squares = the pooled cost)."""
        return np.concatenate([w * p.residuals(self.run_x(x, i))
                               for i, (p, w) in enumerate(zip(self.problems, self.weights))])

    def cost_value(self, x: np.ndarray) -> float:
        """The pooled cost (Xi^2 of all samples)."""
        r = self.residuals(x)
        return float(r @ r)

    def _assemble(self, blocks: list[np.ndarray]) -> np.ndarray:
        jac = np.zeros((self.rows[-1].stop, len(self.names)), order="F")
        for i, (block, w) in enumerate(zip(blocks, self.weights)):
            jac[self.rows[i], self.columns[i]] = w * block
        return jac

    def jacobian(self, x: np.ndarray, *, central: bool = False, rel: float | None = None,
                 method: str | None = None) -> np.ndarray:
        """Jacobian of :meth:`residuals`, from each run's :meth:`FitProblem.jacobian` (same arguments)."""
        return self._assemble([p.jacobian(self.run_x(x, i), central=central, rel=rel, method=method)
                               for i, p in enumerate(self.problems)])

    def uses_sensitivities(self, method: str | None = None) -> bool:
        """Always True: the local fit takes :meth:`jacobian_sensitivity`, which assembles the runs' own."""
        return True

    def jacobian_sensitivity(self, x: np.ndarray, *, steer: bool = False) -> np.ndarray:
        """The steering Jacobian: each run's sensitivity one where it has them, its finite differences otherwise."""
        blocks = []
        for i, p in enumerate(self.problems):
            xi = self.run_x(x, i)
            jac = p.jacobian_sensitivity(xi, steer=steer) if p.uses_sensitivities() else None
            blocks.append(p.jacobian(xi, method="fd") if jac is None else jac)
        return self._assemble(blocks)

    def fd_steps(self, x: np.ndarray, rel: float | None = None) -> np.ndarray:
        """Finite-difference steps of the joint vector: the largest any run takes for a column."""
        steps = np.zeros(len(self.names))
        for i, p in enumerate(self.problems):
            np.maximum.at(steps, self.columns[i], p.fd_steps(self.run_x(x, i), rel))
        return steps

    def restrict(self, t_end: float) -> "StackedProblem":
        """The first ``t_end`` seconds of every run."""
        return self._windowed([p.restrict(p.t_start + t_end) for p in self.problems])

    def rung(self, t_end: float) -> "StackedProblem":
        """The first ``t_end`` seconds of every run, as a rung of the ladder (:meth:`FitProblem.rung`)."""
        return self._windowed([p.rung(p.t_start + t_end) for p in self.problems])

    def with_fixed(self, fixed: Mapping[str, float]) -> "StackedProblem":
        """The same runs with some joint columns held at given values (by label): the profile's inner fits.

        Every run using a held column holds its own name at that value; the other columns keep
        their order.

        Raises
        ------
        ValueError
            A label that is no column.
        """
        unknown = [k for k in fixed if k not in self.names]
        if unknown:
            raise ValueError(f"cannot fix unknown joint parameter {unknown[0]!r}")
        problems, labels_of = [], []
        for p, cols in zip(self.problems, self.columns):
            labels = {n: self.names[j] for n, j in zip(p.names, cols)}
            own = {n: float(fixed[lab]) for n, lab in labels.items() if lab in fixed}
            q = p.with_fixed(own) if own else p
            problems.append(q)
            labels_of.append({n: labels[n] for n in q.names})
        return stack(self.runs, tuple(problems), labels_of)

    def _windowed(self, problems: list[FitProblem]) -> "StackedProblem":
        if all(a is b for a, b in zip(problems, self.problems)):
            return self
        return replace(self, problems=tuple(problems))


def stack(runs: tuple[str, ...], problems: tuple[FitProblem, ...],
          labels_of: list[dict[str, str]]) -> StackedProblem:
    """The :class:`StackedProblem` of the runs' problems, given each run's name -> joint label.

    Parameters
    ----------
    runs : tuple of str
        Run ids.
    problems : tuple of FitProblem
        Their problems.
    labels_of : list of dict
        Per run, each fitted name -> its joint column's label
        (:func:`pendtrack.fitting.joint.scopes.column_label`).
    """
    names: list[str] = []
    lower: list[float] = []
    upper: list[float] = []
    columns = []
    for p, labels in zip(problems, labels_of):
        cols = []
        for k, name in enumerate(p.names):
            label = labels[name]
            if label not in names:
                names.append(label)
                lower.append(-math.inf)
                upper.append(math.inf)
            j = names.index(label)
            lower[j] = max(lower[j], float(p.lower[k]))
            upper[j] = min(upper[j], float(p.upper[k]))
            cols.append(j)
        columns.append(np.array(cols, dtype=np.int64))
    return StackedProblem(runs=tuple(runs), problems=tuple(problems), names=tuple(names), columns=tuple(columns),
                          lower=np.array(lower), upper=np.array(upper),
                          coordinates=joint_coordinates(problems, labels_of))


def joint_coordinates(problems: tuple[FitProblem, ...], labels_of: list[dict[str, str]]) -> Coordinates | None:
    """The decorrelated coordinates of the joint vector, from the runs' own (None: none applies).

    A joint amplitude column (e.g. ``C3`` of one tile and alley) steps in its value at a reference, as a
    single fit's does (:mod:`pendtrack.fitting.leastsq.coordinates`), when every run using it takes each
    of its exponents from one joint column (``p`` of that tile and alley, or a shared ``p``); the
    reference's logarithm is the mean of those runs' own. An amplitude whose exponent is fitted per run
    where the amplitude is not keeps its own coordinate, and so does the time-varying damping (its ``t0``
    is per run): only the steps' path changes, never the minimum.
    """
    refs: dict[str, dict[str, dict[str, list[float]]]] = {}  # amplitude label -> exponent name -> label -> logs
    order: list[tuple[str, tuple[str, ...]]] = []
    for p, labels in zip(problems, labels_of):
        if p.coordinates is None:
            continue
        for amp, exps in p.coordinates.scaled:
            if amp not in labels:
                continue
            entry = refs.setdefault(labels[amp], {})
            if not entry:
                order.append((labels[amp], tuple(e for e, _ in exps)))
            for e, lg in exps:
                if e in labels:
                    entry.setdefault(e, {}).setdefault(labels[e], []).append(float(lg))
    scaled = []
    for amp, exp_names in order:
        entry = refs[amp]
        if any(len(entry.get(e, {})) > 1 for e in exp_names):
            continue  # an exponent in several columns under one amplitude: no single reference
        used = tuple((label, float(np.mean(logs))) for e in exp_names for label, logs in entry.get(e, {}).items())
        if used:
            scaled.append((amp, used))
    return Coordinates(scaled=tuple(scaled)) if scaled else None
