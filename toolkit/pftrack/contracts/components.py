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

import contextlib
import contextvars
import copy
import functools
import inspect
import math
import numbers
import os
import textwrap
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

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
        ut = np.setdiff1d(np.arange(n_tracks), m[:, 0]).astype(np.intp)
        ud = np.setdiff1d(np.arange(n_detections), m[:, 1]).astype(np.intp)
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


# --------------------------------------------------------------------------------------------
# Component base
# --------------------------------------------------------------------------------------------


_NO_DEFAULT = inspect.Parameter.empty

#: What a value of a simple annotated type looks like, in words.
_TYPE_WORDS = {"int": "an integer", "float": "a number", "bool": "true or false",
               "str": "a string"}


def _split_top(text: str, sep: str) -> list[str]:
    """``text`` split at ``sep`` outside brackets, each part stripped."""
    parts, depth, cur = [], 0, ""
    for ch in text:
        if ch in "[(":
            depth += 1
        elif ch in "])":
            depth -= 1
        if ch == sep and depth == 0:
            parts.append(cur.strip())
            cur = ""
        else:
            cur += ch
    parts.append(cur.strip())
    return [p for p in parts if p]


def _is_type(value: Any, t: str) -> bool:
    if t == "bool":
        return isinstance(value, (bool, np.bool_))
    if isinstance(value, (bool, np.bool_)):
        return False
    if t == "int":
        return isinstance(value, numbers.Integral)
    if t == "float":
        return isinstance(value, numbers.Real)
    return isinstance(value, str)


class _Shape:
    """What an annotation such as ``float | tuple[float, float] | None`` allows: the simple
    scalar types, the element type of sequences (``""``: any), and whether None is allowed;
    ``checked`` is False when an alternative is not understood (the type is then not checked)."""

    def __init__(self, annotation: str) -> None:
        self.scalars: list[str] = []
        self.seq: str | None = None
        self.none = False
        self.checked = bool(annotation.strip())
        for alt in _split_top(annotation, "|"):
            base, _, inner = alt.partition("[")
            base = base.strip().rsplit(".", 1)[-1]
            if alt in ("None", "NoneType"):
                self.none = True
            elif alt in _TYPE_WORDS:
                self.scalars.append(alt)
            elif base in ("tuple", "list", "Sequence") and inner:
                items = [i for i in _split_top(inner.rstrip().removesuffix("]"), ",")
                         if i != "..."]
                elem = items[0] if items and all(i == items[0] for i in items) else ""
                self.seq = elem if elem in _TYPE_WORDS else ""
            else:
                self.checked = False


if TYPE_CHECKING:
    # to a type checker a declaration is the value it declares: ``x: float = Param(1.0)``
    _Declaration = Any
else:
    _Declaration = object


@functools.cache
def _shape_of(annotation: str) -> _Shape:
    return _Shape(annotation)


