"""A stand-in for a FitProblem in tests of the machinery around local fits (profile polish, profile scans):
beta and G2, bounds [0, 1], and ``with_fixed`` as the real one; the local fit itself is faked by each test."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class StandInProblem:
    """Stands in for a FitProblem: beta and one other parameter, bounds [0, 1]."""

    fixed: dict = field(default_factory=dict)
    names: tuple = ("beta", "G2")
    t_end: float = 40.0

    @property
    def lower(self) -> np.ndarray:
        return np.zeros(len(self.names) - len(self.fixed))

    @property
    def upper(self) -> np.ndarray:
        return np.ones(len(self.names) - len(self.fixed))

    def with_fixed(self, fixed: dict) -> "StandInProblem":
        return StandInProblem(fixed=dict(fixed))
