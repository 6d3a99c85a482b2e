"""Shared test helpers."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

pytest_plugins = ["pytester"]  # the conformance kit's parametrize helper is run in a sandbox

ROOT = Path(__file__).resolve().parents[1]
# the shared data beside the checkout, also for notebook kernels run in temporary folders
os.environ.setdefault("PFTRACK_DATA", str(ROOT.parent / "shared" / "data"))


def execute_notebook(name: str, cwd: Path = ROOT, timeout: int = 300) -> list[dict]:
    """Execute ``notebooks/NAME`` with nbclient (the ``python3`` kernel, working directory
    ``cwd``), fail on any cell error, and return every code cell's outputs in order."""
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    nb = nbformat.read(ROOT / "notebooks" / name, as_version=4)
    nbclient.NotebookClient(nb, kernel_name="python3", timeout=timeout,
                            resources={"metadata": {"path": str(cwd)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    return outputs


def pngs(outputs: list[dict]) -> list[dict]:
    """The outputs that show a picture."""
    return [o for o in outputs if "image/png" in o.get("data", {})]
