"""CI of issue 15: `pendtrack run VIDEO [--projection none] [--marker-color dark|blue]` on field renders.

Each condition of :data:`field_run.CONDITIONS` is rendered small and short (640x360, 12 s;
one at 1080p) and run through the whole pipeline with no other flag than the lens and the
marker's colour, as a new user would. Targets (issue 15, "Done when"): >= 99 % of the frames
where the marker is visible tracked ok, theta within 2 mrad RMS of the truth (README's zero
convention, the camera's roll included; see :mod:`field_run`), Omega0 of every fitted model
(classic, opa, fractional) within 0.1 % of the renderer's -- or, missed, flagged by the fit itself
as no measurement of the swing's frequency (the memory term as an added mass; README, Known limits).

`run` fits three models with 150 starts each and is slow: two conditions run by default (a
dark ball on a string through a normal lens at 30 fps with the axle above the frame; a blue
ball held by a hand for 2 s, at 60 fps), the others (the roll, the sticker, 1080p, each
condition alone, the balls on the paper's bar) are marked slow. A target missed because of code outside the renderer is an
``xfail(strict=True)`` naming the measured figure, so that a fix shows as XPASS.
"""

from __future__ import annotations

import pytest
from factory import CONDITIONS, OK_MIN, OMEGA0_REL_MAX, THETA_RMS_MAX, flags_for, render_condition, run_and_score

pytestmark = [pytest.mark.video, pytest.mark.integration]  # `pendtrack run` in a subprocess on rendered field videos

DEFAULT = ("dark_string_normal_lens_30fps_axle_out", "blue_ball_hand_60fps")
MODELS = ("classic", "opa", "fractional")

# (condition, what) -> why it fails today, with the figure measured (what: "tracking" or a model).
# Every other (condition, what) met its target when last measured; figures in the session's report.
# dark_ball_on_bar left on 2026-11-24 (it lost the marker in 529 of 719 frames: the ball merged with the dark grey
# bar was no candidate): the ball is split off the bar by its depth and the bar is floored out of its template
# (pendtrack.track.detect._touching_discs); measured 100 % of the frames ok (scores >= 0.957), theta 0.33 mrad RMS,
# Omega0 within 9.1e-5 (classic), 4.5e-6 (opa), 1.1e-4 (fractional).
_ON_BAR: dict[str, str] = {}
KNOWN: dict[tuple[str, str], str] = {(c, what): why for c, why in _ON_BAR.items() for what in ("tracking", "classic", "opa", "fractional")}


def _marks(condition: str, what: str) -> list:
    marks = [] if condition in DEFAULT else [pytest.mark.slow]
    if (condition, what) in KNOWN:
        marks.append(pytest.mark.xfail(strict=True, reason=KNOWN[condition, what]))
    return marks


@pytest.fixture(scope="module")
def scored(tmp_path_factory):
    """``scored(condition) -> Score``: rendered and run once per condition and module."""
    cache = {}

    def get(condition: str):
        if condition not in cache:
            base = tmp_path_factory.mktemp(condition)
            values = CONDITIONS[condition]
            folder = render_condition(base / "render", values)
            cache[condition] = run_and_score(folder, base / "run", flags_for(values))
        return cache[condition]

    return get


@pytest.mark.parametrize("condition", [pytest.param(c, marks=_marks(c, "tracking")) for c in CONDITIONS])
def test_run_tracks_the_visible_frames_within_2_mrad(scored, condition):
    score = scored(condition)
    assert score.returncode in (0, 1), score.stderr  # 1: a fit did not converge (judged below), no crash
    assert "Traceback" not in score.stderr
    assert score.ok_visible >= OK_MIN, score
    assert score.theta_rms <= THETA_RMS_MAX, score


@pytest.mark.parametrize("condition, model", [pytest.param(c, m, marks=_marks(c, m)) for c in CONDITIONS
                                              for m in MODELS])
def test_run_finds_omega0_within_0_1_percent(scored, condition, model):
    score = scored(condition)
    assert model in score.omega0_rel, score
    if score.omega0_rel[model] > OMEGA0_REL_MAX:
        # missed only where the fit itself says its Omega0 is no measurement of the swing's frequency: the
        # fractional model's memory term as an added mass (beta and p_f within 2 standard errors of 1; a rule
        # of the fit that knows no truth, pendtrack.fitting.result.INERTIA_SIGMAS), whose inertia Omega0 trades
        # off against G2. axle_out_of_frame's 12-s record at 0.8 rad carries little damping, and whether a
        # start reaches that lower minimum (Xi^2 1 % below the drag-like one) depends on the machine's rounding
        assert "not the frequency of the swing" in score.omega0_flag.get(model, ""), score
