"""What the command line tells its user: the report's frames (first, 50 later, middle, last,
with or without ``--frames``), the progress bar's label (the command the user ran), the
presets' ``[state]`` tags, the people camera's focal-length messages agreeing with each other,
the getting-started page's account of the camera fit agreeing with the code, and ``./dev``
neither re-pointing another checkout's environment nor reinstalling when only a file's time
changed."""

from __future__ import annotations

import hashlib
import inspect
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from bad_inputs._catalogue import CONFIG  # the smallest runnable configuration
from pftrack.cli import main
from pftrack.workflows.pipeline import run_pipeline

ROOT = Path(__file__).resolve().parents[3]
W, H, SIDE = 96, 72, 14



@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    """A 60-frame 96 x 72 video of a bright square drifting right, and the tiny config."""
    import cv2

    d = tmp_path_factory.mktemp("clip")
    path = d / "clip.avi"
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (W, H))
    for i in range(60):
        img = np.full((H, W, 3), 60, np.uint8)
        x, y = 5 + i, 20 + (i % 5)
        img[y:y + SIDE, x:x + SIDE] = 230
        vw.write(img)
    vw.release()
    cfg = d / "tiny.yaml"
    cfg.write_text(CONFIG)
    return path, cfg


def _overlays(out: Path) -> list[int]:
    return sorted(int(p.stem.split("_")[1]) for p in (out / "report").glob("overlay_*.png"))


@pytest.mark.parametrize("frames, expected", [
    (None, [1, 30, 51, 60]),     # the whole video: its middle and last too
    ("3:41", [3, 22, 41]),      # 50 frames later lies beyond the range
    ("5:", [5, 32, 55, 60]),    # to the end: the middle of the frames announced
])
def test_report_draws_first_50_later_middle_and_last(clip, tmp_path, frames, expected):
    video, cfg = clip
    out = tmp_path / "run"
    res = run_pipeline(cfg, video=video, out_dir=out, frames=frames, progress=False)
    assert res.n_frames == expected[-1] - expected[0] + 1
    assert _overlays(out) == expected


def test_report_keeps_the_last_frame_decoded_when_the_count_is_unknown(clip, tmp_path,
                                                                        monkeypatch):
    from pftrack.scenes.source import FrameSource

    monkeypatch.setattr(FrameSource, "probe", lambda self: (10.0, 0))  # no frame count
    out = tmp_path / "run"
    run_pipeline(clip[1], video=clip[0], out_dir=out, progress=False)
    assert _overlays(out) == [1, 51, 60]


def test_progress_bar_says_the_command_the_user_ran(clip, tmp_path, capsys):
    video, cfg = clip
    run_pipeline(cfg, video=video, out_dir=None, frames="1:4", progress="pftrack track")
    err = capsys.readouterr().err
    assert "pftrack track (tiny)" in err and "pftrack run" not in err
    run_pipeline(cfg, video=video, out_dir=None, frames="1:4", progress=True)
    err = capsys.readouterr().err
    assert "tracking (tiny)" in err and "pftrack" not in err
    assert main(["run", str(cfg), "--video", str(video), "--out", str(tmp_path / "r"),
                 "--frames", "1:4", "--no-report"]) == 0
    assert "pftrack run (tiny)" in capsys.readouterr().err


def test_track_command_labels_its_bar_pftrack_track(clip, tmp_path, capsys):
    video, cfg = clip
    rows = [f"{i},-1,{5 + i - 1},{20 + (i - 1) % 5},{SIDE},{SIDE},0.9" for i in range(1, 9)]
    det = tmp_path / "det.txt"
    det.write_text("\n".join(rows) + "\n")
    assert main(["track", str(video), "--out", str(tmp_path / "t"), "--preset", str(cfg),
                 "--detections", str(det), "--frames", "1:8", "--no-report"]) == 0
    err = capsys.readouterr().err
    assert "pftrack track (tiny)" in err and "pftrack run" not in err


def test_presets_are_tagged_by_their_state_not_their_plugin(capsys):
    assert main(["presets"]) == 0
    lines = capsys.readouterr().out.splitlines()
    tag = {ln.split()[0]: ln.split()[1] for ln in lines if ln and not ln[0].isspace()}
    assert tag["people-image"] == "[image]" and tag["people-colour"] == "[image]"
    assert tag["people-ground"] == "[world]" and tag["pets09-ground"] == "[world]"
    assert any(ln.strip().endswith("people-image.yaml (plugin world)") for ln in lines)
    assert main(["presets", "--json"]) == 0
    items = {i["name"]: i for i in json.loads(capsys.readouterr().out)["presets"]}
    assert items["people-image"]["state"] == "image" and items["people-image"]["plugin"] == "world"


