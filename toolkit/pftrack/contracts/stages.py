"""The contract of a track lifecycle stage: what a stage sees (:class:`FrameView`,
:class:`TrackView`, :class:`ModelView`), the decisions it returns (:class:`Birth`, :class:`End`,
:class:`Confirm`, :class:`Hide`, :class:`OutputBox`, :class:`OutputAs`, :class:`Resize`,
:class:`AppearanceScores`, :class:`Mask`, :class:`Particles`) and the stage base classes, one
per role (:class:`Initiator`, :class:`Confirmer`, :class:`Terminator`, :class:`Merger`,
:class:`Reidentifier`, :class:`Sizer`, :class:`Reporter`, :class:`Masker`).

The runner that calls the stages in their fixed order and applies their decisions to the
engine is :class:`pftrack.engine.lifecycle.LifecycleTracks`; its docstring gives the order.
Plugin authors import these names from :mod:`pftrack.lifecycle`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pftrack.contracts.components import (
    Component,
    DetectionMatch,
    Detections,
    Frame,
    Target,
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
    "Mask",
    "Masker",
    "Merger",
    "ModelView",
    "OutputAs",
    "OutputBox",
    "Particles",
    "Reidentifier",
    "Reporter",
    "ROLES",
    "Resize",
    "Sizer",
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
    particles : ndarray, shape (N, D), read-only, or None
        The track's current particles (after this frame's resampling), in the motion model's
        state space; equally weighted once resampled.
    log_likelihoods : ndarray, shape (N,), read-only, or None
        Each particle's log-likelihood at this frame's weighting (-inf: barred by a region;
        None before the track's first weighting).
    particle_boxes_xywh_px : ndarray, shape (N, 4), read-only, or None
        The image boxes (xywh px) the observation model gave the particles that were weighted
        this frame (points: width and height 0).
    resample_index : ndarray of int, shape (N,), read-only, or None
        Which weighted particle each current particle copies (None: the particles were set
        since, e.g. at birth).
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
    particles: np.ndarray | None = None
    log_likelihoods: np.ndarray | None = None
    particle_boxes_xywh_px: np.ndarray | None = None
    resample_index: np.ndarray | None = None

    @classmethod
    def of(cls, t: Target, tentative: bool) -> TrackView:
        d = t.detection
        if d is not None:  # its box is a row of the frame's detections: read-only too
            d = DetectionMatch(_frozen(d.box_xywh_px), d.score, d.index)  # type: ignore[arg-type]
        return cls(id=t.id, state=_frozen(t.state), box_xywh_px=_frozen(t.box_xywh_px),  # type: ignore[arg-type]
                   age=t.age, misses=t.misses, frames_tracked=t.frames_tracked,
                   detection=d, box_wh_px=t.box_wh_px, tentative=tentative,
                   particles=_frozen(t.particles), log_likelihoods=_frozen(t.log_likelihoods),
                   particle_boxes_xywh_px=_frozen(t.particle_boxes_xywh_px),
                   resample_index=_frozen(t.resample_index))


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
    n_particles : int
        Particles per track (the shape of :attr:`Birth.particles` and :attr:`Particles.particles`
        is ``(n_particles, state_dim)``); 0: not known.
    state_dim : int
        Entries of a state (D); 0: not known.
    """

    position_dims: tuple[int, ...]
    velocity_dims: tuple[int, ...] | None
    dt: float
    _boxes: Callable[[np.ndarray, int | None], np.ndarray]
    _position_from_box: Callable[[np.ndarray], np.ndarray]
    _world: Callable[[np.ndarray], np.ndarray | None]
    _region: Callable[[np.ndarray], np.ndarray] | None
    _log_likelihood: Callable[[np.ndarray, int], np.ndarray]
    n_particles: int = 0
    state_dim: int = 0

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
    rng : numpy.random.Generator or None
        The run's random generator (the engine's own): a stage that draws (particles spread
        through a volume, a subsample) draws from it, so that a run is fixed by its seed. The
        draws are part of the run's one sequence: a stage draws in the order its decisions
        are applied (see :class:`Particles`). None: a view built without a run.
    """

    frame: Frame
    detections: Detections | None
    tracks: tuple[TrackView, ...]
    unmatched: np.ndarray
    claimed: frozenset[int]
    models: ModelView
    rng: np.random.Generator | None = None

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
    particles : ndarray, shape (N, D), optional
        The track's particles (the engine's particle count, the motion model's state space),
        equally weighted: they replace the ones the engine draws about ``position`` (those are
        drawn all the same, so a birth draws from the run's generator as any other), and the
        estimate becomes their mean. None: the engine's own.
    """

    box_xywh_px: np.ndarray | None = None
    position: np.ndarray | None = None
    track_id: int | None = None
    detection_index: int | None = None
    supported: bool = True
    max_iou: float | None = None
    particles: np.ndarray | None = None


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
    """A tentative track is believed: its records from birth on are output.

    Attributes
    ----------
    track_id : int
    at_end : bool
        Output the held records at the end of the frame, after the terminators, mergers and
        initiators, and only if the track is still live then (a track that a later stage of
        this frame ends was never output). False: output now.
    """

    track_id: int
    at_end: bool = False


@dataclass(frozen=True)
class Hide:
    """Leave a confirmed track's record of this frame out of the output (it stays tracked)."""

    track_id: int


@dataclass(frozen=True)
class OutputBox:
    """The box (4,) xywh px that the track's record of this frame carries (the output only:
    the filter's state is its own), and optionally its ground position and size.

    Attributes
    ----------
    track_id : int
    box_xywh_px : ndarray, shape (4,)
    world_m : ndarray, shape (3,), optional
        The record's ground position (``TrackRecord.world_m``), world metres; None: the
        engine's.
    size_m : ndarray, shape (3,), optional
        The record's object size (``TrackRecord.size_m``), metres; None: the engine's.
    """

    track_id: int
    box_xywh_px: np.ndarray
    world_m: np.ndarray | None = None
    size_m: np.ndarray | None = None


