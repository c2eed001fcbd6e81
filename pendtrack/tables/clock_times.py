"""Times of day: a logger's ``14:23:05.123`` clock column, a stopwatch's ``01:23.45``, and the Arduino Serial
Monitor's timestamps.

A data logger (or a terminal program) that writes the time of day in its first column,
``14:23:05.123,114.62``, writes no number there: the line starts with ``HH:MM:SS`` (``.fff``
optional, an ISO date ``2023-11-24`` before it allowed) followed by a separator. :func:`clock_lines` writes that clock as seconds since the
first line's, with the digits it was written to (so a written time's rounding is still known,
:func:`pendtrack.tables.rounded_times.digit_unit`), across midnight if the log runs past it. An
elapsed time in minutes and seconds (``MM:SS.ff``, as a stopwatch or a video player shows it) is read the
same way; its decimals are required, as ``12:34`` alone could be hours and minutes.

The Arduino IDE's Serial Monitor, with "Show timestamp" on, writes each line it received as
``14:23:05.123 -> payload``: the payload is what the board printed, and the clock is when the
computer *received* the line, not when the board measured it (USB hands lines over in bursts, so
consecutive lines often share a time). The payload is the table: its own columns, header and
``--columns`` are read as the board printed them. Only when every line carries one value (the
board printed its reading alone) is the receive time its time, and then only if it increases
from line to line; lines received in bursts are refused with the ways out (the board's own
``millis()`` in each line, or the sketch's rate with ``--rate``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pendtrack.errors import ConfigError
from pendtrack.tables.labelled_values import labelled_lines

_CLOCK = r"(\d{1,2}):([0-5]\d):([0-5]\d)(?:[.,](\d{1,9}))?"
# a date before the clock (ISO, as a logger or Python's datetime writes it) is passed over: a record lasts minutes
_LOGGER_RE = re.compile(rf"^(?:\d{{4}}-\d{{2}}-\d{{2}}[ T])?{_CLOCK}(?=[\t;,]|\s|$)")
_MONITOR_RE = re.compile(rf"^{_CLOCK}\s*->\s?(.*)$")
# a stopwatch's or a video player's elapsed time, minutes and seconds (decimals required: a bare "12:34" could
# be hours and minutes, and whole seconds cannot time a swing)
_ELAPSED_RE = re.compile(r"^()(\d{1,3}):([0-5]\d)[.,](\d{1,9})(?=[\t;,]|\s|$)")
_ONE_NUMBER_RE = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")  # a comma separates the board's values
DAY_S = 86400
MONITOR_ADVICE = ("print the board's own time in each line (e.g. millis() before the reading), or give the "
                  "sketch's rate with --rate HZ")


@dataclass(frozen=True)
class ClockLog:
    """How a log's times of day were read.

    Attributes
    ----------
    kind : str
        ``"logger"`` (a clock column), ``"elapsed"`` (minutes and seconds, ``01:23.45``) or
        ``"serial_monitor"`` (Arduino Serial Monitor timestamps).
    receive_times : bool
        The Serial Monitor's receive times are the table's times (every line carries one value).
    first : str
        The first line's clock as written (t = 0 there).
    """

    kind: str
    receive_times: bool
    first: str

    def describe(self) -> dict[str, object]:
        """Provenance facts."""
        return {"kind": self.kind, "receive_times": self.receive_times, "t0_clock": self.first}


def _ticks(m: re.Match[str], digits: int) -> int:
    """The clock of match ``m`` in units of 10^-digits s since midnight."""
    h, mi, s, frac = int(m.group(1) or 0), int(m.group(2)), int(m.group(3)), m.group(4) or ""
    return ((h * 60 + mi) * 60 + s) * 10 ** digits + int((frac + "0" * digits)[:digits] or 0)


def _seconds(ticks: int, digits: int) -> str:
    """``ticks`` (10^-digits s) written as seconds with ``digits`` decimals, exactly."""
    whole, part = divmod(ticks, 10 ** digits)
    return f"{whole}.{part:0{digits}d}" if digits else f"{whole}"


def _since_first(matches: list[re.Match[str]]) -> list[str]:
    """Each clock as seconds since the first, written to the finest digits any clock has; a clock earlier
    than the one before by more than half a day is on the next day."""
    digits = max(len(m.group(4) or "") for m in matches)
    out, day, first, last = [], 0, None, None
    for m in matches:
        ticks = _ticks(m, digits)
        if last is not None and ticks + day < last - DAY_S // 2 * 10 ** digits:
            day += DAY_S * 10 ** digits
        ticks += day
        first = ticks if first is None else first
        last = ticks
        out.append(_seconds(ticks - first, digits))
    return out


def clock_lines(lines: list[tuple[int, str]], *, rate_hz: float | None = None
                ) -> tuple[list[tuple[int, str]], ClockLog | None]:
    """The lines with times of day written as seconds since the first (module docstring).

    Parameters
    ----------
    lines : list of (int, str)
        A text table's numbered lines (:func:`pendtrack.tables.text.read_lines`).
    rate_hz : float, optional
        ``--rate``: the rows are timed by the rate; the Serial Monitor's receive times are dropped.

    Returns
    -------
    lines : list of (int, str)
        Unchanged when no data line starts with a time of day.
    clock : ClockLog or None

    Raises
    ------
    ConfigError
        Serial Monitor lines of one value whose receive times do not increase.
    """
    monitor = [(n, _MONITOR_RE.match(s)) for n, s in lines]
    if sum(m is not None for _, m in monitor) >= max(2, len(lines) // 2):
        return _monitor_lines(lines, monitor, rate_hz)
    for kind, pattern in (("logger", _LOGGER_RE), ("elapsed", _ELAPSED_RE)):
        logger = [(n, s, pattern.match(s)) for n, s in lines]
        stamped = [m for _, _, m in logger if m is not None]
        if len(stamped) >= max(2, len(lines) // 2):
            seconds = iter(_since_first(stamped))
            out = [(n, next(seconds) + s[m.end():] if m is not None else s) for n, s, m in logger]
            return out, ClockLog(kind, False, stamped[0].group(0))
    return lines, None


def _monitor_lines(lines: list[tuple[int, str]], monitor: list[tuple[int, re.Match[str] | None]],
                   rate_hz: float | None) -> tuple[list[tuple[int, str]], ClockLog]:
    stamped = [(n, m) for n, m in monitor if m is not None]
    first = stamped[0][1].group(0).split("->")[0].strip()
    payload = [(n, (m.group(5) if m is not None else s).strip()) for (n, s), (_, m) in zip(lines, monitor)]
    payload = labelled_lines([(n, s) for n, s in payload if s])  # the board's "Angle: 12.3"
    data = [(n, s) for n, s in payload if re.match(r"^[+-]?(\d|\.\d)", s)]
    one_value = bool(data) and all(_ONE_NUMBER_RE.match(s) for _, s in data)
    if rate_hz is not None or not one_value:
        return payload, ClockLog("serial_monitor", False, first)
    # one value a line: the receive time is the only time there is
    received = dict(zip((n for n, _ in stamped), _since_first([m for _, m in stamped])))
    times = [float(received[n]) for n, _ in data if n in received]
    repeats = sum(1 for a, b in zip(times, times[1:]) if b <= a)
    if repeats or len(times) < len(data):
        raise ConfigError(f"Arduino Serial Monitor lines ('{first} -> ...'): their times are when the computer "
                          f"received each line, not when the board measured it, and {repeats} of {len(times)} lines "
                          f"were received with or before the line above (in bursts); {MONITOR_ADVICE}")
    # a line of text above the values (the board's "angle (deg)") is the value's header, beside the time's
    out = [(n, f"{received[n]}\t{s}" if (n, s) in data else f"t [s]\t{s}") for n, s in payload]
    return out, ClockLog("serial_monitor", True, first)
