"""Many runs at once: a batch of jobs on Dask (a local cluster by default, a cluster by address).

A batch is a list of jobs, read from a YAML file (:func:`load_jobs`) or built in Python
(:class:`Job`), run by :func:`run_batch` and summarised in a table. Three kinds of job:

``run``
    What ``pftrack run`` does: ``config`` (a YAML file or a preset name), ``video``, and
    optionally ``camera``, ``gt``, ``frames``, ``seed``, ``detector_model``, ``set`` (parameter
    overrides by dotted path, ``{tracker.n_particles: 100}``) and ``report`` (draw the report
    pictures; default false).
``demo``
    A registered demo (``demo: walkers``) with its command-line ``args``; ``seed``, when given,
    is passed as ``--seed N``.
``bench``
    A registered benchmark (``bench: core``) with its ``args``; its result dict is written to
    ``result.json``; ``seed`` as for a demo.

A JOBS file::

    defaults:                      # optional: fields every job of a kind taking them inherits
      video: ../shared/data/pets09/vtest.avi
    jobs:
      - name: pets                 # the job's folder under --out (letters, digits, . _ - =);
                                   # optional ``group``: the aggregates' group (default: name)
        config: pets09-ground
        camera: ../shared/data/pets09/View_001.xml
        gt: ../shared/data/pets09/gt.txt
        detector_model: svm.npz
        matrix:                    # expands to the product: here 3 x 2 = 6 jobs
          seed: [0, 1, 2]
          frames: ["401:450", "451:500"]
      - name: walkers
        demo: walkers
        args: [--frames, "60", --no-baseline]
        matrix: {seed: [0, 1, 2]}

Relative paths (``video``, ``camera``, ``gt``, ``detector_model``, a ``config`` file) are read
from the JOBS file's folder. A matrix job ``pets`` with ``seed: 1`` and ``frames: "401:450"`` is
named ``pets-seed1-frames401_450``; jobs that differ only by seed form a *group*, and the table's
aggregates give each figure's mean and standard deviation over a group's seeds.

Each job runs in a temporary folder ``DIR/.tmp-NAME-...`` which is renamed to ``DIR/NAME`` when
the job succeeded, so a job folder is either complete or absent; a job whose folder holds a
``job.json`` of the same job is complete (``resume``), and a job run a second time (a worker died
after its rename, before it could report) keeps the first folder rather than writing twice.
``DIR/summary.csv``, ``DIR/aggregates.csv`` and ``DIR/summary.json`` are rewritten atomically as
jobs finish. A job that raises is a ``failed`` row with its error; the other jobs go on.

Every job runs with one OpenCV and one BLAS thread, so a job's results are the same bits
whichever process runs it, serial or on any worker (``tracks_sha256`` in the table: for a run
job the SHA-256 of its MOT rows as float64, for a demo the SHA-256 of its ``tracks*`` files).
Dask (``pip install pftrack[dask]``) is needed for more than one worker; ``workers=1`` without
a client runs the jobs one after another in this process, without Dask.

:class:`Job` and the reading of a JOBS file are in :mod:`pftrack.workflows.jobs` (and import
from here as well); this module runs the jobs and writes the table.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import math
import os
import shutil
import socket
import sys
import time
import traceback
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from pftrack.workflows.jobs import (  # noqa: F401 (the fields of a job: public here as well)
    COMMON_FIELDS,
    KINDS,
    PATH_FIELDS,
    RUN_FIELDS,
    TOOL_FIELDS,
    Job,
    expand_matrix,
    load_jobs,
    parse_jobs,
)

__all__ = [
    "DASK_MISSING",
    "BatchResult",
    "Job",
    "aggregate_rows",
    "cpu_count",
    "execute_job",
    "expand_matrix",
    "load_jobs",
    "local_cluster",
    "parse_jobs",
    "require_dask",
    "run_batch",
]

DASK_MISSING = ("Dask is not installed: pip install 'pftrack[dask]' (or 'dask[distributed]'); "
                "--workers 1 runs the jobs one after another without it")

#: the figures of a run job's metrics copied into the table (when ground truth is given)
RUN_FIGURES = ("MOTA", "IDF1", "HOTA", "IDSW", "FP", "FN", "median_error_m", "p90_error_m",
               "accuracy_5px")
TIMING_FIGURES = ("frames_per_second", "tracking_s_per_frame", "detection_s_per_frame")
ROW_FIRST = ("job", "group", "kind", "seed", "status", "time_s", "cpu_s", "worker", "resumed",
             "error")


@dataclass
class BatchResult:
    """What :func:`run_batch` produced: one row per job (in the jobs' order), the aggregates
    per group, and the summary files written."""

    rows: list[dict[str, Any]]
    aggregates: list[dict[str, Any]]
    out_dir: Path
    files: dict[str, Path] = field(default_factory=dict)

    @property
    def n_failed(self) -> int:
        return sum(r["status"] != "ok" for r in self.rows)

    def row(self, name: str) -> dict[str, Any]:
        """The row of job ``name`` (KeyError naming it when there is none)."""
        for r in self.rows:
            if r["job"] == name:
                return r
        raise KeyError(f"no job named {name!r} in this batch")


# --------------------------------------------------------------------------------------------
# One job
# --------------------------------------------------------------------------------------------


def _set_dotted(cfg: dict[str, Any], path: str, value: Any, label: str) -> None:
    keys = str(path).split(".")
    node = cfg
    for k in keys[:-1]:
        nxt = node.get(k)
        if nxt is None:
            nxt = node[k] = {}
        if not isinstance(nxt, dict):
            raise ValueError(  # noqa: TRY004
                f"{label}: field 'set': {path!r}: {k!r} is not a mapping")
        node = nxt
    node[keys[-1]] = value


def _tool_args(job: Job) -> Any:
    """The argparse namespace of a demo/bench job (its parser as the command line builds it)."""
    import argparse

    from pftrack.host import UnknownComponentError, get_host

    kind = job.kind
    try:
        tool = get_host().get("benchmark" if kind == "bench" else kind, job.spec[kind])
    except UnknownComponentError as exc:
        raise ValueError(f"job {job.name!r}: field {kind!r}: {exc}") from None
    parser = argparse.ArgumentParser(prog=f"pftrack {kind} {job.spec[kind]}", add_help=False,
                                     exit_on_error=False)
    if kind == "demo":
        parser.add_argument("--out")
    tool.add_arguments(parser)
    args = list(job.spec["args"])
    if job.seed is not None:
        args += ["--seed", str(job.seed)]
    try:
        ns, extra = parser.parse_known_args(args)
    except (argparse.ArgumentError, SystemExit) as exc:
        raise ValueError(f"job {job.name!r}: field 'args': {exc}") from None
    if extra:
        raise ValueError(f"job {job.name!r}: field 'args': unknown arguments {extra} for "
                         f"{kind} {job.spec[kind]!r}")
    return tool, ns


def _flat_numbers(d: Any, prefix: str = "") -> dict[str, float | int]:
    out: dict[str, float | int] = {}
    if isinstance(d, dict):
        for k, v in d.items():
            out.update(_flat_numbers(v, f"{prefix}{k}."))
    elif isinstance(d, bool):
        pass
    elif isinstance(d, (int, float)):
        out[prefix[:-1]] = d
    return out


def _files_digest(folder: Path, pattern: str) -> str | None:
    files = sorted(folder.rglob(pattern))
    if not files:
        return None
    h = hashlib.sha256()
    for p in files:
        h.update(str(p.relative_to(folder)).encode() + b"\0" + p.read_bytes())
    return h.hexdigest()


def _run_job(job: Job, tmp: Path) -> dict[str, Any]:
    """Run ``job`` into ``tmp``; return its figures."""
    import numpy as np

    if job.kind == "run":
        from pftrack.workflows.pipeline import load_config, run_pipeline

        s = job.spec
        label = f"job {job.name!r}"
        cfg = copy.deepcopy(load_config(s["config"]))
        for path, value in (s.get("set") or {}).items():
            _set_dotted(cfg, path, value, label)
        cfg = load_config(cfg)  # the overrides checked as a configuration is
        result = run_pipeline(cfg, video=s["video"], camera=s.get("camera"), out_dir=tmp,
                              gt=s.get("gt"), frames=s.get("frames"),
                              detector_model=s.get("detector_model"), seed=int(s["seed"]),
                              progress=False, report=bool(s.get("report")))
        rows = np.ascontiguousarray(result.rows, dtype=np.float64)
        figures: dict[str, Any] = {
            "frames": result.n_frames, "rows": len(rows),
            "ids": len(set(rows[:, 1].astype(int))) if len(rows) else 0,
            "tracks_sha256": hashlib.sha256(rows.tobytes()).hexdigest()}
        figures.update({k: result.timing[k] for k in TIMING_FIGURES if k in result.timing})
        if result.metrics is not None:
            figures.update({k: result.metrics[k] for k in RUN_FIGURES if k in result.metrics})
        return figures
    tool, ns = _tool_args(job)
    if job.kind == "demo":
        ns.out = str(tmp)
        status = tool.run(ns)
        if status:
            raise RuntimeError(f"demo {job.spec['demo']!r} exited with status {status}")
        figures = {}
        metrics = tmp / "metrics.json"
        if metrics.is_file():
            figures.update(_flat_numbers(json.loads(metrics.read_text())))
        figures["tracks_sha256"] = _files_digest(tmp, "tracks*")
        return figures
    from pftrack.io.atomic import atomic_write_text

    result = tool.run(ns)
    atomic_write_text(tmp / "result.json", json.dumps(result, indent=2, default=float) + "\n")
    return _flat_numbers(result)


@contextlib.contextmanager
def _one_thread() -> Iterator[None]:
    """One OpenCV and one BLAS thread while a job runs: the same bits on any worker, and one
    core per job."""
    import cv2

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        try:
            from threadpoolctl import threadpool_limits
        except ImportError:  # pragma: no cover - scikit-learn brings it
            yield
        else:
            with threadpool_limits(limits=1):
                yield
    finally:
        cv2.setNumThreads(threads)


def _read_done(folder: Path, job: Job) -> dict[str, Any] | None:
    """The recorded row of a complete job folder of this very job, else None."""
    try:
        done = json.loads((folder / "job.json").read_text())
    except (OSError, ValueError):
        return None
    if done.get("token") != job.token() or done.get("row", {}).get("status") != "ok":
        return None
    return done["row"]


def execute_job(job: Job, out_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """Run one job into ``out_dir/job.name``, atomically; return its table row.

    Never raises for a failing job: the row has ``status: "failed"`` and ``error`` (and
    ``traceback``), and no folder is left. A job whose folder already holds this job's result
    (a rerun after its worker died having finished it) returns the recorded row and writes
    nothing. This is the function Dask runs on the workers.

    Returns
    -------
    dict
        ``job``, ``group``, ``kind``, ``seed``, ``status`` (``ok``/``failed``), ``error``,
        ``time_s`` (wall seconds of the job), ``cpu_s`` (CPU seconds of the process during it),
        ``worker`` (``HOST:PID``), ``resumed``, and the job's figures: for a run job ``frames``,
        ``rows``, ``ids``, ``tracks_sha256``, frames per second and, with ground truth, MOTA,
        IDF1, HOTA, IDSW, FP, FN, ground-plane errors; for a demo or benchmark the numbers of
        its ``metrics.json`` or result (nested keys joined by dots).
    """
    out = Path(out_dir)
    final = out / job.name
    worker = f"{socket.gethostname()}:{os.getpid()}"
    row: dict[str, Any] = {"job": job.name, "group": job.group, "kind": job.kind,
                           "seed": job.seed, "worker": worker, "resumed": False}
    done = _read_done(final, job)
    if done is not None:
        return done
    tmp = out / f".tmp-{job.name}-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        tmp.mkdir(parents=True)
        log = tmp / "log.txt"
        with _one_thread(), open(log, "w") as fh, contextlib.redirect_stdout(fh), \
                contextlib.redirect_stderr(fh):
            figures = _run_job(job, tmp)
        row.update(status="ok", time_s=time.perf_counter() - t0,
                   cpu_s=time.process_time() - c0, error="", **figures)
        from pftrack.io.atomic import atomic_write_text

        atomic_write_text(tmp / "job.json", json.dumps(
            {"token": job.token(), "job": asdict(job), "row": row}, indent=2, default=float)
            + "\n")
        try:
            os.rename(tmp, final)
        except OSError:
            # the folder appeared meanwhile (the same job finished elsewhere): keep the first
            done = _read_done(final, job)
            if done is None:
                raise
            return done
        return row
    except Exception as exc:  # noqa: BLE001 - a failing job is a row, the batch goes on
        row.update(status="failed", time_s=time.perf_counter() - t0,
                   error=f"{type(exc).__name__}: {exc}", traceback=traceback.format_exc())
        return row
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


# --------------------------------------------------------------------------------------------
# The table
# --------------------------------------------------------------------------------------------


def aggregate_rows(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per group, over its ``ok`` rows: ``n``, the seeds, and for every numeric figure its mean
    (``KEY_mean``) and sample standard deviation (``KEY_std``, ddof 1; None for one job)."""
    groups: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        if r.get("status") == "ok":
            groups.setdefault(r["group"], []).append(r)
    out = []
    for g, rs in groups.items():
        agg: dict[str, Any] = {"group": g, "n": len(rs),
                               "seeds": [r.get("seed") for r in rs]}
        keys = sorted({k for r in rs for k, v in r.items()
                       if k not in ("seed", "resumed") and isinstance(v, (int, float))
                       and not isinstance(v, bool)})
        for k in keys:
            vals = [float(r[k]) for r in rs if isinstance(r.get(k), (int, float))]
            vals = [v for v in vals if not math.isnan(v)]
            if not vals:
                continue
            mean = sum(vals) / len(vals)
            agg[f"{k}_mean"] = mean
            agg[f"{k}_std"] = (math.sqrt(sum((v - mean) ** 2 for v in vals) / (len(vals) - 1))
                               if len(vals) > 1 else None)
        out.append(agg)
    return out


def _csv_text(rows: Sequence[dict[str, Any]], first: Sequence[str]) -> str:
    import csv
    import io

    keys = [k for k in first if any(k in r for r in rows)]
    keys += sorted({k for r in rows for k in r} - set(keys) - {"traceback"})
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=keys, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else
                        json.dumps(r[k]) if isinstance(r.get(k), list) else r[k])
                    for k in keys})
    return buf.getvalue()


