"""Execute ``notebooks/01_cross_entropy.ipynb`` on short slices (walkers: 30 frames, PETS:
frames 1-20) with nbclient and the venv's ``python3`` kernel."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "01_cross_entropy.ipynb"


@pytest.mark.slow
def test_cross_entropy_notebook_runs(tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    from pftrack.data import data_dir

    if not (data_dir() / "pets09" / "vtest.avi").is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    monkeypatch.setenv("PFTRACK_NB_FRAMES", "30")
    monkeypatch.setenv("PFTRACK_NB_PETS_LAST", "20")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(nb, kernel_name="python3", timeout=600,
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 6  # scene, likelihood maps, overlays, trajectories, curves, PETS
    text = "".join(o.get("data", {}).get("text/markdown", "") for o in outputs)
    for word in ("cross-entropy-bg", "bhattacharyya-bg", "csrt", "mil", "HOTA"):
        assert word in text, word
    # thin cells: a few library calls each, no logic
    for cell in nb.cells:
        if cell.cell_type == "code":
            calls = [ln for ln in cell.source.splitlines() if ln.strip()
                     and not ln.lstrip().startswith(("#", "import ", "from "))]
            assert len(calls) <= 4, cell.source
    assert os.environ.get("PFTRACK_NB_FRAMES") == "30"
