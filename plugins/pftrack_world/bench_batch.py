"""Batch runs on Dask: 8 PETS slices (pets09-ground), serial against a 2-worker local cluster.

``pftrack bench batch --json`` trains the detector once (or takes ``--model``), then runs the same
``--jobs`` slices of ``--frames-per-job`` frames (default 8 x 50, frames 396-795, ground-truth
numbering) through :func:`pftrack.batch.run_batch` twice:

* ``serial_s``: ``workers=1``, the jobs one after another in this process (after one untimed
  5-frame job, so that imports and compilation are not counted against the serial run);
* ``parallel_s``: what ``pftrack batch --workers 2`` costs: start a ``LocalCluster`` of
  ``--workers`` processes (:func:`pftrack.batch.local_cluster`), run the jobs, stop the
  cluster (the workers import pftrack and compile their kernels during their first job: that is
  part of it);
* ``speedup``: ``serial_s / parallel_s``;
* ``overhead_per_job_s``: ``(parallel_s - max over workers of the summed in-job wall time of
  the jobs it ran) / jobs``: the time of the parallel run that no job accounts for on the busiest
  worker (cluster start and stop, scheduling, moving results, the summary table), per job;
* ``warm_parallel_s``, ``warm_speedup``, ``warm_overhead_per_job_s``: the same jobs again on the
  cluster already running (the workers warm), from submission to the last result;
* ``serial_job_cpu_s_mean``, ``parallel_job_cpu_s_mean``: a job's CPU time (its process's),
  and ``parallel_cpu_share``: the parallel jobs' CPU seconds over ``parallel_s x workers``. On an
  idle machine the share is near 1 and a job costs as much CPU in either run; a share far below
  1 means the workers waited for cores others were using, and the speed-up says more about the
  machine than about the engine;
* ``identical_to_serial``: every job's tracks (its MOT rows as float64, SHA-256) are the same
  bits in the three runs.

Timing is wall time. ``--repeats`` rounds (default 3) each run serial, cold cluster and warm
cluster one after another, so that both meet the same load; the figures are those of the round of
median speed-up, and ``rounds`` keeps every round's (with its 1-minute load average). On a machine
others share the figures are only as good as the machine was quiet: ``parallel_cpu_share`` and
``loadavg_*`` say how quiet it was.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Any

GOALS = {"speedup": (">=", 1.8), "overhead_per_job_s": ("<", 0.5)}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--preset", default="pets09-ground",
                        help="configuration: preset name or YAML (default pets09-ground)")
    parser.add_argument("--data", default=None,
                        help="folder holding pets09/ (default: $PFTRACK_DATA or ../shared/data)")
    parser.add_argument("--jobs", type=int, default=8, help="PETS slices (default 8)")
    parser.add_argument("--frames-per-job", type=int, default=50,
                        help="frames per slice (default 50)")
    parser.add_argument("--first", type=int, default=396,
                        help="first frame of the first slice (default 396: 8 x 50 end at 795)")
    parser.add_argument("--workers", type=int, default=2,
                        help="local cluster worker processes (default 2)")
    parser.add_argument("--model", default=None,
                        help="detector model (default: train one on the preset's frames)")
    parser.add_argument("--seed", type=int, default=0, help="tracking seed (default 0)")
    parser.add_argument("--repeats", type=int, default=3,
                        help="rounds of serial, cold-cluster and warm-cluster runs, alternated "
                             "so that both meet the same load; the round of median speed-up is "
                             "reported (default 3)")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


def _busiest_worker_s(rows: list[dict[str, Any]]) -> float:
    per: dict[str, float] = {}
    for r in rows:
        per[r["worker"]] = per.get(r["worker"], 0.0) + float(r["time_s"])
    return max(per.values())


def _round(jobs: list[Any], tmp: Any, args: argparse.Namespace, log: Any) -> dict[str, Any]:
    """One serial run, then one cold and one warm run on a fresh local cluster."""
    from pftrack.batch import local_cluster, require_dask, run_batch

    distributed = require_dask()
    n = len(jobs)
    log(f"batch: {n} jobs of {args.frames_per_job} frames, serial ...")
    t0 = time.perf_counter()
    serial = run_batch(jobs, tmp / "serial", workers=1, progress=not args.quiet)
    serial_s = time.perf_counter() - t0
    log(f"batch: the same on a local cluster of {args.workers} workers ...")
    t0 = time.perf_counter()
    with local_cluster(args.workers) as cluster, distributed.Client(cluster) as client:
        start_s = time.perf_counter() - t0
        par = run_batch(jobs, tmp / "parallel", client=client, progress=not args.quiet)
        t_jobs = time.perf_counter()
        log("batch: again on the warm cluster ...")
        warm = run_batch(jobs, tmp / "warm", client=client, progress=not args.quiet)
        warm_s = time.perf_counter() - t_jobs
        t_close = time.perf_counter()
    # the cold run as the command runs it: start, jobs, stop (the warm run left out)
    parallel_s = (t_jobs - t0) + (time.perf_counter() - t_close)
    figures = {
        "serial_s": serial_s, "parallel_s": parallel_s, "speedup": serial_s / parallel_s,
        "overhead_per_job_s": (parallel_s - _busiest_worker_s(par.rows)) / n,
        "cluster_start_s": start_s,
        "warm_parallel_s": warm_s, "warm_speedup": serial_s / warm_s,
        "warm_overhead_per_job_s": (warm_s - _busiest_worker_s(warm.rows)) / n,
        "serial_job_s_mean": sum(r["time_s"] for r in serial.rows) / n,
        "parallel_job_s_mean": sum(r["time_s"] for r in par.rows) / n,
        "serial_job_cpu_s_mean": sum(r["cpu_s"] for r in serial.rows) / n,
        "parallel_job_cpu_s_mean": sum(r["cpu_s"] for r in par.rows) / n,
        "parallel_cpu_share": sum(r["cpu_s"] for r in par.rows) / (parallel_s * args.workers),
        "loadavg_1min": os.getloadavg()[0],
    }
    return {"figures": figures, "batches": (serial, par, warm)}


def run(args: argparse.Namespace) -> dict[str, Any]:
    import tempfile
    from pathlib import Path

    from pftrack.batch import cpu_count, parse_jobs, require_dask, run_batch
    from pftrack.data import pets09_files
    from pftrack.pipeline import load_config, train_detector

    if args.jobs < 1 or args.frames_per_job < 1 or args.workers < 2 or args.repeats < 1:
        raise ValueError("--jobs, --frames-per-job and --repeats must be >= 1, --workers >= 2")
    video, gt, cam = pets09_files(args.data)
    require_dask()  # before training: say what to install at once
    log = (lambda *a: None) if args.quiet else (lambda *a: print(*a, file=sys.stderr,
                                                                  flush=True))
    cfg = load_config(args.preset)
    starts = [args.first + i * args.frames_per_job for i in range(args.jobs)]
    frames = [f"{a}:{a + args.frames_per_job - 1}" for a in starts]
    with tempfile.TemporaryDirectory(prefix="pftrack-bench-batch-") as tmp_s:
        tmp = Path(tmp_s)
        model = args.model
        if model is None:
            train = (cfg.get("detector") or {}).get("train") or {}
            model = str(tmp / "svm.npz")
            log(f"batch: training the detector on frames {train.get('frames', '1:400')} ...")
            train_detector(video, gt, train.get("frames", "1:400"), out=model, cfg=cfg,
                           seed=int(train.get("seed", 0)))
        entry = {"name": "pets", "config": args.preset, "video": str(video),
                 "camera": str(cam), "gt": str(gt), "detector_model": str(model),
                 "seed": args.seed}
        jobs = parse_jobs({"jobs": [{**entry, "matrix": {"frames": frames}}]})
        warmup = parse_jobs({"jobs": [{**entry, "name": "warmup",
                                       "frames": f"{args.first}:{args.first + 4}"}]})
        load_before = os.getloadavg()
        run_batch(warmup, tmp / "warmup", workers=1, progress=False)
        rounds = [_round(jobs, tmp / f"round{i}", args, log) for i in range(args.repeats)]
        load_after = os.getloadavg()
    failed = [r["job"] for rd in rounds for b in rd["batches"] for r in b.rows
              if r["status"] != "ok"]
    if failed:
        raise RuntimeError(f"jobs failed: {failed}")
    digests = {tuple(r["tracks_sha256"] for r in b.rows) for rd in rounds for b in rd["batches"]}
    n = len(jobs)
    # the round of median speed-up stands for the run; every round's figures are kept
    figures = [rd["figures"] for rd in rounds]
    mid = sorted(figures, key=lambda f: f["speedup"])[len(figures) // 2]
    serial_rows = rounds[0]["batches"][0].rows
    result: dict[str, Any] = {
        "jobs": n, "workers": args.workers, **mid,
        "identical_to_serial": len(digests) == 1,
        "rounds": figures, "repeats": args.repeats,
        "frames": frames, "preset": cfg.get("name", args.preset),
        "MOTA_mean": sum(r["MOTA"] for r in serial_rows) / n,
        "cpus": cpu_count(),
        "loadavg_before": list(load_before), "loadavg_after": list(load_after),
    }
    result["goals"] = {k: {"goal": f"{op} {v}", "value": result[k],
                           "met": bool(result[k] >= v if op == ">=" else result[k] < v)}
                       for k, (op, v) in GOALS.items()}
    return result


def format_table(result: dict[str, Any]) -> str:
    head = (f"{result['jobs']} PETS slices ({result['frames'][0]} .. {result['frames'][-1]}, "
            f"{result['preset']}), serial vs {result['workers']} local workers; "
            f"{result['cpus']} CPUs, load {result['loadavg_before'][0]:.2f} -> "
            f"{result['loadavg_after'][0]:.2f}")
    lines = [head]
    lines.append(f"  round of median speed-up of {result['repeats']}; speed-ups of all rounds: "
                 + ", ".join(f"{r['speedup']:.2f} (warm {r['warm_speedup']:.2f}, load "
                             f"{r['loadavg_1min']:.1f})" for r in result["rounds"]))
    for k in ("serial_s", "parallel_s", "speedup", "overhead_per_job_s", "cluster_start_s",
              "warm_parallel_s", "warm_speedup", "warm_overhead_per_job_s",
              "serial_job_s_mean", "parallel_job_s_mean", "serial_job_cpu_s_mean",
              "parallel_job_cpu_s_mean", "parallel_cpu_share"):
        lines.append(f"  {k:<26} {result[k]:.3f}")
    lines.append(f"  {'identical_to_serial':<26} {result['identical_to_serial']}")
    lines.append("  goals: " + ", ".join(f"{k} {v['goal']}: {'met' if v['met'] else 'NOT met'}"
                                         for k, v in result["goals"].items()))
    return "\n".join(lines)
