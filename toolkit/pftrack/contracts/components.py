"""Component contracts: one abstract base per plugin kind.

Every detector, likelihood, motion model, associator and scene that pftrack runs, built-in or
third-party, subclasses one of the bases here. The conventions follow scikit-learn:

* ``__init__`` only stores its keyword arguments as attributes of the same name (no logic, no I/O);
* parameters round-trip through :meth:`Component.get_params` / :meth:`Component.to_config`;
* learned or per-frame state lives in attributes whose names end with ``_``;
* randomness only through a ``numpy.random.Generator`` that is passed in, never the global one;
* the methods called per frame are vectorised over particles: arrays in, arrays out.

Exchange types (:class:`Frame`, :class:`Detections`, :class:`Target`, :class:`Assignment`) carry
their coordinate frame and unit in their field names (``boxes_xywh_px``, ``points_world_m``).
"""

from __future__ import annotations

import copy
import inspect
import math
import os
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

# the declared parameters live in their own module; their names stay importable from here
from pftrack.contracts.params import (  # noqa: F401
    _NO_DEFAULT,
    _VALIDATING,
    Group,
    Param,
    ParamGroup,
    _declared,
    _generated_init,
    _params_section,
    _plain,
    _problems,
    _unvalidated,
)

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera

__all__ = [
    "Component",
    "Detector",
    "Likelihood",
    "MotionModel",
    "Associator",
    "Scene",
    "Frame",
    "Detections",
    "Target",
    "DetectionMatch",
    "Assignment",
    "Param",
    "Group",
    "ParamGroup",
    "ObservationModel",
    "RunContext",
    "TrackManager",
    "TrackRecord",
]


# --------------------------------------------------------------------------------------------
# Exchange types
# --------------------------------------------------------------------------------------------


@dataclass
class Frame:
    """One video frame.

    Attributes
    ----------
    index : int
        Frame number as the ground truth counts it (MOTChallenge: 1-based).
    image : ndarray, shape (H, W, 3), uint8
        The picture, BGR channel order (OpenCV's).
    time_s : float
        Time stamp in seconds from the start of the sequence.
    """

    index: int
    image: np.ndarray
    time_s: float = 0.0

    @property
    def size_wh(self) -> tuple[int, int]:
        """Image size as (width, height) in pixels."""
        return int(self.image.shape[1]), int(self.image.shape[0])


