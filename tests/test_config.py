"""Config: defaults file agrees with the dataclasses; loading, overrides and errors."""

from pathlib import Path

import pytest

from pendtrack.config import Config, config_from_dict, load_config
from pendtrack.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]


def test_default_toml_matches_dataclass_defaults():
    # configs/default.toml documents every tunable; it must say exactly what the code does.
    import tomllib

    path = ROOT / "configs" / "default.toml"
    raw = tomllib.loads(path.read_text())
    defaults = Config().to_dict()
    for section, values in defaults.items():
        assert section in raw, f"[{section}] missing from {path}"
        missing = sorted(set(values) - set(raw[section]))
        assert not missing, f"[{section}] keys missing from {path}: {missing}"
    assert load_config(path).to_dict() == defaults


def test_partial_file_overrides_only_its_keys(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text("[kinematics]\nsavgol_order = 5\n[fit]\nn_starts = 10\n")
    cfg = load_config(p)
    assert cfg.kinematics.savgol_order == 5 and cfg.fit.n_starts == 10
    assert cfg.kinematics.savgol_window_s == Config().kinematics.savgol_window_s


def test_int_is_accepted_for_float_and_tuple_from_list():
    cfg = config_from_dict({"lens": {"fov_deg": 110}, "track": {"roi": [1, 2, 3, 4]}})
    assert cfg.lens.fov_deg == 110.0 and isinstance(cfg.lens.fov_deg, float)
    assert cfg.track.roi == (1, 2, 3, 4)


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("[lens]\nfov = 120\n", "unknown key 'lens.fov'"),
        ("[nope]\nx = 1\n", "unknown section '[nope]'"),
        ("[fit]\nn_starts = 'many'\n", "'fit.n_starts' must be an integer"),
        ("[lens\n", "not valid TOML"),
    ],
)
def test_bad_config_names_file_and_key(tmp_path, text, fragment):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config(p)
    assert str(p) in str(err.value) and fragment in str(err.value)


def test_missing_config_file(tmp_path):
    with pytest.raises(ConfigError, match="config file not found"):
        load_config(tmp_path / "absent.toml")


def test_replace_overrides_one_section_and_validates():
    cfg = Config().replace("fit", n_starts=7)
    assert cfg.fit.n_starts == 7 and Config().fit.n_starts == 150
    with pytest.raises(ConfigError):
        Config().replace("fit", n_starts="x")


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("[kinematics]\nsavgol_window_s = -1\n", "'kinematics.savgol_window_s' must be > 0, got -1"),
        ("[kinematics]\nsavgol_order = 0\n", "'kinematics.savgol_order' must be >= 1, got 0"),
        ("[kinematics]\nmax_gap_s = nan\n", "'kinematics.max_gap_s' must be finite, got nan"),
        ("[lens]\nprojection = 'fish'\n", "'lens.projection' must be one of equisolid, equidistant"),
        ("[lens]\nfixed_pixels = 1.5\n", "'lens.fixed_pixels' must be within (0, 1], got 1.5"),
        ("[video]\nfps = -30\n", "'video.fps' must be >= 0, got -30"),
        ("[video]\nstart = -1.0\n", "'video.start' must be >= 0, got -1.0"),
        ("[video]\nstart = 5.0\nend = 2.0\n", "'video.end' must be 0 (to the last frame) or later than"),
        ("[track]\nacquire_step_s = 0.0\n", "'track.acquire_step_s' must be > 0, got 0.0"),
        ("[track]\nmax_drift_px = -3.0\n", "'track.max_drift_px' must be > 0, got -3.0"),
        ("[track]\nroi = [1, 2, 3]\n", "'track.roi' must be [] or [x, y, w, h], got [1, 2, 3]"),
        ("[track]\nrefine = 'cubic'\n", "'track.refine' must be one of quadratic, centroid"),
        ("[angle]\nrest_seconds = 0\n", "'angle.rest_seconds' must be > 0, got 0"),
        ("[models]\nmemory_s = 0.0\n", "'models.memory_s' must be > 0, got 0.0"),
        ("[fit]\ncost = 'l1'\n", "'fit.cost' must be one of xi2, theta, got 'l1'"),
        ("[fit]\njacobian = 'adjoint'\n", "'fit.jacobian' must be one of sensitivity, fd, got 'adjoint'"),
        ("[fit]\nn_starts = 0\n", "'fit.n_starts' must be >= 1, got 0"),
        ("[fit]\naccept_ratio = 0.9\n", "'fit.accept_ratio' must be >= 1, got 0.9"),
        ("[fit]\nmodels = ['classic', '']\n", "'fit.models' must hold non-empty names"),
        ("[batch]\nextensions = ['mp4']\n", "'batch.extensions' must hold suffixes with the dot"),
        ("[batch]\nthreads_per_worker = 0\n", "'batch.threads_per_worker' must be >= 1, got 0"),
        ("[discover]\ntrain_fraction = 1.0\n", "'discover.train_fraction' must be within (0, 1), got 1.0"),
        ("[discover]\nseed = -1\n", "'discover.seed' must be >= 0, got -1"),
    ],
)
def test_bad_config_value_names_file_key_and_range(tmp_path, text, fragment):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config(p)
    assert str(err.value).startswith(f"{p}: ") and fragment in str(err.value)
    assert "\n" not in str(err.value)  # one line


def test_flags_are_checked_like_the_file():
    with pytest.raises(ConfigError, match="'kinematics.savgol_window_s' must be > 0, got -0.5"):
        Config().replace("kinematics", savgol_window_s=-0.5)


def test_one_list_of_video_suffixes():
    from pendtrack.batch import runcode
    from pendtrack.config import VIDEO_SUFFIXES
    from pendtrack.discovery import inputs

    assert Config().batch.extensions == VIDEO_SUFFIXES
    assert inputs.is_video("a.WEBM") and inputs.is_video("b.mts")
    assert runcode.parse_run_code("06na5.wmv").run_id == runcode.parse_run_code("06na5").run_id
