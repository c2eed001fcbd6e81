"""Model fits: :func:`fit` (the `fit` stage's core function) and its results, :class:`FitSet` and :class:`ModelFit`."""

from __future__ import annotations

import copy
from collections.abc import Iterator, Mapping, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field
from html import escape
from pathlib import Path
from typing import Any

import pandas as pd

from pendtrack.api.frames import staged, workdir
from pendtrack.api.options import FIT, configure
from pendtrack.config import Config

SUMMARY_KEYS = ("converged", "trustworthy", "xi2_min", "rms", "aic", "bic", "n")


@dataclass(frozen=True)
class ModelFit:
    """One model's fit: the content of ``fit_<model>.json`` and its curves from fit.parquet.

    Attributes
    ----------
    name : str
        The model asked for (``fit_<name>.json``); ``record["fitted_model"]`` is the one fitted.
    record : dict
        ``fit_<name>.json`` as the CLI writes it (provenance included).
    curves : DataFrame
        t, theta, theta_model, omega_model, residual of this model (fit.parquet's rows; a joint fit's:
        fit_runs.parquet's, with each row's ``run``).
    """

    name: str
    record: Mapping[str, Any]
    curves: pd.DataFrame = field(repr=False)

    @property
    def params(self) -> pd.DataFrame:
        """One row per fitted parameter: value, stderr, the 95 % interval to quote (low95, high95), u_paper
        (units as the parameter's), flags."""
        flags = self.record.get("flags") or {}
        intervals = self.record.get("interval95") or {}

        def end(name: str, k: int) -> float | None:
            ends = intervals.get(name)
            return ends[k] if isinstance(ends, list) and len(ends) == 2 else None

        rows = {name: {"value": p.get("value"), "stderr": p.get("stderr"), "low95": end(name, 0),
                       "high95": end(name, 1), "u_paper": p.get("u_paper"), "flags": str(flags.get(name, ""))}
                for name, p in (self.record.get("params") or {}).items()}
        df = pd.DataFrame.from_dict(rows, orient="index",
                                    columns=["value", "stderr", "low95", "high95", "u_paper", "flags"])
        df.index.name = "parameter"
        return df

    @property
    def converged(self) -> bool:
        return bool(self.record.get("converged"))

    @property
    def trustworthy(self) -> bool:
        return bool(self.record.get("trustworthy", self.converged))

    @property
    def rms_over_noise(self) -> float | None:
        """The residual over the record's filtered noise (the fit stage's facts; None when unknown): 4 or
        more, the model misses structure in the data."""
        models = ((self.record.get("provenance") or {}).get("extra") or {}).get("models") or {}
        value = (models.get(self.name) or {}).get("rms_over_noise")
        return float(value) if isinstance(value, (int, float)) else None

    def to_dict(self) -> dict[str, Any]:
        """``fit_<name>.json``'s content (a copy)."""
        return copy.deepcopy(dict(self.record))

    def _repr_html_(self) -> str:
        state = "converged" if self.converged else "NOT converged"
        fitted = self.record.get("fitted_model") or self.name
        caption = (f"<b>{escape(self.name)}</b> (fitted as {escape(str(fitted))}), {state}; "
                   f"Xi2_min = {self.record.get('xi2_min'):.6g}, rms = {self.record.get('rms'):.4g} rad")
        return f"<p>{caption}</p>" + self.params.to_html(float_format=lambda x: f"{x:.6g}")

    def plot(self) -> Any:
        """The report's figure of this fit: theta(t), data and model, with the residual (a Figure)."""
        return _theta_figure({self.name: self.curves}, title=self.name)


def _theta_figure(curves: Mapping[str, pd.DataFrame], *, title: str) -> Any:
    from pendtrack.report.figures import theta_fit_figure

    first = next(iter(curves.values()))
    return theta_fit_figure(first["t"].to_numpy(float), first["theta"].to_numpy(float),
                            {n: c["theta_model"].to_numpy(float) for n, c in curves.items()},
                            {n: c["residual"].to_numpy(float) for n, c in curves.items()}, title=title)


