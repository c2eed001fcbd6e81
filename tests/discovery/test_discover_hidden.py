"""Hidden-effect tests: discovery must name what a synthetic run carries, and nothing more.

Each case is drawn at run time from a base seed (``PENDTRACK_DISCOVER_SEED``, default below,
printed in every failure so that a case can be replayed) by
:func:`pendtrack.discovery.synthetic.draw_run`: release near the top, standard damping in
realistic ranges, and

* one hidden effect -- added mass (Ca 0.01-0.03), time-varying damping or memory (beta
  0.3-0.7; these two redrawn until a standard fit leaves a residual >= 1.2 x the noise) -- or
  two of them (every pair; each redrawn until it alone would leave that residual);
* or none (a control), or none with a measurement artefact: theta's zero offset by 5-15 mrad,
  or an angle scale wrong by 5-15 % at 2.5 rad.

The tool receives only ``t`` and ``theta``, and runs with its default configuration (the
catalogue, the measurement terms, the pair search) but for ``max_effects`` (below). Bars:

=====================================  ============================================  ======
case                                   required                                      bar
=====================================  ============================================  ======
one effect, 120 Hz, 60-90 s            the effect named first                        >= 90 %
one effect, 30 fps, 40 s, 3-5 mrad     the effect named first                        >= 80 %
two effects (a pair)                   both named                                    >= 80 %
measurement artefact, no effect        the term kept as a measurement, no effect     >= 90 %
control                                no effect                                     100 %
outside the catalogue (controls)       no cause named                                100 %
=====================================  ============================================  ======

Measured 2026-11-24 (base seed 20250): 30 fps singles 8/9 named first (slow suite; 2026-11-27, the campaign's 12
cases: 12/12), controls 2/2 clean,
artefacts 8/8 (4 offsets of 6.8-10.0 mrad, 4 scale errors of 6-14 % at 2.5 rad: the term kept, no
effect), pairs at 30 fps 0/3 (a campaign, strict xfail; see its comment). 2026-11-25: pairs at 120 Hz
5/6 in the model kept (a campaign, run twice; see its comment); 2026-11-26: 8/12 over 12 cases; 2026-11-27: 10/12.

A pair counts as named when both effects are in the model kept, or in a model of the same size that
discovery reports it cannot tell apart from the one kept (``DiscoveryResult.equivalents``: within the
BIC an effect needs to be kept); the test prints both counts.

The default (CI) suite runs the 10 cheapest cases (controls and artefacts on 20-40 s of 30 fps:
discovery's cost grows with the samples); the slow suite, also run by CI, the 9 singles at 30 fps,
14 single-effect and control cases and 6 artefacts at 120 Hz, and 4 records of physics outside the catalogue
(a drifting Omega0 twice, a weak drive, a changing length): 43 cases in CI. The last two kinds, where discovery
must name no physical cause, are in ``test_discover_no_cause.py`` (so that CI's test workers share the suite's
longest file between them). The pair campaigns run by
hand (PENDTRACK_CAMPAIGN=1): 6 pairs at 120 Hz take 10-25 minutes, more than the slow suite can spare.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from pendtrack.config import Config
from pendtrack.discovery.inputs import AngleSeries
from pendtrack.discovery.loop import discover
from pendtrack.discovery.synthetic import ARTEFACTS, HIDDEN_EFFECTS, HIDDEN_PAIRS, draw_run

pytestmark = pytest.mark.integration  # discovery's whole search (every candidate fit) on each synthetic run

BASE_SEED = int(os.environ.get("PENDTRACK_DISCOVER_SEED", "20250"))
KINDS: tuple[str | None, ...] = (None, *HIDDEN_EFFECTS)
# CI-size records at 30 fps (a phone's rate); discovery's cost grows with the samples, so each kind
# gets the shortest record its question needs:
SINGLE_30FPS = {"rate_hz": 30.0, "duration": (40.0, 40.0), "noise": (0.003, 0.005)}  # the case: 40 s, 3-5 mrad
# two effects at realistic size need a longer record to tell apart (memory with beta near 1 mimics
# added mass; over 40 s one case of added mass + memory left added mass at dBIC ~0 after memory)
PAIR_30FPS = {"rate_hz": 30.0, "duration": (55.0, 65.0)}
# at 30 fps even 55-65 s do not separate them (0 of 3: memory, three parameters, absorbs the other
# effect within BIC's penalty); the pairs are "at realistic size", not at a phone's rate, and
# 60-70 s at 120 Hz (analysed at 60 Hz) do (slow suite)
PAIR_120HZ = {"rate_hz": 120.0, "duration": (60.0, 70.0)}
# a 5-15 mrad offset or a 5-15 % scale error against 2-4 mrad noise shows in a few swings; 20-25 s
# leave >= 240 held-out samples, and the physical step on the rest is what a control would see
ARTEFACT_30FPS = {"rate_hz": 30.0, "duration": (20.0, 25.0)}


# Campaigns of the bars not met yet (expected to fail, minutes to half an hour each on 2 cores): run
# by hand with PENDTRACK_CAMPAIGN=1 (`PENDTRACK_CAMPAIGN=1 make test-slow`), not in CI, whose 90
# minutes they would take for a figure their measured comments already state.
CAMPAIGN = pytest.mark.skipif(not os.environ.get("PENDTRACK_CAMPAIGN"),
                              reason="campaign of an unmet bar: set PENDTRACK_CAMPAIGN=1 to run it")


def _seeds(salt: int, n: int) -> list[int]:
    rng = np.random.default_rng([BASE_SEED, salt])
    return [int(s) for s in rng.integers(0, 2**31 - 1, size=n)]


def _plan(n_per_kind: int, salt: int) -> list[tuple[int, str | None]]:
    """Balanced kinds in an order (and seeds) drawn from the base seed."""
    rng = np.random.default_rng([BASE_SEED, salt])
    kinds = [k for k in KINDS for _ in range(n_per_kind)]
    order = rng.permutation(len(kinds))
    return [(int(rng.integers(0, 2**31 - 1)), kinds[i]) for i in order]


def _run_case(seed: int, truth: str | tuple[str, ...] | None, *, measurement: str | None = None,
              max_effects: int = 1, outside: str | None = None, **draw: object) -> dict:
    run = draw_run(seed, truth, measurement=measurement, outside=outside, **draw)  # type: ignore[arg-type]
    series = AngleSeries(run.t, run.theta, source=f"synthetic seed {seed}", kind="table")  # type: ignore[arg-type]
    # One step decides "named first" and a control's "nothing": the tests spare the (equally long)
    # later steps; a pair needs two.
    res = discover(series, config=Config().replace("discover", max_effects=max_effects))
    # what `pendtrack discover` writes (discovery.json): every decision, replaced effects included, serialises
    # (an effect replaced by another was recorded with its replacement's fit and raised KeyError here)
    json.dumps(res.to_dict())
    return {"seed": seed, "truth": list(run.effects), "measurement_truth": measurement, "found": list(res.effects),
            "partial": list(res.partial), "outside": outside,
            "measurement": list(res.measurement), "unexplained": list(res.unexplained),
            "equivalents": [e["effects"] for e in res.equivalents],
            "params": {k: round(v, 5) for k, v in run.params.items()}, "excess": run.excess,
            "rate_hz": run.rate_hz, "duration": round(float(run.t[-1]), 1), "noise": round(run.noise, 4),
            "steps": [(s.effect, round(s.delta_bic, 1), round(s.heldout_z, 1))
                      for s in (*res.measurement_steps, *res.steps)],
            "runtime_s": round(res.runtime_s, 1)}


def _report(outcomes: list[dict]) -> str:
    lines = "\n".join(str(o) for o in outcomes)
    print(f"base seed {BASE_SEED}:\n{lines}")  # shown with -s (or -rP) even when the test passes
    return lines


def _check_single(outcomes: list[dict], bar: float) -> None:
    lines = _report(outcomes)
    effect_cases = [o for o in outcomes if o["truth"]]
    hits = [o for o in effect_cases if o["found"][:1] == o["truth"][:1]]
    false_alarms = [o for o in outcomes if not o["truth"] and o["found"]]
    assert not false_alarms, f"effect reported on a control (base seed {BASE_SEED}):\n{lines}"
    assert len(hits) >= bar * len(effect_cases), (
        f"hidden effect named first in {len(hits)}/{len(effect_cases)} cases (base seed {BASE_SEED}):\n{lines}")


def _check_pairs(outcomes: list[dict], bar: float = 0.8) -> None:
    lines = _report(outcomes)
    # named: in the model kept, or in a model of the same size that discovery reports it cannot tell
    # apart from it (within the BIC an effect needs to be kept; DiscoveryResult.equivalents)
    strict = [o for o in outcomes if set(o["truth"]) <= set(o["found"])]
    hits = [o for o in outcomes if set(o["truth"]) <= set(o["found"])
            or any(set(o["truth"]) <= set(e) for e in o["equivalents"])]
    print(f"both named in the model kept: {len(strict)}/{len(outcomes)}; kept or not told apart from it: "
          f"{len(hits)}/{len(outcomes)}")
    assert len(hits) >= bar * len(outcomes), (
        f"both effects named in {len(hits)}/{len(outcomes)} pair cases ({len(strict)} in the model kept; "
        f"base seed {BASE_SEED}):\n{lines}")


def _check_measurement(outcomes: list[dict], bar: float = 0.9) -> None:
    lines = _report(outcomes)
    hits = [o for o in outcomes if o["measurement_truth"] in o["measurement"] and not o["found"]]
    assert len(hits) >= bar * len(outcomes), (
        f"measurement term named and no effect in {len(hits)}/{len(outcomes)} cases (base seed {BASE_SEED}):"
        f"\n{lines}")


# --- the default (CI) suite: controls and artefacts at 30 fps; the singles in the slow suite ---

# Measured 2026-11-24 (base seed 20250, load 5-9): 8 of 9 named first -- the 3 cases of salt 11 (one per
# effect) and the 6 of salt 14 (each effect twice). The miss: added mass (seed 835980378, Ca 0.0165) taken
# for memory (beta 1.03, p_f 4.0: a local, velocity-dependent inertia, not memory) -- the true model's
# 24-s training fit splits Coulomb and viscous damping wrongly (C0 0.018 vs 0.008; its training Xi^2 is
# below the truth's), extrapolates to 7.0 mrad held-out (the noise is 3.5) and misses the z > 3 gate
# (2.8). 9 cases (each effect three times): with 3, one miss already reads 67 %; the bar is a rate.
# 2026-11-25 (a flagged fit is not kept, #26): 7 of 9. Seed 835980378 keeps nothing (memory's fit is flagged,
# added mass misses the z gate as before); memory seed 1369428722 (beta 0.655, p_f 1.06) is fitted at
# beta = 0.45 +- 0.61, p_f = 1.26 +- 0.54, which FitResult.flags marks as an added mass (both within 2 standard
# errors of 1) although beta is undetermined rather than at 1, so power drag is kept instead (partial: the
# dephasing stays unexplained, no cause named). The flag now asks beta and p_f to be measured (standard
# errors <= 0.25, fitting.result.INERTIA_RESOLUTION) before it calls the term an added mass.
# 2026-11-27: 8 of 9, the same decisions under the host's code and NUMBA_CPU_NAME=generic (before, memory seed
# 1369428722 was named on the host only: the whole-record memory fit's profile over beta ended in one of two
# basins, beta 0.71 or 0.09, as the rounding of its start decided; it now reads a fixed beta grid first).
# 2026-12-02, AMD EPYC family 26 model 2: 7 of 9 on the host's code (8 under generic): memory seed 1369428722's
# whole-record fit ended at beta 0.10 (quadratic drag undetermined, flagged, not kept) where beta 0.68 fits
# 3e-4 lower; the whole-record fit of a model with memory now also starts at beta 0.2, 0.5 and 0.8 (the
# others at the training fit): 8 of 9 under both, memory at beta 0.73 (host) and 0.68 (generic).
@pytest.mark.slow  # 9 cases of 10-30 s (AMD EPYC): with the controls and artefacts, more than the default suite holds
def test_single_effect_at_30fps():
    seeds = _seeds(11, 5)[:3] + _seeds(14, 6)
    _check_single([_run_case(s, HIDDEN_EFFECTS[i % 3], **SINGLE_30FPS) for i, s in enumerate(seeds)], bar=0.8)


def test_controls_at_30fps():
    # two clean runs, 3-5 mrad noise: no effect, no measurement term
    seeds = _seeds(11, 5)[3:]
    outcomes = [_run_case(s, None, max_effects=2, **SINGLE_30FPS) for s in seeds]
    _check_single(outcomes, bar=0.9)
    assert not any(o["measurement"] for o in outcomes), _report(outcomes)


# Measured 2026-11-24 (base seed 20250): 0/3 -- memory named in all three; added mass taken for memory
# (both pairs with added mass: memory's three parameters absorb Ca on 55-65 s at 30 fps), and with
# memory kept, time-varying damping left the envelope off but no single effect earned its keep and
# max_effects = 2 left no room for a pair. The bar is not met; strict, so the mark must go when it is.
@pytest.mark.slow
@CAMPAIGN  # a known shortfall (see comment): its 3 cases (6-8 min) would only restate it in CI
@pytest.mark.xfail(strict=True, reason="pairs at 30 fps: added mass taken for memory (see comment)")
def test_pairs_of_effects_at_30fps():
    # every pair of hidden effects once: 3 cases (two steps each)
    _check_pairs([_run_case(s, pair, max_effects=2, **PAIR_30FPS) for s, pair in zip(_seeds(12, 3), HIDDEN_PAIRS)])


def test_measurement_artefacts_at_30fps():
    # 4 zero offsets and 4 angle-scale errors on clean runs: 8 cases
    seeds = _seeds(13, 8)
    _check_measurement([_run_case(s, None, measurement=ARTEFACTS[i % 2], **ARTEFACT_30FPS)
                        for i, s in enumerate(seeds)])


# --- slow: the 120 Hz cases and more of every kind ------------------------------------------

@pytest.mark.slow
def test_hidden_effect_default_cases():
    # one effect case (kind drawn from the seed) and one control, 120 Hz, 60-90 s
    rng = np.random.default_rng([BASE_SEED, 1])
    kind = HIDDEN_EFFECTS[int(rng.integers(len(HIDDEN_EFFECTS)))]
    cases = [(int(rng.integers(0, 2**31 - 1)), kind), (int(rng.integers(0, 2**31 - 1)), None)]
    _check_single([_run_case(seed, k) for seed, k in cases], bar=0.9)


@pytest.mark.slow
def test_hidden_effect_twelve_cases():
    _check_single([_run_case(seed, k) for seed, k in _plan(3, 2)], bar=0.9)


# Measured 2026-11-27 (base seed 20250, AMD EPYC, 2.7 min beside two other jobs): 12 of 12 -- the 9 effects (added
# mass, time-varying damping, memory, 3 each) named first, the 3 controls clean. A campaign: the slow suite's 9
# cases at 30 fps already hold the bar in CI.
@pytest.mark.slow
@CAMPAIGN
def test_single_effect_at_30fps_twelve_cases():
    _check_single([_run_case(seed, k, max_effects=2 if k is None else 1, **SINGLE_30FPS)
                   for seed, k in _plan(3, 21)], bar=0.8)


# Measured 2026-11-25 (base seed 20250), twice: both effects named in the model kept in 5 of 6 each time (3
# per salt, every pair twice; 83 % >= 80 %). Added mass + time-varying damping: seed 20225987 found as memory
# (beta 1.8: a local inertia standing in for the added mass) + time-varying damping until the replacement
# step put added mass in memory's place (BIC -2891); seed 950551639 found as memory + power drag, each
# standing in for one of the truth's, until the swap of both at once (swap_subset: BIC -14, held-out z 8;
# Ca 0.0266 for 0.0265). The miss is time-varying damping + memory taken for memory + power drag, both a
# damping that weakens as the swings shrink (one free decay cannot separate one that weakens with time from
# one that weakens with amplitude), and which case misses turns on the memory fit's optimum: before the
# RK4 kernels' rounding-level change, seed 617653500 (power drag BIC -83.1, time-varying damping reported
# as not told apart at +2.0; 6/6 counting it); on this code seed 637046549 (power drag -66.0 on a memory fit
# 5.6 BIC worse than before; nothing within 10). A campaign (15 min on 2 cores at load 1-3), not CI: the
# slow suite's 90-minute budget.
# 2026-11-26, 12 cases (every pair 4 times; the first 6 are the cases above), 21 min on 2 cores: 8 of 12 (67 %,
# below the bar). Added mass + time-varying damping 3 of 4 (seed 1931966765 keeps both, under partial: a
# hysteresis diagnostic stays); added mass + memory 3 of 4 (seed 2067032035: memory + power drag); time-varying
# damping + memory 2 of 4 (seed 2043974130: time-varying damping + added mass, memory small; seed 950825763,
# 1.4 x the noise: only added mass passes its rules, kept as partial).
# 2026-11-27, the same 12 cases: 10 of 12 (83 %), 30 min on 2 cores shared with another suite. The profile polish's
# beta grid gives seed 2067032035 memory + added mass; the hysteresis z's reference now carries the noise level's
# error and 30 replicas (seed 1931966765: the true model's loop area read z 3.3, now 2.6; both effects named).
# Misses: seeds 2043974130 and 950825763 as above (time-varying damping + memory 2 of 4). With the kept terms also
# put back at their plain shapes (starts.reseated_starts): the same 10 of 12, 16 min beside the slow suite.
# With a pair tried in the place of one kept effect while structure remains (exchange.swap_subset's grow) and a
# fading effect refitted on interleaved folds: 11 of 12 (seed 950825763: time-varying damping + memory in the
# added mass's place), the other 11 decisions unchanged; 16 min beside the slow suite. Again 11 of 12 with a set
# refused when its fit shows a member absent (rules.absent_terms), the same 12 decisions (15 min, beside two jobs).
@pytest.mark.slow
@CAMPAIGN  # 12 discoveries of 60-70 s at 120 Hz: 15-30 min, more than the slow suite can spare
def test_pairs_of_effects_at_120hz():
    seeds = _seeds(12, 6) + _seeds(22, 6)  # 12 cases, every pair 4 times
    _check_pairs([_run_case(s, HIDDEN_PAIRS[i % 3], max_effects=2, **PAIR_120HZ) for i, s in enumerate(seeds)])


# The same bar at the sizes of a field trial (synthetic.FIELD_SIZES: a simulator written outside the project),
# on its records: 60-80 s at 120 Hz with 2-3 mrad of noise. 2026-11-27 (AMD EPYC, 7.5 min): 6 of 12 with the
# candidates started beside the kept terms' fits (added mass + memory 0 of 4: memory at beta 0.93-0.97 stood in
# for the added mass); 9 of 12 with the kept terms also put back at their plain shapes (starts.reseated_starts):
# 3 of 4 for each pair. Misses: seed 1701770564 (the added mass beside memory at beta 0.97: dBIC -0.5), seeds
# 1454907461 and 2087280414 (time-varying damping after an added mass: held-out gain -0.34 and +0.02 mrad).
# With the pair in the place of one kept effect (exchange.swap_subset's grow) and the fading damping refitted on
# interleaved folds (Context.refit_test): 11 of 12, and 11 of 12 from PENDTRACK_DISCOVER_SEED=20251 (13 min each,
# two at once); the misses are added mass + memory with memory kept at beta near 1 (seeds 1701770564, 428690398).
# With a set refused when its fit shows a member absent (rules.absent_terms): 11 of 12 from base seed 20250, the
# same miss (11 min, beside two jobs).
PAIR_FIELD = {"rate_hz": 120.0, "duration": (60.0, 80.0), "noise": (0.002, 0.003), "sizes": "field"}


@pytest.mark.slow
@CAMPAIGN  # 12 discoveries of 60-80 s at 120 Hz: 20-40 min
def test_pairs_of_effects_at_field_sizes():
    seeds = _seeds(24, 6) + _seeds(25, 6)  # 12 cases, every pair 4 times
    _check_pairs([_run_case(s, HIDDEN_PAIRS[i % 3], max_effects=2, **PAIR_FIELD) for i, s in enumerate(seeds)])


@pytest.mark.slow
@CAMPAIGN
@pytest.mark.xfail(strict=False, reason="not measured in full; 0 of 3 pair cases at 30 fps")
def test_pairs_of_effects_nine_cases():
    seeds = _seeds(22, 9)
    _check_pairs([_run_case(s, HIDDEN_PAIRS[i % 3], max_effects=2, **PAIR_30FPS) for i, s in enumerate(seeds)])
