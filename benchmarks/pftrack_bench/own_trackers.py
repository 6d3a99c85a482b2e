"""The trackers ``pftrack bench own-detections`` compares, each fed the same detections frame by
frame: pftrack's presets that take detections (``people-image`` through
:func:`pftrack.workflows.pipeline.run_pipeline`, ``track`` through
:func:`pftrack.workflows.track.track_video`) and the peers with their documented defaults
(norfair; roboflow ``trackers``' ByteTrack, SORT, OC-SORT, BoT-SORT). Each returns its tracks and
the CPU time of its own update calls. :mod:`pftrack_bench.own_detections` describes the
benchmark, and these names import from there as well.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np


def _in_frames(rows: np.ndarray, first: int, last: int) -> np.ndarray:
    rows = np.asarray(rows, dtype=np.float64)
    return rows[(rows[:, 0] >= first) & (rows[:, 0] <= last)]


def write_det_file(path: str | os.PathLike[str], det_rows: np.ndarray) -> Path:
    """Write det rows (N, 7) as a MOTChallenge ``det.txt``, atomically."""
    import io

    from pftrack.io.atomic import atomic_write_text

    rows = np.asarray(det_rows, dtype=np.float64).reshape(-1, 7)
    buf = io.StringIO()
    np.savetxt(buf, rows, fmt=["%d", "%d"] + ["%.3f"] * 4 + ["%.4f"], delimiter=",")
    return atomic_write_text(path, buf.getvalue())


@dataclass
class TrackInput:
    """What every tracker of one cell gets: the video, the part's frames (inclusive, ground-truth
    numbering), the detections of those frames as a ``det.txt`` (``det_path``), the seed (the
    noise seed; pftrack's random stream), the video's frame rate and image size."""

    video: Path
    frames: tuple[int, int]
    det_path: Path
    seed: int
    fps: float
    image_wh: tuple[int, int]
    _dets: dict[int, Any] | None = field(default=None, repr=False)

    def detections(self) -> dict[int, Any]:
        """The det file read as ``pftrack run --detections`` reads it."""
        if self._dets is None:
            from pftrack.io.detections import read_detections

            self._dets = read_detections(self.det_path)
        return self._dets


@dataclass
class TrackResult:
    """One tracker's run on one cell: MOT rows (M, 10); its own time (seconds, summed over the
    frames: CPU and wall) and the frames it stepped; ``status`` ``"ok"``, ``"fallback"`` (it
    ran, not as asked: ``message`` says how) or ``"failed"`` (no usable tracks: ``message``
    says why)."""

    rows: np.ndarray
    cpu_s: float = 0.0
    wall_s: float = 0.0
    n_frames: int = 0
    status: str = "ok"
    message: str = ""


@dataclass(frozen=True)
class TrackerEntry:
    """A tracker the bench runs: ``run(TrackInput) -> TrackResult``; ``kind`` ``"pftrack"`` or
    ``"peer"`` (the goals compare the first against the best of the second); ``settings``
    (JSON) say how it is configured."""

    name: str
    kind: str
    run: Callable[[TrackInput], TrackResult]
    settings: dict[str, Any] = field(default_factory=dict)


def _nan_message(rows: np.ndarray) -> str | None:
    bad = ~np.all(np.isfinite(rows), axis=1) if len(rows) else np.zeros(0, bool)
    if bad.any():
        return f"row {int(np.flatnonzero(bad)[0]) + 1} of its tracks has a NaN or infinite value"
    return None


def _pftrack_run(config: str | os.PathLike[str] | dict[str, Any], inp: TrackInput) -> TrackResult:
    """``pftrack run CONFIG --video V --detections det.txt --frames A:B --seed S``'s library
    call, with its engine-step time."""
    import warnings

    from pftrack.workflows.pipeline import FrameWarning, run_pipeline

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FrameWarning)
        run = run_pipeline(config, video=inp.video, frames=inp.frames, seed=inp.seed,
                           detections=str(inp.det_path), progress=False, report=False)
    n = max(run.n_frames, 1)
    res = TrackResult(run.rows, cpu_s=run.timing["tracking_cpu_s_per_frame"] * n,
                      wall_s=run.timing["tracking_s_per_frame"] * n, n_frames=run.n_frames)
    return _check_rows(res)


def _check_rows(res: TrackResult) -> TrackResult:
    why = _nan_message(res.rows)
    if why is not None:
        res.status, res.message = "failed", why
    return res


def run_pftrack_config(config: str | os.PathLike[str] | dict[str, Any],
                       video: str | os.PathLike[str], frames: tuple[int, int],
                       det_rows: np.ndarray, seed: int = 0) -> np.ndarray:
    """pftrack with ``config`` (a preset name, a YAML path or a configuration dict, e.g. a
    preset loaded with :func:`pftrack.workflows.pipeline.load_config` and modified) on given
    detections.

    ``det_rows`` (N, 7) are written to a temporary ``det.txt`` and tracked as ``pftrack run
    CONFIG --video VIDEO --detections det.txt --frames A:B --seed SEED`` does. Returns the MOT
    track rows (M, 10); ValueError when they hold a NaN.
    """
    import tempfile

    from pftrack.workflows.pipeline import video_fps

    first, last = int(frames[0]), int(frames[1])
    with tempfile.TemporaryDirectory() as tmp:
        det = write_det_file(Path(tmp) / "det.txt", _in_frames(det_rows, first, last))
        inp = TrackInput(Path(video), (first, last), det, int(seed), video_fps(video), (0, 0))
        res = _pftrack_run(config, inp)
    if res.status == "failed":
        raise ValueError(f"run_pftrack_config: {res.message}")
    return res.rows


def reads_images(config: dict[str, Any]) -> bool:
    """Whether a loaded configuration's tracking reads the frames' pixels when it is given
    detections: a likelihood term other than ``detection`` (colour, templates, foreground),
    or a colour model per track (``tracks.appearance``)."""

    def image_likelihood(spec: Any) -> bool:
        if not isinstance(spec, dict):
            return False
        kind = spec.get("type")
        if kind == "composite":
            terms = (spec.get("params") or {}).get("terms") or []
            return any(image_likelihood(t.get("likelihood") if isinstance(t, dict) else None)
                       for t in terms)
        return kind is not None and kind != "detection"

    tracks = (config.get("tracks") or {}).get("params") or {}
    return image_likelihood(config.get("likelihood")) or tracks.get("appearance") is not None


def pftrack_config_entry(name: str, config: str | os.PathLike[str] | dict[str, Any]
                         ) -> TrackerEntry:
    """A tracker entry running pftrack with ``config`` (see :func:`run_pftrack_config`)."""
    from pftrack.workflows.pipeline import load_config

    cfg = load_config(config)  # checked now, not after the first cell
    src = str(config) if not isinstance(config, dict) else cfg.get("_source", "dict")
    return TrackerEntry(name, "pftrack", lambda inp: _pftrack_run(cfg, inp),
                        {"config": src, "preset": cfg.get("name"),
                         "image_term": reads_images(cfg)})


def boxes_only_config() -> dict[str, Any]:
    """``people-image`` without its image term: the same association, motion and lifecycle,
    and no colour model per track (``tracks.appearance: null``), so that tracking reads the
    detections alone. The bench's speed goal for tracking on detections alone is judged on it."""
    from pftrack.workflows.pipeline import load_config

    cfg = load_config("people-image")
    cfg["tracks"]["params"]["appearance"] = None
    return cfg


