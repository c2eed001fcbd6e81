"""Benchmark: discovery on a 60-s, 120-fps synthetic run (prints, no pass/fail).

Target (issues "Discovery" and #14): within 5 minutes on 2 cores, the measurement step and the
pair search included when they are needed. Run: ``python benchmarks/bench_discover.py [CASE]``
with CASE one of

* ``pair`` (default): memory and time-varying damping together, theta's zero offset by 8 mrad --
  the measurement step keeps the offset, then the effects are searched (singles, and pairs when
  no single earns its keep);
* ``memory``: memory alone, no artefact (the original benchmark).
"""

from __future__ import annotations

import os
import sys
import time


def main(case: str = "pair") -> None:
    import numpy as np

    from pendtrack.config import Config
    from pendtrack.discovery.inputs import AngleSeries
    from pendtrack.discovery.loop import discover
    from pendtrack.discovery.synthetic import simulate_run

    params = {"Omega0": 5.6, "C1": 0.02, "C0": 0.012, "C2": 0.004, "G2": 0.008, "beta": 0.5, "p_f": 1.5}
    effects: tuple[str, ...] = ("memory",)
    measurement = None
    if case == "pair":
        params.update({"C4": 0.8, "t0": -6.0, "theta_off": 0.008})
        effects, measurement = ("memory", "time_varying_damping"), "offset"
    elif case != "memory":
        raise SystemExit(f"unknown case {case!r} (pair, memory)")
    rng = np.random.default_rng(2024)
    t, theta = simulate_run(params, effects, duration=60.0, theta0=2.9, noise=0.003, rng=rng,
                            measurement=measurement)
    series = AngleSeries(t, theta, source=f"bench-{case}-60s", kind="table")  # type: ignore[arg-type]
    config = Config()
    print(f"cores: {os.cpu_count()}, record: {t.size} samples over {t[-1]:.1f} s at 120 Hz, hidden: "
          f"{', '.join(effects)}{', ' + measurement if measurement else ''}")
    t0 = time.perf_counter()
    res = discover(series, config=config)
    wall = time.perf_counter() - t0
    print(f"discovery: {wall:.1f} s wall (target < 300 s); measurement: {list(res.measurement) or 'none'}; "
          f"effects added: {list(res.effects) or 'none'}; unexplained: {list(res.unexplained) or 'nothing'}")
    timing = res.data["timing"]
    print(f"  baseline fits + diagnosis: {timing['baseline_s']:.1f} s; "
          f"measurement step: {timing['measurement_s']:.1f} s")
    for k, s in enumerate(timing["steps_s"], start=1):
        tried = [c.effect for c in res.candidates if c.step == k and c.kind == "effect"]
        print(f"  step {k}: {s:.1f} s for {len(tried)} candidates ({', '.join(tried)})")
    try:
        load = os.getloadavg()[0]
        print(f"  load average at the end: {load:.1f} (other processes share the cores)")
    except OSError:
        pass
    print(f"  residual RMS {1e3 * res.baseline_fit.rms:.3f} -> {1e3 * res.final_fit.rms:.3f} mrad (noise 3.000)")


if __name__ == "__main__":
    main(*sys.argv[1:2])
