"""Declared parameters: :class:`Param`, the groups of them (:class:`Group`,
:class:`ParamGroup`), their checks and the docstrings and ``__init__`` generated from them.

Every registered component declares its parameters here (:class:`pftrack.contracts.components.
Component` builds on it); :mod:`pftrack.contracts.components` re-exports the public names.
"""

from __future__ import annotations

import contextlib
import contextvars
import copy
import functools
import inspect
import math
import numbers
import textwrap
from collections.abc import Iterable, Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

__all__ = ["Group", "Param", "ParamGroup"]


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


def _flat(params: dict[str, Param]) -> dict[str, Param]:
    """``params`` with each :class:`Group` followed by its own parameters under dotted names
    (``train``, ``train.C``, ...), as the docstrings and the configuration reference list
    them. The dotted entries are copies named ``group.key``."""
    out: dict[str, Param] = {}
    for k, p in params.items():
        out[k] = p
        if isinstance(p, Group):
            for sub, q in _flat(_declared(p.group)).items():
                q = copy.copy(q)
                q.name = f"{k}.{sub}"
                out[q.name] = q
    return out


def _problems(declared: dict[str, Param], values: Any, names: Iterable[str] | None = None,
              prefix: str = "") -> list[str]:
    """What is wrong with the parameters ``names`` (default: all) of ``values`` (an object
    holding them as attributes) against ``declared``, one message each (``parameter 'x' must
    be ..., got ...``); a :class:`Group` value's own parameters are checked too, named
    ``group.key``, and then its relations (:meth:`ParamGroup._check_relations`)."""
    out = []
    for k in declared if names is None else names:
        if k not in declared:
            continue
        p, v = declared[k], getattr(values, k)
        why = p.problem(v)
        if why is not None:
            out.append(f"parameter {prefix + k!r} must be {why}, got {v!r}")
        elif isinstance(p, Group) and isinstance(v, p.group):
            inner = _problems(_declared(p.group), v, prefix=f"{prefix}{k}.")
            if not inner:
                try:
                    v._check_relations()
                except ValueError as exc:
                    inner = [f"{prefix}{k}: {exc}"]
            out.extend(inner)
    return out


def _params_section(params: dict[str, Param]) -> str:
    lines = ["Parameters", "----------"]
    for p in _flat(params).values():
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
    groups = {k: p for k, p in params.items() if isinstance(p, Group)}

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
            if k in groups:
                v = groups[k].coerce(v, type(self)._label())
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


