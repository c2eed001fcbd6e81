"""Coverage of the fit's intervals: how often each method's 68 % and 95 % intervals hold the truth.

Usage::

    nice -n 19 .venv/bin/python benchmarks/bench_coverage.py --records 400 --models classic,opa,fractional \\
        [--seconds 20] [--fps 120] [--starts K] [--workers 1] [--first-seed 0] [--out coverage.json]

For each model, ``--records`` seeded synthetic records (seed s of model m: record ``m-s``; seeds from
``--first-seed``, so that a method chosen on one set of records can be checked on others):

* **truth** drawn per seed around the paper's values (:data:`CENTRES`, each parameter uniform
  within :data:`SPREAD` of its centre), so the coverage is of a neighbourhood, not of one point;
* **simulated** from rest near the top (``theta0`` uniform in 2.6-3.0 rad) at ``--fps`` for
  ``--seconds``;
* **tracking noise** (:func:`tracking_noise`): white plus AR(1), in the proportions measured on
  the tracked render ``sample_videos/12na1.mp4`` against its truth (0.70 mrad rms; autocorrelation
  0.32, 0.20, 0.12 at lags 1-3 frames: 52 % of the variance in an AR(1) part with rho = 0.62 per
  frame at 120 fps, the rest white), scaled to :data:`NOISE_RAD` rms, the noise of the project's
  recovery tests and of the issue's field records. The correlated part is the marker's
  sub-pixel error, which changes slowly as the blurred spot crosses the pixel grid; its
  correlation time (~2 frames at 120 fps, 17 ms) is kept in seconds when ``--fps`` changes;
* **differentiated** by the kinematics core (:func:`pendtrack.kinematics.record.differentiate_record`
  with the default ``[kinematics]``: the paper's 25-frame cubic Savitzky-Golay window), the same
  filter then applied to the model (:class:`pendtrack.fitting.Observation`), as the fit stage does;
* **fitted** by :func:`pendtrack.fitting.fit_model` with the default ``[fit]`` apart from the
  short cuts (``--starts`` starts, default :data:`STARTS`; one worker process; the profile sigmas
  on). The truth is never
  a start: the starts come from the data-derived estimates.

For every parameter (Omega0 and every damping parameter of the model) and method (``stderr``:
the sandwich; ``profile``: ``stderr_low`` below the value and ``stderr_high`` above it, the side
facing the truth; ``u_paper``; ``bootstrap`` when ``--bootstrap`` > 0) the summary reports the
share of intervals ``value +- z sigma`` (z = 1 and 1.96) that cover the truth, its binomial
standard error ``sqrt(c (1 - c) / n)``, and the RMS of ``(value - truth) / sigma``; and the same for
``interval``: fit.json's own ``interval68`` and ``interval95``, which hold the truth or not, their
sigma for the rms of z the 68 % interval's half-width on the side facing the truth; and the same for
the interval fit.json says to quote (``quote``). Only trustworthy fits count (converged, no
parameter flagged): a user is told not to quote the others; how many there were is reported.

Resumable: each finished record is appended as one JSON line to ``<out>.jsonl``; a second run
with the same ``--out`` fits only the records not there yet (its settings must match: they are
stored with each line and a line with other settings is an error). Parallel over records with
:func:`pendtrack.parallel.process_pool` (``--workers`` > 1); the results do not depend on it.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

MODELS = ("classic", "opa", "fractional")
#: The paper-like values the truths are drawn around (those of tests/test_fit_recovery.py).
CENTRES = {
    "classic": {"Omega0": 5.0, "C0": 0.02, "C3": 0.05, "p": 2.0, "Ca": 0.01},
    "opa": {"Omega0": 5.05, "C4": 3.25, "t0": -8.85, "C5": 1.57e-3},
    "fractional": {"Omega0": 5.0, "G1": 2e-4, "G2": 2e-3, "beta": 0.5, "p_f": 2.5},
}
#: Starts per fit by default (the fit stage runs 150). OPA: the recovery tests' 2, every start reaches the same
#: minimum. Classic: 20; with 2, some fits stopped up the C0-C3-p valley (2 of the 17 records of 200 whose 95 %
#: interval missed C0 or C3: a trust-region run from there lowered the cost by 1e-4 relative and moved C3 from
#: z -4.2 to -2.6). Fractional: 8; with 2, 2 of 25 fits ended in a wrong minimum, beta on its bound.
STARTS = {"classic": 20, "opa": 2, "fractional": 8}
SPREAD = 0.2  # each parameter uniform within +-20 % of its centre (Omega0: +-4 %, a pendulum of another length)
OMEGA0_SPREAD = 0.04
NOISE_RAD = 3e-3  # rms tracking noise [rad]
# measured on the tracked render 12na1 (module docstring): share of the variance in the AR(1) part, its
# lag-one correlation at the render's 120 fps
AR_SHARE = 0.52
AR_RHO_120 = 0.62
LEVELS = ((68, 1.0), (95, 1.959964))  # nominal coverage [%] and the Gaussian half-width in sigmas
METHODS = ("stderr", "profile", "u_paper", "bootstrap", "interval", "quote")
STATE = ("theta0", "omega0")


def draw_truth(model: str, seed: int) -> dict[str, float]:
    """The true parameters of record ``seed`` of ``model``: uniform around :data:`CENTRES`."""
    rng = np.random.default_rng([seed, MODELS.index(model), 1])
    out = {}
    for name, c in CENTRES[model].items():
        spread = OMEGA0_SPREAD if name == "Omega0" else SPREAD
        out[name] = float(c * (1.0 + rng.uniform(-spread, spread)))
    return out


def tracking_noise(n: int, *, fps: float, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """White plus AR(1) noise of ``sigma`` rms [rad], the render's tracking noise (module docstring).

    The AR(1) part keeps its correlation time in seconds: ``rho = AR_RHO_120 ** (120 / fps)``.
    It starts in its stationary distribution.
    """
    rho = AR_RHO_120 ** (120.0 / fps)
    sd_ar = sigma * math.sqrt(AR_SHARE)
    sd_w = sigma * math.sqrt(1.0 - AR_SHARE)
    innov = rng.normal(0.0, sd_ar * math.sqrt(1.0 - rho * rho), n)
    innov[0] = rng.normal(0.0, sd_ar)
    from scipy.signal import lfilter

    ar = lfilter([1.0], [1.0, -rho], innov)
    return ar + rng.normal(0.0, sd_w, n)


def make_record(model: str, seed: int, *, seconds: float, fps: float) -> dict[str, Any]:
    """The seeded record: truth, the kinematics core's arrays and the observation the fit uses."""
    from pendtrack.config import KinematicsConfig
    from pendtrack.fitting import Observation
    from pendtrack.kinematics.record import differentiate_record
    from pendtrack.models import get_model, simulate

    truth = draw_truth(model, seed)
    rng = np.random.default_rng([seed, MODELS.index(model), 2])
    theta0 = float(rng.uniform(2.6, 3.0))
    t = np.arange(int(round(seconds * fps))) / fps
    sim = simulate(get_model(model), truth, t, theta0=theta0, omega0=0.0)
    theta = np.asarray(sim.theta) + tracking_noise(t.size, fps=fps, sigma=NOISE_RAD, rng=rng)
    kin = differentiate_record(t, theta, np.ones(t.size, bool), options=KinematicsConfig(), source=f"{model}-{seed}")
    obs = Observation(savgol_window=int(kin.info["window_points"]), savgol_order=int(kin.info["order"]))
    return {"truth": truth, "theta0": theta0, "t": kin.t, "theta": kin.theta, "omega": kin.omega,
            "alpha": kin.alpha, "ok": kin.ok, "observation": obs}


