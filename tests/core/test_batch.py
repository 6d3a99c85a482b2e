"""``pftrack batch`` and :mod:`pftrack.workflows.batch`: jobs files, the table, faults, resume, and
the same bits serial, on a local Dask cluster and on a scheduler with workers started apart (one of
them killed mid-batch). Real PETS 2009 slices and walkers runs; no mocks."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml
from pftrack.cli import main
from pftrack.io.data import data_dir
from pftrack.workflows.batch import WORKER_CONFIG, load_jobs, local_cluster, parse_jobs, run_batch

PETS = data_dir() / "pets09"
WALKERS = {"name": "walkers", "demo": "walkers",
           "args": ["--frames", "30", "--particles", "100", "--no-baseline"]}


@pytest.fixture(scope="module")
def svm(tmp_path_factory) -> Path:
    """A PETS detector trained on 60 frames (seconds; the figures are not the point here)."""
    from pftrack.workflows.pipeline import load_config, train_detector

    out = tmp_path_factory.mktemp("svm") / "svm60.npz"
    train_detector(PETS / "vtest.avi", PETS / "gt.txt", "1:60", out=out,
                   cfg=load_config("pets09-ground"), seed=0)
    return out


def _write(path: Path, doc: dict) -> Path:
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _pets_entry(svm: Path, **extra) -> dict:
    return {"name": "pets", "config": "pets09-ground", "video": str(PETS / "vtest.avi"),
            "camera": str(PETS / "View_001.xml"), "gt": str(PETS / "gt.txt"),
            "detector_model": str(svm), "frames": "401:410", **extra}


def _summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


# -- the jobs file ------------------------------------------------------------------------------


def test_matrix_expands_seeds_parameters_and_inputs(tmp_path):
    (tmp_path / "a.avi").write_bytes(b"")
    jobs = parse_jobs({
        "defaults": {"video": "a.avi", "seed": 7},
        "jobs": [{"name": "p", "config": "pets09-ground", "frames": "5:9",
                  "matrix": {"seed": [0, 1, 2], "set": [{"tracker.n_particles": 50},
                                                        {"tracker.n_particles": 80}]}},
                 {**WALKERS, "matrix": {"args": [["--frames", "5"], ["--frames", "9"]]}}]},
        base=tmp_path)
    names = [j.name for j in jobs]
    assert names[:3] == ["p-seed0-set0", "p-seed0-set1", "p-seed1-set0"] and len(jobs) == 8
    p = {j.name: j for j in jobs}
    assert p["p-seed2-set1"].spec["set"] == {"tracker.n_particles": 80}
    assert p["p-seed2-set1"].spec["video"] == str(tmp_path / "a.avi")
    assert p["p-seed2-set1"].spec["frames"] == "5:9" and p["p-seed2-set1"].seed == 2
    # seeds share a group; parameters and inputs do not
    assert {j.group for j in jobs if j.name.startswith("p-")} == {"p-set0", "p-set1"}
    # the defaults a demo takes (seed) and not those it does not (video)
    assert p["walkers-args1"].seed == 7 and p["walkers-args1"].spec["args"] == ["--frames", "9"]
    assert "video" not in p["walkers-args1"].spec


@pytest.mark.parametrize(("entry", "words"), [
    ({"name": "j1", "config": "pets09-ground", "video": "v.avi", "sead": 1},
     ["'j1'", "'sead'", "unknown field"]),
    ({"name": "j2", "config": "pets09-ground"}, ["'j2'", "'video'", "missing"]),
    ({"name": "j3", "config": "pets09-ground", "video": "v.avi", "frames": "9:3"},
     ["'j3'", "'frames'"]),
    ({"name": "j4", "demo": "walkers", "matrix": {"frames": [1, 2]}}, ["'j4'", "'frames'"]),
    ({"name": "j5", "demo": "walkers", "bench": "core"}, ["'j5'", "exactly one"]),
    ({"name": "a/b", "demo": "walkers"}, ["'a/b'", "'name'"]),
])
def test_a_bad_jobs_file_names_the_file_the_job_and_the_field(tmp_path, capsys, entry, words):
    jobs = _write(tmp_path / "jobs.yaml", {"jobs": [entry]})
    assert main(["batch", str(jobs), "--out", str(tmp_path / "o"), "--workers", "1"]) == 2
    err = capsys.readouterr().err
    assert "jobs.yaml" in err and all(w in err for w in words), err
    assert not (tmp_path / "o").exists()


def test_duplicate_names_and_unknown_top_level_keys_are_refused(tmp_path):
    with pytest.raises(ValueError, match="two jobs are named 'walkers'"):
        parse_jobs({"jobs": [WALKERS, WALKERS]})
    with pytest.raises(ValueError, match=r"unknown top-level keys \['job'\]"):
        parse_jobs({"job": [WALKERS]})
    with pytest.raises(FileNotFoundError, match="none.yaml"):
        load_jobs(tmp_path / "none.yaml")


# -- faults and resume (serial: no Dask needed) -----------------------------------------------


def test_a_bad_job_fails_alone_and_resume_skips_the_complete_ones(tmp_path, capsys):
    jobs = _write(tmp_path / "jobs.yaml", {"jobs": [
        {**WALKERS, "matrix": {"seed": [0, 1]}},
        {"name": "novideo", "config": "pets09-ground", "video": "missing.avi"},
        {"name": "badparam", "config": "pets09-ground", "video": str(PETS / "vtest.avi"),
         "camera": str(PETS / "View_001.xml"), "frames": "1:3",
         "set": {"tracker.n_particle": 10}},
        {"name": "badargs", "demo": "walkers", "args": ["--frames", "0"]},
    ]})
    out = tmp_path / "out"
    assert main(["batch", str(jobs), "--out", str(out), "--workers", "1", "--quiet"]) == 1
    table = {r["job"]: r for r in _summary(out)["jobs"]}
    assert _summary(out)["counts"] == {"jobs": 5, "ok": 2, "failed": 3, "pending": 0}
    assert table["walkers-seed0"]["status"] == table["walkers-seed1"]["status"] == "ok"
    assert table["walkers-seed0"]["tracks_sha256"] != table["walkers-seed1"]["tracks_sha256"]
    assert table["novideo"]["error"] == (f"FileNotFoundError: video {tmp_path / 'missing.avi'} "
                                         "not found")
    assert "n_particle" in table["badparam"]["error"]
    assert "--frames must be >= 1" in table["badargs"]["error"]
    # a failed job leaves no folder, a done one its outputs; the CSV has the same rows
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["walkers-seed0",
                                                                   "walkers-seed1"]
    assert (out / "walkers-seed0" / "tracks.csv").is_file()
    csv = (out / "summary.csv").read_text().splitlines()
    assert csv[0].startswith("job,group,kind,seed,status,time_s") and len(csv) == 6
    assert "novideo,novideo,run,0,failed," in (out / "summary.csv").read_text()
    aggs = {a["group"]: a for a in _summary(out)["aggregates"]}
    w = aggs["walkers"]
    ce = [table[f"walkers-seed{s}"]["methods.cross-entropy-bg.MOTA"] for s in (0, 1)]
    assert w["n"] == 2 and w["seeds"] == [0, 1]
    assert w["methods.cross-entropy-bg.MOTA_mean"] == pytest.approx(sum(ce) / 2)
    # again without --resume: refused, nothing touched
    assert main(["batch", str(jobs), "--out", str(out), "--workers", "1", "--quiet"]) == 2
    assert "--resume" in capsys.readouterr().err
    before = (out / "walkers-seed0" / "job.json").stat().st_mtime_ns
    assert main(["batch", str(jobs), "--out", str(out), "--workers", "1", "--resume"]) == 1
    printed = capsys.readouterr().out
    assert "2 of 5 jobs ok (2 resumed), 3 failed" in printed and "novideo" in printed
    assert (out / "walkers-seed0" / "job.json").stat().st_mtime_ns == before
    table2 = {r["job"]: r for r in _summary(out)["jobs"]}
    assert table2["walkers-seed0"]["resumed"] is True
    assert table2["walkers-seed0"]["tracks_sha256"] == table["walkers-seed0"]["tracks_sha256"]
    assert not list(out.glob(".tmp-*"))


def test_a_job_run_twice_is_written_once(tmp_path):
    """What a rerun after a worker died past its rename meets: the folder is kept as it is and
    the recorded row comes back."""
    from pftrack.workflows.batch import execute_job

    job = parse_jobs({"jobs": [{**WALKERS, "args": ["--frames", "5", "--particles", "20",
                                                    "--no-baseline"]}]})[0]
    first = execute_job(job, tmp_path)
    assert first["status"] == "ok"
    stamps = {p.name: p.stat().st_mtime_ns for p in (tmp_path / job.name).iterdir()}
    again = execute_job(job, tmp_path)
    assert again == json.loads(json.dumps(first))  # the row read back from job.json
    assert {p.name: p.stat().st_mtime_ns for p in (tmp_path / job.name).iterdir()} == stamps
    assert [p.name for p in tmp_path.iterdir()] == [job.name]


def test_without_dask_it_says_what_to_install_and_runs_serially(tmp_path):
    jobs = _write(tmp_path / "jobs.yaml", {"jobs": [
        {**WALKERS, "args": ["--frames", "5", "--particles", "20", "--no-baseline"]}]})
    # Dask made unimportable in a fresh interpreter (a None entry makes `import` fail)
    code = ("import sys; sys.modules['distributed'] = None; from pftrack.cli import main; "
            "sys.exit(main(sys.argv[1:]))")
    cmd = [sys.executable, "-c", code, "batch", str(jobs), "--quiet"]
    p = subprocess.run([*cmd, "--out", str(tmp_path / "o2"), "--workers", "2"],
                       capture_output=True, text=True, timeout=120, check=False)
    assert p.returncode == 2 and "pip install 'pftrack[dask]'" in p.stderr, p.stderr
    assert "--workers 1" in p.stderr
    p = subprocess.run([*cmd, "--out", str(tmp_path / "o1"), "--workers", "1"],
                       capture_output=True, text=True, timeout=120, check=False)
    assert p.returncode == 0, p.stderr
    assert _summary(tmp_path / "o1")["counts"]["ok"] == 1


# -- on Dask ----------------------------------------------------------------------------------


def test_a_local_cluster_gives_the_serial_bits(tmp_path, svm):
    distributed = pytest.importorskip("distributed")
    import dask
    jobs = parse_jobs({"jobs": [
        _pets_entry(svm, matrix={"seed": [0, 1], "set": [{"tracker.n_particles": 100},
                                                         {"tracker.n_particles": 200}]}),
        {**WALKERS, "matrix": {"seed": [0, 1, 2]}},
    ]})
    serial = run_batch(jobs, tmp_path / "serial", workers=1, progress=False)
    assert serial.n_failed == 0 and len(serial.rows) == 7
    with local_cluster(2) as cluster, distributed.Client(cluster) as client:
        if "MALLOC_TRIM_THRESHOLD_" not in os.environ:
            # glibc's own malloc thresholds in the workers (Dask's default would fix them)
            assert set(client.run(os.getenv, "MALLOC_TRIM_THRESHOLD_").values()) == {None}
        # Dask's bookkeeping made sparse in the workers themselves, not only in this process
        got = client.run(lambda: [dask.config.get(k) for k in WORKER_CONFIG
                                  if not k.startswith("distributed.nanny")])
        want = [v for k, v in WORKER_CONFIG.items() if not k.startswith("distributed.nanny")]
        assert len(got) == 2 and all(g == want for g in got.values())
        assert want[0] is False and dask.config.get("distributed.worker.profile.enabled")
        if sys.platform.startswith("linux"):  # forked after this process imported the pipeline
            assert WORKER_CONFIG["distributed.worker.multiprocessing-method"] == "fork"
            assert set(client.run(lambda: "pftrack.workflows.pipeline" in __import__("sys").modules
                                  ).values()) == {True}  # before any job ran there
        par = run_batch(jobs, tmp_path / "dask", client=client, progress=False)
        assert client.status == "running"  # the caller's client is left open
    assert par.n_failed == 0
    workers = {r["worker"] for r in par.rows}
    assert len(workers) == 2 and os.getpid() not in {int(w.rsplit(":", 1)[1]) for w in workers}
    hashes = {r["job"]: r["tracks_sha256"] for r in serial.rows}
    assert len(set(hashes.values())) == 7  # seeds and parameters change the tracks ...
    assert {r["job"]: r["tracks_sha256"] for r in par.rows} == hashes  # ... workers do not
    for r in serial.rows:
        for f in ("tracks.txt", "metrics.json") if r["kind"] == "run" else ("tracks.csv",):
            a = (tmp_path / "serial" / r["job"] / f).read_bytes()
            b = (tmp_path / "dask" / r["job"] / f).read_bytes()
            if f == "metrics.json":  # timings differ; the scores do not
                a, b = ({k: v for k, v in json.loads(x).items() if "second" not in k
                         and not k.endswith("_per_frame")} for x in (a, b))
            assert a == b, (r["job"], f)
        assert par.row(r["job"]).get("MOTA") == r.get("MOTA")
    agg = {a["group"]: a for a in par.aggregates}
    assert agg["pets-set1"]["n"] == 2 and agg["pets-set1"]["seeds"] == [0, 1]
    mota = [par.row(f"pets-seed{s}-set1")["MOTA"] for s in (0, 1)]
    assert agg["pets-set1"]["MOTA_mean"] == pytest.approx(sum(mota) / 2)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for(cond, timeout: float, what: str) -> None:
    t0 = time.monotonic()
    while not cond():
        if time.monotonic() - t0 > timeout:
            raise TimeoutError(what)
        time.sleep(0.05)


def test_a_scheduler_by_address_survives_a_killed_worker(tmp_path):
    distributed = pytest.importorskip("distributed")
    dask = str(Path(sys.executable).parent / "dask")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ)  # the workers import pftrack as this process does
    log = open(tmp_path / "dask.log", "w")  # noqa: SIM115 - closed in finally
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], env=env, stdout=log, stderr=log)]
    try:
        for i in (1, 2):
            procs.append(subprocess.Popen(
                [dask, "worker", address, "--host", "127.0.0.1", "--nthreads", "1",
                 "--no-nanny", "--no-dashboard", "--name", f"w{i}"],
                env=env, stdout=log, stderr=log))
        with distributed.Client(address, timeout=60) as c:
            c.wait_for_workers(2, timeout=120)
        victim = procs[1]
        out = tmp_path / "out"
        jobs = parse_jobs({"jobs": [{**WALKERS, "args": ["--frames", "30", "--particles", "100",
                                                         "--no-baseline"],
                                     "matrix": {"seed": [0, 1, 2, 3, 4, 5]}}]})
        result: dict = {}
        runner = threading.Thread(target=lambda: result.update(
            r=run_batch(jobs, out, scheduler=address, progress=False)))
        runner.start()
        # kill the victim while it is inside a job (its temporary job folder exists)
        in_flight = []
        _wait_for(lambda: in_flight.extend(out.glob(f".tmp-*-{victim.pid}-*")) or in_flight,
                  120, "no job started on the victim worker")
        os.kill(victim.pid, signal.SIGKILL)
        victim.wait(timeout=30)
        runner.join(timeout=300)
        assert not runner.is_alive()
    finally:
        for p in procs:
            if p.poll() is None:
                p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
        log.close()
    batch = result["r"]
    assert batch.n_failed == 0 and len(batch.rows) == 6
    summary = _summary(out)
    assert summary["counts"] == {"jobs": 6, "ok": 6, "failed": 0, "pending": 0}
    # each job once: one folder each, no temporary folder left, and the job that was in flight
    # on the killed worker was finished by the other one
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == [j.name for j in jobs]
    assert not list(out.glob(".tmp-*"))
    killed_job = in_flight[0].name.split(f"-{victim.pid}-")[0].removeprefix(".tmp-")
    assert batch.row(killed_job)["worker"].endswith(f":{procs[2].pid}")
    assert all(json.loads((out / j.name / "job.json").read_text())["row"]["job"] == j.name
               for j in jobs)
    # the bits do not depend on the worker: the same jobs serial
    serial = run_batch(jobs[:2], tmp_path / "serial", workers=1, progress=False)
    assert [r["tracks_sha256"] for r in serial.rows] == [
        batch.row(j.name)["tracks_sha256"] for j in jobs[:2]]
