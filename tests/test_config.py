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