def fit_record(task: tuple[str, int, Mapping[str, Any]]) -> dict[str, Any]:
    """Fit one record (a process-pool task ``(model, seed, settings)``); the JSON line of it."""
    from pendtrack.config import FitConfig
    from pendtrack.fitting import fit_model
    from pendtrack.models import get_model

    model, seed, settings = task
    rec = make_record(model, seed, seconds=settings["seconds"], fps=settings["fps"])
    starts = int(settings["starts"]) or STARTS[model]
    options = FitConfig(n_starts=starts, profile=True, bootstrap=int(settings["bootstrap"]),
                        workers=1)
    res = fit_model(get_model(model), rec["t"], rec["theta"], rec["omega"], alpha=rec["alpha"], ok=rec["ok"],
                    observation=rec["observation"], options=options, seed=seed, workers=1,
                    source=f"{model}-{seed}")
    params = {}
    for name in rec["truth"]:
        p = res.params[name]
        params[name] = {"value": p.value, "stderr": p.stderr, "stderr_low": p.stderr_low,
                        "stderr_high": p.stderr_high, "u_paper": p.u_paper, "stderr_bootstrap": p.stderr_bootstrap,
                        "interval68": list(p.interval68), "interval95": list(p.interval95),
                        "quote": res.quote().get(name)}
    return {"key": f"{model}-{seed}", "model": model, "seed": seed, "settings": dict(settings),
            "truth": rec["truth"], "converged": bool(res.converged), "trustworthy": bool(res.trustworthy),
            "flags": dict(res.flags), "quote": res.quote(), "hac_lag": int(res.hac_lag),
            "xi2_min": res.xi2_min, "runtime_s": res.runtime_s, "params": _json_safe(params)}


