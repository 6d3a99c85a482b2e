"""Top view renders: reference image, determinism, legend inside the picture, the CLI on PETS."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import MEAN_ABS_TOL, compare_reference
from pftrack.geometry.clouds import ParticleCloud
from pftrack.geometry.volumes import resolve_volume
from pftrack.render.topview import render_topview


def _scene():
    t = np.linspace(0, 1, 40)
    tracks = {3: np.column_stack([-30 + 50 * t, -20 + 30 * t, 0 * t]),
              7: np.column_stack([20 - 40 * t, 25 * np.sin(3 * t), 0 * t])}
    gt = {k: v + [1.5, -1.0, 0.0] for k, v in tracks.items()}
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.normal(10, 3, 300), rng.normal(5, 2, 300), np.zeros(300)])
    w = np.exp(-0.5 * ((pts[:, 0] - 10) ** 2 / 9 + (pts[:, 1] - 5) ** 2 / 4))
    return tracks, gt, resolve_volume("pitch"), [ParticleCloud(pts, w)]


def _render(out=None):
    tracks, gt, vol, clouds = _scene()
    return render_topview(out, tracks=tracks, ground_truth=gt, volume=vol, clouds=clouds,
                          size_wh=(320, 240), title="test")


def test_topview_matches_reference():
    img = _render()
    assert img.shape == (240, 320, 3) and img.dtype == np.uint8
    diff = compare_reference("topview_320x240.png", img)
    print(f"topview mean abs diff vs reference: {diff:.4f}")
    assert diff < MEAN_ABS_TOL


def test_topview_is_deterministic(tmp_path):
    a = _render(tmp_path / "a.png")
    b = _render(tmp_path / "b.png")
    assert np.array_equal(a, b)
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


def test_topview_draws_tracks_in_their_colours():
    from pftrack.render.colours import track_colours_rgb

    img = _render()
    for tid in (3, 7):
        c = track_colours_rgb(np.array([tid]))[0].astype(int)
        hits = np.all(np.abs(img.astype(int) - c) <= 10, axis=2).sum()
        assert hits > 40, (tid, hits)


def test_zoomed_topview_is_cut_to_its_frame():
    """With bounds_m, tracks that run past the shown box stop at its frame: nothing is drawn
    over the axis labels, the title or the legend (VTK clipping planes on the data actors)."""
    from pftrack.render.colours import track_colours_rgb

    tracks, _, vol, _ = _scene()
    zoom = np.array([[-10.0, -10.0], [5.0, 5.0]])
    img = render_topview(tracks=tracks, volume=vol, bounds_m=zoom, size_wh=(320, 240),
                         legend=False)
    colour = track_colours_rgb(np.array([3]))[0].astype(int)
    hit = np.all(np.abs(img.astype(int) - colour) <= 10, axis=2)
    rows, cols = np.nonzero(hit)
    assert len(rows) > 40  # the part of track 3 inside the box is drawn
    # the framed box is the grey rectangle; find its extent from the frame colour (120)
    frame = np.all(img == 120, axis=2)
    fr, fc = np.nonzero(frame)
    assert rows.min() >= fr.min() - 2 and rows.max() <= fr.max() + 2
    assert cols.min() >= fc.min() - 2 and cols.max() <= fc.max() + 2
    # track 3 crosses the whole pitch: unclipped it would reach the picture's left part
    full = render_topview(tracks=tracks, volume=vol, size_wh=(320, 240), legend=False)
    assert np.all(np.abs(full.astype(int) - colour) <= 10, axis=2).sum() > 0


def test_topview_legend_inside_picture():
    """The legend (drawn after rendering) lies fully inside the picture, in the lower right."""
    from pftrack.render.topview import draw_legend

    blank = np.full((240, 320, 3), 255, np.uint8)
    entries = [("estimate (solid, colour = id)", (0, 0, 0), "line"),
               ("ground truth (dashed)", (128, 128, 128), "dash"),
               ("particles (viridis = weight)", (33, 145, 140), "dot"),
               ("pitch", (70, 140, 70), "line")]
    img = draw_legend(blank, entries, scale=240 / 600)
    rows, cols = np.nonzero(np.any(img != 255, axis=2))
    assert len(rows) > 200
    assert rows.max() < 239 and cols.max() < 319  # a margin to the edges
    assert rows.min() > 120 and cols.min() > 100   # lower right
    assert np.all(blank == 255)  # input untouched


def test_topview_rejects_non_png(tmp_path):
    with pytest.raises(ValueError, match="png"):
        _render(tmp_path / "x.jpg")
    assert not (tmp_path / "x.jpg").exists()


def _pets_gt() -> Path:
    from pftrack.io.data import data_dir

    p = data_dir() / "pets09" / "gt.txt"
    if not p.is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    return p


def test_cli_topview_on_pets_gt(tmp_path, capsys):
    from pftrack.cli import main

    gt = _pets_gt()
    out = tmp_path / "top.png"
    assert main(["render", "topview", str(gt), "--out", str(out), "--gt", str(gt),
                 "--size", "400x300", "--title", "PETS"]) == 0
    img = cv2.imread(str(out))
    assert img.shape == (300, 400, 3)
    # many non-white, coloured pixels (19 trajectories)
    sat = img.max(axis=2).astype(int) - img.min(axis=2)
    assert (sat > 60).sum() > 2000


def test_cli_topview_with_volume_and_errors(tmp_path, capsys):
    from pftrack.cli import main

    gt = _pets_gt()
    assert main(["render", "topview", str(gt), "--out", str(tmp_path / "v.png"),
                 "--volume", "pitch"]) == 0
    assert main(["render", "topview", str(tmp_path / "missing.txt"), "--out",
                 str(tmp_path / "m.png")]) == 2
    assert "missing.txt" in capsys.readouterr().err
    bad = tmp_path / "bad.txt"
    bad.write_text("1,2,3\nhello\n")
    assert main(["render", "topview", str(bad), "--out", str(tmp_path / "b.png")]) == 2
    assert "bad.txt" in capsys.readouterr().err
    assert not (tmp_path / "b.png").exists() and not (tmp_path / "m.png").exists()
