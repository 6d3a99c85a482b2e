"""The training-free ``hog-people`` detector: tightened boxes, calibrated scores, scale bands
limited by a camera or by its own first detections, found people on real PETS frames; and the
svm detector's warning when a trained model cannot find its own positives."""

from __future__ import annotations

import time
import warnings

import numpy as np
import pytest
from pftrack.host import get_host
from pftrack.io.data import data_dir
from pftrack.workflows.pipeline import iter_frames, load_config, read_ground_truth, train_detector

PETS = data_dir() / "pets09"
needs_pets = pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")


def _recall_precision(det, first, last):
    """Recall and precision at IoU 0.5 (detections on partly hidden, flag-0 people count
    neither way) and the CPU seconds per frame."""
    from pftrack_bench.fresh_video import detector_recall_precision

    gt = read_ground_truth(PETS / "gt.txt", first, last)
    dets = {}
    c0 = time.process_time()
    for frame in iter_frames(PETS / "vtest.avi", first, last):
        dets[frame.index] = det.detect(frame)
    cpu = (time.process_time() - c0) / (last - first + 1)
    rp = detector_recall_precision(gt, dets, 0.0)
    return rp["detector_recall"], rp["detector_precision"], cpu


def test_registered_and_scores_are_calibrated():
    det = get_host().build("detector", {"type": "hog-people", "params": {}})
    # the logistic map: 0.5 at the offset, monotone, inverted by margin_of
    m = np.array([-2.0, 0.0, det.score_offset, 1.0, 3.0])
    s = det.calibrate(m)
    assert s[2] == pytest.approx(0.5)
    assert np.all(np.diff(s) > 0) and np.all((s > 0) & (s < 1))
    assert det.margin_of(0.8) == pytest.approx(
        det.score_offset + det.score_scale * np.log(4.0))
    # the window geometry: the tightened person box inside OpenCV's 64 x 128 window
    _, _, w, h = det._model().box_in_window
    assert 0.7 * 128 < h < 0.76 * 128 and 0.3 < w / h < 0.4
    assert not det.learns


def test_bad_threshold_and_model_name_the_parameter():
    from pftrack.contracts.components import RunContext

    with pytest.raises(ValueError, match=r"'hog-people'\): parameter 'threshold' must be a number "
                       r"in \(0, 1\)"):
        get_host().build("detector", {"type": "hog-people", "params": {"threshold": 1.5}})
    det = get_host().build("detector", {"type": "hog-people", "params": {}})
    with pytest.raises(ValueError, match="hog-people needs no model"):
        det.setup(RunContext(detector_model="x.npz"))


@needs_pets
def test_finds_pets_people_with_and_without_a_camera():
    """Frames 201-230 (not the 1-200 the margin and score map were measured on): recall and
    precision at IoU 0.5 against the visible ground-truth boxes. The camera limits the scales:
    no more bands than the learnt relation, far fewer than the whole pyramid."""
    from pftrack.geometry.formats import load_camera

    host = get_host()
    cam = load_camera(PETS / "View_001.xml")
    with_cam = host.build("detector", {"type": "hog-people", "params": {"camera": cam}})
    r, p, cpu = _recall_precision(with_cam, 201, 230)
    assert r > 0.75 and p > 0.85, (r, p)
    assert cpu < 0.5  # s per frame of CPU (0.08 measured on an idle core of the dev machine)
    no_cam = host.build("detector", {"type": "hog-people", "params": {"learn_scales": 5}})
    r2, p2, _ = _recall_precision(no_cam, 201, 230)
    assert r2 > 0.7 and p2 > 0.85, (r2, p2)
    # after 5 frames the search follows the learnt height-row relation
    assert no_cam.expected_heights_ is not None
    full = host.build("detector", {"type": "hog-people", "params": {"learn_scales": 0}})
    full._prepare((768, 576))
    band_rows = sum(b.top_max - b.top_min for b in with_cam.plan_)
    full_rows = sum(b.top_max - b.top_min for b in full.plan_)
    assert band_rows < 0.6 * full_rows, (band_rows, full_rows)
    # a detection carries its ground point with a camera
    d = with_cam.detect(next(iter_frames(PETS / "vtest.avi", 201, 201)))
    assert d.points_world_m is not None and d.points_world_m.shape == (len(d.scores), 3)
    assert np.all(np.abs(d.points_world_m[:, 2]) < 1e-6)


