"""Lifecycle durations given in seconds of video (``tracker.max_misses_s``,
``hide_after_s``): the same time at any frame rate, as frames at the run's."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Detections, RunContext
from pftrack.testing import synthetic_scene
from pftrack.workflows.pipeline import build_engine, load_config


@pytest.mark.parametrize(("seconds", "fps", "frames"), [
    (0.3, 10.0, 3), (0.3, 30.0, 9), (5.0, 10.0, 50), (5.0, 29.97, 150), (0.0, 25.0, 0),
    (0.3, 25.0, 8),  # 7.5 frames, rounded half to even
])
def test_a_duration_is_frames_at_the_runs_frame_rate(seconds, fps, frames):
    assert RunContext(fps=fps).frames(seconds) == frames


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf")])
def test_a_bad_duration_is_refused(bad):
    with pytest.raises(ValueError, match="seconds"):
        RunContext(fps=10.0).frames(bad)


@pytest.mark.parametrize(("fps", "frames"), [(10.0, 50), (30.0, 150)])
def test_people_image_keeps_a_lost_track_for_five_seconds(fps, frames):
    engine = build_engine(load_config("people-image"), fps=fps, seed=0)
    assert engine.max_misses == frames


def test_max_misses_in_frames_and_in_seconds_is_refused():
    cfg = load_config("people-image")
    cfg["tracker"]["max_misses"] = 40
    with pytest.raises(ValueError, match=r"tracker\.max_misses .*tracker\.max_misses_s"):
        build_engine(cfg, fps=10.0, seed=0)


def _hidden_after(fps: float, gap: int = 20) -> int:
    """Frames a confirmed track stays in the output once its detections stop, at ``fps``
    (people-image's hide_after_s, 0.3 s)."""
    cfg = load_config("people-image")
    cfg["detector"] = None
    cfg["tracks"]["params"]["appearance"] = None
    engine = build_engine(cfg, fps=fps, seed=0)
    sc = synthetic_scene(seed=0, n_frames=10 + gap)
    box = np.array([[60.0, 30.0, 20.0, 50.0]])
    shown = []
    for k, frame in enumerate(sc.frames):
        dets = Detections(box, np.array([0.9])) if k < 10 else Detections.empty()
        shown.append(len(engine.step(frame, dets)))
    assert shown[9] == 1  # confirmed and output while detected
    return sum(shown[10:])


@pytest.mark.parametrize(("fps", "frames"), [(10.0, 3), (30.0, 9)])
def test_people_image_hides_a_track_after_the_same_time_at_any_frame_rate(fps, frames):
    assert _hidden_after(fps) == frames


def test_hide_after_in_frames_and_in_seconds_is_refused():
    from pftrack_basic.tracks import OutputBoxReporter

    with pytest.raises(ValueError, match="hide_after_misses.*hide_after_s"):
        OutputBoxReporter(hide_after_misses=3, hide_after_s=0.3)
    cfg = load_config("people-image")
    cfg["tracks"]["params"]["hide_after_misses"] = 3
    with pytest.raises(ValueError, match="hide_after_misses.*hide_after_s"):
        build_engine(cfg, fps=10.0, seed=0)
