"""From artifacts to the arrays the figures draw.

The physics is not re-derived here: turning points, the model-free Omega0 and Delta alpha
come from :mod:`pendtrack.kinematics`, model equations from :mod:`pendtrack.models`. What is
here is bookkeeping: finding a value in an artifact's provenance, splitting fit.parquet by
model, cutting time windows, and passing the fitted models' curves through the same
Savitzky-Golay filter as the data so that data and model Delta alpha are seen through one
instrument.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.config import Config
from pendtrack.report.load import RunData

PAPER_HYSTERESIS_S = 10.0  # Fig. dissipativehysteresis shows the initial ten seconds [s]
FIRST_SWINGS = 4.0  # Figs. S2/S3 zoom on the first few natural periods [periods]


@dataclass(frozen=True)
class Omega0:
    """The natural angular frequency used to scale a figure, and where it came from."""

    value: float  # [rad/s]
    stderr: float | None  # [rad/s]
    source: str  # human-readable origin, shown in captions


def finite_number(x: Any) -> float | None:
    """``x`` (or ``x["value"]`` for a provenance entry) as a finite float, else None."""
    if isinstance(x, Mapping):
        x = x.get("value")
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def find_number(record: Mapping[str, Any], *names: str) -> float | None:
    """First finite number among ``names`` in a (possibly nested one level) provenance dict."""
    for name in names:
        if name in record and (v := finite_number(record[name])) is not None:
            return v
    for value in record.values():
        if isinstance(value, Mapping):
            for name in names:
                if name in value and (v := finite_number(value[name])) is not None:
                    return v
    return None


def param_values(fit: Mapping[str, Any]) -> dict[str, float]:
    """A fit.json's parameter values by name (``{"value", ...}`` entries or bare numbers)."""
    out = {}
    for name, entry in (fit.get("params") or {}).items():
        v = finite_number(entry)
        if v is not None:
            out[str(name)] = v
    return out


def data_omega0(run: RunData) -> Omega0 | None:
    """Model-free Omega0: the kinematics stage's (eq. straightline), else a fit's ``omega0_hat``."""
    extra = run.extra("kinematics")
    v = find_number(extra, "Omega0", "omega0")
    if v is not None:
        err = find_number(extra, "Omega0_stderr", "omega0_stderr")
        return Omega0(v, err, "the kinematics stage's model-free estimate from the turning points")
    for name, fit in run.fits.items():
        v = finite_number(fit.get("omega0_hat"))
        if v is not None:
            return Omega0(v, None, f"the model-free estimate recorded by the {name} fit")
    return None


def model_omega0(run: RunData, model: str) -> Omega0 | None:
    """A fitted model's Omega0 with its standard error."""
    fit = run.fits.get(model)
    if not fit:
        return None
    entry = (fit.get("params") or {}).get("Omega0")
    v = finite_number(entry)
    if v is None:
        return None
    err = finite_number(entry.get("stderr")) if isinstance(entry, Mapping) else None
    return Omega0(v, err, f"fitted by the {model} model")


def best_omega0(run: RunData, preference: tuple[str, ...] = ("fractional", "classic")) -> Omega0 | None:
    """The Omega0 that scales time and A_omega: a preferred model's fit, else the model-free one."""
    for model in preference:
        if (w := model_omega0(run, model)) is not None:
            return w
    return data_omega0(run)


def savgol_setup(run: RunData, config: Config) -> tuple[float, int]:
    """Window [s] and order of the Savitzky-Golay filter the kinematics stage used (else config)."""
    section = run.stage_config("kinematics").get("kinematics", {})
    window = finite_number(section.get("savgol_window_s")) or config.kinematics.savgol_window_s
    order = section.get("savgol_order", config.kinematics.savgol_order)
    return float(window), int(order)


def model_curves(run: RunData) -> dict[str, pd.DataFrame]:
    """fit.parquet split by model: name -> frame (t, theta, theta_model, omega_model, residual), t sorted."""
    df = run.get("fit")
    if df is None or df.empty:
        return {}
    if "model" not in df.columns:
        names = list(run.fits) or ["model"]
        return {names[0]: df.sort_values("t").reset_index(drop=True)}
    out = {}
    for name, sub in df.groupby("model", sort=False):
        out[str(name)] = sub.drop(columns="model").sort_values("t").reset_index(drop=True)
    order = [m for m in run.fits if m in out] + [m for m in out if m not in run.fits]
    return {m: out[m] for m in order}


def model_alpha(t: np.ndarray, theta: np.ndarray, *, window_s: float, order: int) -> np.ndarray:
    """Angular acceleration of a model's sampled angle by the data's Savitzky-Golay filter [rad/s^2].

    :func:`pendtrack.kinematics.savgol_kinematics` with the kinematics stage's window and order,
    so the model is seen through the same instrument as the data; samples it drops are NaN.
    """
    from pendtrack.kinematics import savgol_kinematics

    res = savgol_kinematics(t, theta, window_s=window_s, order=order)
    return np.where(np.asarray(res.ok, bool), np.asarray(res.alpha, float), np.nan)