@needs_pets
def test_threshold_means_probability_of_a_person_box():
    """A higher calibrated threshold keeps fewer, more precise detections."""
    from pftrack.geometry.formats import load_camera

    host = get_host()
    cam = load_camera(PETS / "View_001.xml")
    lo = host.build("detector", {"type": "hog-people", "params": {"threshold": 0.2,
                                                                  "camera": cam}})
    hi = host.build("detector", {"type": "hog-people", "params": {"threshold": 0.8,
                                                                  "camera": cam}})
    r_lo, p_lo, _ = _recall_precision(lo, 201, 215)
    r_hi, p_hi, _ = _recall_precision(hi, 201, 215)
    assert r_lo > r_hi and p_hi > p_lo, (r_lo, p_lo, r_hi, p_hi)
    assert p_hi > 0.9


@needs_pets
def test_svm_trained_on_one_frame_warns(tmp_path):
    """The issue's case: six boxes of one frame; the training accuracy is high but the model
    finds few of its own positives, and says so."""
    from pftrack_world.detector import TrainingRecallWarning

    cfg = load_config("pets09-ground")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        det = train_detector(PETS / "vtest.avi", PETS / "gt.txt", "1:1", out=tmp_path / "m.npz",
                             cfg=cfg, seed=0)
    info = det.describe()["info"]
    assert info["train_recall_positives"] < 0.5 and info["train_accuracy"] > 0.95
    msgs = [str(w.message) for w in caught if issubclass(w.category, TrainingRecallWarning)]
    assert msgs and "own" in msgs[0] and "hog-people" in msgs[0]


def test_local_search_parameters_are_checked():
    for bad, name in (({"full_every": 0}, "full_every"), ({"full_every": 1.5}, "full_every"),
                      ({"partial": {"margin": 0.0}}, "partial.margin"),
                      ({"partial": {"memory": 0}}, "partial.memory"),
                      ({"partial": {"motion_threshold": -1.0}}, "partial.motion_threshold")):
        with pytest.raises(ValueError, match=f"'hog-people'\\): parameter '{name}'"):
            get_host().build("detector", {"type": "hog-people", "params": bad})


def test_roi_crops_keep_the_whole_search_window_grid():
    """A crop's windows sit on the whole strip's stride-8 grid, and the windows of a crop
    not touching its border score exactly as in the whole search."""
    import cv2
    from pftrack_world.detector import _roi_crops
    from pftrack_world.people import default_people_model

    m = default_people_model()
    rng = np.random.default_rng(0)
    small = cv2.GaussianBlur(rng.integers(0, 255, (300, 500), dtype=np.uint8), (5, 5), 2)
    rois = np.array([[100.0, 60.0, 30.0, 90.0], [115.0, 70.0, 30.0, 90.0],
                     [400.0, 100.0, 30.0, 90.0]])
    f = 90.0 / m.box_in_window[3]
    crops = _roi_crops(m, rois, f, 0, 1.0, 1.0, (500, 300), 0.3, 1.5)
    # the two overlapping people share one crop; all corners on the grid; at least a window
    assert len(crops) == 2
    for x0, y0, x1, y1 in crops:
        assert x0 % 8 == 0 and y0 % 8 == 0 and x1 - x0 >= 64 and y1 - y0 >= 128
    hog = cv2.HOGDescriptor()
    hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())
    loc, wt = hog.detect(small, hitThreshold=-10.0, winStride=(8, 8), padding=(0, 0))
    whole = {tuple(p): w for p, w in zip(np.asarray(loc).reshape(-1, 2).tolist(),
                                         np.asarray(wt).ravel(), strict=True)}
    x0, y0, x1, y1 = crops[0]
    lc, wc = hog.detect(small[y0:y1, x0:x1], hitThreshold=-10.0, winStride=(8, 8),
                        padding=(0, 0))
    inner = 0
    for (u, v), w in zip(np.asarray(lc).reshape(-1, 2).tolist(), np.asarray(wc).ravel(),
                         strict=True):
        assert (u + x0, v + y0) in whole  # the same grid
        if 0 < u and 0 < v and u + 64 < x1 - x0 and v + 128 < y1 - y0:
            inner += 1
            assert w == pytest.approx(whole[(u + x0, v + y0)], abs=1e-5)
    assert inner > 0


