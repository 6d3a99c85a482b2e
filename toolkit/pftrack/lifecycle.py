"""The track lifecycle as stages: which tracks start, which are believed, which end, which two
are one, and what is output.

Track management is a list of stages, each a :class:`LifecycleStage` component with a narrow
contract (as Stone Soup's tracker loop has an initiator and a deleter, each a component of its
own). A stage sees the frame and the live tracks read-only (:class:`FrameView`,
:class:`TrackView`), keeps its own per-track state keyed by track id, and returns decisions
(:class:`Birth`, :class:`End`, :class:`Confirm`, :class:`Hide`, :class:`OutputBox`,
:class:`Resize`, :class:`AppearanceScores`). No stage receives the engine; one runner,
:class:`LifecycleTracks`, calls the stages and applies their decisions: births and ends through
the engine's public methods (``add_target``, ``remove_target``, ``record``), and the per-target
fields the engine reads but has no method for (``Target.appearance_scores``,
``Target.box_wh_px``, a newborn's ``frames_tracked``) by setting them on its targets.

Roles and the order the runner calls them in, each frame::

    detections
      -> before predict:
           1. initiator.scheduled      births due at this frame (given boxes)
           2. reidentifier.scores      each track's appearance similarity to the detections,
                                       for the associator (``Target.appearance_scores``)
      -> the engine: predict, associate, weight, estimate, resample, the filter's own deaths
      -> after the estimates (``records``: this frame's estimate of each live track):
           3. reidentifier.observe     per-track appearance models learn from matched detections
           4. sizer.resize             each track's own box size (``Target.box_wh_px``)
           5. reporter.report          this frame's output boxes, tracks hidden from the output
           6. confirmer.confirm        tentative -> confirmed (their held-back records are
                                       output from birth on), or ended unconfirmed
           7. terminator.terminate     other ends (left the picture, a given last frame)
              the output is assembled here: the records just confirmed, then the records of
              the confirmed tracks that are neither ended (``End.output`` False) nor hidden
           8. merger.merge             two confirmed tracks that are one object: one ends, its
                                       record of this frame is withdrawn
           9. initiator.initiate       new tracks from the detections no track explains; each
                                       output at once, or held back while a confirmer says it
                                       is tentative
      -> list[TrackRecord]

Stages of one role run in the order they are listed, each seeing the tracks as they were when
the role began. Every stage is told of each track that starts
(:meth:`LifecycleStage.track_started`) and ends, whoever ended it
(:meth:`LifecycleStage.track_ended`), to keep or drop its per-track state.

A configuration lists the stages explicitly (``tracks: {type: stages, params: {stages:
[...]}}``, :class:`StagedTracks`); the named track managers (``manual``, ``births``,
``confirmed``, ``given-boxes``) are fixed lists of stages built from their parameters.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from pftrack.components import (
    Component,
    DetectionMatch,
    Detections,
    Frame,
    RunContext,
    Target,
    TrackManager,
    TrackRecord,
)

__all__ = [
    "AppearanceScores",
    "Birth",
    "Confirm",
    "Confirmer",
    "Decision",
    "End",
    "FrameView",
    "Hide",
    "Initiator",
    "LifecycleStage",
    "LifecycleTracks",
    "ManualTracks",
    "Merger",
    "ModelView",
    "OutputBox",
    "Reidentifier",
    "Reporter",
    "ROLES",
    "Resize",
    "Sizer",
    "StagedTracks",
    "Terminator",
    "TrackView",
]


# --------------------------------------------------------------------------------------------
# What a stage sees
# --------------------------------------------------------------------------------------------


def _frozen(a: np.ndarray | None) -> np.ndarray | None:
    """A read-only view of ``a`` (no copy): a stage cannot write into the engine's arrays."""
    if a is None:
        return None
    v = a.view()
    v.flags.writeable = False
    return v


