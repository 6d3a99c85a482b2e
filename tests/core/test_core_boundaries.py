"""The core package imports no built-in plugin: plugins depend on the core, never the reverse.

Every module under ``toolkit/pftrack`` is parsed and each ``import``/``from ... import`` read,
at any depth (inside functions too), so that a lazy import of a plugin cannot hide either.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pftrack

CORE = Path(pftrack.__file__).parent
PLUGINS = ("pftrack_basic", "pftrack_coast", "pftrack_colour", "pftrack_network", "pftrack_world")


def _imports(path: Path) -> list[tuple[int, str]]:
    out = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            out.extend((node.lineno, a.name) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.append((node.lineno, node.module))
    return out


def test_no_core_module_imports_a_builtin_plugin():
    modules = sorted(CORE.rglob("*.py"))
    assert len(modules) > 40  # the whole core was read
    bad = [f"{p.relative_to(CORE.parent)}:{line} imports {name}"
           for p in modules for line, name in _imports(p)
           if name.split(".")[0] in PLUGINS]
    assert bad == []


def test_the_scan_sees_lazy_imports(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("def f():\n    from pftrack_world.detector import load_model\n"
                   "    import pftrack_basic.motion\n")
    assert _imports(src) == [(2, "pftrack_world.detector"), (3, "pftrack_basic.motion")]


def test_no_core_package_data_is_a_plugin_preset():
    assert not (CORE / "presets").exists()
