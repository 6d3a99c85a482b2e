"""Pages of the documentation generated from the code at build time.

A small Sphinx extension (``docs/conf.py`` loads it). On ``builder-inited`` it writes, under
``docs/_generated/`` (git-ignored):

* ``config_keys.md``, ``config_components.md``, ``config_presets.md``: the configuration
  reference in three pages (:func:`split_config_reference`): every key of a run configuration
  with its type, default, unit and range (from the schema
  :data:`pftrack.host.config.CONFIG_SCHEMA`), every parameter of every component the plugin host
  registers (its signature's default, its ``Parameters`` docstring entry or
  :class:`pftrack.contracts.components.Param` declaration; the unit as the declaration's ``unit=``
  or the description's closing ``Unit: X.`` states it, else read off the name's suffix or the
  description; the range, choices and length the declaration allows), and every preset, key by key
  with the component's default beside it;
* ``cli_reference.md``: every command's ``--help``;
* ``results.md``: the latest result file of each benchmark in ``results/``
  (``pftrack_results.results_page``);
* ``api/*.md``: one autodoc page per public module of the core and of the built-in plugins
  (``api/_modules``), and of the repository's benchmarks (``api/_benchmarks``, their own heading);

and executes the notebooks (``notebooks/*.ipynb``, stored without outputs) into
``docs/gallery/`` on the short slices their tests use (:data:`NOTEBOOKS`), so that myst-nb
renders them with their pictures. The functions are importable without Sphinx (the test of the
configuration reference, ``tests/docs/test_docs.py``, calls :func:`config_reference`).
"""

from __future__ import annotations

import hashlib
import inspect
import json
import os
import re
import shutil
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"

#: Notebook -> (environment for its kernel, working directory: ``"root"`` or ``"tmp"``), as the
#: notebook tests in ``tests/notebooks/test_notebooks_*.py`` run them (their SHORT slices).
NOTEBOOKS: dict[str, tuple[dict[str, str], str]] = {
    "00_geometry.ipynb": ({}, "root"),
    "01_cross_entropy.ipynb": ({"PFTRACK_NB_FRAMES": "30", "PFTRACK_NB_PETS_LAST": "20"}, "tmp"),
    "02_soccer_world.ipynb": ({"PFTRACK_NB_SECONDS": "2"}, "tmp"),
    "03_pets_ground_plane.ipynb": ({"PFTRACK_NB_TRAIN": "1:120", "PFTRACK_NB_FRAMES": "401:460"},
                                   "tmp"),
    "04_block_eigenspace.ipynb": ({}, "root"),
    "05_coastal_volumes.ipynb": ({}, "root"),
    "06_camera_network.ipynb": ({}, "root"),
    "07_own_detector.ipynb": ({"PFTRACK_NB_FRAMES": "1:40"}, "tmp"),
}

#: Component kinds of a run configuration, in the order of the reference page: kind -> the
#: configuration key that names it.
COMPONENT_KINDS = {"observation": "observation", "motion": "motion", "likelihood": "likelihood",
                   "detector": "detector", "associator": "associator", "tracks": "tracks",
                   "stage": "(lifecycle stages: ``tracks: {type: stages, params: {stages: "
                            "[...]}}``)",
                   "scene": "(scenes: ``pftrack demo``, benchmarks, notebooks)"}

#: Modules left out of the API reference: private kernels and the command line's internals.
_API_SKIP = re.compile(r"(^|\.)_|^pftrack\.cli\.|^pftrack\.__main__$")

# a unit read off a parameter's name (suffix) or its description
_NAME_UNITS = {"_m": "m", "_px": "px", "_s": "s", "_deg": "deg", "_frames": "frames",
               "_mps": "m/s", "_ms": "ms"}
_DOC_UNITS = [  # a unit stated as such: ", metres", "in pixels", "(s)", "px." ...
    (r"m/s\^?2|m s\^-2", "m/s²"), (r"m/s|metres per second", "m/s"),
    (r"metres|meters|m", "m"), (r"pixels|px", "px"), (r"seconds|s", "s"),
    (r"frames", "frames"), (r"degrees|deg", "deg"), (r"radians|rad", "rad"),
]
_UNIT_CONTEXT = r"(?:, |\bin |\()(?:{})(?=[.;)]|$)"
# a unit stated as the description's last sentence: "... Unit: px."
_STATED_UNIT = re.compile(r"(?:^|\s)Unit: ([^\s.][^\n]*?)\.?\s*$")
#: The stated unit of a number that is not a quantity (a seed, an index): shown as ``—``.
NOT_A_QUANTITY = "none"


