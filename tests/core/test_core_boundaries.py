"""The core package imports no built-in plugin: plugins depend on the core, never the reverse;
and no part of the product (the core and the built-in plugins) imports the repository's
benchmarks (``pftrack_bench``, a distribution of its own that ``pip install pftrack`` does not
install).

Every module under ``toolkit/pftrack`` is parsed and each ``import``/``from ... import`` read,
at any depth (inside functions too), so that a lazy import of a plugin cannot hide either.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pftrack

CORE = Path(pftrack.__file__).parent
PLUGINS = ("pftrack_basic", "pftrack_coast", "pftrack_colour", "pftrack_network", "pftrack_world")
ROOT = Path(__file__).resolve().parents[2]
BENCH = "pftrack_bench"


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


def test_no_product_module_imports_the_benchmarks():
    plugin_dir = ROOT / "plugins"
    modules = sorted(CORE.rglob("*.py")) + sorted(plugin_dir.rglob("*.py"))
    assert {p.relative_to(plugin_dir).parts[0] for p in plugin_dir.rglob("*.py")} == set(PLUGINS)
    bad = [f"{p}:{line} imports {name}" for p in modules for line, name in _imports(p)
           if name.split(".")[0] == BENCH]
    assert bad == []
    # ... nor does the product ship a benchmark module (they live in benchmarks/pftrack_bench)
    assert sorted(plugin_dir.glob("*/bench_*.py")) == []
    assert sorted(CORE.rglob("bench_*.py")) == []


def test_the_benchmarks_are_their_own_distribution():
    """pftrack's pyproject packages the core and the plugins only; the benchmarks' own
    pyproject registers them through the pftrack entry-point group, as a third party would."""
    import tomllib

    root = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert root["tool"]["setuptools"]["packages"]["find"]["where"] == ["toolkit", "plugins"]
    assert BENCH not in root["project"]["entry-points"]["pftrack"].values()
    bench = tomllib.loads((ROOT / "benchmarks" / "pyproject.toml").read_text())
    assert bench["project"]["entry-points"]["pftrack"] == {"bench": BENCH}
    assert (ROOT / "benchmarks" / BENCH / "__init__.py").is_file()


def test_the_scan_sees_lazy_imports(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("def f():\n    from pftrack_world.detector import load_model\n"
                   "    import pftrack_basic.motion\n    from pftrack_bench import core\n")
    assert _imports(src) == [(2, "pftrack_world.detector"), (3, "pftrack_basic.motion"),
                             (4, "pftrack_bench")]


def test_no_core_package_data_is_a_plugin_preset():
    assert not (CORE / "presets").exists()


def test_without_the_benchmarks_pftrack_bench_says_where_they_are():
    import os
    import subprocess
    import sys

    env = {**os.environ, "PFTRACK_DISABLE_PLUGINS": "bench"}
    out = subprocess.run([sys.executable, "-m", "pftrack", "bench", "--help"], env=env,
                         capture_output=True, text=True, timeout=120, check=True).stdout
    assert "no benchmark is registered: pftrack ships none" in " ".join(out.split())
    assert "pftrack_bench" in out
