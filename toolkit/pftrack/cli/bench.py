"""``pftrack bench NAME``: benchmarks that measure and report (never timed tests).

A benchmark is a :class:`pftrack.contracts.extensions.Benchmark` that a plugin registered through
``pftrack_register_benchmarks``. pftrack itself ships none: the papers' benchmarks (``core``,
``colour``, ``pets09-ground``, ``soccer``, ...) are the repository's package ``pftrack_bench``
(``benchmarks/``, installed by ``./dev``), a plugin like any third party's. Its result dict is
printed as JSON with ``--json`` (and written atomically to ``--out``), otherwise as its
``format_table(result)`` text.
"""

from __future__ import annotations

import argparse
import json
import sys

from pftrack.cli import _args
from pftrack.contracts.extensions import Benchmark


def register(sub: argparse._SubParsersAction) -> None:
    from pftrack.host import get_host

    host = get_host()
    none = next(iter(host.registry.entries("benchmark")), None) is None
    p = sub.add_parser("bench", help="run a benchmark a plugin registered and report its figures",
                       description="no benchmark is registered: pftrack ships none; the "
                       "repository's benchmarks (benchmarks/, package pftrack_bench) are "
                       "installed by its ./dev" if none else None)
    bsub = p.add_subparsers(dest="bench", metavar="NAME")
    for entry in sorted(host.registry.entries("benchmark"), key=lambda e: e.name):
        bench: Benchmark = entry.obj
        bp = bsub.add_parser(entry.name, help=f"{bench.summary} [{entry.plugin}]")
        bp.add_argument("--json", action="store_true", help="print the result as JSON")
        bp.add_argument("--out", help="also write the JSON result to this file (atomically)")
        bench.add_arguments(bp)
        _args.name_seed_options(bp)
        bp.set_defaults(func=_make_handler(bench))
    p.set_defaults(func=lambda a: (p.print_help(), 2)[1])


def _make_handler(bench: Benchmark):
    def handler(args: argparse.Namespace) -> int:
        from pftrack.io.atomic import atomic_write_text

        result = bench.run(args)
        text = json.dumps(result, indent=2, default=float)
        if args.out:
            atomic_write_text(args.out, text + "\n")
        if args.json:
            print(text)
        else:
            print(bench.format_table(result) if bench.format_table else text)
        sys.stdout.flush()
        return 0

    return handler
