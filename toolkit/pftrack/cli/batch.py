"""``pftrack batch JOBS.yaml --out DIR``: many runs at once, on Dask.

JOBS lists ``pftrack run`` jobs (a configuration or preset, the video, camera, frames, seed,
ground truth), registered demos and benchmarks with their arguments, and matrices of them (seeds
x parameters x inputs); :mod:`pftrack.workflows.batch` describes the format. Each job writes into
``DIR/NAME`` atomically; ``DIR/summary.csv``, ``DIR/aggregates.csv`` and ``DIR/summary.json``
(one row per job: status, figures, time; mean and spread per group over seeds) are rewritten as
jobs finish. Without ``--scheduler`` a local Dask cluster of ``--workers`` processes (default:
the cores) starts and stops with the command; ``--workers 1`` runs serially without Dask.
Exit status 0 when every job succeeded, 1 when some failed, 2 for a bad JOBS file.
"""

from __future__ import annotations

import argparse
import sys

from pftrack.cli import _args


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "batch", help="run many jobs (runs, demos, benchmarks, seed sweeps) on Dask",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("jobs", metavar="JOBS", help="jobs file (YAML; see pftrack.workflows.batch)")
    p.add_argument("--out", required=True, metavar="DIR", help="batch output folder")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="a running Dask scheduler (tcp://HOST:8786): the jobs go to its "
                            "workers; DIR must be on a file system they share")
    where.add_argument("--workers", type=_args.positive_int, default=None, metavar="N",
                       help="worker processes of the local cluster (default: the cores); 1 runs "
                            "the jobs one after another without Dask")
    p.add_argument("--resume", action="store_true",
                   help="skip the jobs whose folder holds their complete result")
    p.add_argument("--retries", type=_args.non_negative_int, default=2,
                   help="Dask retries of a job whose worker failed (default 2)")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    from pftrack.workflows.batch import load_jobs, run_batch

    jobs = load_jobs(args.jobs)
    try:
        result = run_batch(jobs, args.out, scheduler=args.scheduler, workers=args.workers,
                           resume=args.resume, retries=args.retries, progress=not args.quiet)
    except ImportError as exc:
        print(f"pftrack batch: error: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        n_ok = sum(r["status"] == "ok" for r in result.rows)
        resumed = sum(bool(r.get("resumed")) for r in result.rows)
        print(f"{n_ok} of {len(result.rows)} jobs ok ({resumed} resumed), "
              f"{result.n_failed} failed; table: {result.files['summary.csv']}")
        for r in result.rows:
            if r["status"] != "ok":
                print(f"  {r['job']}: {r.get('error', r['status'])}")
        sys.stdout.flush()
    return 1 if result.n_failed else 0
