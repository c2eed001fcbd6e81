"""Stages: read -> pure core -> write + provenance. The CLI only parses and calls these.

Every stage function has the shape::

    def xxx_stage(inputs..., *, out_dir: Path, config: Config, force: bool = False,
                  progress: bool = True) -> StageOutput

and uses :func:`up_to_date` so that an output made from the same inputs and config is
not recomputed unless ``force``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pendtrack.artifacts import is_up_to_date


@dataclass(frozen=True)
class StageOutput:
    """What a stage wrote (or found up to date)."""

    paths: tuple[Path, ...]
    skipped: bool = False
    facts: Mapping[str, Any] = field(default_factory=dict)  # figures worth printing (fps, ok fraction...)

    @property
    def path(self) -> Path:
        return self.paths[0]


def up_to_date(paths: tuple[Path, ...], kind: str, *, inputs: Mapping[str, str],
               config: Mapping[str, Any], force: bool) -> bool:
    """True when every output exists with the same inputs and config, and not ``force``."""
    if force:
        return False
    return all(is_up_to_date(p, kind, inputs=inputs, config=config) for p in paths)


def several_records(sources: Any, *, what: str) -> list[Path]:
    """The paths of a stage over several runs: at least two, none given twice.

    Raises
    ------
    FitError
        Fewer than two records (``what`` names the analysis), or one given twice (named).
    """
    from pendtrack.errors import FitError

    paths = [Path(s) for s in sources]
    if len(paths) < 2:
        raise FitError(f"{what} needs at least two records, got {len(paths)}")
    seen = [p.resolve() for p in paths]
    for i, p in enumerate(seen):
        if seen.index(p) != i:
            raise FitError("the record is given twice", path=paths[i])
    return paths
