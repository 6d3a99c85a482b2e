"""Catalogue: bad videos and frame ranges. Unreadable videos and impossible ranges: exit 2, a
one-line message naming the video or ``--frames``, nothing on disk changed. Videos that decode
but not as announced (truncated, short of the range, black): the run finishes, says so in one
warning line, and with ``--gt`` scores only the frames it tracked."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ._catalogue import (
    N_FRAMES,
    assert_untouched,
    damage_middle,
    marked_frames,
    one_line,
    read_mark,
    snapshot,
    write_video,
)


def _warned(recwarn) -> str:
    """The run's warnings, one per line (the command line prints them as one line each)."""
    return "\n".join(str(w.message) for w in recwarn)


def _run(cli, work, video, *extra):
    return cli("run", work.config, "--video", video, "--out", work.out, "--quiet", *extra)


@pytest.mark.parametrize(("make", "expect"), [
    ("missing", "not found"),
    ("folder", "is a folder"),
    ("text", "OpenCV cannot decode it"),
    ("empty", "OpenCV cannot decode it"),
    ("random-bytes", "OpenCV cannot decode it"),
])
def test_unreadable_video(work, cli, make, expect):
    v = work.dir / "v.avi"
    if make == "folder":
        v.mkdir()
    elif make == "text":
        v.write_text("this is not a video\n" * 50)
    elif make == "empty":
        v.write_bytes(b"")
    elif make == "random-bytes":
        v.write_bytes(np.random.default_rng(0).integers(0, 256, 50_000, dtype=np.uint8)
                      .tobytes())
    before = snapshot(work.dir)
    r = _run(cli, work, v)
    assert r.rc == 2
    line = one_line(r.err)
    assert str(v) in line and expect in line
    assert_untouched(before, work.dir)


@pytest.mark.parametrize(("frames_arg", "expect"), [
    ("100:120", f"has {N_FRAMES} frames"),
    (f"{N_FRAMES + 1}:", f"has {N_FRAMES} frames"),
    ("900:950", f"has {N_FRAMES} frames"),
    ("0:3", "need 1 <= A <= B"),
    ("-2:3", "need 1 <= A <= B"),
    ("9:3", "need 1 <= A <= B"),
    ("a:b", "--frames must look like A:B"),
    ("1.5:3", "--frames must look like A:B"),
    ("1:2:3", "--frames must look like A:B"),
])
def test_impossible_frame_range(work, cli, frames_arg, expect):
    before = snapshot(work.dir)
    r = _run(cli, work, work.video, f"--frames={frames_arg}")
    assert r.rc == 2
    line = one_line(r.err)
    assert expect in line and ("--frames" in line or str(work.video) in line)
    assert_untouched(before, work.dir)


def test_range_past_the_end_is_a_short_read(work, cli, recwarn):
    r = _run(cli, work, work.video, "--frames", f"{N_FRAMES - 4}:{N_FRAMES + 10}", "--gt",
             work.gt)
    assert r.rc == 0
    assert "short read" in _warned(recwarn) and str(work.video) in _warned(recwarn)
    m = json.loads((work.out / "metrics.json").read_text())
    assert m["frames_tracked"] == 5 and m["gt_frames_scored"] == 5
    tracks = np.loadtxt(work.out / "tracks.txt", delimiter=",", ndmin=2)
    assert tracks.size == 0 or tracks[:, 0].max() <= N_FRAMES


def test_truncated_video_scores_only_the_tracked_frames(work, cli, recwarn):
    data = work.video.read_bytes()
    v = work.dir / "trunc.avi"
    v.write_bytes(data[: int(len(data) * 0.5)])
    r = _run(cli, work, v, "--gt", work.gt)
    assert r.rc == 0
    said = _warned(recwarn)
    assert f"video {v}: short read" in said and "cannot be trusted" in said
    assert "scored over the" in said and f"of {N_FRAMES} in frames" in said
    m = json.loads((work.out / "metrics.json").read_text())
    assert 0 < m["frames_tracked"] < N_FRAMES
    assert m["gt_frames_scored"] == m["frames_tracked"]
    assert m["gt_frames_in_range"] == N_FRAMES
    assert m["frame_numbers_verified"] is False
    assert m["FN"] + m["TP"] == m["frames_tracked"]  # one person per scored frame


