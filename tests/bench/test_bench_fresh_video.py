"""``pftrack bench fresh-video`` on a short PETS slice: every figure of the issue's JSON is
there and measured (bounds around the values of frames 201-280 on the development machine)."""

from __future__ import annotations

import argparse
import json

import pytest
from pftrack.io.data import data_dir

PETS = data_dir() / "pets09"


@pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")
def test_fresh_video_bench_on_a_slice(capsys):
    pytest.importorskip("norfair")
    from pftrack.host import get_host

    bench = get_host().get("benchmark", "fresh-video")
    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    args = parser.parse_args(["--frames", "201:280", "--seeds", "2", "--quiet"])
    r = bench.run(args)
    json.dumps(r)  # JSON-ready
    for k in ("MOTA", "IDF1", "HOTA", "detector_recall", "detector_precision",
              "camera_median_error_m", "horizon_error_px", "frames_per_second"):
        assert isinstance(r[k], float), k
    assert r["n_frames"] == 80 and r["frames"] == "201:280"
    # the detector pftrack track would choose: PETS's people are small in the frame
    assert r["detector"] == "hog-people" and "small" in r["detector_choice"]
    # the detector: most visible people found, few false alarms
    assert 0.7 < r["detector_recall"] <= 1.0 and r["detector_precision"] > 0.85
    # tracking with a camera estimated from these 80 frames' detections alone
    assert r["MOTA"] > 0.5 and r["IDF1"] > 0.5 and 0.3 < r["HOTA"] <= 1.0, r
    # the estimated camera against the real one: within a metre, horizon within 80 px
    assert r["camera_median_error_m"] < 1.0 and r["horizon_error_px"] < 80
    assert 4.0 < r["camera"]["camera_height_m"] < 10.0
    assert r["frames_per_second"] > 1.0  # a loaded machine; ~10 per CPU second when idle
    peer = r["peer"]
    assert peer["name"] == "norfair" and -1.0 < peer["MOTA"] <= 1.0 and 0 < peer["IDF1"] <= 1
    assert set(r["goals"]) >= {"MOTA", "IDF1", "camera_median_error_m", "better_than_peer"}
    sd = r["seeds"]
    assert sd["n"] == 2 and [x["seed"] for x in sd["per_seed"]] == [0, 1]
    assert sd["per_seed"][0]["IDF1"] == r["IDF1"]  # seed 0 is the headline run
    assert sd["IDF1_mean"] == pytest.approx((r["IDF1"] + sd["per_seed"][1]["IDF1"]) / 2)
    assert "better_than_peer_mean" in r["goals"]
    table = bench.format_table(r)
    assert "mean of 2 seeds" in table
    assert "peer norfair: MOTA" in table and "better_than_peer" in table
    # the preset's detector searches the whole frame on every 2nd frame only (near the people
    # found before and where the frame changed on the others); every frame searched whole: the
    # camera sees the same boxes (every 2nd frame from the first), nearly the same people
    r1 = bench.run(parser.parse_args(["--frames", "201:280", "--seeds", "1", "--quiet",
                                      "--no-peer", "--full-every", "1"]))
    assert r["detector_full_every"] == 2 and r1["detector_full_every"] == 1
    assert r1["camera_median_error_m"] == r["camera_median_error_m"]
    assert abs(r1["detector_recall"] - r["detector_recall"]) < 0.01
    assert abs(r1["detector_precision"] - r["detector_precision"]) < 0.01
    assert r1["MOTA"] > 0.5
