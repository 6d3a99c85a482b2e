"""From a configuration to tracks, metrics and report pictures: what ``pftrack run`` does.

A configuration (a YAML file, or the name of a preset a plugin registered) names the components
by their registered names; this module builds them through the plugin host, so every component of
a run is replaceable by a third-party plugin::

    state: world | image          ground-plane particles through a camera, or image-plane boxes
    observation: {...}            CameraBoxObservation / ImageBoxObservation parameters
    motion: {type, params}        a registered motion model
    likelihood: {type, params}    a registered likelihood (e.g. ``composite``)
    detector: {type, params, train: {frames, params, seed}}
    associator: {type, params}
    tracker: {...}                MultiTargetTracker options (n_particles, max_misses, ...)
    births: {...}                 TrackingSession's birth policy (below)
    valid_region_m: [x0, x1, y0, y1]   optional ground rectangle (metres) people live in

Data flow per frame: video frame -> detector -> :class:`TrackingSession` (the tracker's predict,
associate, weight, estimate, resample, death; then births from confirmed detections) -> track
records -> MOTChallenge rows (world columns filled for ground-plane state).

:class:`TrackingSession` is seed 001's tracking loop around :class:`pftrack.tracker.MultiTargetTracker`
(whose own birth option is left off): an unmatched detection at least ``min_score`` confident,
overlapping no live target by more than ``max_iou``, starts a *tentative* target; it is confirmed
once ``confirm_hits`` of its first ``confirm_window`` frames had a matched detection, and then its
records from birth on are output (so confirmation costs no frames); otherwise it is dropped
unseen. Two confirmed targets that are one person tracked twice (ground positions closer than
``merge_distance_m`` with a world frame, else boxes overlapping by more than ``merge_iou``): the
younger is removed.

Frame numbers are the ground truth's (MOTChallenge, 1-based): MOT frame N is video frame N - 1.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pftrack.components import Detections, Detector, Frame, RunContext, Target
from pftrack.tracker import MultiTargetTracker, TrackRecord, records_to_mot

__all__ = [
    "RunResult",
    "TrackingSession",
    "build_detector",
    "build_session",
    "evaluate_tracks",
    "iter_frames",
    "load_config",
    "parse_frames",
    "read_ground_truth",
    "run_pipeline",
    "train_detector",
]

CONFIG_KEYS = {"name", "description", "state", "observation", "motion", "likelihood", "detector",
               "associator", "tracker", "births", "valid_region_m", "report"}
TRACKER_KEYS = {"n_particles", "resampling", "ess_threshold", "dt", "init_spread",
                "recover_spread", "max_misses", "min_log_likelihood", "kill_out_of_view",
                "target_size"}
BIRTH_KEYS = {"min_score", "max_iou", "confirm_hits", "confirm_window", "merge_iou",
              "merge_distance_m",
              "hide_after_misses", "appearance"}
APPEARANCE_KEYS = {"bins", "sigma", "update_rate", "region"}


# --------------------------------------------------------------------------------------------
# Configuration
# --------------------------------------------------------------------------------------------


def load_config(spec: str | os.PathLike[str] | dict[str, Any]) -> dict[str, Any]:
    """A run configuration from a dict, a YAML file path, or a registered preset name.

    Raises
    ------
    FileNotFoundError
        ``spec`` is neither an existing file nor a registered preset (the message lists the
        presets).
    ValueError
        The YAML does not parse or has unknown keys (the message names the file and the key).
    """
    import yaml

    if isinstance(spec, dict):
        cfg = dict(spec)
        where = str(cfg.pop("_source", "config"))
    else:
        path = Path(spec)
        if not path.is_file():
            from pftrack.host import UnknownComponentError, get_host

            host = get_host()
            try:
                path = Path(host.get("preset", str(spec)))
            except UnknownComponentError:
                names = ", ".join(host.names("preset")) or "none"
                raise FileNotFoundError(f"config {spec}: no such file and no preset of that "
                                        f"name (presets: {names})") from None
        where = str(path)
        try:
            cfg = yaml.safe_load(path.read_text())
        except yaml.YAMLError as exc:
            raise ValueError(f"config {where}: not valid YAML: {exc}") from None
        if not isinstance(cfg, dict):
            raise ValueError(f"config {where}: expected a mapping at the top level")  # noqa: TRY004
    unknown = set(cfg) - CONFIG_KEYS
    if unknown:
        raise ValueError(f"config {where}: unknown keys {sorted(unknown)}; known: "
                         f"{sorted(CONFIG_KEYS)}")
    for key in ("motion", "likelihood"):
        if key not in cfg:
            raise ValueError(f"config {where}: missing {key!r}")
    if cfg.get("state", "world") not in ("world", "image"):
        raise ValueError(f"config {where}: state must be 'world' or 'image', got "
                         f"{cfg.get('state')!r}")
    for key, allowed in (("tracker", TRACKER_KEYS), ("births", BIRTH_KEYS)):
        bad = set(cfg.get(key) or {}) - allowed
        if bad:
            raise ValueError(f"config {where}: unknown {key} options {sorted(bad)}; known: "
                             f"{sorted(allowed)}")
    cfg["_source"] = where
    return cfg


def parse_frames(text: str | Sequence[int] | None) -> tuple[int, int | None]:
    """``"A:B"`` (inclusive, ground-truth numbering, 1-based) -> (A, B); ``"A:"`` -> (A, None)."""
    if text is None:
        return 1, None
    if not isinstance(text, str):
        a, b = text
        return int(a), None if b is None else int(b)
    a, sep, b = text.partition(":")
    try:
        first = int(a) if a.strip() else 1
        last = int(b) if b.strip() else None
    except ValueError:
        raise ValueError(f"--frames must look like A:B (1-based, inclusive), got {text!r}") from None
    if not sep:
        last = first
    if first < 1 or (last is not None and last < first):
        raise ValueError(f"--frames {text!r}: need 1 <= A <= B")
    return first, last


# --------------------------------------------------------------------------------------------
# Frames and ground truth
# --------------------------------------------------------------------------------------------


def iter_frames(video: str | os.PathLike[str], first: int = 1, last: int | None = None,
                ) -> Iterator[Frame]:
    """Stream frames ``first..last`` (ground-truth numbering: MOT frame N = video frame N-1)."""
    from pftrack.scenes.video import VideoScene

    yield from VideoScene(str(video), first=first, last=last).frames()


def video_fps(video: str | os.PathLike[str]) -> float:
    from pftrack.scenes.video import VideoScene

    return float(VideoScene(str(video)).fps)


def read_ground_truth(path: str | os.PathLike[str], first: int = 1,
                      last: int | None = None) -> np.ndarray:
    """MOT rows (M, 10) of frames ``first..last``."""
    from pftrack.io.mot import read_mot

    rows = read_mot(path)
    keep = rows[:, 0] >= first
    if last is not None:
        keep &= rows[:, 0] <= last
    return rows[keep]


# --------------------------------------------------------------------------------------------
# Detector
# --------------------------------------------------------------------------------------------


def build_detector(cfg: dict[str, Any], context: RunContext | None = None):
    """The configured detector (None when the configuration has none), built through the
    context's host and set up with the context (its camera, its detector model)."""
    spec = cfg.get("detector")
    if not spec:
        return None
    context = context or RunContext()
    spec = {"type": spec["type"], "params": dict(spec.get("params") or {})}
    det = context.get_host().build("detector", spec)
    det.setup(context)
    return det