def test_black_frames_scored_only_where_tracked(work, cli, recwarn):
    """40 black frames against 795 frames of ground truth was scored against all 795: here 10
    black frames against 24, scored over 10."""
    v = write_video(work.dir / "black.avi", [np.zeros((72, 96, 3), np.uint8)] * 10)
    r = _run(cli, work, v, "--gt", work.gt)
    assert r.rc == 0
    m = json.loads((work.out / "metrics.json").read_text())
    assert m["frames_tracked"] == 10 and m["gt_frames_scored"] == 10
    assert m["TP"] + m["FN"] == 10 and m["TP"] == 0
    assert "scored over the 10 ground-truth frames that were tracked, of 24" in _warned(recwarn)


def test_complete_video_is_verified(work, cli, recwarn):
    from pftrack.workflows.pipeline import FrameWarning

    r = _run(cli, work, work.video, "--gt", work.gt)
    assert r.rc == 0 and not [w for w in recwarn if issubclass(w.category, FrameWarning)]
    m = json.loads((work.out / "metrics.json").read_text())
    assert m["frames_tracked"] == N_FRAMES == m["gt_frames_scored"]
    assert m["frame_numbers_verified"] is True and m["frame_problems"] == []


def test_frame_source_numbers_and_report(inputs):
    from pftrack.scenes.source import FrameSource

    s = FrameSource(inputs.video, 5, 9)
    idx = [f.index for f in s.frames()]
    assert idx == [5, 6, 7, 8, 9]
    assert s.report.problems() == [] and not s.report.short
    s = FrameSource(inputs.video, N_FRAMES - 1, N_FRAMES + 3)
    assert [f.index for f in s.frames()] == [N_FRAMES - 1, N_FRAMES]
    assert s.report.short and not s.report.lost_inside


def test_detector_train_on_black_frames(work, cli):
    v = write_video(work.dir / "black.avi", [np.zeros((240, 320, 3), np.uint8)] * 6)
    gt = work.dir / "gt_big.txt"
    gt.write_text("".join(f"{i},1,100,50,48,96,1,-1,-1,-1\n" for i in range(1, 7)))
    before = snapshot(work.dir)
    r = cli("detector", "train", "--video", v, "--gt", gt, "--frames", "1:6", "--out",
            work.dir / "m.npz", "--quiet")
    assert r.rc == 2
    line = one_line(r.err)
    assert f"--video {v}" in line and "no signal" in line
    assert_untouched(before, work.dir)


@pytest.mark.parametrize("what", ["video", "gt"])
def test_detector_train_inputs_missing(work, cli, what):
    args = {"video": work.video, "gt": work.gt}
    args[what] = work.dir / "none"
    before = snapshot(work.dir)
    r = cli("detector", "train", "--video", args["video"], "--gt", args["gt"], "--frames", "1:5",
            "--out", work.dir / "m.npz", "--quiet")
    assert r.rc == 2
    label = "video" if what == "video" else "--gt"
    assert f"{label} {work.dir / 'none'} not found" in one_line(r.err)
    assert_untouched(before, work.dir)


def test_overlay_frame_beyond_the_video(work, cli, inputs):
    tracks = work.dir / "t.txt"
    tracks.write_text("1,1,10,20,14,14,1,-1,-1,-1\n")
    before = snapshot(work.dir)
    r = cli("render", "overlay", "--video", inputs.video, "--frame", "500", "--tracks", tracks,
            "--out", work.dir / "o.png")
    assert r.rc == 2
    line = one_line(r.err)
    assert str(inputs.video) in line and f"has {N_FRAMES} frames" in line
    assert_untouched(before, work.dir)


