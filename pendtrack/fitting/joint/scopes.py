"""Which parameters several runs of one pendulum share: the scope of each parameter of a joint fit.

A scope is a tuple of run labels: ``()`` shared by every run, ``("run",)`` one value per run,
``("tile",)`` or ``("tile", "alley")`` one value per group of runs with equal labels. The labels
of a run are the fields of its run code (the paper's Table kindofrun, e.g. ``06na5``): ``tile``
(``"06"``), ``launched`` (``"l"``/``"n"``), ``alley`` (``"a"``/``"n"``); the caller reads them
(:mod:`pendtrack.batch.runcode`), this module only groups by them.

Defaults (:func:`default_scopes`). With run codes they follow the paper's series:

* ``Omega0`` per tile (the tile sets the pendulum's inertia and its centre of mass);
* the Coulomb-like friction of the axle (``C0``, and its twins ``C5`` of OPA and ``G1`` of the
  fractional model) shared by the rig;
* drag, added mass, memory and time-varying damping per tile and alley (the air around the tile);
* the initial state, theta's offset (a measurement parameter) and ``t0`` (a time on the run's
  own clock) per run.

Without run codes the physical parameters are shared and the initial state, the measurement
parameters and ``t0`` are per run.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from pendtrack.errors import FitError

STATE_NAMES = ("theta0", "omega0")
RUN = "run"
SHARED = "shared"
LABELS = ("tile", "launched", "alley")  # the run code's fields a group can be made of, in this order
RIG_TERMS = ("coulomb", "opa_coulomb", "quarter_friction")  # the axle's friction: one rig, one value
PER_RUN_PARAMS = ("t0",)  # a time on the run's own clock

Scope = tuple[str, ...]


def scope_text(scope: Scope) -> str:
    """``()`` -> ``"shared"``, ``("run",)`` -> ``"run"``, ``("tile", "alley")`` -> ``"tile+alley"``."""
    return "+".join(scope) if scope else SHARED


def parse_scope(text: str) -> Scope:
    """The scope named by ``text``: ``shared``, ``run`` (or ``per-run``), or labels joined by ``+``.

    Raises
    ------
    FitError
        An unknown label.
    """
    word = text.strip().lower()
    if word == SHARED:
        return ()
    if word in (RUN, "per-run"):
        return (RUN,)
    keys = [k.strip() for k in word.split("+") if k.strip()]
    unknown = [k for k in keys if k not in LABELS]
    if unknown or not keys:
        raise FitError(f"unknown scope '{text}': shared, run, or run-code fields joined by + "
                       f"({', '.join(LABELS)}; e.g. tile+alley)")
    return tuple(k for k in LABELS if k in keys)


def fitted_names(model: Any) -> tuple[str, ...]:
    """A model's parameters and the initial state: every name a scope can be declared for."""
    return tuple(model.param_names) + STATE_NAMES


def default_scopes(model: Any, *, run_codes: bool) -> dict[str, Scope]:
    """The default scope of every parameter of ``model`` (module docstring).

    Parameters
    ----------
    model : Model
        From :func:`pendtrack.models.get_model` or :func:`~pendtrack.models.compose`.
    run_codes : bool
        Every run has run-code labels.
    """
    from pendtrack.models.terms import CATALOGUE

    term_of = {p: t for t in model.terms for p in CATALOGUE[t].params}
    out: dict[str, Scope] = {}
    for name in fitted_names(model):
        term = term_of.get(name)
        if name in STATE_NAMES or name in PER_RUN_PARAMS or (term and CATALOGUE[term].kind == "measurement"):
            out[name] = (RUN,)
        elif not run_codes or term in RIG_TERMS:
            out[name] = ()
        elif name == "Omega0":
            out[name] = ("tile",)
        else:
            out[name] = ("tile", "alley")
    return out


def resolve_scopes(model: Any, sharing: Mapping[str, str] | None, *,
                   labels: Mapping[str, Mapping[str, str]] | None) -> dict[str, Scope]:
    """Every parameter's scope: the defaults, overridden by ``sharing``; checked.

    Parameters
    ----------
    model : Model
    sharing : mapping, optional
        Parameter name -> scope text (:func:`parse_scope`), e.g. ``{"C0": "shared", "Ca": "tile+alley"}``.
    labels : mapping, optional
        Run id -> its run-code labels (``tile``, ``launched``, ``alley``); None or an empty mapping for
        a run: no run code.

    Raises
    ------
    FitError
        A name that is not a parameter of the model, an initial state not per run, or a group
        scope when a run has no run code.
    """
    run_codes = bool(labels) and all(labels.values())
    scopes = default_scopes(model, run_codes=run_codes)
    for name, text in (sharing or {}).items():
        if name not in scopes:
            raise FitError(f"'{name}' is not a parameter of model '{model.name}' "
                           f"(its parameters: {', '.join(scopes)})")
        scope = parse_scope(text)
        if name in STATE_NAMES and scope != (RUN,):
            raise FitError(f"'{name}' is a run's initial state: it is fitted per run, never {scope_text(scope)}")
        if scope and scope != (RUN,) and not run_codes:
            raise FitError(f"'{name}' per {scope_text(scope)} needs a run code (e.g. 06na5) in every record's name")
        scopes[name] = scope
    return scopes


def group_of(scope: Scope, run: str, labels: Mapping[str, str] | None) -> str:
    """The group a run belongs to for a scope: ``""`` (shared), the run id, or ``"tile=06,alley=a"``."""
    if not scope:
        return ""
    if scope == (RUN,):
        return run
    return ",".join(f"{k}={(labels or {})[k]}" for k in scope)


def column_label(name: str, group: str) -> str:
    """A joint parameter's label: ``C0`` (shared), ``theta0@06na5``, ``Omega0@tile=06``."""
    return f"{name}@{group}" if group else name


def sharing_from_lists(*, shared: Sequence[str] = (), per_run: Sequence[str] = (),
                       per_group: Mapping[str, str] | None = None) -> dict[str, str]:
    """One sharing mapping from the three ways of declaring it (``--shared``, ``--per-run``, ``--per-group``).

    Raises
    ------
    FitError
        A parameter declared twice.
    """
    out: dict[str, str] = {}
    for names, scope in ((shared, SHARED), (per_run, RUN)):
        for name in names:
            if name in out:
                raise FitError(f"'{name}' is declared twice in the sharing")
            out[name] = scope
    for name, scope in (per_group or {}).items():
        if name in out:
            raise FitError(f"'{name}' is declared twice in the sharing")
        out[name] = scope
    return out
