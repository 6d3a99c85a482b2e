"""``pftrack bench NAME``: benchmarks that measure and report (never timed tests).

A benchmark is a module ``pftrack.bench.<name>`` (dashes in NAME become underscores) with
``add_arguments(parser)`` and ``run(args) -> dict``; the dict is printed as JSON with ``--json``
(and written atomically to ``--out``), otherwise as the module's ``format_table(result)`` text.
"""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
import sys


def _bench_modules() -> dict[str, str]:
    import pftrack.bench as pkg

    return {m.name.replace("_", "-"): f"pftrack.bench.{m.name}"
            for m in pkgutil.iter_modules(pkg.__path__) if not m.name.startswith("_")}


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="run a benchmark and report its figures")
    bsub = p.add_subparsers(dest="bench", metavar="NAME")
    for name, modname in sorted(_bench_modules().items()):
        module = importlib.import_module(modname)
        bp = bsub.add_parser(name, help=(module.__doc__ or "").strip().splitlines()[0])
        bp.add_argument("--json", action="store_true", help="print the result as JSON")
        bp.add_argument("--out", help="also write the JSON result to this file (atomically)")
        module.add_arguments(bp)
        bp.set_defaults(func=_make_handler(module))
    p.set_defaults(func=lambda a: (p.print_help(), 2)[1])


def _make_handler(module):
    def handler(args: argparse.Namespace) -> int:
        from pftrack.io.atomic import atomic_write_text

        result = module.run(args)
        text = json.dumps(result, indent=2, default=float)
        if args.out:
            atomic_write_text(args.out, text + "\n")
        if args.json:
            print(text)
        else:
            fmt = getattr(module, "format_table", None)
            print(fmt(result) if fmt else text)
        sys.stdout.flush()
        return 0

    return handler
