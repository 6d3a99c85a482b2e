"""The soccer paper's matching score (eq. 3-4) and its greedy and Hungarian solvers."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Detections, Target
from pftrack_world.association import (
    GreedyScoreAssociator,
    HungarianScoreAssociator,
    greedy_max,
    score_matrix,
)


def _target(tid: int, boxes: np.ndarray) -> Target:
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return Target(id=tid, state=np.zeros(6), box_xywh_px=boxes.mean(axis=0),
                  particle_boxes_xywh_px=boxes)


def test_score_matrix_matches_eq_3_and_4_by_hand():
    # one track whose two particles are 40 px tall boxes; feet at (20, 100) and (24, 100)
    t = _target(1, [[10, 60, 20, 40], [14, 60, 20, 40]])
    # detection: 44 px tall, foot at (22, 103), score 0.7
    d = Detections([[11, 59, 22, 44]], [0.7])
    s = score_matrix([t], d, alpha=2.0, sigma_det=0.25, sigma_size=0.25, max_distance=None)
    size_tr, size_det = 40.0, 44.0
    g = np.exp(-0.5 * (((size_tr - size_det) / size_tr) / 0.25) ** 2)
    dists = np.array([np.hypot(2, 3), np.hypot(-2, 3)]) / size_tr
    prox = np.mean(np.exp(-0.5 * (dists / 0.25) ** 2))
    assert s.shape == (1, 1)
    assert s[0, 0] == pytest.approx(g * (0.7 + 2.0 * prox), rel=1e-12)


def test_distance_gate_and_size_gate():
    t = _target(1, [[100, 100, 20, 50]])
    far = Detections([[400, 100, 20, 50]], [2.0])
    assert score_matrix([t], far, max_distance=1.0)[0, 0] == 0.0
    # without the gate eq. 3 alone lets a confident detection anywhere match
    assert score_matrix([t], far, max_distance=None)[0, 0] == pytest.approx(2.0, rel=1e-6)
    near_small = Detections([[105, 125, 10, 25]], [1.0])  # half the size, same foot
    near_same = Detections([[100, 100, 20, 50]], [1.0])
    s_small = score_matrix([t], near_small)[0, 0]
    s_same = score_matrix([t], near_same)[0, 0]
    assert s_same == pytest.approx(2.0)  # g = 1, c = 1, every particle on the detection
    assert s_small == pytest.approx(np.exp(-0.5 * (0.5 / 0.25) ** 2) * 2.0)


def test_greedy_takes_the_largest_first_hungarian_maximises_the_total():
    S = np.array([[0.9, 0.8], [0.85, 0.3]])  # rows detections, columns tracks
    assert greedy_max(S, 0.2) == [(0, 0), (1, 1)]
    assert greedy_max(S, 0.5) == [(0, 0)]  # (1, 1) is below the threshold
    # the associators on targets/detections built so that S has this structure
    tracks = [_target(1, [[0, 0, 20, 50]]), _target(2, [[200, 0, 20, 50]])]
    dets = Detections([[0, 0, 20, 50], [200, 0, 20, 50]], [0.9, 0.1])
    g = GreedyScoreAssociator(alpha=0.0, max_distance=None, min_score=0.05)
    a = g.associate(tracks, dets)
    assert sorted(map(tuple, a.matches.tolist())) == [(0, 0), (1, 1)]
    assert g.scores_.shape == (2, 2)


def test_greedy_and_hungarian_differ_where_they_should():
    # hand-built score matrix through a subclass hook: greedy 0.9 + 0.3, Hungarian 0.8 + 0.85
    class Fixed(GreedyScoreAssociator):
        def _scores(self, targets, detections):
            self.scores_ = np.array([[0.9, 0.8], [0.85, 0.3]])
            return self.scores_

    class FixedH(HungarianScoreAssociator):
        def _scores(self, targets, detections):
            self.scores_ = np.array([[0.9, 0.8], [0.85, 0.3]])
            return self.scores_

    tr = [_target(1, [[0, 0, 1, 1]]), _target(2, [[0, 0, 1, 1]])]
    d = Detections(np.zeros((2, 4)), [1, 1])
    ag = Fixed(min_score=0.2).associate(tr, d)
    ah = FixedH(min_score=0.2).associate(tr, d)
    # Assignment rows are (track index, detection index)
    assert sorted(map(tuple, ag.matches.tolist())) == [(0, 0), (1, 1)]
    assert sorted(map(tuple, ah.matches.tolist())) == [(0, 1), (1, 0)]
    assert FixedH(min_score=0.82).associate(tr, d).matches.tolist() == [[0, 0]]


def test_empty_inputs_and_validation():
    t = _target(1, [[0, 0, 10, 20]])
    for cls in (GreedyScoreAssociator, HungarianScoreAssociator):
        a = cls().associate([t], Detections.empty())
        assert a.matches.shape == (0, 2) and a.unmatched_tracks.tolist() == [0]
        a = cls().associate([], Detections([[0, 0, 10, 20]], [1.0]))
        assert a.unmatched_detections.tolist() == [0]
        with pytest.raises(ValueError, match="sigma_det"):
            cls(sigma_det=0).associate([t], Detections([[0, 0, 10, 20]], [1.0]))
