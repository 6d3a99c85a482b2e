"""The core's folders are its layers, and no import goes round in a circle.

Every module under ``toolkit/pftrack`` is parsed (``ast``) and each of its imports of another
pftrack module read: at module level, and inside functions (a lazy import runs too, only later).
Imports under ``if TYPE_CHECKING:`` are left out: they never run, they only name types.

The layers, lowest first (a module may import its own layer and the layers below it):

0. ``contracts``: what a plugin implements and what the core hands it (component base classes,
   exchange types, parameter declarations, lifecycle stage contracts, hooks).
1. the base: ``io`` (files in and out), ``geometry`` (cameras, boxes, volumes), ``filter`` (the
   particle-filter numerics), ``metrics``, ``render``, ``scenes`` (frames in).
2. ``host``: the plugin host and the run configuration's schema.
3. ``engine``: the multi-target tracker, the lifecycle runner, the frame loop.
4. ``builtin``: the observation models the core ships.
5. ``workflows``: what the commands do, from inputs to files.
6. ``testing``: the conformance kit for plugin authors.
7. ``cli``: the command line.
8. the public surface: the package itself (``pftrack/__init__.py``, ``__main__``) and the
   modules kept at the paths users and plugins import (``pftrack.components``,
   ``pftrack.lifecycle``, ...; each re-exports a module of a layer). No layer imports them.

The rules, each a test below:

* no circle through module-level imports;
* no circle through any import that runs (module level or in a function), the imports of
  :data:`CALL_TIME_UPWARD` aside;
* no module imports a higher layer, except the imports listed in :data:`CALL_TIME_UPWARD`, each
  inside a function and with the reason it is there; the list holds only imports that exist.
  The package itself (``from pftrack import __version__``) is imported before any of its
  modules whoever asks, so it counts as no layer; its re-export modules do count.

And one rule on size: no module of the core or of the built-in plugins is longer than
:data:`MAX_LINES` (a longer one does several jobs; split it by job and re-export what moved from
the old path).
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pftrack

CORE = Path(pftrack.__file__).parent
TOOLKIT = CORE.parent

LAYERS: tuple[tuple[str, ...], ...] = (
    ("contracts",),
    ("io", "geometry", "filter", "metrics", "render", "scenes"),
    ("host",),
    ("engine",),
    ("builtin",),
    ("workflows",),
    ("testing",),
    ("cli",),
)
PUBLIC = len(LAYERS)  # the package, __main__ and the re-export modules at the public paths

#: Upward imports that run only when a function is called, (importer, imported): why each is
#: there. Each closes no circle at import time; the cycle and layer tests allow exactly these.
CALL_TIME_UPWARD: dict[tuple[str, str], str] = {
    ("pftrack.contracts.components", "pftrack.host"):
        "RunContext.get_host: a context built without a host uses the process-wide one",
    ("pftrack.geometry.volumes", "pftrack.host"):
        "volume files shipped by plugins (pftrack_register_volumes)",
}


#: The longest a module of ``toolkit/pftrack`` or ``plugins/`` may be, in lines.
MAX_LINES = 800


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(CORE.rglob("*.py")):
        parts = list(path.relative_to(TOOLKIT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _resolve(name: str) -> str | None:
    """The pftrack module ``name`` is or lies in (``pftrack.x.y.Class`` -> ``pftrack.x.y``)."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _is_type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


def _imports(module: str) -> list[tuple[str, int, bool]]:
    """The pftrack modules ``module`` imports: (module, line, at module level), typing-only
    imports left out."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: list[tuple[str, int, bool]] = []

    def visit(node: ast.AST, top: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if _is_type_checking(child):
                for other in child.orelse:
                    visit(ast.Module(body=[other], type_ignores=[]), top)
                continue
            if isinstance(child, ast.Import):
                names = [a.name for a in child.names]
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    up = package.split(".")[: len(package.split(".")) - (child.level - 1)]
                    base = ".".join(up + ([child.module] if child.module else []))
                names = [f"{base}.{a.name}" for a in child.names]
            else:
                inner = top and not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                       ast.Lambda))
                visit(child, inner)
                continue
            for name in names:
                target = _resolve(name)
                if target and target != module:
                    found.append((target, child.lineno, top))

    visit(ast.parse(path.read_text(), filename=str(path)), True)
    return found


IMPORTS = {m: _imports(m) for m in MODULES}


def layer(module: str) -> int:
    """The rank of ``module``'s layer (:data:`LAYERS`; :data:`PUBLIC` for the public surface)."""
    parts = module.split(".")
    if len(parts) > 1:
        for rank, folders in enumerate(LAYERS):
            if parts[1] in folders:
                return rank
    return PUBLIC


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def _graph(module_level_only: bool) -> dict[str, set[str]]:
    g: dict[str, set[str]] = defaultdict(set)
    for m, imports in IMPORTS.items():
        for target, _, top in imports:
            if (top or not module_level_only) and (m, target) not in CALL_TIME_UPWARD:
                g[m].add(target)
    return g


