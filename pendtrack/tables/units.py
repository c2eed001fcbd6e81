"""Column names and their units: what a header field or a ``--columns`` name means.

A name is a role (``t``, ``theta``, ``x``, ``y``), optionally an index (``theta1``, ``x 2``), a unit
(``theta [deg]``, ``Time (s)``, ``t_ms``, ``Angle (°)``) and a data-set prefix (``Run 1: Time (s)``,
``VideoAnalysis: X (m)``, Logger Pro's and Vernier Video Analysis' ``<data set>: <column>``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from pendtrack.errors import ConfigError

#: The names of the time and the angle, also in the languages lab software is localised to (Logger Pro, PASCO,
#: phyphox): German, French, Spanish, Portuguese, Italian, Dutch, Polish, Czech, Swedish, Finnish, Turkish, Russian.
TIME_NAMES = frozenset({"t", "time", "timestamp", "times", "zeit", "temps", "tiempo", "tempo", "tijd", "czas", "čas",
                        "aika", "zaman", "время"})
#: An Arduino sketch's clocks, named by the functions that read them, with the unit each counts in.
ARDUINO_CLOCKS = {"millis": "ms", "millis()": "ms", "micros": "µs", "micros()": "µs"}
THETA_NAMES = frozenset({"theta", "θ", "angle", "ang", "phi", "φ", "angular position", "angular displacement",
                         "winkel", "ángulo", "angulo", "ângulo", "angolo", "hoek", "kąt", "úhel", "vinkel", "kulma",
                         "açı", "угол"})
X_NAMES = frozenset({"x", "pos x", "position x", "x position"})
Y_NAMES = frozenset({"y", "pos y", "position y", "y position"})
Y_DOWN_NAMES = frozenset({"y_down", "ydown", "y down"})
#: Factors to s.
TIME_UNITS: Mapping[str, float] = {
    "s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0, "ms": 1e-3, "msec": 1e-3,
    "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "usec": 1e-6, "ns": 1e-9, "min": 60.0,
    "с": 1.0, "мс": 1e-3,  # Cyrillic s and ms
}
#: Factors to rad.
ANGLE_UNITS: Mapping[str, float] = {
    "rad": 1.0, "rads": 1.0, "radian": 1.0, "radians": 1.0, "mrad": 1e-3, "рад": 1.0,
    "deg": math.pi / 180, "degree": math.pi / 180, "degrees": math.pi / 180, "°": math.pi / 180,
    # the same word in the languages of TIME_NAMES ("grad" is left out: it is also the gradian's symbol)
    **{word: math.pi / 180 for word in ("grados", "graus", "gradi", "degrés", "degres", "graden", "stopnie", "grader",
                                        "astetta", "derece", "градусы", "град")},
}
#: Factors to m; ``px`` (image pixels) is a unit of its own (None).
LENGTH_UNITS: Mapping[str, float | None] = {
    "m": 1.0, "cm": 1e-2, "mm": 1e-3, "in": 0.0254, "ft": 0.3048, "px": None, "pixel": None, "pixels": None,
}
ALL_UNITS = frozenset({*TIME_UNITS, *ANGLE_UNITS, *LENGTH_UNITS})
#: Units of rates, which no column pendtrack reads carries (lower case, spaces removed): unit -> what it measures.
RATE_UNITS: Mapping[str, str] = {
    **{u: "an angular velocity" for u in ("rad/s", "deg/s", "°/s", "rpm", "rev/s")},
    **{u: "a linear velocity" for u in ("m/s", "cm/s", "mm/s", "px/s")},
    **{u: "an acceleration" for u in ("rad/s^2", "rad/s²", "rad/s2", "deg/s^2", "deg/s²", "°/s^2", "°/s²",
                                        "m/s^2", "m/s²", "m/s2")},
}
# a sensor's other quantities (a light sensor, a force plate, a voltage, a microphone, a magnetometer): no angle,
# no position, no rate -> what the unit measures
SENSOR_UNITS: Mapping[str, str] = {
    "%": "a percentage", "lx": "an illuminance", "lux": "an illuminance", "v": "a voltage", "mv": "a voltage",
    "n": "a force", "pa": "a pressure", "kpa": "a pressure", "hpa": "a pressure", "db": "a sound level",
    "µt": "a magnetic field", "ut": "a magnetic field", "mt": "a magnetic field", "°c": "a temperature",
}
IGNORED = frozenset({"_", "-"})
_UNIT_RE = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")
_DATASET_RE = re.compile(r"^(?P<set>[^:\[(]+):\s*(?P<name>.+)$")  # Logger Pro's "Run 1: Time (s)"
_RUN_SUFFIX_RE = re.compile(r"^(?P<name>.+?)\s+(?P<set>run\s*#\s*\d+)$")  # PASCO Capstone's "Time (s) Run #1"
_CHANNEL_RE = re.compile(r",\s*ch\s*[\w&]+$")  # PASCO's sensor channel: "Angular Position, Ch 1&2 (rad)"
_INDEX_RE = re.compile(r"^(?P<name>.*?\D)[\s_]*(?P<index>\d+)$")


@dataclass(frozen=True)
class ColumnName:
    """One column's meaning, parsed from a header or ``--columns`` name.

    Attributes
    ----------
    role : str
        ``"t"``, ``"theta"``, ``"x"``, ``"y"`` or ``"_"`` (ignored).
    scale : float
        Factor to s (t), rad (theta) or m (x, y in a length unit); 1 for px or no unit.
    unit : str
        The unit as written, lower case ('' if none): a unit that was declared.
    y_down : bool
        A ``y_down`` column (y points down).
    label : str
        The name as written.
    index : int or None
        An indexed name's number (``theta1``, ``x 2``).
    dataset : str
        The data-set prefix (``Run 1`` of ``Run 1: Time (s)``), '' if none.
    from_rate : bool
        Times made from ``--rate`` (row k at k / rate), not a column of the table.
    from_pair : bool
        One of the two numbers of a header field's (x, y) pair cell (``"(1392, 685)"`` under ``position``).
    assumed : bool
        A role no name gave: the two columns of a table without a header, read as t and theta.
    """

    role: str
    scale: float = 1.0
    unit: str = ""
    y_down: bool = False
    label: str = ""
    index: int | None = None
    dataset: str = ""
    from_rate: bool = False
    from_pair: bool = False
    assumed: bool = False

    @property
    def declared(self) -> bool:
        """The unit is given (by the header or ``--columns``)."""
        return bool(self.unit)

    def describe(self) -> str:
        """The canonical ``--columns`` spelling of this column (``theta[deg]``, ``y_down[px]``, ``_``)."""
        if self.role == "_" or self.from_rate:
            return "_" if self.role == "_" else self.label
        name = "y_down" if self.y_down else self.role
        unit = "deg" if self.unit == "°" else self.unit
        return f"{name}[{unit}]" if unit else name


def split_unit(text: str) -> tuple[str, str]:
    """(name, unit) of ``name [unit]``, ``name (unit)``, ``name_unit``, ``name unit``, ``name/unit`` or ``name°``."""
    m = _UNIT_RE.match(text)
    if m:
        return m.group("name").strip(), m.group("unit").strip()
    for sep in ("_", " "):
        head, _, tail = text.rpartition(sep)
        if head and tail in ALL_UNITS:
            return head.strip(), tail
    head, _, tail = text.partition("/")  # "Time/s", "Angle/rad", "AngVel/rad/s": the quantity over its unit
    if head.strip() and head.strip() not in ALL_UNITS and (tail.strip() in ALL_UNITS or tail.strip() in RATE_UNITS):
        return head.strip(), tail.strip()
    if text.endswith("°"):
        return text[:-1].strip(), "°"
    return text, ""


def _role(name: str) -> tuple[str, bool] | None:
    if name in TIME_NAMES:
        return "t", False
    if name in THETA_NAMES:
        return "theta", False
    if name in X_NAMES:
        return "x", False
    if name in Y_NAMES:
        return "y", False
    if name in Y_DOWN_NAMES:
        return "y", True
    return None


def parse_column_name(label: str, *, aliases: bool = True) -> ColumnName | None:
    """The meaning of a column name (``theta [deg]``, ``time_ms``, ``θ``, ``y_down``, ``Run 1: Angle (°)``,
    ``theta1_rad``, PASCO Capstone's ``Angular Position, Ch 1&2 (rad) Run #1``, ``_``); None if it names
    nothing this reader uses.

    ``aliases=False`` (Parquet files, whose names a program wrote) knows only the names
    ``t``, ``theta``, ``x``, ``y``, ``y_down``, units still allowed.

    Raises
    ------
    ConfigError
        A known name with a unit that does not fit it (``theta [m]``).
    """
    text = label.strip().strip('"').strip().lower()
    dataset = ""
    m = _DATASET_RE.match(text) or _RUN_SUFFIX_RE.match(text)
    if m:
        dataset, text = " ".join(m.group("set").replace("#", " ").split()), m.group("name").strip()
    if text in IGNORED or not text:
        return ColumnName("_", label=label)
    name, unit = split_unit(text)
    name = _CHANNEL_RE.sub("", name).strip()
    if aliases and name in ARDUINO_CLOCKS and not unit:
        name, unit = "time", ARDUINO_CLOCKS[name]
    index = None
    found = _role(name)
    if found is None:
        m = _INDEX_RE.match(name)
        if m:
            found, index = _role(m.group("name").strip()), int(m.group("index"))
    if found is None or (not aliases and (name not in ("t", "theta", "x", "y", "y_down"))):
        return None
    role, y_down = found
    unit = "µs" if unit in ("us", "μs") else unit
    common = {"unit": unit, "label": label, "index": index, "dataset": dataset, "y_down": y_down}
    if role == "t":
        return ColumnName("t", _factor(TIME_UNITS, unit, label, "s, ms, us, min"), **common)
    if role == "theta":
        return ColumnName("theta", _factor(ANGLE_UNITS, unit, label, "rad, deg, mrad"), **common)
    if unit and unit not in LENGTH_UNITS:
        raise ConfigError(f"column {label!r}: unit {unit!r} is not a length (m, cm, mm, px)")
    return ColumnName(role, LENGTH_UNITS.get(unit) or 1.0, **common)


def _factor(table: Mapping[str, float], unit: str, label: str, expected: str) -> float:
    if not unit:
        return 1.0
    if unit not in table:
        raise ConfigError(f"column {label!r}: unknown unit {unit!r} (expected {expected})")
    return table[unit]


def parse_columns(text: str, *, check_roles: bool = True, timed_by_rate: bool = False) -> tuple[str, ...]:
    """Split and check a ``--columns`` value (``t,theta,_``, ``t,x,y``, ``t[us],theta[deg]``).

    Parameters
    ----------
    text : str
    check_roles : bool
        Check that the names make t + theta or t + x + y (False: only that each name is known).
    timed_by_rate : bool
        The times come from ``--rate``: the names make theta or x + y, and no t.

    Raises
    ------
    ConfigError
        An unknown name, or not exactly one ``t`` and one ``theta`` or one ``x`` and one ``y``.
    """
    names = tuple(n.strip() for n in text.split(","))
    parsed = []
    for n in names:
        c = parse_column_name(n)
        if c is None:
            raise ConfigError(f"--columns: unknown column name {n!r} (t, theta, x, y, y_down, or _ to ignore one; "
                              "a unit may follow: theta[deg], t[ms], t[us], x[px])")
        parsed.append(c)
    if check_roles:
        roles(parsed + ([ColumnName("t", unit="s", label="--rate", from_rate=True)] if timed_by_rate else []),
              "--columns")
    return names


def columns_hint(cols: Sequence[ColumnName | None], chosen: Mapping[str, int], **units: str) -> str:
    """A ``--columns`` value naming the ``chosen`` columns (role -> index), with ``units`` (role -> unit)
    overriding theirs, and ``_`` for every other column."""
    out = []
    for i, c in enumerate(cols):
        role = next((r for r, j in chosen.items() if j == i), None)
        if c is not None and c.from_rate:
            continue
        if role is None or c is None:
            out.append("_")
            continue
        unit = units.get(role, "deg" if c.unit == "°" else c.unit)
        name = "y_down" if c.y_down else role
        out.append(f"{name}[{unit}]" if unit else name)
    return ",".join(out)


def roles(cols: Sequence[ColumnName | None], where: str) -> dict[str, int]:
    """Index of each used role; raises ConfigError if the names do not make t + theta or t + x + y.

    Several data sets (``Run 1: …``, ``Run 2: …``) or indexed names (``x1``, ``x2``) that each
    give the roles are ambiguous: the error names the ``--columns`` that picks the first.
    """
    found: dict[str, int] = {}
    dup: tuple[int, int] | None = None
    for i, c in enumerate(cols):
        if c is None or c.role == "_":
            continue
        if c.role in found and c.from_rate:
            j = found[c.role]
            raise ConfigError(f"--rate gives the rows their times, but the {where} names column {j + 1} "
                              f"({cols[j].label!r}) a time: drop --rate, or ignore that column with --columns (_)")
        if c.role in found:
            dup = dup or (found[c.role], i)
            continue
        found[c.role] = i
    if dup is not None:
        a, b = cols[dup[0]], cols[dup[1]]
        assert a is not None and b is not None
        text = f"{where}: two columns are {a.role} ({a.label!r} and {b.label!r})"
        if where != "--columns":
            first = _first_set(cols, a)
            hint = f"; pick one with --columns {columns_hint(cols, first)}" if first else "; name them with --columns"
            text += hint
        raise ConfigError(text)
    if "t" not in found or not ("theta" in found or {"x", "y"} <= set(found)):
        missing = "t" if "t" not in found else "theta"
        names = ", ".join(repr(c.label) for c in cols if c is not None and c.role != "_") or "none"
        rest = ",_" * max(len(cols) - 2, 0)  # one name per column: the table's own count
        hint = "" if where == "columns" else f"; name them, e.g. --columns t,theta{rest} or --columns t,x,y{rest[2:]}"
        if where != "columns" and found.get("t", 0) > 0:  # the clock recognised further in: the hint puts t there
            hint = f"; name them, e.g. --columns {_after_time(len(cols), found['t'], ('theta',))}"
            if found["t"] + 2 < len(cols):
                hint += f" or --columns {_after_time(len(cols), found['t'], ('x', 'y'))}"
        if missing == "t":
            hint += " (a table without times, written at a fixed rate: --rate HZ)"
        raise ConfigError(f"{where}: missing column '{missing}' (needs t and theta, or t, x and y; recognised: "
                          f"{names}){hint}")
    if "theta" in found:
        found.pop("x", None)
        found.pop("y", None)
    x, y = (cols[found[r]] if r in found else None for r in ("x", "y"))
    if x is not None and y is not None and x.unit != y.unit and x.unit and y.unit:
        if LENGTH_UNITS.get(x.unit) is None or LENGTH_UNITS.get(y.unit) is None:
            raise ConfigError(f"{where}: x is in {x.unit} and y in {y.unit}: give them in one unit")
    return found


def _after_time(n: int, at: int, names: tuple[str, ...]) -> str:
    """``--columns`` for ``n`` columns with t at ``at`` and ``names`` in the columns after it, then before it."""
    out = ["_"] * n
    out[at] = "t"
    for i, name in zip([*range(at + 1, n), *range(at)], names):
        out[i] = name
    return ",".join(out)


def _first_set(cols: Sequence[ColumnName | None], like: ColumnName) -> dict[str, int] | None:
    """The roles of the first data set (or index) among several, None if it does not give them all."""
    key = (like.dataset, like.index)
    group: dict[str, int] = {}
    for i, c in enumerate(cols):
        if c is not None and c.role != "_" and (c.dataset, c.index) == key and c.role not in group:
            group[c.role] = i
    # a shared time column (Logger Pro's one time with several angles; x1, y1, x2, y2 with one t)
    if "t" not in group:
        times = [i for i, c in enumerate(cols) if c is not None and c.role == "t"]
        if len(times) == 1:
            group["t"] = times[0]
    if "t" in group and ("theta" in group or {"x", "y"} <= set(group)):
        if "theta" in group:
            group.pop("x", None)
            group.pop("y", None)
        return group
    return None
