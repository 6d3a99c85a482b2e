"""The engine's rows backend: every target's particles stacked into one (T, N, D) array and each
step of a frame one call for all targets (``predict_rows``, ``to_boxes_rows``,
``log_likelihood_rows``, then weights, estimates and systematic resampling of all rows at once),
the records bit for bit those of the reference backend
(:meth:`pftrack.engine.tracker.MultiTargetTracker._step_reference`). Each function is the body
of the :class:`~pftrack.engine.tracker.MultiTargetTracker` method of the same name with a
leading underscore, which calls it with the tracker;
:meth:`~pftrack.engine.tracker.MultiTargetTracker.uses_rows` says when a frame runs here."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.special import expit

from pftrack.contracts.components import Detections, Frame, ObservationModel, TrackRecord
from pftrack.engine.faults import ComponentOutputError
from pftrack.filter import (
    _jit,
    normalize_log_weight_rows,
    systematic_resample_rows,
    weighted_extent,
    weighted_mean,
)
from pftrack.filter.core import _EXP_ZERO_BELOW

if TYPE_CHECKING:
    from pftrack.engine.tracker import MultiTargetTracker, _Filter


def step_rows(tracker: MultiTargetTracker, frame: Frame, filters: list[_Filter],
              detections: Detections | None) -> tuple[list[TrackRecord], list[int],
                                                      np.ndarray]:
    """The frame of :meth:`~pftrack.engine.tracker.MultiTargetTracker._step_reference` with every
    target's particles as one (T, N, D) array: one call each for predict, boxes and
    log-likelihoods (T, N), then weights, estimates, extents and systematic resampling for all
    rows at once (compiled in two passes around numpy's exp when the engine's kernels are
    loaded). Each row's numbers, the random draws and their order are the reference's (T
    offsets from one ``rng.random(T)`` are the T numbers successive draws give). A frame in
    which some target lost every weight ends target by target as in the reference (its
    re-spread draws between the targets' offsets)."""
    targets = [f.target for f in filters]
    p = tracker.motion.predict_rows(tracker._stacked_particles(filters), tracker.dt, tracker.rng,
                                 targets)
    boxes = tracker.observation.to_boxes_rows(p, targets)
    for i, f in enumerate(filters):
        tracker._moved(f, p[i], boxes[i])
    unmatched = tracker._associate(filters, detections)  # (proposals change p in place)
    if not all(f.particles.base is p for f in filters):  # a component replaced some
        p = np.array([f.particles for f in filters])
    tracker.likelihood.begin_frame(frame, targets, detections)
    if tracker.likelihood.offers_rows():
        lw = tracker._log_likelihood_rows(frame, filters, boxes, p)  # (T, N)
    else:  # (backend "rows" forced) the per-target calls, checked as the reference does
        lw = np.array([tracker._log_likelihood(frame, f) for f in filters])
    ends = tracker._weigh_rows(lw, filters, p)
    if ends is None:  # a target lost every weight: the reference's ends, target by target
        records, dead = tracker._filter_each(frame, filters, list(lw), detections)
        return records, dead, unmatched
    states, extents, best, resampled, idx = ends
    records, dead = tracker._finish_rows(frame, filters, detections, states, extents, best,
                                      resampled, idx)
    return records, dead, unmatched


def log_likelihood_rows(tracker: MultiTargetTracker, frame: Frame, filters: list[_Filter],
                        boxes: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Every target's log-likelihoods (T, N) float64 from one
    :meth:`Likelihood.log_likelihood_rows` call, checked as
    :meth:`~pftrack.engine.tracker.MultiTargetTracker._log_likelihood` checks one row (the
    error names the first target at fault), zero outside the valid regions; row ``i`` kept in
    ``targets[i].log_likelihoods``."""
    targets = [f.target for f in filters]
    try:
        lw = tracker.likelihood.log_likelihood_rows(boxes, targets)
    except (ValueError, OSError) as exc:  # bad input met at run time: still exit 2
        raise ValueError(f"{tracker._who(tracker.likelihood)}: {exc}") from exc
    except Exception as exc:
        raise ComponentOutputError(
            f"{tracker._who(tracker.likelihood)} raised {type(exc).__name__}: {exc} (frame "
            f"{frame.index}, targets {[t.id for t in targets]}, log_likelihood_rows)"
        ) from exc
    if type(lw) is not np.ndarray or lw.dtype != np.float64:
        lw = tracker._checked_dtype(lw)
    if lw.shape != boxes.shape[:2]:
        raise ComponentOutputError(
            f"{tracker._who(tracker.likelihood)} returned log-likelihoods of shape {lw.shape} from "
            f"log_likelihood_rows, expected {boxes.shape[:2]} (one row per target, one "
            "value per particle)")
    if not (lw < np.inf).all():
        i = int(np.flatnonzero(~(lw < np.inf).all(axis=1))[0])
        tracker._check_finite(lw[i], frame, targets[i])
    pos = tracker._pos_index(list(tracker.motion.position_dims))
    if tracker.valid_region is not None:
        xy = p[:, :, pos]
        inside = np.asarray(tracker.valid_region(xy.reshape(-1, xy.shape[2])), dtype=bool)
        lw = np.where(inside.reshape(lw.shape), lw, -np.inf)
    own = [(i, t.valid_region) for i, t in enumerate(targets) if t.valid_region is not None]
    if own:
        lw = lw.copy()  # (never the likelihood's own array)
        for i, region in own:
            lw[i] = np.where(region(p[i][:, pos]), lw[i], -np.inf)
    for t, row in zip(targets, lw):
        t.log_likelihoods = row
    return lw


def weigh_rows(tracker: MultiTargetTracker, lw: np.ndarray, filters: list[_Filter], p: np.ndarray,
               ) -> tuple[Any, ...] | None:
    """Step 4 for every target at once (systematic resampling every frame): from the
    log-likelihoods ``lw`` (T, N) and the particles ``p`` (T, N, D), ``(states (T, D),
    extents (T, D), best log-likelihood per row, resampled particles (T, N, D),
    resampling indices (T, N))``, each row the single filter's numbers bit for bit; None,
    having drawn nothing, when some row has no finite weight. Compiled (two passes around
    numpy's exp, :mod:`pftrack.filter._jit`) when the engine's kernels are loaded, else
    numpy's rows functions: the same numbers."""
    if all(f.log_weights is tracker._uniform_log for f in filters):
        logw = tracker._uniform_log_row
    else:
        logw = np.array([f.log_weights for f in filters])
    if (_jit.small_ready() and p.ndim == 3 and p.shape[2] >= 2 and p.flags.c_contiguous
            and p.dtype == np.float64):
        lwc = np.ascontiguousarray(lw, dtype=np.float64)
        status, vals, pos, best = _jit.shift_rows_for_exp(lwc, logw, _EXP_ZERO_BELOW)
        if status != 0:  # (NaN and +inf were rejected when the rows were checked)
            return None
        np.exp(vals, out=vals)  # numpy's exp, on the weights that are not exactly 0
        u = tracker.rng.random(len(filters))  # what the systematic resampling draws
        _, states, extents, idx, resampled = _jit.estimate_resample_rows(vals, pos, p, u)
        return states, extents, best.tolist(), resampled, idx
    weights, ok = normalize_log_weight_rows(lw + logw)
    if not ok.all():
        return None
    states = weighted_mean(p, weights)
    extents = weighted_extent(p, weights, states)
    idx = systematic_resample_rows(weights, tracker.rng)
    flat = idx + (np.arange(len(filters), dtype=np.intp) * p.shape[1])[:, None]
    resampled = p.reshape(-1, p.shape[2]).take(flat.ravel(), axis=0).reshape(p.shape)
    return states, extents, lw.max(axis=1).tolist(), resampled, idx


def finish_rows(tracker: MultiTargetTracker, frame: Frame, filters: list[_Filter],
                detections: Detections | None, states: np.ndarray, extents: np.ndarray,
                best_rows: list[float], resampled: np.ndarray, resample_rows: np.ndarray,
                ) -> tuple[list[TrackRecord], list[int]]:
    """Step 5 of the rows backend, when every target was weighted, estimated and resampled
    by :func:`weigh_rows`: the estimates' boxes, anchors and confidences of all targets at
    once, support and death per target, and the records, each field a row of one block
    copied once per frame (the numbers and the records of
    :meth:`~pftrack.engine.tracker.MultiTargetTracker._filter_one`). Returns
    ``(records, dead ids)``."""
    observation = tracker.observation
    pos_dims = list(tracker.motion.position_dims)
    box_in_view = type(observation).in_view is ObservationModel.in_view
    targets = [f.target for f in filters]
    est_boxes = rec_boxes = None
    if type(observation).to_boxes_rows is not ObservationModel.to_boxes_rows:
        est_boxes = observation.to_boxes_rows(states[:, None, :], targets)[:, 0]
        rec_boxes = est_boxes.copy()
    pos = tracker._pos_index(pos_dims)
    anchors = states[:, pos].copy()  # the engine's: never a view of what callers get
    confidences = expit(np.array(best_rows)).tolist()
    # what the records own: one copy of each block (the targets keep views of the originals)
    rec_states = states.copy()
    rec_positions = states[:, pos].copy()
    rec_extents = extents.copy()
    no_world = type(observation).world_position is ObservationModel.world_position
    uniform, uniform_log = tracker._uniform, tracker._uniform_log
    index = frame.index
    records = []
    dead = []
    for i, f in enumerate(filters):
        t = targets[i]
        best = best_rows[i]
        state = states[i]
        t.state = state
        t.extent = extents[i]
        # (an observation model without rows boxes the estimate of a target whose state
        # and extent are already this frame's, as in the reference)
        box = est_boxes[i] if est_boxes is not None else \
            observation.to_boxes(state[None], t)[0]
        t.box_xywh_px = box
        tracker._support(t, t.detection is not None or tracker._self_supported(best, detections))
        f.anchor = anchors[i]
        # resampled (``t.resample_index``: which weighted particle each new one copies)
        f.particles = t.particles = resampled[i]
        t.resample_index = resample_rows[i]
        f.weights, f.log_weights = uniform, uniform_log
        # 5. death
        if tracker._gone(t, state, box, box_in_view, observation, frame, pos_dims):
            dead.append(t.id)
            continue
        world = None if no_world else observation.world_position(state)
        records.append(TrackRecord(
            frame=index, id=t.id,
            box_xywh_px=rec_boxes[i] if rec_boxes is not None else box.copy(),
            state=rec_states[i],
            position=rec_positions[i], extent=rec_extents[i],
            confidence=confidences[i] if math.isfinite(best) else 0.0,
            world_m=None if world is None else np.asarray(world, dtype=np.float64)))
    # next frame's prediction reads these rows as they are while no filter changed
    tracker._last_stack = (resampled, [f.particles for f in filters])
    return records, dead


def stacked_particles(tracker: MultiTargetTracker, filters: list[_Filter]) -> np.ndarray:
    """Every filter's particles as one (T, N, D) array: the array the last frame's
    resampling filled when each filter still holds its row of it (no copy: predict does
    not modify its input), else a new stack."""
    last = tracker.__dict__.get("_last_stack")
    if last is not None:
        arr, views = last
        if len(views) == len(filters) and all(f.particles is v
                                              for f, v in zip(filters, views)):
            return arr
    return np.array([f.particles for f in filters])