# --------------------------------------------------------------------------------------------
# Configuration reference
# --------------------------------------------------------------------------------------------


def _md_cell(text: Any) -> str:
    """Text for one cell of a Markdown table: one line, pipes escaped, reST roles
    (``:class:`X```) as MyST roles."""
    text = re.sub(r":(\w+):`", r"{\1}`", " ".join(str(text).split()))
    return text.replace("|", "\\|")


def _code(value: Any) -> str:
    """A default or value as inline code (``—`` when there is none)."""
    if value is inspect.Parameter.empty:
        return "required"
    if value is GROUP_DEFAULT:
        return "—"
    text = json.dumps(value) if isinstance(value, (str, bool, type(None))) else repr(value)
    return "`" + text.replace("|", "\\|").replace("`", "'") + "`"


def unit_of(name: str, doc: str) -> str:
    """The unit of parameter ``name``: its name's suffix (``_m``, ``_px``, ...) or the first unit
    word its description names; ``""`` when neither says one."""
    for suffix, unit in _NAME_UNITS.items():
        if name.endswith(suffix):
            return unit
    for pattern, unit in _DOC_UNITS:
        if re.search(_UNIT_CONTEXT.format(pattern), doc.strip()):
            return unit
    return ""


def stated_unit(doc: str) -> tuple[str | None, str]:
    """The unit a description states in its closing ``Unit: X.`` sentence.

    Parameters
    ----------
    doc : str
        A parameter's description.

    Returns
    -------
    unit : str or None
        ``X`` (``"none"``: a number that is not a quantity); None when the description states no
        unit.
    doc : str
        The description without that sentence.
    """
    m = _STATED_UNIT.search(doc)
    if not m:
        return None, doc
    return m.group(1).strip(), doc[:m.start()].rstrip()


def parameters_section(doc: str) -> dict[str, tuple[str, str]]:
    """``{name: (type, description)}`` of a numpydoc docstring's ``Parameters`` section
    (``a, b : float`` documents both names)."""
    lines = inspect.cleandoc(doc).splitlines() + [""]
    rule = re.compile(r"-{3,}")
    starts = [k for k in range(len(lines) - 1)
              if lines[k].strip() == "Parameters" and rule.fullmatch(lines[k + 1].strip())]
    if not starts:
        return {}
    body = []
    for k in range(starts[0] + 2, len(lines) - 1):
        if rule.fullmatch(lines[k + 1].strip()) and lines[k].strip():
            break  # the next section's title
        body.append(lines[k])
    out: dict[str, tuple[str, str]] = {}
    entry: tuple[list[str], str, list[str]] | None = None
    for line in body + ["END"]:
        if line and not line.startswith(" "):
            if entry:
                for n in entry[0]:
                    out.setdefault(n, (entry[1], " ".join(entry[2])))
            head, _, typ = line.partition(" : ")
            entry = ([n.strip().lstrip("*") for n in head.split(",")], typ.strip(), [])
        elif line.strip() and entry:
            entry[2].append(line.strip())
    return out


def _doc_params(cls: type) -> dict[str, tuple[str, str]]:
    """``{name: (type, description)}`` from the ``Parameters`` sections of ``cls``'s docstring
    and its bases' (the nearest class that documents a name wins)."""
    out: dict[str, tuple[str, str]] = {}
    for klass in cls.__mro__:
        doc = klass.__dict__.get("__doc__")
        if not doc:
            continue
        for k, v in parameters_section(doc).items():
            out.setdefault(k, v)
        # "Parameters are those of :class:`Other`." (a sibling sharing a base's __init__)
        same = re.search(r"Parameters are those of :class:`~?([\w.]+)`", doc)
        if same:
            module = inspect.getmodule(klass)
            other = getattr(module, same.group(1).rsplit(".", 1)[-1], None)
            if isinstance(other, type) and other is not klass:
                for k, v in _doc_params(other).items():
                    out.setdefault(k, v)
    return out


