"""``pftrack bench own-detections``: the simulated detector's rates on PETS's ground truth, its
seeding, MOT17's distractor rule, the tune-part refusal, and a short run of the bench."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest
from pftrack.io.data import data_dir
from pftrack_bench import own_detections as bod

PETS = data_dir() / "pets09"
needs_pets = pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")


def _measure(gt: np.ndarray, mask: np.ndarray, det: np.ndarray) -> dict[str, float]:
    """Rates of simulated detections against the detectable rows: true boxes are told from
    false positives by score (0.85 +- 0.05 against 0.55 +- 0.05: cut at 0.7); corner and size
    errors of true boxes matched one to one (Hungarian, IoU >= 0.1) to boxes away from the
    image's edges (clipping would change them)."""
    from pftrack.geometry.boxes import iou_matrix
    from scipy.optimize import linear_sum_assignment

    g = gt[mask]
    true, fp = det[det[:, 6] >= 0.7], det[det[:, 6] < 0.7]
    corner, size = [], []
    for f in np.unique(g[:, 0]):
        gg, dd = g[g[:, 0] == f], true[true[:, 0] == f]
        if not len(dd):
            continue
        iou = iou_matrix(dd[:, 2:6], gg[:, 2:6])
        r, c = linear_sum_assignment(-iou)
        ok = iou[r, c] >= 0.1
        r, c = r[ok], c[ok]
        inner = ((gg[c, 2] > 20) & (gg[c, 3] > 20) & (gg[c, 2] + gg[c, 4] < 748)
                 & (gg[c, 3] + gg[c, 5] < 556))
        corner.append((dd[r, 2:4] - gg[c, 2:4])[inner])
        size.append((dd[r, 4:6] / gg[c, 4:6] - 1.0)[inner])
    cs, ss = np.concatenate(corner), np.concatenate(size)
    return {"detected": len(true) / len(g), "fp": len(fp) / len(g),
            "corner_sd": float(cs.std()), "size_sd": float(ss.std()),
            "true_score": float(true[:, 6].mean()),
            "fp_score": float(fp[:, 6].mean()) if len(fp) else float("nan")}


@needs_pets
@pytest.mark.parametrize("level", ["clean", "noisy"])
def test_simulated_detector_rates_on_pets(level):
    gt = bod.read_gt("pets09")
    mask = bod.detectable_mask(gt, "pets")
    assert mask.sum() == 4650 - 174  # flag-0 rows are nobody a detector is asked for
    lv = bod.LEVELS[level]
    det = bod.simulate_detections(gt, level, 7, (768, 576), detectable=mask)
    assert det.shape[1] == 7 and np.all(det[:, 1] == -1)
    assert np.all(np.diff(det[:, 0]) >= 0)  # sorted by frame
    # clipped to the image as a detector's boxes are
    assert np.all(det[:, 2:4] >= 0) and np.all(det[:, 2] + det[:, 4] <= 768 + 1e-9)
    assert np.all(det[:, 3] + det[:, 5] <= 576 + 1e-9) and np.all(det[:, 4:6] >= 1)
    m = _measure(gt, mask, det)
    # 4476 boxes: the binomial sd of the miss rate is 0.006
    assert m["detected"] == pytest.approx(1.0 - lv.miss_rate, abs=0.02), m
    assert m["fp"] == pytest.approx(lv.fp_rate, abs=0.015), m
    # the corner's and size's standard deviations within 10 % of the level's
    assert m["corner_sd"] == pytest.approx(lv.corner_sd_px, rel=0.1), m
    assert m["size_sd"] == pytest.approx(lv.size_sd, rel=0.1), m
    assert m["true_score"] == pytest.approx(lv.score_mean, abs=0.01), m
    if lv.fp_rate:
        assert m["fp_score"] == pytest.approx(lv.fp_score_mean, abs=0.02), m


@needs_pets
def test_same_seed_same_detections():
    gt = bod.read_gt("pets09")
    mask = bod.detectable_mask(gt, "pets")
    a = bod.simulate_detections(gt, "noisy", 3, (768, 576), detectable=mask)
    b = bod.simulate_detections(gt, "noisy", 3, (768, 576), detectable=mask)
    c = bod.simulate_detections(gt, "noisy", 4, (768, 576), detectable=mask)
    assert np.array_equal(a, b)
    assert len(a) != len(c) or not np.allclose(a, c)
    # by default the flag column says who is detectable: the same draws as the explicit mask
    assert np.array_equal(bod.simulate_detections(gt, "noisy", 3, (768, 576)), a)


def test_unknown_level_and_bad_rows_are_named():
    with pytest.raises(ValueError, match="unknown noise level 'loud'"):
        bod.simulate_detections(np.zeros((1, 10)), "loud", 0, (10, 10))
    with pytest.raises(ValueError, match=r"MOT rows \(M, >= 7\)"):
        bod.simulate_detections(np.zeros((3, 6)), "clean", 0, (10, 10))