def _pftrack_track(inp: TrackInput) -> TrackResult:
    """``pftrack track VIDEO --detections det.txt --frames A:B --seed S`` (a camera estimated
    from the detections, ``people-image`` tracks placed on the ground through it); engine-step
    time only (not the camera fit)."""
    import warnings

    from pftrack.workflows.pipeline import FrameWarning
    from pftrack.workflows.track import track_video

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FrameWarning)
            fr = track_video(inp.video, None, detections=str(inp.det_path),
                             frames=f"{inp.frames[0]}:{inp.frames[1]}", seed=inp.seed,
                             report=False)
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        return TrackResult(np.zeros((0, 10)), status="failed", message=str(exc))
    run = fr.run
    n = max(run.n_frames, 1)
    res = TrackResult(run.rows, cpu_s=run.timing["tracking_cpu_s_per_frame"] * n,
                      wall_s=run.timing["tracking_s_per_frame"] * n, n_frames=run.n_frames)
    if fr.fit is None:
        res.status = "fallback"
        res.message = "; ".join(m for m in fr.messages if m.startswith("no camera")) or \
            str(fr.summary.get("camera"))
    return _check_rows(res)


#: norfair's settings: IoU distance (1 - IoU) below 0.7 matches; a track dies after 15 frames
#: without a match (its default) and is shown after 2 matched frames.
NORFAIR_SETTINGS = {"distance_function": "iou", "distance_threshold": 0.7,
                    "hit_counter_max": 15, "initialization_delay": 2}


def _norfair(inp: TrackInput) -> TrackResult:
    from pftrack_bench.fresh_video import norfair_tracks

    s = NORFAIR_SETTINGS
    timing: dict[str, float] = {}
    first, last = inp.frames
    rows = norfair_tracks(inp.detections(), range(first, last + 1), 0.0,
                          distance_threshold=s["distance_threshold"],
                          hit_counter_max=s["hit_counter_max"],
                          initialization_delay=s["initialization_delay"], timing=timing)
    return TrackResult(rows, timing["cpu_s"], timing["wall_s"], last - first + 1)