def component_params(cls: type) -> list[dict[str, Any]]:
    """Every constructor parameter of component class ``cls``.

    Returns
    -------
    list of dict
        One per parameter in signature order: ``name``, ``type``, ``default`` (the signature's;
        ``inspect.Parameter.empty`` when required), ``unit`` (the stated one, from a
        :class:`pftrack.contracts.components.Param` declaration's ``unit`` or the description's
        closing ``Unit: X.``; otherwise :func:`unit_of`; ``""`` for none or for ``"none"``),
        ``unit_source`` (``"stated"``, ``"name"`` for a name suffix, ``"text"`` for a unit
        word of the description, ``""``), ``doc`` (the description from the declaration or the
        ``Parameters`` section, without its ``Unit:`` sentence), ``numeric`` (whether the
        type or the default is a number or numbers, booleans excluded) and ``allowed`` (what
        a :class:`pftrack.contracts.components.Param` declaration allows, :func:`param_allowed`;
        ``""`` for a parameter of a hand-written ``__init__``).
    """
    from pftrack.contracts.components import Group, _declared

    declared = _declared(cls)
    documented = _doc_params(cls)
    rows = []
    for p in inspect.signature(cls.__init__).parameters.values():
        if p.name == "self" or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        group = declared.get(p.name)
        if isinstance(group, Group):
            keys = ", ".join(f"`{p.name}.{k}`" for k in _declared(group.group))
            rows.append({"name": p.name, "type": "mapping", "default": GROUP_DEFAULT,
                         "unit": "", "unit_source": "", "numeric": False, "allowed": "",
                         "doc": f"{group.doc} A mapping of the keys below ({keys}); a key "
                                "left out takes its default."})
            for sub in _declared(group.group).values():
                rows.append(_declared_row(f"{p.name}.{sub.name}", sub, sub.default))
            continue
        if p.name in declared:
            typ, doc = declared[p.name].type_doc, declared[p.name].doc
            unit = declared[p.name].unit
            if unit is None:
                unit, doc = stated_unit(doc)
        else:
            typ, doc = documented.get(p.name, ("", ""))
            unit, doc = stated_unit(doc)
        if not typ and p.annotation is not inspect.Parameter.empty:
            typ = p.annotation if isinstance(p.annotation, str) else getattr(
                p.annotation, "__name__", str(p.annotation))
        if unit is not None:
            source = "stated"
            unit = "" if unit == NOT_A_QUANTITY else unit
        else:
            unit = unit_of(p.name, doc)
            source = ("name" if any(p.name.endswith(k) for k in _NAME_UNITS) else "text") \
                if unit else ""
        rows.append({"name": p.name, "type": typ, "default": p.default, "unit": unit,
                     "unit_source": source, "doc": doc,
                     "numeric": is_numeric(typ, p.default),
                     "allowed": param_allowed(declared[p.name]) if p.name in declared else ""})
    return rows


#: The default shown for a parameter group (its keys' defaults are on their own rows).
GROUP_DEFAULT = "—"


def _declared_row(name: str, param: Any, default: Any) -> dict[str, Any]:
    """The row of :func:`component_params` for a declared parameter ``param`` named ``name``."""
    typ, doc, unit = param.type_doc, param.doc, param.unit
    if unit is None:
        unit, doc = stated_unit(doc)
    if unit is not None:
        source = "stated"
        unit = "" if unit == NOT_A_QUANTITY else unit
    else:
        unit = unit_of(name, doc)
        source = ("name" if any(name.endswith(k) for k in _NAME_UNITS) else "text") \
            if unit else ""
    return {"name": name, "type": typ, "default": default, "unit": unit,
            "unit_source": source, "doc": doc, "numeric": is_numeric(typ, default),
            "allowed": param_allowed(param)}


def param_allowed(param: Any) -> str:
    """A :class:`pftrack.contracts.components.Param`'s choices, range, length and whether null is
    allowed, in the words of the schema tables (``[1, ∞)``, ``(0, 1]``; ``''`` when free)."""
    parts = []
    if param.choices is not None:
        parts.append("one of " + ", ".join(f"`{c}`" for c in param.choices))
    if param.low is not None or param.high is not None:
        lo = "(-∞" if param.low is None else f"{'(' if param.low_open else '['}{param.low:g}"
        hi = "∞)" if param.high is None else f"{param.high:g}{')' if param.high_open else ']'}"
        parts.append(f"{lo}, {hi}")
    if param.length is not None:
        parts.append("length " + " or ".join(str(n) for n in param.length))
    if param.optional and param.default is not None:
        parts.append("or null")
    return "; ".join(parts)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def is_numeric(typ: str, default: Any) -> bool:
    """Whether a parameter takes a number or numbers: its documented type names ``int`` or
    ``float``, or its default is a number or a sequence of numbers (``bool`` is not a number)."""
    if re.search(r"\b(int|float)s?\b", str(typ)):
        return True
    if _is_number(default):
        return True
    return isinstance(default, (tuple, list)) and bool(default) and all(
        _is_number(v) for v in default)


