"""The run pipeline: configuration loading, the engine a configuration builds with the
``confirmed`` track manager (confirmed births, hidden coasting, duplicate removal, appearance
scores) and a real PETS 2009 run."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pftrack.contracts.components import Detections
from pftrack.io.data import data_dir
from pftrack.io.frames import parse_frames
from pftrack.testing import synthetic_scene
from pftrack.workflows.pipeline import build_engine, load_config

PETS = data_dir() / "pets09"


def _image_cfg(**births) -> dict:
    return {
        "state": "image",
        "observation": {"size_from_box": True},
        "motion": {"type": "constant-acceleration",
                   "params": {"position_noise": 1.5, "velocity_noise": 1.0,
                              "acceleration_noise": 0.3, "max_frames_tracked": 1}},
        "likelihood": {"type": "composite", "params": {"terms": [
            {"likelihood": {"type": "detection", "params": {"phi": 0.0, "sigma": 0.1}},
             "weight": 1.0},
            {"likelihood": {"type": "ncc", "params": {"grid_wh": [4, 8]}}, "weight": 0.05}]}},
        "associator": {"type": "greedy-score", "params": {"max_distance": 1.0}},
        "tracker": {"n_particles": 100, "init_spread": 1.0, "max_misses": 3, "dt": 1.0},
        "births": {"min_score": 0.5, "confirm_hits": 3, "confirm_window": 4, **births},
    }


def _run(engine, scene, dets_by_frame):
    out = {}
    for f in scene.frames:
        for r in engine.step(f, dets_by_frame[f.index]):
            out.setdefault(r.frame, {})[r.id] = r
    return out


def test_load_config_and_frames(tmp_path):
    cfg = load_config("pets09-ground")
    assert cfg["state"] == "world" and cfg["likelihood"]["type"] == "composite"
    assert cfg["_source"].endswith("pets09-ground.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("motion: {type: random-walk}\nlikelihood: ncc\ncolour: red\n")
    with pytest.raises(ValueError, match=r"bad.yaml: colour: unknown key \(known: "):
        load_config(bad)
    (tmp_path / "t.yaml").write_text("motion: x\nlikelihood: y\ntracker: {particles: 3}\n")
    with pytest.raises(ValueError, match="tracker.particles: unknown key"):
        load_config(tmp_path / "t.yaml")
    with pytest.raises(FileNotFoundError, match="presets: .*pets09-ground"):
        load_config("no-such-preset")
    assert parse_frames("401:795") == (401, 795)
    assert parse_frames("5:") == (5, None)
    assert parse_frames("7") == (7, 7)
    with pytest.raises(ValueError, match="--frames"):
        parse_frames("9:3")


def test_session_confirms_births_and_drops_one_frame_detections():
    sc = synthetic_scene(seed=0, n_frames=10)
    dets = {i: sc.detections(i, extra_box=False) for i in sc.boxes_by_frame}
    # a confident false detection seen in frame 2 only: tentative, never confirmed
    d2 = dets[2]
    dets[2] = Detections(np.vstack([d2.boxes_xywh_px, [120, 5, 20, 40]]),
                         np.r_[d2.scores, 0.95])
    engine = build_engine(_image_cfg(), fps=25.0, seed=0)
    out = _run(engine, sc, dets)
    ids_per_frame = {f: sorted(v) for f, v in out.items()}
    # confirmation at frame 3 back-fills frames 1 and 2 with the same ids
    assert ids_per_frame[1] == ids_per_frame[3] == ids_per_frame[10] == [1, 2, 3]
    assert all(len(v) == 3 for v in ids_per_frame.values())
    # the tracks follow their objects: box centres within 3 px of the truth in the last frame
    gt = sc.boxes_by_frame[10]
    est = np.array([out[10][i].box_xywh_px for i in (1, 2, 3)])
    c_gt = gt[:, :2] + gt[:, 2:] / 2
    c_est = est[:, :2] + est[:, 2:] / 2
    d = np.linalg.norm(c_gt[:, None] - c_est[None], axis=2).min(axis=1)
    assert np.all(d < 3.0), d


def test_session_hides_coasting_targets_then_ends_them():
    sc = synthetic_scene(seed=0, n_frames=12)
    dets = {i: sc.detections(i, extra_box=False) for i in sc.boxes_by_frame}
    for i in range(6, 13):  # object 0 (the first detection) disappears from frame 6
        d = dets[i]
        dets[i] = Detections(d.boxes_xywh_px[1:], d.scores[1:])
    engine = build_engine(_image_cfg(hide_after_misses=1), fps=25.0, seed=0)
    out = _run(engine, sc, dets)
    first = min(out[5], key=lambda k: np.linalg.norm(out[5][k].box_xywh_px[:2]
                                                       - sc.boxes_by_frame[5][0, :2]))
    assert first in out[6]  # one miss: still shown
    assert first not in out[7] and first not in out[8]  # coasting: hidden
    assert first not in {t.id for t in engine.targets}  # dead after max_misses = 3
    assert all(len(out[f]) == 2 for f in range(7, 13))


def test_session_removes_the_younger_duplicate_and_scores_appearance():
    sc = synthetic_scene(seed=0, n_frames=6)
    dets = {i: sc.detections(i, extra_box=False) for i in sc.boxes_by_frame}
    cfg = _image_cfg(confirm_hits=1, confirm_window=1, merge_iou=0.5,
                     appearance={"bins": 8, "sigma": 0.1})
    tr = build_engine(cfg, fps=25.0, seed=0)
    f1 = sc.frames[0]
    tr.step(f1, dets[1])
    assert len(tr.targets) == 3
    # a duplicate of object 0, born later
    dup = tr.add_target(f1, box_xywh_px=sc.boxes_by_frame[1][0] + [1, 0, 0, 0])
    out = tr.step(sc.frames[1], dets[2])
    live = {t.id for t in tr.targets}
    assert dup.id not in live and len(live) == 3
    assert dup.id not in {r.id for r in out}
    # every target carries its colour model and, per detection, a similarity in [0, 1] that
    # is highest for its own object
    tr.tracks.before_frame(tr, sc.frames[2], dets[3])
    assert set(tr.tracks.appearance_models_) == {t.id for t in tr.targets}
    for t in tr.targets:
        a = t.appearance_scores
        assert a.shape == (3,) and np.all((a >= 0) & (a <= 1))
        own = int(np.argmin(np.linalg.norm(dets[3].boxes_xywh_px[:, :2] - t.box_xywh_px[:2],
                                           axis=1)))
        assert np.argmax(a) == own


def _world_cfg(**births) -> dict:
    return {
        "state": "world",
        "observation": {"height_m": 1.75, "width_ratio": 0.355},
        "motion": {"type": "constant-acceleration",
                   "params": {"position_noise": 0.001, "velocity_noise": 0.001,
                              "acceleration_noise": 0.001, "max_frames_tracked": 1}},
        "likelihood": {"type": "composite", "params": {"terms": [
            {"likelihood": {"type": "detection", "params": {"floor": 1e-3}}, "weight": 1.0}]}},
        "associator": {"type": "greedy-score", "params": {}},
        "tracker": {"n_particles": 50, "init_spread": 0.001, "max_misses": 10},
        "births": {"confirm_hits": 1, "confirm_window": 1, **births},
    }


@pytest.mark.skipif(not (PETS / "View_001.xml").is_file(), reason="PETS 2009 data not found")
def test_world_duplicates_are_told_by_ground_distance_not_image_overlap():
    """Two people 0.9 m apart, one behind the other: their boxes overlap (IoU > 0.6) yet
    both stay with merge_distance_m; a second track 0.1 m from a person is removed (the
    younger). With image overlap alone (merge_iou) the hidden person would be removed."""
    from pftrack.contracts.components import Frame
    from pftrack.geometry.boxes import iou_matrix
    from pftrack.geometry.formats import load_camera

    cam = load_camera(PETS / "View_001.xml")
    frame0 = Frame(1, np.zeros((576, 768, 3), np.uint8))
    # 0.9 m apart along the camera's line of sight (IoU 0.77 in the image)
    positions = {"front": (-6.0, -6.0), "behind": (-6.0 + 0.9 * np.cos(np.pi / 6),
                                                    -6.0 + 0.9 * np.sin(np.pi / 6)),
                 "duplicate": (-6.05, -5.95)}

    def survivors(**births):
        tr = build_engine(_world_cfg(**births), camera=cam, fps=10.0, seed=0)
        ids = {k: tr.add_target(frame0, np.array(p)).id for k, p in positions.items()}
        boxes = {k: tr._filters[i].target.box_xywh_px for k, i in ids.items()}
        tr.step(Frame(2, frame0.image), Detections.empty())
        live = {t.id for t in tr.targets}
        return {k for k, i in ids.items() if i in live}, boxes

    kept, boxes = survivors(merge_distance_m=0.4)
    assert iou_matrix(boxes["front"], boxes["behind"])[0, 0] > 0.6
    assert kept == {"front", "behind"}
    kept, _ = survivors(merge_iou=0.6)
    assert kept == {"front"}
    with pytest.raises(ValueError, match="merge_distance_m"):
        build_engine(_world_cfg(merge_distance_m=-1.0), camera=cam, fps=10.0, seed=0)


def test_empty_result_writes_an_empty_mot_file(tmp_path):
    from pftrack.io.mot import read_mot
    from pftrack.workflows.pipeline import RunResult, write_outputs

    res = RunResult(np.zeros((0, 10)), {}, {})
    write_outputs(tmp_path, {"name": "x"}, res, {}, None)
    assert (tmp_path / "tracks.txt").read_text() == ""
    assert read_mot(tmp_path / "tracks.txt").shape == (0, 10)


@pytest.mark.slow
def test_pets_run_writes_tracks_metrics_and_report(tmp_path):
    """Train on frames 1-200, track frames 401-460 on the ground plane."""
    from pftrack.io.mot import read_mot
    from pftrack.workflows.pipeline import run_pipeline, train_detector

    cfg = load_config("pets09-ground")
    model = tmp_path / "svm.npz"
    train_detector(PETS / "vtest.avi", PETS / "gt.txt", "1:200", out=model, cfg=cfg,
                   camera=str(PETS / "View_001.xml"), seed=0)
    out = tmp_path / "run"
    res = run_pipeline("pets09-ground", video=PETS / "vtest.avi", camera=PETS / "View_001.xml",
                       out_dir=out, gt=PETS / "gt.txt", frames="401:460", detector_model=model,
                       seed=0, progress=False)
    rows = read_mot(out / "tracks.txt")
    assert rows[:, 0].min() >= 401 and rows[:, 0].max() <= 460
    assert np.all(rows[:, 7:9] != -1) and np.all(rows[:, 9] == 0)  # world columns filled
    m = json.loads((out / "metrics.json").read_text())
    # measured on this slice: MOTA 0.80, IDF1 0.89, median error 0.13 m
    assert m["MOTA"] > 0.7 and m["IDF1"] > 0.7, m
    assert m["median_error_m"] < 0.3
    assert m["tracking_s_per_frame"] > 0 and m["detection_s_per_frame"] > 0
    pngs = sorted(p.name for p in (out / "report").glob("*.png"))
    assert "trajectories_000401.png" in pngs and "overlay_000451.png" in pngs
    assert res.n_frames == 60


@pytest.mark.skipif(not (PETS / "vtest.avi").is_file(), reason="PETS 2009 data not found")
def test_an_unknown_report_writer_stops_the_run_before_it_tracks(tmp_path):
    from pftrack.host import UnknownComponentError
    from pftrack.workflows.pipeline import run_pipeline

    cfg = load_config("pets09-ground")
    cfg["report"] = {"writer": "nope"}
    with pytest.raises(UnknownComponentError, match="no report named 'nope'.*known: .*tracks"):
        run_pipeline(cfg, video=PETS / "vtest.avi", camera=PETS / "View_001.xml",
                     out_dir=tmp_path / "o", frames="401:402", progress=False)
    assert not (tmp_path / "o").exists()
