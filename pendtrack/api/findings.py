"""Discovery: :func:`discover` (the `discover` stage) and its result, :class:`Discovery`."""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from html import escape
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.api.frames import staged, workdir
from pendtrack.api.options import DISCOVER, configure
from pendtrack.config import Config
from pendtrack.errors import ArtifactError

STEP_COLUMNS = ("step", "effect", "kind", "rms_before", "rms_after", "heldout_rms_before", "heldout_rms_after",
                "delta_bic", "heldout_z")


@dataclass(frozen=True)
class Discovery:
    """What discovery found: discovery.json's content and discovery.md's text.

    Attributes
    ----------
    record : dict
        discovery.json as the CLI writes it (provenance included).
    text : str
        discovery.md.
    """

    record: Mapping[str, Any]
    text: str = ""

    @property
    def effects(self) -> list[str]:
        """The physical effects added to the baseline, in the order kept."""
        return list(self.record.get("effects") or [])

    @property
    def measurement(self) -> list[str]:
        """Measurement terms kept (theta's zero offset, an angle-scale error): findings about the record."""
        return list(self.record.get("measurement") or [])

    @property
    def verdict(self) -> str:
        """discovery.md's verdict paragraph."""
        found = re.search(r"^## Verdict\s*\n(.*?)(?=^## |\Z)", self.text, flags=re.S | re.M)
        return found.group(1).strip() if found else ""

    @property
    def steps(self) -> pd.DataFrame:
        """One row per accepted step: effect, RMS [rad] and held-out RMS [rad] before and after, delta BIC, z."""
        rows = [{k: s.get(k) for k in STEP_COLUMNS} for s in self.record.get("steps") or []]
        return pd.DataFrame(rows, columns=list(STEP_COLUMNS))

    def to_dict(self) -> dict[str, Any]:
        """discovery.json's content (a copy)."""
        return copy.deepcopy(dict(self.record))

    def _repr_html_(self) -> str:
        final = self.record.get("final_model") or {}
        name = final.get("model", "") if isinstance(final, Mapping) else str(final)
        facts = pd.DataFrame({"": [str(self.record.get("baseline", "")), ", ".join(self.effects) or "none",
                                   ", ".join(self.measurement) or "none", str(name)]},
                             index=["baseline", "effects added", "measurement findings", "discovered model"])
        return (facts.to_html(header=False) + f"<p>{escape(self.verdict)}</p>"
                + self.steps.to_html(index=False, float_format=lambda x: f"{x:.4g}"))

    def plot(self) -> Any:
        """RMS and held-out RMS [mrad] from the baseline through each kept step (a Figure)."""
        from pendtrack.report.style import new_figure, tidy

        steps = self.record.get("steps") or []
        labels = ["baseline"] + [str(s.get("effect")) for s in steps]
        rms = [steps[0].get("rms_before") if steps else (self.record.get("final_model") or {}).get("rms")]
        held = [steps[0].get("heldout_rms_before") if steps else (self.record.get("final_model") or {}).get("heldout_rms")]
        rms += [s.get("rms_after") for s in steps]
        held += [s.get("heldout_rms_after") for s in steps]
        fig = new_figure(6.0, 3.5)
        ax = tidy(fig.add_subplot())
        x = np.arange(len(labels))
        ax.plot(x, 1e3 * np.array(rms, float), "o-", label="whole record")
        ax.plot(x, 1e3 * np.array(held, float), "s--", label="held-out part")
        ax.set_xticks(x, labels)
        ax.set_ylabel("RMS residual [mrad]")
        ax.legend()
        return fig


def discovery_from_run(run: Any) -> Discovery | None:
    """The :class:`Discovery` of a run folder read by :func:`pendtrack.report.load.load_run` (None if absent)."""
    if run.discovery is None:
        return None
    return Discovery(run.discovery, run.discovery_md or "")


def discover(record: pd.DataFrame | str | Path | Sequence[Any] | Mapping[str, Any], *,
             config: Config | str | Path | None = None, out: str | Path | None = None, progress: bool = False,
             shared: Sequence[str] = (), per_run: Sequence[str] = (), per_group: Mapping[str, str] | None = None,
             **options: Any) -> Discovery:
    """Diagnose the baseline, name the missing physics, extend the model: the `discover` stage.

    Parameters
    ----------
    record : DataFrame or path
        A DataFrame of :func:`kinematics`, :func:`angle` or :func:`read_record`, or a path the CLI
        takes (a table, an artifact, a video). Several records (a list of paths or DataFrames, or a
        mapping run id -> record): discovery across runs of one pendulum
        (:func:`pendtrack.stages.discover.discover_runs_stage`).
    shared, per_run, per_group
        Several records: the scopes over the defaults, as :func:`fit`.
    config : Config, path or None
        As ``--config``.
    out : path, optional
        Keep discovery.json and discovery.md there (``--out``).
    **options
        ``baseline``, ``effects`` (as ``pendtrack discover``), and ``[discover]``'s ``n_starts``,
        ``workers``, ``seed``.
    """
    from pendtrack.report.load import load_run
    from pendtrack.stages.discover import discover_stage

    cfg = configure(config, options, DISCOVER, what="pt.discover")
    if not isinstance(record, (pd.DataFrame, str, Path)):
        from pendtrack.fitting.joint import sharing_from_lists

        sharing = sharing_from_lists(shared=shared, per_run=per_run, per_group=per_group)
        return _discover_runs(record, config=cfg, out=out, sharing=sharing, progress=progress)
    if shared or per_run or per_group:
        from pendtrack.errors import FitError

        raise FitError("pt.discover: shared, per_run and per_group need several records")
    with workdir(out) as folder:
        if isinstance(record, pd.DataFrame):
            with staged(record, what="pt.discover") as src:
                discover_stage(src, out_dir=folder, config=cfg, force=True, progress=progress)
        else:
            discover_stage(record, out_dir=folder, config=cfg, force=True, progress=progress)
        found = discovery_from_run(load_run(folder))
    if found is None:
        raise ArtifactError("the discover stage wrote no discovery.json", path=folder)
    return found


def _discover_runs(records: Sequence[Any] | Mapping[str, Any], *, config: Config, out: str | Path | None,
                   sharing: Mapping[str, str], progress: bool) -> Discovery:
    """Discovery across several records (paths or DataFrames; a DataFrame is staged in a folder named by its run id)."""
    from pendtrack.api.frames import staged_runs
    from pendtrack.artifacts import read_json_artifact
    from pendtrack.stages.discover import discover_runs_stage

    with staged_runs(records, what="pt.discover") as paths, workdir(out) as folder:
        res = discover_runs_stage(paths, out_dir=folder, config=config, sharing=dict(sharing), force=True,
                                  progress=progress)
        found = read_json_artifact(res.paths[0], required=())
        text = res.paths[1].read_text(encoding="utf-8")
    return Discovery(found, text)
