"""``pftrack bench people-colour`` on a short PETS slice with ground-truth boxes as the
detections (written to a temporary det.txt): every configuration's row, per-seed runs, and the
ordering the design predicts when the detections are perfect."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest
from pftrack.host import get_host
from pftrack.io.data import data_dir

PETS = data_dir() / "pets09"


@pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")
def test_people_colour_bench_on_a_slice_with_given_detections(tmp_path):
    gt = np.loadtxt(PETS / "gt.txt", delimiter=",")
    gt = gt[(gt[:, 0] >= 1) & (gt[:, 0] <= 40) & (gt[:, 6] != 0)]
    det = np.column_stack([gt[:, 0], np.full(len(gt), -1), gt[:, 2:6], np.full(len(gt), 0.9)])
    # every 4th frame's detections are missing: the trackers must bridge them
    det = det[det[:, 0] % 4 != 0]
    path = tmp_path / "det.txt"
    np.savetxt(path, det, delimiter=",", fmt="%.2f")
    bench = get_host().get("benchmark", "people-colour")
    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    r = bench.run(parser.parse_args(["--part", "tune", "--frames", "1:40", "--detections",
                                     str(path), "--seeds", "0,1", "--quiet"]))
    json.dumps(r)
    assert r["part"] == "tune" and r["frames"] == "1:40"
    assert r["protocol"]["chosen_on"].startswith("frames 1-200")
    rows = {row["name"]: row for row in r["rows"]}
    assert set(rows) == {"people-colour", "people-colour, colour weight 0", "people-image"}
    for row in rows.values():
        assert [x["seed"] for x in row["runs"]] == [0, 1]
        assert row["MOTA"] == pytest.approx(np.mean([x["MOTA"] for x in row["runs"]]))
    # ground-truth boxes with gaps: the people-colour preset follows them closely
    assert rows["people-colour"]["MOTA"] > 0.8, rows["people-colour"]
    assert rows["people-colour"]["IDF1"] > 0.8, rows["people-colour"]
    assert "people-colour" in bench.format_table(r)


def test_people_colour_bench_refuses_no_seed():
    bench = get_host().get("benchmark", "people-colour")
    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    with pytest.raises(ValueError, match="--seeds"):
        bench.run(parser.parse_args(["--seeds", ",", "--frames", "201:202"]))


def test_people_colour_bench_refuses_the_frames_that_chose_its_settings():
    bench = get_host().get("benchmark", "people-colour")
    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    with pytest.raises(ValueError, match=r"frames 1:40 are not inside its report part "
                                         r"\(201:795\).*only with --part tune"):
        bench.run(parser.parse_args(["--frames", "1:40", "--quiet"]))
    with pytest.raises(ValueError, match="not inside its report part"):
        bench.run(parser.parse_args(["--frames", "190:210", "--quiet"]))
    with pytest.raises(ValueError, match=r"not inside its tune part \(1:200\)"):
        bench.run(parser.parse_args(["--part", "tune", "--frames", "201:240", "--quiet"]))