def train_detector(video: str | os.PathLike[str], gt: str | os.PathLike[str],
                   frames: str | tuple[int, int | None], *, out: str | os.PathLike[str] | None,
                   cfg: dict[str, Any] | None = None, camera: Any = None,
                   params: dict[str, Any] | None = None, seed: int = 0,
                   progress: bool = False):
    """Train the configured detector on ground-truth boxes and save its model (``out``).

    Positives are the ground-truth rows with flag 1; flag-0 rows (partly hidden people) are
    neither positives nor negatives. Returns the fitted detector.
    """
    import numpy as np

    cfg = cfg or {"detector": {"type": "svm", "params": {}}}
    det_cfg = dict(cfg.get("detector") or {"type": "svm"})
    train_cfg = det_cfg.get("train") or {}
    merged = {**(det_cfg.get("params") or {}), **(train_cfg.get("params") or {}),
              **(params or {})}
    det_cfg = {"type": det_cfg.get("type", "svm"), "params": merged}
    det = build_detector({"detector": det_cfg}, RunContext(camera=_load_camera(camera)))
    first, last = parse_frames(frames)
    rows = read_ground_truth(gt, first, last)
    pos: dict[int, np.ndarray] = {}
    ign: dict[int, np.ndarray] = {}
    for f in np.unique(rows[:, 0]).astype(int):
        r = rows[rows[:, 0] == f]
        pos[int(f)] = r[r[:, 6] != 0, 2:6]
        ign[int(f)] = r[r[:, 6] == 0, 2:6]
    rng = np.random.default_rng(seed)
    frames_it = iter_frames(video, first, last)
    if progress:
        from tqdm.auto import tqdm

        n = (last - first + 1) if last is not None else None
        frames_it = tqdm(frames_it, total=n, desc="detector: training frames", unit="frame")
    det.fit(frames_it, pos, rng=rng, ignore_by_frame=ign)
    if out is not None:
        if not det.learns:
            raise ValueError(f"detector {det_cfg['type']!r} learns nothing to save")
        det.save(out)
    return det


