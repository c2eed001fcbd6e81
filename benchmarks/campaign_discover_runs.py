"""Discovery across runs on hidden-effect series: how often the effects are named, and how long it takes.

Usage::

    nice -n 19 .venv/bin/python benchmarks/campaign_discover_runs.py --cases 5 [--kinds pair,strong_drag]
        [--seconds 60] [--base-seed 20260] [--out discover_runs.json]

Each case is a :func:`pendtrack.discovery.synthetic.draw_series` series: three runs of one pendulum,
released from pi - 0.1, 2.2 and 1.2 rad, ``--seconds`` each at 120 Hz with 2-3 mrad noise, drawn from
seed ``base_seed + i`` at run time. The tool gets ``t`` and ``theta`` of each run, never the case.

Kinds (the issue's bars):

* ``pair``: time-varying damping + memory; both must be named (>= 80 % of the cases);
* ``strong_drag``: memory with a strong quadratic drag (``C2`` 0.02-0.04); time-varying damping
  must never be named (nor kept under ``partial``).

Resumable: each finished case is one JSON line in ``<out>.jsonl``; a rerun fits only the missing ones.
The summary (share named, runtime per case) goes to ``--out`` and stdout, with the CPU model.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

KINDS = {"pair": (("time_varying_damping", "memory"), False), "strong_drag": (("memory",), True)}


def run_case(kind: str, seed: int, seconds: float) -> dict:
    """One case: draw the series, discover across its runs, record what was named."""
    from pendtrack.config import Config
    from pendtrack.discovery.across_runs import discover_runs
    from pendtrack.discovery.inputs import AngleSeries
    from pendtrack.discovery.synthetic import draw_series

    effects, strong = KINDS[kind]
    s = draw_series(seed, effects, duration=seconds, strong_drag=strong)
    series = {f"release{i + 1}": AngleSeries(r.t, r.theta, source=f"release{i + 1}", kind="table")  # type: ignore[arg-type]
              for i, r in enumerate(s.runs)}
    t0 = time.perf_counter()
    res = discover_runs(series, config=Config())
    return {"kind": kind, "seed": seed, "seconds": seconds, "truth": list(effects), "params": s.params,
            "effects": list(res.effects), "partial": list(res.partial),
            "scopes": {k: v["scope"] for k, v in res.scopes.items()},
            "unexplained": {r: list(v) for r, v in res.unexplained.items()},
            "candidates": [c.to_dict() for c in res.candidates], "runtime_s": time.perf_counter() - t0}


def verdict(line: dict) -> bool:
    """The case meets its bar: the pair both named; the strong drag without time-varying damping."""
    if line["kind"] == "pair":
        return set(line["truth"]) <= set(line["effects"])
    return "time_varying_damping" not in line["effects"] + line["partial"]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=5, help="cases per kind")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--seconds", type=float, default=60.0, help="each run's length [s]")
    ap.add_argument("--base-seed", type=int, default=20260)
    ap.add_argument("--out", type=Path, default=Path("discover_runs.json"))
    args = ap.parse_args(argv)
    kinds = [k for k in args.kinds.split(",") if k]
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        print(f"error: unknown kind {unknown[0]!r} (kinds: {', '.join(KINDS)})", file=sys.stderr)
        sys.exit(2)
    log = args.out.with_suffix(".jsonl")
    done = {}
    if log.is_file():
        for text in log.read_text().splitlines():
            line = json.loads(text)
            if line["seconds"] == args.seconds:
                done[(line["kind"], line["seed"])] = line
    for kind in kinds:
        for i in range(args.cases):
            seed = args.base_seed + i
            if (kind, seed) in done:
                continue
            line = run_case(kind, seed, args.seconds)
            done[(kind, seed)] = line
            with log.open("a") as fh:
                fh.write(json.dumps(line) + "\n")
            print(f"{kind:<12} seed {seed}  named {line['effects']}  partial {line['partial']}  "
                  f"{'meets' if verdict(line) else 'misses'}  {line['runtime_s']:.0f} s", flush=True)
    from bench_run import cpu_model  # this folder's: the CPU named as the other benchmarks name it

    summary = {"cpu": cpu_model(), "seconds": args.seconds, "kinds": {}}
    for kind in kinds:
        lines = [done[(kind, args.base_seed + i)] for i in range(args.cases)]
        met = sum(verdict(x) for x in lines)
        summary["kinds"][kind] = {"cases": len(lines), "meets": met, "share": met / len(lines),
                                  "runtime_s": [round(x["runtime_s"], 1) for x in lines]}
        print(f"{kind:<12} {met}/{len(lines)} meet the bar; runtime per case "
              f"{min(x['runtime_s'] for x in lines):.0f}-{max(x['runtime_s'] for x in lines):.0f} s ({summary['cpu']})")
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text(json.dumps(summary, indent=1))
    tmp.replace(args.out)


if __name__ == "__main__":
    main()
