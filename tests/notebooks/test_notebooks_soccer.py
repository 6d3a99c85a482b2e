"""Execute ``notebooks/02_soccer_world.ipynb`` on a 2 s slice with nbclient and the venv's
``python3`` kernel: it runs without error, shows its pictures and scores, and stays thin."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import code_outputs, fat_cells, markdown, pngs, run_notebook


@pytest.mark.slow
def test_soccer_notebook_runs(tmp_path, monkeypatch):
    monkeypatch.setenv("PFTRACK_NB_SECONDS", "2")
    nb = run_notebook("02_soccer_world.ipynb", cwd=tmp_path, timeout=600)
    outputs = code_outputs(nb)
    images = pngs(outputs)
    assert len(images) == 5  # scene, calibration, tracks, particle clouds, top view
    text = markdown(outputs)
    assert "22 x 300" in text and "50 at 25 fps" in text
    # the scores table: on the first 2 s every player is tracked
    mota = float(re.search(r"IoU 0\.5, as pets09-ground\) \| ([0-9.]+) /", text).group(1))
    acc = float(re.search(r"within 5 px\) \| ([0-9.]+)", text).group(1))
    assert mota > 0.8 and acc > 0.95
    # thin cells: a few library calls each, no logic
    assert not fat_cells(nb, 4)
