"""Execute ``notebooks/06_camera_network.ipynb`` (seed 004 on a small case, about a minute); it
must show its three pictures and the tables."""

from __future__ import annotations

import pytest
from conftest import execute_notebook, pngs


@pytest.mark.slow
def test_camera_network_notebook_runs():
    from pftrack.data import data_dir

    if not (data_dir() / "reid" / "caviar4reid").is_dir():
        pytest.skip("CAVIAR4REID data not found (set PFTRACK_DATA)")
    outputs = execute_notebook("06_camera_network.ipynb")
    assert len(pngs(outputs)) == 3
    tables = [o["data"]["text/markdown"] for o in outputs if "text/markdown" in o.get("data", {})]
    assert len(tables) == 1
    assert "min-cost-flow" in tables[0] and "C_d=13" in tables[0]
