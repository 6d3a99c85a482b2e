"""Execute ``notebooks/01_cross_entropy.ipynb`` on short slices (walkers: 30 frames, PETS:
frames 1-20) with nbclient and the venv's ``python3`` kernel."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from conftest import code_outputs, fat_cells, markdown, pngs, run_notebook


@pytest.mark.slow
def test_cross_entropy_notebook_runs(tmp_path, monkeypatch):
    from pftrack.io.data import data_dir

    if not (data_dir() / "pets09" / "vtest.avi").is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    monkeypatch.setenv("PFTRACK_NB_FRAMES", "30")
    monkeypatch.setenv("PFTRACK_NB_PETS_LAST", "20")
    nb = run_notebook("01_cross_entropy.ipynb", cwd=tmp_path, timeout=600)
    outputs = code_outputs(nb)
    images = pngs(outputs)
    assert len(images) >= 6  # scene, likelihood maps, overlays, trajectories, curves, PETS
    text = markdown(outputs)
    for word in ("cross-entropy-bg", "bhattacharyya-bg", "csrt", "mil", "HOTA"):
        assert word in text, word
    # thin cells: a few library calls each, no logic
    assert not fat_cells(nb, 4)
    assert os.environ.get("PFTRACK_NB_FRAMES") == "30"