def model_delta_alpha(curve: pd.DataFrame, omega0: float, *, window_s: float, order: int) -> np.ndarray:
    """Delta alpha = alpha + Omega0^2 sin(theta) of a model's curve [rad/s^2] (eq. lobulosprovados).

    ``alpha`` is the Savitzky-Golay second derivative of ``theta_model``, as the data's is; with
    the model's own Omega0 this is its a_diss + a_iner seen through the data's filter.
    """
    from pendtrack.kinematics import delta_alpha

    t = curve["t"].to_numpy(float)
    theta = curve["theta_model"].to_numpy(float)
    return np.asarray(delta_alpha(theta, model_alpha(t, theta, window_s=window_s, order=order), omega0), float)


def power_law_curve(classic: Mapping[str, float], omega_max: float, *, n: int = 401) -> tuple[np.ndarray, np.ndarray]:
    """The classic model's dissipation with C_a = 0 (the paper's "power-law") on an omega grid.

    Evaluated by :meth:`pendtrack.models.Model.accel` at theta = 0, where the gravity and
    added-mass terms vanish: ``-sgn(omega)(C0 + C3 |omega/Omega0|^p)`` [rad/s^2].
    """
    from pendtrack.models import get_model

    omega = np.linspace(-omega_max, omega_max, n)
    params = {**classic, "Ca": 0.0}
    a = get_model("classic").accel(params, np.zeros(n), omega, np.zeros(n))
    return omega, np.asarray(a, float)


def amplitudes(theta: np.ndarray, omega: np.ndarray, omega0: float) -> tuple[np.ndarray, np.ndarray]:
    """A_theta = sin(theta/2), A_omega = omega/(2 Omega0) (eq. amplitudes), by :mod:`pendtrack.kinematics`."""
    from pendtrack.kinematics import amplitudes as core_amplitudes

    a_th, a_om, _ = core_amplitudes(np.asarray(theta, float), np.asarray(omega, float), omega0)
    return a_th, a_om


@dataclass(frozen=True)
class TurningPoints:
    """alpha at the extreme angles (omega = 0) and the -Omega0^2 sin fits (eq. straightline)."""

    theta_ext: np.ndarray  # [rad]
    alpha_ext: np.ndarray  # [rad/s^2]
    omega0: float  # Savitzky-Golay bias corrected when the filter is known, as the kinematics stage [rad/s]
    omega0_stderr: float | None  # [rad/s]
    omega0_raw: float  # the direct fit through the plotted points [rad/s]
    corrected: bool  # omega0 has the smoothing bias removed


def turning_points(kin: pd.DataFrame, *, window_s: float, order: int,
                   extra: Mapping[str, Any] | None = None) -> TurningPoints:
    """Turning points of the usable samples and the eq. straightline fits, by :mod:`pendtrack.kinematics`.

    Crossings within half a Savitzky-Golay window of a segment's ends are left out, as the
    kinematics stage does. With the filter's ``window_points`` and step ``h`` (the stage's
    provenance ``extra``) the Savitzky-Golay bias is removed from ``omega0`` as the stage does.
    """
    from pendtrack.kinematics import (KinematicsResult, estimate_omega0, record_turning_points,
                                      record_turning_values, smoothing_moments)

    t, th, om, al = (kin[c].to_numpy(float) for c in ("t", "theta", "omega", "alpha"))
    seg = kin["segment"].to_numpy() if "segment" in kin.columns else np.zeros(t.size, dtype=np.int64)
    extra = extra or {}
    w = finite_number(extra.get("window_s"))
    info: dict[str, Any] = {"window_s": window_s if w is None else w, "order": extra.get("order", order)}
    points, h = finite_number(extra.get("window_points")), finite_number(extra.get("h"))
    if points is not None and h is not None:
        info.update(window_points=points, h=h)
    record = KinematicsResult(t=t, theta=th, omega=om, alpha=al, ok=kin["ok"].to_numpy(bool), segment=seg,
                                         info=info)
    tp = record_turning_points(record)
    th_ext, al_ext = record_turning_values(record, tp)
    raw = estimate_omega0(th_ext, al_ext)
    moments = smoothing_moments(info)
    est = raw if moments is None else estimate_omega0(th_ext, al_ext, sg_moments=moments)
    corrected = moments is not None
    return TurningPoints(theta_ext=th_ext, alpha_ext=al_ext,
                         omega0=float(est.omega0), omega0_stderr=finite_number(est.stderr), omega0_raw=float(raw.omega0),
                         corrected=corrected)


def time_window(df: pd.DataFrame, start: float, length: float) -> pd.DataFrame:
    """Rows with ``start <= t <= start + length``."""
    t = df["t"].to_numpy(float)
    return df[(t >= start) & (t <= start + length)]
