"""Catalogue: faults. ``pftrack run`` in a subprocess, stopped by SIGINT, SIGTERM or SIGKILL
before the first frame (components being set up), during tracking and while writing its
outputs (a slow in-process plugin holds the run at that point and says so through a marker
file). SIGINT: exit 130, one line, the previous outputs untouched (not even a temporary file
left). SIGKILL / SIGTERM: the previous outputs untouched; what the killed run left (its staging
folder) is removed by the next run into the folder. Also: a closed stdout pipe, warnings and
--debug as a user sees them."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ._catalogue import assert_untouched, snapshot

DRIVER = r'''
import os, pathlib, signal, sys, time
# Ctrl-C as a terminal delivers it: a test runner started in the background (nohup, `cmd &` in a
# script) hands its children SIGINT ignored, and Python then installs no KeyboardInterrupt
signal.signal(signal.SIGINT, signal.default_int_handler)
import numpy as np
marker, stage = pathlib.Path(sys.argv[1]), sys.argv[2]
import pftrack.host as hm
from pftrack import hookimpl
from pftrack.contracts.extensions import ReportWriter
from pftrack_basic.gaussian import GaussianLikelihood

def hold():
    marker.write_text(str(os.getpid()))
    time.sleep(120)

class Slow(GaussianLikelihood):
    def setup(self, context):
        super().setup(context)
        if stage == "setup":
            hold()

    def begin_frame(self, frame, targets, detections=None):
        if stage == "tracking" and frame.index >= 5:
            hold()
        return super().begin_frame(frame, targets, detections)

def write(out_dir, rows, frames, **kw):
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "overlay_000001.png").write_bytes(b"half a pic")
    if stage == "writing":
        hold()
    return [out_dir / "overlay_000001.png"]

class Plugin:
    @hookimpl
    def pftrack_register_likelihoods(self, register):
        register("slow-gaussian", Slow)

    @hookimpl
    def pftrack_register_report_writers(self, register):
        register("slow", ReportWriter(summary="slow", write=write))

hm._HOST = hm.Host(plugins=[("slow", Plugin())])
from pftrack.cli import main
sys.exit(main(sys.argv[3:]))
'''

ROOT = Path(__file__).resolve().parents[4]


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "toolkit"), str(ROOT / "plugins"),
                                         env.get("PYTHONPATH", "")])
    return env


@pytest.fixture
def slow_run(work):
    driver = work.dir / "driver.py"
    driver.write_text(DRIVER)
    cfg = work.dir / "slow.yaml"
    cfg.write_text(work.config.read_text().replace("type: gaussian", "type: slow-gaussian")
                   + "report: {writer: slow}\n")

    started: list[subprocess.Popen] = []

    def start(stage: str) -> tuple[subprocess.Popen, Path]:
        marker = work.dir / f"held-{stage}"
        proc = subprocess.Popen(
            [sys.executable, str(driver), str(marker), stage, "run", str(cfg), "--video",
             str(work.video), "--gt", str(work.gt), "--out", str(work.out), "--quiet"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env(),
            start_new_session=True)
        started.append(proc)
        deadline = time.monotonic() + 90
        while not marker.exists():
            if proc.poll() is not None:
                raise AssertionError(f"the run ended before {stage}: {proc.communicate()}")
            if time.monotonic() > deadline:
                proc.kill()
                raise AssertionError(f"the run never reached {stage}")
            time.sleep(0.05)
        return proc, marker

    yield start
    for proc in started:  # a failed case leaves no held run behind
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


STAGES = ["setup", "tracking", "writing"]


@pytest.mark.parametrize("stage", STAGES)
def test_sigint_leaves_everything_as_it_was(work, slow_run, stage):
    before = snapshot(work.out)
    proc, _marker = slow_run(stage)
    proc.send_signal(signal.SIGINT)
    _out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == ("pftrack run: interrupted; outputs left as they "
                                            "were before the run")
    assert_untouched(before, work.out)  # no staging folder, no temporary file either


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
@pytest.mark.parametrize("stage", STAGES)
def test_kill_keeps_the_previous_outputs_and_the_next_run_cleans(work, slow_run, cli, stage,
                                                                 sig):
    visible = {k: v for k, v in snapshot(work.out).items() if "/." not in k}
    proc, _marker = slow_run(stage)
    proc.send_signal(sig)
    proc.communicate(timeout=60)
    assert proc.returncode == -sig
    now = {k: v for k, v in snapshot(work.out).items() if "/." not in k}
    assert now == visible
    if stage == "writing":
        assert list(work.out.glob(".pftrack-staging-*"))  # what the next run must clean
    r = cli("run", work.config, "--video", work.video, "--gt", work.gt, "--out", work.out,
            "--quiet", "--no-report")
    assert r.rc == 0
    assert sorted(p.name for p in work.out.iterdir()) == ["metrics.json", "tracks.txt",
                                                          "tracks_uncertainty.csv"]


def test_closed_stdout_pipe_is_quiet(tmp_path):
    proc = subprocess.run(
        f"{sys.executable} -m pftrack presets --json | head -c 20",
        shell=True, capture_output=True, text=True, env=_env(), check=False,
        executable="/bin/bash")
    assert proc.stdout == '{\n  "presets": [\n    '[:20]
    assert proc.stderr == ""


def test_broken_pipe_exit_code(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-c", ("import sys; from pftrack.cli import main; "
         "sys.stdout.close = lambda: None; import os; r, w = os.pipe(); os.close(r); "
         "os.dup2(w, 1); sys.exit(main(['presets', '--json']))")],
        capture_output=True, text=True, env=_env(), check=False)
    assert proc.returncode == 141 and proc.stderr == ""


def test_warnings_are_one_line_and_debug_adds_the_traceback(work):
    data = work.video.read_bytes()
    trunc = work.dir / "t.avi"
    trunc.write_bytes(data[: len(data) // 2])
    proc = subprocess.run(
        [sys.executable, "-m", "pftrack", "run", str(work.config), "--video", str(trunc),
         "--out", str(work.dir / "o"), "--quiet", "--no-report"],
        capture_output=True, text=True, env=_env(), check=False)
    assert proc.returncode == 0
    warn = [ln for ln in proc.stderr.splitlines() if ln.startswith("pftrack run: warning: ")]
    assert len(warn) == 1 and f"video {trunc}: short read" in warn[0]
    proc = subprocess.run(
        [sys.executable, "-m", "pftrack", "run", str(work.config), "--video",
         str(work.dir / "none.avi"), "--out", str(work.dir / "o"), "--debug"],
        capture_output=True, text=True, env=_env(), check=False)
    assert proc.returncode == 2
    assert "Traceback" in proc.stderr and "none.avi not found" in proc.stderr