class Param(_Declaration):
    """A declared parameter of a component (as Stone Soup's ``Property``)::

        class MyLikelihood(Likelihood):
            sigma: float = Param(1.0, "Noise standard deviation.", unit="px", low=0.0,
                                 low_open=True)

    A component class that declares parameters this way and defines no ``__init__`` of its own
    gets one that takes them as arguments (those of its bases first, in declaration order; by
    keyword, or by position in that order), stores each unchanged as an attribute of the same
    name and then checks every value against its declaration (type, range, choices, length),
    raising a ``ValueError`` that names the component, the parameter, the allowed values and
    the value given; its docstring gets a
    numpydoc ``Parameters`` section built from the declarations (types from the annotations).
    A subclass inherits its bases' declarations and may redeclare one (a new default or doc),
    or fix one as a plain class attribute (it is then no parameter of the subclass).
    The configuration check (:func:`pftrack.host.config.validate_config`) and the configuration
    reference read the same declarations.

    The type is the annotation: ``int``, ``float``, ``bool``, ``str``, ``tuple[float, float]``,
    ``list[int]`` and unions of them with ``None`` are checked (an ``int`` is not a float or a
    bool; a ``float`` takes any real number); other annotations are not.

    Parameters
    ----------
    default : object, optional
        The value a component gets when the keyword is left out (none: the keyword is required).
    doc : str
        What the parameter does, one or more sentences.
    unit : str, optional
        The unit of a numeric parameter, in the words of the configuration reference: ``"px"``,
        ``"m"``, ``"m/s"``, ``"s"``, ``"frames"``, ``"deg"``, ``"grey levels"``, ``"1"``
        (dimensionless: a ratio, fraction, probability or weight), ``"count"`` (a number of
        things), ``"none"`` (a number that is not a quantity: a seed, an index). None: the
        parameter is not a number (a name, a flag, a list of names). The generated
        ``Parameters`` section ends the description with ``Unit: <unit>.``, the convention a
        component documenting its ``__init__`` by hand follows too.
    low, high : float, optional
        Bounds of a number, or of every number of a sequence (None: unbounded on that side).
    low_open, high_open : bool
        Whether the bound itself is excluded (``low=0, low_open=True``: > 0).
    choices : sequence, optional
        The allowed values (names, usually).
    length : int or tuple of int, optional
        The allowed length(s) of a sequence value.
    optional : bool, optional
        Whether None is allowed; by default when the default is None or the annotation says
        ``| None``.
    finite : bool, optional
        Whether numbers must be finite; by default unless the default is infinite. NaN is never
        allowed.
    """

    def __init__(self, default: Any = _NO_DEFAULT, doc: str = "", unit: str | None = None, *,
                 low: float | None = None, high: float | None = None, low_open: bool = False,
                 high_open: bool = False, choices: Sequence[Any] | None = None,
                 length: int | tuple[int, ...] | None = None, optional: bool | None = None,
                 finite: bool | None = None) -> None:
        self.default = default
        self.doc = doc
        self.unit = unit
        self.low = low
        self.high = high
        self.low_open = low_open
        self.high_open = high_open
        self.choices = tuple(choices) if choices is not None else None
        self.length = (length,) if isinstance(length, int) else length
        self._optional = optional
        if finite is None:
            finite = not (isinstance(default, float) and math.isinf(default))
        self.finite = finite
        self.name = ""
        self.type_doc = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name
        ann = owner.__dict__.get("__annotations__", {}).get(name)
        self.type_doc = ann if isinstance(ann, str) else getattr(ann, "__name__", "") or (
            "" if ann is None else str(ann))

    @classmethod
    def from_signature(cls, p: inspect.Parameter) -> Param:
        """The declaration a hand-written ``__init__`` keyword implies: its default and its
        annotation's type, no range (what :func:`pftrack.host.config.validate_config` checks of a
        component that does not declare its parameters with Param)."""
        out = cls(p.default)
        ann = p.annotation
        out.name = p.name
        out.type_doc = "" if ann is inspect.Parameter.empty else (
            ann if isinstance(ann, str) else getattr(ann, "__name__", str(ann)))
        return out

    @property
    def optional(self) -> bool:
        """Whether None is an allowed value."""
        if self._optional is not None:
            return self._optional
        return self.default is None or _shape_of(self.type_doc).none

    def __repr__(self) -> str:
        return f"Param({self.default!r})"

    # -- checking ------------------------------------------------------------------------------

    def range_words(self) -> str:
        """The range in words (``"in (0, 1]"``, ``">= 1"``; ``""`` when unbounded)."""
        lo, hi = self.low, self.high
        if lo is not None and hi is not None:
            return (f"in {'(' if self.low_open else '['}{lo:g}, {hi:g}"
                    f"{')' if self.high_open else ']'}")
        if lo is not None:
            return f"{'>' if self.low_open else '>='} {lo:g}"
        if hi is not None:
            return f"{'<' if self.high_open else '<='} {hi:g}"
        return ""

    def allowed(self) -> str:
        """The choices, range and length in words, for the configuration reference (``""``
        when the declaration allows anything of its type)."""
        parts = []
        if self.choices is not None:
            parts.append("one of " + ", ".join(repr(c) for c in self.choices))
        if self.range_words():
            parts.append(self.range_words())
        if self.length is not None:
            parts.append("length " + " or ".join(str(n) for n in self.length))
        if self.optional and self.default is not None:
            parts.append("or None")
        return "; ".join(parts)

    def expected(self) -> str:
        """What a valid value looks like, in words (used in error messages)."""
        if self.choices is not None:
            text = "one of " + ", ".join(repr(c) for c in self.choices)
        else:
            shape = _shape_of(self.type_doc)
            alts = [_TYPE_WORDS[t] for t in shape.scalars] if shape.checked else []
            if shape.checked and shape.seq is not None:
                n = " or ".join(str(k) for k in self.length) if self.length else "a list of"
                elem = {"int": "integers", "float": "numbers", "bool": "flags",
                        "str": "strings"}.get(shape.seq, "values")
                alts.append(f"{n} {elem}")
            text = " or ".join(alts) if alts else (self.type_doc or "a value")
            if self.range_words():
                text += f" {self.range_words()}"
            if not shape.checked and self.length is not None:
                text += " of length " + " or ".join(str(n) for n in self.length)
        if self.optional:
            text += " or None"
        if self.unit and self.unit not in ("none", "1", "count"):
            text += f" ({self.unit})"
        return text

    def problem(self, value: Any) -> str | None:
        """None when ``value`` is allowed; else what is allowed, in words (:meth:`expected`)."""
        bad = self.expected()
        if isinstance(value, np.ndarray) and value.ndim == 0:
            value = value.item()
        if value is None:
            return None if self.optional else bad
        if self.choices is not None:
            try:
                return None if any(value == c for c in self.choices) else bad
            except (TypeError, ValueError):
                return bad
        shape = _shape_of(self.type_doc)
        numbers_: list[Any] = []
        if isinstance(value, (list, tuple, np.ndarray)) and not isinstance(value, str):
            if shape.checked and shape.seq is None:
                return bad
            if self.length is not None and len(value) not in self.length:
                return bad
            elem = shape.seq if shape.checked else ""
            items = list(np.ravel(value)) if isinstance(value, np.ndarray) else list(value)
            if elem and not all(_is_type(v, elem) for v in items):
                return bad
            numbers_ = [v for v in items if _is_type(v, "float")]
        else:
            if shape.checked and not any(_is_type(value, t) for t in shape.scalars):
                return bad
            if _is_type(value, "float"):
                numbers_ = [value]
        for v in numbers_:
            x = float(v)
            if math.isnan(x) or (self.finite and math.isinf(x)):
                return bad
            if self.low is not None and (x < self.low or (self.low_open and x == self.low)):
                return bad
            if self.high is not None and (x > self.high or (self.high_open and x == self.high)):
                return bad
        return None


