"""Execute ``notebooks/04_block_eigenspace.ipynb`` (the water sequences, about 10 s) with nbclient
and fail on any cell error; it must show its four pictures and the comparison table."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "notebooks" / "04_block_eigenspace.ipynb"


@pytest.mark.slow
def test_block_eigenspace_notebook_runs():
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    from pftrack.data import data_dir

    if not (data_dir() / "water" / "zodiac").is_dir():
        pytest.skip("water data not found (set PFTRACK_DATA)")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(nb, kernel_name="python3", timeout=300,
                                     resources={"metadata": {"path": str(ROOT)}})
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    assert len([o for o in outputs if "image/png" in o.get("data", {})]) == 4
    tables = [o["data"]["text/markdown"] for o in outputs if "text/markdown" in o.get("data", {})]
    assert len(tables) == 1 and "ocean    eigenspace block" in tables[0]
