"""The frame loop: each frame through the detector (or the given detections) and one step of the
engine, the track records out with the time each part took.

Every run of the engine over frames goes through :func:`run_frames` (``pftrack run``, the
benchmarks, the conformance kit): one place decides what is timed. Per frame::

    frame (from the iterable: reading or decoding it counts in the loop's time only)
      -> detections: given[frame.index] | detector.detect(frame) | None     timed: detection
      -> before_step hooks                                                  not timed
      -> engine.step(frame, detections) -> records                          timed: tracking
      -> after_step hooks                                                   not timed

Each timed part is measured in wall time (``time.perf_counter``) and in the process's CPU time
(``time.process_time``): on an idle core they agree; on a shared, loaded machine the CPU time
is the one-core cost and the wall time includes waiting for a core. A hook's time is measured
apart (:attr:`FrameRun.hook_s`) and left out of every figure, so what a run draws, writes or
checks on the side does not change its speed.

Example::

    from pftrack.io.detections import read_detections
    from pftrack.workflows.pipeline import build_engine, iter_frames, load_config
    from pftrack.engine.runner import run_frames

    engine = build_engine(load_config("people-image"), fps=7.0, seed=0)
    run = run_frames(engine, iter_frames("vtest.avi", 1, 80),
                     detections=read_detections("det.txt"), progress="my run")
    rows = run.rows()                         # MOTChallenge rows, by frame then id
    fps = run.timing()["frames_per_second"]   # reading frames, detection and tracking
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from pftrack.contracts.components import Detections, Detector, Frame

if TYPE_CHECKING:
    from pftrack.engine.tracker import MultiTargetTracker, TrackRecord

__all__ = ["FrameHook", "FrameRun", "FrameStep", "run_frames"]


@dataclass
class FrameStep:
    """One frame as a hook sees it (the same object before and after the engine's step).

    Attributes
    ----------
    engine : MultiTargetTracker
        The engine; in a ``before_step`` hook its targets are those carried into the frame.
    frame : Frame
    number : int
        How many frames the loop has run, this one included (1 for the first).
    detections : Detections or None
        What the engine is given this frame (None: no detector and none given; the engine's
        own detector, if it has one, runs inside its step).
    records : list of TrackRecord
        What the step returned (empty in a ``before_step`` hook).
    detection_s, tracking_s, detection_cpu_s, tracking_cpu_s : float
        This frame's detection and step times, wall and CPU, seconds (tracking ones 0 in a
        ``before_step`` hook).
    """

    engine: MultiTargetTracker
    frame: Frame
    number: int
    detections: Detections | None
    records: list[TrackRecord] = field(default_factory=list)
    detection_s: float = 0.0
    tracking_s: float = 0.0
    detection_cpu_s: float = 0.0
    tracking_cpu_s: float = 0.0


#: A per-frame callback: it reads (or changes) the engine, the frame and its records.
FrameHook = Callable[[FrameStep], None]


@dataclass
class FrameRun:
    """What :func:`run_frames` gives back.

    Attributes
    ----------
    records : list of TrackRecord
        Every step's records, in the order the steps returned them.
    detections : dict {frame: Detections}
        The detections each frame's step was given (frames given none left out).
    n_frames : int
        Frames run.
    frame_detection_s, frame_tracking_s, frame_detection_cpu_s, frame_tracking_cpu_s : ndarray
        Per frame (n_frames,): detection and tracking (the engine's step), wall and CPU seconds.
    loop_s, loop_cpu_s : float
        The whole loop, wall and CPU seconds: getting each frame from the iterable (decoding,
        drawing), the progress bar, detection and tracking; the hooks left out.
    hook_s, hook_cpu_s : dict {name: float}
        Each hook's own time over the run, wall and CPU seconds (by the name it was given).
    """

    records: list[TrackRecord]
    detections: dict[int, Detections]
    n_frames: int
    frame_detection_s: np.ndarray
    frame_tracking_s: np.ndarray
    frame_detection_cpu_s: np.ndarray
    frame_tracking_cpu_s: np.ndarray
    loop_s: float
    loop_cpu_s: float
    hook_s: dict[str, float]
    hook_cpu_s: dict[str, float]

    def rows(self) -> np.ndarray:
        """The records as MOTChallenge rows (:func:`pftrack.engine.tracker.records_to_mot`), sorted
        by frame, then id."""
        from pftrack.engine.tracker import records_to_mot

        rows = records_to_mot(self.records)
        if len(rows):
            rows = rows[np.lexsort((rows[:, 1], rows[:, 0]))]
        return rows

    def timing(self) -> dict[str, float]:
        """Seconds per frame of detection and of tracking (wall, and ``_cpu`` the process's CPU
        time) and frames per second of the whole loop (:attr:`loop_s`: reading frames,
        detection and tracking; no hook), wall and CPU."""
        n = max(self.n_frames, 1)
        return {"detection_s_per_frame": float(self.frame_detection_s.sum()) / n,
                "tracking_s_per_frame": float(self.frame_tracking_s.sum()) / n,
                "frames_per_second": n / max(self.loop_s, 1e-12),
                "detection_cpu_s_per_frame": float(self.frame_detection_cpu_s.sum()) / n,
                "tracking_cpu_s_per_frame": float(self.frame_tracking_cpu_s.sum()) / n,
                "frames_per_second_cpu": n / max(self.loop_cpu_s, 1e-12)}


@contextmanager
def _cv2_threads(n: int | None) -> Iterator[None]:
    """OpenCV's worker threads set to ``n`` for the loop, restored after (None: untouched)."""
    if n is None:
        yield
        return
    import cv2

    before = cv2.getNumThreads()
    cv2.setNumThreads(int(n))
    try:
        yield
    finally:
        cv2.setNumThreads(before)


def run_frames(engine: MultiTargetTracker, frames: Iterable[Frame], *,
               detector: Detector | None = None,
               detections: Mapping[int, Detections] | None = None,
               before_step: Mapping[str, FrameHook] | None = None,
               after_step: Mapping[str, FrameHook] | None = None,
               progress: bool | str = False, total: int | None = None,
               cv2_threads: int | None = None) -> FrameRun:
    """Step ``engine`` through ``frames`` and collect its records, timed.

    Parameters
    ----------
    engine : MultiTargetTracker
        Built and ready (:func:`pftrack.workflows.pipeline.build_engine`); its targets carry over
        from any earlier frames.
    frames : iterable of Frame
        In order (a list, :func:`pftrack.workflows.pipeline.iter_frames`, a generator drawing them).
    detector : Detector, optional
        Run on each frame, timed as detection.
    detections : mapping {frame: Detections}, optional
        Given detections (e.g. :func:`pftrack.io.detections.read_detections`): a frame
        without an entry gets none (an empty :class:`Detections`). Not with ``detector``.
        With neither, the engine is given None (its own detector, if any, runs in its step).
    before_step, after_step : mapping {name: hook}, optional
        Called in order for each frame with its :class:`FrameStep`, after the detections and
        before the engine's step (e.g. to start targets by hand, or count the live ones), and
        after the step (e.g. to fill the records' spread, keep a picture). Not timed: each
        one's time is in :attr:`FrameRun.hook_s` under its name.
    progress : bool or str
        A progress bar on stderr (tqdm); a string is its label (True: ``"tracking"``).
    total : int, optional
        Frames expected (the bar's end) when ``frames`` has no length.
    cv2_threads : int, optional
        OpenCV's threads during the loop (1: a one-core figure), restored after; default
        OpenCV's own setting.

    Returns
    -------
    FrameRun

    Raises
    ------
    ValueError
        Both ``detector`` and ``detections`` given, or a hook named in both mappings.
    """
    if detector is not None and detections is not None:
        raise ValueError("run_frames: give detector or detections, not both (given detections "
                         "replace the detector)")
    before = dict(before_step or {})
    after = dict(after_step or {})
    if set(before) & set(after):
        raise ValueError(f"run_frames: hook names {sorted(set(before) & set(after))} are in "
                         "both before_step and after_step; each name is timed apart")
    hook_s = dict.fromkeys([*before, *after], 0.0)
    hook_cpu_s = dict.fromkeys([*before, *after], 0.0)
    it: Iterable[Frame] = frames
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(frames, total=total, unit="frame", leave=False,
                  desc=progress if isinstance(progress, str) else "tracking")
    wall, cpu = time.perf_counter, time.process_time

    def call(hooks: dict[str, FrameHook], step: FrameStep) -> tuple[float, float]:
        t_all = c_all = 0.0
        for name, hook in hooks.items():
            t, c = wall(), cpu()
            hook(step)
            t, c = wall() - t, cpu() - c
            hook_s[name] += t
            hook_cpu_s[name] += c
            t_all += t
            c_all += c
        return t_all, c_all

    records: list[TrackRecord] = []
    given: dict[int, Detections] = {}
    det_s: list[float] = []
    trk_s: list[float] = []
    det_c: list[float] = []
    trk_c: list[float] = []
    t_hooks = c_hooks = 0.0
    n = 0
    with _cv2_threads(cv2_threads):
        t_start, c_start = wall(), cpu()
        for frame in it:
            n += 1
            t0, c0 = wall(), cpu()
            if detections is not None:
                d: Detections | None = detections.get(frame.index, Detections.empty())
            elif detector is not None:
                d = detector.detect(frame)
            else:
                d = None
            t1, c1 = wall(), cpu()
            step = FrameStep(engine, frame, n, d, detection_s=t1 - t0, detection_cpu_s=c1 - c0)
            if before:
                t, c = call(before, step)
                t_hooks += t
                c_hooks += c
            t1, c1 = wall(), cpu()
            recs = engine.step(frame, d)
            t2, c2 = wall(), cpu()
            step.records = recs
            step.tracking_s, step.tracking_cpu_s = t2 - t1, c2 - c1
            if after:
                t, c = call(after, step)
                t_hooks += t
                c_hooks += c
            records.extend(recs)
            if d is not None:
                given[frame.index] = d
            det_s.append(step.detection_s)
            trk_s.append(step.tracking_s)
            det_c.append(step.detection_cpu_s)
            trk_c.append(step.tracking_cpu_s)
        loop_s = wall() - t_start - t_hooks
        loop_cpu_s = cpu() - c_start - c_hooks
    return FrameRun(records, given, n, np.array(det_s), np.array(trk_s), np.array(det_c),
                    np.array(trk_c), loop_s, loop_cpu_s, hook_s, hook_cpu_s)
