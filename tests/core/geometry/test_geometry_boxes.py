"""pftrack.geometry.boxes (the one home of box primitives) and pftrack.io.images (the one PNG
writer)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from pftrack.geometry.boxes import (
    box_iou,
    clip_boxes,
    covered_fraction,
    foot_points,
    iou_matrix,
    nms,
    sub_boxes,
)
from pftrack.io.images import figure_png, png_bytes, write_png


def test_box_iou_numbers_broadcast_and_degenerate_boxes():
    a = np.array([0.0, 0.0, 10.0, 10.0])
    assert box_iou(a, [5.0, 0.0, 10.0, 10.0]) == pytest.approx(50 / 150)
    # integer boxes meeting exactly at 0.5 stay exactly 0.5 (TrackEval's arithmetic)
    assert box_iou([0, 0, 4, 4], [0, 0, 4, 2]) == 0.5
    assert box_iou(a, [20.0, 20.0, 5.0, 5.0]) == 0.0
    assert box_iou(a, [0.0, 0.0, 0.0, 0.0]) == 0.0
    assert box_iou(a, [0.0, 0.0, -3.0, 10.0]) == 0.0
    assert box_iou(a, [np.nan, 0.0, 10.0, 10.0]) == 0.0
    b = np.array([[0.0, 0, 10, 10], [5.0, 5, 10, 10], [100.0, 0, 1, 1]])
    m = iou_matrix(b, b)
    assert m.shape == (3, 3) and np.allclose(np.diag(m), 1.0) and np.allclose(m, m.T)
    assert m[0, 1] == pytest.approx(25 / 175)
    np.testing.assert_array_equal(m, box_iou(b[:, None, :], b[None, :, :]))
    assert iou_matrix(np.zeros((0, 4)), b).shape == (0, 3)


def test_nms_keeps_the_best_of_each_overlapping_group():
    boxes = np.array([[0.0, 0, 10, 20], [1.0, 1, 10, 20], [50.0, 0, 10, 20], [51.0, 0, 10, 20]])
    scores = np.array([-0.5, 0.2, -1.0, -0.9])
    keep = nms(boxes, scores, 0.5)
    assert keep.tolist() == [1, 3]
    assert nms(np.zeros((0, 4)), np.zeros(0), 0.5).shape == (0,)


def test_nms_keeps_a_lone_box_and_the_lowest_scoring_separate_one():
    one = np.array([[10.0, 10, 20, 40]])
    for s in (-2.0, 0.0, 0.7):
        assert nms(one, np.array([s]), 0.5).tolist() == [0]
    # three separate boxes: all kept, best first, the lowest-scoring one too
    boxes = np.array([[0.0, 0, 10, 20], [50.0, 0, 10, 20], [100.0, 0, 10, 20]])
    assert nms(boxes, np.array([0.3, -4.0, 0.9]), 0.5).tolist() == [2, 0, 1]
    # equal scores: none is below the others, all separate boxes kept
    assert sorted(nms(boxes, np.zeros(3), 0.5).tolist()) == [0, 1, 2]


def test_sub_boxes_foot_points_and_clipping():
    b = np.array([[10.0, 20.0, 40.0, 100.0]])
    np.testing.assert_allclose(sub_boxes(b, (0.25, 0.1, 0.75, 0.5)), [[20.0, 30.0, 20.0, 40.0]])
    whole = sub_boxes(b, None)
    whole[0, 0] = -1.0
    assert b[0, 0] == 10.0  # a new array, never a view of the input
    np.testing.assert_array_equal(foot_points(b), [[30.0, 120.0]])
    assert foot_points(np.zeros((2, 3, 4))).shape == (2, 3, 2)
    c, n = clip_boxes(np.array([[-5, -5, 10, 10], [90, 10, 120, 20], [200, 0, 210, 5]]),
                      (100, 50))
    assert c.tolist() == [[0, 0, 10, 10], [90, 10, 100, 20], [100, 0, 100, 5]]
    assert n.tolist() == [100, 100, 0]


def test_png_bytes_and_write_png_round_trip(tmp_path):
    img = np.random.default_rng(0).integers(0, 256, (12, 17, 3), dtype=np.uint8)
    data = png_bytes(img)
    np.testing.assert_array_equal(cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR),
                                  img)
    out = write_png(tmp_path / "a.png", img[:, ::-1])  # a non-contiguous view is fine
    np.testing.assert_array_equal(cv2.imread(str(out)), img[:, ::-1])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png"]  # no temporary left
    with pytest.raises(ValueError, match=r"b\.jpg: the output must be a \.png file"):
        write_png(tmp_path / "b.jpg", img)
    with pytest.raises(ValueError, match=r"c\.png: .*shape \(2, 2, 7\)"):
        write_png(tmp_path / "c.png", np.zeros((2, 2, 7), np.uint8))
    assert not (tmp_path / "c.png").exists()


def test_figure_png_closes_the_figure():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(2, 1))
    ax.plot([0, 1], [0, 1])
    data = figure_png(fig, dpi=50)
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    assert img.shape == (50, 100, 3)
    assert not plt.fignum_exists(fig.number)


def test_covered_fraction_is_the_intersection_over_the_first_boxs_area():
    a = np.array([0.0, 0.0, 40.0, 100.0])
    # 30 of its 40 px width under b, its whole height: three quarters
    assert covered_fraction(a, np.array([10.0, -10.0, 40.0, 200.0])) == 0.75
    # not symmetric: b (a larger box) is covered by a over 3000 of its 8000 px^2
    assert covered_fraction(np.array([10.0, -10.0, 40.0, 200.0]), a) == 3000.0 / 8000.0
    # broadcast (2, 1, 4) x (1, 3, 4): apart, inside, the same box
    aa = np.array([a, [100.0, 0.0, 10.0, 10.0]])[:, None]
    bb = np.array([[500.0, 0.0, 5.0, 5.0], [-5.0, -5.0, 60.0, 200.0], a])[None]
    np.testing.assert_array_equal(covered_fraction(aa, bb), [[0.0, 1.0, 1.0], [0.0, 0.0, 0.0]])
    # no area or not a number: 0
    assert covered_fraction(np.array([0.0, 0.0, 0.0, 10.0]), a) == 0.0
    assert covered_fraction(np.array([np.nan, 0.0, 4.0, 10.0]), a) == 0.0
