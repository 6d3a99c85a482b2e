"""Lifecycle stages for detection-driven runs, and the named track managers built from them.

Stages (plugin kind ``stage``; :mod:`pftrack.engine.lifecycle` says in which order the roles run):

* ``unmatched-births`` (initiator): every detection the associator left unmatched, at least
  ``min_score`` confident, starts a track, in detection order.
* ``detection-births`` (initiator): a detection no surviving track explains, at least
  ``min_score`` confident, overlapping no live track by more than ``max_iou``, inside the run's
  valid region, starts a track; most confident first.
* ``hit-confirmation`` (confirmer): a new track is confirmed once ``confirm_hits`` of its first
  ``confirm_window`` frames had a matched detection, and its records from birth on are output
  (confirmation costs no frames); otherwise it ends unseen.
* ``border-exit`` (terminator): a confirmed track that missed its detection ends when its box,
  or its box walked on at its last matched velocity, is not wholly inside the image.
* ``duplicate-merge`` (merger): two confirmed tracks that are one object tracked twice (ground
  positions closer than ``merge_distance_m`` with a world frame, else boxes overlapping by more
  than ``merge_iou``): the younger ends.
* ``colour-reid`` (reidentifier): each track keeps a colour model (Breitenstein et al.'s
  track-specific appearance) that the associator reads as ``Target.appearance_scores``.
* ``output-boxes`` (reporter): hides tracks that have gone a while without a detection, and
  moves output boxes towards matched detections.

Named track managers, each a fixed list of these stages built from its parameters:

* :class:`DetectionBirthTracks` (``births``): ``unmatched-births``.
* :class:`ConfirmedTracks` (``confirmed``, the soccer paper on real video): ``colour-reid`` (with
  ``appearance``), ``output-boxes``, ``hit-confirmation``, ``border-exit`` (with
  ``end_at_border``), ``duplicate-merge``, ``detection-births``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pftrack.contracts.components import Param, RunContext
from pftrack.contracts.stages import (
    AppearanceScores,
    Birth,
    Confirm,
    Confirmer,
    End,
    FrameView,
    Hide,
    Initiator,
    LifecycleStage,
    Merger,
    OutputBox,
    Reidentifier,
    Reporter,
    Terminator,
    TrackView,
)
from pftrack.engine.lifecycle import LifecycleTracks
from pftrack.geometry.boxes import box_iou, iou_matrix

__all__ = ["BorderTerminator", "ColourReidentifier", "ConfirmedTracks", "DetectionBirthInitiator",
           "DetectionBirthTracks", "DuplicateMerger", "HitConfirmer", "OutputBoxReporter",
           "UnmatchedBirthInitiator"]

APPEARANCE_KEYS = {"bins", "sigma", "update_rate", "region"}


# --------------------------------------------------------------------------------------------
# Initiators
# --------------------------------------------------------------------------------------------


class UnmatchedBirthInitiator(Initiator):
    """Every detection the associator matched to no track, scoring at least ``min_score``,
    starts a track (in detection order).

    {params}
    """

    min_score: float = Param(0.5, "Least detector score c(det) of a detection that starts a "
                             "track.", unit="detector score")

    def initiate(self, view: FrameView) -> list[Birth]:
        d = view.detections
        if d is None:
            return []
        return [Birth(box_xywh_px=d.boxes_xywh_px[i], detection_index=int(i))
                for i in view.unmatched if d.scores[i] >= self.min_score]


class DetectionBirthInitiator(Initiator):
    """A detection that no track explains (no track that outlived the filter's deaths matched
    it), scoring at least ``min_score``, starts a track, most confident first; not where it
    overlaps a live track (or one just started) by more than ``max_iou``, nor where its position
    is not finite or outside the run's valid region.

    {params}
    """

    min_score: float = Param(0.2, "Least detector score c(det) of a detection that may start a "
                             "track.", unit="detector score")
    max_iou: float = Param(0.3, "A detection overlapping a live track's box by more than this "
                           "intersection over union starts nothing.", unit="1")

    def initiate(self, view: FrameView) -> list[Birth]:
        d = view.detections
        if d is None or not len(d):
            return []
        cand = [i for i in range(len(d)) if i not in view.claimed and d.scores[i] >= self.min_score]
        cand.sort(key=lambda i: -d.scores[i])
        out = []
        for i in cand:
            box = d.boxes_xywh_px[i]
            pos = view.models.position_from_box(box)
            if not np.all(np.isfinite(pos)) or not view.models.in_region(pos[None])[0]:
                continue
            out.append(Birth(box_xywh_px=box, detection_index=i, max_iou=self.max_iou))
        return out


# --------------------------------------------------------------------------------------------
# Confirmation, ends, duplicates
# --------------------------------------------------------------------------------------------


class HitConfirmer(Confirmer):
    """A new track is tentative; it is confirmed once it has had ``confirm_hits`` matched
    detections within its first ``confirm_window`` frames (its birth frame counts as one hit),
    else it ends unconfirmed. ``confirm_hits`` 1: a track is confirmed at birth.

    {params}

    Attributes
    ----------
    counts_ : dict[int, [hits, age]]
        Each tentative track's matched detections and frames so far, by id.
    """

    confirm_hits: int = Param(3, "Matched detections, birth frame included, that confirm a "
                              "track within its first confirm_window frames.", unit="count")
    confirm_window: int = Param(5, "The frames, from its birth frame on, in which a tentative "
                                "track must reach confirm_hits matched detections.",
                                unit="frames")

    def setup(self, context: RunContext) -> None:
        """Validate the parameters (``__init__`` only stores them)."""
        self._check()

    def _check(self) -> None:
        if self.confirm_hits < 1 or self.confirm_window < self.confirm_hits:
            raise ValueError(f"tracks: need 1 <= confirm_hits <= confirm_window, got "
                             f"{self.confirm_hits}, {self.confirm_window}")

    @property
    def counts_(self) -> dict[int, list[int]]:
        return self.__dict__.setdefault("_counts", {})

    def tentative(self, birth: Birth) -> bool:
        return self.confirm_hits > 1

    def track_started(self, track: TrackView, birth: Birth) -> None:
        if track.tentative:
            self.counts_[track.id] = [1, 1]

    def track_ended(self, track_id: int) -> None:
        self.counts_.pop(track_id, None)

    def confirm(self, view: FrameView) -> list[Confirm | End]:
        live = {t.id: t for t in view.tracks}
        out: list[Confirm | End] = []
        counts = self.counts_
        for tid in list(counts):
            t = live.get(tid)
            if t is None:
                del counts[tid]
                continue
            c = counts[tid]
            c[1] += 1
            c[0] += int(t.detection is not None)
            if c[0] >= self.confirm_hits:
                out.append(Confirm(tid))
                del counts[tid]
            elif c[1] >= self.confirm_window:
                out.append(End(tid, "unconfirmed"))
        return out


class BorderTerminator(Terminator):
    """A confirmed track that has missed its detection ends at once when its box, or the box
    it would have walking on at the velocity it had at its last matched detection (for the
    frames it has missed, ``dt`` each), is not wholly inside the image: its object is walking
    out of the picture.

    A detector's boxes lie inside the image, so a box reaching past the border with no
    detection is an object partly gone, and an object whose own motion carried it out is gone
    even when its track was held back inside (by neighbours' detections or colour), where it
    would wait hidden and take over the next object entering at that edge. The walking-on box
    needs a motion model with ``velocity_dims``; without, only the track's own box is tested.
    No parameters.

    Attributes
    ----------
    last_matched_ : dict[int, ndarray (D,)]
        Each confirmed track's state at its last matched detection, by id.
    """

    @property
    def last_matched_(self) -> dict[int, np.ndarray]:
        return self.__dict__.setdefault("_last_matched", {})

    def track_ended(self, track_id: int) -> None:
        self.last_matched_.pop(track_id, None)

    def terminate(self, view: FrameView) -> list[End]:
        last = self.last_matched_
        cand = []
        for t in view.tracks:
            if t.tentative:
                continue
            if t.detection is not None:
                last[t.id] = np.array(t.state, dtype=np.float64)
            elif t.misses > 0:
                cand.append(t)
        if not cand:
            return []
        # each candidate's own box, then the walking-on boxes (the same track may come twice)
        boxes = [np.asarray(t.box_xywh_px, dtype=np.float64) for t in cand]
        m = view.models
        if m.velocity_dims is not None:
            pos, vel = list(m.position_dims), list(m.velocity_dims)
            for t in list(cand):
                s0 = last.get(t.id)
                if s0 is None:
                    continue
                s = s0.copy()
                s[pos] = s0[pos] + s0[vel] * (float(m.dt) * int(t.misses))
                boxes.append(np.asarray(m.boxes(s[None], t.id)[0], dtype=np.float64))
                cand.append(t)
        img_w, img_h = view.frame.size_wh
        b = np.array(boxes).reshape(-1, 4)
        with np.errstate(invalid="ignore"):
            out = ((b[:, 0] < 0) | (b[:, 1] < 0) | (b[:, 0] + b[:, 2] > img_w)
                   | (b[:, 1] + b[:, 3] > img_h))
        gone = {t.id: t for t, o in zip(cand, out, strict=True) if o}
        return [End(tid, "left the picture") for tid in gone]


class DuplicateMerger(Merger):
    """Two confirmed tracks that are one object tracked twice: the younger ends (the older id
    is kept).

    {params}
    """

    merge_iou: float = Param(0.6, "Confirmed tracks whose boxes overlap by more than this "
                             "intersection over union are one object (1 or more: no merging by "
                             "overlap).", unit="1")
    merge_distance_m: float | None = Param(
        None, "With a ground-plane observation model: confirmed tracks whose ground positions "
        "are closer than this are one object, and merge_iou is then not used. Image overlap is "
        "the wrong test on the ground plane: two people one behind the other (a metre or more "
        "apart in depth) overlap in the image, and removing one of them loses a correctly "
        "tracked person.", unit="m")

    def setup(self, context: RunContext) -> None:
        """Validate the parameters (``__init__`` only stores them)."""
        if self.merge_distance_m is not None and not float(self.merge_distance_m) > 0:
            raise ValueError(f"tracks.merge_distance_m must be > 0 metres or null, got "
                             f"{self.merge_distance_m!r}")

    def _same(self, view: FrameView, tracks: Sequence[TrackView]) -> np.ndarray | None:
        """Boolean (T, T): pairs of tracks that are one object (None: no test applies)."""
        if self.merge_distance_m is not None:
            world = [view.models.world_position(t.state) for t in tracks]
            if all(w is not None for w in world):
                xy = np.array([np.asarray(w, dtype=np.float64)[:2] for w in world])
                d = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=2)
                return d < float(self.merge_distance_m)
        if self.merge_iou >= 1.0:
            return None
        boxes = np.array([t.box_xywh_px for t in tracks])
        return iou_matrix(boxes, boxes) > self.merge_iou

    def merge(self, view: FrameView) -> list[End]:
        confirmed = [t for t in view.tracks if not t.tentative]
        same = self._same(view, confirmed) if len(confirmed) > 1 else None
        if same is None:
            return []
        gone: list[int] = []
        for i, j in zip(*np.nonzero(np.triu(same, 1))):
            a, b = confirmed[i], confirmed[j]
            if a.id in gone or b.id in gone:
                continue
            young = a if (a.age, -a.id) < (b.age, -b.id) else b
            gone.append(young.id)
        return [End(tid, "duplicate") for tid in gone]


# --------------------------------------------------------------------------------------------
# Appearance and output
# --------------------------------------------------------------------------------------------


class ColourReidentifier(Reidentifier):
    """A colour model per track: per-channel BGR histograms (``bins`` per channel) of its
    matched detections' ``region``, a running mean with ``update_rate``, started from the
    detection it was born from. Before each frame's association each track's
    ``appearance_scores`` are ``exp(-d^2 / (2 sigma^2))`` with ``d`` the exact per-channel 1-D
    EMD (bins, / (bins - 1), channel mean) between its model and each detection; associators
    with an appearance term read them.

    {params}

    Attributes
    ----------
    models_ : dict[int, ndarray (3, bins)]
        Each track's colour model, by id.
    """

    bins: int = Param(16, "Histogram bins per colour channel.", unit="count")
    sigma: float = Param(0.1, "The colour distance (EMD, 0-1) at which the similarity falls "
                         "to exp(-1/2).", unit="1")
    update_rate: float = Param(0.1, "Weight of each matched detection's histogram in the "
                               "running mean.", unit="1")
    region: tuple = Param((0.15, 0.1, 0.85, 0.9), "The part of a box whose pixels are counted: "
                          "(left, top, right, bottom) as fractions of its width and height.",
                          unit="1")
    @property
    def models_(self) -> dict[int, np.ndarray]:
        return self.__dict__.setdefault("_models", {})

    def track_ended(self, track_id: int) -> None:
        self.models_.pop(track_id, None)

    def _histograms(self, image: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """Per-channel normalised histograms (K, 3, bins) of the boxes' regions (every pixel)."""
        bins = int(self.bins)
        fx0, fy0, fx1, fy1 = self.region
        H, W = image.shape[:2]
        out = np.full((len(boxes), 3, bins), 1.0 / bins)
        # OpenCV's histogram of an 8-bit channel: bin floor(v * bins / 256), the same counts as
        # the integer formula below (bins / 256 is exact in binary), about six times faster
        fast = image.dtype == np.uint8 and image.ndim == 3
        if fast:
            import cv2
        for k, (x, y, w, h) in enumerate(np.asarray(boxes, dtype=np.float64)):
            x0, x1 = int(max(x + fx0 * w, 0)), int(min(x + fx1 * w, W))
            y0, y1 = int(max(y + fy0 * h, 0)), int(min(y + fy1 * h, H))
            if x1 <= x0 or y1 <= y0:
                continue
            roi = image[y0:y1, x0:x1]
            n = (y1 - y0) * (x1 - x0)
            if fast:
                for c in range(3):
                    counts = cv2.calcHist([roi], [c], None, [bins], [0, 256])[:, 0]
                    out[k, c] = counts.astype(np.float64) / n
                continue
            q = (roi.reshape(-1, 3).astype(np.int32) * bins) >> 8
            idx = (np.arange(3)[None, :] * bins + q).ravel()
            out[k] = np.bincount(idx, minlength=3 * bins).reshape(3, bins) / n
        return out

    def scores(self, view: FrameView) -> AppearanceScores:
        self.hists_ = None
        d = view.detections
        if d is None or len(d) == 0:
            return AppearanceScores({t.id: None for t in view.tracks})
        hists = self._histograms(view.frame.image, d.boxes_xywh_px)
        sigma = float(self.sigma)
        cdf = np.cumsum(hists, axis=-1)
        bins = hists.shape[-1]
        out: dict[int, np.ndarray | None] = {}
        for t in view.tracks:
            model = self.models_.get(t.id)
            if model is None:
                out[t.id] = None
                continue
            dist = np.abs(cdf - np.cumsum(model, axis=-1)[None]).sum(axis=-1).mean(axis=1)
            dist /= bins - 1
            out[t.id] = np.exp(-0.5 * (dist / sigma) ** 2)
        self.hists_ = hists
        return AppearanceScores(out)

    def observe(self, view: FrameView) -> None:
        hists = self.__dict__.get("hists_")
        if hists is None:
            return
        a = float(self.update_rate)
        models = self.models_
        for t in view.tracks:
            if t.detection is None:
                continue
            h = hists[t.detection.index]
            old = models.get(t.id)
            models[t.id] = h.copy() if old is None else (1 - a) * old + a * h

    def track_started(self, track: TrackView, birth: Birth) -> None:
        hists = self.__dict__.get("hists_")
        if hists is not None and birth.detection_index is not None:
            self.models_[track.id] = hists[birth.detection_index].copy()


class OutputBoxReporter(Reporter):
    """What a track's record looks like and whether it is output: a track that has gone more
    than ``hide_after_misses`` frames without a detection is not output (it keeps being tracked
    and reappears when matched again), and in a frame where a track matched a detection its
    output box moves towards the detection's.

    {params}
    """

    hide_after_misses: int | None = Param(
        None, "A confirmed track is not output in frames where it has gone more than this many "
        "frames without a matched detection. None: always output.", unit="frames")
    hide_after_s: float | None = Param(
        None, "hide_after_misses in seconds of video: round(hide_after_s * fps) frames at the "
        "run's frame rate, so that a track is hidden after the same time on a 7 and on a 30 "
        "frames-per-second video. Not with hide_after_misses.", unit="s", low=0.0)
    box_from_detection: float = Param(
        0.0, "Weight w of a track's matched detection in its output box: (1 - w) * estimate's "
        "box + w * detection's box (0: the estimate's box alone). Only the output box; the "
        "state and what the next frame predicts are the filter's own. A projected estimate's "
        "box carries the model's errors (the assumed height and width ratio, the camera's "
        "tilt); the detector's box follows the person's own outline.", unit="1", low=0.0,
        high=1.0)
    box_min_iou: float = Param(
        0.3, "box_from_detection moves a box only towards a detection that overlaps it by at "
        "least this intersection over union: a detection the associator matched from further "
        "away (it gates by distance) may be someone else's.", unit="1", low=0.0, high=1.0)

    def _check_relations(self) -> None:
        if self.hide_after_misses is not None and self.hide_after_s is not None:
            raise ValueError("output-boxes: give hide_after_misses (frames) or hide_after_s "
                             "(seconds), not both")

    def setup(self, context: RunContext) -> None:
        """The frames a track may miss before it is hidden, at the run's frame rate."""
        self.hide_frames_ = (self.hide_after_misses if self.hide_after_s is None
                             else context.frames(self.hide_after_s))

    def report(self, view: FrameView) -> list[OutputBox | Hide]:
        out: list[OutputBox | Hide] = []
        if self.box_from_detection > 0.0:
            pairs = [t for t in view.tracks if t.detection is not None]
            if pairs:
                est = np.array([t.box_xywh_px for t in pairs], dtype=np.float64)
                det = np.array([t.detection.box_xywh_px for t in pairs],  # type: ignore[union-attr]
                               dtype=np.float64)
                w = float(self.box_from_detection)
                ok = box_iou(est, det) >= float(self.box_min_iou)
                for t, ok_t, e, d in zip(pairs, ok, est, det, strict=True):
                    if ok_t:
                        out.append(OutputBox(t.id, (1.0 - w) * e + w * d))
        hide = self.__dict__.get("hide_frames_", self.hide_after_misses)
        if hide is not None:
            out.extend(Hide(t.id) for t in view.tracks if t.misses > hide)
        return out


# --------------------------------------------------------------------------------------------
# Named track managers: fixed lists of stages
# --------------------------------------------------------------------------------------------


class DetectionBirthTracks(LifecycleTracks):
    """Every unmatched detection scoring at least ``min_score`` starts a target (in detection
    order), output from its first frame on: the stage ``unmatched-births`` alone.

    {params}
    """

    min_score: float = Param(0.5, "Least detector score of a detection that starts a "
                             "target.", unit="1", low=0.0)

    def build_stages(self) -> list[LifecycleStage]:
        return [UnmatchedBirthInitiator(min_score=self.min_score)]


class ConfirmedTracks(LifecycleTracks):
    """Births from confirmed detections, duplicate removal, an optional appearance model: the
    stages ``colour-reid`` (with ``appearance``), ``output-boxes`` (with ``hide_after_misses``
    or ``box_from_detection``), ``hit-confirmation``, ``border-exit`` (with ``end_at_border``),
    ``duplicate-merge`` and ``detection-births``, built from the parameters below (see the
    stages for what each does).

    {params}

    Births happen only where the engine's ``valid_region`` (if any) holds.
    """

    min_score: float = Param(0.2, "Least detector score of a detection that may start a "
                             "target.", unit="1", low=0.0)
    max_iou: float = Param(0.3, "A detection overlapping a live target's box by more than "
                           "this starts nothing.", unit="1", low=0.0, high=1.0)
    confirm_hits: int = Param(3, "Matched detections within confirm_window that confirm a "
                              "tentative target.", unit="count", low=1)
    confirm_window: int = Param(5, "Frames from its birth in which a tentative target must "
                                "reach confirm_hits.", unit="frames", low=1)
    merge_iou: float = Param(0.6, "Confirmed targets overlapping by more than this: the "
                             "younger is removed (1 or more: never).", unit="1", low=0.0)
    merge_distance_m: float | None = Param(None, "With a ground-plane observation: targets "
                                           "closer than this on the ground are one; "
                                           "merge_iou is then not used.", unit="m", low=0.0,
                                           low_open=True)
    hide_after_misses: int | None = Param(None, "Frames without a detection after which a "
                                          "live target is not output.", unit="frames", low=0)
    hide_after_s: float | None = Param(None, "hide_after_misses in seconds of video (frames "
                                       "at the run's frame rate); not with hide_after_misses.",
                                       unit="s", low=0.0)
    end_at_border: bool = Param(False, "End a target that missed its detection when its box "
                                "leaves the image (stage border-exit).")
    appearance: dict | None = Param(None, "{bins, sigma, update_rate, region}: a colour model "
                                    "per target (stage colour-reid).")
    box_from_detection: float = Param(0.0, "Weight of the matched detection in the output "
                                      "box.", unit="1", low=0.0, high=1.0)
    box_min_iou: float = Param(0.3, "box_from_detection moves a box only towards a detection "
                               "overlapping it by at least this.", unit="1", low=0.0,
                               high=1.0)

    def _check_relations(self) -> None:
        if self.appearance is not None:
            bad = set(self.appearance) - APPEARANCE_KEYS
            if bad:
                raise ValueError(f"tracks.appearance: unknown options {sorted(bad)}; known: "
                                 f"{sorted(APPEARANCE_KEYS)}")

    def build_stages(self) -> list[LifecycleStage]:
        stages: list[LifecycleStage] = []
        if self.appearance is not None:
            stages.append(ColourReidentifier(**self.appearance))
        if (self.hide_after_misses is not None or self.hide_after_s is not None
                or self.box_from_detection != 0.0):
            stages.append(OutputBoxReporter(hide_after_misses=self.hide_after_misses,
                                            hide_after_s=self.hide_after_s,
                                            box_from_detection=self.box_from_detection,
                                            box_min_iou=self.box_min_iou))
        stages.append(HitConfirmer(confirm_hits=self.confirm_hits,
                                   confirm_window=self.confirm_window))
        if self.end_at_border:
            stages.append(BorderTerminator())
        stages.append(DuplicateMerger(merge_iou=self.merge_iou,
                                      merge_distance_m=self.merge_distance_m))
        stages.append(DetectionBirthInitiator(min_score=self.min_score, max_iou=self.max_iou))
        # validated now, also when no run context sets them up
        for s in stages:
            s.setup(RunContext())
        return stages

    @property
    def appearance_models_(self) -> dict[int, np.ndarray]:
        """Each live target's colour model, by id (empty without ``appearance``)."""
        for s in self._stages():
            if isinstance(s, ColourReidentifier):
                return s.models_
        return {}