@dataclass(frozen=True)
class TrackView:
    """One live track as a stage sees it (read-only).

    Attributes
    ----------
    id : int
        Track id (positive).
    state : ndarray, shape (D,), read-only
        The current estimate in the motion model's state space (position in pixels for
        image-plane models, world metres for ground-plane ones).
    box_xywh_px : ndarray, shape (4,), read-only
        The estimate as an image box (left, top, width, height), pixels.
    age : int
        Frames since birth (frames).
    misses : int
        Consecutive frames without support (frames).
    frames_tracked : int
        Consecutive frames with support (frames).
    detection : DetectionMatch or None
        The detection matched to the track in this frame (None before association and when
        unmatched).
    box_wh_px : (float, float) or None
        The track's own image box size (width, height), pixels, when its observation model
        keeps one per track.
    tentative : bool
        Not yet confirmed (its records are held back until a confirmer confirms it).
    """

    id: int
    state: np.ndarray
    box_xywh_px: np.ndarray
    age: int
    misses: int
    frames_tracked: int
    detection: DetectionMatch | None
    box_wh_px: tuple[float, float] | None
    tentative: bool

    @classmethod
    def of(cls, t: Target, tentative: bool) -> TrackView:
        d = t.detection
        if d is not None:  # its box is a row of the frame's detections: read-only too
            d = DetectionMatch(_frozen(d.box_xywh_px), d.score, d.index)  # type: ignore[arg-type]
        return cls(id=t.id, state=_frozen(t.state), box_xywh_px=_frozen(t.box_xywh_px),  # type: ignore[arg-type]
                   age=t.age, misses=t.misses, frames_tracked=t.frames_tracked,
                   detection=d, box_wh_px=t.box_wh_px, tentative=tentative)


@dataclass(frozen=True)
class ModelView:
    """Questions about positions and boxes that the run's models answer, without the engine.

    Attributes
    ----------
    position_dims : tuple of int
        The entries of a state that are its position.
    velocity_dims : tuple of int or None
        The entries that are its velocity (None: the motion model has none).
    dt : float
        Time step per frame, in the motion model's unit (frames or seconds).
    """

    position_dims: tuple[int, ...]
    velocity_dims: tuple[int, ...] | None
    dt: float
    _boxes: Callable[[np.ndarray, int | None], np.ndarray]
    _position_from_box: Callable[[np.ndarray], np.ndarray]
    _world: Callable[[np.ndarray], np.ndarray | None]
    _region: Callable[[np.ndarray], np.ndarray] | None
    _log_likelihood: Callable[[np.ndarray, int], np.ndarray]

    def boxes(self, states: np.ndarray, track_id: int | None = None) -> np.ndarray:
        """States (N, D) -> image boxes (N, 4) xywh px, with track ``track_id``'s own box size
        when it has one."""
        return self._boxes(np.asarray(states, dtype=np.float64), track_id)

    def position_from_box(self, box_xywh_px: np.ndarray) -> np.ndarray:
        """An image box (4,) -> the state-space position (P,) a track started from it gets."""
        return self._position_from_box(np.asarray(box_xywh_px, dtype=np.float64))

    def world_position(self, state: np.ndarray) -> np.ndarray | None:
        """Ground position (x, y, z) in world metres of a state (D,), or None (no world frame)."""
        return self._world(state)

    def in_region(self, positions: np.ndarray) -> np.ndarray:
        """Boolean (N,): the positions (N, P) lie in the run's valid region (all True when the
        run has none)."""
        p = np.asarray(positions, dtype=np.float64)
        if self._region is None:
            return np.ones(len(p), dtype=bool)
        return np.asarray(self._region(p), dtype=bool)

    def log_likelihood(self, boxes_xywh_px: np.ndarray, track_id: int) -> np.ndarray:
        """The run's likelihood of boxes (N, 4) xywh px for track ``track_id`` (N,): a box size
        search asks it."""
        return self._log_likelihood(boxes_xywh_px, track_id)


