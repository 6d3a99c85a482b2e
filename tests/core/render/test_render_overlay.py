"""OpenCV overlays: polylines broken at invalid points, vectorised points, a reference image,
and the PETS 2009 frame 200 check (projected GT ground points sit on the box foot points)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import MEAN_ABS_TOL, compare_reference
from pftrack.geometry.camera import Camera, OpenCVDistortion
from pftrack.geometry.clouds import ParticleCloud
from pftrack.geometry.volumes import CuboidVolume
from pftrack.render.overlay import (
    GROUND_DOT_BGR,
    draw_points,
    project_polylines,
    render_overlay,
)


def _camera(distortion=None) -> Camera:
    return Camera.look_at([0.0, -20.0, 8.0], [0.0, 0.0, 0.0], (320, 240), fx=300.0,
                          distortion=distortion)


def test_project_polylines_breaks_behind_camera():
    cam = _camera()
    # a line on the ground from in front of the camera to behind it (y = -20 is the camera)
    line = np.array([[0.0, 10.0, 0.0], [0.0, -40.0, 0.0]])
    pieces = project_polylines(cam, [line], step_m=0.5)
    assert len(pieces) == 1
    p = pieces[0]
    assert np.all(np.isfinite(p))
    # nothing beyond the far-outside margin
    assert p[:, 1].max() <= 1.5 * 240 and p[:, 1].min() >= -0.5 * 240
    # two separate lines stay separate, a gap in the middle splits one line in two
    a = np.array([[-5.0, 0.0, 0.0], [5.0, 0.0, 0.0]])
    b = np.array([[-5.0, 5.0, 0.0], [5.0, 5.0, 0.0]])
    assert len(project_polylines(cam, [a, b], step_m=1.0)) == 2
    mid = np.array([[-5.0, -30.0, 0.0], [0.0, 10.0, 0.0], [5.0, -30.0, 0.0]])
    assert len(project_polylines(cam, [mid], step_m=0.25)) == 1
    v = np.array([[-5.0, -21.0, 0.0], [0.0, 10.0, 0.0], [5.0, -21.0, 0.0]])
    assert len(project_polylines(cam, [v], step_m=0.25)) >= 1


def test_dense_sampling_follows_distortion():
    cam = _camera(OpenCVDistortion(k1=-0.3))
    line = np.array([[-12.0, 6.0, 0.0], [12.0, 6.0, 0.0]])  # straight, off the centre row
    p = project_polylines(cam, [line], step_m=0.1)[0]
    assert len(p) > 200
    # with barrel distortion the projected line bends: its middle is off the end chord
    chord_v = np.interp(p[:, 0], [p[0, 0], p[-1, 0]], [p[0, 1], p[-1, 1]])
    assert np.abs(p[:, 1] - chord_v).max() > 1.0  # 1.45 px here
    straight = project_polylines(_camera(), [line], step_m=0.1)[0]
    chord_s = np.interp(straight[:, 0], [straight[0, 0], straight[-1, 0]],
                        [straight[0, 1], straight[-1, 1]])
    assert np.abs(straight[:, 1] - chord_s).max() < 0.01


def test_draw_points_vectorised_and_clipped():
    img = np.zeros((20, 30, 3), np.uint8)
    pts = np.array([[5.0, 5.0], [29.0, 19.0], [np.nan, 3.0], [-10.0, 4.0], [5.0, 5.0]])
    cols = np.array([[1, 2, 3], [4, 5, 6], [7, 8, 9], [10, 11, 12], [200, 100, 50]], np.uint8)
    out = draw_points(img, pts, cols, radius=1)
    assert np.all(img == 0)  # input untouched
    assert tuple(out[5, 5]) == (200, 100, 50)  # the later point wins
    assert tuple(out[19, 29]) == (4, 5, 6)  # clipped at the corner, still drawn
    assert (np.any(out != 0, axis=2)).sum() == 9 + 4  # a 3x3 disc + a clipped 2x2 one


def _overlay_scene():
    cam = _camera(OpenCVDistortion(k1=-0.1))
    frame = np.full((240, 320, 3), (60, 120, 60), np.uint8)
    vol = CuboidVolume.from_bounds([-6.0, -4.0, 0.0], [6.0, 6.0, 2.0], name="box")
    rng = np.random.default_rng(1)
    pts = vol.sample(400, rng)
    w = rng.random(400)
    boxes = np.array([[40.0, 60.0, 30.0, 70.0], [200.0, 90.0, 25.0, 60.0]])
    ground = np.array([[-3.0, 0.0, 0.0], [3.0, 2.0, 0.0]])
    return render_overlay(frame, camera=cam, boxes_xywh_px=boxes, ids=np.array([3, 7]),
                          ground_points_m=ground, volume=vol, clouds=[ParticleCloud(pts, w)])


def test_overlay_matches_reference_and_is_deterministic():
    a = _overlay_scene()
    b = _overlay_scene()
    assert np.array_equal(a, b)
    diff = compare_reference("overlay_320x240.png", a[:, :, ::-1])
    print(f"overlay mean abs diff vs reference: {diff:.4f}")
    assert diff < MEAN_ABS_TOL


def test_overlay_needs_camera_for_world_layers():
    with pytest.raises(ValueError, match="camera"):
        render_overlay(np.zeros((10, 10, 3), np.uint8), ground_points_m=np.zeros((1, 3)))


# ---- PETS 2009 ------------------------------------------------------------------------------

def _pets(name: str) -> Path:
    from pftrack.io.data import data_dir

    p = data_dir() / "pets09" / name
    if not p.is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    return p


def test_cli_overlay_pets_frame_200_dots_on_feet(tmp_path):
    from pftrack.cli import main
    from pftrack.geometry.formats import load_camera
    from pftrack.io.mot import read_mot

    gt, video, xml = _pets("gt.txt"), _pets("vtest.avi"), _pets("View_001.xml")
    out = tmp_path / "ov.png"
    assert main(["render", "overlay", "--video", str(video), "--frame", "200", "--tracks",
                 str(gt), "--camera", str(xml), "--out", str(out)]) == 0
    img = cv2.imread(str(out))
    assert img.shape == (576, 768, 3)
    rows = read_mot(gt)
    rows = rows[rows[:, 0] == 200]
    assert len(rows) >= 5
    cam = load_camera(xml)
    px = cam.project(np.column_stack([rows[:, 7:9], np.zeros(len(rows))]))
    foot = np.column_stack([rows[:, 2] + rows[:, 4] / 2, rows[:, 3] + rows[:, 5]])
    err = np.linalg.norm(px - foot, axis=1)
    print("PETS frame 200 projected-vs-foot px:", np.round(err, 2))
    assert err.max() < 5.0
    # the dot colour is at every projected point (pixel-exact, no anti-aliasing on dots)
    uv = np.round(px).astype(int)
    assert np.all(img[uv[:, 1], uv[:, 0]] == np.array(GROUND_DOT_BGR, np.uint8))
    # and box colours are drawn: compare with the raw video frame
    from pftrack.render.overlay import read_video_frame

    raw = read_video_frame(video, 199)
    assert (np.any(raw != img, axis=2)).sum() > 1000


def test_cli_overlay_errors_name_the_file(tmp_path, capsys):
    from pftrack.cli import main

    gt = _pets("gt.txt")
    assert main(["render", "overlay", "--video", str(tmp_path / "no.avi"), "--frame", "1",
                 "--tracks", str(gt), "--out", str(tmp_path / "o.png")]) == 2
    assert "no.avi" in capsys.readouterr().err
    video = _pets("vtest.avi")
    assert main(["render", "overlay", "--video", str(video), "--frame", "100000",
                 "--tracks", str(gt), "--out", str(tmp_path / "o.png")]) == 2
    assert "vtest.avi" in capsys.readouterr().err
    assert not (tmp_path / "o.png").exists()


def test_soccer_pitch_overlay_lines_through_projected_corners():
    from conftest import ROOT
    from pftrack.geometry.formats import load_camera
    from pftrack.geometry.volumes import resolve_volume

    cam = load_camera(ROOT / "calib" / "soccer_camera.yaml")
    pitch = resolve_volume("pitch_corner")
    w, h = cam.image_size
    green = np.full((h, w, 3), (40, 110, 40), np.uint8)
    img = render_overlay(green, camera=cam, volume=pitch)
    drawn = np.any(img != green, axis=2)
    assert 2000 < drawn.sum() < 0.2 * w * h
    # every pitch corner (ground) that falls inside the image has a drawn line within 2 px
    b = pitch.bounds()
    corners = np.array([[b[0, 0], b[0, 1], 0], [b[1, 0], b[0, 1], 0], [b[1, 0], b[1, 1], 0],
                        [b[0, 0], b[1, 1], 0]])
    px = cam.project(corners)
    inside = cam.in_image(px, margin_px=3)
    assert inside.sum() >= 2
    for u, v in np.round(px[inside]).astype(int):
        assert drawn[v - 2:v + 3, u - 2:u + 3].any(), (u, v)
