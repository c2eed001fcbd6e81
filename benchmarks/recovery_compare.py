"""The recovery tests' fits, written out and compared with another code's (prints; no pass/fail).

Usage::

    .venv/bin/python benchmarks/recovery_compare.py --out new.json [--compare old.json]

Fits every record of ``tests/fitting/test_fit_recovery.py`` (this tree's records, seeds 0-5 of each
model and of the memory-only fractional model, the tests' own options: few starts, no time
budget, profile sigmas) with whatever ``pendtrack`` is importable, in one process, and writes
each fit's Xi^2_min, values, standard errors and z-scores (the tests' definition) to
``--out``. ``--compare`` prints issue #16's "nothing found changes" table against an earlier
``--out``: Xi^2_min (relative change), the largest change of a value in standard errors,
the largest |z| of the parameters the tests bound (all but Omega0), before and after. With
older code::

    git worktree add /tmp/base <commit>
    PYTHONPATH=/tmp/base .venv/bin/python benchmarks/recovery_compare.py --out /tmp/rec-base.json
    .venv/bin/python benchmarks/recovery_compare.py --out /tmp/rec-new.json --compare /tmp/rec-base.json

Not run by ``make bench`` (it needs a second code to mean anything); ~2 min with this code.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1] / "tests"
sys.path[:0] = [str(TESTS / "fitting"), str(TESTS)]  # the recovery tests, and the helpers they import

import test_fit_recovery as recovery  # noqa: E402

from pendtrack.fitting import fit_model  # noqa: E402
from pendtrack.models import get_model  # noqa: E402

SEEDS = range(6)


def fit_all() -> dict[str, dict]:
    """Every recovery record fitted: ``{case: {xi2, converged, seconds, params: {name: [value, stderr]}, z}}``."""
    cases = [(n, s, False) for n in recovery.CASES for s in SEEDS] + [("fractional", s, True) for s in SEEDS]
    out = {}
    for name, seed, memory_only in cases:
        truth = recovery.MEMORY_ONLY if memory_only else recovery.TRUTHS[name]
        fixed = {"G1": 0.0} if memory_only else None
        t, theta, omega, alpha, ok, obs = recovery.record(name, seed, truth)
        t0 = time.monotonic()
        res = fit_model(get_model(name), t, theta, omega, alpha=alpha, ok=ok, observation=obs,
                        options=recovery.options(recovery.N_STARTS[name]), seed=seed, workers=1, fixed=fixed)
        z = {k: (res.params[k].value - v) / (res.params[k].stderr_low if res.params[k].value > v
                                              else res.params[k].stderr_high)
             for k, v in truth.items() if k not in (fixed or {})}
        key = f"{name}{'-memory' if memory_only else ''}-{seed}"
        out[key] = {"xi2": res.xi2_min, "converged": bool(res.converged), "seconds": time.monotonic() - t0,
                    "params": {k: [p.value, p.stderr] for k, p in res.params.items()}, "z": z}
        print(f"{key:<20} {out[key]['seconds']:6.1f} s  Xi2_min {res.xi2_min:.10g}", flush=True)
    return out


def compare(old: dict[str, dict], new: dict[str, dict]) -> None:
    """Print the change from ``old`` to ``new`` case by case."""
    for key, a in old.items():
        b = new.get(key)
        if b is None:
            print(f"{key:<20} not in the new file")
            continue
        rel = (b["xi2"] - a["xi2"]) / a["xi2"]
        moves = {p: (b["params"][p][0] - v[0]) / v[1] for p, v in a["params"].items() if v[1]}
        worst = max(moves, key=lambda p: abs(moves[p]))
        za = max(abs(v) for k, v in a["z"].items() if k != "Omega0")
        zb = max(abs(v) for k, v in b["z"].items() if k != "Omega0")
        print(f"{key:<20} Xi2_min {rel:+.2e} relative; largest move {moves[worst]:+.3f} SE ({worst}); "
              f"max |z| {za:.2f} -> {zb:.2f}; converged {a['converged']} -> {b['converged']}")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="JSON file to write")
    ap.add_argument("--compare", default=None, help="an earlier --out to compare with")
    args = ap.parse_args(argv)
    fits = fit_all()
    Path(args.out).write_text(json.dumps(fits))
    if args.compare:
        compare(json.loads(Path(args.compare).read_text()), fits)


if __name__ == "__main__":
    main()
