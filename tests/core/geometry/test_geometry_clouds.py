"""Particle clouds: Open3D conversion and PLY files keep the weights exactly."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.geometry.clouds import ParticleCloud, load_ply, save_ply, weights_to_colours


def _cloud(n=500, seed=0):
    rng = np.random.default_rng(seed)
    w = rng.gamma(1.0, size=n)
    return ParticleCloud(rng.normal(size=(n, 3)) * [10, 5, 1], w / w.sum(),
                         rng.integers(-1, 6, size=n))


def test_ply_round_trip_is_exact(tmp_path):
    c = _cloud()
    path = save_ply(tmp_path / "sub" / "p.ply", c)
    assert path.exists() and not list(path.parent.glob(".*tmp*"))
    back = load_ply(path)
    assert np.array_equal(back.points_world_m, c.points_world_m)
    assert np.array_equal(back.weights, c.weights)  # bit for bit
    assert np.array_equal(back.labels, c.labels)
    head = path.read_bytes()[:400]
    assert b"property double weights" in head and b"property uchar red" in head


def test_open3d_tensor_and_legacy_round_trip():
    c = _cloud(seed=1)
    t = c.to_open3d()
    assert t.point.weights.numpy().shape == (len(c), 1)
    back = ParticleCloud.from_open3d(t)
    assert np.array_equal(back.weights, c.weights) and np.array_equal(back.labels, c.labels)
    legacy = c.to_legacy_open3d()
    back2 = ParticleCloud.from_open3d(legacy)
    assert np.array_equal(back2.weights, c.weights)
    assert np.array_equal(back2.points_world_m, c.points_world_m)
    assert back2.labels is None
    cols = np.asarray(legacy.colors)
    assert np.allclose(cols * 255, c.colours(), atol=1e-6)


def test_weight_colours_follow_the_fixed_colormap():
    cols = weights_to_colours(np.array([0.0, 0.5, 1.0, 2.0]), vmax=1.0)
    assert cols.dtype == np.uint8 and cols.shape == (4, 3)
    assert cols[0].tolist() == [68, 1, 84]  # viridis bottom (dark purple)
    assert cols[2].tolist() == [253, 231, 37]  # viridis top (yellow)
    assert np.array_equal(cols[2], cols[3])  # clipped
    # heavier weights are brighter (viridis luminance rises monotonically)
    w = np.linspace(0, 1, 20)
    lum = weights_to_colours(w).astype(float) @ [0.299, 0.587, 0.114]
    assert np.all(np.diff(lum) > 0)
    assert np.array_equal(weights_to_colours(np.zeros(3)), np.repeat(cols[:1], 3, axis=0))


def test_default_weights_and_validation(tmp_path):
    c = ParticleCloud(np.zeros((4, 3)))
    assert np.allclose(c.weights, 0.25)
    with pytest.raises(ValueError, match="4 points but 3 weights"):
        ParticleCloud(np.zeros((4, 3)), np.ones(3))
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        ParticleCloud(np.zeros((4, 2)))
    with pytest.raises(ValueError, match=">= 0"):
        ParticleCloud(np.zeros((2, 3)), [1.0, -1.0])
    with pytest.raises(ValueError, match="empty"):
        save_ply(tmp_path / "e.ply", ParticleCloud(np.zeros((0, 3))))
    bad = tmp_path / "bad.ply"
    bad.write_text("not a ply")
    with pytest.raises(ValueError, match="bad.ply"):
        load_ply(bad)
    with pytest.raises(FileNotFoundError, match="missing.ply"):
        load_ply(tmp_path / "missing.ply")


def test_concatenate():
    a, b = _cloud(10, 0), _cloud(5, 1)
    c = ParticleCloud.concatenate([a, b])
    assert len(c) == 15 and np.array_equal(c.weights[10:], b.weights)
    assert np.array_equal(c.labels[:10], a.labels)