# --------------------------------------------------------------------------------------------
# The tracking loop
# --------------------------------------------------------------------------------------------


@dataclass
class _Tentative:
    hits: int
    age: int
    records: list[TrackRecord] = field(default_factory=list)


def _box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    x0 = np.maximum(a[:, None, 0], b[None, :, 0])
    y0 = np.maximum(a[:, None, 1], b[None, :, 1])
    x1 = np.minimum(a[:, None, 0] + a[:, None, 2], b[None, :, 0] + b[None, :, 2])
    y1 = np.minimum(a[:, None, 1] + a[:, None, 3], b[None, :, 1] + b[None, :, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    union = (a[:, 2] * a[:, 3])[:, None] + (b[:, 2] * b[:, 3])[None, :] - inter
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)
    return np.nan_to_num(out)


class TrackingSession:
    """Seed 001's tracking loop: the tracker's per-target filters, births from confirmed
    detections, duplicate removal (see the module docstring).

    Parameters
    ----------
    tracker : MultiTargetTracker
        Built with ``birth_min_score=None`` (births are decided here).
    min_score : float
        Least detector score c(det) of a detection that may start a target.
    max_iou : float
        A detection overlapping a live target's box by more than this starts nothing.
    confirm_hits, confirm_window : int
        A tentative target is confirmed after ``confirm_hits`` matched detections within its
        first ``confirm_window`` frames (birth frame included), else dropped.
    merge_iou : float
        Confirmed targets overlapping by more than this: the younger is removed.
    merge_distance_m : float, optional
        With a ground-plane observation model: confirmed targets whose ground positions are
        closer than this (metres) are one person tracked twice and the younger is removed;
        ``merge_iou`` is then not used. Image overlap is the wrong test on the ground plane:
        two people one behind the other (a metre or more apart in depth) overlap in the
        image, and removing one of them loses a correctly tracked person.
    valid_region : callable, optional
        ``f(positions (N, 2)) -> bool (N,)``: births only where true.
    hide_after_misses : int, optional
        A live target is not output in frames where it has gone more than this many frames
        without a matched detection (it keeps being tracked and reappears when matched again):
        a coasting estimate is worth showing for a short occlusion, not once it may have drifted.
    appearance : dict, optional
        ``{bins, sigma, update_rate, region}``: keep a colour model per target (per-channel BGR
        histograms of its matched detections, ``bins`` per channel, running mean with
        ``update_rate``, over the ``region`` fractions of the box) and, before each frame's
        association, put ``target.appearance_scores`` = ``exp(-d^2 / (2 sigma^2))``
        with ``d`` the exact per-channel 1-D EMD (bins, / (bins - 1), channel mean) between the
        target's model and each detection; associators with ``appearance_weight > 0`` use it.
    """

    def __init__(self, tracker: MultiTargetTracker, *, min_score: float = 0.2,
                 max_iou: float = 0.3, confirm_hits: int = 3, confirm_window: int = 5,
                 merge_iou: float = 0.6, merge_distance_m: float | None = None,
                 valid_region: Any = None, hide_after_misses: int | None = None,
                 appearance: dict[str, Any] | None = None) -> None:
        if confirm_hits < 1 or confirm_window < confirm_hits:
            raise ValueError(f"births: need 1 <= confirm_hits <= confirm_window, got "
                             f"{confirm_hits}, {confirm_window}")
        self.tracker = tracker
        self.min_score = float(min_score)
        self.max_iou = float(max_iou)
        self.confirm_hits = int(confirm_hits)
        self.confirm_window = int(confirm_window)
        self.merge_iou = float(merge_iou)
        if merge_distance_m is not None and not float(merge_distance_m) > 0:
            raise ValueError(f"births.merge_distance_m must be > 0 metres or null, got "
                             f"{merge_distance_m!r}")
        self.merge_distance_m = None if merge_distance_m is None else float(merge_distance_m)
        self.valid_region = valid_region
        self.hide_after_misses = hide_after_misses
        if appearance is not None:
            bad = set(appearance) - APPEARANCE_KEYS
            if bad:
                raise ValueError(f"births.appearance: unknown options {sorted(bad)}; known: "
                                 f"{sorted(APPEARANCE_KEYS)}")
        self.appearance = appearance
        self.tentative: dict[int, _Tentative] = {}
        # each live target's colour model (per-channel histograms), by target id
        self.appearance_models_: dict[int, np.ndarray] = {}

    def _record(self, frame: Frame, t: Target) -> TrackRecord:
        obs = self.tracker.observation
        pos = t.state[list(self.tracker.motion.position_dims)]
        world = obs.world_position(t.state)
        return TrackRecord(frame=frame.index, id=t.id, box_xywh_px=t.box_xywh_px.copy(),
                           state=t.state.copy(), position=pos.copy(), extent=t.extent.copy(),
                           confidence=0.5,
                           world_m=None if world is None else np.asarray(world, float))

    # -- appearance ---------------------------------------------------------------------------

    def _histograms(self, frame: Frame, boxes: np.ndarray) -> np.ndarray:
        """Per-channel normalised histograms (K, 3, bins) of the boxes' regions (every pixel)."""
        opts = self.appearance or {}
        bins = int(opts.get("bins", 16))
        fx0, fy0, fx1, fy1 = opts.get("region", (0.15, 0.1, 0.85, 0.9))
        img = frame.image
        H, W = img.shape[:2]
        out = np.full((len(boxes), 3, bins), 1.0 / bins)
        for k, (x, y, w, h) in enumerate(np.asarray(boxes, dtype=np.float64)):
            x0, x1 = int(max(x + fx0 * w, 0)), int(min(x + fx1 * w, W))
            y0, y1 = int(max(y + fy0 * h, 0)), int(min(y + fy1 * h, H))
            if x1 <= x0 or y1 <= y0:
                continue
            q = (img[y0:y1, x0:x1].reshape(-1, 3).astype(np.int32) * bins) >> 8
            idx = (np.arange(3)[None, :] * bins + q).ravel()
            out[k] = np.bincount(idx, minlength=3 * bins).reshape(3, bins) / len(q)
        return out

    def _appearance_before(self, frame: Frame, detections: Detections | None) -> np.ndarray | None:
        if self.appearance is None or detections is None or len(detections) == 0:
            for t in self.tracker.targets:
                t.appearance_scores = None
            return None
        hists = self._histograms(frame, detections.boxes_xywh_px)
        sigma = float(self.appearance.get("sigma", 0.1))
        cdf = np.cumsum(hists, axis=-1)
        bins = hists.shape[-1]
        for t in self.tracker.targets:
            model = self.appearance_models_.get(t.id)
            if model is None:
                t.appearance_scores = None
                continue
            d = np.abs(cdf - np.cumsum(model, axis=-1)[None]).sum(axis=-1).mean(axis=1)
            d /= bins - 1
            t.appearance_scores = np.exp(-0.5 * (d / sigma) ** 2)
        return hists

    def _adapt_sizes(self) -> None:
        update = getattr(self.tracker.observation, "update_target", None)
        if update is None:
            return
        for t in self.tracker.targets:
            if t.detection is not None:
                update(t, t.detection.box_xywh_px)

    def _appearance_after(self, hists: np.ndarray | None) -> None:
        if hists is None:
            return
        a = float(self.appearance.get("update_rate", 0.1))
        models = self.appearance_models_
        for t in self.tracker.targets:
            if t.detection is None:
                continue
            h = hists[t.detection.index]
            old = models.get(t.id)
            models[t.id] = h.copy() if old is None else (1 - a) * old + a * h

    def _duplicates(self, targets: list[Target]) -> np.ndarray | None:
        """Boolean (T, T): pairs of targets that are one person (None: no test configured)."""
        obs = self.tracker.observation
        if self.merge_distance_m is not None:
            world = [obs.world_position(t.state) for t in targets]
            if all(w is not None for w in world):
                xy = np.array([np.asarray(w, dtype=np.float64)[:2] for w in world])
                d = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=2)
                return d < self.merge_distance_m
        if self.merge_iou >= 1.0:
            return None
        boxes = np.array([t.box_xywh_px for t in targets])
        return _box_iou(boxes, boxes) > self.merge_iou

    def step(self, frame: Frame, detections: Detections | None) -> list[TrackRecord]:
        """One frame; returns the records to output now (confirmed targets, plus the buffered
        records of targets confirmed in this frame)."""
        tr = self.tracker
        hists = self._appearance_before(frame, detections)
        records = tr.step(frame, detections)
        self._appearance_after(hists)
        self._adapt_sizes()
        live = {t.id: t for t in tr.targets}
        out: list[TrackRecord] = []
        by_id = {r.id: r for r in records}
        matched = {t.detection.index for t in live.values() if t.detection is not None}
        # tentative targets: count hits, confirm or drop
        for tid in list(self.tentative):
            tent = self.tentative[tid]
            if tid not in live:
                del self.tentative[tid]
                continue
            tent.age += 1
            tent.hits += int(live[tid].detection is not None)
            if tid in by_id:
                tent.records.append(by_id[tid])
            if tent.hits >= self.confirm_hits:
                out.extend(tent.records)
                del self.tentative[tid]
            elif tent.age >= self.confirm_window:
                tr.remove_target(tid)
                del self.tentative[tid]
                live.pop(tid, None)
        hide = self.hide_after_misses
        for r in records:
            if (r.id in live and r.id not in self.tentative and r not in out
                    and (hide is None or live[r.id].misses <= hide)):
                out.append(r)
        # duplicates among confirmed targets
        confirmed = [t for t in live.values() if t.id not in self.tentative]
        same = self._duplicates(confirmed) if len(confirmed) > 1 else None
        if same is not None:
            gone: set[int] = set()
            for i, j in zip(*np.nonzero(np.triu(same, 1))):
                a, b = confirmed[i], confirmed[j]
                if a.id in gone or b.id in gone:
                    continue
                young = a if (a.age, -a.id) < (b.age, -b.id) else b
                gone.add(young.id)
            for tid in gone:
                tr.remove_target(tid)
                live.pop(tid, None)
            out = [r for r in out if r.id not in gone or r.frame != frame.index]
        # births
        if detections is not None and len(detections):
            cand = [i for i in range(len(detections))
                    if i not in matched and detections.scores[i] >= self.min_score]
            cand.sort(key=lambda i: -detections.scores[i])
            taken = [t.box_xywh_px for t in live.values()]
            for i in cand:
                box = detections.boxes_xywh_px[i]
                if taken and _box_iou(box, np.array(taken)).max() > self.max_iou:
                    continue
                pos = tr.observation.position_from_box(box)
                if not np.all(np.isfinite(pos)):
                    continue
                if self.valid_region is not None and not self.valid_region(pos[None])[0]:
                    continue
                t = tr.add_target(frame, box_xywh_px=box)
                t.frames_tracked = 1
                if hists is not None:
                    self.appearance_models_[t.id] = hists[i].copy()
                taken.append(t.box_xywh_px)
                rec = self._record(frame, t)
                if self.confirm_hits <= 1:
                    out.append(rec)
                else:
                    self.tentative[t.id] = _Tentative(hits=1, age=1, records=[rec])
        for tid in [tid for tid in self.appearance_models_ if tid not in live
                    and tid not in {t.id for t in tr.targets}]:
            del self.appearance_models_[tid]  # the target died
        return out


class ExternalDetector(Detector):
    """Stands in the tracker's ``detector`` slot when detections are computed outside it (timed
    separately, or reused across runs) and handed to ``step(frame, detections)``: it marks the
    tracker as detection-driven, so a frame supports a target only through a matched detection
    (``max_misses`` counts frames without one). It never detects anything itself."""

    def detect(self, frame: Frame) -> Detections:
        return Detections.empty()


def _valid_region(rect: Sequence[float] | None):
    if rect is None:
        return None
    x0, x1, y0, y1 = (float(v) for v in rect)
    if not (x0 < x1 and y0 < y1):
        raise ValueError(f"valid_region_m must be [x0, x1, y0, y1] with x0 < x1, y0 < y1, got "
                         f"{rect}")

    def inside(p: np.ndarray) -> np.ndarray:
        p = np.asarray(p, dtype=np.float64)
        return (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)

    return inside


def build_session(cfg: dict[str, Any], *, camera: Any = None, fps: float = 25.0,
                  seed: int = 0) -> TrackingSession:
    """Build motion, likelihood, associator and observation from ``cfg`` through the host and
    wrap them in a :class:`TrackingSession` (the detector is run separately)."""
    from pftrack.host import get_host
    from pftrack.tracker import ImageBoxObservation

    host = get_host()
    state = cfg.get("state", "world")
    obs_params = dict(cfg.get("observation") or {})
    if state == "world":
        if camera is None:
            raise ValueError(f"config {cfg.get('_source', '')}: state 'world' needs a camera "
                             "(--camera PATH)")
        from pftrack.observation_world import CameraBoxObservation

        observation = CameraBoxObservation(camera, **obs_params)
    else:
        observation = ImageBoxObservation(**obs_params)
    motion = host.build("motion", cfg["motion"])
    likelihood = host.build("likelihood", cfg["likelihood"])
    associator = host.build("associator", cfg["associator"]) if cfg.get("associator") else None
    context = RunContext(host=host, camera=camera, fps=float(fps))
    for component in (motion, likelihood, associator):
        if component is not None:
            component.setup(context)
    topts = dict(cfg.get("tracker") or {})
    dt = topts.pop("dt", "auto")
    dt = 1.0 / float(fps) if dt in (None, "auto") else float(dt)
    valid = _valid_region(cfg.get("valid_region_m"))
    tracker = MultiTargetTracker(motion, likelihood, observation, dt=dt, associator=associator,
                                 detector=ExternalDetector() if associator is not None else None,
                                 birth_min_score=None, valid_region=valid,
                                 rng=np.random.default_rng(seed), **topts)
    births = dict(cfg.get("births") or {})
    return TrackingSession(tracker, valid_region=valid, **births)


# --------------------------------------------------------------------------------------------
# Evaluation
# --------------------------------------------------------------------------------------------


def _matched_world_errors(gt: np.ndarray, tracks: np.ndarray, iou_threshold: float = 0.5
                          ) -> np.ndarray:
    """Ground-plane distances (m) of gt/track rows matched per frame (Hungarian on IoU >= thr)."""
    from scipy.optimize import linear_sum_assignment

    errs = []
    tf = tracks[:, 0].astype(int)
    for f in np.unique(gt[:, 0]).astype(int):
        g = gt[gt[:, 0] == f]
        t = tracks[tf == f]
        if len(g) == 0 or len(t) == 0:
            continue
        iou = _box_iou(g[:, 2:6], t[:, 2:6])
        r, c = linear_sum_assignment(-iou)
        ok = iou[r, c] >= iou_threshold
        d = np.linalg.norm(g[r[ok], 7:9] - t[c[ok], 7:9], axis=1)
        errs.append(d)
    return np.concatenate(errs) if errs else np.zeros(0)


def evaluate_tracks(gt_rows: np.ndarray, track_rows: np.ndarray) -> dict[str, Any]:
    """MOTA, IDF1, HOTA on image boxes (IoU 0.5), ground-plane error of matched boxes (median,
    p90, metres; when the tracks carry world columns) and seed 001's accuracy (projected foot
    point within 5 px of the ground-truth foot point, averaged over people)."""
    from pftrack.io.mot import has_world
    from pftrack.metrics import accuracy_within, evaluate, points_by_target

    out: dict[str, Any] = {}
    tracks = np.asarray(track_rows, dtype=np.float64).reshape(-1, 10)
    gt = np.asarray(gt_rows, dtype=np.float64).reshape(-1, 10)
    m = evaluate(gt, tracks, metric="iou", threshold=0.5)
    out.update({k: m[k] for k in ("MOTA", "IDF1", "HOTA", "MOTP", "IDSW", "FP", "FN", "TP",
                                  "Recall", "Precision", "DetA", "AssA", "num_tracker_ids",
                                  "num_gt_ids") if k in m})
    visible = gt[gt[:, 6] != 0]
    if len(tracks) and np.all(has_world(tracks)):
        e = _matched_world_errors(visible, tracks)
        out["median_error_m"] = float(np.median(e)) if len(e) else float("nan")
        out["p90_error_m"] = float(np.percentile(e, 90)) if len(e) else float("nan")
        out["n_world_pairs"] = len(e)
    else:
        out["median_error_m"] = out["p90_error_m"] = float("nan")
    if len(tracks):
        pts = points_by_target(visible, tracks, id_map="match", point="foot")
        acc, _ = accuracy_within(pts["estimated_px"], pts["truth_px"], 5.0)
        out["accuracy_5px"] = float(acc)
    else:
        out["accuracy_5px"] = 0.0
    return out