@dataclass(frozen=True)
class FitSet:
    """The fits of one `fit` run: ``fits["fractional"]``, ``fits.selected``, ``fits.to_dict()``.

    Attributes
    ----------
    fits : mapping
        Model name -> :class:`ModelFit`, in the order fitted.
    combined : dict
        fit.json as the CLI writes it (one model's record, or the container of several).
    """

    fits: Mapping[str, ModelFit]
    combined: Mapping[str, Any]

    def __getitem__(self, name: str) -> ModelFit:
        try:
            return self.fits[name]
        except KeyError:
            raise KeyError(f"no fit of {name!r}; fitted: {', '.join(self.fits)}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.fits)

    def __len__(self) -> int:
        return len(self.fits)

    @property
    def selected(self) -> str | None:
        """The fit stage's choice: the trustworthy fit with the lowest BIC, else the converged one; None if none."""
        if "models" in self.combined:
            return self.combined.get("selected")
        return ((self.combined.get("provenance") or {}).get("extra") or {}).get("selected")

    @property
    def summary(self) -> pd.DataFrame:
        """One row per model: converged, trustworthy, xi2_min, rms [rad], aic, bic, n."""
        df = pd.DataFrame.from_dict({n: {k: f.record.get(k) for k in SUMMARY_KEYS} for n, f in self.fits.items()},
                                    orient="index", columns=list(SUMMARY_KEYS))
        df.index.name = "model"
        return df

    def to_dict(self) -> dict[str, Any]:
        """fit.json's content (a copy)."""
        return copy.deepcopy(dict(self.combined))

    def _repr_html_(self) -> str:
        head = f"<p>Selected: <b>{escape(str(self.selected))}</b></p>"
        return head + self.summary.to_html(float_format=lambda x: f"{x:.6g}") + "".join(
            f._repr_html_() for f in self.fits.values())

    def plot(self) -> Any:
        """The report's figure of the fits: theta(t), data and every model, with the residuals (a Figure)."""
        return _theta_figure({n: f.curves for n, f in self.fits.items()}, title=", ".join(self.fits))


def fitset_from_run(run: Any) -> FitSet | None:
    """The :class:`FitSet` of a run folder read by :func:`pendtrack.report.load.load_run` (None without fits)."""
    if not run.fits:
        return None
    curves = run.get("fit")
    fits = {}
    for name, record in run.fits.items():
        rows = curves[curves["model"] == name] if curves is not None and "model" in curves else curves
        fits[name] = ModelFit(name, record, pd.DataFrame() if rows is None else rows.reset_index(drop=True))
    combined = run.combined if run.combined is not None else next(iter(run.fits.values()))
    return FitSet(fits, combined)


def fit(record: pd.DataFrame | Sequence[Any] | Mapping[str, Any], models: str | Sequence[str] | None = None, *,
        config: Config | str | Path | None = None, out: str | Path | None = None, progress: bool = False,
        shared: Sequence[str] = (), per_run: Sequence[str] = (), per_group: Mapping[str, str] | None = None,
        **options: Any) -> FitSet:
    """Fit models to a record: :func:`pendtrack.fitting.models_fit.fit_models`, as ``pendtrack fit`` calls it
    (the same fits to the last digit); or jointly to several records, as ``pendtrack fit RUN1 RUN2 ...``.

    Parameters
    ----------
    record : DataFrame, path, sequence or mapping
        From :func:`kinematics`, or any record :func:`read_record` or :func:`angle` gives
        (differentiated with ``[kinematics]`` first, as the CLI does), or the path of one such file
        (kinematics.parquet, a measured table), read as ``pendtrack fit PATH`` reads it. Several records (a list of
        paths or DataFrames, or a mapping run id -> DataFrame, e.g. ``{"06na5": df}``; a path is named by its
        own file or folder, a DataFrame of a list ``run1``, ``run2``, ...) are
        fitted jointly (:func:`pendtrack.stages.series.series_fit_stage`): each :class:`ModelFit`'s
        record is then the joint ``fit_<model>.json`` and its curves its rows of ``fit_runs.parquet``
        (every run's, with a ``run`` column).
    shared, per_run : sequence of str
        Several records: parameters shared by every run, or fitted per run (``--shared``, ``--per-run``).
    per_group : mapping, optional
        Several records: parameter -> run-code fields, e.g. ``{"Ca": "tile+alley"}`` (``--per-group``).
    models : str or sequence of str, optional
        As ``--model`` (``"classic"``, ``"standard+memory"``); default ``[fit] models``.
    config : Config, path or None
        As ``--config``.
    out : path, optional
        Keep fit.json, fit_<model>.json and fit.parquet there (``--out``).
    progress : bool
        Progress bars on stderr.
    **options
        The flags of ``pendtrack fit``: ``cost``, ``starts``, ``seed``, ``workers`` (and ``offset``).

    Returns
    -------
    FitSet
    """
    from pendtrack.artifacts import Provenance, as_written, inputs_for
    from pendtrack.fitting.models_fit import check_models
    from pendtrack.stages.fit import fit_artifact, fit_sections, write_fits
    from pendtrack.stages.kinematics import kinematics_input

    cfg = configure(config, options, FIT, what="pt.fit")
    names = (models,) if isinstance(models, str) else tuple(models or cfg.fit.models)
    check_models(names, source="pt.fit")
    if not isinstance(record, (pd.DataFrame, str, Path)):
        from pendtrack.fitting.joint import sharing_from_lists

        sharing = sharing_from_lists(shared=shared, per_run=per_run, per_group=per_group)
        return _fit_series(record, names, config=cfg, out=out, sharing=sharing)
    if shared or per_run or per_group:
        from pendtrack.errors import FitError

        raise FitError("pt.fit: shared, per_run and per_group need several records")
    # a DataFrame is staged and read as the CLI's stage reads its file; a path is that file (a record or a table)
    with (staged(record, what="pt.fit") if isinstance(record, pd.DataFrame) else nullcontext(Path(record))) as src:
        art, input_sections = kinematics_input(src, config=cfg)
        inputs = inputs_for(src)
        fits = fit_artifact(art, names, config=cfg, source=str(src), progress=progress)
    prov = Provenance(stage="fit", config=fit_sections(cfg, input_sections, names), inputs=inputs, extra=fits.facts)
    if out is not None:
        with workdir(out) as folder:
            write_fits(fits, folder, prov)
    curves = pd.DataFrame(fits.curves)
    order = sorted(fits.records, key=lambda n: fits.files[n])  # as pt.load reads a folder: by file name
    return FitSet({n: ModelFit(n, as_written(fits.records[n], prov), curves[curves["model"] == n].reset_index(drop=True))
                   for n in order}, as_written(fits.combined, prov))


def _fit_series(records: Sequence[Any] | Mapping[str, Any], names: tuple[str, ...], *, config: Config,
                out: str | Path | None, sharing: Mapping[str, str]) -> FitSet:
    """The joint fit of several records (paths or DataFrames; a DataFrame is staged in a folder named by its run id)."""
    from pendtrack.api.frames import staged_runs
    from pendtrack.artifacts import read_artifact, read_json_artifact
    from pendtrack.stages.series import CURVES, series_fit_stage

    with staged_runs(records, what="pt.fit") as paths, workdir(out) as folder:
        res = series_fit_stage(paths, out_dir=folder, config=config, models=names, sharing=sharing, force=True)
        combined = read_json_artifact(res.paths[0], required=())
        curves = read_artifact(folder / CURVES, "joint_fit").data
        fits = {n: ModelFit(n, read_json_artifact(folder / res.facts["files"][n], required=()),
                            curves[curves["model"] == n].reset_index(drop=True)) for n in names}
    return FitSet(fits, combined)
