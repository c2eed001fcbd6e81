"""Keyword options of the library door: the CLI's flag names, mapped onto config keys.

A keyword is the flag's name in Python spelling (``--marker-color`` -> ``marker_color``,
``--starts`` -> ``starts``); its default is the config's, as on the command line. A value the
config refuses raises the config's one-line :class:`~pendtrack.errors.ConfigError`, naming the
keyword the user typed.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pendtrack.config import Config, load_config
from pendtrack.errors import ConfigError

#: keyword -> (config section, key), per door function: the flags of the matching CLI command
TRACK = {"marker_color": ("track", "marker_color"), "marker": ("track", "marker_color"), "roi": ("track", "roi"),
         "min_score": ("track", "min_score"), "evolution_rate": ("track", "evolution_rate"),
         "search_margin_px": ("track", "search_margin_px"), "track_in_corrected": ("track", "track_in_corrected"),
         "projection": ("lens", "projection"), "fov": ("lens", "fov_deg"), "fov_deg": ("lens", "fov_deg"),
         "fixed_pixels": ("lens", "fixed_pixels"), "fps": ("video", "fps"), "start": ("video", "start"),
         "end": ("video", "end")}
ANGLE = {"axle": ("angle", "axle"), "rest_seconds": ("angle", "rest_seconds"),
         "lens_check": ("angle", "lens_check")}
KINEMATICS = {"window_s": ("kinematics", "savgol_window_s"), "order": ("kinematics", "savgol_order"),
              "max_gap_s": ("kinematics", "max_gap_s"), "min_segment_s": ("kinematics", "min_segment_s")}
FIT = {"cost": ("fit", "cost"), "starts": ("fit", "n_starts"), "n_starts": ("fit", "n_starts"),
       "seed": ("fit", "seed"), "workers": ("fit", "workers"), "offset": ("fit", "offset")}
DISCOVER = {"baseline": ("discover", "baseline"), "effects": ("discover", "effects"),
            "n_starts": ("discover", "n_starts"), "workers": ("discover", "workers"), "seed": ("discover", "seed")}


def base_config(config: Config | str | Path | None) -> Config:
    """The config the CLI's ``--config`` would give: a :class:`Config`, a TOML file, or the defaults."""
    if isinstance(config, Config):
        return config
    return load_config(config)


def configure(config: Config | str | Path | None, options: Mapping[str, Any], known: Mapping[str, tuple[str, str]],
              *, what: str) -> Config:
    """``config`` with the given (not None) keyword options applied, each onto its config key.

    Raises
    ------
    ConfigError
        An unknown keyword (naming the ones ``what`` takes), or a value the config refuses.
    """
    cfg = base_config(config)
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise ConfigError(f"{what}: unknown option {', '.join(unknown)} (options: {', '.join(sorted(known))})")
    by_section: dict[str, dict[str, Any]] = {}
    typed: dict[str, str] = {}
    for name, value in options.items():
        if value is None:
            continue
        section, key = known[name]
        if isinstance(value, list):
            value = tuple(value)
        by_section.setdefault(section, {})[key] = value
        typed[f"'{section}.{key}'"] = name
    for section, values in by_section.items():
        try:
            cfg = cfg.replace(section, **values)
        except ConfigError as exc:
            text = str(exc).removeprefix("<flags>: ")
            for quoted, name in typed.items():
                text = text.replace(quoted, name)
            raise ConfigError(f"{what}: {text}") from None
    return cfg