# -- the people camera's focal length, said one way --------------------------------------------


def _leaning_people(n, lean_sd, seed=8):
    from pftrack.geometry.people import camera_from_parameters

    rng = np.random.default_rng(seed)
    cam = camera_from_parameters(1300.0, 17.0, -3.0, 7.0, (768, 576))
    X, Y, Hm = rng.uniform(-12, 12, 4 * n), rng.uniform(6, 40, 4 * n), rng.normal(1.7, .07, 4 * n)
    foot = cam.project(np.column_stack([X, Y, np.zeros_like(X)]))
    head = cam.project(np.column_stack([X, Y, Hm]))
    ok = cam.in_image(foot, margin_px=3) & cam.in_image(head, margin_px=3)
    foot, head = foot[ok][:n], head[ok][:n]
    hh = foot[:, 1] - head[:, 1]
    boxes = np.column_stack([foot[:, 0] - 0.2 * hh, head[:, 1], 0.4 * hh, hh])
    ground = cam.image_to_ground(foot)
    lo, hi = cam.project(ground + [0, 0, 0.3 * 1.7]), cam.project(ground + [0, 0, 1.7])
    slants = (hi[:, 0] - lo[:, 0]) / (hi[:, 1] - lo[:, 1]) + rng.normal(0, lean_sd, len(foot))
    return boxes, slants


def test_focal_length_messages_agree_with_what_was_fitted():
    from pftrack.cli.calib import _focal_source
    from pftrack.geometry.people import PRIOR_LOG_FOCAL_SD, estimate_camera_from_people

    # few, noisy leans: fitted, but not narrowed to half the prior's width
    boxes, slants = _leaning_people(40, 0.3)
    fit = estimate_camera_from_people(boxes, (768, 576), slants=slants, n_bootstrap=20,
                                      rng=np.random.default_rng(0))
    assert fit.slants_used == 39 and not fit.focal_identified
    post = fit.uncertainty["focal_px"] / fit.focal_px
    assert post >= 0.5 * PRIOR_LOG_FOCAL_SD
    said = " ".join(fit.notes)
    assert "focal length from 39 leans" in said
    assert "it follows the prior" not in said  # it does not: 772 px, the prior's is 927
    assert (f"focal length not identified: fitted from the 39 leans and the heights to "
            f"{fit.focal_px:.0f} +- {fit.uncertainty['focal_px']:.0f} px (log-sd {post:.2f}"
            ) in said
    assert abs(fit.focal_px - 927.06) > 100
    assert _focal_source(fit) == " (fitted to 39 leans, not identified)"
    # many good leans: identified, and said so without a contradiction
    boxes, slants = _leaning_people(400, 0.03)
    good = estimate_camera_from_people(boxes, (768, 576), slants=slants, n_bootstrap=20,
                                       rng=np.random.default_rng(0))
    assert good.focal_identified and not any("not identified" in t for t in good.notes)
    assert _focal_source(good) == f" (from {good.slants_used} leans)"
    # no leans: the prior, said as such
    plain = estimate_camera_from_people(boxes, (768, 576), n_bootstrap=0)
    assert _focal_source(plain) == " (prior)"
    assert any(t.startswith("focal length not identified from boxes: the prior's 927.1 px")
               for t in plain.notes)


def test_the_track_video_page_says_which_frames_fit_the_camera():
    from pftrack.workflows.track import estimate_camera, track_video

    est = inspect.signature(estimate_camera).parameters
    every, first_n = est["every"].default, est["max_frames"].default
    min_boxes, scale = est["min_boxes"].default, est["silhouette_scale"].default
    score = inspect.signature(track_video).parameters["calib_min_score"].default
    assert (every, first_n, min_boxes, scale, score) == (2, 600, 20, 0.5, 0.5)
    text = " ".join((ROOT / "docs" / "tasks" / "track-video.md").read_text().split())
    assert (f"to the person boxes scoring at least {score:g} in every {every}nd of the first "
            f"{first_n} frames (counted from the first frame of `--frames`; every frame when "
            f"that leaves fewer than {min_boxes} boxes), each person's top, bottom and lean "
            f"measured in the moving pixels of those frames at half size") in text
    assert "first 200" not in text


# -- ./dev and the environment it is pointed at ------------------------------------------------


