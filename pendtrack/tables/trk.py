"""Tracker project files (``.trk``): a point-mass track in world units, timed by the video clip.

A ``.trk`` file is Open Source Physics XML: ``<object class="…TrackerPanel">`` with
``<property name="…">`` children. Read here:

* the ``PointMass`` track (``tracks`` collection): ``framedata`` entries ``[n]`` (n the video
  frame) holding the mark's image position ``x``, ``y`` [px, y down];
* the calibration ``coords`` (``ImageCoordSystem``): ``framedata`` entries ``[n]`` with the
  image position of the world origin ``xorigin``, ``yorigin`` [px], the world x axis'
  ``angle`` [deg, counter-clockwise from the image x axis] and ``xscale``, ``yscale``
  [px per world unit]; an entry holds from its frame until the next one (Tracker's key
  frames). World positions, y up, as Tracker computes them::

      u = (x_img - xorigin) / xscale,   v = -(y_img - yorigin) / yscale
      x = cos(a) u + sin(a) v,          y = -sin(a) u + cos(a) v

* the clip (``videoclip``): ``startframe``, ``stepsize``, ``stepcount``, ``starttime`` [ms], and
  the frame duration ``delta_t`` [ms] of the video (or of ``clipcontrol``): the time of frame n is
  ``(starttime + (n - startframe) delta_t) / 1000`` s. Marks on frames that are not steps of the
  clip are left out (Tracker's own table shows the steps only).

The unit of the world positions is the project's ``length_unit`` (m when absent).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from pendtrack.errors import ConfigError
from pendtrack.tables.units import ColumnName

PREFIX = "org.opensourcephysics."
PANEL = PREFIX + "cabrillo.tracker.TrackerPanel"
POINT_MASS = PREFIX + "cabrillo.tracker.PointMass"


def _prop(node: ET.Element, name: str) -> ET.Element | None:
    return next((p for p in node.findall("property") if p.get("name") == name), None)


def _object(node: ET.Element | None) -> ET.Element | None:
    return None if node is None else node.find("object")


def _number(node: ET.Element, name: str, default: float | None = None) -> float:
    p = _prop(node, name)
    if p is None or p.text is None or not p.text.strip():
        if default is None:
            raise ConfigError(f"Tracker project: no {name!r} in {node.get('class', 'an object').rsplit('.', 1)[-1]}")
        return default
    try:
        return float(p.text)
    except ValueError:
        raise ConfigError(f"Tracker project: {name!r} is {p.text!r}, not a number") from None


def _frames(node: ET.Element | None) -> dict[int, ET.Element]:
    """``framedata`` entries by frame number: ``<property name="[n]"><object …>``."""
    out: dict[int, ET.Element] = {}
    data = None if node is None else _prop(node, "framedata")
    if data is None:
        return out
    for p in data.findall("property"):
        name, obj = p.get("name", ""), p.find("object")
        if name.startswith("[") and name.endswith("]") and name[1:-1].isdigit() and obj is not None:
            out[int(name[1:-1])] = obj
    return out


def _track(panel: ET.Element, name: str | None) -> ET.Element:
    tracks = _prop(panel, "tracks")
    masses = [o for o in ([] if tracks is None else [_object(p) for p in tracks.findall("property")])
              if o is not None and o.get("class") == POINT_MASS]
    names = [(getattr(_prop(o, "name"), "text", None) or "") for o in masses]
    if name is not None:
        if name not in names:
            raise ConfigError(f"no point-mass track named {name!r} (tracks: {', '.join(map(repr, names)) or 'none'})")
        return masses[names.index(name)]
    if not masses:
        raise ConfigError("the Tracker project has no point-mass track")
    if len(masses) > 1:
        raise ConfigError(f"the Tracker project has {len(masses)} point-mass tracks ({', '.join(map(repr, names))}): "
                          f"choose one with --track NAME")
    return masses[0]


def _calibration(panel: ET.Element) -> list[tuple[int, tuple[float, float, float, float, float]]]:
    """Key frames of the calibration: (frame, (xorigin, yorigin, angle [rad], xscale, yscale)), sorted."""
    coords = _object(_prop(panel, "coords"))
    frames = _frames(coords)
    if not frames:
        return [(0, (0.0, 0.0, 0.0, 1.0, 1.0))]  # Tracker's default: image pixels, y up, origin top left
    out = []
    for n, f in sorted(frames.items()):
        xs, ys = _number(f, "xscale"), _number(f, "yscale")
        if xs == 0 or ys == 0:
            raise ConfigError(f"Tracker project: calibration frame {n} has a zero scale")
        out.append((n, (_number(f, "xorigin"), _number(f, "yorigin"), math.radians(_number(f, "angle")), xs, ys)))
    return out


def image_to_world(x: np.ndarray, y: np.ndarray, calib: tuple[float, float, float, float, float]
                   ) -> tuple[np.ndarray, np.ndarray]:
    """World x, y (y up) of image positions [px, y down] under one calibration (Tracker's transform)."""
    xo, yo, a, xs, ys = calib
    u, v = (x - xo) / xs, -(y - yo) / ys
    return math.cos(a) * u + math.sin(a) * v, -math.sin(a) * u + math.cos(a) * v


def read_trk(path: Path, track: str | None = None) -> dict[str, Any]:
    """The raw record of a Tracker project's point mass (module docstring): t [s], world x, y (y up).

    Raises
    ------
    ConfigError
        Not a Tracker project, no (or several) point-mass tracks, no frame duration, no marks.
    """
    try:
        panel = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ConfigError(f"not a readable Tracker project (XML: {exc})") from None
    if panel.tag != "object" or panel.get("class") != PANEL:
        raise ConfigError(f"not a Tracker project (the root is {panel.get('class') or panel.tag!r}, expected "
                          "TrackerPanel)")
    clip = _object(_prop(panel, "videoclip"))
    if clip is None:
        raise ConfigError("the Tracker project has no video clip (no frame times)")
    start, step = int(_number(clip, "startframe", 0.0)), int(_number(clip, "stepsize", 1.0))
    count = int(_number(clip, "stepcount", 0.0))
    if int(_number(clip, "frameshift", 0.0)):
        raise ConfigError("the Tracker project's clip has a frame shift, which this reader does not apply")
    video, control = _object(_prop(clip, "video")), _object(_prop(panel, "clipcontrol"))
    dt = next((_number(o, "delta_t", math.nan) for o in (video, control) if o is not None
               and math.isfinite(_number(o, "delta_t", math.nan))), math.nan)
    if not (math.isfinite(dt) and dt > 0):
        raise ConfigError("the Tracker project gives no frame duration (delta_t): open it in Tracker and save it "
                          "again, or export its data (File > Export > Data)")
    mass = _track(panel, track)
    marks = {n: (_number(f, "x"), _number(f, "y")) for n, f in _frames(mass).items()}
    frames = np.array(sorted(n for n in marks if n >= start and (n - start) % max(step, 1) == 0
                             and (count <= 0 or (n - start) // max(step, 1) < count)), dtype=np.int64)
    if frames.size == 0:
        raise ConfigError("the point-mass track has no marks on the clip's steps")
    px = np.array([marks[n][0] for n in frames])
    py = np.array([marks[n][1] for n in frames])
    calib = _calibration(panel)
    keys = np.array([k for k, _ in calib])
    which = np.clip(np.searchsorted(keys, frames, side="right") - 1, 0, len(calib) - 1)
    x, y = np.empty(frames.size), np.empty(frames.size)
    for j in np.unique(which):
        sel = which == j
        x[sel], y[sel] = image_to_world(px[sel], py[sel], calib[j][1])
    t = (_number(clip, "starttime", 0.0) + (frames - start) * dt) / 1000.0
    unit_node = _prop(panel, "length_unit")
    unit = (unit_node.text or "m").strip() if unit_node is not None else "m"
    name_node = _prop(mass, "name")
    cols = [ColumnName("t", unit="s", label="t"), ColumnName("x", unit=unit, label="x"),
            ColumnName("y", unit=unit, label="y")]
    return {"t": t, "theta": None, "x": x, "y": y, "y_down": False, "ok": np.isfinite(x) & np.isfinite(y),
            "kind": "tracker", "labels": ["t [s]", f"x [{unit}]", f"y [{unit}]"], "columns": {}, "cols": cols,
            "roles": {"t": 0, "x": 1, "y": 2},
            "tracker": {"track": None if name_node is None else name_node.text, "frames": [int(frames[0]),
                        int(frames[-1])], "delta_t_ms": dt, "start_frame": start, "step_size": step,
                        "calibration_key_frames": [int(k) for k in keys], "length_unit": unit}}
