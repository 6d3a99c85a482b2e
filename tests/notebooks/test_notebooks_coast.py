"""Execute ``notebooks/04_block_eigenspace.ipynb`` (the water sequences, about 10 s); it must
show its four pictures and the comparison table."""

from __future__ import annotations

import pytest
from conftest import execute_notebook, pngs


@pytest.mark.slow
def test_block_eigenspace_notebook_runs():
    from pftrack.io.data import data_dir

    if not (data_dir() / "water" / "zodiac").is_dir():
        pytest.skip("water data not found (set PFTRACK_DATA)")
    outputs = execute_notebook("04_block_eigenspace.ipynb")
    assert len(pngs(outputs)) == 4
    tables = [o["data"]["text/markdown"] for o in outputs if "text/markdown" in o.get("data", {})]
    assert len(tables) == 1 and "ocean    eigenspace block" in tables[0]
