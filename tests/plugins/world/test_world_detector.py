"""The sliding-window SVM detector: model files, scale plans, dense scoring, training, real data."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pftrack.contracts.components import Frame
from pftrack.geometry.boxes import iou_matrix, nms
from pftrack.io.data import data_dir
from pftrack.testing import synthetic_scene
from pftrack_world.detector import (
    ScaleBand,
    SVMDetector,
    SVMModel,
    _dense_windows,
    _hog,
    crop_windows,
    heights_from_boxes,
    load_model,
    merge_clusters,
    save_model,
    scale_plan,
    train_svm_model,
    window_features,
)

PETS = data_dir() / "pets09"


def _random_model(feature: str = "hog", window=(16, 32), seed: int = 0) -> SVMModel:
    rng = np.random.default_rng(seed)
    n = _hog(window).getDescriptorSize() if feature == "hog" else window[0] * window[1]
    w = rng.normal(size=n).astype(np.float32)
    w /= np.linalg.norm(w)
    return SVMModel(w, -0.05, feature, window, (2.0, 3.0, 12.0, 26.0), {"note": "test"})


def test_model_round_trip_and_validation(tmp_path):
    m = _random_model()
    p = save_model(m, tmp_path / "m.npz")
    back = load_model(p)
    np.testing.assert_array_equal(back.weights, m.weights)
    assert (back.bias, back.feature, back.window_wh, back.box_in_window) == \
        (m.bias, m.feature, m.window_wh, m.box_in_window)
    with pytest.raises(FileNotFoundError, match="missing.npz"):
        load_model(tmp_path / "missing.npz")
    (tmp_path / "text.npz").write_text("not a model")
    with pytest.raises(ValueError, match="text.npz.*not an .npz"):
        load_model(tmp_path / "text.npz")
    with pytest.raises(ValueError, match="must end in .npz"):
        save_model(m, tmp_path / "m.pkl")
    # weights that do not fit the parameters, and a foreign format, name the file
    params = m.params()
    np.savez(tmp_path / "short.npz", weights=m.weights[:10], params=np.array(json.dumps(params)))
    with pytest.raises(ValueError, match="short.npz: 10 weights"):
        load_model(tmp_path / "short.npz")
    params["format"] = "something-else"
    np.savez(tmp_path / "other.npz", weights=m.weights, params=np.array(json.dumps(params)))
    with pytest.raises(ValueError, match="other.npz: format"):
        load_model(tmp_path / "other.npz")
    # pickled objects are never loaded
    np.savez(tmp_path / "obj.npz", weights=np.array([object()], dtype=object),
             params=np.array(json.dumps(m.params())))
    with pytest.raises(ValueError, match="obj.npz"):
        load_model(tmp_path / "obj.npz")


def test_scale_plan_follows_the_camera():
    from pftrack.geometry.formats import load_camera

    cam = load_camera(PETS / "View_001.xml")
    bands = scale_plan(76.8, 96, 86.4, (768, 576), scale_step=1.15, min_height_px=48,
                       max_height_px=400, camera=cam)
    fs = np.array([b.f for b in bands])
    assert np.all(np.diff(fs) > 0)
    np.testing.assert_allclose(fs[1:] / fs[:-1], 1.15)
    assert fs[0] * 76.8 == pytest.approx(48.0)
    # larger scales scan lower rows (people nearer the camera stand lower in the picture)
    tops = np.array([b.top_min for b in bands])
    assert tops[-1] > tops[0] + 150
    # without a camera: a plain pyramid over the whole height range
    plain = scale_plan(76.8, 96, 86.4, (768, 576), min_height_px=48, max_height_px=150)
    assert [b.top_min for b in plain] == [0] * len(plain)
    assert len(plain) == int(np.floor(np.log(150 / 48) / np.log(1.15))) + 1
    with pytest.raises(ValueError, match="scale_step"):
        scale_plan(76.8, 96, 86.4, (768, 576), scale_step=1.0)


def test_heights_learnt_from_boxes_match_the_camera_on_pets():
    """The affine foot -> height law fitted to PETS ground-truth boxes (frames 1-400) predicts
    the camera's expected heights, and the scale plan it gives scans the same bands."""
    from pftrack.geometry.formats import load_camera
    from pftrack.workflows.pipeline import read_ground_truth
    from pftrack_world.detector import expected_heights_px

    # exact on boxes that follow an affine law; NaN above the "horizon" (h <= 0)
    u, v = np.meshgrid(np.arange(0, 640, 40.0), np.arange(0, 480, 40.0))
    h = 0.4 * v.ravel() - 0.05 * u.ravel() - 20.0
    keep = h > 5
    boxes = np.stack([u.ravel() - 0.2 * h, v.ravel() - h, 0.4 * h, h], axis=1)[keep]
    feet, heights = heights_from_boxes(boxes, (640, 480), step_px=16)
    ok = np.isfinite(heights)
    np.testing.assert_allclose(heights[ok], 0.4 * feet[ok, 1] - 0.05 * feet[ok, 0] - 20.0,
                               atol=1e-9)
    assert not np.isfinite(heights[feet[:, 1] == 0]).any()
    with pytest.raises(ValueError, match="at least 3"):
        heights_from_boxes(boxes[:2], (640, 480))
    if not (PETS / "gt.txt").is_file():
        pytest.skip("PETS 2009 data not found")
    gt = read_ground_truth(PETS / "gt.txt", 1, 400)
    feet, learnt = heights_from_boxes(gt[gt[:, 6] == 1, 2:6], (768, 576))
    cam = load_camera(PETS / "View_001.xml")
    _, camera = expected_heights_px(cam, 1.75, (768, 576))
    both = np.isfinite(learnt) & np.isfinite(camera) & (feet[:, 1] >= 250)  # the walkway rows
    # measured: median relative difference 0.014
    assert np.median(np.abs(learnt[both] / camera[both] - 1)) < 0.05
    plan_cam = scale_plan(76.8, 96, 86.4, (768, 576), min_height_px=48, camera=cam)
    plan_box = scale_plan(76.8, 96, 86.4, (768, 576), min_height_px=48,
                          expected=(feet, learnt))
    assert plan_box[0].f == pytest.approx(plan_cam[0].f)
    # the same ten scales; each scans about the same rows as the camera's (measured: band
    # ends within 32 px)
    assert len(plan_box) == len(plan_cam) == 10
    for b, c in zip(plan_box, plan_cam):
        assert b.f == pytest.approx(c.f)
        assert abs(b.top_min - c.top_min) <= 40 and abs(b.top_max - c.top_max) <= 40


