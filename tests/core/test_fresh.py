"""``pftrack track VIDEO``: one command from a video to tracks (pftrack.workflows.track), the
image-plane fallback said aloud, and the reasons a run gives when nothing came out."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pftrack.contracts.components import Detections
from pftrack.io.data import data_dir
from pftrack.workflows.pipeline import load_config
from pftrack.workflows.track import check_thresholds, explain_no_tracks, track_video

PETS = data_dir() / "pets09"
needs_pets = pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")
NO_ROWS = np.zeros((0, 10))


def test_ground_truth_in_the_camera_frame_is_its_feet_on_that_cameras_ground():
    from pftrack.geometry.boxes import foot_points
    from pftrack.geometry.camera import Camera
    from pftrack.workflows.pipeline import ground_truth_in_camera_frame

    cam = Camera.look_at((0.0, -10.0, 6.0), (0.0, 5.0, 0.0), (640, 480), fx=800.0)
    feet = cam.project(np.array([[1.0, 3.0, 0.0], [-2.0, 8.0, 0.0]]))
    boxes = np.c_[feet[:, 0] - 10, feet[:, 1] - 60, np.full(2, 20.0), np.full(2, 60.0)]
    # a third box whose foot point lies above the horizon: no ground under it
    boxes = np.vstack([boxes, [300.0, -400.0, 20.0, 60.0]])
    gt = np.c_[[5, 5, 6], [1, 2, 3], boxes, np.ones(3), np.full((3, 3), 99.0)]
    out = ground_truth_in_camera_frame(gt, cam)
    np.testing.assert_allclose(foot_points(out[:, 2:6])[:2], feet, atol=1e-9)  # boxes kept
    np.testing.assert_allclose(out[:2, 7:10], [[1.0, 3.0, 0.0], [-2.0, 8.0, 0.0]], atol=1e-6)
    np.testing.assert_array_equal(out[2, 7:10], [-1.0, -1.0, -1.0])
    np.testing.assert_array_equal(gt[:, 7:10], 99.0)  # the caller's rows untouched


def _dets(*scores):
    return {1: Detections(np.tile([10.0, 10, 20, 60], (len(scores), 1)), np.array(scores))}


def test_explain_no_tracks_names_the_parameter():
    cfg = load_config("people-ground")
    assert explain_no_tracks(cfg, np.ones((1, 10)), _dets(0.9), 10) == []
    msg = explain_no_tracks(cfg, NO_ROWS, {1: Detections.empty()}, 10)
    assert len(msg) == 1 and "found nothing in 10 frames" in msg[0]
    assert "detector.params.threshold (now 0.5)" in msg[0]
    msg = explain_no_tracks(cfg, NO_ROWS, _dets(0.3, 0.45), 10)
    assert "tracks.params.min_score = 0.5" in msg[0] and "best of 2 scored 0.45" in msg[0]
    msg = explain_no_tracks(cfg, NO_ROWS, _dets(0.9, 0.8), 10)
    assert "2 detections scored" in msg[0] and "confirm_hits = 3" in msg[0]
    assert "no frame was read" in explain_no_tracks(cfg, NO_ROWS, {}, 0)[-1]


def test_a_threshold_that_can_never_start_a_track():
    cfg = load_config("people-ground")
    assert check_thresholds(cfg) == []
    cfg["tracks"]["params"]["min_score"] = 1.2
    cfg["detector"]["params"]["threshold"] = 1.5
    msgs = check_thresholds(cfg)
    assert len(msgs) == 2
    assert "tracks.params.min_score = 1.2" in msgs[0] and "no track can ever start" in msgs[0]
    assert "detector.params.threshold = 1.5 is outside (0, 1)" in msgs[1]


@needs_pets
def test_run_without_tracks_says_why(tmp_path, capsys):
    from pftrack.cli import main

    det = tmp_path / "det.txt"
    det.write_text("1,-1,100,100,30,90,0.3\n2,-1,102,100,30,90,0.3\n")
    assert main(["run", "people-image", "--video", str(PETS / "vtest.avi"), "--frames", "1:5",
                 "--detections", str(det), "--out", str(tmp_path / "o"), "--no-report",
                 "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "no detection reached tracks.params.min_score = 0.5" in err
    assert (tmp_path / "o" / "tracks.txt").read_text() == ""


@needs_pets
def test_track_command_on_a_pets_slice(tmp_path, capsys):
    """Frames 201-260: hog-people, a camera estimated from the people, people-ground; tracks,
    report, summary and the camera written; scored against the ground truth for the test."""
    from pftrack.cli import main
    from pftrack.geometry.formats import load_camera
    from pftrack.io.mot import read_mot

    out = tmp_path / "out"
    assert main(["track", str(PETS / "vtest.avi"), "--out", str(out), "--frames", "201:260",
                 "--gt", str(PETS / "gt.txt"), "--quiet"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["preset"] == "people-ground" and s["camera"].startswith("estimated from")
    assert s["frames"] == 60 and 3 <= s["tracks"] <= 20
    fit = s["camera_fit"]
    assert 4.0 < fit["camera_height_m"] < 12.0  # the real camera is 6.7 m... up to the 1.7 m
    rows = read_mot(out / "tracks.txt")
    assert rows[:, 0].min() >= 201 and rows[:, 0].max() <= 260
    assert s["metrics"]["MOTA"] > 0.4 and s["metrics"]["IDF1"] > 0.4, s["metrics"]
    assert load_camera(out / "camera.yaml").image_size == (768, 576)
    # the ground truth carried into the estimated camera's frame: ground errors of the tracking
    # (tens of metres when the ground truth's own frame was compared with the camera's)
    m = json.loads((out / "metrics.json").read_text())
    assert m["n_world_pairs"] > 100 and m["median_error_m"] < 0.5, m["median_error_m"]
    assert sum("its world frame is its own" in x for x in s["messages"]) == 1
    assert sorted(p.suffix for p in (out / "report").iterdir()) and \
        all(p.suffix == ".png" for p in (out / "report").iterdir())
    # frames per second of the work for the frames; writing the outputs (the report's images)
    # is a cost per run, given apart, and the whole run's time includes it
    assert 0 < s["outputs_cpu_s"] < s["cpu_seconds"]
    assert s["frames_per_second_cpu"] == pytest.approx(
        60 / (s["cpu_seconds"] - s["outputs_cpu_s"]))
    assert s["frames_per_second"] == pytest.approx(60 / (s["seconds"] - s["outputs_s"]))


@needs_pets
def test_too_few_people_falls_back_to_the_image_plane(tmp_path):
    det = tmp_path / "det.txt"
    det.write_text("".join(f"{f},-1,{100 + 2 * f},100,30,90,0.9\n" for f in range(1, 11)))
    res = track_video(PETS / "vtest.avi", tmp_path / "o", detections=det, frames="1:10",
                      report=False)
    assert res.summary["preset"] == "people-image" and res.summary["state"] == "image"
    assert res.summary["camera"].startswith("none: only 10 person boxes")
    assert any(m.startswith("no camera: only 10 person boxes") and "no ground positions" in m
               for m in res.messages)
    assert res.summary["tracks"] == 1


@needs_pets
def test_an_earlier_camera_does_not_stay_beside_image_plane_tracks(tmp_path):
    det = tmp_path / "det.txt"
    det.write_text("".join(f"{f},-1,{100 + 2 * f},100,30,90,0.9\n" for f in range(1, 11)))
    out = tmp_path / "o"
    out.mkdir()
    (out / "camera.yaml").write_text("an earlier run's estimate\n")
    res = track_video(PETS / "vtest.avi", out, detections=det, frames="1:10", report=False)
    assert res.summary["state"] == "image" and "camera_file" not in res.summary
    assert not (out / "camera.yaml").exists()


@needs_pets
def test_track_checks_its_outputs_before_detecting(tmp_path, monkeypatch):
    import pftrack.workflows.track as fresh

    def no_detection(*a, **k):
        raise AssertionError("the detector ran before --out was checked")

    monkeypatch.setattr(fresh, "detect_video", no_detection)
    out = tmp_path / "o"
    (out / "summary.json").mkdir(parents=True)
    with pytest.raises(IsADirectoryError, match="summary.json is a folder"):
        track_video(PETS / "vtest.avi", out, frames="1:10", report=False)
    with pytest.raises(FileNotFoundError, match="--gt .*none.txt not found"):
        track_video(PETS / "vtest.avi", tmp_path / "p", gt=tmp_path / "none.txt")


@needs_pets
def test_pitch_blob_takes_the_run_camera_file(tmp_path):
    """``pftrack run soccer-ground --camera calib/soccer_camera.yaml`` stopped
    with ``TypeError: expected str ... not Camera`` in pitch-blob; the run's camera object is
    used as is (on any video: the camera is resized to its frames)."""
    from pathlib import Path

    from pftrack.cli import main

    cam = Path(__file__).resolve().parents[2] / "calib" / "soccer_camera.yaml"
    assert main(["run", "soccer-ground", "--video", str(PETS / "vtest.avi"), "--camera",
                 str(cam), "--frames", "1:3", "--out", str(tmp_path / "s"), "--no-report",
                 "--quiet"]) == 0
    assert (tmp_path / "s" / "tracks.txt").is_file()


@needs_pets
@pytest.mark.parametrize("people_fit", [True, False])
def test_run_with_a_camera_made_from_people_carries_the_ground_truth(people_fit, recwarn):
    """``pftrack run --gt`` (the two-step path): with a camera written by ``calib people`` the
    ground truth's world columns are taken into its frame, and the run says so; with any other
    camera (here PETS's own, whose frame is the ground truth's) they are used as they are."""
    from pftrack.geometry.formats import load_camera
    from pftrack.workflows.pipeline import GroundTruthFrameWarning, read_ground_truth, run_pipeline

    cam = load_camera(PETS / "View_001.xml")
    if people_fit:
        cam.metadata["people_fit"] = {"camera_height_m": 7.0}
    gt = read_ground_truth(PETS / "gt.txt", 201, 203)
    dets = {f: Detections(gt[gt[:, 0] == f, 2:6], np.full(int((gt[:, 0] == f).sum()), 0.9))
            for f in (201, 202, 203)}
    cfg = load_config("people-ground")
    cfg["tracks"]["params"]["confirm_hits"] = 1
    cfg["tracks"]["params"]["confirm_window"] = 1
    r = run_pipeline(cfg, video=PETS / "vtest.avi", camera=cam, gt=PETS / "gt.txt",
                     frames="201:203", detections=dets, progress=False, report=False)
    said = [w for w in recwarn if issubclass(w.category, GroundTruthFrameWarning)]
    assert len(said) == int(people_fit)
    assert r.metrics["n_world_pairs"] > 10
    # both compare like with like: the tracks (started on the ground-truth boxes) against the
    # truth's feet through this camera, or against its surveyed positions in the camera's frame
    assert r.metrics["median_error_m"] < 0.5


@needs_pets
def test_a_thing_that_never_moves_is_left_out_and_listed(tmp_path):
    """A box over a fixed patch of PETS's background (the building, top left) for 12 s, and
    a person walking: the box is a static thing, listed in the summary and left out of
    tracks.txt and the metrics unless kept."""
    from pftrack.io.mot import read_mot

    lines = []
    for f in range(1, 121):
        lines.append(f"{f},-1,20,20,30,90,0.9\n")
        lines.append(f"{f},-1,{150 + 3 * f},300,30,90,0.9\n")
    det = tmp_path / "det.txt"
    det.write_text("".join(lines))
    runs = {}
    for keep in (False, True):
        out = tmp_path / f"o{keep}"
        res = track_video(PETS / "vtest.avi", out, detections=det, frames="1:120",
                          report=False, preset="people-image", keep_static=keep)
        s = json.loads((out / "summary.json").read_text())
        assert len(s["static_tracks"]) == 1 and s["static_tracks_reported"] is keep
        t = s["static_tracks"][0]
        assert t["seconds"] >= 10.0 and t["shift_heights"] <= 0.1 and t["similarity"] >= 0.9
        runs[keep] = (t["id"], read_mot(out / "tracks.txt"), res)
    sid, rows, res = runs[False]
    assert sid not in rows[:, 1] and len(np.unique(rows[:, 1])) == 1  # the walker only
    assert any("static things" in m and "--keep-static" in m for m in res.messages)
    sid, rows, _ = runs[True]
    assert sid in rows[:, 1] and len(np.unique(rows[:, 1])) == 2


@needs_pets
def test_given_scores_off_the_probability_scale_are_said(tmp_path):
    det = tmp_path / "det.txt"
    det.write_text("".join(f"{f},-1,{100 + 2 * f},100,30,90,{40 + f}\n" for f in range(1, 11)))
    res = track_video(PETS / "vtest.avi", tmp_path / "o", detections=det, frames="1:10",
                      report=False)
    said = [m for m in res.messages if "not 0-1" in m]
    assert len(said) == 1 and str(det) in said[0] and "from 41 to 50" in said[0]
    assert "tracks.params.min_score = 0.5" in said[0]
    assert res.summary["tracks"] == 1  # tracked all the same
