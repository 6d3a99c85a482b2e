"""The colour paper's experiments as library calls: track a scene from given boxes, score, tabulate.

Used by ``pftrack demo``, :mod:`pftrack_colour.pets`, the notebook ``01_cross_entropy.ipynb``
and the repository's benchmarks ``colour`` and ``pets09-colour`` (package ``pftrack_bench``).

Timing covers tracking only: frames are decoded or rendered before the clock starts (or outside
the timed calls), and drawing happens afterwards.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pftrack.builtin.image_box import ImageBoxObservation
from pftrack.contracts.components import Detections, Frame, Likelihood, Param, Target, TrackManager
from pftrack.contracts.stages import (
    Birth,
    End,
    FrameView,
    Initiator,
    LifecycleStage,
    Resize,
    Sizer,
    Terminator,
    TrackView,
)
from pftrack.engine.lifecycle import LifecycleTracks
from pftrack.engine.runner import FrameStep, run_frames
from pftrack.engine.tracker import MultiTargetTracker, records_to_mot
from pftrack.host import Host, get_host

from pftrack_colour import _jit

__all__ = [
    "LIKELIHOODS",
    "TrackingRun",
    "build_tracker",
    "centre_errors",
    "cumulative_errors",
    "BoxSizeSizer",
    "GivenBoxTracks",
    "GivenEndsTerminator",
    "GivenStartsInitiator",
    "first_boxes",
    "implementation",
    "last_frames",
    "track",
    "track_boxes",
]

#: The four likelihoods of the colour paper, baseline first.
LIKELIHOODS = ("bhattacharyya", "bhattacharyya-bg", "cross-entropy", "cross-entropy-bg")

def implementation() -> str:
    """How the likelihoods are computed, for the benchmark reports."""
    ce = ("the common case (same-size boxes inside the image) in compiled numba kernels "
          "(pftrack_colour._jit), the rest in numpy" if _jit.ENABLED
          else "numpy only (PFTRACK_NO_JIT)")
    return ("Bhattacharyya baselines: numpy, one histogram per sample (eq. 7), vectorised over "
            f"samples; cross entropy: O(1) per sample through an integral image, {ce}")


#: Random-walk noise per frame (px) used by the experiments; the walkers move 1-3 px a frame.
DEFAULT_SIGMA_PX = 4.0


class _TimedLikelihood(Likelihood):
    """Forwards to ``inner`` and accumulates the seconds spent in it (for reporting the
    likelihood's share of the tracking time)."""

    def __init__(self, inner: Likelihood) -> None:
        self.inner = inner

    def _timed(self, fn: Callable[..., Any], *args: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return fn(*args)
        finally:
            self.seconds_ = getattr(self, "seconds_", 0.0) + time.perf_counter() - t0

    def prepare(self) -> None:
        self._timed(self.inner.prepare)

    def init_target(self, frame: Frame, target: Target) -> None:
        self._timed(self.inner.init_target, frame, target)

    def end_target(self, target: Target) -> None:
        self._timed(self.inner.end_target, target)

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        self._timed(self.inner.begin_frame, frame, targets, detections)

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        return self._timed(self.inner.log_likelihood, boxes_xywh_px, target)

    def log_likelihood_rows(self, boxes_xywh_px: np.ndarray,
                            targets: Sequence[Target]) -> np.ndarray:
        return self._timed(self.inner.log_likelihood_rows, boxes_xywh_px, targets)

    def offers_rows(self) -> bool:
        return self.inner.offers_rows()


@dataclass
class TrackingRun:
    """What :func:`track` returns.

    Attributes
    ----------
    rows : ndarray, shape (M, 10)
        The tracks as MOTChallenge rows (frame, id, left, top, width, height, conf, -1, -1, -1).
    seconds : float
        Wall time spent tracking (starting targets, steps, ending targets); decoding, rendering
        and drawing excluded.
    likelihood_seconds : float
        The part of ``seconds`` spent in the likelihood.
    n_frames : int
        Frames tracked.
    n_updates : int
        Person-updates: the number of (target, frame) estimates made.
    snapshots : dict[int, dict[int, ndarray (N, 2)]]
        For the frames asked for, each live target's samples as the likelihood weighted them
        (box centres in px, after prediction, before resampling).
    recoveries : int
        Frames in which some target lost every weight and was re-spread.
    """

    rows: np.ndarray
    seconds: float
    likelihood_seconds: float
    n_frames: int
    n_updates: int
    snapshots: dict[int, dict[int, np.ndarray]] = field(default_factory=dict)
    recoveries: int = 0

    @property
    def seconds_per_frame(self) -> float:
        return self.seconds / max(self.n_frames, 1)

    @property
    def frames_per_second(self) -> float:
        return self.n_frames / self.seconds if self.seconds > 0 else float("inf")

    @property
    def updates_per_second(self) -> float:
        return self.n_updates / self.seconds if self.seconds > 0 else float("inf")


def build_tracker(likelihood: Likelihood | str | dict[str, Any], *, n_particles: int = 500,
                  sigma_px: float = DEFAULT_SIGMA_PX,
                  box_size_px: tuple[float, float] | None = (30.0, 30.0), seed: int = 0,
                  min_log_likelihood: float | None = None, max_misses: int | None = None,
                  motion: str | dict[str, Any] | None = None,
                  tracks: TrackManager | None = None,
                  host: Host | None = None) -> MultiTargetTracker:
    """The colour paper's tracker: random walk of the box centre, fixed-size boxes, resampling every
    frame (systematic), initial spread N(0, 1) px (eq. 6), estimate = weighted mean (eq. 12).

    Parameters
    ----------
    likelihood
        A likelihood, or its registered name / config.
    n_particles : int
        Samples per target.
    sigma_px : float
        Random-walk noise per frame, px.
    box_size_px : (w, h) or None
        Box size for every target (the paper: 30 x 30); None: each target keeps the size of the
        box it is started from.
    seed : int
        Seeds the tracker's ``numpy.random.Generator``.
    min_log_likelihood, max_misses : optional
        A target ends after more than ``max_misses`` consecutive frames whose best particle's
        log-likelihood is below ``min_log_likelihood`` (for ``cross-entropy-bg``, 0 means "the
        box looks no more like the target than like the background").
    motion : str or dict, optional
        Another motion model (registered name or config; its state must start with the box
        centre in px); default: ``random-walk`` with ``sigma_px``.
    tracks : TrackManager, optional
        The engine's track management (default: targets added by the caller).
    """
    host = host or get_host()
    lik = host.build("likelihood", likelihood)
    if motion is None:
        motion = {"type": "random-walk", "params": {"sigma_px": sigma_px}}
    motion = host.build("motion", motion)
    if box_size_px is None:
        obs = ImageBoxObservation(size_from_box=True)
    else:
        obs = ImageBoxObservation(float(box_size_px[0]), float(box_size_px[1]))
    return MultiTargetTracker(motion, lik, obs, tracks=tracks, n_particles=n_particles,
                              resampling="systematic",
                              ess_threshold=1.0, init_spread=1.0,
                              min_log_likelihood=min_log_likelihood, max_misses=max_misses,
                              kill_out_of_view=True, rng=np.random.default_rng(seed))


def first_boxes(gt_rows: np.ndarray, ids: Iterable[int] | None = None,
                ) -> dict[int, list[tuple[int, np.ndarray]]]:
    """Each ground-truth id's first box: ``{frame: [(id, box_xywh_px), ...]}``."""
    gt = np.asarray(gt_rows, dtype=np.float64).reshape(-1, 10)
    wanted = None if ids is None else {int(i) for i in ids}
    out: dict[int, list[tuple[int, np.ndarray]]] = {}
    order = np.lexsort((gt[:, 0], gt[:, 1]))
    g = gt[order]
    starts = np.flatnonzero(np.r_[True, g[1:, 1] != g[:-1, 1]])
    for i in starts:
        tid = int(g[i, 1])
        if wanted is None or tid in wanted:
            out.setdefault(int(g[i, 0]), []).append((tid, g[i, 2:6].copy()))
    return out


def last_frames(gt_rows: np.ndarray) -> dict[int, int]:
    """Each ground-truth id's last frame."""
    gt = np.asarray(gt_rows, dtype=np.float64).reshape(-1, 10)
    out: dict[int, int] = {}
    for f, tid in gt[:, :2].astype(int):
        out[tid] = max(out.get(tid, f), f)
    return out


def track(frames: Iterable[Frame], likelihood: Likelihood | str | dict[str, Any],
          starts: dict[int, list[tuple[int, np.ndarray]]], *,
          ends: dict[int, int] | None = None, snapshot_frames: Iterable[int] = (),
          scale_step: float | None = None, scale_limits: tuple[float, float] = (0.6, 1.6),
          perspective: bool = False, **tracker_kw: Any) -> TrackingRun:
    """Track targets started from given boxes through ``frames``.

    Parameters
    ----------
    frames : iterable of Frame
        Already decoded / rendered frames (a list), or a stream: only the tracker's calls are
        timed, so decoding is excluded either way.
    likelihood
        A likelihood or its registered name / config.
    starts : {frame: [(id, box_xywh_px)]}
        Targets to start, e.g. :func:`first_boxes` of the ground truth. With a fixed box size
        the target is started at the box's centre.
    ends : {id: frame}, optional
        Frame after which a target is stopped (e.g. :func:`last_frames` of the ground truth).
    snapshot_frames : iterable of int
        Frames whose particles to keep (for drawing).
    scale_step : float, optional
        Adapt each target's box size (needs ``box_size_px=None``): after each step the
        likelihood is evaluated at the estimate with the box scaled by ``1 - scale_step``, 1
        and ``1 + scale_step`` (aspect kept) and the best size is kept for the next frame, within
        ``scale_limits`` times the starting size. With cross entropy + background the summed
        log-ratio grows with every target-like pixel a box takes in and falls with every
        background-like one, so it peaks at the size that fits the target.
    perspective : bool
        Adapt each target's box size to its image row (needs ``box_size_px=None``): people on
        a flat ground seen by a fixed camera have an image height linear in their foot row,
        ``h = a y_foot + b``; ``a, b`` are fitted (least squares) to the boxes the targets were
        started from so far, and each target keeps its own ratio to the fit at its start.
    **tracker_kw
        Passed to :func:`build_tracker`.

    Returns
    -------
    TrackingRun
    """
    # building the tracker prepares the likelihood (compiled kernels loaded) before the clock
    tracks = GivenBoxTracks(starts=starts, ends=ends or {}, scale_step=scale_step,
                            scale_limits=scale_limits, perspective=perspective)
    tracker = build_tracker(likelihood, tracks=tracks, **tracker_kw)
    timed = _TimedLikelihood(tracker.likelihood)
    tracker.likelihood = timed
    snaps = {int(f) for f in snapshot_frames}
    with np.errstate(over="ignore"):  # the tracker's confidence exp(-logL) overflows harmlessly
        return _track_loop(tracker, timed, frames, snaps)


def _track_loop(tracker: MultiTargetTracker, timed: _TimedLikelihood, frames: Iterable[Frame],
                snaps: set[int]) -> TrackingRun:
    """Step the engine through ``frames`` (its track manager starts, resizes and ends the
    targets), timing the engine's calls only."""
    snapshots: dict[int, dict[int, np.ndarray]] = {}

    def snapshot(step: FrameStep) -> None:
        if step.frame.index in snaps:
            snapshots[step.frame.index] = {
                t.id: t.particle_boxes_xywh_px[:, :2] + t.particle_boxes_xywh_px[:, 2:] / 2
                for t in tracker.targets if t.particle_boxes_xywh_px is not None}

    loop = run_frames(tracker, frames, after_step={"snapshots": snapshot})
    return TrackingRun(rows=records_to_mot(loop.records),
                       seconds=float(loop.frame_tracking_s.sum()),
                       likelihood_seconds=getattr(timed, "seconds_", 0.0),
                       n_frames=loop.n_frames, n_updates=len(loop.records), snapshots=snapshots,
                       recoveries=tracker.recoveries)


class GivenStartsInitiator(Initiator):
    """Starts targets from given boxes at given frames, with given ids (the colour paper's
    protocol: each person from its first ground-truth box), before that frame's predict step.

    {params}
    """

    starts: dict[int, list[tuple[int, np.ndarray]]] | None = Param(
        None, "Targets to start: {frame: [(id, box_xywh_px)]} (e.g. :func:`first_boxes` of the "
        "ground truth).", unit="none")

    def scheduled(self, view: FrameView) -> list[Birth]:
        return [Birth(box_xywh_px=np.asarray(box, float), track_id=tid, supported=False)
                for tid, box in (self.starts or {}).get(view.frame.index, ())]


class GivenEndsTerminator(Terminator):
    """Ends each target after a given frame (its record of that frame is still output).

    {params}
    """

    ends: dict[int, int] | None = Param(
        None, "Frame after which each target is stopped: {id: frame} (e.g. "
        ":func:`last_frames`).", unit="none")

    def terminate(self, view: FrameView) -> list[End]:
        ends = self.ends
        if not ends:  # none given (the colour paper's walkers): no target to look at
            return []
        return [End(t.id, "given last frame", output=True) for t in view.tracks
                if ends.get(t.id, np.inf) <= view.frame.index]


class _BoxSizing:
    """The box-size parameters :class:`BoxSizeSizer` adapts with, declared once for it and for
    :class:`GivenBoxTracks`, which passes them on."""

    scale_step: float | None = Param(
        None, "Per-frame scale search around the estimate (see :func:`track`).", unit="1", low=0.0)
    scale_limits: tuple[float, float] = Param(
        (0.6, 1.6), "Bounds of the scale search, times the starting size.",
        unit="1", low=0.0, low_open=True, length=2)
    perspective: bool = Param(
        False, "Box height from a linear fit of height against foot row (see :func:`track`).")


class BoxSizeSizer(_BoxSizing, Sizer):
    """Adapts each target's box size every frame: a scale search around the estimate
    (``scale_step``) and/or a perspective fit of box height against foot row
    (``perspective``), see :func:`track`.

    {params}

    Attributes
    ----------
    start_boxes_ : dict[int, ndarray]
        Each target's starting box (perspective).
    first_sizes_ : dict[int, (float, float)]
        Each target's first size (scale search).
    feet_ : list of (foot row, height)
        The start boxes so far (perspective fit).
    """

    def _state(self) -> None:
        if "start_boxes_" not in self.__dict__:
            self.start_boxes_: dict[int, np.ndarray] = {}
            self.first_sizes_: dict[int, tuple[float, float]] = {}
            self.feet_: list[tuple[float, float]] = []
            self.fit_: tuple[float, float] | None = None

    def track_started(self, track: TrackView, birth: Birth) -> None:
        self._state()
        if self.perspective and birth.box_xywh_px is not None:
            b = np.asarray(birth.box_xywh_px, float)
            self.feet_.append((b[1] + b[3], b[3]))
            self.fit_ = _fit_perspective(self.feet_)
            self.start_boxes_[track.id] = b.copy()

    def track_ended(self, track_id: int) -> None:
        self._state()
        self.start_boxes_.pop(track_id, None)
        self.first_sizes_.pop(track_id, None)

    def resize(self, view: FrameView) -> list[Resize]:
        self._state()
        sizes = {t.id: (t.box_wh_px, t.box_xywh_px) for t in view.tracks}
        out: list[Resize] = []
        if self.scale_step:
            for r in _adapt_scale(view, float(self.scale_step), self.scale_limits,
                                  self.first_sizes_):
                sizes[r.track_id] = (r.box_wh_px, r.box_xywh_px)
                out.append(r)
        if self.perspective and self.fit_ is not None:
            out.extend(_perspective_size(sizes, self.fit_, self.start_boxes_))
        return out


class GivenBoxTracks(_BoxSizing, LifecycleTracks):
    """Targets started from given boxes at given frames and stopped at given frames (the colour
    paper's protocol: each person from its first ground-truth box to its last), optionally resized
    every frame; every live target's estimate is output. The stages
    :class:`GivenStartsInitiator`, :class:`BoxSizeSizer` (with ``scale_step`` or
    ``perspective``) and :class:`GivenEndsTerminator`.

    {params}
    """

    starts: dict[int, list[tuple[int, np.ndarray]]] | None = Param(
        None, "Targets to start: {frame: [(id, box_xywh_px)]} (e.g. :func:`first_boxes` of the "
        "ground truth).", unit="none")
    ends: dict[int, int] | None = Param(
        None, "Frame after which each target is stopped: {id: frame} (e.g. "
        ":func:`last_frames`).", unit="none")
    def build_stages(self) -> list[LifecycleStage]:
        stages: list[LifecycleStage] = [GivenStartsInitiator(starts=self.starts)]
        if self.scale_step or self.perspective:
            stages.append(BoxSizeSizer(scale_step=self.scale_step,
                                       scale_limits=self.scale_limits,
                                       perspective=self.perspective))
        stages.append(GivenEndsTerminator(ends=self.ends))
        return stages


def _held_estimates(track_rows: np.ndarray, tid: int, frames: np.ndarray,
                    hold_last: bool) -> np.ndarray:
    """Boxes (F, 4) of track ``tid`` at ``frames`` (NaN where none; with ``hold_last`` a frame
    without a box takes the track's latest earlier box)."""
    t = track_rows[track_rows[:, 1] == tid]
    t = t[np.argsort(t[:, 0], kind="stable")]
    out = np.full((len(frames), 4), np.nan)
    if len(t) == 0:
        return out
    if hold_last:
        k = np.searchsorted(t[:, 0], frames, side="right") - 1
        ok = k >= 0
        out[ok] = t[k[ok], 2:6]
    else:
        k = np.searchsorted(t[:, 0], frames)
        k = np.minimum(k, len(t) - 1)
        ok = t[k, 0] == frames
        out[ok] = t[k[ok], 2:6]
    return out


def track_boxes(track_rows: np.ndarray, gt_rows: np.ndarray, ids: Iterable[int] | None = None,
                hold_last: bool = False) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per ground-truth id, its ground-truth boxes and the same-id track's boxes in the same
    frames: ``{id: (gt (F, 4), track (F, 4) with NaN rows where there is none)}``.

    ``hold_last``: a frame where the track has no box (it ended early, or skipped it) uses the
    track's latest earlier box, so a tracker that stops does not escape its error.
    """
    tr = np.asarray(track_rows, dtype=np.float64).reshape(-1, 10)
    gt = np.asarray(gt_rows, dtype=np.float64).reshape(-1, 10)
    wanted = np.unique(gt[:, 1]).astype(int) if ids is None else [int(i) for i in ids]
    out = {}
    for tid in wanted:
        g = gt[gt[:, 1] == tid]
        g = g[np.argsort(g[:, 0], kind="stable")]
        out[int(tid)] = (g[:, 2:6].copy(), _held_estimates(tr, tid, g[:, 0], hold_last))
    return out


def _fit_perspective(feet: list[tuple[float, float]]) -> tuple[float, float] | None:
    """Least-squares ``h = a y_foot + b`` over start boxes; None when ill-posed (fewer than two
    distinct rows, or a height that does not grow downwards)."""
    if len(feet) < 2:
        return None
    y, h = np.asarray(feet, float).T
    if np.ptp(y) < 1.0:
        return None
    a, b = np.polyfit(y, h, 1)
    return (float(a), float(b)) if a > 0 else None


def _perspective_size(sizes: dict[int, tuple[Any, np.ndarray]], fit: tuple[float, float],
                      start_boxes: dict[int, np.ndarray]) -> list[Resize]:
    """Each target's box from the perspective fit at its current foot row, about the same
    centre (``sizes``:
    each live target's ``(box_wh_px, box_xywh_px)`` by id; ``start_boxes``: its starting box)."""
    a, b = fit
    out = []
    for tid, (wh, box) in sizes.items():
        b0 = start_boxes.get(tid)
        if b0 is None or wh is None:
            continue
        model0 = a * (b0[1] + b0[3]) + b
        if model0 <= 0:
            continue
        k = b0[3] / model0  # this person's height relative to the fit
        cx, cy = box[0] + box[2] / 2, box[1] + box[3] / 2
        denom = 1.0 - k * a / 2.0  # h = k (a (cy + h / 2) + b)
        if denom <= 0:
            continue
        h = k * (a * cy + b) / denom
        h = float(np.clip(h, 0.5 * b0[3], 2.0 * b0[3]))
        w = float(b0[2] * h / b0[3])
        out.append(Resize(tid, (w, h), np.array([cx - w / 2, cy - h / 2, w, h])))
    return out


def _adapt_scale(view: FrameView, step: float, limits: tuple[float, float],
                 first_sizes: dict[int, tuple[float, float]]) -> list[Resize]:
    """One step of scale search per target around its estimate (see :func:`track`);
    ``first_sizes`` keeps each target's first box size (by id), the reference of ``limits``."""
    factors = np.array([1.0 - step, 1.0, 1.0 + step])
    out = []
    for t in view.tracks:
        wh = t.box_wh_px
        if wh is None:
            continue
        w0 = first_sizes.setdefault(t.id, wh)[0]
        box = t.box_xywh_px
        cx, cy = box[0] + box[2] / 2, box[1] + box[3] / 2
        ws = np.clip(wh[0] * factors, limits[0] * w0, limits[1] * w0)
        hs = ws * (wh[1] / wh[0])
        cands = np.column_stack([cx - ws / 2, cy - hs / 2, ws, hs])
        ll = view.models.log_likelihood(cands, t.id)
        k = int(np.argmax(ll))
        if k != 1 and np.isfinite(ll[k]):
            out.append(Resize(t.id, (float(ws[k]), float(hs[k])), cands[k].copy()))
    return out


def centre_errors(track_rows: np.ndarray, gt_rows: np.ndarray,
                  ids: Iterable[int] | None = None, hold_last: bool = False,
                  ) -> dict[int, np.ndarray]:
    """Per ground-truth id, the centre distance (px) between the track of the same id and the
    ground truth in each of that id's ground-truth frames, in frame order (NaN where the track
    has no box; see :func:`track_boxes` for ``hold_last``)."""
    out = {}
    for tid, (g, e) in track_boxes(track_rows, gt_rows, ids, hold_last).items():
        out[tid] = np.hypot(e[:, 0] + e[:, 2] / 2 - g[:, 0] - g[:, 2] / 2,
                            e[:, 1] + e[:, 3] / 2 - g[:, 1] - g[:, 3] / 2)
    return out


def cumulative_errors(track_rows: np.ndarray, gt_rows: np.ndarray,
                      names: dict[int, str], frames: Iterable[int] | None = None,
                      ) -> dict[str, float]:
    """The colour paper's accuracy: per target, the sum over frames of the centre distance (px).

    ``names`` maps ids to the names to report (``{1: "blue", ...}``); only ids with a track are
    reported. A target whose track ended early keeps its last estimate for the remaining frames.
    ``frames`` restricts the sum to those frames (all by default).
    """
    gt = np.asarray(gt_rows, dtype=np.float64).reshape(-1, 10)
    if frames is not None:
        gt = gt[np.isin(gt[:, 0], np.fromiter(frames, dtype=float))]
    tr = np.asarray(track_rows, dtype=np.float64).reshape(-1, 10)
    present = set(np.unique(tr[:, 1]).astype(int))
    errs = centre_errors(tr, gt, ids=[i for i in names if i in present], hold_last=True)
    return {names[tid]: float(np.nansum(d)) for tid, d in errs.items()}
