"""Discovery: show what a model gets wrong, name the cause, extend the model, measure the gain.

Public API::

    from pendtrack.discovery import read_angle_series, discover, diagnose, CATALOGUE
    series = read_angle_series("angle.parquet")          # or a CSV / whitespace table
    result = discover(series, config=Config())            # DiscoveryResult (frozen, to_dict())
    write_markdown(result)                                # discovery.md text

Modules: :mod:`~pendtrack.discovery.inputs` (readers), :mod:`~pendtrack.discovery.data`
(uniform grid, kinematics, held-out split), :mod:`~pendtrack.discovery.residuals`,
:mod:`~pendtrack.discovery.cycles`, :mod:`~pendtrack.discovery.hysteresis` and
:mod:`~pendtrack.discovery.diagnostics` (what is wrong, in numbers),
:mod:`~pendtrack.discovery.catalogue` (effects and signatures),
:mod:`~pendtrack.discovery.candidate_fits` (the candidates' fits), :mod:`~pendtrack.discovery.rules` (the decision rule),
:mod:`~pendtrack.discovery.loop` (the loop, a state object), :mod:`~pendtrack.discovery.narrative`
(discovery.md), :mod:`~pendtrack.discovery.result`.

Importing this package loads numpy only: fitting, models and numba are imported on use.
"""

from __future__ import annotations

from typing import Any

__all__ = ["CATALOGUE", "AngleSeries", "Diagnosis", "DiscoveryResult", "diagnose", "discover", "read_angle_series",
           "write_markdown"]

_LAZY = {
    "CATALOGUE": ("pendtrack.discovery.catalogue", "CATALOGUE"),
    "AngleSeries": ("pendtrack.discovery.inputs", "AngleSeries"),
    "read_angle_series": ("pendtrack.discovery.inputs", "read_angle_series"),
    "Diagnosis": ("pendtrack.discovery.diagnostics", "Diagnosis"),
    "diagnose": ("pendtrack.discovery.diagnostics", "diagnose"),
    "DiscoveryResult": ("pendtrack.discovery.result", "DiscoveryResult"),
    "discover": ("pendtrack.discovery.loop", "discover"),
    "write_markdown": ("pendtrack.discovery.narrative", "write_markdown"),
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    raise AttributeError(f"module 'pendtrack.discovery' has no attribute {name!r}")