def test_mot17_visibility_rule():
    rows = np.array([[1, 1, 0, 0, 10, 20, 1, 1, 0.9, 0],    # a visible pedestrian
                     [1, 2, 0, 0, 10, 20, 1, 1, 0.1, 0],    # one hidden behind another
                     [1, 3, 0, 0, 10, 20, 0, 7, 1.0, 0],    # a static person: not asked for
                     [1, 4, 0, 0, 10, 20, 1, 1, bod.MOT17_MIN_VISIBILITY, 0]], float)
    assert bod.detectable_mask(rows, "mot17").tolist() == [True, False, False, True]


def test_mot17_distractor_rule_removes_a_box_on_class_7_and_keeps_one_on_a_pedestrian():
    from pftrack.metrics import evaluate

    # frame 1: a pedestrian (class 1), a static person (7), an occluder (9), far apart
    gt = np.array([[1, 1, 100, 100, 50, 100, 1, 1, 1.0, -1],
                   [1, 2, 300, 100, 50, 100, 0, 7, 1.0, -1],
                   [1, 3, 500, 100, 50, 100, 0, 9, 1.0, -1]], float)
    tracks = np.array([[1, 10, 102, 101, 50, 100, 1, -1, -1, -1],   # on the pedestrian
                       [1, 11, 303, 99, 50, 100, 1, -1, -1, -1],    # on the static person
                       [1, 12, 501, 100, 50, 100, 1, -1, -1, -1]], float)  # on the occluder
    g, t = bod.mot17_scoring_rows(gt, tracks)
    assert g[:, 1].tolist() == [1] and g[0, 6] == 1  # pedestrians only
    assert sorted(t[:, 1].tolist()) == [10, 12]      # the box on class 7 is gone
    m = bod.score_tracks(gt, tracks, "mot17", (1, 1))
    # the pedestrian found, the box on the occluder a false positive, class 7 neither way
    assert (m["TP"], m["FP"], m["FN"]) == (1, 1, 0)
    assert m == evaluate(g, t, zero_marked="keep")
    # a box on the static person that overlaps it below IoU 0.5 is not removed
    off = tracks.copy()
    off[1, 2] = 340.0  # IoU 10/90
    assert sorted(bod.mot17_scoring_rows(gt, off)[1][:, 1].tolist()) == [10, 11, 12]


def test_tune_frames_are_refused_unless_the_tune_part_is_asked_for():
    assert bod.resolve_frames("pets09", "report") == (401, 795)
    assert bod.resolve_frames("mot17-09", "report") == (263, 525)
    assert bod.resolve_frames("mot17-09", "tune") == (1, 262)
    with pytest.raises(ValueError, match="printed only with --part tune"):
        bod.resolve_frames("pets09", "report", (1, 60))
    with pytest.raises(ValueError, match="not inside its report part"):
        bod.resolve_frames("pets09", "report", (380, 420))  # straddles the two parts
    assert bod.resolve_frames("pets09", "tune", (1, 60)) == (1, 60)
    with pytest.raises(ValueError, match="not inside its tune part"):
        bod.resolve_frames("pets09", "tune", (401, 460))
    # through the command line: refused before any tracking
    from pftrack.host import get_host

    bench = get_host().get("benchmark", "own-detections")
    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    with pytest.raises(ValueError, match="--part tune"):
        bench.run(parser.parse_args(["--videos", "pets09", "--frames", "pets09=1:60"]))
    with pytest.raises(ValueError, match="unknown tracker 'deepsort'"):
        bench.run(parser.parse_args(["--videos", "pets09", "--trackers", "deepsort"]))


@needs_pets
@pytest.mark.slow
def test_bench_on_60_pets_frames():
    pytest.importorskip("trackers")
    r = bod.run_benchmark(videos=["pets09"], levels=["clean"], seeds=[0],
                          trackers=["people-image", "bytetrack", "norfair"],
                          frames={"pets09": (401, 460)})
    json.dumps(r)
    assert r["part"] == "report" and r["settings_chosen_on"] == "tune"
    assert r["frames"] == {"pets09": [401, 460]} and r["protocol"]["videos"]["pets09"]["tune"]
    assert r["machine"]["cpu_count"] >= 1 and len(r["commit"] or "x" * 40) == 40
    cells = {c["tracker"]: c for c in r["cells"]}
    assert set(cells) == {"people-image", "bytetrack", "norfair"}
    for c in cells.values():
        assert c["status"] == "ok" and c["n_frames"] == 60, c
        assert all(np.isfinite(c[k]) for k in bod.FIGURES), c
        assert c["cpu_s"] > 0, c
    # measured on this slice (seed 0): people-image HOTA 0.70, IDF1 0.93, MOTA 0.91;
    # ByteTrack 0.59, 0.87, 0.77; norfair 0.71, 0.91, 0.83
    for name in cells:
        assert 0.45 < cells[name]["HOTA"] < 0.9 and 0.7 < cells[name]["IDF1"] <= 1.0, cells[name]
        assert 0.55 < cells[name]["MOTA"] <= 1.0 and cells[name]["IDSW"] <= 3, cells[name]
    s = {x["tracker"]: x for x in r["summary"]}
    assert s["bytetrack"]["cpu_ratio_to_bytetrack"] == pytest.approx(1.0)
    assert s["people-image"]["cpu_ratio_to_bytetrack"] > 0
    g = r["goals"]
    assert g["applies"] is False and set(g["trackers"]) == {"people-image"}
    text = bod.format_table(r)
    assert "report part" in text and "people-image" in text and "not one the goals" in text


