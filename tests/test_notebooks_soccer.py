"""Execute ``notebooks/02_soccer_world.ipynb`` on a 2 s slice with nbclient and the venv's
``python3`` kernel: it runs without error, shows its pictures and scores, and stays thin."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "02_soccer_world.ipynb"


@pytest.mark.slow
def test_soccer_notebook_runs(tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    monkeypatch.setenv("PFTRACK_NB_SECONDS", "2")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(nb, kernel_name="python3", timeout=600,
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) == 5  # scene, calibration, tracks, particle clouds, top view
    text = "".join(o.get("data", {}).get("text/markdown", "") for o in outputs)
    assert "22 x 300" in text and "50 at 25 fps" in text
    # the scores table: on the first 2 s every player is tracked
    mota = float(re.search(r"IoU 0\.5, as pets09-ground\) \| ([0-9.]+) /", text).group(1))
    acc = float(re.search(r"within 5 px\) \| ([0-9.]+)", text).group(1))
    assert mota > 0.8 and acc > 0.95
    # thin cells: a few library calls each, no logic
    for cell in nb.cells:
        if cell.cell_type == "code":
            calls = [ln for ln in cell.source.splitlines() if ln.strip()
                     and not ln.lstrip().startswith(("#", "import ", "from "))]
            assert len(calls) <= 4, cell.source