@dataclass
class Detections:
    """Detections in one frame.

    Attributes
    ----------
    boxes_xywh_px : ndarray, shape (K, 4), float64
        Boxes as (left, top, width, height) in image pixels.
    scores : ndarray, shape (K,), float64
        Detector confidence; for an SVM the signed distance to the decision boundary, c(det).
    points_world_m : ndarray, shape (K, 3), float64, optional
        Ground position of each detection in world metres, when a camera is known.
    """

    boxes_xywh_px: np.ndarray
    scores: np.ndarray
    points_world_m: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.boxes_xywh_px = np.asarray(self.boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
        self.scores = np.asarray(self.scores, dtype=np.float64).reshape(-1)
        if len(self.scores) != len(self.boxes_xywh_px):
            raise ValueError(
                f"Detections: {len(self.boxes_xywh_px)} boxes but {len(self.scores)} scores"
            )
        if self.points_world_m is not None:
            self.points_world_m = np.asarray(self.points_world_m, dtype=np.float64).reshape(-1, 3)

    def __len__(self) -> int:
        return len(self.scores)

    @classmethod
    def empty(cls) -> Detections:
        return cls(np.zeros((0, 4)), np.zeros(0))


@dataclass(frozen=True)
class DetectionMatch:
    """The detection an associator matched to a target in this frame.

    Attributes
    ----------
    box_xywh_px : ndarray, shape (4,), float64
        The detection's box (left, top, width, height), pixels.
    score : float
        The detector's confidence c(det).
    index : int
        Its row in this frame's :class:`Detections`.
    """

    box_xywh_px: np.ndarray
    score: float
    index: int


@dataclass
class Target:
    """What the tracker knows of one target; handed to likelihoods, motion models and associators.

    Attributes
    ----------
    id : int
        Track id (positive).
    state : ndarray, shape (D,)
        Current estimate in the motion model's state space (weighted mean of the particles).
    box_xywh_px : ndarray, shape (4,)
        Current estimate as an image box (left, top, width, height), pixels.
    particles : ndarray, shape (N, D)
        The current particle states (after the last predict, before resampling).
    particle_boxes_xywh_px : ndarray, shape (N, 4)
        The particles as image boxes, same order.
    extent : ndarray, shape (D,)
        2 * sqrt(weighted variance) per state axis (the coastal paper's eq. 10).
    frames_tracked : int
        Consecutive frames with support (detection or likelihood above threshold); the soccer paper
        scales its velocity and acceleration noise by its inverse.
    size_m : float
        Typical physical size of the target (metres) or image size (pixels) for image-plane state;
        the soccer paper scales its position noise by it.
    age : int
        Frames since birth.
    misses : int
        Consecutive frames without support.
    detection : DetectionMatch or None
        The detection matched to the target in this frame (set by the tracker after
        association, None when unmatched); likelihoods and track management read it.
    box_wh_px : (float, float) or None
        The target's own image box size (width, height) in pixels, for observation models that
        keep one per target (an image-plane box started from a detection or a given box).
    appearance_scores : ndarray, shape (K,), or None
        Appearance similarity in [0, 1] of this frame's K detections to the target's
        appearance model (set before association by the track management that keeps such a
        model; associators with an appearance term read it). NaN: the track management bars
        that pair (the associator must not match them).
    observation_px : ndarray, shape (2,), or None
        A point measurement of the target in pixels that the caller supplies (synthetic data,
        tests); likelihoods that use points prefer it to the matched detection.
    log_likelihoods : ndarray, shape (N,), or None
        This frame's log-likelihood of each particle, in the order of the particles the frame
        weighted (before resampling), region masks applied; set by the engine after weighting.
        Track managers count particles above a likelihood with it (the coastal paper's entry and
        exit).
    valid_region : callable or None
        The target's own region, ``f(positions (N, P)) -> bool (N,)``: particles outside get
        likelihood zero, as with the engine's ``valid_region`` (the coastal paper: each particle
        group in its volume, a detection group kept off the intruders already tracked); unlike the
        engine's, leaving it does not end the target (its track manager decides).
    resample_index : ndarray, shape (N,), or None
        Which of the weighted particles (the rows of ``particle_boxes_xywh_px`` and
        ``log_likelihoods``) each particle is a copy of after this frame's resampling; None
        when the frame did not resample. ``particle_boxes_xywh_px[resample_index]`` are the
        boxes of the current particles without projecting them again.
    """

    id: int
    state: np.ndarray
    box_xywh_px: np.ndarray
    particles: np.ndarray | None = None
    particle_boxes_xywh_px: np.ndarray | None = None
    extent: np.ndarray | None = None
    frames_tracked: int = 0
    size_m: float = 1.0
    age: int = 0
    misses: int = 0
    detection: DetectionMatch | None = None
    box_wh_px: tuple[float, float] | None = None
    appearance_scores: np.ndarray | None = None
    observation_px: np.ndarray | None = None
    log_likelihoods: np.ndarray | None = None
    valid_region: Callable[[np.ndarray], np.ndarray] | None = None
    resample_index: np.ndarray | None = None


@dataclass
class Assignment:
    """Result of detection-to-track association.

    Attributes
    ----------
    matches : ndarray, shape (M, 2), int
        Rows of (track index, detection index), indices into the sequences given to the associator.
    unmatched_tracks : ndarray, shape (T - M,), int
    unmatched_detections : ndarray, shape (K - M,), int
    """

    matches: np.ndarray
    unmatched_tracks: np.ndarray
    unmatched_detections: np.ndarray

    @classmethod
    def from_matches(cls, matches: Sequence[tuple[int, int]] | np.ndarray, n_tracks: int,
                     n_detections: int) -> Assignment:
        m = np.asarray(matches, dtype=np.intp).reshape(-1, 2)
        ut = np.delete(np.arange(n_tracks, dtype=np.intp), m[:, 0])  # sorted, as setdiff1d
        ud = np.delete(np.arange(n_detections, dtype=np.intp), m[:, 1])
        return cls(m, ut, ud)


@dataclass
class RunContext:
    """What a run knows beyond a component's own parameters, handed to
    :meth:`Component.setup` once when the run is built (before any frame).

    A component takes its dependencies from here, never by having a parameter of a particular
    name filled in: the camera a ground-plane detector scans with, the detector model file a
    trained detector loads, the host a composite builds its parts with.

    Attributes
    ----------
    host : pftrack.host.Host, optional
        Builds sub-components by registered name (default: the process-wide host).
    camera : pftrack.geometry.camera.Camera, optional
        The run's calibrated camera (world metres, z up), when it has one.
    fps : float
        Frames per second of the source.
    detector_model : str, optional
        A model file written by :meth:`Detector.save` (``pftrack detector train``) for the
        run's detector to :meth:`Detector.load`.
    """

    host: Any = None
    camera: Camera | None = None
    fps: float = 25.0
    detector_model: str | None = None

    def get_host(self) -> Any:
        """``host``, or the process-wide :func:`pftrack.host.get_host` when none was given."""
        if self.host is None:
            from pftrack.host import get_host

            self.host = get_host()
        return self.host

    def frames(self, seconds: float) -> int:
        """A duration in seconds as whole frames at ``fps`` (rounded half to even)."""
        if not (math.isfinite(seconds) and seconds >= 0):
            raise ValueError(f"a duration must be a finite number of seconds >= 0: {seconds!r}")
        return int(round(float(seconds) * float(self.fps)))


# --------------------------------------------------------------------------------------------
# Component base
# --------------------------------------------------------------------------------------------


class Component(ABC):
    """Base of every plugin component.

    Subclasses declare their parameters as class attributes with :class:`Param`: the
    ``__init__`` that stores them, the check of every value against its declaration (at
    construction and in :meth:`set_params`), the docstring's ``Parameters`` section and the
    configuration reference are generated from the declarations; a relation between parameters
    is checked by overriding :meth:`_check_relations`. A class may instead take its parameters
    as keyword arguments of a hand-written ``__init__``, storing each one unchanged as an
    attribute of the same name (its values are then checked only by their annotated type, in a
    configuration). ``kind
    names the plugin kind; ``name`` is filled in by the registry with the name the component was
    registered under.
    """

    kind: ClassVar[str] = "component"
    name: ClassVar[str | None] = None

    if TYPE_CHECKING:
        # the __init__ generated from Param declarations takes them by keyword or position
        def __init__(self, *args: Any, **kwargs: Any) -> None: ...

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        params = _declared(cls)
        if not params or "__init__" in vars(cls):
            return
        cls.__init__ = _generated_init(cls, params)  # type: ignore[method-assign]
        doc = cls.__dict__.get("__doc__") or ""
        if "{params}" in doc:
            cls.__doc__ = doc.replace("{params}", _params_section(params).replace(
                "\n", "\n    "))

    @classmethod
    def _param_names(cls) -> list[str]:
        if cls.__init__ is object.__init__:
            return []  # no parameters declared and no __init__ written
        sig = inspect.signature(cls.__init__)
        names = []
        for p in sig.parameters.values():
            if p.name == "self":
                continue
            if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
                raise TypeError(
                    f"{cls.__name__}.__init__ must declare explicit keyword parameters, "
                    f"not *{p.name}"
                )
            names.append(p.name)
        return names

    def get_params(self) -> dict[str, Any]:
        """Parameters as given to ``__init__`` (scikit-learn convention)."""
        out = {}
        for n in self._param_names():
            if not hasattr(self, n):
                raise AttributeError(
                    f"{type(self).__name__}: parameter {n!r} is not stored as an attribute "
                    "of the same name in __init__"
                )
            out[n] = getattr(self, n)
        return out

    def setup(self, context: RunContext) -> None:
        """Called once when a run is built, before any frame, with what the run knows (its
        camera, fps, detector model, the host). Take dependencies from ``context`` into ``*_``
        attributes here. Default: nothing."""

    def set_params(self, **params: Any) -> Component:
        """Set parameters (scikit-learn convention), checked as at construction. A
        :class:`Group` parameter takes a mapping (its keys left out take their defaults), or
        one of its parameters is set by its dotted name: ``set_params(**{"train.C": 0.1})``."""
        valid = set(self._param_names())
        declared = _declared(type(self))
        changed = []
        for k, v in params.items():
            group, dot, sub = k.partition(".")
            if dot and isinstance(declared.get(group), Group):
                current = getattr(self, group)
                v = {**(current.get_params() if isinstance(current, ParamGroup) else {}),
                     sub: v}
                k = group
            if k not in valid:
                raise ValueError(
                    f"{type(self).__name__}: unknown parameter {k!r}; valid: {sorted(valid)}"
                )
            p = declared.get(k)
            setattr(self, k, p.coerce(v, self._label()) if isinstance(p, Group) else v)
            changed.append(k)
        if _VALIDATING.get():
            self._validate_params(changed)
        return self

    @classmethod
    def declared_params(cls) -> dict[str, Param]:
        """``{name: Param}`` of every parameter, in signature order: the :class:`Param`
        declarations, and for a keyword of a hand-written ``__init__`` the declaration its
        default and annotation imply (:meth:`Param.from_signature`: type only, no range)."""
        declared = _declared(cls)
        out = {}
        for p in inspect.signature(cls.__init__).parameters.values():
            if p.name == "self" or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
                continue
            out[p.name] = declared.get(p.name) or Param.from_signature(p)
        return out

    @classmethod
    def _label(cls) -> str:
        return f"{cls.__name__} ({cls.kind} {cls.name!r})" if cls.name else cls.__name__

    def _validate_params(self, names: Sequence[str] | None = None) -> None:
        """Check the parameters ``names`` (default: all) against their declarations (a
        group's parameters one by one, named ``group.key``), then :meth:`_check_relations`;
        raise a ``ValueError`` naming the component, every parameter at fault, what it allows
        and the value given."""
        problems = _problems(_declared(type(self)), self, names)
        if problems:
            raise ValueError(f"{self._label()}: " + "; ".join(problems))
        self._check_relations()

    def _check_relations(self) -> None:
        """Check what single declarations cannot say (a relation between two parameters);
        raise a ``ValueError`` naming the parameters. Called after the per-parameter checks,
        at construction and by :meth:`set_params`. Default: nothing."""

    def to_config(self) -> dict[str, Any]:
        """``{"type": registered name, "params": {...}}``; the inverse is ``Host.build``."""
        return {"type": self.name or type(self).__name__, "params": _plain(self.get_params())}

    def clone(self) -> Component:
        """A fresh, unfitted copy with the same parameters."""
        return type(self)(**copy.deepcopy(self.get_params()))

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"


class MotionModel(Component):
    """State transition of a particle filter, vectorised over particles.

    ``state_dim`` is the length D of a state vector; ``position_dims`` lists which of its entries
    are the position (whose weighted mean is the estimate).
    """

    kind: ClassVar[str] = "motion"

    @property
    @abstractmethod
    def state_dim(self) -> int:
        """D, the length of a state vector."""

    @property
    def position_dims(self) -> tuple[int, ...]:
        return (0, 1)

    @abstractmethod
    def predict(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                target: Target | None = None) -> np.ndarray:
        """Propagate particles one step.

        Parameters
        ----------
        states : ndarray, shape (N, D), float64
        dt : float
            Time step in the model's time unit (frames for image-plane models, seconds for
            world models).
        rng : numpy.random.Generator
        target : Target, optional
            The target these particles belong to; adaptive models read ``size_m`` and
            ``frames_tracked`` from it.

        Returns
        -------
        ndarray, shape (N, D), float64
            New states (a new array; the input is not modified).
        """

    def predict_rows(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                     targets: Sequence[Target]) -> np.ndarray:
        """Every target's particles in one call: ``states`` (T, N, D) -> (T, N, D), row ``i``
        the particles of ``targets[i]``.

        Must equal T successive :meth:`predict` calls, row by row, bit for bit (the same draws
        in the same order): the engine uses it to predict all targets at once. The default
        does exactly that; a model whose noise does not depend on the target overrides it with
        one vectorised call.
        """
        return np.array([self.predict(s, dt, rng, target=t) for s, t in zip(states, targets)])

    @abstractmethod
    def init_states(self, position: np.ndarray, n: int, rng: np.random.Generator,
                    spread: float | np.ndarray = 1.0) -> np.ndarray:
        """``n`` particles around ``position`` (shape (len(position_dims),)): Gaussian with
        standard deviation ``spread`` on position, zero derivatives. Returns (n, D) float64."""


class Likelihood(Component):
    """Observation likelihood: maps N particle boxes of one target to N log-weights.

    Life cycle, driven by the tracker:

    1. :meth:`init_target` once when a target is born (build its template, the colour paper's eq.
       5);
    2. :meth:`begin_frame` once per frame with every live target (per-frame, per-target passes:
       background histogram, integral images, detections);
    3. :meth:`log_likelihood` once per target per frame, vectorised over that target's particles;
       or, for a likelihood that overrides :meth:`log_likelihood_rows`, that method once per
       frame with every target's particles (when the engine runs its rows backend:
       :meth:`pftrack.engine.tracker.MultiTargetTracker.uses_rows`).

    Log-weights may be ``-inf`` (impossible) but never NaN.
    """

    kind: ClassVar[str] = "likelihood"

    def prepare(self) -> None:
        """Called once when a tracker is built with this likelihood, before any frame: load or
        compile whatever is expensive to set up, so that the first frame of a timed run does
        not pay for it. Must be idempotent. Default: nothing."""

    def init_target(self, frame: Frame, target: Target) -> None:
        """Called when ``target`` is born in ``frame``; default: nothing."""

    def end_target(self, target: Target) -> None:
        """Called when ``target`` dies; release its per-target state. Default: nothing."""

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        """Per-frame preparation with all live targets; default: nothing."""

    @abstractmethod
    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        """Log-likelihood of each particle of ``target``.

        Parameters
        ----------
        boxes_xywh_px : ndarray, shape (N, 4), float64
            Each particle as an image box (left, top, width, height) in pixels. Boxes may reach
            outside the image; a likelihood handles that (clips) rather than failing.
        target : Target

        Returns
        -------
        ndarray, shape (N,), float64
            Log-likelihoods (up to an additive constant per target and frame).
        """

    def log_likelihood_rows(self, boxes_xywh_px: np.ndarray,
                            targets: Sequence[Target]) -> np.ndarray:
        """Log-likelihoods of every target's particles in one call (optional, for speed).

        A likelihood MAY override this to score all targets at once (one compiled pass instead
        of one call per target); row ``i`` must equal ``log_likelihood(boxes_xywh_px[i],
        targets[i])``. The engine calls it, instead of :meth:`log_likelihood` per target, on
        its rows backend, which it picks when :meth:`offers_rows` says so and the motion and
        observation models offer their rows too. Default: the per-target calls, stacked.

        Parameters
        ----------
        boxes_xywh_px : ndarray, shape (T, N, 4), float64
            Each target's particles as image boxes (left, top, width, height), pixels.
        targets : sequence of Target
            The T targets, in the rows' order.

        Returns
        -------
        ndarray, shape (T, N), float64
        """
        if len(targets) == 0:
            return np.zeros((0, np.shape(boxes_xywh_px)[1] if np.ndim(boxes_xywh_px) > 1 else 0))
        return np.array([self.log_likelihood(b, t) for b, t in zip(boxes_xywh_px, targets)],
                        dtype=np.float64)

    def offers_rows(self) -> bool:
        """Whether this likelihood scores all targets in one call: by default, whether its
        class overrides :meth:`log_likelihood_rows` (a wrapper forwards its inner
        likelihood's answer). The engine asks once per frame."""
        return type(self).log_likelihood_rows is not Likelihood.log_likelihood_rows


class Detector(Component):
    """Finds objects in a frame."""

    kind: ClassVar[str] = "detector"
    #: The file name ending of the models :meth:`save` writes (checked before training);
    #: None: any name.
    model_suffix: ClassVar[str | None] = ".npz"

    def fit(self, frames: Sequence[Frame] | Iterator[Frame], boxes_by_frame: dict[int, np.ndarray],
            rng: np.random.Generator | None = None,
            ignore_by_frame: dict[int, np.ndarray] | None = None) -> Detector:
        """Learn from frames with ground-truth boxes (``{frame index: (K, 4) xywh px}``);
        ``ignore_by_frame`` holds boxes that are neither positives nor negatives (partly hidden
        people). Default: nothing to learn."""
        return self

    @property
    def learns(self) -> bool:
        """Whether :meth:`fit` learns something that :meth:`save` can write."""
        return type(self).save is not Detector.save

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write what :meth:`fit` learned to ``path`` in a safe format (no pickle), atomically;
        the inverse is :meth:`load`. Returns the path written. A detector that learns nothing
        raises ``NotImplementedError``."""
        raise NotImplementedError(f"detector {self.name or type(self).__name__!r} learns "
                                  "nothing to save")

    def load(self, path: str | os.PathLike[str]) -> Detector:
        """Use the model :meth:`save` wrote to ``path`` (returns ``self``). Raises
        ``ValueError`` naming the file when it is not such a model."""
        raise NotImplementedError(f"detector {self.name or type(self).__name__!r} has no model "
                                  "to load")

    def describe(self) -> dict[str, Any]:
        """What the learned model holds (parameters, training record), JSON-serialisable, for
        ``pftrack detector info``. Default: the parameters."""
        return _plain(self.get_params())

    @abstractmethod
    def detect(self, frame: Frame) -> Detections:
        """Detections in ``frame``: boxes in pixels with scores."""


class Associator(Component):
    """Detection-to-track association."""

    kind: ClassVar[str] = "associator"

    @abstractmethod
    def associate(self, targets: Sequence[Target], detections: Detections) -> Assignment:
        """Match live targets to detections; each used at most once."""


class Scene(Component):
    """A source of frames, optionally with ground truth and a camera (a video, a synthetic scene).

    ``frames`` streams: it must not hold the whole video in memory.
    """

    kind: ClassVar[str] = "scene"

    @abstractmethod
    def frames(self) -> Iterator[Frame]:
        """Yield the frames in order."""

    def ground_truth(self) -> np.ndarray | None:
        """MOTChallenge rows ``(frame, id, left, top, width, height, conf, x, y, z)`` as an
        (M, 10) float64 array, or None if the scene has none."""
        return None

    @property
    def fps(self) -> float:
        return 25.0


# --------------------------------------------------------------------------------------------
# The engine's replaceable parts: observation model, track management
# --------------------------------------------------------------------------------------------


@dataclass
class TrackRecord:
    """One target's estimate in one frame: what the engine outputs.

    ``box_xywh_px`` is the image box of the estimate; ``position`` its position in state space
    (pixels for image-plane models, world metres for ground-plane ones); ``world_m`` the ground
    position (x, y, z) in metres when the observation model knows one, else None;
    ``confidence`` the logistic of the best particle's log-likelihood (0.5 at a birth);
    ``size_m`` the object's size in metres (width across the view, height, depth along the
    view) when the track manager estimates one (the coastal paper), else None. ``extent`` is 2
    standard deviations of the weighted particles per state axis (the motion model's axis order).

    ``xyxy_sd`` (x1, y1, x2, y2 standard deviations, pixels) and ``world_cov`` (2 x 2 ground
    covariance, m^2) are the particle cloud's spread when a caller asked for it
    (:class:`pftrack.workflows.spread.RecordSpread`, which ``pftrack run`` and
    :class:`pftrack.Tracker` use), else None.
    """

    frame: int
    id: int
    box_xywh_px: np.ndarray
    state: np.ndarray
    position: np.ndarray
    extent: np.ndarray
    confidence: float
    world_m: np.ndarray | None = None
    size_m: np.ndarray | None = None
    xyxy_sd: np.ndarray | None = None
    world_cov: np.ndarray | None = None


class ObservationModel(Component):
    """Maps particle states to image boxes, and a detection box back to a position.

    The engine is state-space agnostic: an image-plane model reads the box centre from the
    state, a ground-plane model projects a foot and a head point through the run's camera
    (taken from :class:`RunContext` in :meth:`setup`), a volume model points in a 3-D cuboid.
    """

    kind: ClassVar[str] = "observation"

    @abstractmethod
    def to_boxes(self, states: np.ndarray, target: Target | None = None) -> np.ndarray:
        """States (N, D) -> boxes (N, 4) as (left, top, width, height) in pixels.

        ``target`` lets a model use per-target parameters (``target.box_wh_px``, or its own
        per-target state keyed by ``target.id``).
        """

    def to_boxes_rows(self, states: np.ndarray, targets: Sequence[Target]) -> np.ndarray:
        """Every target's particles as boxes in one call: ``states`` (T, N, D) -> (T, N, 4),
        equal to :meth:`to_boxes` row by row (the default does exactly that)."""
        return np.array([self.to_boxes(s, t) for s, t in zip(states, targets)])

    def init_target(self, target: Target, box_xywh_px: np.ndarray | None) -> None:
        """Called when a target is born, with the box it was started from (if any)."""

    def end_target(self, target: Target) -> None:
        """Called when a target dies: drop any per-target state kept for it."""

    def update_target(self, target: Target, box_xywh_px: np.ndarray) -> None:
        """Called after each frame in which ``target`` matched a detection (its box), for
        models that adapt per-target parameters (a height factor). Default: nothing."""

    @abstractmethod
    def position_from_box(self, box_xywh_px: np.ndarray) -> np.ndarray:
        """A box (4,) -> the position (P,) in state space that would produce it (for births)."""

    def box_height_in_state(self, box_xywh_px: np.ndarray) -> float | None:
        """The height of a box (4,) in state-space position units, at that box: how far one
        box height reaches in the state (pixels for an image-plane model). None (the default)
        when the model cannot say; the engine's ``birth_velocity_spread`` needs it."""
        return None

    def world_position(self, state: np.ndarray) -> np.ndarray | None:
        """Ground position (x, y, z) in world metres of a state (D,), or None when the model
        has no world frame (image-plane tracking)."""
        return None

    def in_view(self, states: np.ndarray, image_size_wh: tuple[int, int],
                target: Target | None = None) -> np.ndarray:
        """Boolean (N,): the state's box overlaps the image. Override for volumes/fields."""
        b = self.to_boxes(states, target)
        w, h = image_size_wh
        return (b[:, 0] < w) & (b[:, 1] < h) & (b[:, 0] + b[:, 2] > 0) & (b[:, 1] + b[:, 3] > 0)


class TrackManager(Component):
    """Track management: which targets exist and which estimates are output.

    This is the engine's interface to track management. Write new track management as
    lifecycle stages (:mod:`pftrack.engine.lifecycle`: each stage returns decisions, and
    :class:`pftrack.engine.lifecycle.LifecycleTracks` applies them through this interface); a
    subclass that overrides ``before_frame`` / ``after_frame`` and drives the engine itself is the
    legacy form, still supported (the coastal paper's ``volumes``).

    The engine (:class:`pftrack.engine.tracker.MultiTargetTracker`) runs one frame as: detect ->
    ``before_frame`` -> predict -> associate -> weight -> normalise, estimate, resample -> the
    filter's own deaths (misses, out of view, out of the valid region) -> ``after_frame``.
    A track manager decides births (from unmatched detections, or from given boxes), the
    tentative -> confirmed life of a new target, merging duplicates, any other end of a target,
    and which of the frame's records to output (a confirmed target's earlier frames may be
    output when it is confirmed). It changes the engine only through its public methods
    (``add_target``, ``remove_target``, ``record``, ``targets``).
    """

    kind: ClassVar[str] = "tracks"

    def before_frame(self, engine: Any, frame: Frame, detections: Detections | None) -> None:
        """Called before the frame's predict step, with the frame's detections (None when the
        run has none): start targets due in this frame, prepare what the associator reads
        (``Target.appearance_scores``). Default: nothing."""

    def after_frame(self, engine: Any, frame: Frame, detections: Detections | None,
                    records: list[TrackRecord], unmatched_detections: np.ndarray,
                    ) -> list[TrackRecord]:
        """Called once the live targets are estimated; returns the records to output now.

        Parameters
        ----------
        engine : MultiTargetTracker
        frame : Frame
        detections : Detections or None
            The frame's detections (None when the run has none).
        records : list of TrackRecord
            This frame's estimate of every live target, in id order.
        unmatched_detections : ndarray of int
            Rows of ``detections`` that no target matched (candidates for births).

        Default: output every record (no births).
        """
        return records

    def end_target(self, target: Target) -> None:
        """Called when ``target`` dies, whoever ended it; drop its per-target state."""