@dataclass(frozen=True)
class FrameView:
    """One frame as a stage sees it (read-only).

    Attributes
    ----------
    frame : Frame
        The frame, its image read-only.
    detections : Detections or None
        The frame's detections, read-only (None when the run has none).
    tracks : tuple of TrackView
        The live tracks, in id order, as they are when the stage is called.
    unmatched : ndarray of int
        Rows of ``detections`` the associator matched to no track (before association: all).
    claimed : frozenset of int
        Rows of ``detections`` matched to a track that outlived the filter's own deaths, even
        if a stage ended it in this frame: what a birth should not take again.
    models : ModelView
        Boxes, positions and likelihoods from the run's models.
    """

    frame: Frame
    detections: Detections | None
    tracks: tuple[TrackView, ...]
    unmatched: np.ndarray
    claimed: frozenset[int]
    models: ModelView

    def track(self, track_id: int) -> TrackView | None:
        """The live track ``track_id``, or None."""
        for t in self.tracks:
            if t.id == track_id:
                return t
        return None


# --------------------------------------------------------------------------------------------
# What a stage decides
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Birth:
    """Start a track.

    Attributes
    ----------
    box_xywh_px : ndarray, shape (4,), optional
        The image box (left, top, width, height), pixels, it starts from.
    position : ndarray, shape (P,), optional
        Or its state-space position (pixels or world metres); one of the two is needed.
    track_id : int, optional
        The id to give it (a given track's own id); default: the next free id.
    detection_index : int, optional
        The row of this frame's detections it starts from (stages keep e.g. its colour).
    supported : bool
        Its first frame counts as supported (``frames_tracked`` 1): it starts from a detection.
    max_iou : float, optional
        Skip this birth when its box overlaps a live track's box, or the box of a track born
        before it in this frame, by more than this intersection over union (unit: 1). None: no
        test.
    """

    box_xywh_px: np.ndarray | None = None
    position: np.ndarray | None = None
    track_id: int | None = None
    detection_index: int | None = None
    supported: bool = True
    max_iou: float | None = None


@dataclass(frozen=True)
class End:
    """End a live track.

    Attributes
    ----------
    track_id : int
    reason : str
        Why, in a few words (``"unconfirmed"``, ``"duplicate"``, ``"left the picture"``).
    output : bool
        Whether its record of this frame is still output (a track whose last frame this is);
        False: withdrawn.
    """

    track_id: int
    reason: str
    output: bool = False


@dataclass(frozen=True)
class Confirm:
    """A tentative track is believed: its records from birth on are output now."""

    track_id: int


@dataclass(frozen=True)
class Hide:
    """Leave a confirmed track's record of this frame out of the output (it stays tracked)."""

    track_id: int


@dataclass(frozen=True)
class OutputBox:
    """The box (4,) xywh px that the track's record of this frame carries (the output only:
    the filter's state is its own)."""

    track_id: int
    box_xywh_px: np.ndarray


@dataclass(frozen=True)
class Resize:
    """The track's own image box size from now on (``box_wh_px``, width and height in pixels)
    and, optionally, its estimate's box in this frame (4,) xywh px, record included."""

    track_id: int
    box_wh_px: tuple[float, float]
    box_xywh_px: np.ndarray | None = None


@dataclass(frozen=True)
class AppearanceScores:
    """Each track's appearance similarity (K,) in [0, 1] to this frame's K detections, for the
    associator (``Target.appearance_scores``; NaN bars a pair, None: no model).

    Attributes
    ----------
    scores : mapping of track id to ndarray (K,) or None
    """

    scores: Mapping[int, np.ndarray | None]


Decision = Birth | End | Confirm | Hide | OutputBox | Resize | AppearanceScores


# --------------------------------------------------------------------------------------------
# Stage contracts
# --------------------------------------------------------------------------------------------


