"""The track lifecycle as stages: which tracks start, which are believed, which end, which two
are one, and what is output.

Track management is a list of stages, each a :class:`LifecycleStage` component with a narrow
contract (as Stone Soup's tracker loop has an initiator and a deleter, each a component of its
own). A stage sees the frame and the live tracks read-only (:class:`FrameView`,
:class:`TrackView`), keeps its own per-track state keyed by track id, and returns decisions
(:class:`Birth`, :class:`End`, :class:`Confirm`, :class:`Hide`, :class:`OutputBox`,
:class:`OutputAs`, :class:`Resize`, :class:`AppearanceScores`, :class:`Mask`,
:class:`Particles`). No stage receives the engine; one runner, :class:`LifecycleTracks`, calls
the stages and applies their decisions: births, particles and ends through the engine's public
methods (``add_target``, ``set_particles``, ``remove_target``, ``record``), output ids on the
records it returns, and the per-target fields the engine reads but has no method for
(``Target.appearance_scores``, ``Target.box_wh_px``, ``Target.valid_region``, a newborn's
``frames_tracked``) by setting them on its targets.

Roles and the order the runner calls them in, each frame::

    detections
      -> before predict:
           1. initiator.scheduled      births due at this frame (given boxes, detection
                                       groups); when there were some, masker.mask (as in 10)
           2. reidentifier.scores      each track's appearance similarity to the detections,
                                       for the associator (``Target.appearance_scores``)
      -> the engine: predict, associate, weight, estimate, resample, the filter's own deaths
      -> after the estimates (``records``: this frame's estimate of each live track):
           3. sizer.resize             each track's own box size (``Target.box_wh_px``)
           4. reporter.report          this frame's output boxes, tracks hidden from the output
           5. confirmer.confirm        tentative -> confirmed (their held-back records are
                                       output from birth on, now or with ``Confirm.at_end`` at
                                       the end of the frame), or ended unconfirmed
           6. terminator.terminate     other ends (left the picture, a given last frame)
              the output is assembled here: the records just confirmed, then the records of
              the confirmed tracks that are neither ended (``End.output`` False) nor hidden
           7. merger.merge             two confirmed tracks that are one object: one ends, its
                                       record of this frame is withdrawn
           8. initiator.initiate       new tracks from the detections no track explains; each
                                       output at once, or held back while a confirmer says it
                                       is tentative (with :class:`Particles` decisions among
                                       them, applied in the order returned); the reporters'
                                       ``report_started`` gives each first record its box or
                                       hides it
           9. masker.mask              where each track's particles may live from the next
                                       weighting on (``Target.valid_region``)
              the records confirmed with ``Confirm.at_end`` whose tracks are still live join
              the output
          10. reidentifier.observe     per-track appearance models learn from the frame's
                                       tracks (matched detections, this frame's estimates);
                                       :class:`OutputAs` decisions give the output records
                                       their output ids
      -> list[TrackRecord]

Stages of one role run in the order they are listed, each seeing the tracks as they were when
the role began. An initiator's decisions are applied one at a time as it returns them (a
generator is resumed after each), and every stage hears of a birth before the next decision is
asked for. Every stage is told of each track that starts
(:meth:`LifecycleStage.track_started`) and ends, whoever ended it
(:meth:`LifecycleStage.track_ended`), to keep or drop its per-track state.

A configuration lists the stages explicitly (``tracks: {type: stages, params: {stages:
[...]}}``, :class:`StagedTracks`); the named track managers (``manual``, ``births``,
``confirmed``, ``given-boxes``) are fixed lists of stages built from their parameters.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from pftrack.contracts.components import (
    Detections,
    Frame,
    Param,
    RunContext,
    Target,
    TrackManager,
    TrackRecord,
)
from pftrack.contracts.stages import (
    ROLES,
    Birth,
    Confirm,
    End,
    FrameView,
    Hide,
    LifecycleStage,
    Mask,
    ModelView,
    OutputAs,
    OutputBox,
    Particles,
    TrackView,
    _frozen,
)

__all__ = [
    "LifecycleTracks",
    "ManualTracks",
    "StagedTracks",
]


# --------------------------------------------------------------------------------------------
# The runner
# --------------------------------------------------------------------------------------------


class LifecycleTracks(TrackManager):
    """Runs lifecycle stages in the fixed order of :mod:`pftrack.engine.lifecycle` and applies their
    decisions through the engine's public methods; the engine sees it as its track manager.

    Subclasses say which stages (:meth:`build_stages`). The stages are built once, on first use.

    Attributes
    ----------
    stages_ : list of LifecycleStage
        The stages, in the order given.
    tentative_ : dict[int, list of TrackRecord]
        Tentative tracks by id, with their records held back so far.
    """

    def build_stages(self) -> list[LifecycleStage]:
        """The stages this manager runs (default: none)."""
        return []

    def setup(self, context: RunContext) -> None:
        """Build the stages and hand each the run's context."""
        for s in self._stages():
            s.setup(context)

    # -- state ------------------------------------------------------------------------------

    def _stages(self) -> list[LifecycleStage]:
        st = self.__dict__.get("stages_")
        if st is None:
            st = self.stages_ = list(self.build_stages())
            for s in st:
                if not isinstance(s, LifecycleStage) or s.role not in ROLES:
                    raise ValueError(f"tracks {self.name or type(self).__name__!r}: {s!r} is "
                                     f"not a lifecycle stage of a known role {ROLES}")
            # each role's stages, typed loosely: a role's methods are its subclass's
            self.by_role_: dict[str, list[Any]] = {r: [s for s in st if s.role == r]
                                                   for r in ROLES}
            # whether a tentative track's hidden records are held back (every confirmer agrees)
            self.holds_hidden_ = all(c.holds_hidden for c in self.by_role_["confirmer"])
        return st

    @property
    def tentative_(self) -> dict[int, list[TrackRecord]]:
        return self.__dict__.setdefault("_tentative", {})

    def end_target(self, target: Target) -> None:
        self.tentative_.pop(target.id, None)
        for s in self._stages():
            s.track_ended(target.id)

    # -- views ------------------------------------------------------------------------------

    def _models(self, engine: Any) -> ModelView:
        """The run's models as a :class:`ModelView` (tracks looked up when a stage asks)."""
        obs, motion, lik = engine.observation, engine.motion, engine.likelihood

        def target(track_id: int) -> Target | None:
            for t in engine.targets:
                if t.id == track_id:
                    return t
            return None

        def boxes(states: np.ndarray, track_id: int | None) -> np.ndarray:
            return obs.to_boxes(states, None if track_id is None else target(track_id))

        def log_likelihood(b: np.ndarray, track_id: int) -> np.ndarray:
            t = target(track_id)
            if t is None:
                raise ValueError(f"log_likelihood: no live track {track_id}")
            return lik.log_likelihood(b, t)

        vel = getattr(motion, "velocity_dims", None)
        return ModelView(tuple(motion.position_dims), None if vel is None else tuple(vel),
                         float(engine.dt), boxes, obs.position_from_box, obs.world_position,
                         engine.valid_region, log_likelihood,
                         int(getattr(engine, "n_particles", 0)),
                         int(getattr(motion, "state_dim", 0)))

    @staticmethod
    def _read_only(frame: Frame, detections: Detections | None,
                   ) -> tuple[Frame, Detections | None]:
        """The frame and detections as stages see them: read-only views (no copies)."""
        f = Frame(frame.index, _frozen(frame.image), frame.time_s)  # type: ignore[arg-type]
        if detections is None:
            return f, None
        return f, Detections(_frozen(detections.boxes_xywh_px),  # type: ignore[arg-type]
                             _frozen(detections.scores),  # type: ignore[arg-type]
                             _frozen(detections.points_world_m))

    def _view(self, engine: Any, frame: Frame, detections: Detections | None,
              unmatched: np.ndarray, claimed: frozenset[int], models: ModelView) -> FrameView:
        tent = self.tentative_
        return FrameView(frame=frame, detections=detections,
                         tracks=tuple(TrackView.of(t, t.id in tent) for t in engine.targets),
                         unmatched=unmatched, claimed=claimed, models=models, rng=engine.rng)

    # -- applying decisions -----------------------------------------------------------------

    def _apply_births(self, engine: Any, frame: Frame, births: Iterable[Birth | Particles],
                      out: list[TrackRecord] | None) -> None:
        """Start the tracks (and set the particles of :class:`Particles` decisions), one
        decision at a time in the order given; ``out`` (after the estimates): the new tracks'
        first records go there, or are held back while tentative."""
        from pftrack.geometry.boxes import iou_matrix

        confirmers = self.by_role_["confirmer"]
        reporters = self.by_role_["reporter"]
        for b in births:
            if isinstance(b, Particles):
                if any(t.id == b.track_id for t in engine.targets):
                    engine.set_particles(b.track_id, b.particles)
                continue
            if b.max_iou is not None and b.box_xywh_px is not None:
                taken = [t.box_xywh_px for t in engine.targets]
                if taken and iou_matrix(np.asarray(b.box_xywh_px, dtype=np.float64),
                                        np.array(taken)).max() > b.max_iou:
                    continue
            t = engine.add_target(frame, b.position, box_xywh_px=b.box_xywh_px,
                                  target_id=b.track_id)
            if b.particles is not None:
                engine.set_particles(t.id, b.particles)
            if b.supported:
                t.frames_tracked = 1
            tentative = any(c.tentative(b) for c in confirmers)
            rec = engine.record(frame, t) if out is not None else None
            if tentative:
                self.tentative_[t.id] = []
            view = TrackView.of(t, tentative)
            for s in self.stages_:
                s.track_started(view, b)
            if rec is None or out is None:
                continue
            hidden: set[int] = set()
            for s in reporters:
                self._apply_outputs(s.report_started(view, b), {t.id: rec}, hidden)
            shown = t.id not in hidden
            if tentative:
                if shown or self.holds_hidden_:
                    self.tentative_[t.id].append(rec)
            elif shown:
                out.append(rec)

    def _end(self, engine: Any, decisions: Iterable[Any], withdrawn: set[int]) -> None:
        """Apply the :class:`End` decisions; the ended tracks whose record of this frame is
        not output (``End.output`` False, or never confirmed) go to ``withdrawn``."""
        for d in decisions:
            if isinstance(d, End):
                if not d.output or d.track_id in self.tentative_:
                    withdrawn.add(d.track_id)
                engine.remove_target(d.track_id)

    def _apply_masks(self, engine: Any, view: FrameView) -> None:
        """Ask the maskers and set the live tracks' ``Target.valid_region`` (a region that
        reads the particles' boxes, ``Mask.boxes``, through :class:`_BoxedRegion`)."""
        live = {t.id: t for t in engine.targets}
        for s in self.by_role_["masker"]:
            for d in s.mask(view):
                if isinstance(d, Mask) and d.track_id in live:
                    t = live[d.track_id]
                    t.valid_region = _BoxedRegion(d.region, t) if d.boxes and \
                        d.region is not None else d.region

    @staticmethod
    def _apply_outputs(decisions: Iterable[Any], by_id: dict[int, TrackRecord],
                       hidden: set[int]) -> None:
        """Apply :class:`OutputBox` decisions to the records ``by_id`` (each record owns its
        box: written in place) and gather the :class:`Hide` decisions' ids in ``hidden``."""
        for d in decisions:
            if isinstance(d, Hide):
                hidden.add(d.track_id)
            elif isinstance(d, OutputBox) and d.track_id in by_id:
                r = by_id[d.track_id]
                r.box_xywh_px[:] = d.box_xywh_px
                if d.world_m is not None:
                    r.world_m = np.array(d.world_m, dtype=np.float64)
                if d.size_m is not None:
                    r.size_m = np.array(d.size_m, dtype=np.float64)

    # -- the engine's two calls -------------------------------------------------------------

    def before_frame(self, engine: Any, frame: Frame, detections: Detections | None) -> None:
        """Steps 1-2: given starts, then appearance scores for the associator."""
        stages = self._stages()
        if not stages:
            return
        roles = self.by_role_
        every = np.arange(len(detections)) if detections is not None else np.zeros(0, int)
        every.flags.writeable = False
        models = self._models(engine)
        seen, seen_detections = self._read_only(frame, detections)
        if roles["initiator"]:
            view = self._view(engine, seen, seen_detections, every, frozenset(), models)
            n = len(engine.targets)
            for s in roles["initiator"]:
                self._apply_births(engine, frame, s.scheduled(view), None)
            if roles["masker"] and len(engine.targets) != n:
                self._apply_masks(engine, self._view(engine, seen, seen_detections, every,
                                                     frozenset(), models))
        if roles["reidentifier"]:
            view = self._view(engine, seen, seen_detections, every, frozenset(), models)
            live = {t.id: t for t in engine.targets}
            for s in roles["reidentifier"]:
                d = s.scores(view)
                if d is None:
                    continue
                for tid, sc in d.scores.items():
                    if tid in live:
                        live[tid].appearance_scores = sc

    def after_frame(self, engine: Any, frame: Frame, detections: Detections | None,
                    records: list[TrackRecord], unmatched_detections: np.ndarray,
                    ) -> list[TrackRecord]:
        """Steps 3-10 (see the module docstring); returns the records to output now."""
        stages = self._stages()
        if not stages:
            return records
        roles = self.by_role_
        claimed = frozenset(t.detection.index for t in engine.targets
                            if t.detection is not None)
        models = self._models(engine)
        seen, seen_detections = self._read_only(frame, detections)
        unmatched = _frozen(np.asarray(unmatched_detections))

        def view() -> FrameView:
            """The tracks as they are now (rebuilt only after a role changed them)."""
            return self._view(engine, seen, seen_detections, unmatched,  # type: ignore[arg-type]
                              claimed, models)

        v = view()
        by_id = {r.id: r for r in records}
        if roles["sizer"]:
            live = {t.id: t for t in engine.targets}
            resized = False
            for s in roles["sizer"]:
                for d in s.resize(v):
                    t = live.get(d.track_id)
                    if t is None:
                        continue
                    resized = True
                    t.box_wh_px = d.box_wh_px
                    if d.box_xywh_px is not None:
                        t.box_xywh_px = np.array(d.box_xywh_px, dtype=np.float64)
                        if d.track_id in by_id:
                            by_id[d.track_id].box_xywh_px = np.array(d.box_xywh_px,
                                                                     dtype=np.float64)
            if resized:
                v = view()
        hidden: set[int] = set()
        for s in roles["reporter"]:
            self._apply_outputs(s.report(v), by_id, hidden)
        tentative = self.tentative_
        out: list[TrackRecord] = []
        withdrawn: set[int] = set()
        at_end: dict[int, list[TrackRecord]] = {}  # confirmed, output at the end if still live
        if roles["confirmer"]:
            for tid, held in tentative.items():
                if tid in by_id and (self.holds_hidden_ or tid not in hidden):
                    held.append(by_id[tid])
            decided = False
            for s in roles["confirmer"]:
                for d in s.confirm(v):
                    decided = True
                    if isinstance(d, Confirm) and d.track_id in tentative:
                        if d.at_end:
                            at_end[d.track_id] = tentative.pop(d.track_id)
                        else:
                            out.extend(tentative.pop(d.track_id))
                    elif isinstance(d, End):
                        self._end(engine, [d], withdrawn)
            if decided:
                v = view()
        ended: list[End] = []
        for s in roles["terminator"]:
            ends = list(s.terminate(v))
            self._end(engine, ends, withdrawn)
            ended += ends
        if ended:
            v = view()
        flushed = {id(r) for r in out}
        flushed.update(id(r) for held in at_end.values() for r in held)
        for r in records:
            if (r.id not in withdrawn and r.id not in tentative and id(r) not in flushed
                    and r.id not in hidden):
                out.append(r)
        gone: set[int] = set()
        merged: list[End] = []
        for s in roles["merger"]:
            ends = list(s.merge(v))
            self._end(engine, ends, gone)
            merged += ends
        if gone:
            out = [r for r in out if r.id not in gone or r.frame != frame.index]
        if merged:
            v = view()
        for s in roles["initiator"]:
            self._apply_births(engine, frame, s.initiate(v), out)
        if roles["masker"]:
            self._apply_masks(engine, view())
        if at_end:
            alive = {t.id for t in engine.targets}
            for tid, held in at_end.items():
                if tid in alive:
                    out.extend(held)
        if roles["reidentifier"]:
            v = view()
            output_as: dict[int, int] = {}
            for s in roles["reidentifier"]:
                for d in s.observe(v) or ():
                    if isinstance(d, OutputAs):
                        output_as[d.track_id] = int(d.output_id)
            if output_as:
                for r in out:
                    if r.id in output_as:
                        r.id = output_as[r.id]
        return out