def _declared(cls: type) -> dict[str, Param]:
    out: dict[str, Param] = {}
    for base in reversed(cls.__mro__):
        for k, v in vars(base).items():
            if isinstance(v, Param):
                out[k] = v  # a redeclaration keeps the base's position, with its new default
            elif k in out:
                del out[k]  # a subclass fixes a base's parameter as a plain class attribute
    return out


def _params_section(params: dict[str, Param]) -> str:
    lines = ["Parameters", "----------"]
    for p in params.values():
        lines.append(f"{p.name} : {p.type_doc}" if p.type_doc else p.name)
        text = " ".join(p.doc.split())
        allowed = p.allowed()
        if allowed:
            text = f"{text} Allowed: {allowed}." if text else f"Allowed: {allowed}."
        if p.unit:
            text = f"{text} Unit: {p.unit}." if text else f"Unit: {p.unit}."
        lines.extend(textwrap.wrap(text, 92, initial_indent="    ", subsequent_indent="    "))
    return "\n".join(lines)


#: Off while the conformance kit probes that ``__init__`` stores placeholders unchanged.
_VALIDATING: contextvars.ContextVar[bool] = contextvars.ContextVar("pftrack_validating",
                                                                   default=True)


@contextlib.contextmanager
def _unvalidated() -> Iterator[None]:
    """Build components without checking their parameters (the conformance kit's probe)."""
    token = _VALIDATING.set(False)
    try:
        yield
    finally:
        _VALIDATING.reset(token)


def _generated_init(cls: type, params: dict[str, Param]) -> Any:
    names = list(params)
    defaults = {k: p.default for k, p in params.items()}

    def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
        if len(args) > len(names):
            raise TypeError(f"{type(self).__name__}() takes {len(names)} parameters, "
                            f"{len(args)} given")
        for k, v in zip(names, args):
            if k in kwargs:
                raise TypeError(f"{type(self).__name__}() got parameter {k!r} twice")
            kwargs[k] = v
        unknown = set(kwargs) - set(names)
        if unknown:
            raise TypeError(f"{type(self).__name__}() got unexpected parameters "
                            f"{sorted(unknown)}; parameters: {names}")
        for k in names:
            if k in kwargs:
                v = kwargs[k]
            elif defaults[k] is _NO_DEFAULT:
                raise TypeError(f"{type(self).__name__}() missing parameter {k!r}")
            else:
                v = defaults[k]
            setattr(self, k, v)
        if _VALIDATING.get():
            self._validate_params()

    __init__.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
        [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
        + [inspect.Parameter(k, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=defaults[k])
           for k in names])
    __init__.__qualname__ = f"{cls.__qualname__}.__init__"
    __init__.__doc__ = f"Store the parameters of :class:`{cls.__name__}` (declared with Param)."
    __init__._pftrack_generated = True  # type: ignore[attr-defined]
    return __init__


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
        """Set parameters (scikit-learn convention), checked as at construction."""
        valid = set(self._param_names())
        for k, v in params.items():
            if k not in valid:
                raise ValueError(
                    f"{type(self).__name__}: unknown parameter {k!r}; valid: {sorted(valid)}"
                )
            setattr(self, k, v)
        if _VALIDATING.get():
            self._validate_params(list(params))
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
        """Check the parameters ``names`` (default: all) against their declarations, then
        :meth:`_check_relations`; raise a ``ValueError`` naming the component, every parameter
        at fault, what it allows and the value given."""
        declared = _declared(type(self))
        problems = []
        for k in declared if names is None else names:
            if k in declared:
                why = declared[k].problem(getattr(self, k))
                if why is not None:
                    problems.append(f"parameter {k!r} must be {why}, got "
                                    f"{getattr(self, k)!r}")
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


def _plain(obj: Any) -> Any:
    """Make parameters YAML/JSON friendly (tuples -> lists, numpy scalars -> Python)."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


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

