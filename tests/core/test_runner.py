"""The one frame loop (pftrack.engine.runner.run_frames): records as stepping by hand, detections
from a detector or given, hooks before and after the step and their time left out of the
figures."""

from __future__ import annotations

import time

import numpy as np
import pytest
from conftest import SampleWalk
from pftrack.builtin.image_box import ImageBoxObservation
from pftrack.contracts.components import Detections
from pftrack.engine.runner import run_frames
from pftrack.engine.tracker import MultiTargetTracker
from pftrack_basic.tracks import DetectionBirthTracks

from tests.core.test_tracker import (
    _frames,
    _ListDetector,
    _NearestAssociator,
    _record_bytes,
    _TruthLikelihood,
)

#: one object detected in frames 5..30 at a fixed place
BOXES = {k: np.array([[45.0, 45.0, 10.0, 10.0]]) for k in range(5, 31)}


def _engine(seed=0, detector=None):
    lik = _TruthLikelihood()
    lik.truth_ = type("T", (), {"__getitem__": lambda s, i: (lambda k: np.array([50.0, 50.0]))})()
    return MultiTargetTracker(SampleWalk(1.0), lik, ImageBoxObservation(10, 10), n_particles=100,
                              detector=detector, associator=_NearestAssociator(),
                              tracks=DetectionBirthTracks(min_score=0.5), max_misses=3,
                              rng=np.random.default_rng(seed))


def _by_hand(seed=0):
    engine = _engine(seed, detector=_ListDetector(BOXES))
    return [r for f in _frames(50) for r in engine.step(f)]


def test_records_are_those_of_stepping_by_hand_with_a_detector_or_given_detections():
    want = _record_bytes(_by_hand())
    assert len(want) > 20
    detector = _ListDetector(BOXES)
    run = run_frames(_engine(), _frames(50), detector=detector)
    assert _record_bytes(run.records) == want
    assert run.n_frames == 50
    # every frame's detections are kept, those of frames without a box too (empty)
    assert sorted(run.detections) == list(range(1, 51))
    assert len(run.detections[5]) == 1 and len(run.detections[40]) == 0
    given = {k: Detections(b, np.ones(len(b))) for k, b in BOXES.items()}
    run2 = run_frames(_engine(), _frames(50), detections=given)
    assert _record_bytes(run2.records) == want
    # a frame not in the mapping is given no detection: an empty Detections, not None
    assert len(run2.detections[1]) == 0
    # neither: the engine's own detector runs inside its step (timed as tracking)
    run3 = run_frames(_engine(detector=_ListDetector(BOXES)), _frames(50))
    assert _record_bytes(run3.records) == want
    assert run3.detections == {}
    rows = run.rows()
    assert rows.shape == (len(want), 10)
    assert np.all(np.diff(rows[:, 0]) >= 0)


def test_hooks_see_the_frame_before_and_after_the_step_and_may_change_the_engine():
    seen = []

    def before(step):
        assert step.records == [] and step.tracking_s == 0.0
        seen.append(("before", step.number, step.frame.index, len(step.engine.targets)))
        if step.frame.index == 3:  # a target started by hand, as the soccer bench does
            step.engine.add_target(step.frame, np.array([50.0, 50.0]), target_id=7)

    def after(step):
        seen.append(("after", step.number, step.frame.index, len(step.records)))

    run = run_frames(_engine(), _frames(6), before_step={"b": before},
                     after_step={"a": after})
    assert seen[:6] == [("before", 1, 1, 0), ("after", 1, 1, 0), ("before", 2, 2, 0),
                        ("after", 2, 2, 0), ("before", 3, 3, 0), ("after", 3, 3, 1)]
    assert seen[6] == ("before", 4, 4, 1)  # the targets carried into frame 4
    assert {r.id for r in run.records} == {7}
    assert set(run.hook_s) == set(run.hook_cpu_s) == {"a", "b"}


def test_a_hooks_time_is_measured_apart_and_left_out_of_the_loops():
    def nap(step):
        time.sleep(0.05)

    t0 = time.perf_counter()
    run = run_frames(_engine(), _frames(10), detector=_ListDetector(BOXES),
                     after_step={"nap": nap})
    outer = time.perf_counter() - t0
    assert run.hook_s["nap"] >= 0.5
    # the loop's time is what is left once the naps are taken out
    assert run.loop_s <= outer - run.hook_s["nap"]
    assert run.loop_s >= run.frame_detection_s.sum() + run.frame_tracking_s.sum()
    assert run.frame_tracking_s.shape == run.frame_detection_cpu_s.shape == (10,)
    timing = run.timing()
    assert timing["frames_per_second"] == pytest.approx(10 / run.loop_s)
    assert timing["tracking_s_per_frame"] == pytest.approx(run.frame_tracking_s.mean())
    assert timing["frames_per_second_cpu"] == pytest.approx(10 / run.loop_cpu_s)


def test_progress_goes_to_stderr_with_its_label_and_opencv_threads_are_restored(capsys):
    import cv2

    threads = cv2.getNumThreads()
    cv2.setNumThreads(3)
    inside = []
    try:
        run_frames(_engine(), _frames(5), progress="label-of-run", cv2_threads=1,
                   after_step={"threads": lambda step: inside.append(cv2.getNumThreads())})
        after = cv2.getNumThreads()
    finally:
        cv2.setNumThreads(threads)
    assert inside == [1] * 5
    assert after == 3
    captured = capsys.readouterr()
    assert "label-of-run" in captured.err and captured.out == ""


def test_bad_arguments_are_refused_naming_them():
    with pytest.raises(ValueError, match="detector or detections"):
        run_frames(_engine(), _frames(2), detector=_ListDetector(BOXES), detections={})
    with pytest.raises(ValueError, match=r"\['x'\]"):
        run_frames(_engine(), _frames(2), before_step={"x": print}, after_step={"x": print})


def test_no_frame_gives_an_empty_run():
    run = run_frames(_engine(), [])
    assert run.n_frames == 0 and run.records == [] and run.rows().shape[0] == 0
    assert run.timing()["tracking_s_per_frame"] == 0.0
