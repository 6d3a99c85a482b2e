"""Catalogue: bad MOTChallenge files, as ground truth of ``pftrack eval`` and ``pftrack run
--gt`` and as tracks of ``pftrack render topview``. Each case asserts exit 2, a one-line message
naming the file (and the line where there is one), and that nothing on disk changed; a bad
ground truth of ``pftrack run`` is found before any frame is tracked."""

from __future__ import annotations

import pytest

from ._catalogue import assert_untouched, one_line, snapshot

GOOD = "1,1,10,20,14,14,1,-1,-1,-1\n2,1,12,21,14,14,1,-1,-1,-1\n"

# (case id, file text, text the message must contain besides the file name)
CASES = [
    ("too-few-columns", "1,1,10,20,14\n", "line 1: expected 6 to 10 comma-separated columns"),
    ("too-many-columns", "1,1,10,20,14,14,1,-1,-1,-1,9\n", "line 1: expected 6 to 10"),
    ("word", "1,1,ten,20,14,14\n", "line 1: non-numeric value"),
    ("nan", "1,1,nan,20,14,14\n", "line 1: NaN or infinite value"),
    ("inf", "1,1,10,inf,14,14\n", "line 1: NaN or infinite value"),
    ("fractional-frame", "1.5,1,10,20,14,14\n", "line 1: frame and id must be integers"),
    ("fractional-id", "1,2.25,10,20,14,14\n", "line 1: frame and id must be integers"),
    ("negative-width", "1,1,10,20,-14,14\n", "line 1: negative box width/height"),
    ("negative-height", "1,1,10,20,14,-1\n", "line 1: negative box width/height"),
    ("frame-zero", "0,1,10,20,14,14\n", "line 1: frame 0 must be >= 1"),
    ("frame-negative", "-3,1,10,20,14,14\n", "line 1: frame -3 must be >= 1"),
    ("id-below-minus-one", "1,-2,10,20,14,14\n", "line 1: id -2 must be >= 0"),
    ("id-above-2-63", "1,9223372036854775808,10,20,14,14\n",
     "line 1: id 9223372036854775808 is too large"),
    ("id-above-2-64", "1,18446744073709551617,10,20,14,14\n", "is too large"),
    ("id-above-2-53", "1,9007199254740993,10,20,14,14\n", "is too large"),
    ("frame-huge", "99999999999999999999,1,10,20,14,14\n", "frame 99999999999999999999 is too"),
    ("duplicate-id", GOOD + "2,1,30,30,14,14,1,-1,-1,-1\n",
     "line 3: id 1 appears twice in frame 2 (first at line 2)"),
    ("bad-later-line", GOOD + "3,1,10,20\n", "line 3: expected 6 to 10"),
    ("semicolons", "1;1;10;20;14;14\n", "line 1"),
    ("empty-field", "1,,10,20,14,14\n", "line 1: non-numeric value"),
    ("hex", "0x1,1,10,20,14,14\n", "line 1: non-numeric value"),
]


@pytest.mark.parametrize(("text", "expect"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_ground_truth_in_eval(tmp_path, cli, text, expect):
    bad = tmp_path / "gt.txt"
    bad.write_text(text)
    tracks = tmp_path / "tracks.txt"
    tracks.write_text(GOOD)
    before = snapshot(tmp_path)
    r = cli("eval", bad, tracks, "--json", "--out", tmp_path / "m.json")
    assert r.rc == 2
    line = one_line(r.err)
    assert str(bad) in line and expect in line
    assert_untouched(before, tmp_path)


@pytest.mark.parametrize(("text", "expect"), [c[1:] for c in CASES[::3]],
                         ids=[c[0] for c in CASES[::3]])
def test_bad_tracks_in_eval(tmp_path, cli, text, expect):
    gt = tmp_path / "gt.txt"
    gt.write_text(GOOD)
    bad = tmp_path / "tracks.txt"
    bad.write_text(text)
    before = snapshot(tmp_path)
    r = cli("eval", gt, bad)
    assert r.rc == 2
    line = one_line(r.err)
    assert str(bad) in line and expect in line
    assert_untouched(before, tmp_path)


@pytest.mark.parametrize(("text", "expect"), [c[1:] for c in CASES[1::4]],
                         ids=[c[0] for c in CASES[1::4]])
def test_bad_ground_truth_stops_a_run_before_tracking(work, cli, monkeypatch, text, expect):
    from pftrack.workflows import pipeline

    bad = work.dir / "gt.txt"
    bad.write_text(text)
    built = []
    monkeypatch.setattr(pipeline, "build_engine", lambda *a, **k: built.append(1))
    before = snapshot(work.dir)
    r = cli("run", work.config, "--video", work.video, "--gt", bad, "--out", work.out,
            "--quiet")
    assert r.rc == 2 and not built  # refused before the engine was even built
    line = one_line(r.err)
    assert str(bad) in line and expect in line
    assert_untouched(before, work.dir)


@pytest.mark.parametrize("what", ["missing", "folder", "unreadable"])
def test_ground_truth_path_checked_before_tracking(work, cli, monkeypatch, what):
    import os

    from pftrack.workflows import pipeline

    gt = work.dir / "gt.txt"
    if what == "folder":
        gt.mkdir()
    elif what == "unreadable":
        if os.geteuid() == 0:
            pytest.skip("root reads every file")
        gt.write_text(GOOD)
        gt.chmod(0)
    built = []
    monkeypatch.setattr(pipeline, "build_engine", lambda *a, **k: built.append(1))
    before = snapshot(work.dir)
    r = cli("run", work.config, "--video", work.video, "--gt", gt, "--out", work.out,
            "--quiet")
    assert r.rc == 2 and not built
    line = one_line(r.err)
    assert f"--gt {gt}" in line
    assert_untouched(before, work.dir)


def test_eval_missing_file(tmp_path, cli):
    r = cli("eval", tmp_path / "none.txt", tmp_path / "none2.txt")
    assert r.rc == 2 and "none.txt" in one_line(r.err)
    assert list(tmp_path.iterdir()) == []


def test_topview_skips_unknown_world_positions(tmp_path, cli):
    """Rows whose world position is unknown (x, y, z all -1) are not drawn at (-1, -1) m: a file
    with only such rows is refused, naming it."""
    tracks = tmp_path / "tracks.txt"
    tracks.write_text("1,1,10,20,14,14,1,-1,-1,-1\n2,1,11,20,14,14,1,-1,-1,-1\n")
    before = snapshot(tmp_path)
    r = cli("render", "topview", tracks, "--out", tmp_path / "top.png")
    assert r.rc == 2
    line = one_line(r.err)
    assert str(tracks) in line and "known (not -1) world positions" in line
    assert_untouched(before, tmp_path)


def test_topview_world_positions_keep_known_rows():
    import numpy as np
    from pftrack.render.tracks import tracks_from_mot

    rows = np.array([[1, 1, 0, 0, 1, 1, 1, -1, -1, -1],
                     [2, 1, 0, 0, 1, 1, 1, 3.0, 4.0, 0.0],
                     [3, 1, 0, 0, 1, 1, 1, -1.0, 2.0, 0.0]])  # one -1 is a coordinate
    out = tracks_from_mot(rows)
    assert out[1][:, :2].tolist() == [[3.0, 4.0], [-1.0, 2.0]]
