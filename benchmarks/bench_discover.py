"""Benchmark: discovery on a 60-s, 120-fps synthetic run carrying memory (prints, no pass/fail).

Target (issue "Discovery"): within 5 minutes on 2 cores. Run: ``python benchmarks/bench_discover.py``.
"""

from __future__ import annotations

import os
import time


def main() -> None:
    import numpy as np

    from pendtrack.config import Config
    from pendtrack.discovery.inputs import AngleSeries
    from pendtrack.discovery.search import discover
    from pendtrack.discovery.synthetic import simulate_run

    params = {"Omega0": 5.6, "C1": 0.02, "C0": 0.012, "C2": 0.004, "G2": 0.008, "beta": 0.5, "p_f": 1.5}
    rng = np.random.default_rng(2024)
    t, theta = simulate_run(params, "memory", duration=60.0, theta0=2.9, noise=0.003, rng=rng)
    series = AngleSeries(t, theta, source="bench-memory-60s", kind="table")  # type: ignore[arg-type]
    config = Config()
    print(f"cores: {os.cpu_count()}, record: {t.size} samples over {t[-1]:.1f} s at 120 Hz, hidden effect: memory")
    t0 = time.perf_counter()
    res = discover(series, config=config)
    wall = time.perf_counter() - t0
    print(f"discovery: {wall:.1f} s wall (target < 300 s); effects added: {list(res.effects) or 'none'}")
    timing = res.data["timing"]
    print(f"  baseline fits + diagnosis: {timing['baseline_s']:.1f} s")
    for k, s in enumerate(timing["steps_s"], start=1):
        tried = [c.effect for c in res.candidates if c.step == k]
        print(f"  step {k}: {s:.1f} s for {len(tried)} candidates ({', '.join(tried)})")
    try:
        load = os.getloadavg()[0]
        print(f"  load average at the end: {load:.1f} (other processes share the cores)")
    except OSError:
        pass
    print(f"  residual RMS {1e3 * res.baseline_fit.rms:.3f} -> {1e3 * res.final_fit.rms:.3f} mrad (noise 3.000)")


if __name__ == "__main__":
    main()
