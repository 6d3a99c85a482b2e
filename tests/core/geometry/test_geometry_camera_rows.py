"""Camera.project_rows: T projections in one compiled pass, the numbers of T numpy calls."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.geometry import camera as camera_module
from pftrack.geometry.camera import (
    Camera,
    NoDistortion,
    OpenCVDistortion,
    TsaiDistortion,
    same_bits,
)

LENSES = [NoDistortion(), TsaiDistortion(0.15772011860650012), TsaiDistortion(-0.08),
          OpenCVDistortion(-0.05), OpenCVDistortion(-0.2, 0.05, 0.001, -0.002, 0.01),
          OpenCVDistortion(0.3, 0.1, 0, 0, 0.01, 0.4, 0.05, 0.0)]


def _camera(lens) -> Camera:
    return Camera.look_at([3.0, -20.0, 8.0], [0.0, 5.0, 0.0], (768, 576), fx=700.0, fy=690.0,
                          cx=380.0, cy=290.0, distortion=lens)


def _points(seed: int = 0) -> np.ndarray:
    """(4, 3000, 3): a cloud around the scene, some behind the camera, some far outside the
    field of view, rows of different spreads (Tsai's Newton stops after a different number of
    iterations per row), a NaN point."""
    rng = np.random.default_rng(seed)
    pts = rng.normal(0.0, 1.0, (4, 3000, 3)) * np.array([[[4.0, 8.0, 2.0]], [[15.0, 30.0, 6.0]],
                                                         [[0.5, 0.5, 0.5]], [[60.0, 60.0, 20.0]]])
    pts[:, :, 1] += 5.0
    pts[0, 0] = [np.nan, 0.0, 1.0]
    pts[1, 0] = [3.0, -20.0, 8.0]  # the camera centre
    return pts


def _numpy_rows(cam: Camera, pts: np.ndarray) -> np.ndarray:
    return np.array([cam._project_numpy(cam.world_to_camera(p)) for p in pts])


@pytest.mark.parametrize("lens", LENSES, ids=lambda d: f"{d.model}{list(d.params().values())}")
def test_project_rows_equals_the_numpy_projection_row_by_row_bit_for_bit(lens):
    cam = _camera(lens)
    pts = _points()
    assert camera_module._rows_kernel() is not None  # numba is a dependency: the kernel runs
    rows = cam.project_rows(pts)
    ref = _numpy_rows(cam, pts)
    assert rows.shape == (4, 3000, 2)
    assert same_bits(rows, ref)
    assert np.isnan(rows[0, 0]).all() and np.isnan(rows[1, 0]).all()
    assert np.isfinite(rows[2]).all()
    # once loaded, project() goes through the kernel too: the same numbers
    assert same_bits(np.array([cam.project(p) for p in pts]), ref)
    # one row alone gives its numbers (Newton's stopping rule is per row, not per stack)
    assert same_bits(cam.project_rows(pts[2:3])[0], ref[2])


def test_project_rows_without_the_kernel_and_bad_shapes(monkeypatch):
    cam = _camera(TsaiDistortion(0.15))
    pts = _points(1)[:2, :50]
    fast = cam.project_rows(pts)
    monkeypatch.setattr(camera_module, "_ROWS_KERNEL", [None])  # PFTRACK_NO_JIT, or a mismatch
    assert same_bits(cam.project_rows(pts), fast)
    assert same_bits(cam.project(pts[0]), fast[0])
    with pytest.raises(ValueError, match=r"project_rows: expected an array of shape \(T, N, 3\)"):
        cam.project_rows(pts[0])


def test_same_bits_tells_signed_zeros_and_nans():
    assert same_bits(np.array([np.nan, 1.0]), np.array([np.nan, 1.0]))
    assert not same_bits(np.array([0.0]), np.array([-0.0]))
    assert not same_bits(np.array([1.0]), np.array([np.nextafter(1.0, 2.0)]))
    assert not same_bits(np.zeros(2), np.zeros(3))
