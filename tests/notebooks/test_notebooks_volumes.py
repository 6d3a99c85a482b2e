"""Execute ``notebooks/05_coastal_volumes.ipynb`` on its short slices (PETS frames 401-470 with a
model of frames 1-120; the coast boat's first 70 frames): both stories, with their pictures and
tables."""

from __future__ import annotations

import pytest
from conftest import execute_notebook, pngs


@pytest.mark.slow
def test_coastal_volumes_notebook_runs():
    from pftrack.io.data import data_dir

    if not (data_dir() / "pets09" / "vtest.avi").is_file():
        pytest.skip("PETS data not found (set PFTRACK_DATA)")
    outputs = execute_notebook("05_coastal_volumes.ipynb", timeout=600)
    assert len(pngs(outputs)) == 3
    tables = [o["data"]["text/markdown"] for o in outputs if "text/markdown" in o.get("data", {})]
    assert len(tables) == 2
    assert "MOTA ground" in tables[0] and "| boat | 7.5 x 1.8 x 2.3 |" in tables[1]
