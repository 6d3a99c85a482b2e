"""``confirmed`` track management's ``end_at_border``: a target with no detection whose box
reaches past the image border ends (its object is leaving), so it cannot wait there hidden
and take over the next object entering at that edge."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Detections
from pftrack.testing import synthetic_scene
from pftrack.workflows.pipeline import build_engine

W, H = 160, 120  # the synthetic scene's size (px)


def _cfg(**tracks) -> dict:
    return {
        "state": "image",
        "observation": {"size_from_box": True},
        "motion": {"type": "constant-acceleration",
                   "params": {"position_noise": 1.5, "velocity_noise": 1.0,
                              "acceleration_noise": 0.3, "max_frames_tracked": 1}},
        "likelihood": {"type": "composite", "params": {"terms": [
            {"likelihood": {"type": "detection", "params": {"phi": 0.0, "sigma": 0.1}},
             "weight": 1.0}]}},
        "associator": {"type": "greedy-score", "params": {"max_distance": 1.0}},
        "tracker": {"n_particles": 100, "init_spread": 1.0, "max_misses": 30, "dt": 1.0},
        "births": {"min_score": 0.5, "confirm_hits": 2, "confirm_window": 3,
                   "hide_after_misses": 2, **tracks},
    }


def _detections(sc, newcomer_from: int):
    """The scene's detections: boxes wholly inside the image only, and object 0 (moving right,
    3 px/frame) not detected once its box comes within 12 px of the right border (as a
    window-based detector misses people near the border); from ``newcomer_from`` on a new
    object enters at the right border moving left."""
    dets = {}
    for i, b in sc.boxes_by_frame.items():
        keep = (b[:, 0] >= 0) & (b[:, 0] + b[:, 2] <= W) & (b[:, 1] >= 0) & (b[:, 1] + b[:, 3] <= H)
        keep[0] &= b[0, 0] + b[0, 2] < W - 12
        boxes = b[keep]
        if i >= newcomer_from:
            k = i - newcomer_from
            boxes = np.vstack([boxes, [W - 24 - 3.0 * k, 40.0 + 0.5 * k, 22.0, 36.0]])
        dets[i] = Detections(boxes, np.full(len(boxes), 0.9))
    return dets


def _run(end_at_border: bool, seed: int):
    sc = synthetic_scene(seed=seed, n_frames=60)
    dets = _detections(sc, newcomer_from=50)
    engine = build_engine(_cfg(end_at_border=end_at_border), fps=25.0, seed=seed)
    out, ended = {}, {}
    alive_before: set[int] = set()
    for f in sc.frames:
        for r in engine.step(f, dets[f.index]):
            out.setdefault(r.frame, {})[r.id] = r
        alive = {t.id for t in engine.targets}
        for tid in alive_before - alive:
            ended[tid] = f.index
        alive_before = alive
    return sc, out, ended


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_target_leaving_through_the_border_ends_and_does_not_take_the_next_one(seed):
    sc, out, ended = _run(True, seed)
    # object 0's target: the id nearest object 0 in frame 30 (object 0 well inside the image)
    first = min(out[30], key=lambda k: np.abs(out[30][k].box_xywh_px[:2]
                                              - sc.boxes_by_frame[30][0, :2]).sum())
    # its last detection is in the last frame its box is more than 12 px from the border
    b0 = np.array([sc.boxes_by_frame[i][0] for i in range(1, 61)])
    last_det = int(np.nonzero(b0[:, 0] + b0[:, 2] < W - 12)[0][-1]) + 1
    # walking on at about 3 px/frame it passes the border within about 12 / 3 + 1 frames and
    # ends there (without the rule it lives on hidden until max_misses, 30 frames)
    assert first in ended and last_det < ended[first] <= last_det + 8, (last_det, ended)
    # the newcomer entering at that border later gets a new id
    newcomer = [k for k, r in out[60].items() if r.box_xywh_px[0] > W - 60]
    assert len(newcomer) == 1 and all(newcomer[0] not in out.get(f, {}) for f in range(1, 50))
    assert all(first not in out.get(f, {}) for f in range(ended[first], 61))
    # while every object is inside and detected (frames 1-27) the rule changes nothing: the
    # same tracks, box for box, as without it
    _, out0, _ = _run(False, seed)
    assert all(b[:, 0].min() > 0 and (b[:, 0] + b[:, 2]).max() < W - 12
               for b in (sc.boxes_by_frame[f] for f in range(1, 28)))
    for f in range(1, 28):
        assert out[f].keys() == out0[f].keys()
        assert all(np.array_equal(out[f][k].box_xywh_px, out0[f][k].box_xywh_px) for k in out[f])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_without_the_rule_a_hidden_target_takes_the_newcomer(seed):
    # the failure the rule removes (same scene): a target whose object walked out, held back
    # inside the image, waits hidden and is matched to the newcomer, an old id on a new object
    sc, out, ended = _run(False, seed)
    newcomer = [k for k, r in out[60].items() if r.box_xywh_px[0] > W - 60]
    assert len(newcomer) == 1 and any(newcomer[0] in out.get(f, {}) for f in range(1, 50))


def test_end_at_border_keeps_a_matched_target_at_the_border():
    # a detection touching the border keeps its target: only unmatched targets end
    sc = synthetic_scene(seed=0, n_frames=8)
    dets = {i: Detections(np.array([[W - 22.0, 40.0, 22.0, 36.0]]), np.array([0.9]))
            for i in sc.boxes_by_frame}
    engine = build_engine(_cfg(end_at_border=True), fps=25.0, seed=0)
    ids = [{r.id for r in engine.step(f, dets[f.index])} for f in sc.frames]
    assert ids[-1] == ids[2] and len(ids[-1]) == 1


# -- a NaN appearance score bars a pair ------------------------------------------------------


def _reid_engine(seed: int = 0):
    sc = synthetic_scene(seed=seed, n_frames=8)
    dets = {i: Detections(b, np.full(len(b), 0.9)) for i, b in sc.boxes_by_frame.items()}
    cfg = _cfg(appearance={"bins": 8, "sigma": 0.1}, confirm_hits=1, confirm_window=1)
    engine = build_engine(cfg, fps=25.0, seed=seed)
    for f in sc.frames[:5]:
        engine.step(f, dets[f.index])
    return sc, dets, engine


def test_barred_pairs_score_zero():
    from pftrack_world.association import score_matrix
    sc, dets, engine = _reid_engine()
    t = sorted(engine.targets, key=lambda t: t.id)[0]
    t.appearance_scores = np.array([np.nan, 1.0, 1.0])
    S = score_matrix([t], dets[6], max_distance=None, appearance_weight=0.0)
    assert S[0, 0] == 0.0 and np.all(S[1:, 0] > 0)
    t.appearance_scores = np.array([1.0, 1.0, 1.0])
    assert score_matrix([t], dets[6], max_distance=None)[0, 0] > 0.5
