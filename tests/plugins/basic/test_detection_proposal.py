"""The engine's ``detection_proposal`` (a fraction of a matched target's particles redrawn
around its detection before weighting) and ``confirmed`` tracks' ``box_from_detection`` (the
output box moved towards the matched detection's)."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Detections
from pftrack.testing import synthetic_scene
from pftrack.workflows.pipeline import build_engine

BOX = np.array([60.0, 40.0, 22.0, 36.0])  # one person-like box (px)


def _cfg(tracker: dict | None = None, **tracks) -> dict:
    return {
        "state": "image",
        "observation": {"size_from_box": True},
        "motion": {"type": "constant-velocity-2d",
                   "params": {"position_noise": 0.5, "velocity_noise": 0.1}},
        "likelihood": {"type": "composite", "params": {"terms": [
            {"likelihood": {"type": "detection", "params": {"phi": 0.0, "sigma": 0.1}},
             "weight": 1.0}]}},
        "associator": {"type": "greedy-score", "params": {"max_distance": 1.0}},
        "tracker": {"n_particles": 200, "init_spread": 1.0, "max_misses": 30, "dt": 1.0,
                    **(tracker or {})},
        "births": {"min_score": 0.5, "confirm_hits": 1, "confirm_window": 1, **tracks},
    }


def _drifted(proposal: float, seed: int = 0):
    """A target born on BOX whose particles then sit 15 px (4 detection sigmas) to the right,
    tightly (0.5 px), and a frame whose only detection is BOX again: the estimate after it."""
    sc = synthetic_scene(seed=seed, n_frames=2)
    engine = build_engine(_cfg({"detection_proposal": proposal}), fps=25.0, seed=seed)
    engine.step(sc.frames[0], Detections(BOX[None], np.array([0.9])))
    (t,) = engine.targets
    p = t.particles.copy()
    p[:, :2] = engine.observation.position_from_box(BOX) + [15.0, 0.0]
    p[:, :2] += np.random.default_rng(seed).normal(0.0, 0.5, (len(p), 2))
    p[:, 2:] = 0.0
    engine.set_particles(t.id, p)
    (r,) = engine.step(sc.frames[1], Detections(BOX[None], np.array([0.9])))
    assert t.detection is not None  # the associator matched it (15 px < one box height)
    return r, engine.observation.position_from_box(BOX)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_drifted_target_returns_to_its_matched_detection_with_the_proposal(seed):
    r0, at = _drifted(0.0, seed)
    r1, _ = _drifted(0.1, seed)
    # the prior alone: every particle 15 px off, the estimate stays there (the detection
    # likelihood only reweights the cloud it is given)
    assert np.linalg.norm(r0.position[:2] - at) > 10.0
    # a tenth redrawn around the detection (init_spread 1 px) outweighs the drifted ones
    # (exp(-8) each): the estimate is on the detection
    assert np.linalg.norm(r1.position[:2] - at) < 2.0


def test_the_proposal_is_seeded_and_zero_draws_nothing(monkeypatch):
    a, _ = _drifted(0.1, seed=4)
    b, _ = _drifted(0.1, seed=4)
    np.testing.assert_array_equal(a.state, b.state)
    c, _ = _drifted(0.0, seed=4)
    assert not np.array_equal(a.state, c.state)
    # 0: the proposal is never entered (no draw: every other preset's tracks unchanged)
    from pftrack.engine.tracker import MultiTargetTracker

    def never(self, targets):
        raise AssertionError("proposal entered with detection_proposal 0")

    monkeypatch.setattr(MultiTargetTracker, "_propose_at_detections", never)
    d, _ = _drifted(0.0, seed=4)
    np.testing.assert_array_equal(c.state, d.state)
    with pytest.raises(AssertionError, match="proposal entered"):
        _drifted(0.1, seed=4)


@pytest.mark.parametrize("bad", [-0.1, 1.5, True, "half"])
def test_a_bad_proposal_fraction_is_refused_with_its_name(bad):
    with pytest.raises(ValueError, match="tracker.detection_proposal"):
        build_engine(_cfg({"detection_proposal": bad}), fps=25.0, seed=0)


def _box_run(w: float, det_box: np.ndarray, min_iou: float = 0.3):
    sc = synthetic_scene(seed=0, n_frames=2)
    engine = build_engine(_cfg(box_from_detection=w, box_min_iou=min_iou), fps=25.0, seed=0)
    engine.step(sc.frames[0], Detections(BOX[None], np.array([0.9])))
    (t,) = engine.targets
    (r,) = engine.step(sc.frames[1], Detections(det_box[None], np.array([0.9])))
    return r, t


def test_the_output_box_moves_towards_the_matched_detection():
    det = BOX + [3.0, 1.0, 4.0, 6.0]  # overlapping (IoU ~0.7), a larger outline
    r0, t0 = _box_run(0.0, det)
    r, t = _box_run(0.5, det)
    assert t.detection is not None
    # the filter itself is untouched (the same seed gives the same estimate)...
    np.testing.assert_array_equal(r.state, r0.state)
    np.testing.assert_array_equal(t.box_xywh_px, t0.box_xywh_px)
    # ...and the record's box is half-way between the estimate's and the detection's
    np.testing.assert_allclose(r.box_xywh_px, 0.5 * r0.box_xywh_px + 0.5 * det, atol=1e-12)
    r1, _ = _box_run(1.0, det)
    np.testing.assert_allclose(r1.box_xywh_px, det, atol=1e-12)


def test_a_detection_overlapping_less_than_box_min_iou_leaves_the_box_alone():
    det = BOX + [14.0, 0.0, 0.0, 0.0]  # 14 px to the right: IoU (8 * 36) / (2 * 792 - 288)
    r0, _ = _box_run(0.0, det)
    r, t = _box_run(0.5, det, min_iou=0.3)
    assert t.detection is not None
    np.testing.assert_array_equal(r.box_xywh_px, r0.box_xywh_px)
    r2, _ = _box_run(0.5, det, min_iou=0.1)  # a looser gate lets it move
    assert r2.box_xywh_px[0] > r0.box_xywh_px[0] + 1.0


@pytest.mark.parametrize("key,bad", [("box_from_detection", 2.0), ("box_from_detection", -1),
                                     ("box_min_iou", 1.5), ("box_min_iou", "0.3")])
def test_bad_box_options_are_refused_with_their_name(key, bad):
    with pytest.raises(ValueError, match=f"'{key}'"):
        build_engine(_cfg(**{key: bad}), fps=25.0, seed=0)


def test_the_proposal_on_the_stacked_rows_of_several_targets():
    """Three targets weighted as one (T, N) block (the vectorised path): each drifted target
    returns to its own detection, and the particle boxes the likelihood scored are the boxes of
    the particles the filter kept (the redrawn rows updated in place, not stale)."""
    sc = synthetic_scene(seed=3, n_frames=2)
    boxes = np.array([BOX, BOX + [60.0, 10.0, 0.0, 0.0], BOX + [-40.0, 30.0, 0.0, 0.0]])
    engine = build_engine(_cfg({"detection_proposal": 0.1}), fps=25.0, seed=3)
    engine.step(sc.frames[0], Detections(boxes, np.full(3, 0.9)))
    targets = sorted(engine.targets, key=lambda t: t.id)
    assert len(targets) == 3
    rng = np.random.default_rng(3)
    for t, b in zip(targets, boxes, strict=True):
        p = t.particles.copy()
        p[:, :2] = engine.observation.position_from_box(b) + [12.0, -5.0]
        p[:, :2] += rng.normal(0.0, 0.5, (len(p), 2))
        p[:, 2:] = 0.0
        engine.set_particles(t.id, p)
    seen = {}
    lik = engine.likelihood
    assert engine.uses_rows()  # every target scored in one log_likelihood_rows call
    orig = type(lik).log_likelihood_rows

    def spy(self, boxes_xywh_px, targets):
        for b, target in zip(boxes_xywh_px, targets, strict=True):
            seen[target.id] = (np.array(b), target.particles.copy())
        return orig(self, boxes_xywh_px, targets)

    type(lik).log_likelihood_rows = spy
    try:
        recs = {r.id: r for r in engine.step(sc.frames[1], Detections(boxes, np.full(3, 0.9)))}
    finally:
        type(lik).log_likelihood_rows = orig
    for t, b in zip(targets, boxes, strict=True):
        assert t.detection is not None
        scored, parts = seen[t.id]
        np.testing.assert_allclose(scored, engine.observation.to_boxes(parts, t), atol=1e-9)
        at = engine.observation.position_from_box(b)
        assert np.linalg.norm(recs[t.id].position[:2] - at) < 2.0, (t.id, recs[t.id].position)
