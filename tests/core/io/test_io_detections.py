"""Detections from elsewhere: MOTChallenge det.txt read and written, and tracked by
``pftrack run --detections FILE`` and the configuration's ``detections:`` key."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pftrack.contracts.components import Detections
from pftrack.io.data import data_dir
from pftrack.io.detections import detections_to_mot, read_detections, write_detections

PETS = data_dir() / "pets09"
needs_pets = pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")


class _FlatCamera:
    """image_to_ground: pixel (u, v) -> (u / 100, v / 100, 0)."""

    def image_to_ground(self, px):
        px = np.asarray(px, dtype=np.float64)
        return np.column_stack([px[:, 0] / 100, px[:, 1] / 100, np.zeros(len(px))])


def test_read_det_txt_groups_frames_scores_and_ground_points(tmp_path):
    p = tmp_path / "det.txt"
    p.write_text("3,-1,10,20,30,60,0.9,-1,-1,-1\n1,-1,0,0,10,20,0.4\n3,-1,100,20,30,60,-1\n"
                 "# a comment\n\n1,-1,5,5,10,20,0.7,-1,-1,-1\n")
    d = read_detections(p)
    assert sorted(d) == [1, 3]
    assert np.allclose(d[1].scores, [0.4, 0.7])  # the file's order within a frame
    assert np.allclose(d[3].scores, [0.9, 1.0])  # conf -1: score 1
    assert np.allclose(d[3].boxes_xywh_px[1], [100, 20, 30, 60])
    assert d[1].points_world_m is None
    g = read_detections(p, camera=_FlatCamera(), min_score=0.5)
    assert len(g[1].scores) == 1 and np.allclose(g[1].points_world_m, [[0.10, 0.25, 0.0]])
    assert np.allclose(g[3].points_world_m[0], [0.25, 0.80, 0.0])  # foot = bottom centre


def test_write_read_round_trip(tmp_path):
    dets = {2: Detections(np.array([[1.5, 2, 3, 4], [5, 6, 7, 8]]), np.array([0.25, 0.75])),
            4: Detections(np.zeros((0, 4)), np.zeros(0)),
            7: Detections(np.array([[9, 9, 9, 9]]), np.array([0.5]))}
    write_detections(tmp_path / "det.txt", dets)
    back = read_detections(tmp_path / "det.txt")
    assert sorted(back) == [2, 7]
    assert np.allclose(back[2].boxes_xywh_px, dets[2].boxes_xywh_px)
    assert np.allclose(back[7].scores, [0.5])
    rows = detections_to_mot(dets)
    assert rows.shape == (3, 10) and np.all(rows[:, 1] == -1)


def test_bad_files_name_themselves(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.txt"):
        read_detections(tmp_path / "nope.txt")
    bad = tmp_path / "bad.txt"
    bad.write_text("1,-1,10,20,30\n")
    with pytest.raises(ValueError, match=r"bad.txt, line 1"):
        read_detections(bad)
    empty = tmp_path / "empty_box.txt"
    empty.write_text("1,-1,10,20,0,60,0.9\n")
    with pytest.raises(ValueError, match="empty_box.txt: row 1 has an empty box"):
        read_detections(empty)


@needs_pets
def test_run_tracks_a_det_file_from_the_cli_and_from_yaml(tmp_path):
    """Ground-truth boxes of frames 1-40 written as det.txt: tracked in the image plane by
    ``pftrack run people-image --detections`` (the detector is not run) and by a YAML whose
    ``detections:`` is relative to it; both give the same tracks, close to the truth."""
    from pftrack.cli import main
    from pftrack.io.mot import read_mot
    from pftrack.workflows.pipeline import read_ground_truth

    gt = read_ground_truth(PETS / "gt.txt", 1, 40)
    vis = gt[gt[:, 6] == 1]
    det = np.column_stack([vis[:, 0], -np.ones(len(vis)), vis[:, 2:6], np.full(len(vis), 0.9)])
    sub = tmp_path / "cfg"
    sub.mkdir()
    np.savetxt(sub / "det.txt", det, fmt="%g", delimiter=",")
    args = ["run", "people-image", "--video", str(PETS / "vtest.avi"), "--frames", "1:40",
            "--gt", str(PETS / "gt.txt"), "--no-report", "--quiet"]
    assert main([*args, "--detections", str(sub / "det.txt"), "--out", str(tmp_path / "a")]) == 0
    m = json.loads((tmp_path / "a" / "metrics.json").read_text())
    assert m["MOTA"] > 0.7 and m["IDF1"] > 0.7, m
    assert m["detection_s_per_frame"] < 0.01  # no detector ran
    import yaml
    from pftrack.workflows.pipeline import load_config

    cfg = load_config("people-image")
    cfg.pop("_source")
    cfg["detections"] = "det.txt"
    (sub / "mine.yaml").write_text(yaml.safe_dump(cfg))
    args[1] = str(sub / "mine.yaml")
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    a, b = read_mot(tmp_path / "a" / "tracks.txt"), read_mot(tmp_path / "b" / "tracks.txt")
    assert a.shape == b.shape and np.allclose(a, b)


def test_negative_scores_are_kept_and_only_minus_one_means_no_score(tmp_path):
    p = tmp_path / "det.txt"
    p.write_text("1,-1,0,0,10,20,-0.25\n1,-1,5,5,10,20,-1\n1,-1,9,9,10,20,2.5\n")
    assert np.allclose(read_detections(p)[1].scores, [-0.25, 1.0, 2.5])


def test_scores_off_the_probability_scale_are_named_with_the_thresholds_they_meet():
    from pftrack.workflows.pipeline import load_config, score_scale_warning

    cfg = load_config("people-image")
    boxes = np.array([[0, 0, 10, 20], [5, 5, 10, 20], [9, 9, 10, 20], [1, 1, 10, 20]], float)
    off = {1: Detections(boxes, np.array([-1.5, 0.2, 0.7, 3.0]))}
    line = score_scale_warning(cfg, off, "det.txt")
    assert "det.txt" in line and "-1.5 to 3" in line
    assert "tracks.params.min_score = 0.5" in line and "associator.params.high_score = 0.5" in line
    assert "50% of the detections" in line
    inside = {1: Detections(boxes, np.array([0.0, 0.2, 0.7, 1.0]))}
    assert score_scale_warning(cfg, inside, "det.txt") == ""
    # nothing in the configuration reads scores: nothing to say
    bare = {k: v for k, v in cfg.items() if k not in ("tracks", "associator")}
    assert score_scale_warning(bare, off, "det.txt") == ""


@needs_pets
def test_pftrack_run_warns_of_scores_off_the_scale(tmp_path):
    import warnings

    from pftrack.workflows.pipeline import DetectionScoreWarning, run_pipeline

    gt = np.loadtxt(PETS / "gt.txt", delimiter=",")
    gt = gt[gt[:, 0] <= 5]
    rows = np.column_stack([gt[:, 0], -np.ones(len(gt)), gt[:, 2:6], np.full(len(gt), 7.0)])
    det = tmp_path / "det.txt"
    np.savetxt(det, rows, delimiter=",", fmt="%.3f")
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        run_pipeline("people-image", video=PETS / "vtest.avi", frames=(1, 5), detections=det,
                     progress=False, report=False)
    lines = [str(w.message) for w in said if issubclass(w.category, DetectionScoreWarning)]
    assert len(lines) == 1 and str(det) in lines[0] and "from 7 to 7" in lines[0]
