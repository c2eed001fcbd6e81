"""Run codes (the paper's Table kindofrun) and the videos of a batch folder.

A run code is two digits for the tile length in cm (``00`` = no tile), ``l`` or ``n``
(launched or not), ``a`` or ``n`` (alley or not) and the trial number: ``06na5`` is the
fifth run with the 6 cm tile, released from rest (not launched), with the alley.

File names
----------
The code is read from the file's stem, case-insensitively, and must start it. It may be
followed by a suffix after ``_``, ``-``, ``.`` or a space (``06na5_take2.mp4``,
``06NA5-repeat.MOV``); the suffix is kept, lower-cased, in the run id
(``06na5_take2``), so a second take is a separate run whose code fields are those of
``06na5``. Anything else (``06na5b.mp4``, ``run1.mp4``, ``6na5.mp4``) does not match
and is reported as skipped with the reason. Two files with the same run id (``06na5.mp4``
and ``06NA05.mov``) are a conflict: the first in name order is run, the others skipped.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pendtrack.config import VIDEO_SUFFIXES
from pendtrack.errors import FitError, PendtrackError

RUN_CODE_RE = re.compile(
    r"(?P<tile>\d{2})(?P<launch>[ln])(?P<alley>[an])(?P<trial>\d+)(?:[_\-. ](?P<suffix>.+))?",
    re.IGNORECASE,
)
RUN_CODE_HELP = "two digits for the tile in cm, l|n, a|n, trial number (e.g. 06na5 or 06na5_take2)"


class RunCodeError(PendtrackError):
    """A file name that is not a run code."""


@dataclass(frozen=True)
class RunCode:
    """The parsed run code of one video.

    Attributes
    ----------
    tile_cm : int
        Tile length l1 [cm]; 0 = no tile.
    launched : bool
        Launched with an initial speed (``l``) rather than released from rest (``n``).
    alley : bool
        Run with the alley (``a``).
    trial : int
        Trial number.
    suffix : str
        Lower-cased text after the code in the file name ("" if none).
    """

    tile_cm: int
    launched: bool
    alley: bool
    trial: int
    suffix: str = ""

    @property
    def kind(self) -> str:
        """The two-letter infix of Table kindofrun: ``la``, ``ln``, ``na`` or ``nn``."""
        return ("l" if self.launched else "n") + ("a" if self.alley else "n")

    @property
    def code(self) -> str:
        """Canonical run code, e.g. ``06na5``."""
        return f"{self.tile_cm:02d}{self.kind}{self.trial}"

    @property
    def run_id(self) -> str:
        """Code plus suffix: the run's output folder name, e.g. ``06na5_take2``."""
        return f"{self.code}_{self.suffix}" if self.suffix else self.code

    @property
    def l1_m(self) -> float:
        """Tile length l1 [m]."""
        return self.tile_cm / 100.0

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of the code's fields (and run id, kind, l1 in m)."""
        return {"run_id": self.run_id, "code": self.code, "tile_cm": self.tile_cm, "l1_m": self.l1_m,
                "launched": self.launched, "alley": self.alley, "kind": self.kind, "trial": self.trial,
                "suffix": self.suffix}


def parse_run_code(name: str | Path) -> RunCode:
    """Parse a run code from a file name or stem (case-insensitive).

    Parameters
    ----------
    name : str or Path
        File name (``06na5.mp4``), path, or bare stem (``06na5``).

    Returns
    -------
    RunCode

    Raises
    ------
    RunCodeError
        The stem does not start with a run code followed by nothing or by a separator.
    """
    stem = Path(name).stem if Path(name).suffix.lower() in VIDEO_SUFFIXES else Path(name).name
    m = RUN_CODE_RE.fullmatch(stem)
    if m is None:
        raise RunCodeError(f"name '{stem}' is not a run code ({RUN_CODE_HELP})")
    suffix = re.sub(r"[^a-z0-9_.\-]+", "-", (m["suffix"] or "").strip().lower()).strip("-.")
    return RunCode(tile_cm=int(m["tile"]), launched=m["launch"].lower() == "l", alley=m["alley"].lower() == "a",
                   trial=int(m["trial"]), suffix=suffix)



def run_names(paths: Sequence[Path]) -> tuple[list[str], list[dict[str, str]]]:
    """Each record's run id and run-code labels (``tile``, ``launched``, ``alley``; empty without a code).

    The run code is read from the file's stem, else from its folder's name (``pendtrack batch``
    writes ``DIR/06na5/kinematics.parquet``); a record without one is named by its stem (or
    ``folder/stem`` where stems repeat).

    Raises
    ------
    FitError
        Two records with the same run id.
    """
    ids, labels = [], []
    stems = [p.stem for p in paths]
    for p in paths:
        for name in (p.stem, p.parent.name):
            try:
                code = parse_run_code(name)
            except RunCodeError:
                continue
            ids.append(code.run_id)
            labels.append({"tile": f"{code.tile_cm:02d}", "launched": "l" if code.launched else "n",
                           "alley": "a" if code.alley else "n"})
            break
        else:
            ids.append(p.stem if stems.count(p.stem) == 1 else f"{p.parent.name}/{p.stem}")
            labels.append({})
    for i, run in enumerate(ids):
        if ids.index(run) != i:
            raise FitError(f"two records are run '{run}' ({paths[ids.index(run)]} and {paths[i]})", path=paths[i])
    return ids, labels

@dataclass(frozen=True)
class PlannedRun:
    """A video to process, with its parsed code."""

    video: Path
    code: RunCode

    @property
    def run_id(self) -> str:
        """The run's id (its output folder name)."""
        return self.code.run_id


@dataclass(frozen=True)
class SkippedFile:
    """A video that is not processed, and why."""

    video: Path
    reason: str


def find_videos(folder: str | Path, *, extensions: tuple[str, ...], recursive: bool = False,
                exclude: str | Path | None = None) -> list[Path]:
    """The video files of a folder, sorted by path.

    Hidden files (``.name``) are ignored; extensions compare case-insensitively.

    Parameters
    ----------
    folder : path
        Folder to scan.
    extensions : tuple of str
        Suffixes that count as videos, with the dot (``.mp4``).
    recursive : bool
        Also scan sub-folders.
    exclude : path, optional
        A folder to leave out (the batch's own output folder, when inside ``folder``).
    """
    folder = Path(folder)
    exts = {e.lower() for e in extensions}
    pattern = "**/*" if recursive else "*"
    skip = Path(exclude).resolve() if exclude is not None else None
    found = []
    for p in folder.glob(pattern):
        if p.name.startswith(".") or not p.is_file() or p.suffix.lower() not in exts:
            continue
        if skip is not None and skip in p.resolve().parents:
            continue
        found.append(p)
    return sorted(found)


def plan_runs(videos: list[Path]) -> tuple[list[PlannedRun], list[SkippedFile]]:
    """Split videos into runs (unique run ids) and skipped files (with the reason).

    Videos are taken in the given order; the first of several with the same run id wins.
    """
    runs: dict[str, PlannedRun] = {}
    skipped: list[SkippedFile] = []
    for video in videos:
        try:
            code = parse_run_code(video.stem)
        except RunCodeError as exc:
            skipped.append(SkippedFile(video, str(exc)))
            continue
        if code.run_id in runs:
            skipped.append(SkippedFile(video, f"duplicate run id '{code.run_id}' (already {runs[code.run_id].video.name})"))
            continue
        runs[code.run_id] = PlannedRun(video, code)
    return list(runs.values()), skipped