def _roboflow(cls_name: str, needs_frame: bool = False) -> Callable[[TrackInput], TrackResult]:
    """A roboflow ``trackers`` tracker with its defaults (``frame_rate`` the video's), fed
    ``supervision.Detections`` of the boxes; rows from its confirmed tracks (id >= 0)."""

    def run(inp: TrackInput) -> TrackResult:
        import supervision as sv
        import trackers

        tracker = getattr(trackers, cls_name)(frame_rate=float(inp.fps))
        dets = inp.detections()
        first, last = inp.frames
        images: Any = None
        if needs_frame:
            from pftrack.workflows.pipeline import iter_frames

            images = iter_frames(inp.video, first, last)
        rows: list[np.ndarray] = []
        cpu = wall = 0.0
        n = 0
        for f in range(first, last + 1):
            image = None
            if images is not None:
                frame = next(images, None)
                if frame is None:
                    break
                image = frame.image
            d = dets.get(f)
            if d is not None and len(d):
                b = d.boxes_xywh_px
                xyxy = np.column_stack([b[:, :2], b[:, :2] + b[:, 2:]])
                det = sv.Detections(xyxy=xyxy, confidence=d.scores.copy(),
                                    class_id=np.zeros(len(b), dtype=int))
            else:
                det = sv.Detections.empty()
            t0, c0 = time.perf_counter(), time.process_time()
            out = tracker.update(det, frame=image) if needs_frame else tracker.update(det)
            wall += time.perf_counter() - t0
            cpu += time.process_time() - c0
            n += 1
            ids = np.asarray(out.tracker_id if out.tracker_id is not None else [], dtype=int)
            ok = ids >= 0
            if ok.any():
                xy = np.asarray(out.xyxy, dtype=np.float64)[ok]
                r = np.full((int(ok.sum()), 10), -1.0)
                r[:, 0], r[:, 1] = f, ids[ok]
                r[:, 2:4], r[:, 4:6] = xy[:, :2], xy[:, 2:] - xy[:, :2]
                r[:, 6] = 1.0
                rows.append(r)
        out_rows = np.concatenate(rows) if rows else np.zeros((0, 10))
        return TrackResult(out_rows, cpu, wall, n)

    return run


def default_trackers() -> dict[str, TrackerEntry]:
    """The bench's trackers by name: pftrack's ``people-image``, ``people-image-boxes``
    (:func:`boxes_only_config`) and ``track`` (ground plane), and the peers ``norfair``,
    ``bytetrack``, ``sort``, ``ocsort``, ``botsort``."""
    import trackers

    version = getattr(trackers, "__version__", None)
    if version is None:
        from importlib.metadata import version as _v

        version = _v("trackers")

    def rf(cls: str) -> dict[str, Any]:
        return {"package": f"trackers {version}", "class": cls,
                "arguments": "defaults; frame_rate = the video's"}

    from pftrack.workflows.pipeline import load_config

    people = reads_images(load_config("people-image"))  # `track` tracks with it too
    return {
        "people-image": TrackerEntry(
            "people-image", "pftrack", lambda inp: _pftrack_run("people-image", inp),
            {"command": "pftrack run people-image --video V --detections det.txt",
             "image_term": people}),
        "people-image-boxes": TrackerEntry(
            "people-image-boxes", "pftrack", lambda inp: _pftrack_run(boxes_only_config(), inp),
            {"command": "pftrack run people-image --video V --detections det.txt with "
                        "tracks.appearance: null (detections alone, no image term)",
             "image_term": reads_images(boxes_only_config())}),
        "track": TrackerEntry(
            "track", "pftrack", _pftrack_track,
            {"command": "pftrack track V --detections det.txt (camera estimated from the "
                        "detections, people-image placed on the ground through it)",
             "image_term": people}),
        "norfair": TrackerEntry("norfair", "peer", _norfair, dict(NORFAIR_SETTINGS)),
        "bytetrack": TrackerEntry("bytetrack", "peer", _roboflow("ByteTrackTracker"),
                                  rf("ByteTrackTracker")),
        "sort": TrackerEntry("sort", "peer", _roboflow("SORTTracker"), rf("SORTTracker")),
        "ocsort": TrackerEntry("ocsort", "peer", _roboflow("OCSORTTracker"),
                               rf("OCSORTTracker")),
        "botsort": TrackerEntry("botsort", "peer", _roboflow("BoTSORTTracker", needs_frame=True),
                                {**rf("BoTSORTTracker"), "note": "camera-motion compensation "
                                 "(sparse optical flow) on the frames; no appearance model"}),
    }
