"""``pftrack plugins``: list every plugin the host found, with its components by kind.

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
    listing = host.listing()
    for p in listing["plugins"]:
        p["hooks"] = plugin_hooks(host, p["name"])
    if args.json:
        print(json.dumps(listing, indent=2))
    else:
        print(format_listing(listing))
    return 0
