"""Execute ``notebooks/03_pets_ground_plane.ipynb`` on short slices (training frames 1-120,
tracking frames 401-460) with nbclient and the venv's ``python3`` kernel."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import code_outputs, fat_cells, markdown, pngs, run_notebook


@pytest.mark.slow
def test_pets_ground_plane_notebook_runs(tmp_path, monkeypatch):
    from pftrack.io.data import data_dir

    if not (data_dir() / "pets09" / "vtest.avi").is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    monkeypatch.setenv("PFTRACK_NB_TRAIN", "1:120")
    monkeypatch.setenv("PFTRACK_NB_FRAMES", "401:460")
    nb = run_notebook("03_pets_ground_plane.ipynb", cwd=tmp_path, timeout=600)
    outputs = code_outputs(nb)
    images = pngs(outputs)
    assert len(images) == 3  # two trajectory figures, one overlay
    text = markdown(outputs)
    assert "MOTA" in text and "median_error_m" in text and "trained on frames 1:120" in text
    # the metrics row: MOTA on this slice is well above zero
    row = text.split("\n")[-1].strip("| ").split(" | ")
    assert float(row[0]) > 0.5, text
    # thin cells: a few library calls each, no logic
    assert not fat_cells(nb, 8)