def test_every_module_is_read_and_has_a_layer():
    assert len(MODULES) > 60
    folders = {p.relative_to(CORE).parts[0] for p in CORE.rglob("*.py")
               if len(p.relative_to(CORE).parts) > 1}
    assert folders == {f for group in LAYERS for f in group}  # a new folder needs a layer
    # the top level holds only the package, __main__ and the re-exports at the public paths
    top = sorted(p.stem for p in CORE.glob("*.py"))
    assert top == ["__init__", "__main__", "batch", "components", "data", "extensions",
                   "hookspecs", "lifecycle", "pipeline"]


def test_no_import_circle_at_module_level():
    assert _cycles(_graph(module_level_only=True)) == []


def test_no_import_circle_through_imports_in_functions():
    assert _cycles(_graph(module_level_only=False)) == []


def test_no_module_imports_a_higher_layer():
    bad = [f"{m} (layer {layer(m)}) line {line} imports {t} (layer {layer(t)})"
           for m, imports in IMPORTS.items() for t, line, _ in imports
           if t != "pftrack" and layer(t) > layer(m) and (m, t) not in CALL_TIME_UPWARD]
    assert bad == []


def test_the_allowed_upward_imports_exist_and_run_only_when_called():
    seen = {(m, t): top for m, imports in IMPORTS.items() for t, _, top in imports
            if (m, t) in CALL_TIME_UPWARD}
    assert set(seen) == set(CALL_TIME_UPWARD)  # an entry no longer needed is removed
    assert not any(seen.values())  # none at module level
    assert all(layer(t) > layer(m) for m, t in CALL_TIME_UPWARD)


def test_the_checks_see_a_circle_and_an_upward_import():
    """The graph helpers on made-up modules: a circle is found, a chain is not."""
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": {"c"}}) == []
    assert layer("pftrack.contracts.components") < layer("pftrack.host") \
        < layer("pftrack.engine.tracker") < layer("pftrack.workflows.pipeline") \
        < layer("pftrack.cli") < layer("pftrack.components")
    # a lazy import inside a function is read, and marked as such
    assert [top for t, _, top in IMPORTS["pftrack.host.config"] if t == "pftrack.io.frames"] \
        == [False]


def _line_counts(root: Path) -> dict[str, int]:
    """Lines of every module under ``toolkit/pftrack`` and ``plugins`` of the checkout at
    ``root``, by path from ``root``."""
    return {path.relative_to(root).as_posix(): len(path.read_text().splitlines())
            for base in (root / "toolkit" / "pftrack", root / "plugins")
            for path in sorted(base.rglob("*.py"))}


def test_no_module_is_longer_than_the_limit():
    root = TOOLKIT.parent
    lines = _line_counts(root)
    assert {"toolkit/pftrack/engine/tracker.py", "plugins/pftrack_world/soccer.py"} <= set(lines)
    assert {path: n for path, n in lines.items() if n > MAX_LINES} == {}


def test_the_size_check_counts_lines(tmp_path):
    """On a made-up checkout: a module of MAX_LINES + 1 lines is over, one of MAX_LINES is not."""
    (tmp_path / "toolkit" / "pftrack").mkdir(parents=True)
    (tmp_path / "plugins" / "pftrack_x").mkdir(parents=True)
    (tmp_path / "toolkit" / "pftrack" / "a.py").write_text("x = 1\n" * (MAX_LINES + 1))
    (tmp_path / "plugins" / "pftrack_x" / "b.py").write_text("y = 2\n" * MAX_LINES)
    assert _line_counts(tmp_path) == {"toolkit/pftrack/a.py": MAX_LINES + 1,
                                      "plugins/pftrack_x/b.py": MAX_LINES}
