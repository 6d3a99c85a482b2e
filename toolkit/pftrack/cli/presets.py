"""``pftrack presets``: the tracking configurations plugins ship (for ``pftrack run NAME``).

Lists each preset's name, its state (``[world]``: ground-plane positions in metres, needs a
camera; ``[image]``: pixels, no camera), its description, and its file with the plugin that
registered it; ``--json`` prints the same as JSON, ``--show NAME`` prints the preset's YAML.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("presets", help="list the tracking presets (pftrack run NAME)",
                       description="List the tracking configurations registered by plugins: "
                                   "name, [state] ([world]: ground plane in metres, needs "
                                   "--camera; [image]: pixels, no camera), description, file "
                                   "and the plugin that registered it.")
    p.add_argument("--json", action="store_true", help="print as JSON")
    p.add_argument("--show", metavar="NAME", default=None, help="print one preset's YAML")
    p.set_defaults(func=handler)


def preset_listing() -> list[dict[str, str]]:
    """``[{"name", "plugin", "state", "path", "description"}]`` for every registered preset
    (``state``: the configuration's, ``world`` when it does not say, as
    :func:`pftrack.workflows.pipeline.load_config` reads it; ``?`` when the file cannot be read)."""
    import yaml

    from pftrack.host import get_host

    out = []
    for e in sorted(get_host().registry.entries("preset"), key=lambda e: e.name):
        try:
            cfg = yaml.safe_load(Path(e.obj).read_text()) or {}
            if not isinstance(cfg, dict):
                raise yaml.YAMLError(f"a {type(cfg).__name__}, not a mapping")
            desc = " ".join(str(cfg.get("description", "")).split())
            state = str(cfg.get("state", "world"))
        except (OSError, yaml.YAMLError) as exc:
            desc, state = f"(unreadable: {exc})", "?"
        out.append({"name": e.name, "plugin": e.plugin, "state": state, "path": str(e.obj),
                    "description": desc})
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
        print(f"{i['name']:<{width}}  [{i['state']}]  {i['description']}")
        print(f"{'':<{width}}  {i['path']} (plugin {i['plugin']})")
    return 0
