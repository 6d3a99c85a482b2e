"""``pftrack plugins``: list every plugin the host found, with its components by kind.

``pftrack plugins --params`` lists instead every registered component class that declares
parameters: its parameters counted (a parameter group counts once, and its members are
counted as leaves) and the shipped presets that use it, then the totals; with ``--json`` as
``{"components": [{"kind", "name", "plugin", "class", "parameters", "leaves", "names",
"presets"}, ...], "classes", "parameters", "leaves"}`` (:func:`parameter_inventory`).

``pftrack plugins --json`` prints ``{"plugins": [{"name", "version", "builtin", "source",
"components": {kind: [names]}, "hooks": [hook names], ["error"]}, ...]}`` (built-ins first):
:meth:`pftrack.host.Host.listing` plus the hooks each plugin implements.
:func:`pftrack.host.list_plugins` gives the same list in a notebook. ``PFTRACK_DISABLE_PLUGINS``
and ``PFTRACK_DISABLE_PLUGIN_AUTOLOAD`` apply as everywhere.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from typing import Any

_KIND_ORDER = ("detector", "likelihood", "motion", "associator", "scene", "observation", "tracks",
               "preset", "metric",
               "benchmark", "command", "demo", "report")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("plugins", help="list plugins and their components",
                       description=__doc__.strip().splitlines()[0])
    p.add_argument("--json", action="store_true", help="print the listing as JSON")
    p.add_argument("--params", action="store_true",
                   help="list the components' parameters: how many each declares and which "
                        "presets use it, with the totals")
    p.set_defaults(func=handler)


def format_listing(listing: dict[str, Any]) -> str:
    """Human-readable text of a :meth:`~pftrack.host.Host.listing`."""
    lines = []
    plugins = listing["plugins"]
    if not plugins:
        return "no plugins loaded"
    for p in plugins:
        origin = "built-in" if p["builtin"] else "third-party"
        lines.append(f"{p['name']} {p['version']} ({origin}; {p['source']})")
        comps = p.get("components", {})
        kinds = [k for k in _KIND_ORDER if k in comps] + sorted(set(comps) - set(_KIND_ORDER))
        for k in kinds:
            lines.append(f"  {k + ':':12s} {', '.join(comps[k])}")
        if not comps:
            lines.append("  (no components)")
        if p.get("hooks"):
            lines.append(f"  {'hooks:':12s} {', '.join(p['hooks'])}")
        if p.get("error"):
            lines.append(f"  ERROR: {p['error']}")
    return "\n".join(lines)


def _preset_types(config: Any, out: set[str]) -> set[str]:
    """Every component name (a mapping's ``type``) anywhere in a configuration."""
    if isinstance(config, dict):
        if isinstance(config.get("type"), str):
            out.add(config["type"])
        for v in config.values():
            _preset_types(v, out)
    elif isinstance(config, list):
        for v in config:
            _preset_types(v, out)
    return out


def parameter_inventory(host: Any) -> dict[str, Any]:
    """The parameters every registered component class declares, and the presets that use it.

    One entry per class (a class registered under two names is counted once, under its first
    name), classes declaring no parameter left out. ``parameters``: the class's declared
    parameters, a :class:`~pftrack.contracts.components.Group` counting as one; ``leaves``:
    a group counted as its members instead. ``presets``: the presets the host knows whose
    configuration names the component (as ``type`` anywhere in it). Sorted by kind, then
    parameters, most first.
    """
    from pftrack.contracts.components import Group
    from pftrack.workflows.pipeline import load_config

    used: dict[str, set[str]] = {}
    for name in host.names("preset"):
        for t in _preset_types(load_config(name), set()):
            used.setdefault(t, set()).add(name)
    rows: list[dict[str, Any]] = []
    seen: set[int] = set()
    for e in host.registry.entries():
        cls = e.obj
        declared = getattr(cls, "declared_params", None)
        if not isinstance(cls, type) or id(cls) in seen or declared is None:
            continue
        params = declared()
        if not params:
            continue
        seen.add(id(cls))
        leaves = sum(len(p.group.declared_params()) if isinstance(p, Group) else 1
                     for p in params.values())
        rows.append({"kind": e.kind, "name": e.name, "plugin": e.plugin,
                     "class": f"{cls.__module__}.{cls.__qualname__}",
                     "parameters": len(params), "leaves": leaves, "names": list(params),
                     "presets": sorted(used.get(e.name, ()))})
    order = {k: i for i, k in enumerate(_KIND_ORDER)}
    rows.sort(key=lambda r: (order.get(r["kind"], len(order)), r["kind"], -r["parameters"],
                             r["name"]))
    return {"components": rows, "classes": len(rows),
            "parameters": sum(r["parameters"] for r in rows),
            "leaves": sum(r["leaves"] for r in rows)}


def format_inventory(inv: dict[str, Any]) -> str:
    """Human-readable text of :func:`parameter_inventory`."""
    lines = [f"{'kind':12s} {'component':24s} {'params':>6s} {'leaves':>6s}  presets"]
    for r in inv["components"]:
        lines.append(f"{r['kind']:12s} {r['name']:24s} {r['parameters']:6d} {r['leaves']:6d}  "
                     f"{', '.join(r['presets']) or '-'}")
    lines.append(f"{inv['classes']} component classes, {inv['parameters']} parameters "
                 f"({inv['leaves']} counting each group's members)")
    return "\n".join(lines)


def plugin_hooks(host: Any, name: str) -> list[str]:
    """Names of the hooks plugin ``name`` implements (empty when it failed to load)."""
    obj = host.pm.get_plugin(name)
    if obj is None:
        return []
    return sorted(hc.name for hc in host.pm.get_hookcallers(obj) or [])


def handler(args: argparse.Namespace) -> int:
    from pftrack.host import PluginLoadWarning, get_host

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PluginLoadWarning)
        host = get_host()
    for w in caught:  # a broken plugin is listed with its error; say so on stderr as well
        if issubclass(w.category, PluginLoadWarning):
            print(f"pftrack plugins: warning: {w.message}", file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if args.params:
        inv = parameter_inventory(host)
        print(json.dumps(inv, indent=2) if args.json else format_inventory(inv))
        return 0
    listing = host.listing()
    for p in listing["plugins"]:
        p["hooks"] = plugin_hooks(host, p["name"])
    if args.json:
        print(json.dumps(listing, indent=2))
    else:
        print(format_listing(listing))
    return 0
