"""Batch runs on Dask: 8 PETS slices (pets09-ground), serial against a 2-worker local cluster.

``pftrack bench batch --json`` trains the detector once (or takes ``--model``), writes the
``--jobs`` slices of ``--frames-per-job`` frames (default 8 x 50, frames 396-795, ground-truth
numbering) to a jobs file and runs them, in each round:

* ``serial_s``: the command ``pftrack batch JOBS --workers 1`` (the jobs one after another in
  one new process), timed from outside: interpreter start, imports, compilation, the jobs;
* ``parallel_s``: the command ``pftrack batch JOBS --workers 2``, timed the same way: the same,
  plus starting and stopping a ``LocalCluster`` whose workers import pftrack and compile their
  kernels during their first job;
* ``speedup``: ``serial_s / parallel_s``: what a user gains by giving the command two workers;
  both sides pay the same start-up costs once per process they start;
* ``in_process_serial_s``, ``in_process_parallel_s``, ``in_process_speedup``: the figures as
  in-process variant: :func:`pftrack.workflows.batch.run_batch` called in this process, serially
  after one untimed 5-frame job (so imports and compilation are *not* counted on the serial
  side), and on a ``LocalCluster`` started for the batch (where the workers' imports and
  compilation *are* counted). The asymmetry holds this speed-up 1-3 % below the command's;
* ``overhead_per_job_s``: ``(in_process_parallel_s - max over workers of the summed in-job wall
  time of the jobs it ran) / jobs``: the time of the parallel run that no job accounts for on
  the busiest worker (cluster start and stop, scheduling, moving results, the summary table),
  per job;
* ``warm_parallel_s``, ``warm_speedup``, ``warm_overhead_per_job_s``: the same jobs again on the
  cluster already running (the workers warm), from submission to the last result, against
  ``in_process_serial_s`` (both warm);
* ``serial_job_cpu_s_mean``, ``parallel_job_cpu_s_mean``: a job's CPU time (its process's) in
  the in-process serial run and on the cold cluster, and ``parallel_cpu_share``: the parallel
  jobs' CPU seconds over ``in_process_parallel_s x workers``. On an idle machine the share is
  near 1 and a job costs as much CPU in either run; a share far below 1 means the workers waited
  for cores others were using, and the speed-up says more about the machine than about the
  engine;
* ``identical_to_serial``: every job's tracks (its MOT rows as float64, SHA-256) are the same
  bits in all five runs of every round.

Timing is wall time. ``--repeats`` rounds (default 3) each run the five one after another, so
that all meet the same load; the figures are those of the round of median speed-up, and
``rounds`` keeps every round's (with its 1-minute load average). On a machine others share the
figures are only as good as the machine was quiet: ``parallel_cpu_share`` and ``loadavg_*`` say
how quiet it was.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from pftrack_bench.protocol import Protocol

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="PETS 2009 S2.L1, the pets09-ground preset in 8 slices of 50 frames",
    chosen_on="nothing is tuned: the same jobs serially and on a 2-worker local "
              "Dask cluster",
    reported_on="frames 396-795; wall times on a shared machine, with its load",
)


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


def _command(jobs_file: Path, out: Path, workers: int) -> tuple[float, list[dict[str, Any]]]:
    """Run ``pftrack batch JOBS --out OUT --workers N`` in a new process; its wall time (from
    outside) and its jobs' rows (read from each job's ``job.json``)."""
    cmd = [sys.executable, "-m", "pftrack", "batch", str(jobs_file), "--out", str(out),
           "--workers", str(workers), "--quiet"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited with {proc.returncode}: "
                           f"{proc.stderr.strip()[-2000:]}")
    rows = [json.loads(f.read_text())["row"] for f in sorted(out.glob("*/job.json"))]
    return wall, rows


def _round(jobs: list[Any], jobs_file: Path, tmp: Any, args: argparse.Namespace, log: Any
           ) -> dict[str, Any]:
    """The two commands (serial, then parallel), then the in-process serial run and one cold and
    one warm run on a fresh local cluster."""
    from pftrack.workflows.batch import local_cluster, require_dask, run_batch

    distributed = require_dask()
    n = len(jobs)
    log(f"batch: {n} jobs of {args.frames_per_job} frames, the command with --workers 1 ...")
    cmd_serial_s, cmd_serial_rows = _command(jobs_file, tmp / "cmd-serial", 1)
    log(f"batch: the command with --workers {args.workers} ...")
    cmd_par_s, cmd_par_rows = _command(jobs_file, tmp / "cmd-parallel", args.workers)
    log(f"batch: {n} jobs in this process, serial ...")
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
        "serial_s": cmd_serial_s, "parallel_s": cmd_par_s, "speedup": cmd_serial_s / cmd_par_s,
        "overhead_per_job_s": (parallel_s - _busiest_worker_s(par.rows)) / n,
        "in_process_serial_s": serial_s, "in_process_parallel_s": parallel_s,
        "in_process_speedup": serial_s / parallel_s,
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
    return {"figures": figures,
            "rows": (serial.rows, par.rows, warm.rows, cmd_serial_rows, cmd_par_rows)}


def run(args: argparse.Namespace) -> dict[str, Any]:
    import tempfile

    import yaml
    from pftrack.io.data import pets09_files
    from pftrack.workflows.batch import cpu_count, parse_jobs, require_dask, run_batch
    from pftrack.workflows.pipeline import load_config, train_detector

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
        if len(jobs) != len(frames):
            raise RuntimeError(f"{len(jobs)} jobs from {len(frames)} slices")
        jobs_doc = {"jobs": [{**entry, "matrix": {"frames": frames}}]}
        jobs_file = tmp / "jobs.yaml"
        jobs_file.write_text(yaml.safe_dump(jobs_doc, sort_keys=False))
        warmup = parse_jobs({"jobs": [{**entry, "name": "warmup",
                                       "frames": f"{args.first}:{args.first + 4}"}]})
        load_before = os.getloadavg()
        run_batch(warmup, tmp / "warmup", workers=1, progress=False)
        rounds = [_round(jobs, jobs_file, tmp / f"round{i}", args, log)
                  for i in range(args.repeats)]
        load_after = os.getloadavg()
    failed = [r["job"] for rd in rounds for rows in rd["rows"] for r in rows
              if r["status"] != "ok"]
    counts = {len(rows) for rd in rounds for rows in rd["rows"]}
    if failed:
        raise RuntimeError(f"jobs failed: {failed}")
    if counts != {args.jobs}:
        raise RuntimeError(f"a run returned {sorted(counts)} rows for {args.jobs} jobs")
    digests = {tuple(r["tracks_sha256"] for r in sorted(rows, key=lambda r: r["job"]))
               for rd in rounds for rows in rd["rows"]}
    n = len(jobs)
    # the round of median speed-up stands for the run; every round's figures are kept
    figures = [rd["figures"] for rd in rounds]
    mid = sorted(figures, key=lambda f: f["speedup"])[len(figures) // 2]
    serial_rows = rounds[0]["rows"][0]
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
                 + ", ".join(f"{r['speedup']:.2f} (in process {r['in_process_speedup']:.2f}, "
                             f"warm {r['warm_speedup']:.2f}, load "
                             f"{r['loadavg_1min']:.1f})" for r in result["rounds"]))
    for k in ("serial_s", "parallel_s", "speedup", "overhead_per_job_s", "in_process_serial_s",
              "in_process_parallel_s", "in_process_speedup", "cluster_start_s",
              "warm_parallel_s", "warm_speedup", "warm_overhead_per_job_s",
              "serial_job_s_mean", "parallel_job_s_mean", "serial_job_cpu_s_mean",
              "parallel_job_cpu_s_mean", "parallel_cpu_share"):
        lines.append(f"  {k:<26} {result[k]:.3f}")
    lines.append(f"  {'identical_to_serial':<26} {result['identical_to_serial']}")
    lines.append("  goals: " + ", ".join(f"{k} {v['goal']}: {'met' if v['met'] else 'NOT met'}"
                                         for k, v in result["goals"].items()))
    return "\n".join(lines)
