"""The tracking engine: one particle filter per target, driven frame by frame. Every run of
pftrack (``pftrack run``, the demo, every benchmark, the notebooks) goes through
:meth:`MultiTargetTracker.step`; what varies between papers is a component chosen by
configuration, not another loop.

Data flow per frame (top to bottom), :meth:`MultiTargetTracker.step`::

    frame -> [detector] -> detections
          -> tracks.before_frame                    lifecycle: starts due now, appearance
          -> motion.predict                         particles (N, D) in the motion model's space
          -> observation.to_boxes                   particle boxes (N, 4) xywh px
          -> [associator] detections <-> targets    ``target.detection`` (and the detection
                                                    proposal's redrawn particles)
          -> likelihood.begin_frame(all targets) -> likelihood.log_likelihood
          -> normalise, estimate (weighted mean), extent, resample (re-spread a target whose
             weights all vanished)
          -> the filter's own ends (misses, leaving the image or the valid region)
          -> observation.update_target (matched targets)
          -> tracks.after_frame                     lifecycle: births, confirmation, merging,
                                                    ends, the records to output
          -> list[TrackRecord]

Two backends compute the frame, with the same records bit for bit (a test holds them equal):
the reference, :meth:`MultiTargetTracker._step_reference`, one target at a time, the steps
above as written; and the rows backend, :meth:`MultiTargetTracker._step_rows`, every target's
particles stacked into one (T, N, D) array and each step one call for all targets
(``predict_rows``, ``to_boxes_rows``, ``log_likelihood_rows``, then weights, estimates and
systematic resampling of all rows at once). The rows backend runs wherever every per-frame
component offers its rows method and the filter resamples systematically every frame; the
reference otherwise (:meth:`MultiTargetTracker.uses_rows`). The rows backend's methods are in
:mod:`pftrack.engine.rows` (each method ``_x`` there as the function ``x``); the
records as arrays in :mod:`pftrack.engine.records`; the error naming a component at fault in
:mod:`pftrack.engine.faults`; each still imports from here.

The observation model (:class:`pftrack.contracts.components.ObservationModel`) and the track
management (:class:`pftrack.contracts.components.TrackManager`) are plugin kinds;
:class:`ManualTracks` (targets added by the caller, every estimate output) is the default (the
built-in observation models are in :mod:`pftrack.builtin`). Track management is written as
lifecycle stages (:mod:`pftrack.engine.lifecycle`) that return decisions; their runner applies them
through the engine's public methods below.

The engine streams: it keeps only the live targets, so memory does not grow with video length.
All randomness comes from one ``numpy.random.Generator``; the same seed gives bit-identical tracks.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import expit

from pftrack.contracts.components import (
    Associator,
    DetectionMatch,
    Detections,
    Detector,
    Frame,
    Likelihood,
    MotionModel,
    ObservationModel,
    Target,
    TrackManager,
    TrackRecord,
)
from pftrack.engine import rows
from pftrack.engine.faults import ComponentOutputError, component_label
from pftrack.engine.lifecycle import ManualTracks
from pftrack.engine.records import (  # noqa: F401 (public here as well)
    UNCERTAINTY_COLUMNS,
    records_to_mot,
    records_uncertainty,
)
from pftrack.filter import (
    RESAMPLERS,
    _jit,
    effective_sample_size,
    normalize_log_weights,
    weighted_extent,
    weighted_mean,
)

log = logging.getLogger(__name__)

_NO_DETECTIONS = np.zeros(0, dtype=int)  # unmatched detections of a frame without any
_NO_DETECTIONS.flags.writeable = False
_BACKENDS = ("auto", "rows", "reference")  # MultiTargetTracker(backend=...)

__all__ = [
    "ComponentOutputError",
    "ManualTracks",
    "MultiTargetTracker",
    "ObservationModel",
    "TrackRecord",
    "records_to_mot",
    "records_uncertainty",
]


@dataclass
class _Filter:
    target: Target
    particles: np.ndarray
    weights: np.ndarray
    anchor: np.ndarray  # position to re-spread around when every weight vanishes
    log_weights: np.ndarray  # np.log(weights), kept so a uniform row is not re-logged each frame


class MultiTargetTracker:
    """The tracking engine: one particle filter per target; track management, observation
    model, motion, likelihood, detector and associator are its replaceable parts.

    Parameters
    ----------
    motion : MotionModel
    likelihood : Likelihood
        One likelihood (combine several with a composite likelihood plugin).
    observation : ObservationModel
    tracks : TrackManager, optional
        Births, confirmation, merging, ends and output (default :class:`ManualTracks`).
    n_particles : int
        Particles per target.
    resampling : {"systematic", "stratified", "residual", "multinomial"}
    ess_threshold : float
        Resample when ESS < ess_threshold * n_particles (1.0: every frame, as the papers do;
        the ESS is then not computed).
    dt : float
        Time step per frame in the motion model's unit (1 frame, or 1/fps seconds).
    init_spread : float or array
        Std of the initial particle spread around a new target's position (the colour paper eq. 6:
        1 px).
    recover_spread : float or array, optional
        Std used to re-spread the particles around the last estimate when every weight is zero or
        non-finite (defaults to ``5 * init_spread``).
    detector, associator : optional
        When given, detections are computed each frame and matched to targets; the match is put
        in ``target.detection`` (:class:`~pftrack.contracts.components.DetectionMatch`) for
        likelihoods.
    detection_driven : bool, optional
        Whether only a matched detection supports a target (then a frame without detections
        counts as a miss for every target). Default (None): when there is a detector, or
        detections are handed to :meth:`step`.
    max_misses : int, optional
        A target dies after this many consecutive frames without support.
    min_log_likelihood : float, optional
        A frame supports a target when it has a matched detection or its best particle's
        log-likelihood is at least this; with no detections (neither a detector nor detections
        handed to :meth:`step`) and no threshold, every frame supports.
    kill_out_of_view : bool
        A target dies when its estimate's box leaves the image.
    detection_proposal : float
        Fraction (0-1) of a target's predicted particles redrawn around its matched
        detection before weighting, as a newborn target's are (``init_spread`` about the
        detection's position; velocity and the other state dimensions kept from the
        particles they replace): a mixture proposal of the motion prior and the detections
        (Okuma et al., "A boosted particle filter", ECCV 2004). A target whose particles
        drifted while its detections were missing then has particles where its person is
        found again, which the detection likelihood can weight; with the prior alone a
        matched detection a few particle spreads away supports none of them. 0: the motion
        prior alone (no random draws). Unit: 1.
    birth_velocity_spread : float
        Std of a new target's particle velocities (zero mean), in heights of the box it is
        started from per unit of ``dt``: a target started from a box (a detection) holds
        hypotheses of its speed from the first frame, the fast and the slow, and the first
        matched detections keep the ones that fit, instead of starting at rest and catching up
        through the velocity noise. In box heights because an image-plane speed scales with
        the person's size in the image (a person near a low camera crosses hundreds of pixels
        a second, a distant one a few). Needs a motion model with ``velocity_dims`` and an
        observation model that gives a box's height in state units
        (:meth:`~pftrack.contracts.components.ObservationModel.box_height_in_state`: the
        image-plane ones); targets started from a position without a box start at rest. 0:
        every target starts at rest (no random draws). Unit: box heights per dt.
    valid_region : callable, optional
        ``f(positions (N, P)) -> bool (N,)``; particles outside get likelihood zero (the coastal
        paper: particles leaving the volume) and a target whose estimate leaves it dies.
    target_size : float
        Default ``Target.size_m`` for new targets (adaptive motion noise).
    rng : numpy.random.Generator
        The only source of randomness.
    backend : {"auto", "rows", "reference"}
        How a frame is computed; every backend gives the same records bit for bit.
        ``reference``: one target at a time (:meth:`_step_reference`); ``rows``: all targets'
        particles as one (T, N, D) array, each step one vectorised call (:meth:`_step_rows`;
        needs systematic resampling every frame); ``auto``: rows when every per-frame
        component offers its rows method and the filter resamples systematically every frame,
        else the reference (:meth:`uses_rows`).
    """

    #: The last frame's resampled rows and each filter's view of them, set by the rows backend
    #: (:func:`pftrack.engine.rows.finish_rows`); an annotation only, no class attribute.
    _last_stack: tuple[np.ndarray, list[np.ndarray]]

    def __init__(self, motion: MotionModel, likelihood: Likelihood, observation: ObservationModel,
                 *, n_particles: int = 500, resampling: str = "systematic",
                 ess_threshold: float = 1.0, dt: float = 1.0,
                 init_spread: float | np.ndarray = 1.0,
                 recover_spread: float | np.ndarray | None = None,
                 tracks: TrackManager | None = None,
                 detector: Detector | None = None, associator: Associator | None = None,
                 detection_driven: bool | None = None, max_misses: int | None = None,
                 min_log_likelihood: float | None = None, kill_out_of_view: bool = True,
                 detection_proposal: float = 0.0, birth_velocity_spread: float = 0.0,
                 valid_region: Callable[[np.ndarray], np.ndarray] | None = None,
                 target_size: float = 1.0, rng: np.random.Generator | None = None,
                 backend: str = "auto") -> None:
        if n_particles < 1:
            raise ValueError(f"n_particles must be >= 1, got {n_particles}")
        if not 0.0 <= ess_threshold <= 1.0:
            raise ValueError(f"ess_threshold must be in [0, 1], got {ess_threshold}")
        if rng is None:
            raise ValueError("MultiTargetTracker needs rng=np.random.default_rng(seed): "
                             "pftrack never uses global random state")
        if (isinstance(detection_proposal, bool)
                or not isinstance(detection_proposal, (int, float))
                or not 0.0 <= detection_proposal <= 1.0):
            raise ValueError(f"tracker.detection_proposal must be a number in [0, 1], got "
                             f"{detection_proposal!r}")
        if (isinstance(birth_velocity_spread, bool)
                or not isinstance(birth_velocity_spread, (int, float))
                or not birth_velocity_spread >= 0.0 or not math.isfinite(birth_velocity_spread)):
            raise ValueError(f"tracker.birth_velocity_spread must be a finite number >= 0, got "
                             f"{birth_velocity_spread!r}")
        if birth_velocity_spread > 0.0:
            if getattr(motion, "velocity_dims", None) is None:
                raise ValueError(f"tracker.birth_velocity_spread: the motion model "
                                 f"{self._who(motion)} has no velocity (velocity_dims)")
            if (type(observation).box_height_in_state
                    is ObservationModel.box_height_in_state):
                raise ValueError(f"tracker.birth_velocity_spread: the observation model "
                                 f"{self._who(observation)} cannot give a box's height in "
                                 "state units (box_height_in_state); use it with an "
                                 "image-plane observation, or set it to 0")
        if resampling not in RESAMPLERS:
            raise ValueError(f"resampling scheme {resampling!r} unknown; choose one of "
                             f"{sorted(RESAMPLERS)}")
        self.motion = motion
        self.likelihood = likelihood
        self.observation = observation
        self.n_particles = int(n_particles)
        self.resampling = resampling
        self.ess_threshold = float(ess_threshold)
        self.dt = float(dt)
        self.init_spread = init_spread
        self.recover_spread = (np.asarray(init_spread, dtype=np.float64) * 5.0
                               if recover_spread is None else recover_spread)
        self.tracks = ManualTracks() if tracks is None else tracks
        self.detector = detector
        self.associator = associator
        self.detection_driven = detection_driven
        self.max_misses = max_misses
        self.min_log_likelihood = min_log_likelihood
        self.kill_out_of_view = kill_out_of_view
        self.detection_proposal = float(detection_proposal)
        self.birth_velocity_spread = float(birth_velocity_spread)
        self.valid_region = valid_region
        self.target_size = float(target_size)
        self.rng = rng
        self._filters: dict[int, _Filter] = {}
        self._next_id = 1
        self.recoveries = 0  # frames in which some target lost every weight and was re-spread
        self.last_detections: Detections | None = None
        # read-only uniform weights and their logarithm, shared by every target after resampling
        self._uniform = np.full(self.n_particles, 1.0 / self.n_particles)
        self._uniform_log = np.log(self._uniform)
        self._uniform.flags.writeable = False
        self._uniform_log.flags.writeable = False
        self._uniform_log_row = self._uniform_log[None].copy()  # (1, N), for the kernels
        if backend not in _BACKENDS:
            raise ValueError(f"tracker.backend must be one of {_BACKENDS}, got {backend!r}")
        self._rows_filter = self.resampling == "systematic" and self.ess_threshold >= 1.0
        if backend == "rows" and not self._rows_filter:
            raise ValueError("tracker.backend 'rows' resamples systematically every frame: it "
                             "needs resampling='systematic' and ess_threshold=1, got "
                             f"{resampling!r} and {ess_threshold}")
        self.backend = backend
        # every per-frame component vectorised over the targets (backend "auto": rows)
        self._rows_components = (self._rows_filter
                                 and type(motion).predict_rows is not MotionModel.predict_rows
                                 and type(observation).to_boxes_rows
                                 is not ObservationModel.to_boxes_rows)
        likelihood.prepare()  # compiled kernels and the like: before the first frame
        # a likelihood that imported numba: the engine's own kernels serve its small per-frame
        # calls too (same numbers), loaded now rather than in the first frame
        if _jit.warm_up_small():
            _jit.prepare_generator(rng)  # its state words found before the first frame

    # -- checks of what components return ----------------------------------------------------

    @staticmethod
    def _who(component: Any) -> str:
        """The component at fault, for messages: :func:`component_label`."""
        return component_label(component)

    def _checked_dtype(self, logl: Any) -> np.ndarray:
        arr = np.asarray(logl)
        if arr.dtype.kind != "f":
            raise ComponentOutputError(
                f"{self._who(self.likelihood)} returned log-likelihoods of dtype {arr.dtype}, "
                "expected floating point")
        return arr.astype(np.float64, copy=False)

    def _check_finite(self, logl: np.ndarray, frame: Frame, target: Target) -> None:
        """Stop the run, naming the likelihood, when ``logl`` holds NaN or +inf (-inf, an
        impossible particle, is allowed)."""
        if not (logl < np.inf).all():
            bad = int(np.count_nonzero(~(logl < np.inf)))
            raise ComponentOutputError(
                f"{self._who(self.likelihood)} returned {bad} NaN or +inf log-likelihood(s) "
                f"of {len(logl)} at frame {frame.index} (target {target.id})")

    # -- targets ------------------------------------------------------------------------------

    @property
    def targets(self) -> list[Target]:
        """Live targets, in id order."""
        return [f.target for f in self._filters.values()]

    def add_target(self, frame: Frame, position: np.ndarray | None = None, *,
                   box_xywh_px: np.ndarray | None = None, target_id: int | None = None,
                   size: float | None = None) -> Target:
        """Start a target at ``position`` (state-space position) or from an image box.

        Its particles are drawn around the position (``init_spread``), its likelihood template
        is built from ``frame`` (``likelihood.init_target``).
        """
        if position is None:
            if box_xywh_px is None:
                raise ValueError("add_target needs a position or a box_xywh_px")
            position = self.observation.position_from_box(np.asarray(box_xywh_px, float))
        position = np.asarray(position, dtype=np.float64)
        if target_id is None:
            target_id = self._next_id
        if target_id in self._filters:
            raise ValueError(f"target id {target_id} is already live")
        self._next_id = max(self._next_id, int(target_id) + 1)
        particles = self.motion.init_states(position, self.n_particles, self.rng,
                                            spread=self.init_spread)
        if self.birth_velocity_spread > 0.0 and box_xywh_px is not None:
            self._spread_velocities(particles, np.asarray(box_xywh_px, dtype=np.float64))
        weights = self._uniform
        state = weighted_mean(particles, weights)
        state[list(self.motion.position_dims)] = position  # the given position, not its sample mean
        target = Target(id=int(target_id), state=state, box_xywh_px=np.zeros(4),
                        particles=particles, extent=weighted_extent(particles, weights, state),
                        size_m=self.target_size if size is None else float(size))
        self.observation.init_target(target, box_xywh_px)
        target.box_xywh_px = self.observation.to_boxes(state[None], target)[0]
        target.particle_boxes_xywh_px = self.observation.to_boxes(particles, target)
        self._filters[target.id] = _Filter(target, particles, weights, position.copy(),
                                           self._uniform_log)
        self.likelihood.init_target(frame, target)
        return target

    def _spread_velocities(self, particles: np.ndarray, box_xywh_px: np.ndarray) -> None:
        """Draw a new target's particle velocities (in place): zero mean, std
        ``birth_velocity_spread`` times the box's height in state units, per axis."""
        height = self.observation.box_height_in_state(box_xywh_px)
        if height is None or not math.isfinite(height) or height <= 0.0:
            return  # a box with no usable height: the target starts at rest
        vel = list(self.motion.velocity_dims)  # type: ignore[attr-defined]
        std = self.birth_velocity_spread * float(height)
        particles[:, vel] = self.rng.standard_normal((len(particles), len(vel))) * std

    def set_particles(self, target_id: int, particles: np.ndarray) -> Target:
        """Replace a live target's particles (N, D) with equal weights (the coastal paper's
        re-spread of a detection group through its volume, a new group taken from another's
        particles); its estimate and extent become theirs."""
        f = self._filters.get(int(target_id))
        if f is None:
            raise ValueError(f"set_particles: no live target {target_id}")
        p = np.array(particles, dtype=np.float64)  # a copy: the engine owns its particles
        if p.shape != (self.n_particles, self.motion.state_dim):
            raise ValueError(f"set_particles: particles must have shape "
                             f"({self.n_particles}, {self.motion.state_dim}), got {p.shape}")
        t = f.target
        f.particles = t.particles = p
        t.resample_index = None  # (its particles are not copies of the weighted ones)
        f.weights, f.log_weights = self._uniform, self._uniform_log
        t.state = weighted_mean(p, self._uniform)
        t.extent = weighted_extent(p, self._uniform, t.state)
        f.anchor = t.state[list(self.motion.position_dims)]
        return t

    def remove_target(self, target_id: int) -> None:
        """End a live target (no-op for an unknown id); every component forgets it."""
        f = self._filters.pop(target_id, None)
        if f is not None:
            self.likelihood.end_target(f.target)
            self.observation.end_target(f.target)
            self.tracks.end_target(f.target)

    # -- one frame ----------------------------------------------------------------------------

    def step(self, frame: Frame, detections: Detections | None = None) -> list[TrackRecord]:
        """Advance every live target by one frame and return their estimates.

        ``detections`` overrides the tracker's own detector for this frame. The frame runs on
        :meth:`_step_reference` (one target at a time) or on :meth:`_step_rows` (all targets
        as rows of arrays, the same records bit for bit); :meth:`uses_rows` says which. Over
        many frames, timed: :func:`pftrack.engine.runner.run_frames`.
        """
        if detections is None and self.detector is not None:
            detections = self.detector.detect(frame)
        if detections is None and self.detection_driven:
            detections = Detections.empty()
        self.last_detections = detections
        self.tracks.before_frame(self, frame, detections)  # starts due now, appearance scores
        filters = list(self._filters.values())
        if filters and self.uses_rows():
            records, dead, unmatched = self._step_rows(frame, filters, detections)
        else:
            records, dead, unmatched = self._step_reference(frame, filters, detections)
        for tid in dead:
            self.remove_target(tid)
        # per-target observation parameters from the matched detections (a height factor)
        if type(self.observation).update_target is not ObservationModel.update_target:
            for f in self._filters.values():
                if f.target.detection is not None:
                    self.observation.update_target(f.target, f.target.detection.box_xywh_px)
        # births, confirmation, merging, ends, the records to output
        return self.tracks.after_frame(self, frame, detections, records, unmatched)

    def uses_rows(self) -> bool:
        """Whether :meth:`step` runs on the rows backend (:meth:`_step_rows`).

        ``backend="auto"`` (the default): when every per-frame component does its work for all
        targets in one vectorised call -- the motion model overrides
        :meth:`~pftrack.contracts.components.MotionModel.predict_rows`, the observation model
        :meth:`~pftrack.contracts.components.ObservationModel.to_boxes_rows`, the likelihood
        :meth:`~pftrack.contracts.components.Likelihood.offers_rows` -- and the filter resamples
        systematically every frame (``resampling="systematic"``, ``ess_threshold=1``);
        otherwise the reference. ``"rows"`` and ``"reference"`` force one (the records are the
        same; rows with a component lacking its rows method stack its per-target calls).
        """
        if self.backend != "auto":
            return self.backend == "rows"
        return self._rows_components and self.likelihood.offers_rows()

    def _step_reference(self, frame: Frame, filters: list[_Filter],
                        detections: Detections | None) -> tuple[list[TrackRecord], list[int],
                                                                np.ndarray]:
        """The engine's frame, one target at a time: what every backend must equal, record
        for record. Returns ``(records, ids of the targets that died, unmatched detections)``.
        """
        rng = self.rng
        for f in filters:  # 1. predict; the particles' boxes serve associator and likelihood
            p = self.motion.predict(f.particles, self.dt, rng, target=f.target)
            self._moved(f, p, self.observation.to_boxes(p, f.target))
        unmatched = self._associate(filters, detections)  # 2. ``target.detection``
        self.likelihood.begin_frame(frame, [f.target for f in filters], detections)
        logls = [self._log_likelihood(frame, f) for f in filters]  # 3. weight every target
        # 4. normalise, estimate, resample; 5. the filter's own ends
        records, dead = self._filter_each(frame, filters, logls, detections)
        return records, dead, unmatched

    def _filter_each(self, frame: Frame, filters: list[_Filter],
                     logls: Sequence[np.ndarray], detections: Detections | None,
                     ) -> tuple[list[TrackRecord], list[int]]:
        """Steps 4 and 5 target by target (:meth:`_filter_one`): ``(records, dead ids)``."""
        records: list[TrackRecord] = []
        dead: list[int] = []
        recovered = False
        for f, logl in zip(filters, logls):
            record, lost = self._filter_one(frame, f, logl, detections)
            recovered |= lost
            if record is None:
                dead.append(f.target.id)
            else:
                records.append(record)
        if recovered:
            self.recoveries += 1
            log.info("frame %d: every particle weight of a target vanished; re-spread around "
                     "its last estimate", frame.index)
        return records, dead

    def _filter_one(self, frame: Frame, f: _Filter, logl: np.ndarray,
                    detections: Detections | None) -> tuple[TrackRecord | None, bool]:
        """Steps 4 and 5 for one target: normalise its weights (re-spread around the last
        estimate when every weight vanished), estimate, resample (every frame, or when the
        ESS falls below ``ess_threshold * N``), support and misses, death. Returns ``(its
        record or None when it died, whether it was re-spread)``."""
        t, n = f.target, self.n_particles
        w, ok = normalize_log_weights(f.log_weights + logl)
        if not ok:  # nothing explains the observation: re-spread around the last estimate
            f.particles = self.motion.init_states(f.anchor, n, self.rng,
                                                  spread=self.recover_spread)
            w = self._uniform
        best = float(logl.max()) if ok and len(logl) else -math.inf
        state = weighted_mean(f.particles, w)
        t.extent = weighted_extent(f.particles, w, state)
        if self.ess_threshold >= 1.0 or effective_sample_size(w) < self.ess_threshold * n + 1e-9:
            ri = RESAMPLERS[self.resampling](w, self.rng, None)
            # take() is several times faster than fancy indexing for small N, same values
            f.particles = f.particles.take(ri, axis=0)
            t.resample_index = ri if ok else None  # (re-spread particles are not copies)
            f.weights, f.log_weights = self._uniform, self._uniform_log
        else:
            f.weights, f.log_weights = w, np.log(w)
        t.particles = f.particles
        t.state = state
        t.box_xywh_px = box = self.observation.to_boxes(state[None], t)[0]
        pos_dims = list(self.motion.position_dims)
        f.anchor = state[pos_dims]  # a copy
        self._support(t, ok and (t.detection is not None or self._self_supported(best,
                                                                                 detections)))
        box_in_view = type(self.observation).in_view is ObservationModel.in_view
        if self._gone(t, state, box, box_in_view, self.observation, frame, pos_dims):
            return None, not ok
        return self._record(frame, t, best, pos_dims), not ok

    # -- the rows backend (pftrack.engine.rows) ------------------------------------------------

    def _step_rows(self, frame: Frame, filters: list[_Filter],
                   detections: Detections | None) -> tuple[list[TrackRecord], list[int],
                                                           np.ndarray]:
        """The frame on the rows backend: :func:`pftrack.engine.rows.step_rows`."""
        return rows.step_rows(self, frame, filters, detections)

    def _log_likelihood_rows(self, frame: Frame, filters: list[_Filter], boxes: np.ndarray,
                             p: np.ndarray) -> np.ndarray:
        """:func:`pftrack.engine.rows.log_likelihood_rows`."""
        return rows.log_likelihood_rows(self, frame, filters, boxes, p)

    def _weigh_rows(self, lw: np.ndarray, filters: list[_Filter], p: np.ndarray,
                    ) -> tuple[Any, ...] | None:
        """:func:`pftrack.engine.rows.weigh_rows`."""
        return rows.weigh_rows(self, lw, filters, p)

    def _finish_rows(self, frame: Frame, filters: list[_Filter], detections: Detections | None,
                     states: np.ndarray, extents: np.ndarray, best_rows: list[float],
                     resampled: np.ndarray, resample_rows: np.ndarray,
                     ) -> tuple[list[TrackRecord], list[int]]:
        """:func:`pftrack.engine.rows.finish_rows`."""
        return rows.finish_rows(self, frame, filters, detections, states, extents, best_rows,
                                resampled, resample_rows)

    def _stacked_particles(self, filters: list[_Filter]) -> np.ndarray:
        """:func:`pftrack.engine.rows.stacked_particles`."""
        return rows.stacked_particles(self, filters)

    # -- the parts of a frame -----------------------------------------------------------------

    def _moved(self, f: _Filter, particles: np.ndarray, boxes: np.ndarray) -> None:
        """A target's predicted particles and their boxes, at the start of its frame."""
        t = f.target
        f.particles = t.particles = particles
        t.particle_boxes_xywh_px = boxes
        t.resample_index = None
        t.age += 1
        t.detection = None

    def _associate(self, filters: list[_Filter], detections: Detections | None) -> np.ndarray:
        """Match the frame's detections to the targets (``target.detection``), redraw a share
        of each matched target's particles at its detection (``detection_proposal``); returns
        the rows of ``detections`` no target matched."""
        if detections is None:
            return _NO_DETECTIONS
        if self.associator is None or not filters:
            return np.arange(len(detections))
        targets = [f.target for f in filters]
        a = self.associator.associate(targets, detections)
        for ti, di in a.matches:
            targets[ti].detection = DetectionMatch(detections.boxes_xywh_px[di],
                                                   float(detections.scores[di]), int(di))
        if self.detection_proposal > 0.0 and len(a.matches):
            self._propose_at_detections(targets)
        return a.unmatched_detections

    def _self_supported(self, best: float, detections: Detections | None) -> bool:
        """Whether a frame supports a target without a matched detection: its best particle's
        log-likelihood reaches ``min_log_likelihood``, or the run has neither detections nor
        that threshold."""
        mll = self.min_log_likelihood
        return (mll is not None and best >= mll) or (detections is None and mll is None)

    @staticmethod
    def _support(t: Target, supported: bool) -> None:
        t.frames_tracked = t.frames_tracked + 1 if supported else 0
        t.misses = 0 if supported else t.misses + 1

    def _log_likelihood(self, frame: Frame, f: _Filter) -> np.ndarray:
        """One target's log-likelihoods (N,) from :meth:`Likelihood.log_likelihood`, checked
        (dtype, shape, no NaN or +inf), zero outside the valid regions; kept in
        ``target.log_likelihoods``."""
        t = f.target
        try:
            logl = self.likelihood.log_likelihood(t.particle_boxes_xywh_px, t)  # type: ignore[arg-type]
        except (ValueError, OSError) as exc:  # bad input met at run time: still exit 2
            raise ValueError(f"{self._who(self.likelihood)}: {exc}") from exc
        except Exception as exc:
            raise ComponentOutputError(
                f"{self._who(self.likelihood)} raised {type(exc).__name__}: {exc} (frame "
                f"{frame.index}, target {t.id})") from exc
        if type(logl) is not np.ndarray or logl.dtype != np.float64:
            logl = self._checked_dtype(logl)
        if logl.shape != (len(f.particles),):
            raise ComponentOutputError(
                f"{self._who(self.likelihood)} returned log-likelihoods of shape "
                f"{logl.shape}, expected ({len(f.particles)},) (one per particle)")
        self._check_finite(logl, frame, t)
        pos_dims = list(self.motion.position_dims)
        if self.valid_region is not None:
            logl = np.where(self.valid_region(f.particles[:, pos_dims]), logl, -np.inf)
        if t.valid_region is not None:
            logl = np.where(t.valid_region(f.particles[:, pos_dims]), logl, -np.inf)
        t.log_likelihoods = logl
        return logl


    def _propose_at_detections(self, targets: list[Target]) -> None:
        """Redraw ``detection_proposal`` of each matched target's predicted particles around
        its detection's position (in place: the stacked rows and their boxes stay shared).
        Which particles (``k`` of the ``N``, uniformly without replacement: the ``k`` smallest
        of ``N`` uniform keys) and their new positions (``init_spread`` about the detection's)
        are drawn for all matched targets at once, in that order."""
        n = self.n_particles
        k = int(round(self.detection_proposal * n))
        if k < 1:
            return
        chosen, centres = [], []
        for t in targets:
            if t.detection is None or t.particles is None or len(t.particles) != n:
                continue
            pos = self.observation.position_from_box(
                np.asarray(t.detection.box_xywh_px, dtype=np.float64))
            if np.all(np.isfinite(pos)):
                chosen.append(t)
                centres.append(pos)
        if not chosen:
            return
        m = len(chosen)
        pos_dims = list(self.motion.position_dims)
        idx = np.sort(np.argpartition(self.rng.random((m, n)), k - 1, axis=1)[:, :k], axis=1)
        # Gaussian about the origin (the motion model's own start), moved to each detection
        fresh = self.motion.init_states(np.zeros(len(pos_dims)), m * k, self.rng,
                                        spread=self.init_spread)
        # the chosen particles of each target, (m, k, D)
        rows = np.array([t.particles[i] for t, i in zip(chosen, idx)])  # type: ignore[index]
        rows[:, :, pos_dims] = (fresh[:, pos_dims].reshape(m, k, len(pos_dims))
                                + np.array(centres)[:, None, :])
        boxes = self.observation.to_boxes_rows(rows, chosen)
        for t, i, r, b in zip(chosen, idx, rows, boxes):
            t.particles[i] = r  # type: ignore[index]
            if t.particle_boxes_xywh_px is not None:
                t.particle_boxes_xywh_px[i] = b


    def _pos_index(self, pos_dims: list[int]) -> slice | list[int]:
        """``pos_dims`` as a slice when they are consecutive (a basic index: no fancy-index
        machinery), else the list."""
        hit = self.__dict__.get("_pos_slice")
        if hit is not None and hit[0] == pos_dims:
            return hit[1]
        index: slice | list[int] = pos_dims
        if pos_dims and pos_dims == list(range(pos_dims[0], pos_dims[0] + len(pos_dims))):
            index = slice(pos_dims[0], pos_dims[0] + len(pos_dims))
        self._pos_slice = (list(pos_dims), index)
        return index

    def _gone(self, t: Target, state: np.ndarray, box: np.ndarray, box_in_view: bool,
              observation: ObservationModel, frame: Frame, pos_dims: list[int]) -> bool:
        """Step 5 for one target at the end of a frame: whether it dies (more than
        ``max_misses`` frames unsupported, out of view under ``kill_out_of_view`` -- by its box
        when ``box_in_view``, else by the observation model -- or outside ``valid_region``)."""
        gone = self.max_misses is not None and t.misses > self.max_misses
        if self.kill_out_of_view:
            if box_in_view:
                img_w, img_h = frame.size_wh
                bx, by, bw, bh = box.tolist()
                visible = bx < img_w and by < img_h and bx + bw > 0 and by + bh > 0
            else:
                visible = observation.in_view(state[None], frame.size_wh, t)[0]
            if not visible:
                gone = True
        if self.valid_region is not None and not self.valid_region(state[None, pos_dims])[0]:
            gone = True
        return bool(gone)

    def record(self, frame: Frame, target: Target, best_logl: float = 0.0) -> TrackRecord:
        """``target``'s current estimate as a :class:`TrackRecord` of ``frame`` (confidence
        ``expit(best_logl)``: 0.5 by default, as for a target born this frame)."""
        return self._record(frame, target, best_logl)

    def _record(self, frame: Frame, t: Target, best_logl: float,
                pos_dims: list[int] | None = None,
                confidence: float | None = None) -> TrackRecord:
        """``confidence``: ``expit(best_logl)`` when already computed (with the others')."""
        world = self.observation.world_position(t.state)
        if pos_dims is None:
            pos_dims = list(self.motion.position_dims)
        if not math.isfinite(best_logl):
            confidence = 0.0
        elif confidence is None:
            confidence = float(expit(best_logl))
        return TrackRecord(
            frame=frame.index, id=t.id, box_xywh_px=t.box_xywh_px.copy(), state=t.state.copy(),
            position=t.state[pos_dims],  # fancy indexing: already a copy
            extent=t.extent.copy(),  # type: ignore[union-attr]
            confidence=confidence,
            world_m=None if world is None else np.asarray(world, dtype=np.float64),
        )