@pytest.mark.parametrize("fourcc", ["mp4v", "XVID"])
def test_damaged_avi_keeps_true_frame_numbers(work, fourcc):
    """Random bytes over the middle of an AVI: OpenCV drops the damaged frames and counts on,
    so every later frame was misnumbered (PETS: MOTA 0.90 -> -0.84 with exit 0). The file's
    AVI index shows which frames are damaged; the frames after them keep their numbers."""
    from pftrack.scenes.source import FrameSource, avi_intact_frames

    v = write_video(work.dir / "m.avi", marked_frames(60), fourcc=fourcc)
    bad = damage_middle(v, work.dir / "bad.avi")
    intact = avi_intact_frames(bad)
    damaged = [k + 1 for k, ok in enumerate(intact) if not ok]
    assert avi_intact_frames(v) == [True] * 60 and 0 < len(damaged) < 20
    s = FrameSource(bad)
    got = [(f.index, read_mark(f.image)) for f in s.frames()]
    after = [(i, m) for i, m in got if i > damaged[-1]]
    assert after and all(i == m for i, m in after)  # was: every one off by len(damaged)
    assert [i for i, m in got if i < damaged[0] - 1 and i != m] == []
    assert s.report.index_verified and s.report.numbers_trusted
    assert s.report.gaps == [(damaged[0], len(damaged))]
    assert f"{len(damaged)} frame(s) missing (frames {damaged[0]}-{damaged[-1]}): damaged in " \
        "the file" in s.report.problems()[0]
    s = FrameSource(bad, damaged[0] - 3, damaged[-1] + 3)  # a range across the damage
    assert [f.index for f in s.frames()] == [*range(damaged[0] - 3, damaged[0]),
                                             *range(damaged[-1] + 1, damaged[-1] + 4)]


def test_damaged_run_scores_true_frames(work, cli, recwarn):
    images = marked_frames(N_FRAMES)
    v = write_video(work.dir / "m.avi", images, fourcc="mp4v")
    bad = damage_middle(v, work.dir / "bad.avi", fraction=1 / 5)
    r = _run(cli, work, bad, "--gt", work.gt, "--no-report")
    assert r.rc == 0
    m = json.loads((work.out / "metrics.json").read_text())
    assert m["frame_numbers_verified"] is True
    assert m["frames_tracked"] == m["gt_frames_scored"] < N_FRAMES
    assert "damaged in the file" in _warned(recwarn)


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_damaged_mjpg_numbers_are_right_or_not_claimed(work, seed):
    """Whatever the damage does to the stream, a number is either right or said to be
    untrusted: never silently wrong."""
    from pftrack.scenes.source import FrameSource

    v = write_video(work.dir / "m.avi", marked_frames(60, seed=seed))
    bad = damage_middle(v, work.dir / "bad.avi", seed=seed)
    s = FrameSource(bad)
    got = [(f.index, read_mark(f.image)) for f in s.frames()]
    rep = s.report
    first_damaged = rep.index_damaged[0]
    if rep.numbers_trusted:
        assert all(i == m for i, m in got if i > rep.index_damaged[-1] or i < first_damaged - 1)
    else:
        assert any("cannot be trusted" in p for p in rep.problems())


def test_untrusted_report_says_so():
    from pftrack.scenes.source import FrameReport

    rep = FrameReport("v.avi", 1, None, frame_count=60, indices=list(range(1, 30)),
                      ended_at=30, index_damaged=[31, 32], index_verified=False)
    assert not rep.numbers_trusted
    assert "frame numbers after the first damaged frame cannot be trusted" in rep.problems()[0]
    rep = FrameReport("v.avi", 1, None, frame_count=60, indices=list(range(1, 40)), ended_at=40)
    assert rep.lost_inside and not rep.numbers_trusted and "truncated" in rep.problems()[0]


def test_training_frames_short_read_is_warned(work):
    """A detector trained on a truncated file said nothing: the frame stream warns."""
    from pftrack.workflows.pipeline import FrameWarning, iter_frames

    data = work.video.read_bytes()
    trunc = work.dir / "t.avi"
    trunc.write_bytes(data[: len(data) // 2])
    with pytest.warns(FrameWarning, match=f"video {trunc}: short read: frames 1..{N_FRAMES}"):
        got = [f.index for f in iter_frames(trunc, 1, N_FRAMES)]
    assert 0 < len(got) < N_FRAMES and got == list(range(1, len(got) + 1))


def test_run_detections_file_missing(work, cli, monkeypatch):
    # checked before the first frame: no tracking, nothing written
    from pftrack.workflows import pipeline

    def no_engine(*a, **k):
        raise AssertionError("the engine was built before --detections was checked")

    monkeypatch.setattr(pipeline, "build_engine", no_engine)
    before = snapshot(work.dir)
    r = cli("run", work.config, "--video", work.video, "--detections", work.dir / "none.txt",
            "--out", work.dir / "out", "--quiet")
    assert r.rc == 2
    assert f"--detections {work.dir / 'none.txt'} not found" in one_line(r.err)
    assert_untouched(before, work.dir)
