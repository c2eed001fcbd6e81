"""The package's import structure: layers only import downwards, and no module imports itself back.

Every import in ``pendtrack/`` is read from the source (module level, function level and
``TYPE_CHECKING`` blocks alike: a lazy import is still a dependency), so a cycle hidden by a
function-level import fails here too.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "pendtrack"

#: The layers, lowest first (docs/architecture.md). A module may import from its own layer and
#: from layers to its left, never from a layer to its right.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("version", "errors", "config", "progress", "apparatus", "gitlfs"),
    ("parallel",),
    ("artifacts", "tables", "lens", "video"),
    ("models",),
    ("kinematics",),
    ("track", "render"),
    ("fitting",),
    ("discovery",),
    ("batch",),
    ("report",),
    ("stages",),
    ("api",),
    ("cli", "__main__"),
    # the top-level door: ``import pendtrack as pt``; its PEP 562 ``__getattr__`` imports
    # :mod:`pendtrack.api` on first use (so ``import pendtrack`` stays free), and nothing imports it
    ("pendtrack",),
)
LAYER_OF = {name: i for i, names in enumerate(LAYERS) for name in names}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """Modules of ``pendtrack`` that ``name`` imports anywhere in its source."""
    is_package = path.name == "__init__.py"
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.split(".")[0] == "pendtrack")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_package else name.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "pendtrack":
                continue
            for alias in node.names:  # `from pkg import submodule` imports the submodule
                sub = f"{target}.{alias.name}"
                out.add(sub if sub in known else target)
    return {m for m in out if m in known}


def _layer(module: str) -> int:
    parts = module.split(".")
    key = parts[1] if len(parts) > 1 else parts[0]
    assert key in LAYER_OF, f"{module} is in no layer: add it to LAYERS (and to docs/architecture.md)"
    return LAYER_OF[key]


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    known = set(mods)
    return {m: _imports(m, p, known) - {m} for m, p in mods.items()}


def test_every_import_goes_down_the_layers() -> None:
    upward = sorted(f"{m} (layer {_layer(m)}) imports {d} (layer {_layer(d)})"
                    for m, deps in _graph().items() for d in deps if _layer(d) > _layer(m))
    assert not upward, "upward imports:\n" + "\n".join(upward)


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _without_package_reexports(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """Drop a package ``__init__``'s imports of its own submodules.

    A package that re-exports its submodules' names is the ordinary Python pattern, not a
    cycle; a submodule importing from its own package's ``__init__`` still is one.
    """
    return {m: {d for d in deps if not d.startswith(m + ".")} for m, deps in graph.items()}


def test_no_import_cycles() -> None:
    cycles = _cycles(_without_package_reexports(_graph()))
    assert not cycles, "import cycles:\n" + "\n".join(" <-> ".join(c) for c in cycles)


def test_the_walker_sees_function_level_and_relative_imports(tmp_path: Path) -> None:
    """The reader itself: a lazy import inside a function and a relative import both count."""
    src = tmp_path / "pendtrack" / "models" / "x.py"
    src.parent.mkdir(parents=True)
    src.write_text("def f():\n    from pendtrack.fitting.leastsq import lm\n\nfrom . import y\n", encoding="utf-8")
    known = {"pendtrack.fitting.leastsq", "pendtrack.fitting.leastsq.lm", "pendtrack.models.y"}
    assert _imports("pendtrack.models.x", src, known) == {"pendtrack.fitting.leastsq.lm", "pendtrack.models.y"}
    assert _layer("pendtrack.fitting.leastsq.lm") > _layer("pendtrack.models.x")