def _cell(video, level, seed, tracker, kind, hota, idf1, idsw, cpu_s, status="ok"):
    c = {"video": video, "level": level, "seed": seed, "tracker": tracker, "kind": kind,
         "status": status, "message": "" if status == "ok" else "no camera", "n_frames": 100,
         "cpu_s": cpu_s, "wall_s": cpu_s, "n_detections": 10}
    if status != "failed":
        c.update(HOTA=hota, IDF1=idf1, MOTA=0.5, IDSW=idsw, Frag=3)
    return c


def _result(video, cells):
    r = {"commit": "a" * 40, "dirty": False, "date_utc": "2026-01-01T00:00:00Z",
         "machine": {"cpu_count": 2},
         "part": "report", "levels": ["clean"], "seeds": [0, 1], "videos": [video],
         "trackers": {"pf": {"kind": "pftrack"}, "bytetrack": {"kind": "peer"},
                      "norfair": {"kind": "peer"}},
         "frames": {video: [1, 100]}, "hog_detection_timing": {}, "cells": cells}
    r["summary"] = bod._summarise(cells)
    r["speed"] = bod._speed(cells)
    r["goals"] = bod.judge_goals(r)
    return r


def test_speed_goals_by_whether_a_tracker_reads_images():
    # 100 frames a cell: ByteTrack 0.10 s -> 1 ms a frame
    cells = [_cell(v, "clean", 0, *t) for v in ("pets09", "mot17-09") for t in (
        ("boxes", "pftrack", 0.6, 0.7, 3, 0.08),       # 0.8 ms: faster than ByteTrack
        ("slow-boxes", "pftrack", 0.6, 0.7, 3, 0.12),  # 1.2 ms: slower
        ("colour", "pftrack", 0.6, 0.7, 3, 0.45 if v == "pets09" else 2.0),  # 4.5 ms on PETS
        ("bytetrack", "peer", 0.5, 0.7, 5, 0.10))]
    r = _result("pets09", cells)
    r["trackers"] = {"boxes": {"kind": "pftrack", "image_term": False},
                     "slow-boxes": {"kind": "pftrack", "image_term": False},
                     "colour": {"kind": "pftrack", "image_term": True},
                     "bytetrack": {"kind": "peer"}}
    r["goals"] = bod.judge_goals(r)
    sp = {n: t["speed"] for n, t in r["goals"]["trackers"].items()}
    assert sp["boxes"]["met"] is True and sp["boxes"]["ratio_to_bytetrack"] == pytest.approx(0.8)
    assert sp["slow-boxes"]["met"] is False
    # judged on PETS alone (4.5 ms), not on the whole run (12.25 ms) nor against ByteTrack
    assert sp["colour"]["pets09_cpu_ms_per_frame"] == pytest.approx(4.5)
    assert r["speed"]["colour"]["cpu_ms_per_frame"] == pytest.approx(12.25)
    assert sp["colour"]["met"] is True and sp["colour"]["image_term"] is True
    r["cells"] = [c if c["tracker"] != "colour" or c["video"] != "pets09" else
                  {**c, "cpu_s": 0.55} for c in cells]
    r["speed"] = bod._speed(r["cells"])
    assert bod.judge_goals(r)["trackers"]["colour"]["speed"]["met"] is False  # 5.5 ms
    assert "no slower than ByteTrack" in bod.format_table(r)


def test_which_configurations_read_images():
    from pftrack.workflows.pipeline import load_config
    from pftrack_bench.own_trackers import boxes_only_config, reads_images

    assert reads_images(load_config("people-image")) is True  # a colour model per track
    assert reads_images(boxes_only_config()) is False
    assert reads_images(load_config("people-colour")) is True  # a colour likelihood term
    trackers = bod.default_trackers()
    assert trackers["people-image-boxes"].settings["image_term"] is False
    assert trackers["people-image"].settings["image_term"] is True


