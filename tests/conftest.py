"""Shared test helpers: the repository root, the notebook runner, the sample motion model and the
reference-image comparison. Imported by the test modules as ``from conftest import ...``."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from pftrack.contracts.components import MotionModel

pytest_plugins = ["pytester"]  # the conformance kit's parametrize helper is run in a sandbox

ROOT = Path(__file__).resolve().parents[1]
# the shared data beside the checkout, also for notebook kernels run in temporary folders
os.environ.setdefault("PFTRACK_DATA", str(ROOT.parent / "shared" / "data"))


# -- notebooks -----------------------------------------------------------------------------------


def run_notebook(name: str, cwd: Path = ROOT, timeout: int = 300) -> Any:
    """Execute ``notebooks/NAME`` with nbclient (the ``python3`` kernel, working directory
    ``cwd``; the environment is the test's), fail on any cell error, and return the executed
    notebook."""
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    nb = nbformat.read(ROOT / "notebooks" / name, as_version=4)
    nbclient.NotebookClient(nb, kernel_name="python3", timeout=timeout,
                            resources={"metadata": {"path": str(cwd)}}).execute()
    errors = [o for o in code_outputs(nb) if o.get("output_type") == "error"]
    assert not errors, errors
    return nb


def code_outputs(nb: Any) -> list[dict]:
    """Every code cell's outputs, in order."""
    return [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]


def execute_notebook(name: str, cwd: Path = ROOT, timeout: int = 300) -> list[dict]:
    """:func:`run_notebook`, returning every code cell's outputs in order."""
    return code_outputs(run_notebook(name, cwd, timeout))


def pngs(outputs: list[dict]) -> list[dict]:
    """The outputs that show a picture."""
    return [o for o in outputs if "image/png" in o.get("data", {})]


def markdown(outputs: list[dict]) -> str:
    """The Markdown the outputs show, joined."""
    return "".join(o.get("data", {}).get("text/markdown", "") for o in outputs)


def fat_cells(nb: Any, max_calls: int) -> list[str]:
    """Code cells with more than ``max_calls`` lines that are neither comments nor imports (a
    notebook's cells stay thin: a few library calls each, no logic)."""
    fat = []
    for cell in nb.cells:
        if cell.cell_type == "code":
            calls = [ln for ln in cell.source.splitlines() if ln.strip()
                     and not ln.lstrip().startswith(("#", "import ", "from "))]
            if len(calls) > max_calls:
                fat.append(cell.source)
    return fat


# -- a sample motion model -----------------------------------------------------------------------


class SampleWalk(MotionModel):
    """A 2-D random walk: ``sigma * sqrt(dt)`` pixels of Gaussian noise per step."""

    def __init__(self, sigma: float = 1.0) -> None:
        self.sigma = sigma

    @property
    def state_dim(self) -> int:
        return 2

    def predict(self, states, dt, rng, target=None):
        return states + rng.normal(0.0, self.sigma * np.sqrt(dt), states.shape)

    def init_states(self, position, n, rng, spread=1.0):
        return position[None, :] + rng.normal(0.0, 1.0, (n, 2)) * spread


# -- reference images ----------------------------------------------------------------------------

REF_DIR = ROOT / "tests" / "core" / "render" / "reference_images"
#: mean absolute difference (grey levels, 0-255, over all pixels and channels) allowed
#: against a reference; renders here differ from the reference by 0.0 on the same machine.
MEAN_ABS_TOL = 2.0


def compare_reference(name: str, image_rgb: np.ndarray) -> float:
    """Mean abs difference to ``REF_DIR / NAME`` (rewritten when
    PFTRACK_UPDATE_REFERENCES=1)."""
    path = REF_DIR / name
    if os.environ.get("PFTRACK_UPDATE_REFERENCES") == "1":
        REF_DIR.mkdir(exist_ok=True)
        assert cv2.imwrite(str(path), np.ascontiguousarray(image_rgb[:, :, ::-1]))
    ref = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert ref is not None, f"missing reference {path}; run with PFTRACK_UPDATE_REFERENCES=1"
    ref = ref[:, :, ::-1]
    assert ref.shape == image_rgb.shape
    return float(np.abs(ref.astype(np.int16) - image_rgb.astype(np.int16)).mean())
