"""``pftrack presets``: the tracking configurations plugins ship (for ``pftrack run NAME``).

Lists each preset's name, the plugin that registered it, its file and its description; ``--json``
prints the same as JSON, ``--show NAME`` prints the preset's YAML.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("presets", help="list the tracking presets (pftrack run NAME)",
                       description="List the tracking configurations registered by plugins.")
    p.add_argument("--json", action="store_true", help="print as JSON")
    p.add_argument("--show", metavar="NAME", default=None, help="print one preset's YAML")
    p.set_defaults(func=handler)


def preset_listing() -> list[dict[str, str]]:
    """``[{"name", "plugin", "path", "description"}]`` for every registered preset."""
    import yaml

    from pftrack.host import get_host

    out = []
    for e in sorted(get_host().registry.entries("preset"), key=lambda e: e.name):
        try:
            cfg = yaml.safe_load(Path(e.obj).read_text()) or {}
            desc = " ".join(str(cfg.get("description", "")).split())
        except (OSError, yaml.YAMLError) as exc:
            desc = f"(unreadable: {exc})"
        out.append({"name": e.name, "plugin": e.plugin, "path": str(e.obj), "description": desc})
    return out


def handler(args: argparse.Namespace) -> int:
    from pftrack.host import get_host

    if args.show:
        path = get_host().get("preset", args.show)
        print(Path(path).read_text(), end="")
        return 0
    items = preset_listing()
    if args.json:
        print(json.dumps({"presets": items}, indent=2))
        return 0
    if not items:
        print("no presets registered")
        return 0
    width = max(len(i["name"]) for i in items)
    for i in items:
        print(f"{i['name']:<{width}}  [{i['plugin']}]  {i['description']}")
        print(f"{'':<{width}}  {i['path']}")
    return 0