@dataclass(frozen=True)
class OutputAs:
    """Output the track's records of this frame under the id ``output_id`` instead of its own
    (held-back records output in this frame included): an identity that carries on a track
    that ended, or two tracks that exchanged their objects. Returned by a reidentifier's
    :meth:`Reidentifier.observe`; it holds for this frame only (a track output under another
    id every frame is told so every frame).

    Attributes
    ----------
    track_id : int
    output_id : int
        The id its records carry (positive).
    """

    track_id: int
    output_id: int


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


@dataclass(frozen=True)
class Mask:
    """Where a live track's particles may live from its next weighting on: a particle whose
    position ``region`` says False for gets likelihood 0 (``Target.valid_region``). Unlike the
    run's own valid region, leaving it does not end the track. A track keeps its mask until a
    later :class:`Mask` replaces it.

    Attributes
    ----------
    track_id : int
    region : callable or None
        ``region(positions (N, P)) -> bool (N,)``, positions in the motion model's state
        space (pixels or world metres); None: anywhere (the mask is lifted). It is kept for the
        frames to come, so it should be picklable and hold neither the engine nor a track.
    boxes : bool
        Whether ``region`` is called with the particles' image boxes as well:
        ``region(positions (N, P), boxes (N, 4) xywh px or None) -> bool (N,)``, the boxes the
        observation model gave the particles being weighted (read-only; None when the track
        has none of this frame), so that a region drawn in the image need not project the
        particles again.
    """

    track_id: int
    region: Callable[..., np.ndarray] | None
    boxes: bool = False


@dataclass(frozen=True)
class Particles:
    """Replace a live track's particles (N, D) with these, equally weighted (a detection group
    spread again through its volume); its estimate becomes their mean. Returned by an initiator
    among its births, and applied in the order returned."""

    track_id: int
    particles: np.ndarray


Decision = (Birth | End | Confirm | Hide | OutputBox | OutputAs | Resize | AppearanceScores | Mask
            | Particles)


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

    def scheduled(self, view: FrameView) -> Iterable[Birth | Particles]:
        """Births due at this frame, applied before the predict step (tracks from given boxes).
        Default: none."""
        return ()

    def initiate(self, view: FrameView) -> Iterable[Birth | Particles]:
        """Births from this frame's detections, applied after the estimates (``view.unmatched``
        and ``view.claimed`` say which detections no track explains), in the order returned.
        Default: none.

        Both methods may return :class:`Particles` decisions among the births, and may be
        generators: each decision is applied before the next is asked for, and every stage is
        told of a birth (:meth:`LifecycleStage.track_started`, with the new track's id) before
        the generator goes on -- so a stage can start a track and then set its particles, and
        its draws from ``view.rng`` fall between the engine's own in the order given.
        """
        return ()


class Confirmer(LifecycleStage):
    """Holds new tracks tentative until they are believed."""

    role: ClassVar[str] = "confirmer"
    #: Whether a tentative track's records that a reporter hides (:class:`Hide`) are held back
    #: and output on confirmation like the others (True), or dropped (False: a confirmation
    #: outputs only the records that were shown in their frame).
    holds_hidden: ClassVar[bool] = True

    def tentative(self, birth: Birth) -> bool:
        """Whether a track started by ``birth`` begins tentative (its records held back until
        :class:`Confirm`). Default: yes."""
        return True

    def confirm(self, view: FrameView) -> Sequence[Confirm | End]:
        """:class:`Confirm` the tentative tracks now believed, :class:`End` those given up
        (``view.tracks[i].tentative`` says which are tentative). Called after the reporters:
        this frame's :class:`Hide` decisions are known."""
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
    """Keeps an appearance model per track, scores detections against it, and may say under
    which id a track's records are output."""

    role: ClassVar[str] = "reidentifier"

    def scores(self, view: FrameView) -> AppearanceScores | None:
        """Before association: each track's similarity to this frame's detections (None:
        leave them unset)."""
        return None

    def observe(self, view: FrameView) -> Sequence[OutputAs] | None:
        """Last in the frame, after the masks: learn from the frame's tracks as they end it
        (those ended in this frame gone, those started in it present; ``detection``: the
        detection matched to each), and return :class:`OutputAs` decisions for the tracks
        whose records of this frame are output under another id. Default: nothing."""
        return None


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

    def report_started(self, track: TrackView, birth: Birth) -> Sequence[OutputBox | Hide]:
        """:class:`OutputBox` and :class:`Hide` decisions for the first record of a track an
        initiator starts after the estimates (called after every stage heard of it,
        :meth:`LifecycleStage.track_started`; a hidden first record is not output, nor held
        back when the confirmers drop hidden records). Default: none."""
        return ()


class Masker(LifecycleStage):
    """Says where each track's particles may live (a track kept in its volume, off its
    neighbours)."""

    role: ClassVar[str] = "masker"

    def mask(self, view: FrameView) -> Sequence[Mask]:
        """:class:`Mask` decisions: called after the births (the masks hold from the next
        frame's weighting on), and before the predict step when given births started tracks.
        Default: none."""
        return ()


#: The roles in the order the runner calls them after the estimates (the initiator's
#: ``scheduled``, the reidentifier's ``scores`` and, after given births, the masker run before
#: the predict step too).
ROLES: tuple[str, ...] = ("sizer", "reporter", "confirmer", "terminator", "merger",
                          "initiator", "masker", "reidentifier")