class Group(Param):
    """A declared group of parameters: parameters that belong together (a detector's training
    settings) declared once as a :class:`ParamGroup` subclass and taken as one parameter::

        class SvmTraining(ParamGroup):
            C: float = Param(0.01, "LinearSVC regularisation.", unit="1", low=0.0,
                             low_open=True)

        class SVMDetector(Detector):
            train: SvmTraining = Group(SvmTraining, "How fit() trains a model.")

    A configuration gives the group as a nested mapping (``params: {train: {C: 0.003}}``);
    the generated ``__init__`` (and :meth:`~pftrack.contracts.components.Component.set_params`)
    builds the :class:`ParamGroup` from such a mapping (keys left out take their defaults) and
    stores a :class:`ParamGroup` given as one unchanged. Each of the group's parameters is
    checked against its own declaration, and named with its group in messages
    (``parameter 'train.C' must be a number > 0``), in the generated docstring and in the
    configuration reference (``train.C``). ``get_params`` returns the :class:`ParamGroup`;
    ``to_config`` writes it as a mapping. As scikit-learn's nested parameters
    (``estimator__C``), but spelled with a dot, as YAML nesting reads.

    Parameters
    ----------
    group : type
        The :class:`ParamGroup` subclass that declares the group's parameters.
    doc : str
        What the group is for, one sentence.
    """

    def __init__(self, group: type[ParamGroup], doc: str = "") -> None:
        if not (isinstance(group, type) and issubclass(group, ParamGroup)):
            raise TypeError(f"Group({group!r}): expected a ParamGroup subclass")
        super().__init__(None, doc)
        self.group = group
        self.default = group()

    @property
    def optional(self) -> bool:
        return False

    def coerce(self, value: Any, owner: str) -> Any:
        """``value`` as the group's :class:`ParamGroup`: a mapping builds one (its unknown keys
        are a ``ValueError`` naming ``owner`` and the dotted parameter); the default is a
        fresh copy; anything else is returned unchanged (and checked by :meth:`problem`)."""
        if value is self.default:
            return copy.copy(value)
        if not isinstance(value, Mapping):
            return value
        declared = _declared(self.group)
        unknown = [k for k in value if k not in declared]
        if unknown:
            raise ValueError(f"{owner}: unknown parameter"
                             f"{'s' if len(unknown) > 1 else ''} "
                             f"{', '.join(repr(f'{self.name}.{k}') for k in unknown)} "
                             f"(parameters of {self.name}: {', '.join(declared)})")
        with _unvalidated():
            return self.group(**value)

    def expected(self) -> str:
        return f"a mapping of {self.name} parameters ({', '.join(_declared(self.group))})"

    def allowed(self) -> str:
        return ""

    def problem(self, value: Any) -> str | None:
        """None for a :class:`ParamGroup` of this group (its own parameters are checked one by
        one) or, in a configuration, a mapping; else what is allowed."""
        return None if isinstance(value, (self.group, Mapping)) else self.expected()

    def __repr__(self) -> str:
        return f"Group({self.group.__name__})"


class ParamGroup:
    """Parameters that belong together, declared with :class:`Param` as a component's are, and
    taken by a component as one :class:`Group` parameter.

    A subclass gets the same generated ``__init__`` (by keyword, or by position in declaration
    order; values checked against their declarations, a ``ValueError`` naming the group),
    docstring ``Parameters`` section (``{params}``) and relation check
    (:meth:`_check_relations`) as a component. Its instances are plain values: equal when their
    parameters are, copied by :meth:`replace`.
    """

    if TYPE_CHECKING:
        def __init__(self, *args: Any, **kwargs: Any) -> None: ...

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        params = _declared(cls)
        if "__init__" not in vars(cls):
            cls.__init__ = _generated_init(cls, params)  # type: ignore[method-assign]
        doc = cls.__dict__.get("__doc__") or ""
        if "{params}" in doc:
            cls.__doc__ = doc.replace("{params}", _params_section(params).replace(
                "\n", "\n    "))

    @classmethod
    def declared_params(cls) -> dict[str, Param]:
        """``{name: Param}`` of the group's parameters, in declaration order."""
        return _declared(cls)

    @classmethod
    def _label(cls) -> str:
        return cls.__name__

    def get_params(self) -> dict[str, Any]:
        """``{name: value}`` of the group's parameters."""
        return {k: getattr(self, k) for k in _declared(type(self))}

    def replace(self, **changes: Any) -> ParamGroup:
        """A copy with ``changes`` (checked as at construction)."""
        return type(self)(**{**self.get_params(), **changes})

    def _validate_params(self, names: Sequence[str] | None = None) -> None:
        problems = _problems(_declared(type(self)), self, names)
        if problems:
            raise ValueError(f"{self._label()}: " + "; ".join(problems))
        self._check_relations()

    def _check_relations(self) -> None:
        """Check what single declarations cannot say; raise a ``ValueError`` naming the
        parameters. Default: nothing."""

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ParamGroup) and type(other) is type(self) and _plain(
            self.get_params()) == _plain(other.get_params())

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"


def _plain(obj: Any) -> Any:
    """Make parameters YAML/JSON friendly (tuples -> lists, numpy scalars -> Python, a
    :class:`ParamGroup` -> a mapping)."""
    if isinstance(obj, ParamGroup):
        return _plain(obj.get_params())
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj
