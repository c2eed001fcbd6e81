"""Two resolutions of one rendered take give the same zero of theta (issue #27).

One scene (a blue ball on a string, normal lens, the axle above the frame, 60 fps) is rendered at
1280x720 and at 640x360 -- the same motion, the same seed -- and run as a user would
(``pendtrack run --projection none --marker-color blue --model classic``). The take never comes to
rest, so theta's zero is not measured and the fit carries it as ``theta_off``; both copies must
agree on it within 2 standard errors of their difference (issue 27 found 5.5 mrad between the
1080p and 720p copies of one real take, ~6 of their standard errors).
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from factory import render_condition

pytestmark = [pytest.mark.video, pytest.mark.integration]  # `pendtrack run` in a subprocess on two renders

BLUE_STRING = dict(rig="string", marker_color="blue", marker_shape="ball", spot_radius_m=0.02, lens_projection="none",
                   lens_fov_deg=70.0, camera_offset_m=(0.0, 0.13), theta0=0.8, fps=60.0, seconds=8.0)


def _theta_off(folder, out):
    env = os.environ | {"PYTHONPATH": os.pathsep.join(filter(None, [os.getcwd(), os.environ.get("PYTHONPATH")]))}
    proc = subprocess.run([sys.executable, "-m", "pendtrack", "run", str(folder / "video.mp4"), "--out", str(out), "-q",
                           "--projection", "none", "--marker-color", "blue", "--model", "classic"],
                          capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    (path,) = sorted(out.glob("fit_*.json"))
    p = json.loads(path.read_text())["params"]["theta_off"]
    return p["value"], p["stderr"]


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "not met yet: measured theta_off -0.022 +- 0.016 mrad (1280x720) and +0.144 +- 0.031 mrad (640x360), 4.8 "
    "standard errors apart; the 640x360 theta is 0.12-0.15 mrad off the truth (a 0.035 px sideways bias of the "
    "tracked point on a 235 px arc, with refine = centroid 0.24 mrad), while the fit's standard error counts "
    "white noise only"))
def test_two_resolutions_of_one_take_give_one_zero(tmp_path):
    offs = {}
    for w, h in ((1280, 720), (640, 360)):
        folder = render_condition(tmp_path / f"r{w}", BLUE_STRING | dict(width=w, height=h))
        offs[w] = _theta_off(folder, tmp_path / f"out{w}")
    (a, sa), (b, sb) = offs[1280], offs[640]
    assert np.isfinite([a, sa, b, sb]).all() and sa > 0 and sb > 0
    assert abs(a - b) <= 2 * np.hypot(sa, sb), offs