def _json_safe(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    return obj


def sigma_of(p: Mapping[str, Any], method: str, truth: float) -> float:
    """The method's sigma of one fitted parameter, on the side facing ``truth`` for the profile and the
    interval (there: the 68 % interval's half-width on that side) [unit]."""
    if method == "quote":
        method = p["quote"]
        if method is None:
            return math.nan
    if method == "profile":
        s = p["stderr_low"] if p["value"] > truth else p["stderr_high"]
    elif method == "interval":
        lo, hi = p.get("interval68") or (None, None)
        if lo is None or hi is None:
            return math.nan
        s = p["value"] - lo if p["value"] > truth else hi - p["value"]
    else:
        s = p["stderr_bootstrap" if method == "bootstrap" else method]
    return math.nan if s is None else float(s)


def covers(p: Mapping[str, Any], method: str, truth: float, level: int, half: float) -> bool:
    """Whether the method's ``level`` % interval of one fitted parameter holds ``truth``: ``value +- half
    sigma``, or for ``interval`` the fit's own ``[low, high]``."""
    if method == "quote":
        method = p["quote"]
    if method == "interval":
        lo, hi = p[f"interval{level}"]
        return lo is not None and hi is not None and bool(lo <= truth <= hi)
    return bool(abs(p["value"] - truth) <= half * sigma_of(p, method, truth))


def coverage(lines: Iterable[Mapping[str, Any]]) -> dict[str, Any]:
    """The coverage table of finished records.

    Returns
    -------
    dict
        ``{model: {"records", "converged", "trustworthy", "params": {name: {method: {"n", "cover68", "se68",
        "cover95", "se95", "rms_z"}}}}}``; shares in [0, 1], a method without a finite sigma on a
        record does not count there (``n`` says how many did).
    """
    by_model: dict[str, list[Mapping[str, Any]]] = {}
    for line in lines:
        by_model.setdefault(line["model"], []).append(line)
    out: dict[str, Any] = {}
    for model in sorted(by_model, key=lambda m: MODELS.index(m) if m in MODELS else len(MODELS)):
        recs = sorted(by_model[model], key=lambda r: r["seed"])
        ok = [r for r in recs if r["trustworthy"]]
        table: dict[str, Any] = {}
        for name in recs[0]["truth"]:
            table[name] = {}
            for method in METHODS:
                z, held = [], []
                for r in ok:
                    p, truth = r["params"][name], r["truth"][name]
                    s = sigma_of(p, method, truth)
                    if math.isfinite(s) and s > 0 and p["value"] is not None:
                        z.append((p["value"] - truth) / s)
                        held.append([covers(p, method, truth, level, half) for level, half in LEVELS])
                if not z:
                    continue
                za = np.abs(np.asarray(z))
                row: dict[str, Any] = {"n": int(za.size)}
                for k, (level, _) in enumerate(LEVELS):
                    c = float(np.mean([h[k] for h in held]))
                    row[f"cover{level}"] = c
                    row[f"se{level}"] = math.sqrt(c * (1.0 - c) / za.size)
                row["rms_z"] = float(np.sqrt(np.mean(za * za)))
                table[name][method] = row
        out[model] = {"records": len(recs), "converged": sum(r["converged"] for r in recs), "trustworthy": len(ok),
                      "params": table}
    return out


def read_lines(path: Path, settings: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The finished records of an earlier run (ValueError if one was run with other settings)."""
    if not path.is_file():
        return []
    lines = []
    for text in path.read_text().splitlines():
        if not text.strip():
            continue
        line = json.loads(text)
        if line["settings"] != dict(settings):
            raise ValueError(f"{path}: record {line['key']} was run with {line['settings']}, not {dict(settings)}")
        lines.append(line)
    return lines


def run(models: Sequence[str], records: int, settings: Mapping[str, Any], *, jsonl: Path, workers: int,
        echo: Any = None, first_seed: int = 0) -> list[dict[str, Any]]:
    """Fit every record (seeds ``first_seed`` on) not yet in ``jsonl``, appending each as it finishes; all
    lines of these records."""
    from pendtrack.parallel import process_pool, worker_count

    done = {line["key"]: line for line in read_lines(jsonl, settings)}
    seeds = range(first_seed, first_seed + records)
    tasks = [(m, s, dict(settings)) for m in models for s in seeds if f"{m}-{s}" not in done]
    jsonl.parent.mkdir(parents=True, exist_ok=True)

    def keep(line: dict[str, Any]) -> None:
        with jsonl.open("a") as fh:  # one whole line per record: an interrupted run loses at most the record in flight
            fh.write(json.dumps(line, sort_keys=True) + "\n")
        done[line["key"]] = line
        if echo:
            echo(line)

    n = worker_count(workers, len(tasks)) if tasks else 1
    if n == 1:
        for task in tasks:
            keep(fit_record(task))
    else:
        with process_pool(n) as pool:
            for line in pool.map(fit_record, tasks):
                keep(line)
    return [done[f"{m}-{s}"] for m in models for s in seeds]


def table_text(summary: Mapping[str, Any]) -> str:
    """The coverage table as Markdown (shares in %, +- one binomial standard error)."""
    rows = ["| model | parameter | method | n | 68 % interval covers | 95 % interval covers | rms z |",
            "|---|---|---|---|---|---|---|"]
    for model, block in summary.items():
        for name, methods in block["params"].items():
            for method, r in methods.items():
                rows.append(f"| {model} | {name} | {method} | {r['n']} | {100 * r['cover68']:.0f} +- "
                            f"{100 * r['se68']:.0f} | {100 * r['cover95']:.0f} +- {100 * r['se95']:.0f} | "
                            f"{r['rms_z']:.2f} |")
    return "\n".join(rows)


def fail(message: str) -> None:
    """One line ``error: ...`` on stderr, exit code 2 (the project's bad-input rule)."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=400, help="records per model")
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--seconds", type=float, default=20.0, help="record length [s]")
    ap.add_argument("--fps", type=float, default=120.0, help="frame rate [1/s]")
    ap.add_argument("--starts", type=int, default=0, help="starts per fit (0: STARTS of the model; the fit stage uses 150)")
    ap.add_argument("--bootstrap", type=int, default=0, help="block-bootstrap refits per fit (0: none)")
    ap.add_argument("--workers", type=int, default=1, help="processes over records (0: all cores)")
    ap.add_argument("--first-seed", type=int, default=0,
                    help="the records' seeds start here (another --first-seed: records no method was chosen on)")
    ap.add_argument("--out", type=Path, default=Path("coverage.json"))
    args = ap.parse_args(argv)
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    unknown = [m for m in models if m not in CENTRES]
    if unknown or args.records < 1 or args.seconds <= 0 or args.fps <= 0 or args.starts < 0 or args.first_seed < 0:
        fail(f"bad arguments (models {unknown or models}, records {args.records}, seconds {args.seconds}, "
             f"fps {args.fps}, starts {args.starts})")
    settings = {"seconds": args.seconds, "fps": args.fps, "starts": args.starts, "bootstrap": args.bootstrap}
    jsonl = args.out.with_suffix(".jsonl")

    def echo(line: Mapping[str, Any]) -> None:
        print(f"{line['key']:<16} trustworthy {line['trustworthy']!s:<5} lag {line['hac_lag']:3d}  "
              f"{line['runtime_s']:6.1f} s", flush=True)

    try:
        lines = run(models, args.records, settings, jsonl=jsonl, workers=args.workers, echo=echo,
                    first_seed=args.first_seed)
    except ValueError as exc:
        fail(str(exc))
    from bench_run import cpu_model  # this folder's: the CPU named as the other benchmarks name it

    summary = coverage(lines)
    payload = {"command": " ".join(["benchmarks/bench_coverage.py", *(argv if argv is not None else sys.argv[1:])]),
               "cpu": cpu_model(), "cores": os.cpu_count(), "settings": settings, "records": args.records,
               "first_seed": args.first_seed,
               "noise": {"rms_rad": NOISE_RAD, "ar_share": AR_SHARE, "ar_rho_120fps": AR_RHO_120},
               "coverage": summary}
    tmp = args.out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(payload, indent=1, sort_keys=True))
    tmp.replace(args.out)
    print(table_text(summary))


if __name__ == "__main__":
    main()