def _write_summary(out: Path, jobs: Sequence[Job], rows: dict[str, dict[str, Any]]
                   ) -> tuple[list[dict[str, Any]], list[dict[str, Any]], dict[str, Path]]:
    from pftrack.io.atomic import atomic_write_text

    table = [rows.get(j.name) or {"job": j.name, "group": j.group, "kind": j.kind,
                                  "seed": j.seed, "status": "pending"} for j in jobs]
    aggs = aggregate_rows(table)
    counts = {s: sum(r["status"] == s for r in table) for s in ("ok", "failed", "pending")}
    files = {"summary.json": out / "summary.json", "summary.csv": out / "summary.csv",
             "aggregates.csv": out / "aggregates.csv"}
    atomic_write_text(files["summary.csv"], _csv_text(table, ROW_FIRST))
    atomic_write_text(files["aggregates.csv"], _csv_text(aggs, ("group", "n", "seeds")))
    atomic_write_text(files["summary.json"], json.dumps(
        {"counts": {"jobs": len(table), **counts}, "jobs": table, "aggregates": aggs},
        indent=2, default=float) + "\n")
    return table, aggs, files


# --------------------------------------------------------------------------------------------
# The batch
# --------------------------------------------------------------------------------------------


def cpu_count() -> int:
    """The cores this process may use (its affinity where the system has one)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


#: Dask settings of the local cluster :func:`local_cluster` starts (see there for why).
WORKER_CONFIG: dict[str, Any] = {
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.worker.profile.enabled": False,
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.tick.interval": "500ms",
}
if sys.platform.startswith("linux"):
    # workers forked from the calling process, which has pftrack and its plugins imported
    WORKER_CONFIG["distributed.worker.multiprocessing-method"] = "fork"


def local_cluster(n_workers: int) -> Any:
    """A ``dask.distributed.LocalCluster`` of ``n_workers`` single-threaded worker processes, as
    :func:`run_batch` starts one (no dashboard).

    The cluster runs with :data:`WORKER_CONFIG` (the documentation's "Run a batch on Dask" page
    shows the same settings for workers started with ``dask worker``):

    * its workers keep glibc's own malloc thresholds: Dask's default sets
      ``MALLOC_TRIM_THRESHOLD_=65536`` in its workers' environment, which also fixes glibc's mmap
      threshold at 128 KiB, so that every frame-sized array is a fresh ``mmap`` with its page
      faults; measured on PETS slices, a job then costs about 1.4x the CPU time it costs in the
      calling process (4.0 against 2.85 s for 30 frames). ``MALLOC_TRIM_THRESHOLD_: null`` under
      ``distributed.nanny.pre-spawn-environ`` is Dask's documented way to leave it unset;
    * Dask's own bookkeeping is made sparse: the workers' statistical profiler (a thread that
      samples the job's stack every 10 ms, for a dashboard this cluster does not start) is off,
      and the system monitor (psutil every 0.5 s), the nanny's memory monitor (every 0.1 s) and
      the event loops' tick (every 20 ms) wake up every 2 s, 1 s and 0.5 s. Measured on the 8 PETS
      slices of ``pftrack bench batch`` (machine loaded by other work, one run each): the jobs'
      CPU on the workers 48.6 / 47.9 s with Dask's defaults, 44.9 / 45.2 s with the profiler off
      and the system monitor at 2 s, 42.9 s with all four, against 41.3 s serially in one process;
    * on Linux its worker processes are forked from the calling process (Dask's default is
      ``spawn``) after pftrack's pipeline and plugins are imported there, so a worker starts with
      them loaded instead of importing numpy, OpenCV, scikit-learn, SciPy and the plugins again
      (about 1.5 s of CPU per worker, paid inside the batch on a 2-core machine). Measured on
      the same 8 slices with the command ``pftrack batch --workers 2`` (two runs each): 24.0 /
      23.6 s with ``spawn``, 23.6 / 24.6 s with ``forkserver``, 20.7 / 22.0 s with ``fork``,
      against 40.3-41.5 s with ``--workers 1``. The jobs themselves pin OpenCV and BLAS to one
      thread; tracks are bit-identical either way (``pftrack bench batch`` checks it). The
      environment variable ``DASK_DISTRIBUTED__WORKER__MULTIPROCESSING_METHOD``, when set, wins
      (``spawn``, ``forkserver``).
    """
    import dask

    distributed = require_dask()
    config = dict(WORKER_CONFIG)
    if os.environ.get("DASK_DISTRIBUTED__WORKER__MULTIPROCESSING_METHOD"):
        config.pop("distributed.worker.multiprocessing-method", None)
    _preload()
    with dask.config.set(config):
        return distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1,
                                        processes=True, dashboard_address=None)


def _preload() -> None:
    """Import what a job needs in this process, so that forked workers start with it.

    Best effort: a plugin that fails to load fails its jobs, with their own error rows."""
    try:
        import pftrack.workflows.pipeline  # noqa: F401
        from pftrack.host import get_host

        get_host()
    except Exception:  # noqa: BLE001 - reported by the jobs themselves
        pass


def require_dask() -> Any:
    """``dask.distributed``; ImportError saying what to install when Dask is missing."""
    try:
        import distributed
    except ImportError:
        raise ImportError(DASK_MISSING) from None
    return distributed


def run_batch(jobs: Sequence[Job] | str | os.PathLike[str], out_dir: str | os.PathLike[str], *,
              client: Any = None, scheduler: str | None = None, workers: int | None = None,
              resume: bool = False, retries: int = 2, progress: bool = True,
              on_row: Callable[[dict[str, Any]], None] | None = None) -> BatchResult:
    """Run a batch of jobs and write each into ``out_dir/NAME``, with the summary table.

    Parameters
    ----------
    jobs : list of Job, or a JOBS file path
        The jobs (:func:`load_jobs`).
    out_dir : path
        The batch folder (created). On a cluster every worker must see it at the same path (a
        shared file system).
    client : dask.distributed.Client, optional
        A client the caller already has (a notebook's); it is used and left open.
    scheduler : str, optional
        A Dask scheduler's address (``tcp://HOST:8786``): the jobs go to its workers.
    workers : int, optional
        Without ``client`` or ``scheduler``: the worker processes of a local Dask cluster
        started and stopped here (default: the cores). ``1`` runs the jobs one after another
        in this process, without Dask.
    resume : bool
        Skip the jobs whose folder holds their complete result. Without it, an existing job
        folder is an error (it would be neither rewritten nor silently reused).
    retries : int
        Dask reruns of a job whose worker raised outside the job (a job's own error is a
        ``failed`` row, not retried). A job whose worker died is rerun by the scheduler.
    progress : bool
        A progress bar counting jobs (stderr).
    on_row : callable, optional
        Called with each row as its job finishes (after the table is updated).

    Returns
    -------
    BatchResult
    """
    if not isinstance(jobs, (list, tuple)):
        jobs = load_jobs(jobs)  # type: ignore[arg-type]
    if client is not None and scheduler is not None:
        raise ValueError("give a client or a scheduler address, not both")
    if workers is not None and workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    out = Path(out_dir).absolute()
    out.mkdir(parents=True, exist_ok=True)
    for stale in out.glob(".tmp-*"):  # a job interrupted by a killed process
        shutil.rmtree(stale, ignore_errors=True)
    rows: dict[str, dict[str, Any]] = {}
    todo: list[Job] = []
    for job in jobs:
        folder = out / job.name
        if folder.exists():
            done = _read_done(folder, job)
            if not resume:
                raise ValueError(f"{folder} exists: use --resume to skip the jobs already done, "
                                 "or another --out")
            if done is None:
                raise ValueError(f"{folder} exists but is not the complete result of job "
                                 f"{job.name!r} as now defined: remove it to rerun the job")
            rows[job.name] = {**done, "resumed": True}
        else:
            todo.append(job)
    _write_summary(out, jobs, rows)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(jobs), initial=len(rows), desc="pftrack batch", unit="job")

    def finished(row: dict[str, Any]) -> None:
        rows[row["job"]] = row
        _write_summary(out, jobs, rows)
        if bar is not None:
            bar.update(1)
            bar.set_postfix(failed=sum(r["status"] != "ok" for r in rows.values()))
        if on_row is not None:
            on_row(row)

    try:
        if client is None and scheduler is None and workers == 1:
            for job in todo:
                finished(execute_job(job, out))
        elif todo:
            distributed = require_dask()
            with contextlib.ExitStack() as stack:
                if client is None:
                    if scheduler is not None:
                        try:
                            client = stack.enter_context(distributed.Client(scheduler))
                        except OSError as exc:
                            raise ValueError(f"--scheduler {scheduler}: cannot connect: "
                                             f"{exc}") from None
                    else:
                        cluster = stack.enter_context(local_cluster(workers or cpu_count()))
                        client = stack.enter_context(distributed.Client(cluster))
                _submit_all(distributed, client, todo, out, retries, finished)
    finally:
        if bar is not None:
            bar.close()
    table, aggs, files = _write_summary(out, jobs, rows)
    for stale in out.glob(".tmp-*"):
        shutil.rmtree(stale, ignore_errors=True)
    return BatchResult(rows=table, aggregates=aggs, out_dir=out, files=files)


def _submit_all(distributed: Any, client: Any, todo: Sequence[Job], out: Path, retries: int,
                finished: Callable[[dict[str, Any]], None]) -> None:
    batch = uuid.uuid4().hex[:8]
    futures = {}
    for job in todo:
        fut = client.submit(execute_job, job, str(out), key=f"pftrack-batch-{batch}-{job.name}",
                            pure=False, retries=retries)
        futures[fut] = job
    for fut in distributed.as_completed(futures):
        job = futures[fut]
        try:
            row = fut.result()
        except Exception as exc:  # noqa: BLE001 - the engine gave up on it (e.g. KilledWorker)
            row = {"job": job.name, "group": job.group, "kind": job.kind, "seed": job.seed,
                   "status": "failed", "error": f"{type(exc).__name__}: {exc}",
                   "worker": "", "resumed": False}
        finished(row)