class LifecycleStage(Component):
    """Base of every lifecycle stage (plugin kind ``stage``; see the module docstring for the
    roles and their order). A stage subclasses one role below and overrides its method(s).

    A stage keeps its per-track state keyed by track id, dropped in :meth:`track_ended`; it
    never holds or writes a :class:`~pftrack.components.Target`.
    """

    kind: ClassVar[str] = "stage"
    #: The role, one of :data:`ROLES` (set by the role classes below).
    role: ClassVar[str] = ""

    def track_started(self, track: TrackView, birth: Birth) -> None:
        """Called when a track starts (whichever stage asked for it), after its first
        estimate. Default: nothing."""

    def track_ended(self, track_id: int) -> None:
        """Called when a track ends, whoever ended it: drop its per-track state. Default:
        nothing."""


class Initiator(LifecycleStage):
    """Starts tracks: returns :class:`Birth` decisions."""

    role: ClassVar[str] = "initiator"

    def scheduled(self, view: FrameView) -> Sequence[Birth]:
        """Births due at this frame, applied before the predict step (tracks from given boxes).
        Default: none."""
        return ()

    def initiate(self, view: FrameView) -> Sequence[Birth]:
        """Births from this frame's detections, applied after the estimates (``view.unmatched``
        and ``view.claimed`` say which detections no track explains), in the order returned.
        Default: none."""
        return ()


class Confirmer(LifecycleStage):
    """Holds new tracks tentative until they are believed."""

    role: ClassVar[str] = "confirmer"

    def tentative(self, birth: Birth) -> bool:
        """Whether a track started by ``birth`` begins tentative (its records held back until
        :class:`Confirm`). Default: yes."""
        return True

    def confirm(self, view: FrameView) -> Sequence[Confirm | End]:
        """:class:`Confirm` the tentative tracks now believed, :class:`End` those given up
        (``view.tracks[i].tentative`` says which are tentative)."""
        return ()


class Terminator(LifecycleStage):
    """Ends tracks (other than the filter's own deaths: misses, out of view)."""

    role: ClassVar[str] = "terminator"

    def terminate(self, view: FrameView) -> Sequence[End]:
        """:class:`End` decisions for this frame. Default: none."""
        return ()


class Merger(LifecycleStage):
    """Finds two confirmed tracks that are one object; ends one of them."""

    role: ClassVar[str] = "merger"

    def merge(self, view: FrameView) -> Sequence[End]:
        """:class:`End` decisions for duplicates (their records of this frame are withdrawn).
        Default: none."""
        return ()


class Reidentifier(LifecycleStage):
    """Keeps an appearance model per track and scores detections against it."""

    role: ClassVar[str] = "reidentifier"

    def scores(self, view: FrameView) -> AppearanceScores | None:
        """Before association: each track's similarity to this frame's detections (None:
        leave them unset)."""
        return None

    def observe(self, view: FrameView) -> None:
        """After the estimates: learn from the detections matched to the tracks."""


class Sizer(LifecycleStage):
    """Adapts each track's own image box size."""

    role: ClassVar[str] = "sizer"

    def resize(self, view: FrameView) -> Sequence[Resize]:
        """:class:`Resize` decisions for this frame. Default: none."""
        return ()


class Reporter(LifecycleStage):
    """Decides what each track's record of this frame looks like, and which are output."""

    role: ClassVar[str] = "reporter"

    def report(self, view: FrameView) -> Sequence[OutputBox | Hide]:
        """:class:`OutputBox` and :class:`Hide` decisions for this frame. Default: none."""
        return ()


#: The roles in the order the runner calls them after the estimates (the initiator's
#: ``starts`` and the reidentifier's ``scores`` run before the predict step).
ROLES: tuple[str, ...] = ("reidentifier", "sizer", "reporter", "confirmer", "terminator",
                          "merger", "initiator")


