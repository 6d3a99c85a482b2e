"""Execute ``notebooks/07_own_detector.ipynb`` (pftrack.Tracker fed OpenCV HOG people
detections on PETS 2009 S2.L1) on frames 1-40 with nbclient and the venv's ``python3``
kernel."""

from __future__ import annotations

import pytest
from conftest import code_outputs, fat_cells, markdown, pngs, run_notebook


@pytest.mark.slow
def test_own_detector_notebook_runs(tmp_path, monkeypatch):
    from pftrack.io.data import data_dir

    if not (data_dir() / "pets09" / "vtest.avi").is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    monkeypatch.setenv("PFTRACK_NB_FRAMES", "1:40")
    nb = run_notebook("07_own_detector.ipynb", cwd=tmp_path, timeout=600)
    outputs = code_outputs(nb)
    assert len(pngs(outputs)) == 2  # the last frame with ellipses, the sd over time
    text = markdown(outputs)
    assert "published after their frame" in text and "| MOTA | IDF1 | HOTA |" in text
    row = text.split("\n")[-1].strip("| ").split(" | ")
    assert float(row[0]) > 0.4 and float(row[1]) > 0.4, text  # 0.656 / 0.753 when written
    streams = "".join(o.get("text", "") for o in outputs if o.get("output_type") == "stream")
    assert "frame 40: tracks" in streams and "box sd (px)" in streams
    assert not fat_cells(nb, 8)
