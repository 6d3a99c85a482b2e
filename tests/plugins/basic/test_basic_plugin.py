"""The ``basic`` plugin's Gaussian likelihood, box associators and MOG2 detector (the motion models
are in test_motion_models.py)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from pftrack.contracts.components import DetectionMatch, Detections, Frame, Target
from pftrack.geometry.boxes import iou_matrix
from pftrack.io.data import data_dir
from pftrack_basic.association import (
    GreedyIoUAssociator,
    HungarianIoUAssociator,
    centre_distance,
)
from pftrack_basic.background import BackgroundSubtractionDetector
from pftrack_basic.gaussian import GaussianLikelihood


def _t(box, tid=1, observation_px=None, detection=None):
    return Target(id=tid, state=np.zeros(2), box_xywh_px=np.asarray(box, float),
                  observation_px=observation_px, detection=detection)


# -- Gaussian likelihood -----------------------------------------------------------------------


def test_gaussian_likelihood_values_and_observation_precedence():
    lik = GaussianLikelihood(sigma_px=2.0)
    boxes = np.array([[0.0, 0.0, 10, 10], [3.0, 4.0, 10, 10], [-50, -50, 10, 10]])  # centres
    t = _t([0, 0, 10, 10], observation_px=[5.0, 5.0],
           detection=DetectionMatch(np.array([100.0, 100, 10, 10]), 1.0, 0))
    lik.begin_frame(Frame(1, np.zeros((20, 20, 3), np.uint8)), [t], None)
    ll = lik.log_likelihood(boxes, t)
    # d^2 = 0, 25, 5000 -> -d^2 / (2 * 4)
    assert ll.dtype == np.float64 and np.allclose(ll, [0.0, -25 / 8, -5000 / 8])
    t.observation_px = None  # now the matched detection, centre (105, 105)
    ll = lik.log_likelihood(np.array([[100.0, 100, 10, 10], [103.0, 104, 10, 10]]), t)
    assert np.allclose(ll, [0.0, -25 / 8])


def test_gaussian_likelihood_nearest_detection_and_missing_observation():
    lik = GaussianLikelihood(sigma_px=1.0)
    t = _t([0, 0, 4, 4])
    dets = Detections(np.array([[0.0, 0, 2, 2], [10.0, 0, 2, 2]]), np.array([0.9, 0.5]))
    lik.begin_frame(Frame(1, np.zeros((20, 20, 3), np.uint8)), [t], dets)
    # particle centres 1, 8, 11 on x; detection centres 1 and 11
    ll = lik.log_likelihood(np.array([[0.0, 0, 2, 2], [7.0, 0, 2, 2], [10.0, 0, 2, 2]]), t)
    assert np.allclose(ll, [0.0, -4.5, 0.0])
    lik.begin_frame(Frame(2, np.zeros((20, 20, 3), np.uint8)), [t], None)
    assert np.array_equal(lik.log_likelihood(np.zeros((3, 4)), t), np.zeros(3))
    lik2 = GaussianLikelihood(use_all_detections=False, missing_log_likelihood=-5.0)
    lik2.begin_frame(Frame(1, np.zeros((20, 20, 3), np.uint8)), [t], dets)
    assert np.array_equal(lik2.log_likelihood(np.zeros((2, 4)), t), [-5.0, -5.0])


def test_gaussian_likelihood_rejects_bad_parameters():
    t = _t([0, 0, 4, 4], observation_px=[1.0, 2.0])
    with pytest.raises(ValueError, match="sigma_px"):
        GaussianLikelihood(sigma_px=0.0).log_likelihood(np.zeros((2, 4)), t)
    with pytest.raises(ValueError, match="observation_px"):
        GaussianLikelihood().log_likelihood(np.zeros((2, 4)), _t([0, 0, 1, 1], observation_px=[1]))
    with pytest.raises(ValueError, match=r"\(N, 4\)"):
        GaussianLikelihood().log_likelihood(np.zeros((2, 3)), t)


# -- associators -------------------------------------------------------------------------------


def test_box_iou_and_centre_distance_numbers():
    a = np.array([[0.0, 0, 10, 10], [0.0, 0, 0, 0]])
    b = np.array([[5.0, 0, 10, 10], [0.0, 0, 10, 10], [20.0, 20, 5, 5]])
    iou = iou_matrix(a, b)
    assert iou.shape == (2, 3)
    assert np.allclose(iou[0], [50 / 150, 1.0, 0.0]) and np.all(iou[1] == 0.0)
    assert np.allclose(centre_distance(a[:1], b), [5.0, 0.0, np.hypot(17.5, 17.5)])
    assert iou_matrix(np.zeros((0, 4)), b).shape == (0, 3)


def test_hungarian_is_optimal_where_greedy_is_not():
    # centres on a line: targets at x = 0, 6; detections at x = 5, 12 (costs 5, 12 / 1, 6)
    targets = [_t([-1, -1, 2, 2], 1), _t([5, -1, 2, 2], 2)]
    dets = Detections(np.array([[4.0, -1, 2, 2], [11.0, -1, 2, 2]]), np.ones(2))
    h = HungarianIoUAssociator(metric="distance", max_distance_px=20.0).associate(targets, dets)
    g = GreedyIoUAssociator(metric="distance", max_distance_px=20.0).associate(targets, dets)
    assert h.matches.tolist() == [[0, 0], [1, 1]]  # total 11
    assert sorted(g.matches.tolist()) == [[0, 1], [1, 0]]  # takes the cost-1 pair first: 13
    assert len(h.unmatched_tracks) == len(g.unmatched_detections) == 0


def test_gates_leave_far_pairs_unmatched():
    targets = [_t([0, 0, 10, 10], 1), _t([100, 100, 10, 10], 2), _t([300, 0, 10, 10], 3)]
    dets = Detections(np.array([[1.0, 1, 10, 10], [104.0, 100, 10, 10], [0, 300, 10, 10]]),
                      np.ones(3))
    for cls in (HungarianIoUAssociator, GreedyIoUAssociator):
        a = cls(min_iou=0.5).associate(targets, dets)  # IoUs: 0.68, 0.43 -> only the first
        assert a.matches.tolist() == [[0, 0]]
        assert a.unmatched_tracks.tolist() == [1, 2] and a.unmatched_detections.tolist() == [1, 2]
        a = cls(min_iou=0.4).associate(targets, dets)
        assert sorted(a.matches.tolist()) == [[0, 0], [1, 1]]
        a = cls(metric="distance", max_distance_px=3.0).associate(targets, dets)
        assert a.matches.tolist() == [[0, 0]]  # distance sqrt(2); the second is 4 px away
        assert len(cls().associate([], dets).matches) == 0
        assert cls().associate(targets, Detections.empty()).unmatched_tracks.tolist() == [0, 1, 2]
    with pytest.raises(ValueError, match="metric"):
        HungarianIoUAssociator(metric="cosine").associate(targets, dets)


def test_hungarian_prefers_more_admissible_matches():
    # one target overlaps two detections; the other only the first: both must be matched
    targets = [_t([0, 0, 10, 10], 1), _t([6, 0, 10, 10], 2)]
    dets = Detections(np.array([[5.0, 0, 10, 10], [0.0, 0, 10, 10]]), np.ones(2))
    a = HungarianIoUAssociator(min_iou=0.3).associate(targets, dets)
    assert sorted(a.matches.tolist()) == [[0, 1], [1, 0]]


# -- MOG2 detector -----------------------------------------------------------------------------


def _square_video(n=40, size=(160, 120), start=25):
    rng = np.random.default_rng(0)
    bg = rng.integers(40, 80, (size[1], size[0], 3), dtype=np.uint8)
    frames, boxes = [], []
    for k in range(n):
        img = bg.copy()
        x, y = 10 + 3 * max(k - start, 0), 40
        if k >= start:
            img[y:y + 24, x:x + 16] = (230, 220, 210)
        frames.append(Frame(k + 1, img))
        boxes.append([x, y, 16, 24])
    return frames, np.array(boxes, float), start


def test_mog2_finds_a_moving_square_after_learning_the_background():
    frames, boxes, start = _square_video()
    det = BackgroundSubtractionDetector(min_area_px=50, warmup_frames=2)
    out = [det.detect(f) for f in frames]
    assert len(out[0]) == len(out[1]) == 0  # warm-up
    assert all(len(d) == 0 for d in out[2:start])  # static background: nothing
    for d, b in zip(out[start:], boxes[start:]):
        assert len(d) == 1
        assert iou_matrix(b[None], d.boxes_xywh_px)[0, 0] > 0.8
        assert 0.8 < d.scores[0] <= 1.0
    assert det.frames_seen_ == len(frames)


def test_mog2_stream_state_reset_and_pickle():
    frames, _, _ = _square_video(n=30)
    det = BackgroundSubtractionDetector(min_area_px=50)
    for f in frames[:10]:
        det.detect(f)
    with pytest.raises(ValueError, match="reset"):
        det.detect(Frame(99, np.zeros((50, 60, 3), np.uint8)))
    copy = pickle.loads(pickle.dumps(det))  # OpenCV state is dropped: a new stream
    assert not hasattr(copy, "subtractor_") and copy.get_params() == det.get_params()
    copy.detect(Frame(1, np.zeros((50, 60, 3), np.uint8)))
    det.reset()
    assert not hasattr(det, "subtractor_")
    det.detect(Frame(1, np.zeros((50, 60, 3), np.uint8)))
    with pytest.raises(ValueError, match="uint8"):
        BackgroundSubtractionDetector().detect(Frame(1, np.zeros((50, 60, 3))))


def test_mog2_on_pets09_finds_most_people():
    """Real data: PETS09 S2.L1 frames 51-150 (after 50 frames of learning), 768x576; recall of
    ground-truth people at IoU >= 0.3 (groups merge into one blob, the lamp post splits some)."""
    import cv2

    path = data_dir() / "pets09" / "vtest.avi"
    if not path.is_file():
        pytest.fail(f"real data missing: {path} (set PFTRACK_DATA)")
    gt = np.loadtxt(data_dir() / "pets09" / "gt.txt", delimiter=",")
    cap = cv2.VideoCapture(str(path))
    det = BackgroundSubtractionDetector()
    hits = total = n_det = matched_det = 0
    try:
        for k in range(150):
            ok, img = cap.read()
            assert ok, f"{path}: could not read frame {k}"
            d = det.detect(Frame(k + 1, img))  # video frame k is ground-truth frame k + 1
            if k < 50:
                continue
            g = gt[(gt[:, 0] == k + 1) & (gt[:, 6] > 0), 2:6]
            iou = iou_matrix(g, d.boxes_xywh_px)
            if len(d):
                hits += int(np.sum(iou.max(axis=1) >= 0.3))
                matched_det += int(np.sum(iou.max(axis=0) >= 0.3))
            total += len(g)
            n_det += len(d)
    finally:
        cap.release()
    recall, precision = hits / total, matched_det / n_det
    assert total > 500
    assert recall > 0.6, recall  # measured 0.666
    assert precision > 0.6, precision  # measured 0.67
