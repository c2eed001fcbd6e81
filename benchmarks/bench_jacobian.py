"""Benchmark: ``[fit] jacobian = "fd"`` against ``"sensitivity"`` on the paper's 150-start fit (prints, never fails).

    .venv/bin/python benchmarks/bench_jacobian.py                       # classic and opa, 150 starts, 60 s
    .venv/bin/python benchmarks/bench_jacobian.py --models classic --starts 30

A 60 s, 120 Hz synthetic record per model (as ``bench_fit.py`` makes it: released from rest
near the top, 3 mrad noise, the paper's 25-frame cubic Savitzky-Golay filter), fitted with
both Jacobians in the same run, no time budget (every start runs, so the two do the same
work). The order alternates between models (fd first, then sensitivity first) against a
drift of the machine's load. Prints the wall times and their ratio, and what the fits found:
Xi^2_min (relative difference) and each value's difference in reported standard errors.
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import replace

import numpy as np

TRUTHS = {
    "classic": {"Omega0": 5.0, "C0": 0.02, "C3": 0.05, "p": 2.0, "Ca": 0.01},
    "opa": {"Omega0": 5.05, "C4": 3.25, "t0": -8.85, "C5": 1.57e-3},
    "standard": {"Omega0": 5.0, "C1": 0.02, "C0": 0.02, "C2": 0.002},
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=["classic", "opa"], choices=sorted(TRUTHS))
    ap.add_argument("--starts", type=int, default=150)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--workers", type=int, default=0, help="0 = all cores")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    from pendtrack.config import Config
    from pendtrack.fitting import Observation, fit_model
    from pendtrack.kinematics import savgol_kinematics
    from pendtrack.models import get_model, simulate

    fs = 120.0
    t = np.arange(int(args.seconds * fs)) / fs
    print(f"{args.seconds:g} s at {fs:g} Hz, {args.starts} starts, workers={args.workers or os.cpu_count()} "
          f"(cpu_count={os.cpu_count()}), no time budget", flush=True)
    for k, name in enumerate(args.models):
        model = get_model(name)
        truth = TRUTHS[name]
        sim = simulate(model, truth, t, theta0=2.8, omega0=0.0)
        theta = sim.theta + np.random.default_rng(args.seed).normal(0.0, 3e-3, t.size)
        kin = savgol_kinematics(t, theta, window_s=25 / fs, order=3)
        obs = Observation(savgol_window=int(kin.info["window_points"]), savgol_order=int(kin.info["order"]))
        results, walls = {}, {}
        order = ("fd", "sensitivity") if k % 2 == 0 else ("sensitivity", "fd")
        for method in order:
            options = replace(Config().fit, n_starts=args.starts, jacobian=method)
            t0 = time.perf_counter()
            results[method] = fit_model(model, kin.t, kin.theta, kin.omega, options=options, alpha=kin.alpha,
                                        ok=kin.ok, observation=obs, workers=args.workers, seed=args.seed)
            walls[method] = time.perf_counter() - t0
            r = results[method]
            print(f"{name:9s} {method:11s} wall {walls[method]:7.1f} s  Xi2_min {r.xi2_min:.10e}  "
                  f"converged={r.converged}  accepted {r.n_accepted}/{r.n_starts}", flush=True)
        fd, sens = results["fd"], results["sensitivity"]
        print(f"{name:9s} wall fd / sensitivity = {walls['fd'] / walls['sensitivity']:.2f}   "
              f"Xi2_min (sens - fd)/fd = {(sens.xi2_min - fd.xi2_min) / fd.xi2_min:+.2e}")
        print(f"  {'param':8s} {'fd':>14s} {'sensitivity':>14s} {'stderr':>10s} {'diff/stderr':>12s}")
        for pname, p in fd.params.items():
            q = sens.params[pname]
            print(f"  {pname:8s} {p.value:14.8g} {q.value:14.8g} {p.stderr:10.3g} "
                  f"{(q.value - p.value) / p.stderr:+12.4f}")


if __name__ == "__main__":
    main()