def _missing_system_packages() -> bool:
    text = (ROOT / "dev").read_text()
    names = text.split("SYSTEM_PACKAGES=(", 1)[1].split(")", 1)[0].split()
    if shutil.which("dpkg-query") is None:
        return True
    for n in names:
        r = subprocess.run(["dpkg-query", "-W", "-f=${Status}", n], capture_output=True,
                           text=True)
        if "install ok installed" not in r.stdout:
            return True
    return False


@pytest.fixture
def dev_copy(tmp_path):
    """``dev`` and ``pyproject.toml`` in a folder of their own, with a bare environment
    ``env`` (no pip) whose Python is this one's version."""
    for name in ("dev", "pyproject.toml", "benchmarks/pyproject.toml"):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        shutil.copy2(ROOT / name, tmp_path / name)
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(tmp_path / "env")],
                   check=True)
    return tmp_path


def _digest(folder: Path) -> str:
    """What ./dev's stamp records: the SHA-256 of the two pyproject.toml files, joined."""
    return hashlib.sha256((folder / "pyproject.toml").read_bytes()
                          + (folder / "benchmarks" / "pyproject.toml").read_bytes()).hexdigest()


def _fake_pftrack(env: Path, url: str) -> None:
    site = next(env.glob("lib/python3*/site-packages"))
    info = site / "pftrack-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: pftrack\nVersion: 0.1.0\n")
    (info / "direct_url.json").write_text(json.dumps({"url": url,
                                                      "dir_info": {"editable": True}}))


def _dev(folder: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PFTRACK_VENV": "env", "PYTHON": sys.executable}
    return subprocess.run([str(folder / "dev"), *args], capture_output=True, text=True,
                          env=env, timeout=120)


def test_dev_refuses_an_environment_with_pftrack_from_elsewhere(dev_copy, tmp_path_factory):
    other = tmp_path_factory.mktemp("another_checkout")
    _fake_pftrack(dev_copy / "env", other.as_uri())
    before = sorted(p.name for p in (dev_copy / "env").iterdir())
    for command in ("setup", "docs"):
        r = _dev(dev_copy, command)
        assert r.returncode == 1
        assert (f"dev: env has pftrack installed from {other.resolve()}, not from this checkout "
                f"({dev_copy.resolve()}): not re-pointing it") in r.stderr
        assert "installing" not in r.stdout
    assert sorted(p.name for p in (dev_copy / "env").iterdir()) == before


@pytest.mark.skipif(_missing_system_packages(), reason="./dev setup would install system "
                                                        "libraries first")
def test_dev_does_not_reinstall_when_only_the_time_changed(dev_copy):
    _fake_pftrack(dev_copy / "env", dev_copy.resolve().as_uri())
    stamp = dev_copy / "env" / ".pftrack-installed"
    digest = _digest(dev_copy)
    stamp.write_text(digest + "\n")
    t = stamp.stat().st_mtime
    os.utime(dev_copy / "pyproject.toml", (t + 60, t + 60))  # newer than the stamp, same text
    r = _dev(dev_copy, "setup")
    assert r.returncode == 0, r.stderr
    assert "installing" not in r.stdout
    # the older, empty stamp newer than pyproject.toml: up to date, given the hash
    stamp.write_text("")
    os.utime(dev_copy / "pyproject.toml", (t - 60, t - 60))
    r = _dev(dev_copy, "setup")
    assert r.returncode == 0 and "installing" not in r.stdout
    assert stamp.read_text().strip() == digest


@pytest.mark.skipif(_missing_system_packages(), reason="./dev setup would install system "
                                                        "libraries first")
def test_dev_is_not_fooled_by_the_checkouts_own_egg_info(dev_copy):
    # an editable install leaves pftrack.egg-info in the checkout; run from there, Python would
    # find it before the environment's own record of where pftrack comes from
    _fake_pftrack(dev_copy / "env", dev_copy.resolve().as_uri())
    egg = dev_copy / "pftrack.egg-info"
    egg.mkdir()
    (egg / "PKG-INFO").write_text("Metadata-Version: 2.1\nName: pftrack\nVersion: 0.1.0\n")
    stamp = dev_copy / "env" / ".pftrack-installed"
    stamp.write_text(_digest(dev_copy) + "\n")
    r = subprocess.run([str(dev_copy / "dev"), "setup"], capture_output=True, text=True,
                       cwd=dev_copy, timeout=120,
                       env={**os.environ, "PFTRACK_VENV": "env", "PYTHON": sys.executable})
    assert r.returncode == 0, r.stderr
    assert "not re-pointing" not in r.stderr
