"""The engine's ``birth_velocity_spread``: a target started from a box holds hypotheses of its
speed from the first frame (zero-mean velocities, std in heights of that box per dt)."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Detections
from pftrack.testing import synthetic_scene
from pftrack.workflows.pipeline import build_engine

H = 50.0  # box height (px); the synthetic frames are 160 x 120


def _cfg(spread: float, n: int = 200, motion: str = "constant-velocity-2d",
         velocity_noise: float = 0.1) -> dict:
    params = ({"sigma_px": 0.5} if motion == "random-walk"
              else {"position_noise": 0.5, "velocity_noise": velocity_noise})
    return {
        "state": "image",
        "observation": {"size_from_box": True},
        "motion": {"type": motion, "params": params},
        "likelihood": {"type": "composite", "params": {"terms": [
            {"likelihood": {"type": "detection", "params": {"phi": 0.0, "sigma": 0.05}},
             "weight": 1.0}]}},
        "associator": {"type": "greedy-score", "params": {"max_distance": 1.0}},
        "tracker": {"n_particles": n, "init_spread": 1.0, "max_misses": 30, "dt": 1.0,
                    "detection_proposal": 0.1, "birth_velocity_spread": spread},
        "births": {"min_score": 0.5, "confirm_hits": 1, "confirm_window": 1},
    }


def _box(x: float) -> np.ndarray:
    return np.array([x, 40.0, 0.4 * H, H])


def _born(spread: float, seed: int = 0, n: int = 4000):
    sc = synthetic_scene(seed=seed, n_frames=1)
    engine = build_engine(_cfg(spread, n=n), fps=25.0, seed=seed)
    engine.step(sc.frames[0], Detections(_box(10.0)[None], np.array([0.9])))
    (t,) = engine.targets
    return t.particles.copy()


@pytest.mark.parametrize("spread", [0.02, 0.05, 0.1])
def test_a_target_born_from_a_box_has_velocities_spread_by_its_height(spread):
    p = _born(spread)
    v = p[:, 2:4]
    # zero mean, std spread * H per axis (4000 particles: the sample std within 5 %)
    assert np.abs(v.mean(axis=0)).max() < 4 * spread * H / np.sqrt(len(v))
    np.testing.assert_allclose(v.std(axis=0), spread * H, rtol=0.05)
    # the positions are drawn first and are the ones a target at rest gets
    np.testing.assert_array_equal(p[:, :2], _born(0.0)[:, :2])


def test_zero_spread_starts_every_target_at_rest():
    p = _born(0.0)
    assert not p[:, 2:4].any()


def _speed(spread: float, seed: int, speed: float = 8.0, frames: int = 8) -> float:
    """A person moving ``speed`` px per frame (0.16 box heights), detected every frame from
    its first: the track's estimated horizontal speed after ``frames`` frames."""
    sc = synthetic_scene(seed=seed, n_frames=frames)
    engine = build_engine(_cfg(spread), fps=25.0, seed=seed)
    for k in range(frames):
        engine.step(sc.frames[k], Detections(_box(10.0 + speed * k)[None], np.array([0.9])))
    (t,) = engine.targets
    return float(t.state[2])


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_a_fast_person_is_followed_from_the_start(seed):
    # started at rest, with a velocity noise of 0.1 px/frame, a track cannot reach 8 px/frame
    # in eight frames (the detection proposal keeps its position on the person, one frame
    # behind); with speeds as hypotheses its first detections keep the right one
    assert _speed(0.0, seed) < 2.5
    assert abs(_speed(0.1, seed) - 8.0) < 1.5


def test_a_target_started_from_a_position_starts_at_rest():
    sc = synthetic_scene(seed=0, n_frames=1)
    engine = build_engine(_cfg(0.05), fps=25.0, seed=0)
    t = engine.add_target(sc.frames[0], np.array([40.0, 60.0]))
    assert not t.particles[:, 2:4].any()


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf"), True, "0.1"])
def test_a_bad_spread_is_refused_naming_it(bad):
    with pytest.raises(ValueError, match="birth_velocity_spread"):
        build_engine(_cfg(bad), fps=25.0, seed=0)


def test_a_motion_model_without_velocity_is_refused():
    with pytest.raises(ValueError, match="birth_velocity_spread.*velocity"):
        build_engine(_cfg(0.05, motion="random-walk"), fps=25.0, seed=0)


def test_an_observation_without_box_heights_is_refused():
    from pftrack.contracts.components import ObservationModel
    from pftrack.engine.tracker import MultiTargetTracker

    class NoHeights(ObservationModel):
        def to_boxes(self, states, target=None):
            return np.zeros((len(states), 4))

        def position_from_box(self, box_xywh_px):
            return np.zeros(2)

    engine = build_engine(_cfg(0.0), fps=25.0, seed=0)
    with pytest.raises(ValueError, match="birth_velocity_spread.*box_height_in_state"):
        MultiTargetTracker(engine.motion, engine.likelihood, NoHeights(),
                           birth_velocity_spread=0.05, rng=np.random.default_rng(0))
