"""``pftrack bench detectors``' scoring: one-to-one matching with MOT17's removed classes,
recall by box height and at the frame's edge, the precision-matched threshold and the
logistic fit of the calibration."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack_bench import detectors as B


def _rows(frame, boxes, flag=1, cls=1):
    """MOT rows (10 columns: frame, id, box, consider, class, visibility, ...)."""
    b = np.asarray(boxes, float).reshape(-1, 4)
    return np.column_stack([np.full(len(b), frame), np.arange(len(b)), b,
                            np.full(len(b), flag), np.full(len(b), cls), np.ones(len(b)),
                            np.zeros(len(b))])


def test_match_frame_one_to_one_and_removed_boxes():
    counted = np.array([[0, 0, 10, 20], [100, 0, 10, 20]], float)
    det = np.array([[0, 0, 10, 20], [1, 0, 10, 20], [200, 0, 10, 20], [300, 0, 10, 20]], float)
    ignored = np.array([[300, 0, 10, 20]], float)
    hit, state = B.match_frame(det, counted, ignored)
    assert hit.tolist() == [True, False]
    # one hit; the duplicate and the far box are false positives; the ignored one is removed
    assert state.tolist() == [1, 0, 0, -1]


def test_score_by_height_edge_and_mot17_rule():
    W, H = 640, 480
    gt = np.vstack([
        _rows(1, [[10, 10, 20, 50], [200, 100, 40, 150], [0, 200, 30, 90]]),  # counted
        _rows(1, [[400, 100, 40, 120]], cls=7),          # a static person: removed if matched
        _rows(1, [[500, 100, 40, 120]], flag=0),          # consider 0: not counted
    ])
    det = np.array([[10, 10, 20, 50], [0, 200, 30, 90], [400, 100, 40, 120],
                    [500, 300, 40, 120]], float)
    s = B.score(gt, {1: (det, np.array([0.9, 0.8, 0.7, 0.6]))}, "mot17-09", (W, H), 0.5, (1, 1))
    assert s["gt_boxes"] == 3
    assert s["recall"] == pytest.approx(2 / 3)
    # 2 hits, 1 false positive (the box at y 300), the static person's match removed
    assert s["detections"] == 3 and s["precision"] == pytest.approx(2 / 3)
    assert s["recall_by_height"] == {"0-60": 1.0, "60-100": 1.0, "100-200": 0.0,
                                     "200-400": None, "400+": None}
    # the box at x 0 touches the left edge, and is found
    assert s["gt_at_edge"] == 1 and s["recall_at_edge"] == 1.0
    # a score threshold above the second detection's score drops it
    s2 = B.score(gt, {1: (det, np.array([0.9, 0.4, 0.7, 0.6]))}, "mot17-09", (W, H), 0.5,
                 (1, 1))
    assert s2["recall"] == pytest.approx(1 / 3) and s2["recall_at_edge"] == 0.0
    # PETS's rule: the flag-0 row is the one ignored, class is not read
    s3 = B.score(gt, {1: (det, np.full(4, 0.9))}, "pets09", (W, H), 0.5, (1, 1))
    assert s3["gt_boxes"] == 4 and s3["recall"] == pytest.approx(3 / 4)


def test_threshold_for_precision():
    s = np.array([0.9, 0.8, 0.7, 0.6, 0.5])
    y = np.array([1, 1, 0, 1, 0], bool)
    assert B.threshold_for_precision(s, y, 0.75) == pytest.approx(0.6)  # 3 of 4
    assert B.threshold_for_precision(s, y, 1.0) == pytest.approx(0.8)
    assert B.threshold_for_precision(s[2:3], y[2:3], 0.5) is None


def test_fit_logistic_recovers_the_map():
    rng = np.random.default_rng(0)
    z = rng.normal(0.0, 3.0, 20000)
    offset, scale = 0.7, 1.4
    y = rng.random(len(z)) < 1.0 / (1.0 + np.exp(-(z - offset) / scale))
    o, s = B.fit_logistic(z, y)
    assert o == pytest.approx(offset, abs=0.08) and s == pytest.approx(scale, rel=0.06)


def test_bin_names():
    assert B.bin_names() == ["0-60", "60-100", "100-200", "200-400", "400+"]


def test_parse_spec():
    assert B.parse_spec("hog-people") == ("hog-people", {})
    assert B.parse_spec("ssdlite-people:input_height=384, threshold=0.3") == (
        "ssdlite-people", {"input_height": 384, "threshold": 0.3})
    with pytest.raises(ValueError, match="--detector ssdlite-people:576"):
        B.parse_spec("ssdlite-people:576")
