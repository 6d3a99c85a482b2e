"""The run configuration's schema and its validation.

:data:`CONFIG_SCHEMA` declares every key of a run configuration (what ``pftrack run CONFIG``
reads; see :mod:`pftrack.workflows.pipeline`) as a tree of :class:`Field`: its type, default, unit,
range or choices and a one-line doc. It is plain data, so that the configuration reference can be
generated from it (:func:`iter_fields` walks it).

:func:`validate_config` checks a configuration against the schema and, for the components it
names (``observation``, ``motion``, ``likelihood``, ``detector``, ``associator``, ``tracks`` /
``births``), checks their parameters against the registered class: unknown parameters (with the
closest known name), and each value against its declaration (the type, range, choices and
length a :class:`pftrack.contracts.components.Param` states, or the type a hand-written ``__init__``
keyword is annotated with): the declarations the component checks itself against when built.
Every problem is reported at once in a :class:`ConfigError` naming the source, the key path,
what was expected and what was given::

    config run.yaml: tracker.n_particles: expected an integer >= 1 (particles per target),
    got 200.7
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = [
    "CONFIG_SCHEMA",
    "ConfigError",
    "ConfigIssue",
    "Field",
    "component_param_issues",
    "iter_fields",
    "validate_config",
]


@dataclass(frozen=True)
class Field:
    """One key of the configuration schema.

    Attributes
    ----------
    name : str
        The key.
    type : str
        ``int``, ``float``, ``bool``, ``str``, ``float|auto``, ``float|list[float]``,
        ``list[float]``, ``frames`` (``"A:B"``), ``component`` (a registered name, or
        ``{type, params}``), ``mapping`` (with ``children``) or ``any``.
    default : Any
        The value used when the key is absent (``None``: none / off).
    unit : str
        Unit of the value ('' when it has none).
    doc : str
        One line.
    range : tuple of (float or None, float or None), optional
        Inclusive bounds of numbers (None: unbounded on that side).
    choices : tuple of str, optional
        Allowed values of a string.
    nullable : bool
        Whether ``null`` is allowed.
    kind : str, optional
        For ``component`` fields: the plugin kind of the component.
    length : int, optional
        For lists: the exact length.
    children : tuple of Field
        For ``mapping`` fields: the keys inside.
    open : bool
        For ``mapping`` fields: other keys are allowed (checked elsewhere, e.g. component
        parameters).
    """

    name: str
    type: str
    default: Any = None
    unit: str = ""
    doc: str = ""
    range: tuple[float | None, float | None] | None = None
    choices: tuple[str, ...] | None = None
    nullable: bool = False
    kind: str | None = None
    length: int | None = None
    children: tuple[Field, ...] = ()
    open: bool = False

    def child(self, name: str) -> Field | None:
        """The child field called ``name`` (None when there is none)."""
        for c in self.children:
            if c.name == name:
                return c
        return None

    def expected(self) -> str:
        """What a valid value looks like, in words (used in error messages)."""
        words = {"int": "an integer", "float": "a number", "bool": "true or false",
                 "str": "a string", "float|auto": "a number or 'auto'",
                 "float|list[float]": "a number or a list of numbers",
                 "list[float]": "a list of numbers", "frames": "frames 'A:B' (1-based)",
                 "component": f"a registered {self.kind} name or {{type, params}}",
                 "mapping": "a mapping", "any": "anything"}
        text = words.get(self.type, self.type)
        if self.length is not None:
            text += f" of length {self.length}"
        if self.choices:
            text = "one of " + ", ".join(repr(c) for c in self.choices)
        if self.range is not None:
            lo, hi = self.range
            if lo is not None and hi is not None:
                text += f" in [{lo:g}, {hi:g}]"
            elif lo is not None:
                text += f" >= {lo:g}"
            elif hi is not None:
                text += f" <= {hi:g}"
        if self.nullable:
            text += " or null"
        if self.unit:
            text += f" ({self.unit})"
        return text


def _component(name: str, kind: str, doc: str, default: Any = None) -> Field:
    return Field(name, "component", default=default, kind=kind, doc=doc, nullable=True)


_TRACKER = Field("tracker", "mapping",
                 doc="Engine options (pftrack.engine.tracker.MultiTargetTracker).",
                 nullable=True, children=(
    Field("n_particles", "int", 500, "particles per target", "Particles per target.",
          range=(1, None)),
    Field("resampling", "str", "systematic", "", "Resampling scheme.",
          choices=("systematic", "stratified", "residual", "multinomial")),
    Field("ess_threshold", "float", 1.0, "fraction of n_particles",
          "Resample when ESS < ess_threshold * n_particles (1: every frame).", range=(0.0, 1.0)),
    Field("dt", "float|auto", "auto", "motion model's time unit (s, or frames)",
          "Time step per frame; 'auto': 1 / fps.", range=(0.0, None)),
    Field("init_spread", "float|list[float]", 1.0, "state units (m or px)",
          "Std of a new target's particle spread around its position.", range=(0.0, None)),
    Field("recover_spread", "float|list[float]", None, "state units (m or px)",
          "Std of the re-spread when every weight is zero (default 5 * init_spread).",
          range=(0.0, None), nullable=True),
    Field("max_misses", "int", None, "frames",
          "A target dies after this many consecutive frames without support.",
          range=(0, None), nullable=True),
    Field("max_misses_s", "float", None, "s",
          "max_misses in seconds of video: round(max_misses_s * fps) frames at the run's frame "
          "rate (the same time on a 7 and on a 30 frames-per-second video); not with "
          "max_misses.", range=(0.0, None), nullable=True),
    Field("min_log_likelihood", "float", None, "log-likelihood",
          "A frame supports a target whose best particle reaches this.", nullable=True),
    Field("kill_out_of_view", "bool", True, "", "A target dies when its box leaves the image."),
    Field("detection_proposal", "float", 0.0, "fraction of n_particles",
          "Particles of a target redrawn around its matched detection (init_spread) before "
          "weighting: a mixture of the motion prior and the detections; 0: prior alone.",
          range=(0.0, 1.0)),
    Field("birth_velocity_spread", "float", 0.0, "box heights per dt",
          "Std of a new target's particle velocities, in heights of the box it starts from "
          "(image-plane observations): speeds held as hypotheses from the first frame; 0: "
          "every target starts at rest.", range=(0.0, None)),
    Field("target_size", "float", 1.0, "m", "Default target size (adaptive motion noise).",
          range=(0.0, None)),
))

_DETECTOR = Field("detector", "mapping", nullable=True, kind="detector",
                  doc="The detector: {type, params, train, detect}.", children=(
    Field("type", "str", None, "", "A registered detector name."),
    Field("params", "mapping", None, "", "The detector's parameters.", nullable=True, open=True),
    Field("detect", "bool", True, "",
          "Run it per frame (false: only trained, its model read by other components)."),
    Field("train", "mapping", None, "", "How `pftrack detector train` trains it.",
          nullable=True, children=(
        Field("frames", "frames", None, "frames (1-based)", "Training frames 'A:B'.",
              nullable=True),
        Field("params", "mapping", None, "",
              "Training settings: the keys of the detector's `train` parameter group when it "
              "declares one (the svm detector's: `train.C` is `C` here), else detector "
              "parameters used only while training.", nullable=True, open=True),
        Field("seed", "int", 0, "", "Training seed.", range=(0, None)),
    )),
))

CONFIG_SCHEMA = Field("config", "mapping", doc="A run configuration (pftrack run CONFIG).",
                      children=(
    Field("name", "str", None, "", "Name shown in progress and reports.", nullable=True),
    Field("description", "str", None, "", "Free text.", nullable=True),
    Field("state", "str", "world", "", "State space: ground plane (world) or image pixels.",
          choices=("world", "image")),
    _component("observation", "observation",
               "Observation model (default camera-box for world, image-box for image state); "
               "legacy: a mapping of camera-box parameters."),
    _component("motion", "motion", "Motion model (required)."),
    _component("likelihood", "likelihood", "Likelihood (required), e.g. composite."),
    _DETECTOR,
    _component("associator", "associator", "Detection-to-target associator."),
    _component("tracks", "tracks", "Track manager (default confirmed).", default="confirmed"),
    Field("births", "mapping", None, "", "Legacy: the confirmed track manager's parameters.",
          nullable=True, open=True, kind="tracks"),
    _TRACKER,
    Field("valid_region_m", "list[float]", None, "m",
          "Ground rectangle [x0, x1, y0, y1] people live in.", nullable=True, length=4),
    Field("detections", "str", None, "path",
          "A MOTChallenge det.txt (relative to the YAML file): detections from elsewhere; the "
          "detector is not run.", nullable=True),
    Field("report", "mapping", None, "", "Report options.", nullable=True, children=(
        Field("writer", "str", "tracks", "", "A registered report writer."),
    )),
))


def iter_fields(field: Field = CONFIG_SCHEMA, prefix: str = "") -> Iterator[tuple[str, Field]]:
    """Every field below ``field`` with its dotted key path, depth first, in schema order."""
    for c in field.children:
        path = f"{prefix}{c.name}"
        yield path, c
        yield from iter_fields(c, path + ".")


# --------------------------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ConfigIssue:
    """One problem: the dotted key path, what was expected and what was given."""

    path: str
    message: str

    def __str__(self) -> str:
        return f"{self.path}: {self.message}"


class ConfigError(ValueError):
    """A configuration that does not match the schema; ``issues`` lists every problem."""

    def __init__(self, source: str, issues: Sequence[ConfigIssue]) -> None:
        self.source = source
        self.issues = list(issues)
        super().__init__(f"config {source}: " + "; ".join(str(i) for i in self.issues))


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _suggest(name: str, known: Sequence[str]) -> str:
    close = difflib.get_close_matches(str(name), list(known), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def _check_range(f: Field, raw: Any, path: str, out: list[ConfigIssue]) -> None:
    v = float(raw)
    if not math.isfinite(v):
        out.append(ConfigIssue(path, f"expected {f.expected()}, got {raw!r}"))
        return
    if f.range is None:
        return
    lo, hi = f.range
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        out.append(ConfigIssue(path, f"expected {f.expected()}, got {raw!r}"))


def _check_value(f: Field, v: Any, path: str, out: list[ConfigIssue], host: Any) -> None:
    if v is None:
        if not f.nullable and f.default is not None:
            out.append(ConfigIssue(path, f"expected {f.expected()}, got null"))
        return
    bad = ConfigIssue(path, f"expected {f.expected()}, got {v!r}")
    t = f.type
    if t == "int":
        if not _is_int(v):
            out.append(bad)
            return
        _check_range(f, v, path, out)
    elif t == "float":
        if not _is_number(v):
            out.append(bad)
            return
        _check_range(f, v, path, out)
    elif t == "bool":
        if not isinstance(v, bool):
            out.append(bad)
    elif t == "str":
        if not isinstance(v, str):
            out.append(bad)
        elif f.choices and v not in f.choices:
            out.append(ConfigIssue(path, f"expected {f.expected()}, got {v!r}"
                                   + _suggest(v, f.choices)))
    elif t == "float|auto":
        if v == "auto":
            return
        if not _is_number(v) or float(v) <= 0 or not math.isfinite(float(v)):
            out.append(ConfigIssue(path, f"expected a number > 0 or 'auto' ({f.unit}), "
                                   f"got {v!r}"))
    elif t in ("float|list[float]", "list[float]"):
        items = [v] if (t == "float|list[float]" and _is_number(v)) else v
        if not isinstance(items, (list, tuple)) or not all(_is_number(x) for x in items) \
                or not items:
            out.append(bad)
            return
        if f.length is not None and len(items) != f.length:
            out.append(bad)
            return
        for x in items:
            before = len(out)
            _check_range(f, x, path, out)
            if len(out) > before:
                out[-1] = bad
                return
    elif t == "frames":
        if not isinstance(v, str):
            out.append(bad)
            return
        from pftrack.io.frames import parse_frames

        try:
            parse_frames(v)
        except ValueError:
            out.append(bad)
    elif t == "component":
        _check_component(f, v, path, out, host)
    elif t == "mapping":
        if not isinstance(v, Mapping):
            out.append(bad)
            return
        _check_mapping(f, v, path, out, host)


def _check_mapping(f: Field, v: Mapping[str, Any], path: str, out: list[ConfigIssue],
                   host: Any) -> None:
    known = [c.name for c in f.children]
    for key, val in v.items():
        sub = f"{path}.{key}" if path else str(key)
        c = f.child(key)
        if c is None:
            if f.open:
                continue
            out.append(ConfigIssue(sub, f"unknown key (known: {', '.join(known)})"
                                   + _suggest(key, known)))
            continue
        _check_value(c, val, sub, out, host)
    if f is _DETECTOR and isinstance(v.get("type"), str):
        params = {**(v.get("params") or {})} if isinstance(v.get("params"), Mapping) else {}
        train: Mapping[str, Any] = v["train"] if isinstance(v.get("train"), Mapping) else {}
        tparams: Mapping[str, Any] = (train["params"] if isinstance(train.get("params"), Mapping)
                                      else {})
        out.extend(component_param_issues("detector", v["type"], params, f"{path}.params",
                                          host))
        if _training_group(host, v["type"]) is not None:
            out.extend(component_param_issues("detector", v["type"], {"train": dict(tparams)},
                                              f"{path}.train.params", host, group="train"))
        else:
            out.extend(component_param_issues("detector", v["type"], dict(tparams),
                                              f"{path}.train.params", host))
    if f.name == "births" and f.kind == "tracks":
        out.extend(component_param_issues("tracks", "confirmed", dict(v), path, host))


def _check_component(f: Field, v: Any, path: str, out: list[ConfigIssue], host: Any) -> None:
    if isinstance(v, str):
        out.extend(component_param_issues(f.kind or "", v, {}, path, host))
        return
    if not isinstance(v, Mapping):
        out.append(ConfigIssue(path, f"expected {f.expected()}, got {v!r}"))
        return
    if "type" in v:
        extra = set(v) - {"type", "params"}
        if extra:
            out.append(ConfigIssue(path, f"unknown keys {sorted(extra)} beside type and params "
                                   "(put parameters under params)"))
        if not isinstance(v["type"], str):
            out.append(ConfigIssue(f"{path}.type", f"expected a registered {f.kind} name, "
                                   f"got {v['type']!r}"))
            return
        params = v.get("params") or {}
        if not isinstance(params, Mapping):
            out.append(ConfigIssue(f"{path}.params", f"expected a mapping, got {params!r}"))
            return
        out.extend(component_param_issues(f.kind or "", v["type"], dict(params),
                                          f"{path}.params", host))
        _check_nested(params, f"{path}.params", out, host)
    elif f.name == "observation":
        # legacy form: the default observation model's parameters (checked in validate_config,
        # which knows the state)
        return
    else:
        out.append(ConfigIssue(path, f"expected {f.expected()}, got a mapping without 'type'"))


_NESTED_KINDS = ("likelihood", "detector", "motion", "observation", "associator")


def _check_nested(params: Mapping[str, Any], path: str, out: list[ConfigIssue],
                  host: Any) -> None:
    """Component specs inside parameters (a composite likelihood's ``terms: [{likelihood:
    {type, params}, weight}]``): checked as components of their kind."""
    for key, val in params.items():
        if not isinstance(val, list):
            continue
        for i, item in enumerate(val):
            if not isinstance(item, Mapping):
                continue
            for kind in _NESTED_KINDS:
                spec = item.get(kind)
                if isinstance(spec, Mapping) and "type" in spec:
                    _check_component(_component(kind, kind, ""), spec,
                                     f"{path}.{key}[{i}].{kind}", out, host)


def _training_group(host: Any, name: str) -> Any:
    """The :class:`~pftrack.contracts.params.Group` named ``train`` of the registered detector
    ``name`` (its training settings), or None when it declares none."""
    from pftrack.contracts.params import Group, _declared

    if host is None:
        from pftrack.host import get_host

        host = get_host()
    try:
        cls = host.get("detector", name)
    except KeyError:
        return None
    group = _declared(cls).get("train") if isinstance(cls, type) else None
    return group if isinstance(group, Group) else None


def training_params(name: str, params: Mapping[str, Any], training: Mapping[str, Any],
                    host: Any = None) -> dict[str, Any]:
    """The parameters the detector ``name`` is trained with: ``params`` (its configuration's
    ``detector.params``) with ``training`` (``detector.train.params``, and the command line's
    options) over them. For a detector that declares a ``train`` parameter group (the ``svm``
    detector's training settings) ``training`` are that group's keys, over ``params.train``;
    for another, detector parameters used only while training."""
    out = dict(params)
    if not training:
        return out
    if _training_group(host, name) is None:
        return {**out, **training}
    from pftrack.contracts.params import _plain

    given = out.get("train")
    base = _plain(given) if given is not None else {}
    out["train"] = {**(base if isinstance(base, Mapping) else {}), **training}
    return out


def component_param_issues(kind: str, name: str, params: Mapping[str, Any], path: str,
                           host: Any = None, group: str | None = None) -> list[ConfigIssue]:
    """Problems with the parameters of the registered ``kind`` component ``name``.

    Unknown parameter names (with the closest known one), and values that their declarations
    (:meth:`pftrack.contracts.components.Component.declared_params`: the
    :class:`~pftrack.contracts.components.Param` type, range, choices and length, or a hand-written
    ``__init__``'s annotated type) do not allow: the same check the component makes when it is
    built. A parameter group (:class:`~pftrack.contracts.params.Group`) is a nested mapping
    whose keys are checked against the group's declarations, at ``path.group.key``; with
    ``group``, ``params`` is ``{group: mapping}`` and the mapping's keys are reported at
    ``path.key`` (a group configured elsewhere, as ``detector.train.params``). An unregistered
    name gives no issue here (building it reports it with the registered names).
    """
    from pftrack.contracts.params import Group, _declared

    if host is None:
        from pftrack.host import get_host

        host = get_host()
    try:
        cls = host.get(kind, name)
    except KeyError:
        return []
    if not isinstance(cls, type):
        return []
    try:
        declared = cls.declared_params()  # type: ignore[attr-defined]  # a Component, or not
    except (AttributeError, TypeError, ValueError):
        return []
    who = f"{kind} {name!r}"

    def check(decl: Mapping[str, Any], values: Mapping[str, Any], at: str, prefix: str
              ) -> list[ConfigIssue]:
        # prefix: the group's dotted name ("train.") when checking a group's keys
        names = list(decl)
        of = f" of {prefix.rstrip('.')}" if prefix else ""
        out = []
        for key, val in values.items():
            sub = f"{at}.{key}"
            if key not in decl:
                what = f"parameter {prefix}{key}" if prefix else "parameter"
                out.append(ConfigIssue(sub, f"unknown {what} of {who} (parameters{of}: "
                                       f"{', '.join(names) or 'none'})" + _suggest(key, names)))
                continue
            p = decl[key]
            why = p.problem(val)
            if why is not None:
                named = f" for {prefix}{key}" if prefix else ""
                out.append(ConfigIssue(sub, f"{who} expects {why}{named}, got {val!r}"))
            elif isinstance(p, Group) and isinstance(val, Mapping):
                # a group configured elsewhere reports its keys at ``path.key``
                inner = path if (group == key and not prefix) else sub
                out.extend(check(_declared(p.group), val, inner, f"{prefix}{key}."))
        return out

    return check(declared, params, path, "")


def validate_config(cfg: Mapping[str, Any], source: str = "config", host: Any = None
                    ) -> Mapping[str, Any]:
    """Check ``cfg`` against :data:`CONFIG_SCHEMA` and its components' parameters.

    Parameters
    ----------
    cfg : mapping
        A run configuration (a ``_source`` key is ignored).
    source : str
        Where it came from (a file name), named in the message.
    host : pftrack.host.Host, optional
        Where component classes are looked up (default: the process-wide host).

    Returns
    -------
    mapping
        ``cfg`` itself, unchanged, when it is valid.

    Raises
    ------
    ConfigError
        Listing every problem with its key path, the expected type/range and the given value.
    """
    if not isinstance(cfg, Mapping):
        raise ConfigError(source, [ConfigIssue("(top level)", f"expected a mapping, got "
                                               f"{type(cfg).__name__}")])
    issues: list[ConfigIssue] = []
    body = {k: v for k, v in cfg.items() if k != "_source"}
    _check_mapping(CONFIG_SCHEMA, body, "", issues, host)
    for key in ("motion", "likelihood"):
        if body.get(key) is None:
            issues.append(ConfigIssue(key, "missing (required)"))
    obs = body.get("observation")
    if isinstance(obs, Mapping) and "type" not in obs:
        default = "image-box" if body.get("state") == "image" else "camera-box"
        issues.extend(component_param_issues("observation", default, dict(obs), "observation",
                                             host))
    region = body.get("valid_region_m")
    if isinstance(region, (list, tuple)) and len(region) == 4 and all(map(_is_number, region)):
        x0, x1, y0, y1 = (float(r) for r in region)
        if not (x0 < x1 and y0 < y1):
            issues.append(ConfigIssue("valid_region_m", f"expected [x0, x1, y0, y1] with "
                                      f"x0 < x1 and y0 < y1 (m), got {list(region)}"))
    if body.get("tracks") is not None and body.get("births"):
        issues.append(ConfigIssue("births", "give 'tracks' or the legacy 'births', not both"))
    if issues:
        raise ConfigError(source, issues)
    return cfg
