"""Track management for detection-driven runs: which detections start targets, when a new
target is believed, which two targets are one object, and what is output.

* :class:`DetectionBirthTracks` (``births``): every unmatched detection at least ``min_score``
  confident starts a target, output at once.
* :class:`ConfirmedTracks` (``confirmed``, the soccer paper on real video): an unmatched detection
  at least ``min_score`` confident, overlapping no live target by more than ``max_iou``, starts a
  *tentative* target; it is confirmed once ``confirm_hits`` of its first ``confirm_window`` frames
  had a matched detection, and then its records from birth on are output (confirmation costs no
  frames); otherwise it is dropped unseen. Two confirmed targets that are one object tracked twice
  (ground positions closer than ``merge_distance_m`` with a world frame, else boxes overlapping by
  more than ``merge_iou``): the younger is removed. Optionally each target keeps a colour model
  (Breitenstein et al.'s track-specific appearance) that the associator reads as
  ``Target.appearance_scores``.

Both run inside the one engine, :class:`pftrack.tracker.MultiTargetTracker`, as its ``tracks``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pftrack.components import Detections, Frame, Target, TrackManager, TrackRecord
from pftrack.geometry.boxes import box_iou, iou_matrix

__all__ = ["ConfirmedTracks", "DetectionBirthTracks"]

APPEARANCE_KEYS = {"bins", "sigma", "update_rate", "region"}


class DetectionBirthTracks(TrackManager):
    """Every unmatched detection scoring at least ``min_score`` starts a target (in detection
    order), output from its first frame on.

    Parameters
    ----------
    min_score : float
        Least detector score c(det) of a detection that starts a target. Unit: detector score.
    """

    def __init__(self, min_score: float = 0.5) -> None:
        self.min_score = min_score

    def after_frame(self, engine: Any, frame: Frame, detections: Detections | None,
                    records: list[TrackRecord], unmatched_detections: np.ndarray,
                    ) -> list[TrackRecord]:
        if detections is None:
            return records
        for di in unmatched_detections:
            if detections.scores[di] >= self.min_score:
                t = engine.add_target(frame, box_xywh_px=detections.boxes_xywh_px[di])
                t.frames_tracked = 1
                records.append(engine.record(frame, t))
        return records


@dataclass
class _Tentative:
    hits: int
    age: int
    records: list[TrackRecord] = field(default_factory=list)


class ConfirmedTracks(TrackManager):
    """Births from confirmed detections, duplicate removal, an optional appearance model (see
    the module docstring).

    Parameters
    ----------
    min_score : float
        Least detector score c(det) of a detection that may start a target. Unit: detector score.
    max_iou : float
        A detection overlapping a live target's box by more than this starts nothing. Unit: 1.
    confirm_hits : int
        A tentative target is confirmed after ``confirm_hits`` matched detections within its
        first ``confirm_window`` frames (birth frame included), else dropped. Unit: count.
    confirm_window : int
        The frames, from its birth frame on, in which a tentative target must reach
        ``confirm_hits`` matched detections. Unit: frames.
    merge_iou : float
        Confirmed targets overlapping by more than this: the younger is removed (1 or more: no
        merging by overlap). Unit: 1.
    merge_distance_m : float, optional
        With a ground-plane observation model: confirmed targets whose ground positions are
        closer than this (metres) are one object tracked twice and the younger is removed;
        ``merge_iou`` is then not used. Image overlap is the wrong test on the ground plane:
        two people one behind the other (a metre or more apart in depth) overlap in the
        image, and removing one of them loses a correctly tracked person. Unit: m.
    hide_after_misses : int, optional
        A live target is not output in frames where it has gone more than this many frames
        without a matched detection (it keeps being tracked and reappears when matched again).
        Unit: frames.
    end_at_border : bool
        A confirmed target that has missed its detection ends at once when its box, or the box
        it would have walking on at the velocity it had at its last matched detection (for the
        frames it has missed, ``dt`` each), is not wholly inside the image: its object is
        walking out of the picture. No constant: a detector's boxes lie inside the image, so a
        box reaching past the border with no detection is an object partly gone, and an object
        whose own motion carried it out is gone even when its target was held back inside (by
        neighbours' detections or colour), where it would wait hidden and take over the next
        object entering at that edge. The walking-on box needs a motion model with
        ``velocity_dims`` (constant velocity or acceleration; the acceleration is not
        extrapolated); without, only the target's own box is tested. False: only the engine's
        ``max_misses`` and out-of-view tests end a target.
    hidden_reid : bool
        With ``appearance`` and ``hide_after_misses``: a hidden target (more than
        ``hide_after_misses`` misses) may take a detection only if the detection looks more like
        it than like any other target with a colour model (its appearance score is the
        highest of the targets'), so a person returning is re-identified by colour, and someone
        else walking where a hidden target waits starts a track of their own. No constant. The
        barred pairs get ``appearance_scores`` NaN, which associators treat as "no match".
    box_from_detection : float
        Weight ``w`` (0-1) of a target's matched detection in its output box: in a frame
        where the target matched a detection its record's box is ``(1 - w) * estimate's box
        + w * detection's box`` (0: the estimate's box alone, as before). Only the output
        box; the state, its world position and what the next frame predicts are the
        filter's own. A projected estimate's box carries the model's errors (the assumed
        height and width ratio, the camera's tilt); the detector's box follows the person's
        own outline. Unit: 1.
    box_min_iou : float
        ``box_from_detection`` moves a box only towards a detection that overlaps it by at
        least this intersection over union: a detection the associator matched from further
        away (it gates by distance) may be someone else's, and pulling the output onto it
        would write that mistake into the tracks. Unit: 1.
    appearance : dict, optional
        ``{bins, sigma, update_rate, region}``: keep a colour model per target (per-channel BGR
        histograms of its matched detections, ``bins`` per channel, running mean with
        ``update_rate``, over the ``region`` fractions of the box) and, before each frame's
        association, set ``target.appearance_scores`` = ``exp(-d^2 / (2 sigma^2))`` with ``d``
        the exact per-channel 1-D EMD (bins, / (bins - 1), channel mean) between the target's
        model and each detection; associators with an appearance term read it.

    Births happen only where the engine's ``valid_region`` (if any) holds.

    Attributes
    ----------
    tentative_ : dict[int, _Tentative]
        Targets not yet confirmed, by id, with their buffered records.
    appearance_models_ : dict[int, ndarray (3, bins)]
        Each live target's colour model, by id.
    """

    def __init__(self, min_score: float = 0.2, max_iou: float = 0.3, confirm_hits: int = 3,
                 confirm_window: int = 5, merge_iou: float = 0.6,
                 merge_distance_m: float | None = None, hide_after_misses: int | None = None,
                 end_at_border: bool = False, hidden_reid: bool = False,
                 appearance: dict[str, Any] | None = None,
                 box_from_detection: float = 0.0, box_min_iou: float = 0.3) -> None:
        self.min_score = min_score
        self.max_iou = max_iou
        self.confirm_hits = confirm_hits
        self.confirm_window = confirm_window
        self.merge_iou = merge_iou
        self.merge_distance_m = merge_distance_m
        self.hide_after_misses = hide_after_misses
        self.end_at_border = end_at_border
        self.hidden_reid = hidden_reid
        self.appearance = appearance
        self.box_from_detection = box_from_detection
        self.box_min_iou = box_min_iou

    def setup(self, context: Any) -> None:
        """Validate the parameters (``__init__`` only stores them)."""
        self._check()

    def _check(self) -> None:
        if "checked_" in self.__dict__:
            return
        if self.confirm_hits < 1 or self.confirm_window < self.confirm_hits:
            raise ValueError(f"tracks: need 1 <= confirm_hits <= confirm_window, got "
                             f"{self.confirm_hits}, {self.confirm_window}")
        if self.merge_distance_m is not None and not float(self.merge_distance_m) > 0:
            raise ValueError(f"tracks.merge_distance_m must be > 0 metres or null, got "
                             f"{self.merge_distance_m!r}")
        if self.hidden_reid and (self.appearance is None or self.hide_after_misses is None):
            raise ValueError("tracks.hidden_reid needs tracks.appearance and "
                             "tracks.hide_after_misses")
        w = self.box_from_detection
        if isinstance(w, bool) or not isinstance(w, (int, float)) or not 0.0 <= w <= 1.0:
            raise ValueError(f"tracks.box_from_detection must be a number in [0, 1], got {w!r}")
        m = self.box_min_iou
        if isinstance(m, bool) or not isinstance(m, (int, float)) or not 0.0 <= m <= 1.0:
            raise ValueError(f"tracks.box_min_iou must be a number in [0, 1], got {m!r}")
        if self.appearance is not None:
            bad = set(self.appearance) - APPEARANCE_KEYS
            if bad:
                raise ValueError(f"tracks.appearance: unknown options {sorted(bad)}; known: "
                                 f"{sorted(APPEARANCE_KEYS)}")
        self.checked_ = True

    # -- per-target state ---------------------------------------------------------------------

    @property
    def tentative_(self) -> dict[int, _Tentative]:
        return self.__dict__.setdefault("_tentative", {})

    @property
    def appearance_models_(self) -> dict[int, np.ndarray]:
        return self.__dict__.setdefault("_appearance_models", {})

    @property
    def last_matched_(self) -> dict[int, np.ndarray]:
        """Each confirmed target's state at its last matched detection (``end_at_border``)."""
        return self.__dict__.setdefault("_last_matched", {})

    def end_target(self, target: Target) -> None:
        self.tentative_.pop(target.id, None)
        self.last_matched_.pop(target.id, None)
        self.appearance_models_.pop(target.id, None)

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

    def before_frame(self, engine: Any, frame: Frame, detections: Detections | None) -> None:
        """Histograms of the frame's detections and each target's appearance scores."""
        self.hists_ = None
        if self.appearance is None or detections is None or len(detections) == 0:
            for t in engine.targets:
                t.appearance_scores = None
            return
        hists = self._histograms(frame, detections.boxes_xywh_px)
        sigma = float(self.appearance.get("sigma", 0.1))
        cdf = np.cumsum(hists, axis=-1)
        bins = hists.shape[-1]
        for t in engine.targets:
            model = self.appearance_models_.get(t.id)
            if model is None:
                t.appearance_scores = None
                continue
            d = np.abs(cdf - np.cumsum(model, axis=-1)[None]).sum(axis=-1).mean(axis=1)
            d /= bins - 1
            t.appearance_scores = np.exp(-0.5 * (d / sigma) ** 2)
        if self.hidden_reid:
            self._bar_hidden(engine.targets)
        self.hists_ = hists

    def _bar_hidden(self, targets: list[Target]) -> None:
        """``hidden_reid``: NaN in a hidden target's appearance scores where another target
        looks more like the detection."""
        scored = [t for t in targets if t.appearance_scores is not None]
        hide = int(self.hide_after_misses)  # type: ignore[arg-type]
        hidden = [k for k, t in enumerate(scored) if t.misses > hide]
        if not hidden or len(scored) < 2:
            return
        A = np.array([t.appearance_scores for t in scored])  # (T, K)
        best = A.max(axis=0)
        for k in hidden:
            t = scored[k]
            t.appearance_scores = np.where(A[k] < best, np.nan, A[k])

    def _update_appearance(self, targets: list[Target]) -> None:
        hists = getattr(self, "hists_", None)
        if hists is None:
            return
        a = float(self.appearance.get("update_rate", 0.1))
        models = self.appearance_models_
        for t in targets:
            if t.detection is None:
                continue
            h = hists[t.detection.index]
            old = models.get(t.id)
            models[t.id] = h.copy() if old is None else (1 - a) * old + a * h

    # -- duplicates ---------------------------------------------------------------------------

    def _duplicates(self, engine: Any, targets: list[Target]) -> np.ndarray | None:
        """Boolean (T, T): pairs of targets that are one object (None: no test configured)."""
        obs = engine.observation
        if self.merge_distance_m is not None:
            world = [obs.world_position(t.state) for t in targets]
            if all(w is not None for w in world):
                xy = np.array([np.asarray(w, dtype=np.float64)[:2] for w in world])
                d = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=2)
                return d < float(self.merge_distance_m)
        if self.merge_iou >= 1.0:
            return None
        boxes = np.array([t.box_xywh_px for t in targets])
        return iou_matrix(boxes, boxes) > self.merge_iou

    # -- one frame ----------------------------------------------------------------------------

    def after_frame(self, engine: Any, frame: Frame, detections: Detections | None,
                    records: list[TrackRecord], unmatched_detections: np.ndarray,
                    ) -> list[TrackRecord]:
        """Confirm or drop tentative targets, output, remove duplicates, start new targets."""
        self._check()
        live = {t.id: t for t in engine.targets}
        self._update_appearance(list(live.values()))
        if self.box_from_detection > 0.0:
            self._boxes_from_detections(records, live)
        tentative = self.tentative_
        out: list[TrackRecord] = []
        by_id = {r.id: r for r in records}
        matched = {t.detection.index for t in live.values() if t.detection is not None}
        for tid in list(tentative):
            tent = tentative[tid]
            if tid not in live:
                del tentative[tid]
                continue
            tent.age += 1
            tent.hits += int(live[tid].detection is not None)
            if tid in by_id:
                tent.records.append(by_id[tid])
            if tent.hits >= self.confirm_hits:
                out.extend(tent.records)
                del tentative[tid]
            elif tent.age >= self.confirm_window:
                engine.remove_target(tid)
                live.pop(tid, None)
        if self.end_at_border:
            self._end_at_border(engine, frame, live, tentative)
        hide = self.hide_after_misses
        for r in records:
            if (r.id in live and r.id not in tentative and r not in out
                    and (hide is None or live[r.id].misses <= hide)):
                out.append(r)
        confirmed = [t for t in live.values() if t.id not in tentative]
        same = self._duplicates(engine, confirmed) if len(confirmed) > 1 else None
        if same is not None:
            gone: set[int] = set()
            for i, j in zip(*np.nonzero(np.triu(same, 1))):
                a, b = confirmed[i], confirmed[j]
                if a.id in gone or b.id in gone:
                    continue
                young = a if (a.age, -a.id) < (b.age, -b.id) else b
                gone.add(young.id)
            for tid in gone:
                engine.remove_target(tid)
                live.pop(tid, None)
            out = [r for r in out if r.id not in gone or r.frame != frame.index]
        if detections is not None and len(detections):
            self._births(engine, frame, detections, matched, live, out)
        return out

    def _boxes_from_detections(self, records: list[TrackRecord], live: dict[int, Target]
                               ) -> None:
        """Move each output box of a target matched this frame towards its detection's box
        (``box_from_detection``) when the two overlap by ``box_min_iou`` or more."""
        pairs = [(r, live[r.id].detection) for r in records
                 if r.id in live and live[r.id].detection is not None]
        if not pairs:
            return
        est = np.array([r.box_xywh_px for r, _ in pairs], dtype=np.float64)
        det = np.array([d.box_xywh_px for _, d in pairs], dtype=np.float64)
        w = float(self.box_from_detection)
        ok = box_iou(est, det) >= float(self.box_min_iou)
        for (r, _), ok_r, d in zip(pairs, ok, det, strict=True):
            if ok_r:  # each record owns its box (a copy of the target's)
                r.box_xywh_px[:] = (1.0 - w) * r.box_xywh_px + w * d

    def _end_at_border(self, engine: Any, frame: Frame, live: dict[int, Target],
                       tentative: dict[int, _Tentative]) -> None:
        """End the confirmed targets that missed their detection and whose box, or whose box
        walked on from their last matched state, is not wholly inside the image
        (``end_at_border``); remember the matched ones' states."""
        last = self.last_matched_
        cand = []
        for t in live.values():
            if t.id in tentative:
                continue
            if t.detection is not None:
                last[t.id] = np.array(t.state, dtype=np.float64)
            elif t.misses > 0:
                cand.append(t)
        if not cand:
            return
        # each candidate's own box, then the walking-on boxes (the same target may come twice)
        boxes = [np.asarray(t.box_xywh_px, dtype=np.float64) for t in cand]
        vel = getattr(engine.motion, "velocity_dims", None)
        if vel is not None:
            pos = list(engine.motion.position_dims)
            vel = list(vel)
            own = list(cand)
            for t in own:
                s0 = last.get(t.id)
                if s0 is None:
                    continue
                s = s0.copy()
                s[pos] = s0[pos] + s0[vel] * (float(engine.dt) * int(t.misses))
                boxes.append(np.asarray(engine.observation.to_boxes(s[None], t)[0],
                                        dtype=np.float64))
                cand.append(t)
        img_w, img_h = frame.size_wh
        b = np.array(boxes).reshape(-1, 4)
        with np.errstate(invalid="ignore"):
            out = ((b[:, 0] < 0) | (b[:, 1] < 0) | (b[:, 0] + b[:, 2] > img_w)
                   | (b[:, 1] + b[:, 3] > img_h))
        for t in {t.id: t for t, o in zip(cand, out, strict=True) if o}.values():
            engine.remove_target(t.id)
            live.pop(t.id, None)

    def _births(self, engine: Any, frame: Frame, detections: Detections, matched: set[int],
                live: dict[int, Target], out: list[TrackRecord]) -> None:
        cand = [i for i in range(len(detections))
                if i not in matched and detections.scores[i] >= self.min_score]
        cand.sort(key=lambda i: -detections.scores[i])
        taken = [t.box_xywh_px for t in live.values()]
        hists = getattr(self, "hists_", None)
        valid = engine.valid_region
        for i in cand:
            box = detections.boxes_xywh_px[i]
            if taken and iou_matrix(box, np.array(taken)).max() > self.max_iou:
                continue
            pos = engine.observation.position_from_box(box)
            if not np.all(np.isfinite(pos)):
                continue
            if valid is not None and not valid(pos[None])[0]:
                continue
            t = engine.add_target(frame, box_xywh_px=box)
            t.frames_tracked = 1
            if hists is not None:
                self.appearance_models_[t.id] = hists[i].copy()
            taken.append(t.box_xywh_px)
            rec = engine.record(frame, t)
            if self.confirm_hits <= 1:
                out.append(rec)
            else:
                self.tentative_[t.id] = _Tentative(hits=1, age=1, records=[rec])