class _BoxedRegion:
    """A :class:`Mask` region that reads the particles' image boxes (``Mask.boxes``), as the
    engine's ``Target.valid_region``: called with the positions being weighted, it passes the
    region those positions and the target's particle boxes of this frame (read-only; None when
    the target has none). Picklable when the region is."""

    def __init__(self, region: Any, target: Target) -> None:
        self.region, self.target = region, target

    def __call__(self, positions: np.ndarray) -> np.ndarray:
        return self.region(positions, _frozen(self.target.particle_boxes_xywh_px))


class StagedTracks(LifecycleTracks):
    """Track management as an explicit list of lifecycle stages (see :mod:`pftrack.engine.lifecycle`
    for the roles and the order they run in), e.g. the configuration ``tracks: {type: stages,
    params: {stages: [{type: detection-births, params: {min_score: 0.5}}, hit-confirmation,
    duplicate-merge]}}`` (a full example: the docs page "How tracks start, are confirmed and end").

    {params}
    """

    stages: list[Any] | None = Param(
        None, "The stages, each a registered stage name or ``{type: NAME, params: {...}}``; "
        "stages of one role run in this order (none: no stages, as ``manual``).")

    def setup(self, context: RunContext) -> None:
        """Build the stages through the run's host and hand each the context."""
        self._build_host = context.get_host()  # only while building: a host does not pickle
        try:
            super().setup(context)
        finally:
            del self._build_host

    def build_stages(self) -> list[LifecycleStage]:
        host = self.__dict__.get("_build_host")
        if host is None:
            from pftrack.host import get_host

            host = get_host()
        specs = [] if self.stages is None else self.stages
        if not isinstance(specs, (list, tuple)):
            raise ValueError(  # noqa: TRY004 - a configuration error: exit 2, as all are
                f"tracks.stages must be a list of stages, got {self.stages!r}")
        out = []
        for k, spec in enumerate(specs):
            try:
                out.append(host.build("stage", spec))
            except (KeyError, ValueError, TypeError) as exc:
                raise ValueError(f"tracks.stages[{k}]: {exc}") from None
        return out  # type: ignore[return-value]


class ManualTracks(LifecycleTracks):
    """The default track management: no stages. Targets are added by the caller
    (:meth:`pftrack.engine.tracker.MultiTargetTracker.add_target`), end only by the filter's own
    rules, and every live target's estimate is output. No parameters."""