# --------------------------------------------------------------------------------------------
# The runner
# --------------------------------------------------------------------------------------------


class LifecycleTracks(TrackManager):
    """Runs lifecycle stages in the fixed order of :mod:`pftrack.lifecycle` and applies their
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
                         engine.valid_region, log_likelihood)

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
                         unmatched=unmatched, claimed=claimed, models=models)

    # -- applying decisions -----------------------------------------------------------------

    def _apply_births(self, engine: Any, frame: Frame, births: Iterable[Birth],
                      out: list[TrackRecord] | None) -> None:
        """Start the tracks; ``out`` (after the estimates): their first records go there, or
        are held back while tentative."""
        from pftrack.geometry.boxes import iou_matrix

        confirmers = self.by_role_["confirmer"]
        for b in births:
            if b.max_iou is not None and b.box_xywh_px is not None:
                taken = [t.box_xywh_px for t in engine.targets]
                if taken and iou_matrix(np.asarray(b.box_xywh_px, dtype=np.float64),
                                        np.array(taken)).max() > b.max_iou:
                    continue
            t = engine.add_target(frame, b.position, box_xywh_px=b.box_xywh_px,
                                  target_id=b.track_id)
            if b.supported:
                t.frames_tracked = 1
            tentative = any(c.tentative(b) for c in confirmers)
            if out is not None:
                rec = engine.record(frame, t)
                if tentative:
                    self.tentative_[t.id] = [rec]
                else:
                    out.append(rec)
            elif tentative:
                self.tentative_[t.id] = []
            view = TrackView.of(t, tentative)
            for s in self.stages_:
                s.track_started(view, b)

    def _end(self, engine: Any, decisions: Iterable[Any], withdrawn: set[int]) -> None:
        """Apply the :class:`End` decisions; the ended tracks whose record of this frame is
        not output (``End.output`` False, or never confirmed) go to ``withdrawn``."""
        for d in decisions:
            if isinstance(d, End):
                if not d.output or d.track_id in self.tentative_:
                    withdrawn.add(d.track_id)
                engine.remove_target(d.track_id)

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
            for s in roles["initiator"]:
                self._apply_births(engine, frame, s.scheduled(view), None)
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
        """Steps 3-9 (see the module docstring); returns the records to output now."""
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
        for s in roles["reidentifier"]:
            s.observe(v)
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
            for d in s.report(v):
                if isinstance(d, Hide):
                    hidden.add(d.track_id)
                elif isinstance(d, OutputBox) and d.track_id in by_id:
                    by_id[d.track_id].box_xywh_px[:] = d.box_xywh_px  # each record owns its box
        tentative = self.tentative_
        out: list[TrackRecord] = []
        withdrawn: set[int] = set()
        if roles["confirmer"]:
            for tid, held in tentative.items():
                if tid in by_id:
                    held.append(by_id[tid])
            decided = False
            for s in roles["confirmer"]:
                for d in s.confirm(v):
                    decided = True
                    if isinstance(d, Confirm) and d.track_id in tentative:
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
        return out


class StagedTracks(LifecycleTracks):
    """Track management as an explicit list of lifecycle stages (see :mod:`pftrack.lifecycle`
    for the roles and the order they run in), e.g. the configuration ``tracks: {type: stages,
    params: {stages: [{type: detection-births, params: {min_score: 0.5}}, hit-confirmation,
    duplicate-merge]}}`` (a full example: the docs page "How tracks start, are confirmed and end").

    Parameters
    ----------
    stages : list
        The stages, each a registered stage name or ``{type: NAME, params: {...}}``; stages of
        one role run in this order.
    """

    def __init__(self, stages: list[Any] | None = None) -> None:
        self.stages = stages

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
    (:meth:`pftrack.tracker.MultiTargetTracker.add_target`), end only by the filter's own rules,
    and every live target's estimate is output. No parameters."""

    def __init__(self) -> None:
        """No parameters."""