@needs_pets
def test_local_search_between_whole_searches_finds_the_same_people():
    """``full_every`` 3 on frames 201-260 with the real camera: frames 201, 204, ... are
    searched whole (identical detections), the others only near the people found in the last
    ``roi_memory`` frames: at least 97 % of the whole search's detections found there at the
    same boxes (IoU > 0.95; a crop's border moves a few), at most 1 % that the whole search
    does not have (a window at a crop's border scoring above the threshold); a frame out of
    sequence is searched whole."""
    from pftrack.geometry.boxes import iou_matrix
    from pftrack.geometry.formats import load_camera
    from scipy.optimize import linear_sum_assignment

    host = get_host()
    cam = load_camera(PETS / "View_001.xml")
    whole = host.build("detector", {"type": "hog-people", "params": {"camera": cam}})
    local = host.build("detector", {"type": "hog-people", "params": {"camera": cam,
                                                                     "full_every": 3}})
    n = found = extra = 0
    for frame in iter_frames(PETS / "vtest.avi", 201, 260):
        a, b = whole.detect(frame), local.detect(frame)
        if (frame.index - 201) % 3 == 0:
            assert local.full_index_ == frame.index
            np.testing.assert_array_equal(a.boxes_xywh_px, b.boxes_xywh_px)
            continue
        assert local.full_index_ < frame.index
        n += len(a.scores)
        iou = iou_matrix(a.boxes_xywh_px, b.boxes_xywh_px)
        if iou.size:
            r, c = linear_sum_assignment(-iou)
            found += int((iou[r, c] > 0.95).sum())
            extra += len(b.scores) - int((iou[r, c] >= 0.5).sum())
        else:
            extra += len(b.scores)
    assert n > 200 and found >= 0.97 * n and extra <= 0.01 * n, (n, found, extra)
    # out of sequence (a seek, another video): a whole search
    local.detect(next(iter_frames(PETS / "vtest.avi", 300, 300)))
    assert local.full_index_ == 300


def test_motion_rois_stand_a_person_on_each_changed_region():
    """Between whole searches, a region that changed becomes a person box of the expected
    height at its bottom row (here a learnt relation: height = 0.25 * row), as wide as the
    region; a change below the threshold or too small for a person there gives none."""
    det = get_host().build("detector", {"type": "hog-people",
                                        "params": {"full_every": 2, "learn_scales": 0}})
    w, h = 320, 240
    us, vs = np.meshgrid(np.arange(0, w, 16.0), np.arange(0, h, 16.0))
    det.expected_heights_ = (np.stack([us.ravel(), vs.ravel()], 1), 0.25 * vs.ravel())
    prev = np.full((h // 4, w // 4), 100, np.uint8)
    cur = prev.copy()
    cur[30:40, 20:26] = 140  # a 24 x 40 px region, bottom at row 160
    cur[50:51, 60:61] = 140  # one quarter-size pixel (16 px²): too small at row 200 (H 50)
    cur[20:30, 50:60] = 110  # changed by 10 grey levels only
    r = det._motion_rois(cur, prev, (w, h))
    assert r.shape == (1, 4)
    x, y, bw, bh = r[0]
    # dilated twice by a 3 x 3 kernel: two quarter-size pixels (8 px) on each side
    assert bh == pytest.approx(0.25 * (160 + 8), abs=4) and y + bh == pytest.approx(168, abs=1)
    assert x <= 80 - 8 and x + bw >= 104 + 8
    assert det._motion_rois(prev, prev, (w, h)).shape == (0, 4)


def test_partial_search_settings_are_one_group_and_describe_writes_them_as_json():
    import json

    det = get_host().build("detector", {"type": "hog-people",
                                        "params": {"full_every": 2, "partial": {"memory": 4}}})
    assert (det.partial.memory, det.partial.margin, det.partial.motion_threshold) == \
        (4, 0.3, 15.0)
    info = json.loads(json.dumps(det.describe()))
    assert info["partial"] == {"margin": 0.3, "memory": 4, "motion_threshold": 15.0}
    assert info["full_every"] == 2 and "train" not in info and "score_offset" not in info
    # the calibration and the window box are fixed, not parameters
    assert not {"score_offset", "score_scale", "box_fraction"} & set(det.get_params())
    assert (det.score_offset, det.score_scale) == (0.46, 0.32)