def test_goals_against_the_best_peer_per_figure_and_merged_runs():
    a = _result("pets09", [
        _cell("pets09", "clean", s, *t) for s in (0, 1) for t in (
            ("pf", "pftrack", 0.60 + 0.02 * s, 0.70, 3, 0.05),
            ("bytetrack", "peer", 0.50, 0.72, 5, 0.10),   # the best peer's IDF1
            ("norfair", "peer", 0.58, 0.60, 3, 0.20))])   # the best peer's HOTA and IDSW
    s = {x["tracker"]: x for x in a["summary"]}
    assert s["pf"]["HOTA_mean"] == pytest.approx(0.61)
    assert (s["pf"]["HOTA_min"], s["pf"]["HOTA_max"]) == (0.60, 0.62)
    assert s["pf"]["cpu_ms_per_frame"] == pytest.approx(0.5)
    assert s["pf"]["cpu_ratio_to_bytetrack"] == pytest.approx(0.5)
    c = a["goals"]["trackers"]["pf"]["cells"][0]
    assert c["best_peer"] == {"HOTA": 0.58, "IDF1": 0.72, "IDSW": 3}
    assert (c["HOTA_met"], c["IDF1_met"], c["IDSW_met"]) == (True, False, True)
    assert a["goals"]["trackers"]["pf"]["identity_met"] is False
    assert a["goals"]["trackers"]["pf"]["speed"]["met"] is True
    assert a["goals"]["applies"] is False  # 2 seeds, one video, one level
    # a run that failed on one seed: its mean is over the seed that gave tracks, the goal unmet
    b = _result("mot17-09", [
        _cell("mot17-09", "clean", 0, "pf", "pftrack", 0.9, 0.9, 0, 0.05),
        _cell("mot17-09", "clean", 1, "pf", "pftrack", None, None, None, 0.0, "failed"),
        *[_cell("mot17-09", "clean", k, "bytetrack", "peer", 0.5, 0.5, 5, 0.10) for k in (0, 1)],
        *[_cell("mot17-09", "clean", k, "norfair", "peer", 0.5, 0.5, 5, 0.10) for k in (0, 1)]])
    sb = {x["tracker"]: x for x in b["summary"]}
    assert sb["pf"]["failed"] == 1 and sb["pf"]["HOTA_mean"] == 0.9
    assert b["goals"]["trackers"]["pf"]["cells"][0]["met"] is False
    m = bod.merge_results([a, b])
    assert m["videos"] == ["pets09", "mot17-09"] and len(m["cells"]) == 12
    assert {(x["video"], x["tracker"]) for x in m["summary"]} == {
        (v, t) for v in ("pets09", "mot17-09") for t in ("pf", "bytetrack", "norfair")}
    # the whole-run speed sums both runs' runs that gave tracks: pf 0.15 s over 300 frames,
    # ByteTrack 0.4 s over 400
    assert m["speed"]["pf"]["cpu_ms_per_frame"] == pytest.approx(0.5)
    assert m["speed"]["pf"]["ratio_to_bytetrack"] == pytest.approx(0.5)
    with pytest.raises(ValueError, match="a video appears in two runs"):
        bod.merge_results([a, a])
    with pytest.raises(ValueError, match="differ in 'seeds'"):
        bod.merge_results([a, {**b, "seeds": [0]}])
    assert "pf: identity NOT met" in bod.format_table(m)


@needs_pets
def test_hog_detections_are_computed_once_and_keyed_by_the_detector(tmp_path, monkeypatch):
    import pftrack.workflows.track
    from pftrack.workflows.pipeline import load_config

    video = PETS / "vtest.avi"
    a = bod.hog_detections(video, "1:3", tmp_path)
    assert a.shape[1] == 7 and set(np.unique(a[:, 0])) <= {1, 2, 3} and len(a) > 0
    assert np.all(a[:, 6] >= 0.5)  # people-image's detector threshold
    t = bod.hog_timing(video, "1:3", tmp_path)
    assert t["frames"] == 3 and t["cpu_s"] > 0
    files = sorted(p.name for p in tmp_path.iterdir())
    assert len(files) == 2  # the det file and its key and timing

    def no_detector(*args, **kwargs):
        raise AssertionError("the detector ran again")

    monkeypatch.setattr(pftrack.workflows.track, "detect_video", no_detector)
    assert np.array_equal(bod.hog_detections(video, "1:3", tmp_path), a)
    # other detector parameters: another file, computed
    cfg = load_config("people-image")
    cfg["detector"]["params"]["threshold"] = 0.7
    with pytest.raises(AssertionError, match="ran again"):
        bod.hog_detections(video, "1:3", tmp_path, config=cfg)
