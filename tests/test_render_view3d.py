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
