"""Execute ``notebooks/06_camera_network.ipynb`` (the camera-network paper on a small case, about a minute); it
must show its three pictures and the tables, the gated ensemble in both figure 5 and Table 1."""

from __future__ import annotations

import base64

import pytest
from conftest import execute_notebook, pngs


@pytest.mark.slow
def test_camera_network_notebook_runs():
    from pftrack.io.data import data_dir

    if not (data_dir() / "reid" / "caviar4reid").is_dir():
        pytest.skip("CAVIAR4REID data not found (set PFTRACK_DATA)")
    outputs = execute_notebook("06_camera_network.ipynb")
    assert len(pngs(outputs)) == 3
    tables = [o["data"]["text/markdown"] for o in outputs if "text/markdown" in o.get("data", {})]
    assert len(tables) == 1
    assert "min-cost-flow" in tables[0] and "C_d=13" in tables[0]
    assert "trajectory-ensemble-gated (C_d=9)" in tables[0]
    # figure 5 side by side: min-cost flow, the paper's ensemble and the gated one (3 panels
    # of 5.4 in at 90 dpi; two would be 972 px wide)
    png = base64.b64decode(pngs(outputs)[2]["data"]["image/png"])
    assert int.from_bytes(png[16:20], "big") == round(3 * 5.4 * 90)
