"""Execute ``notebooks/00_geometry.ipynb`` with nbclient (python3 kernel, cwd = repo root) and
fail on any cell error; it must show its seven pictures."""

from __future__ import annotations

import pytest
from conftest import execute_notebook, pngs


@pytest.mark.slow
def test_geometry_notebook_runs():
    from pftrack.io.data import data_dir

    if not (data_dir() / "pets09" / "vtest.avi").is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    assert len(pngs(execute_notebook("00_geometry.ipynb"))) == 7
