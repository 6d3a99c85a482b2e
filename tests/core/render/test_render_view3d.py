"""3D view of volumes and particle clouds: deterministic, draws particles by weight."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.geometry.clouds import ParticleCloud
from pftrack.geometry.volumes import resolve_volume
from pftrack.render.view3d import render_view3d


def _scene():
    near = resolve_volume("near")
    rng = np.random.default_rng(3)
    pts = near.sample(2000, rng)
    w = np.exp(-0.5 * ((pts[:, 0] - 5.0) ** 2 / 20 + (pts[:, 1] - 100.0) ** 2 / 4))
    return near, ParticleCloud(pts, w)


def test_view3d_deterministic_and_draws(tmp_path):
    near, cloud = _scene()
    a = render_view3d(tmp_path / "a.png", volumes=[near], clouds=[cloud], size_wh=(320, 240))
    b = render_view3d(tmp_path / "b.png", volumes=[near], clouds=[cloud], size_wh=(320, 240))
    assert a.shape == (240, 320, 3)
    assert np.array_equal(a, b)
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()
    empty = render_view3d(volumes=[near], size_wh=(320, 240))
    # the particles add many coloured pixels over the bare volume
    assert (np.any(a != empty, axis=2)).sum() > 500
    # viridis: dark purple (light particles) and yellow-green (heavy ones) both appear
    purple = np.all(np.abs(a.astype(int) - [68, 1, 84]) < 30, axis=2).sum()
    bright = ((a[:, :, 1] > 150) & (a[:, :, 2] < 120)).sum()
    assert purple > 50 and bright > 5


def test_view3d_needs_something():
    with pytest.raises(ValueError, match="nothing to draw"):
        render_view3d()


def test_view3d_camera_frustum_on_pets(tmp_path):
    from pftrack.geometry.formats import load_camera
    from pftrack.io.data import data_dir
    from pftrack.io.mot import read_mot
    from pftrack.render.tracks import tracks_from_mot
    from pftrack.render.view3d import CAMERA_RGB, camera_frustum

    pets = data_dir() / "pets09"
    if not (pets / "View_001.xml").is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    cam = load_camera(pets / "View_001.xml")
    segs, foot = camera_frustum(cam, far_m=80.0)
    assert segs.shape == (8, 2, 3)
    assert np.allclose(segs[:4, 0], cam.center_m)
    # the two lower image corners see the ground; their rays end on z = 0 and project back
    # onto those corners
    w, h = cam.image_size
    lower = segs[2:4, 1]
    assert np.allclose(lower[:, 2], 0.0, atol=1e-9)
    assert np.allclose(cam.project(lower), [[w - 0.5, h - 0.5], [-0.5, h - 0.5]], atol=1e-3)
    # the footprint lies on the ground and projects onto the image border
    pts = np.vstack(foot)
    assert np.allclose(pts[:, 2], 0.0, atol=1e-9) and len(pts) > 50
    px = cam.project(pts)
    border = np.minimum.reduce([np.abs(px[:, 0] + 0.5), np.abs(px[:, 0] - (w - 0.5)),
                                np.abs(px[:, 1] + 0.5), np.abs(px[:, 1] - (h - 0.5))])
    assert np.max(border) < 1e-3
    tracks = tracks_from_mot(read_mot(pets / "gt.txt"))
    a = render_view3d(tmp_path / "f.png", tracks=tracks, cameras=[cam], size_wh=(320, 240))
    b = render_view3d(tracks=tracks, cameras=[cam], size_wh=(320, 240))
    assert np.array_equal(a, b)
    red = np.all(np.abs(a.astype(int) - CAMERA_RGB) < 40, axis=2).sum()
    assert red > 100  # the frustum is drawn
    bare = render_view3d(tracks=tracks, size_wh=(320, 240), axes=False)
    assert np.all(np.abs(bare.astype(int) - CAMERA_RGB) < 40, axis=2).sum() < 5


def test_view3d_matches_reference():
    from conftest import MEAN_ABS_TOL, compare_reference

    near, cloud = _scene()
    img = render_view3d(volumes=[near], clouds=[cloud], size_wh=(320, 240), title="near")
    assert compare_reference("view3d_320x240.png", img) < MEAN_ABS_TOL
