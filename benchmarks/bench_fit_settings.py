"""The fits of `pendtrack run`'s benchmark record under two sets of ``[fit]`` settings (prints; no pass/fail).

Usage::

    .venv/bin/python benchmarks/bench_fit_settings.py                       # defaults vs the exact integrator
    .venv/bin/python benchmarks/bench_fit_settings.py --reference rung_phase=0 --models classic opa

The record is ``bench_run.py``'s: a 60-s, 720p/120 fps render of the paper's setup (rendered once
into the same cache), tracked, turned into angles and kinematics with the defaults. Each model is
then fitted twice, 150 starts and no time budget (every start runs, so both do the same search):
with the defaults, and with the defaults overridden by ``--reference`` (default: the simulation's
own RK4 sub-steps for the residuals, the Jacobian that steers the iterations and the ladder's shorter
windows, i.e. the fits before ``[fit] substep_phase``, ``steer_phase`` and ``rung_phase``). Printed per model: each fit's runtime, and
what issue #16 asks to stay the same -- Xi^2_min (relative difference), every value's difference
in reported standard errors, ``n_accepted``, and ``u_paper`` in standard errors.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
from pathlib import Path

from bench_run import render_once

from pendtrack.config import Config
from pendtrack.stages.angle import angle_stage
from pendtrack.stages.fit import fit_stage
from pendtrack.stages.kinematics import kinematics_stage
from pendtrack.stages.track import track_stage


def kinematics_of(video: Path, folder: Path, config: Config) -> Path:
    """track -> angle -> kinematics of ``video`` into ``folder`` (reused when there)."""
    kin = folder / "kinematics.parquet"
    if not kin.is_file():
        common = {"out_dir": folder, "config": config, "force": True, "progress": False}
        track = track_stage(video, **common)
        angle = angle_stage(track.path, **common)
        kinematics_stage(angle.path, **common)
    return kin


def fit_one(kin: Path, out: Path, config: Config, model: str) -> dict:
    """One model's fit.json under ``config``."""
    out.mkdir(parents=True, exist_ok=True)
    shutil.copy(kin, out / "kinematics.parquet")
    fit_stage(out / "kinematics.parquet", out_dir=out, config=config, models=[model], force=True, progress=False)
    return json.loads((out / f"fit_{model}.json").read_text())


def _value(text: str) -> object:
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", nargs="*", default=["substep_phase=0", "steer_phase=0", "rung_phase=0"],
                    help="[fit] key=value overrides of the reference fits")
    ap.add_argument("--models", nargs="+", default=None, help="default: [fit] models")
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "pendtrack-bench-run"))
    args = ap.parse_args(argv)
    cache = Path(args.cache)
    video = render_once(cache / f"render_{args.seconds:g}s", args.seconds)
    base = Config()
    kin = kinematics_of(video, cache / f"kinematics_{args.seconds:g}s", base)
    overrides = dict(kv.split("=", 1) for kv in args.reference)
    configs = {
        "defaults": base,
        "reference": base.replace("fit", **{k: _value(v) for k, v in overrides.items()}),
    }
    models = args.models or list(base.fit.models)
    print(f"record: {kin} ({args.seconds:g} s); reference: {' '.join(args.reference)}; "
          f"{base.fit.n_starts} starts, no time budget; load average {os.getloadavg()[0]:.2f}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for model in models:
            fits = {name: fit_one(kin, Path(tmp) / name, cfg, model) for name, cfg in configs.items()}
            ref, new = fits["reference"], fits["defaults"]
            print(f"{model}: runtime reference {ref['runtime_s']:.1f} s, defaults {new['runtime_s']:.1f} s "
                  f"(x{ref['runtime_s'] / new['runtime_s']:.2f}); Xi2_min (defaults - reference) / reference "
                  f"{(new['xi2_min'] - ref['xi2_min']) / ref['xi2_min']:+.2e}; n_accepted {ref.get('n_accepted')} "
                  f"-> {new.get('n_accepted')}; load average {os.getloadavg()[0]:.2f}")
            print(f"  {'param':10s} {'diff/stderr':>12s} {'u_paper/stderr ref':>19s} {'defaults':>9s}")
            for pname, p in ref["params"].items():
                q = new["params"][pname]
                se = p["stderr"] or float("nan")
                print(f"  {pname:10s} {(q['value'] - p['value']) / se:+12.2e} {p['u_paper'] / se:19.4f} "
                      f"{q['u_paper'] / se:9.4f}", flush=True)


if __name__ == "__main__":
    main()
