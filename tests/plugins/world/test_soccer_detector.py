"""The pitch blob detector on the soccer scene: recall, precision and ground-point accuracy."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Frame
from pftrack.testing import assert_conforms
from pftrack_world.soccer import PitchBlobDetector, SoccerScene
from scipy.optimize import linear_sum_assignment


@pytest.fixture(scope="module")
def run():
    scene = SoccerScene(duration_s=4.0, seed=2, supersample=1)
    det = PitchBlobDetector()
    frames, dets = [], []
    for f in scene.frames():
        frames.append(f.index)
        dets.append(det.detect(f))
    return scene, det, frames, dets


def test_finds_the_players(run) -> None:
    scene, _det, frames, dets = run
    gt = scene.ground_truth()
    assert len(dets[0]) == 0  # the first frame only teaches the background
    tp = fp = fn = 0
    err_m, err_px = [], []
    for k, d in zip(frames[10:], dets[10:]):
        g = gt[gt[:, 0] == k]
        foot_g = np.column_stack([g[:, 2] + g[:, 4] / 2, g[:, 3] + g[:, 5]])
        b = d.boxes_xywh_px
        foot_d = np.column_stack([b[:, 0] + b[:, 2] / 2, b[:, 1] + b[:, 3]])
        cost = np.linalg.norm(foot_g[:, None] - foot_d[None], axis=2)
        r, c = linear_sum_assignment(cost)
        ok = cost[r, c] < 4.0
        tp += ok.sum()
        fn += len(g) - ok.sum()
        fp += len(d) - ok.sum()
        err_px += cost[r, c][ok].tolist()
        err_m += np.linalg.norm(d.points_world_m[c[ok], :2] - g[r[ok], 7:9], axis=1).tolist()
    recall, precision = tp / (tp + fn), tp / (tp + fp)
    # measured: recall 0.90, precision 0.82, foot 0.7 px, ground 0.3 m (median)
    assert recall > 0.85
    assert precision > 0.75
    assert np.median(err_px) < 1.2
    assert np.median(err_m) < 0.6
    assert np.percentile(err_m, 90) < 1.6


def test_processes_only_the_pitch_band(run) -> None:
    _, det, _, _ = run
    y0, y1, x0, x1 = det.band_
    # the soccer paper's camera sees the pitch in a thin band of the 1280 x 720 image
    assert 0 < y0 < y1 < 720 and y1 - y0 < 200
    assert det.region_.shape == (y1 - y0, x1 - x0)
    # a player's expected box at the pitch centre is ~11 px tall
    cam = det.camera_
    c = cam.project(np.array([[52.5, 34.0, 0.0]]))
    h = det.expected_boxes(c)[0, 3]
    assert 8 < h < 16


def test_stream_shape_is_checked(run) -> None:
    det = PitchBlobDetector()
    det.detect(Frame(1, np.zeros((720, 1280, 3), np.uint8)))
    with pytest.raises(ValueError, match="reset"):
        det.detect(Frame(2, np.zeros((360, 640, 3), np.uint8)))
    det.reset()
    assert len(det.detect(Frame(3, np.zeros((360, 640, 3), np.uint8)))) == 0


def test_conforms() -> None:
    assert_conforms(PitchBlobDetector)
    assert_conforms(SoccerScene)