# --------------------------------------------------------------------------------------------
# Whole runs
# --------------------------------------------------------------------------------------------


@dataclass
class RunResult:
    """What :func:`run_pipeline` produced.

    ``rows``: MOT rows (M, 10) sorted by frame and id; ``detections``: per frame (reusable by
    another run on the same frames); ``timing``: seconds per frame for detection and tracking;
    ``metrics``: :func:`evaluate_tracks` when ground truth was given.
    """

    rows: np.ndarray
    detections: dict[int, Detections]
    timing: dict[str, float]
    metrics: dict[str, Any] | None = None
    out_dir: Path | None = None
    n_frames: int = 0


def _load_camera(camera: Any) -> Any:
    if camera is None or not isinstance(camera, (str, os.PathLike)):
        return camera
    from pftrack.geometry.formats import load_camera

    return load_camera(camera)


def run_pipeline(config: str | os.PathLike[str] | dict[str, Any], *, video: str | os.PathLike[str],
                 camera: Any = None, out_dir: str | os.PathLike[str] | None = None,
                 gt: str | os.PathLike[str] | None = None,
                 frames: str | tuple[int, int | None] | None = None,
                 detector_model: str | os.PathLike[str] | None = None, seed: int = 0,
                 detections: dict[int, Detections] | None = None, progress: bool = True,
                 report: bool = True) -> RunResult:
    """Track ``video`` with ``config`` and write ``out_dir/tracks.txt`` (and ``metrics.json``
    with ground truth, ``report/*.png``).

    Parameters
    ----------
    detections : dict {frame: Detections}, optional
        Precomputed detections (another run's ``RunResult.detections``): the detector is not run.
    """
    cfg = load_config(config)
    cam = _load_camera(camera)
    video = Path(video)
    if not video.is_file():
        raise FileNotFoundError(f"video {video} not found")
    first, last = parse_frames(frames)
    fps = video_fps(video)
    session = build_session(cfg, camera=cam, fps=fps, seed=seed)
    detector = None
    if detections is None and cfg.get("detector"):
        detector = build_detector(cfg, RunContext(camera=cam, fps=fps, detector_model=(
            None if detector_model is None else str(detector_model))))
    frame_iter: Iterable[Frame] = iter_frames(video, first, last)
    n_total = None
    if last is not None:
        n_total = last - first + 1
    if progress:
        from tqdm.auto import tqdm

        frame_iter = tqdm(frame_iter, total=n_total, desc=f"pftrack run {cfg.get('name', '')}",
                          unit="frame", leave=False)
    records: list[TrackRecord] = []
    dets_out: dict[int, Detections] = {}
    t_det = t_trk = c_det = c_trk = 0.0
    n = 0
    keep_frames: dict[int, np.ndarray] = {}
    want = _report_frames(first, last) if (report and out_dir is not None) else set()
    t_start, c_start = time.perf_counter(), time.process_time()
    for frame in frame_iter:
        t0, c0 = time.perf_counter(), time.process_time()
        if detections is not None:
            d = detections.get(frame.index, Detections.empty())
        elif detector is not None:
            d = detector.detect(frame)
        else:
            d = None
        t1, c1 = time.perf_counter(), time.process_time()
        records.extend(session.step(frame, d))
        t2, c2 = time.perf_counter(), time.process_time()
        t_det += t1 - t0
        t_trk += t2 - t1
        c_det += c1 - c0
        c_trk += c2 - c1
        n += 1
        if d is not None:
            dets_out[frame.index] = d
        if frame.index in want:
            keep_frames[frame.index] = frame.image.copy()
    t_loop = time.perf_counter() - t_start
    c_loop = time.process_time() - c_start
    rows = records_to_mot(records)
    if len(rows):
        rows = rows[np.lexsort((rows[:, 1], rows[:, 0]))]
    n = max(n, 1)
    # frames per second of the whole loop: decoding, detection and tracking (not the report).
    # Wall time, and the process's CPU time (the same on an idle core; on a shared, loaded
    # machine the CPU time is the one-core cost and the wall time includes waiting for a core).
    timing = {"detection_s_per_frame": t_det / n, "tracking_s_per_frame": t_trk / n,
              "frames_per_second": n / max(t_loop, 1e-12),
              "detection_cpu_s_per_frame": c_det / n, "tracking_cpu_s_per_frame": c_trk / n,
              "frames_per_second_cpu": n / max(c_loop, 1e-12)}
    metrics = None
    gt_rows = None
    if gt is not None:
        gt_rows = read_ground_truth(gt, first, last if last is not None else 10**9)
        metrics = evaluate_tracks(gt_rows, rows)
        metrics.update(timing)
    result = RunResult(rows, dets_out, timing, metrics, None, n)
    if out_dir is not None:
        result.out_dir = write_outputs(out_dir, cfg, result, cam, keep_frames, gt_rows)
    return result


def _report_frames(first: int, last: int | None) -> set[int]:
    """Frames kept for the report: the first, about 5 s (50 frames) later, and the last."""
    out = {first, first + 50}
    if last is not None:
        out |= {last, (first + last) // 2}
    return out


def write_outputs(out_dir: str | os.PathLike[str], cfg: dict[str, Any], result: RunResult,
                  camera: Any, frames: dict[int, np.ndarray],
                  gt_rows: np.ndarray | None) -> Path:
    """``tracks.txt``, ``metrics.json`` (with ground truth) and ``report/*.png``, atomically."""
    import json

    from pftrack.io.atomic import atomic_write_text
    from pftrack.io.mot import write_mot

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_mot(out / "tracks.txt", result.rows)  # no tracks: an empty file, still a result
    if result.metrics is not None:
        atomic_write_text(out / "metrics.json",
                          json.dumps(result.metrics, indent=2, default=float) + "\n")
    if frames:
        from pftrack.report_world import write_report

        write_report(out / "report", result.rows, frames, camera=camera, gt_rows=gt_rows,
                     title=str(cfg.get("name", "")))
    return out
