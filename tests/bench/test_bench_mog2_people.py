"""``pftrack bench mog2-people`` on a short PETS slice: blob boxes against person boxes through
the real camera, recall and precision at IoU 0.5."""

from __future__ import annotations

import argparse
import json

import pytest
from pftrack.host import get_host
from pftrack.io.data import data_dir

PETS = data_dir() / "pets09"


@pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")
def test_mog2_people_bench_on_a_slice():
    bench = get_host().get("benchmark", "mog2-people")
    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    r = bench.run(parser.parse_args(["--frames", "201:240", "--quiet"]))
    json.dumps(r)
    blob, person = r["rows"]
    assert blob["boxes"] == "blob" and person["boxes"] == "person"
    assert person["camera"].endswith("View_001.xml")
    assert r["frames"] == "201:240" and blob["gt_boxes"] == person["gt_boxes"] == 182
    # measured on 201-240: blob 0.890 / 0.753, person 0.973 / 0.876
    assert person["detector_recall"] > blob["detector_recall"] + 0.05, r
    assert person["detector_precision"] > blob["detector_precision"] + 0.05, r
    assert "person" in bench.format_table(r)