def _param_table(rows: list[dict[str, Any]]) -> list[str]:
    out = ["| key | type | default | unit | description |", "|---|---|---|---|---|"]
    for r in rows:
        desc = _md_cell(r["doc"]) + (f" Allowed: {r['allowed']}." if r.get("allowed") else "")
        out.append(f"| `{r['name']}` | {_md_cell(r['type'])} | {_code(r['default'])} | "
                   f"{r['unit'] or '—'} | {desc.strip() or '—'} |")
    return out


def _leaves(value: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    """``(dotted.path, value)`` of every leaf of a parsed YAML document (list items as ``[i]``)."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _leaves(v, f"{path}.{k}" if path else str(k))
    elif isinstance(value, list) and any(isinstance(v, (dict, list)) for v in value):
        for i, v in enumerate(value):
            yield from _leaves(v, f"{path}[{i}]")
    else:
        yield path, value


def preset_defaults(cfg: dict[str, Any], host: Any) -> dict[str, Any]:
    """``{dotted.path: default}`` of the component parameters a preset sets (its sections'
    ``type``'s constructor defaults), to show what a preset changes."""
    out: dict[str, Any] = {}
    kinds = {"observation": "observation", "motion": "motion", "likelihood": "likelihood",
             "detector": "detector", "associator": "associator", "tracks": "tracks"}
    for key, kind in kinds.items():
        spec = cfg.get(key)
        if not isinstance(spec, dict) or "type" not in spec:
            continue
        try:
            cls = host.get(kind, spec["type"])
        except KeyError:
            continue
        for r in component_params(cls):
            for path in _preset_paths(key, r["name"]):
                out[path] = r["default"]
    return out


def _preset_paths(key: str, name: str) -> list[str]:
    """Where a preset sets component parameter ``name`` of its section ``key``: under
    ``params``, and a detector's training group (``train.X``) under ``train.params`` too."""
    out = [f"{key}.params.{name}"]
    if key == "detector" and name.startswith("train."):
        out.append(f"detector.train.params.{name.removeprefix('train.')}")
    return out


def preset_units(cfg: dict[str, Any], host: Any) -> dict[str, str]:
    """``{dotted.path: unit}`` of the keys a preset may set: the schema's keys (their
    :class:`pftrack.host.config.Field` unit) and its sections' component parameters (the unit the
    component states, :func:`component_params`); ``""``: not a quantity or not known."""
    out = {path: f.unit for path, f in schema_fields()}
    for key in COMPONENT_KINDS:
        spec = cfg.get(key)
        if not isinstance(spec, dict) or "type" not in spec:
            continue
        try:
            cls = host.get(key, spec["type"])
        except KeyError:
            continue
        for r in component_params(cls):
            for path in _preset_paths(key, r["name"]):
                out[path] = r["unit"]
    return out


def schema_fields(field: Any = None) -> list[tuple[str, Any]]:
    """``(dotted key, Field)`` of the direct children of ``field`` (default: the top level of
    :data:`pftrack.host.config.CONFIG_SCHEMA`) and of their children, in schema order."""
    from pftrack.host.config import CONFIG_SCHEMA, iter_fields

    return list(iter_fields(CONFIG_SCHEMA if field is None else field))


def _allowed(field: Any) -> str:
    """A field's choices, range, length or component kind, in words ('' when free)."""
    parts = []
    if field.choices:
        parts.append("one of " + ", ".join(f"`{c}`" for c in field.choices))
    if field.range is not None:
        lo, hi = field.range
        parts.append(f"[{'' if lo is None else f'{lo:g}'}, {'' if hi is None else f'{hi:g}'}]"
                     .replace("[, ", "(-∞, ").replace(", ]", ", ∞)"))
    if field.length is not None:
        parts.append(f"length {field.length}")
    if field.kind and field.type == "component":
        parts.append(f"a registered {{ref}}`{field.kind} <config-kind-{field.kind}>` component")
    return "; ".join(parts)


def _schema_table(fields: list[tuple[str, Any]]) -> list[str]:
    out = ["| key | type | default | unit | description |", "|---|---|---|---|---|"]
    for path, f in fields:
        allowed = _allowed(f)
        desc = _md_cell(f.doc) + (f" Allowed: {allowed}." if allowed else "")
        typ = f.type + (" or null" if f.nullable else "")
        out.append(f"| `{path}` | {_md_cell(typ)} | "
                   f"{'—' if f.default is None else _code(f.default)} | "
                   f"{_md_cell(f.unit) or '—'} | {desc or '—'} |")
    return out


def _component_plugins(host: Any) -> list[str]:
    """The loaded plugins that register more than benchmarks (the repository's benchmark
    package registers only those: it is no part of a run's configuration)."""
    return [name for name, p in host.plugins.items()
            if set(p.components) - {"benchmark"} or not p.components]


def config_reference() -> str:
    """The configuration reference page, generated from the code.

    Returns
    -------
    str
        MyST Markdown: the schema's keys (top level, then each section), every registered
        component's parameters by kind, and every preset key by key.
    """
    import yaml
    from pftrack.host import get_host

    host = get_host()
    lines = [
        "<!-- generated by docs/_ext/pftrack_docs.py from the code: do not edit -->",
        "",
        "## Top-level keys",
        "",
        "A run configuration is a YAML mapping with these keys, from the schema "
        "{data}`pftrack.host.config.CONFIG_SCHEMA` that `pftrack run` validates against (any other "
        "key is an error naming the file and the key). Each component section is `{type: NAME, "
        "params: {...}}`: `NAME` is a registered name (below), `params` its constructor's "
        "keyword arguments; a parameter left out takes its default.",
        "",
    ]
    lines += _schema_table([(p, f) for p, f in schema_fields() if "." not in p])
    for path, field in schema_fields():
        if "." not in path and field.type == "mapping" and field.children:
            lines += ["", f"(config-{path})=", f"## `{path}:` keys", "", _md_cell(field.doc),
                      ""]
            lines += _schema_table([(f"{path}.{p}", f) for p, f in schema_fields(field)
                                    if "." not in p])
            for sub, f in schema_fields(field):
                if "." not in sub and f.type == "mapping" and f.children:
                    lines += ["", f"`{path}.{sub}:` {_md_cell(f.doc)}", ""]
                    lines += _schema_table([(f"{path}.{sub}.{c.name}", c) for c in f.children])
    lines += ["", "## Components", "",
              "Every component registered by the installed plugins (this build's: "
              + ", ".join(f"`{p}`" for p in sorted(_component_plugins(host)))
              + "). The unit column "
              "shows the unit each component states (a `Param`'s `unit`, or a description's "
              "closing `Unit: X.`; for a third-party parameter that states none, one read off "
              "its name, `_m`, `_px`, ...):", "",
              "- `px` image pixels (`px²` an area), `m` world metres, `s` seconds, `frames` "
              "video frames (a number of frames or a frame number), `frames/s` a frame rate, "
              "`grey levels` 8-bit intensity steps, `log-likelihood` a natural logarithm;",
              "- `state units (m or px)`: the motion model's state, metres in world "
              "coordinates, pixels in the image plane; `dt`: the tracker's time step "
              "(`tracker.dt`: seconds, or frames), so `m/dt` is a velocity and a noise "
              "`per √dt` is the standard deviation of one step of `dt = 1` (it grows with "
              "`√dt`);",
              "- `track heights`, `detection heights`, `target sizes`: relative to that box or "
              "size; `1/frame`: a blending rate applied once per frame;",
              "- `1`: a dimensionless number (a ratio, a fraction, an IoU, a probability, a "
              "weight, a score); `count`: a number of things (bins, cells, particles, "
              "samples); `detector score`: the run's detector's own score c(det);",
              "- `—`: not a quantity (a name, a flag, a list of names, a file, a random seed, "
              "an index into the state vector).", ""]
    for kind, key in COMPONENT_KINDS.items():
        title = f"`{key}:`" if key == kind else key
        lines += [f"(config-kind-{kind})=",
                  f"### {kind.capitalize()} components {title if key == kind else ''}".rstrip(),
                  ""]
        for name in host.names(kind):
            cls = host.get(kind, name)
            entry = host.registry.get(kind, name)
            summary = (inspect.getdoc(cls) or "").split("\n\n")[0]
            lines += [f"(config-{kind}-{name})=", f"#### `{name}`", "",
                      f"{{class}}`{cls.__module__}.{cls.__qualname__}` (plugin "
                      f"`{entry.plugin}`). {_md_cell(summary)}", ""]
            rows = component_params(cls)
            lines += _param_table(rows) if rows else ["No parameters."]
            lines.append("")
    writers = host.names("report")
    lines += ["(config-kind-report)=", "### Report writers `report: {writer: NAME}`", "",
              "| name | plugin | what it draws |", "|---|---|---|"]
    for name in writers:
        entry = host.registry.get("report", name)
        lines.append(f"| `{name}` | `{entry.plugin}` | {_md_cell(entry.obj.summary)} |")
    lines += [""]
    lines += ["## Presets", "",
              "The configurations the plugins ship (`pftrack presets --show NAME` prints one; "
              "`pftrack run NAME ...` runs it). Each key the preset sets, with the component's "
              "default where it has one and its unit (as in the tables above; `—`: not a "
              "quantity, or a key inside a list such as a composite's terms).", ""]
    for name in host.names("preset"):
        path = Path(host.get("preset", name))
        cfg = yaml.safe_load(path.read_text())
        defaults = preset_defaults(cfg, host)
        units = preset_units(cfg, host)
        desc = " ".join(str(cfg.get("description", "")).split())
        lines += [f"(preset-{name})=", f"### `{name}`", "", _md_cell(desc), "",
                  f"Shipped as `{path.parent.parent.name}/{path.parent.name}/{path.name}`.", "",
                  "| key | value | default | unit |", "|---|---|---|---|"]
        for leaf, value in _leaves(cfg):
            if leaf in ("name", "description"):
                continue
            default = defaults.get(leaf, None)
            shown = _code(default) if leaf in defaults else "—"
            lines.append(f"| `{leaf}` | {_code(value)} | {shown} | "
                         f"{_md_cell(units.get(leaf, '')) or '—'} |")
        lines += ["", "```yaml",
                  path.read_text().rstrip(), "```", ""]
    return "\n".join(lines) + "\n"


def split_config_reference(page: str) -> dict[str, str]:
    """The configuration reference in three pages that each stay short enough to read:
    ``keys`` (the schema's keys), ``components`` (every registered component's parameters) and
    ``presets`` (every preset, key by key), split at the ``## Components`` and ``## Presets``
    headings of :func:`config_reference`'s page (the headings themselves become the pages'
    titles). Each keeps the generated-page marker."""
    marker = page.splitlines()[0]
    head, rest = page.split("\n## Components\n", 1)
    components, presets = rest.split("\n## Presets\n", 1)

    def up(text: str) -> str:  # one heading level up: the section's title is the page's
        return re.sub(r"^#(#{2,}) ", r"\1 ", text.strip(), flags=re.M)

    return {"keys": head.rstrip() + "\n",
            "components": marker + "\n\n" + up(components) + "\n",
            "presets": marker + "\n\n" + up(presets) + "\n"}


def _subparsers(parser: Any) -> dict[str, Any]:
    import argparse

    for action in parser._actions:  # argparse keeps its sub-commands here only
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def cli_reference() -> str:
    """The command-line reference page, from ``pftrack.cli.build_parser()``.

    Returns
    -------
    str
        MyST Markdown: the ``--help`` text of every ``pftrack`` command and sub-command
        (the plugins' commands included), formatted 88 columns wide.
    """
    from pftrack.cli import build_parser

    saved = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "88"  # what a page's code block shows unscrolled
    try:
        lines = ["<!-- generated by docs/_ext/pftrack_docs.py from the code: do not edit -->", ""]

        def walk(name: str, parser: Any, depth: int) -> None:
            lines.extend([f"(cli-{name.replace(' ', '-')})=", f"{'#' * depth} `{name}`", "",
                          "```text", parser.format_help().rstrip(), "```", ""])
            for sub, p in _subparsers(parser).items():
                walk(f"{name} {sub}", p, min(depth + 1, 4))

        root = build_parser()
        for name, p in _subparsers(root).items():
            walk(f"pftrack {name}", p, 2)
    finally:
        if saved is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = saved
    return "\n".join(lines)


def docstring_markdown(module: str, start: str | None = None) -> str:
    """A module's docstring as MyST Markdown, from its line ``start`` on: numpydoc section
    titles become level-2 headings, ``::`` literal blocks fenced code, reST roles MyST roles,
    so a guide page shows it without a second autodoc entry of the module."""
    import importlib

    lines = inspect.cleandoc(importlib.import_module(module).__doc__ or "").splitlines()
    if start is not None:
        lines = lines[next(i for i, ln in enumerate(lines) if ln.strip() == start):]
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if line.strip() and re.fullmatch(r"-{3,}", nxt.strip()):
            out += [f"## {line.strip()}", ""]
            i += 2
            continue
        if line.rstrip().endswith("::"):
            out.append(_myst_roles(line.rstrip()[:-1], module))
            block = []
            i += 1
            while i < len(lines) and (not lines[i].strip() or lines[i].startswith(" ")):
                block.append(lines[i])
                i += 1
            body = inspect.cleandoc("\n".join(block))
            lang = "yaml" if re.search(r"^\s*[\w-]+:", body, re.M) else ""
            out += ["", f"```{lang}", body, "```", ""]
            continue
        out.append(_myst_roles(line, module))
        i += 1
    return "\n".join(out).strip() + "\n"


def _myst_roles(text: str, module: str) -> str:
    """reST roles as MyST roles; a target without a dot is qualified with ``module``."""
    def one(m: re.Match[str]) -> str:
        role, target = m.group(1), m.group(2)
        if "." not in target.lstrip("~") and role in ("func", "class", "meth", "data"):
            target = f"~{module}.{target}"
        return f"{{{role}}}`{target}`"

    return re.sub(r":(\w+):`([^`]+)`", one, text)


# --------------------------------------------------------------------------------------------
# API pages
# --------------------------------------------------------------------------------------------


def api_modules(bases: tuple[str, ...] = ("toolkit", "plugins")) -> list[str]:
    """The public modules under the repository folders ``bases`` (default: the core and the
    built-in plugins, the product), sorted."""
    mods = []
    for base in (ROOT / b for b in bases):
        for path in sorted(base.rglob("*.py")):
            rel = path.relative_to(base).with_suffix("")
            parts = list(rel.parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            name = ".".join(parts)
            if name and not _API_SKIP.search(name) and "__pycache__" not in path.parts:
                mods.append(name)
    return sorted(set(mods))


def write_api_pages(out: Path, bases: tuple[str, ...] = ("toolkit", "plugins")) -> list[str]:
    """One Markdown page per module of :func:`api_modules` (``bases``) under ``out``; returns
    the names. The benchmarks (``bases=("benchmarks",)``) get a folder of their own, listed
    under their own heading: they are not the product's API."""
    out.mkdir(parents=True, exist_ok=True)
    mods = api_modules(bases)
    for stale in set(out.glob("*.md")) - {out / f"{m}.md" for m in mods}:
        stale.unlink()  # a module moved or renamed since the last build
    for mod in mods:
        _write_if_changed(out / f"{mod}.md", "\n".join([
            f"# `{mod}`", "", "```{eval-rst}", f".. automodule:: {mod}", "   :members:",
            "   :show-inheritance:", "```", ""]))
    return mods


# --------------------------------------------------------------------------------------------
# Notebooks
# --------------------------------------------------------------------------------------------


def _data_dir() -> Path:
    """``$PFTRACK_DATA``, else the ``shared/data`` beside the repository (as the tests set it)."""
    env = os.environ.get("PFTRACK_DATA")
    return Path(env) if env else ROOT.parent / "shared" / "data"


def execute_notebooks(out: Path, *, force: bool = False, log: Any = print) -> dict[str, float]:
    """Execute every notebook of :data:`NOTEBOOKS` into ``out`` (same name) with nbclient and
    the ``python3`` kernel, on its short slice; a notebook whose source and settings are
    unchanged since its last execution is kept (``force``: execute all again).

    Returns the seconds each executed notebook took.

    Raises
    ------
    RuntimeError
        A cell failed (the message names the notebook and the cell's error).
    FileNotFoundError
        A notebook of :data:`NOTEBOOKS` is missing from ``notebooks/``.
    """
    import nbclient
    import nbformat

    out.mkdir(parents=True, exist_ok=True)
    times: dict[str, float] = {}
    for name, (env, where) in NOTEBOOKS.items():
        src = ROOT / "notebooks" / name
        if not src.is_file():
            raise FileNotFoundError(f"docs: notebook {src} (listed in NOTEBOOKS) is missing")
        key = hashlib.sha256(src.read_bytes() + json.dumps(env, sort_keys=True).encode())
        stamp = out / f".{name}.sha256"
        dest = out / name
        if not force and dest.is_file() and stamp.is_file() and \
                stamp.read_text() == key.hexdigest():
            continue
        nb = nbformat.read(src, as_version=4)
        # the shared data as this process finds it (beside the repository): a kernel working in
        # a temporary folder would not find it from its own working directory
        env = {"PFTRACK_DATA": str(_data_dir()), **env}
        saved = {k: os.environ.get(k) for k in env}
        t0 = time.perf_counter()
        log(f"pftrack docs: executing notebooks/{name} {env or ''}")
        with tempfile.TemporaryDirectory(prefix="pftrack-docs-") as tmp:
            cwd = str(ROOT) if where == "root" else tmp
            os.environ.update(env)
            try:
                nbclient.NotebookClient(nb, kernel_name="python3", timeout=900,
                                        resources={"metadata": {"path": cwd}}).execute()
            except nbclient.exceptions.CellExecutionError as exc:
                raise RuntimeError(f"docs: notebooks/{name} failed: {exc}") from None
            finally:
                for k, v in saved.items():
                    if v is None:
                        os.environ.pop(k, None)
                    else:
                        os.environ[k] = v
        times[name] = time.perf_counter() - t0
        tmp_dest = dest.with_suffix(".ipynb.tmp")
        nbformat.write(nb, tmp_dest)
        os.replace(tmp_dest, dest)
        stamp.write_text(key.hexdigest())
    return times


def write_thumbnails(gallery: Path) -> dict[str, Path]:
    """The first picture each executed notebook of ``gallery`` shows, as
    ``gallery/_thumbs/NAME.png`` (a blank 1 x 1 picture for a notebook without one, e.g. an
    unexecuted copy); returns the files by notebook name."""
    import base64

    import nbformat

    blank = base64.b64decode("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAQAAAC1HAwCAAAAC0lEQVR42mP8/x8AAwMB"
                             "/6XKpQAAAABJRU5ErkJggg==")
    out: dict[str, Path] = {}
    for name in NOTEBOOKS:
        nb = nbformat.read(gallery / name, as_version=4)
        pngs = [o["data"]["image/png"] for c in nb.cells if c.cell_type == "code"
                for o in c.get("outputs", []) if "image/png" in o.get("data", {})]
        data = base64.b64decode(pngs[0]) if pngs else blank
        dest = gallery / "_thumbs" / name.replace(".ipynb", ".png")
        if not dest.is_file() or dest.read_bytes() != data:
            dest.parent.mkdir(parents=True, exist_ok=True)
            tmp = dest.with_suffix(".png.tmp")
            tmp.write_bytes(data)
            os.replace(tmp, dest)
        out[name] = dest
    return out


# --------------------------------------------------------------------------------------------
# Sphinx
# --------------------------------------------------------------------------------------------


def _write_if_changed(path: Path, text: str) -> None:
    """Write ``text`` unless the file already holds it (Sphinx then keeps its cached page)."""
    if not path.is_file() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(text)
        os.replace(tmp, path)


def _generate(app: Any) -> None:
    from sphinx.util import logging

    logger = logging.getLogger(__name__)
    gen = DOCS / "_generated"
    for part, text in split_config_reference(config_reference()).items():
        _write_if_changed(gen / f"config_{part}.md", text)
    from pftrack_results import results_page

    _write_if_changed(gen / "results.md", results_page())
    _write_if_changed(gen / "cli_reference.md", cli_reference())
    _write_if_changed(gen / "volumes_doc.md",
                      docstring_markdown("pftrack.geometry.volumes", "World frame conventions"))
    write_api_pages(DOCS / "api" / "_modules")
    write_api_pages(DOCS / "api" / "_benchmarks", bases=("benchmarks",))
    if os.environ.get("PFTRACK_DOCS_NOTEBOOKS", "1") == "0":
        for name in NOTEBOOKS:  # unexecuted copies: a quick build without pictures
            dest = DOCS / "gallery" / name
            if not dest.is_file():
                shutil.copyfile(ROOT / "notebooks" / name, dest)
        write_thumbnails(DOCS / "gallery")
        return
    times = execute_notebooks(DOCS / "gallery",
                              force=os.environ.get("PFTRACK_DOCS_REEXECUTE") == "1",
                              log=logger.info)
    for name, sec in times.items():
        logger.info(f"pftrack docs: {name} executed in {sec:.0f} s")
    write_thumbnails(DOCS / "gallery")


def setup(app: Any) -> dict[str, Any]:
    """Register the generation step with Sphinx."""
    app.connect("builder-inited", _generate)
    from pftrack_results import result_role

    app.add_role("result", result_role)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