def test_nms_and_merge():
    boxes = np.array([[0, 0, 10, 20], [1, 0, 10, 20], [30, 0, 10, 20]], dtype=float)
    scores = np.array([0.5, 0.9, 0.7])
    keep = nms(boxes, scores, 0.3)
    assert keep.tolist() == [1, 2]
    merged = merge_clusters(boxes, scores, keep, tau=0.1)
    w = np.exp((0.5 - 0.9) / 0.1)
    assert merged[0, 0] == pytest.approx((1.0 + w * 0.0) / (1 + w))
    np.testing.assert_allclose(merged[1], boxes[2])
    assert iou_matrix(boxes[:1], boxes[1:2])[0, 0] == pytest.approx(180 / 220)


@pytest.mark.parametrize("feature", ["grey", "hog"])
def test_dense_scores_equal_per_window_scores(feature):
    import cv2

    rng = np.random.default_rng(1)
    grey = cv2.GaussianBlur((rng.random((80, 96)) * 255).astype(np.uint8), (0, 0), 1.5)
    grey[20:60, 30:50] = 30
    model = _random_model(feature)
    boxes, scores = _dense_windows(model, grey, [ScaleBand(1.0, 0, 48)], -np.inf,
                                   _hog_for(model))
    assert len(boxes) > 5
    bl, bt = model.box_in_window[:2]
    wins = np.stack([boxes[:, 0] - bl, boxes[:, 1] - bt,
                     np.full(len(boxes), 16.0), np.full(len(boxes), 32.0)], axis=1)
    crops = crop_windows(grey, wins, (16, 32))
    direct = window_features(crops, feature) @ model.weights + model.bias
    if feature == "grey":
        np.testing.assert_allclose(scores, direct, atol=1e-4)
    else:
        # a crop's border gradients see replicated pixels, the whole image their neighbours
        assert np.corrcoef(scores, direct)[0, 1] > 0.98
        assert np.max(np.abs(scores - direct)) < 0.05


def _hog_for(model: SVMModel):
    if model.feature != "hog":
        return None
    hog = _hog(model.window_wh)
    hog.setSVMDetector(np.r_[model.weights, np.float32(model.bias)].astype(np.float32))
    return hog


def test_fit_is_seeded_and_finds_the_objects():
    sc = synthetic_scene(seed=2, n_frames=20)
    kw = {"window_wh": (16, 32), "n_negatives": 400}
    a = train_svm_model(sc.frames, sc.boxes_by_frame, np.random.default_rng(0), **kw)
    b = train_svm_model(sc.frames, sc.boxes_by_frame, np.random.default_rng(0), **kw)
    c = train_svm_model(sc.frames, sc.boxes_by_frame, np.random.default_rng(1), **kw)
    np.testing.assert_array_equal(a.weights, b.weights)
    assert not np.array_equal(a.weights, c.weights)
    assert a.info["n_positive"] == 2 * 3 * 20  # every box and its mirror image
    # no camera: hard negatives mined over the scales the training boxes show
    assert a.info["mining_scales"] == "training boxes"
    assert np.linalg.norm(a.weights) == pytest.approx(1.0, rel=1e-5)
    det = SVMDetector(min_height_px=25, max_height_px=60, scale_step=1.1, train=kw)
    det.fit(sc.frames, sc.boxes_by_frame, rng=np.random.default_rng(0))
    test = synthetic_scene(seed=5, n_frames=3)
    hits = 0
    for f in test.frames:
        d = det.detect(f)
        iou = iou_matrix(test.boxes_by_frame[f.index], d.boxes_xywh_px)
        hits += int((iou.max(axis=1) >= 0.5).sum()) if iou.size else 0
    assert hits >= 7  # of 9 objects (measured: 8)
    # no boxes and no model: a clear error; with a model, fit keeps it
    with pytest.raises(ValueError, match="no ground-truth boxes"):
        SVMDetector().fit(test.frames, {}, rng=np.random.default_rng(0))
    model = det.model_
    assert det.fit(test.frames, {}, rng=np.random.default_rng(0)).model_ is model


