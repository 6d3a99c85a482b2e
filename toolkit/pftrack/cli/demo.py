"""``pftrack demo [NAME] --out DIR``: the first thing to run.

Runs a demo a plugin registered (:class:`pftrack.contracts.extensions.Demo`, hook
``pftrack_register_demos``). Without NAME, the default one: the built-in ``walkers`` demo of the
colour plugin (the colour paper: three synthetic walkers tracked with cross entropy + background
beside the paper's Bhattacharyya baseline; tracks, metrics and report pictures).
"""

from __future__ import annotations

import argparse

from pftrack.cli import _args
from pftrack.contracts.extensions import Demo


def _default(demos: dict[str, Demo]) -> str | None:
    marked = sorted(n for n, d in demos.items() if d.default)
    if marked:
        return marked[0]
    return sorted(demos)[0] if len(demos) == 1 else None


def register(subparsers: argparse._SubParsersAction) -> None:
    from pftrack.host import get_host

    host = get_host()
    demos: dict[str, Demo] = {e.name: e.obj for e in host.registry.entries("demo")}
    default = _default(demos)
    p = subparsers.add_parser("demo", help="run a demo end to end and write its report",
                              description=__doc__)
    dsub = p.add_subparsers(dest="demo", metavar="NAME")
    for name, demo in sorted(demos.items()):
        dp = dsub.add_parser(name, help=demo.summary + (" (default)" if name == default else ""))
        dp.add_argument("--out", required=True, help="output folder (created)")
        demo.add_arguments(dp)
        _args.name_seed_options(dp)
        dp.set_defaults(func=demo.run)
    if default is not None:
        # ``pftrack demo --out DIR [its options]`` runs the default demo
        p.add_argument("--out", help="output folder (created)")
        demos[default].add_arguments(p)
        _args.name_seed_options(p)
    p.set_defaults(func=_make_default_handler(demos, default))


def _make_default_handler(demos: dict[str, Demo], default: str | None):
    def handler(args: argparse.Namespace) -> int:
        if default is None:
            known = ", ".join(sorted(demos)) or "none"
            raise ValueError(f"no default demo is registered; name one (demos: {known})")
        if not getattr(args, "out", None):
            raise ValueError("--out DIR is required")
        return demos[default].run(args)

    return handler
