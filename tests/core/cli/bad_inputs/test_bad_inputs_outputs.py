"""Catalogue: output paths and the output unit. Every output path is checked before work starts
(an existing file, a path under a regular file, a read-only folder, a full disk); a run's outputs
are replaced together or not at all; stale outputs and temporary files of earlier runs are
removed. Each refusal asserts exit 2, a one-line message naming the path, and that nothing on
disk changed."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest
from pftrack.workflows import pipeline

from ._catalogue import assert_untouched, one_line, snapshot


def _no_tracking(monkeypatch):
    """Fail the test if the engine is built: the refusal must come before any frame."""
    built = []
    monkeypatch.setattr(pipeline, "build_engine", lambda *a, **k: built.append(1))
    return built


# ---- pftrack run --out ----------------------------------------------------------------------

@pytest.mark.parametrize(("make", "expect"), [
    ("out-is-file", "is a file, not a folder"),
    ("out-under-file", "is a file, not a folder"),
    ("out-deep-under-file", "is a file, not a folder"),
    ("report-is-file", "report is a file, where the run writes a folder"),
    ("tracks-is-folder", "tracks.txt is a folder, where the run writes a file"),
    ("metrics-is-folder", "metrics.json is a folder, where the run writes a file"),
])
def test_run_out_checked_before_tracking(work, cli, monkeypatch, make, expect):
    out = work.out
    if make == "out-is-file":
        out = work.dir / "plain"
        out.write_text("a file\n")
    elif make == "out-under-file":
        (work.dir / "plain").write_text("a file\n")
        out = work.dir / "plain" / "o"
    elif make == "out-deep-under-file":
        (work.dir / "plain").write_text("a file\n")
        out = work.dir / "plain" / "a" / "b" / "c"
    elif make == "report-is-file":
        import shutil

        shutil.rmtree(out / "report")
        (out / "report").write_text("my notes\n")
    elif make == "tracks-is-folder":
        (out / "tracks.txt").unlink()
        (out / "tracks.txt").mkdir()
    elif make == "metrics-is-folder":
        (out / "metrics.json").unlink()
        (out / "metrics.json").mkdir()
    built = _no_tracking(monkeypatch)
    before = snapshot(work.dir)
    r = cli("run", work.config, "--video", work.video, "--gt", work.gt, "--out", out, "--quiet")
    assert r.rc == 2 and not built
    line = one_line(r.err)
    assert f"--out {out}" in line and expect in line
    assert_untouched(before, work.dir)


def test_rerun_without_gt_removes_the_old_metrics(work, cli):
    r = cli("run", work.config, "--video", work.video, "--out", work.out, "--quiet")
    assert r.rc == 0
    assert not (work.out / "metrics.json").exists()
    assert (work.out / "tracks.txt").read_text() != "1,1,1,1,5,5,1,-1,-1,-1\n"
    names = sorted(p.name for p in (work.out / "report").iterdir())
    assert "overlay_000001.png" in names
    assert (work.out / "report" / "overlay_000001.png").read_bytes() != b"old picture"
    assert sorted(p.name for p in work.out.iterdir()) == ["report", "tracks.txt",
                                                          "tracks_uncertainty.csv"]


def test_rerun_without_report_removes_the_old_report(work, cli):
    r = cli("run", work.config, "--video", work.video, "--out", work.out, "--gt", work.gt,
            "--quiet", "--no-report")
    assert r.rc == 0
    assert sorted(p.name for p in work.out.iterdir()) == ["metrics.json", "tracks.txt",
                                                          "tracks_uncertainty.csv"]
    assert json.loads((work.out / "metrics.json").read_text())["frames_tracked"] == 24


def test_killed_runs_leftovers_are_removed_on_the_next_start(work, cli):
    stale = work.out / ".pftrack-staging-999999"
    (stale / "new").mkdir(parents=True)
    (stale / "new" / "tracks.txt").write_text("half")
    tmp_png = work.out / "report" / ".overlay_000001.abc123.tmp.png"
    tmp_png.write_bytes(b"half a picture")
    tmp_txt = work.out / ".tracks.xyz.tmp.txt"
    tmp_txt.write_text("half")
    r = cli("run", work.config, "--video", work.video, "--out", work.out, "--quiet")
    assert r.rc == 0
    left = [p.name for p in work.out.rglob("*") if p.name.startswith(".")]
    assert left == []


def test_journalled_move_is_completed_on_the_next_start(tmp_path):
    """A run killed during the move of its outputs: the next start finishes the move, so the
    folder never mixes two runs."""
    from pftrack.io.outputs import OutputSet, clean_stale

    out = tmp_path / "o"
    out.mkdir()
    (out / "tracks.txt").write_text("old")
    (out / "metrics.json").write_text("old")
    staging = out / ".pftrack-staging-1"
    (staging / "new").mkdir(parents=True)
    (staging / "new" / "tracks.txt").write_text("new")
    (staging / "COMMIT.json").write_text(json.dumps(
        {"names": ["tracks.txt", "metrics.json", "report"], "produced": ["tracks.txt"]}))
    clean_stale(out)
    assert sorted(p.name for p in out.iterdir()) == ["tracks.txt"]
    assert (out / "tracks.txt").read_text() == "new"
    # without a journal the staged files are dropped and the old outputs stay
    (staging / "new").mkdir(parents=True)
    (staging / "new" / "tracks.txt").write_text("newer")
    clean_stale(out)
    assert (out / "tracks.txt").read_text() == "new" and not staging.exists()
    with OutputSet(out, ["tracks.txt", "x.json"]) as o:
        o.path("tracks.txt").write_text("third")
        with pytest.raises(ValueError, match="not one of this run's outputs"):
            o.path("other")
    assert (out / "tracks.txt").read_text() == "third"


class _BrokenWriter:
    def __call__(self, out_dir, rows, frames, **kw):
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        (Path(out_dir) / "overlay_000001.png").write_bytes(b"new")
        raise OSError(28, "No space left on device", str(Path(out_dir) / "x.png"))


def test_failure_while_writing_leaves_the_previous_outputs(work, cli, plugin_host):
    from pftrack import hookimpl
    from pftrack.contracts.extensions import ReportWriter

    class P:
        @hookimpl
        def pftrack_register_report_writers(self, register):
            register("broken", ReportWriter(summary="fails", write=_BrokenWriter()))

    plugin_host(("broken-writer", P()))
    cfg = work.dir / "c.yaml"
    cfg.write_text(work.config.read_text() + "report: {writer: broken}\n")
    before = snapshot(work.out)
    r = cli("run", cfg, "--video", work.video, "--gt", work.gt, "--out", work.out, "--quiet")
    assert r.rc == 2
    assert "no space left on the device" in one_line(r.err) and "x.png" in one_line(r.err)
    assert_untouched(before, work.out)
    assert not list(work.out.glob(".pftrack-staging-*"))


# ---- other commands' outputs -----------------------------------------------------------------

def _cases(tmp: Path) -> dict[str, list[str]]:
    cam = str(Path(__file__).resolve().parents[4] / "calib" / "soccer_camera.yaml")
    tracks = tmp / "tracks.txt"
    tracks.write_text("1,1,10,20,14,14,1,1.0,2.0,0.0\n2,1,11,20,14,14,1,1.1,2.0,0.0\n")
    return {
        "calib-convert": ["calib", "convert", cam, "{out}.yaml"],
        "render-topview": ["render", "topview", str(tracks), "--out", "{out}.png"],
        "bench": ["bench", "core", "--out", "{out}.json"],
        "demo": ["demo", "--out", "{out}"],
        "eval": ["eval", str(tracks), str(tracks), "--out", "{out}.json"],
        "detector-train": ["detector", "train", "--video", "{video}", "--gt", "{gt}",
                           "--frames", "1:5", "--out", "{out}.npz", "--quiet"],
    }


@pytest.mark.parametrize("command", ["calib-convert", "render-topview", "bench", "demo", "eval",
                                     "detector-train"])
@pytest.mark.parametrize("where", ["under-file", "deep-under-file"])
def test_output_under_a_regular_file(work, cli, command, where):
    (work.dir / "plain").write_text("a file\n")
    out = work.dir / "plain" / "o" if where == "under-file" else work.dir / "plain" / "a" / "o"
    args = [a.format(out=out, video=work.video, gt=work.gt) for a in _cases(work.dir)[command]]
    before = snapshot(work.dir)
    r = cli(*args)
    assert r.rc == 2
    line = one_line(r.err)
    assert str(work.dir / "plain") in line and "is a file, not a folder" in line
    assert_untouched(before, work.dir)


def test_detector_train_out_is_a_folder(work, cli):
    (work.dir / "m.npz").mkdir()
    before = snapshot(work.dir)
    r = cli("detector", "train", "--video", work.video, "--gt", work.gt, "--frames", "1:5",
            "--out", work.dir / "m.npz", "--quiet")
    assert r.rc == 2
    assert f"--out {work.dir / 'm.npz'}: is a folder" in one_line(r.err)
    assert_untouched(before, work.dir)


@pytest.mark.parametrize("size", ["100000x100000", "9000x10", "10x10", "axb", "0x0"])
def test_topview_size(tmp_path, cli, size):
    tracks = tmp_path / "t.txt"
    tracks.write_text("1,1,10,20,14,14,1,1.0,2.0,0.0\n")
    before = snapshot(tmp_path)
    r = cli("render", "topview", tracks, "--out", tmp_path / "top.png", "--size", size)
    assert r.rc == 2
    assert "--size" in one_line(r.err)
    assert_untouched(before, tmp_path)


def test_topview_out_not_png(tmp_path, cli):
    tracks = tmp_path / "t.txt"
    tracks.write_text("1,1,10,20,14,14,1,1.0,2.0,0.0\n")
    before = snapshot(tmp_path)
    r = cli("render", "topview", tracks, "--out", tmp_path / "top.jpg")
    assert r.rc == 2 and "top.jpg" in one_line(r.err)
    assert_untouched(before, tmp_path)


# ---- read-only folder and full disk (tmpfs mounts; root only) ---------------------------------

def _mount(path: Path, options: str) -> None:
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    path.mkdir(parents=True, exist_ok=True)
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                          capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {proc.stderr.strip()}")


@pytest.fixture
def mounts():
    done: list[Path] = []

    def mount(path: Path, options: str) -> Path:
        _mount(path, options)
        done.append(path)
        return path

    yield mount
    for p in reversed(done):
        subprocess.run(["umount", "-l", str(p)], check=False)


def test_read_only_output_folder(work, cli, mounts, monkeypatch):
    ro = work.dir / "ro"
    mounts(ro, "size=1m")
    (ro / "out").mkdir()
    (ro / "out" / "tracks.txt").write_text("old\n")
    subprocess.run(["mount", "-o", "remount,ro", str(ro)], check=True)
    built = _no_tracking(monkeypatch)
    before = snapshot(ro)
    r = cli("run", work.config, "--video", work.video, "--out", ro / "out", "--quiet")
    assert r.rc == 2 and not built
    line = one_line(r.err)
    assert f"--out {ro / 'out'}" in line and "not writable" in line
    assert_untouched(before, ro)


@pytest.mark.parametrize("command", ["calib-convert", "bench", "eval"])
def test_read_only_folder_other_commands(work, cli, mounts, command):
    ro = work.dir / "ro"
    mounts(ro, "size=1m,ro")
    out = ro / "o"
    args = [a.format(out=out, video=work.video, gt=work.gt) for a in _cases(work.dir)[command]]
    r = cli(*args)
    assert r.rc == 2
    assert "not writable" in one_line(r.err) and str(ro) in one_line(r.err)
    assert list(ro.iterdir()) == []


def test_full_disk_leaves_the_previous_outputs(work, cli, mounts):
    small = work.dir / "small"
    mounts(small, "size=48k")
    out = small / "out"
    (out / "report").mkdir(parents=True)
    (out / "tracks.txt").write_text("old\n")
    (out / "metrics.json").write_text('{"MOTA": 0.5}\n')
    # fill the disk but for a few kilobytes: the new tracks fit, the report pictures do not
    filler = small / "filler"
    with filler.open("wb") as fh:
        try:
            fh.write(b"\0" * (40 * 1024))
        except OSError:
            pass
    before = snapshot(out)
    r = cli("run", work.config, "--video", work.video, "--gt", work.gt, "--out", out, "--quiet")
    assert r.rc == 2
    line = one_line(r.err)
    assert "no space left on the device" in line and str(out) in line
    assert_untouched(before, out)
    assert not list(out.glob(".pftrack-staging-*"))