def test_detect_without_a_model_names_the_fix():
    with pytest.raises(ValueError, match="pftrack detector"):
        SVMDetector().detect(Frame(1, np.zeros((64, 64, 3), np.uint8)))


@pytest.mark.slow
def test_trained_on_pets_detects_people_in_unseen_frames(tmp_path):
    """Train on 120 PETS frames (HOG, 32 x 64 windows), detect on frames 401-440."""
    from pftrack.workflows.pipeline import iter_frames, read_ground_truth, train_detector

    cfg = {"detector": {"type": "svm", "params": {"min_height_px": 48},
                        "train": {"params": {"window_wh": [32, 64], "C": 0.01}}}}
    det = train_detector(PETS / "vtest.avi", PETS / "gt.txt", "1:120", out=tmp_path / "m.npz",
                         cfg=cfg, camera=str(PETS / "View_001.xml"), seed=0)
    assert load_model(tmp_path / "m.npz").info["n_positive"] > 1000
    gt = read_ground_truth(PETS / "gt.txt", 401, 440)
    gt = gt[gt[:, 6] == 1]
    tp = fp = fn = 0
    for f in iter_frames(PETS / "vtest.avi", 401, 440):
        d = det.detect(f)
        assert d.points_world_m is not None and d.points_world_m.shape == (len(d), 3)
        g = gt[gt[:, 0] == f.index, 2:6]
        iou = iou_matrix(g, d.boxes_xywh_px)
        from scipy.optimize import linear_sum_assignment

        m = 0
        if iou.size:
            r, c = linear_sum_assignment(-iou)
            m = int((iou[r, c] >= 0.5).sum())
        tp, fp, fn = tp + m, fp + len(d) - m, fn + len(g) - m
    recall, precision = tp / (tp + fn), tp / max(tp + fp, 1)
    # measured: recall 0.94, precision 0.77 (seed 0)
    assert recall > 0.8 and precision > 0.65, (recall, precision)


def test_training_settings_are_the_train_group_wherever_the_configuration_gives_them():
    """``detector.train.params`` (and ``pftrack detector train``'s options) fill the svm's
    ``train`` group, over ``detector.params.train``; a detector without such a group takes
    them as its own parameters."""
    from pftrack.host.config import ConfigError, training_params, validate_config
    from pftrack.workflows.pipeline import load_config

    merged = training_params("svm", {"threshold": 0.5, "train": {"C": 0.1, "n_negatives": 50}},
                             {"C": 0.003, "feature": "grey"})
    assert merged == {"threshold": 0.5,
                      "train": {"C": 0.003, "n_negatives": 50, "feature": "grey"}}
    det = SVMDetector(**merged)
    assert (det.train.C, det.train.n_negatives, det.train.feature, det.train.window_wh) == \
        (0.003, 50, "grey", (32, 64))
    assert training_params("eigenspace", {"block_size": 8}, {"min_samples": 3}) == \
        {"block_size": 8, "min_samples": 3}
    # the shipped preset trains with its training settings in the group
    cfg = load_config("pets09-ground")
    tp = cfg["detector"]["train"]["params"]
    built = SVMDetector(**training_params("svm", cfg["detector"]["params"], tp))
    assert (built.train.C, tuple(built.train.window_wh)) == (0.003, (48, 96))
    # a configuration's mistakes are named by their dotted key and the component
    cfg["detector"]["train"]["params"] = {"C": 0, "window": [48, 96]}
    cfg["detector"]["params"]["train"] = {"n_negatives": -1}
    with pytest.raises(ConfigError) as info:
        validate_config(cfg, "pets.yaml")
    text = str(info.value)
    assert "detector.params.train.n_negatives: detector 'svm' expects an integer >= 0 for " \
           "train.n_negatives, got -1" in text
    assert "detector.train.params.C: detector 'svm' expects a number > 0 for train.C, got 0" \
        in text
    assert "detector.train.params.window: unknown parameter train.window of detector 'svm'" \
        in text and "did you mean 'window_wh'?" in text
