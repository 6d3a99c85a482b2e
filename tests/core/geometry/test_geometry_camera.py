"""Camera model: projection, inverse projection, lens models, Tsai's parameterisation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pftrack.geometry.camera import (
    Camera,
    NoDistortion,
    OpenCVDistortion,
    TsaiDistortion,
    distortion_from_dict,
    look_at_rotation,
    tsai_angles,
    tsai_rotation,
)


def _camera(lens=None) -> Camera:
    return Camera.look_at([3.0, -20.0, 8.0], [0.0, 5.0, 0.0], (800, 600), fx=700.0, fy=690.0,
                          cx=410.0, cy=295.0, distortion=lens, name="test")


LENSES = [NoDistortion(), OpenCVDistortion(-0.2, 0.05, 0.001, -0.002, 0.01),
          OpenCVDistortion(0.3, 0.1, 0, 0, 0.01, 0.4, 0.05, 0.0), TsaiDistortion(0.15),
          TsaiDistortion(-0.08)]


def _ground_grid(cam: Camera) -> np.ndarray:
    g = np.mgrid[-15:15:31j, -5:30:36j].reshape(2, -1).T
    pts = np.c_[g, np.zeros(len(g))]
    return pts[cam.visible(pts)]


@pytest.mark.parametrize("lens", LENSES, ids=repr)
def test_project_then_back_project_returns_the_ground_points(lens):
    cam = _camera(lens)
    pts = _ground_grid(cam)
    assert len(pts) > 200
    back = cam.image_to_ground(cam.project(pts))
    assert np.abs(back - pts).max() < 1e-6  # metres


@pytest.mark.parametrize("lens", LENSES, ids=repr)
def test_lens_undistort_inverts_distort(lens):
    g = np.mgrid[-0.6:0.6:25j, -0.45:0.45:19j].reshape(2, -1).T
    assert np.abs(lens.undistort(lens.distort(g)) - g).max() < 1e-10
    # the lens moves points (except the identity), so the test above can fail
    if not lens.is_identity:
        assert np.abs(lens.distort(g) - g).max() > 1e-3


def test_projection_matches_opencv_projectpoints():
    import cv2

    lens = OpenCVDistortion(-0.2, 0.05, 0.001, -0.002, 0.01)
    cam = _camera(lens)
    pts = _ground_grid(cam) + [0.0, 0.0, 1.0]
    ref, _ = cv2.projectPoints(pts, cam.rvec, cam.t_m, cam.K, lens.coeffs)
    assert np.abs(cam.project(pts) - ref.reshape(-1, 2)).max() < 1e-9


def test_pinhole_projection_by_hand():
    cam = Camera(np.array([[100.0, 0, 50], [0, 120, 40], [0, 0, 1]]), np.eye(3), [0, 0, 0],
                 (100, 80))
    px = cam.project([[1.0, 2.0, 4.0], [0.0, 0.0, 2.0]])
    np.testing.assert_allclose(px, [[75.0, 100.0], [50.0, 40.0]])
    assert cam.in_image(px).tolist() == [False, True]


def test_tsai_radial_model_direction():
    # Tsai: undistorted = distorted * (1 + k r_d^2), so for k > 0 the image shrinks (barrel)
    lens = TsaiDistortion(0.2)
    d = np.array([[0.5, 0.0]])
    np.testing.assert_allclose(lens.undistort(d), [[0.5 * (1 + 0.2 * 0.25), 0.0]])
    np.testing.assert_allclose(lens.distort(lens.undistort(d)), d, atol=1e-14)


def test_tsai_negative_kappa_beyond_the_fold_is_nan():
    lens = TsaiDistortion(-0.5)
    r_max = 2 / (3 * math.sqrt(3 * 0.5))  # largest undistorted radius the model reaches
    out = lens.distort(np.array([[0.9 * r_max, 0.0], [1.1 * r_max, 0.0]]))
    assert np.isfinite(out[0]).all() and np.isnan(out[1]).all()


def _tsai_distort_masked(k: float, xy: np.ndarray) -> np.ndarray:
    """The Newton loop as it was before its stopping test lost the masked copies (with the
    cube as two products, as the lens computes it)."""
    ru = np.hypot(xy[:, 0], xy[:, 1])
    rd = ru.copy()
    for _ in range(60):
        f = k * (rd * rd * rd) + rd - ru
        step = f / (3 * k * rd * rd + 1)
        rd = rd - step
        if np.all(np.abs(step[np.isfinite(step)]) <= 1e-15 * (1 + ru[np.isfinite(step)])):
            break
    bad = ~np.isfinite(rd) | (np.abs(k * (rd * rd * rd) + rd - ru) > 1e-9 * (1 + ru))
    if k < 0:
        bad |= 3 * k * rd * rd + 1 <= 0
    scale = np.where(ru > 0, rd / np.where(ru > 0, ru, 1.0), 1.0)
    scale[bad] = np.nan
    return xy * scale[:, None]


@pytest.mark.parametrize("k", [0.1577, 2.5, -0.5])
def test_tsai_distort_is_bit_identical_to_the_masked_stopping_test(k):
    # the stopping test's rewrite is a speed-up only: same iterations, same numbers (NaN rows,
    # points beyond the fold and the centre included)
    rng = np.random.default_rng(7)
    xy = rng.uniform(-1.2, 1.2, size=(4000, 2))
    xy[:3] = [[0.0, 0.0], [np.nan, 0.1], [1e-300, 0.0]]
    with np.errstate(invalid="ignore", over="ignore"):
        got = TsaiDistortion(k).distort(xy)
        want = _tsai_distort_masked(k, xy)
    assert np.array_equal(got, want, equal_nan=True)
    assert np.isfinite(got[3:]).all() if k > 0 else np.isnan(got).any()


def test_points_behind_the_camera_project_to_nan_and_are_not_visible():
    cam = _camera()
    behind = cam.center_m - 5 * cam.optical_axis
    front = cam.center_m + 5 * cam.optical_axis
    px = cam.project(np.stack([behind, front]))
    assert np.isnan(px[0]).all() and np.isfinite(px[1]).all()
    assert cam.in_front(np.stack([behind, front])).tolist() == [False, True]
    np.testing.assert_allclose(cam.depth(np.stack([behind, front])), [-5.0, 5.0])
    assert cam.visible(np.stack([behind, front])).tolist() == [False, True]


def test_rays_start_at_the_centre_and_pass_through_the_point():
    cam = _camera(TsaiDistortion(0.1))
    pts = np.array([[1.0, 4.0, 0.5], [-3.0, 10.0, 2.0]])
    o, d = cam.rays(cam.project(pts))
    np.testing.assert_allclose(o, np.broadcast_to(cam.center_m, (2, 3)))
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    v = pts - o
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    np.testing.assert_allclose(d, v, atol=1e-9)


def test_image_to_plane_general_plane_and_misses():
    cam = _camera()
    # a vertical wall y = 12 (n = (0, 1, 0), d = 12)
    wall = np.array([[0.0, 12.0, 1.0], [4.0, 12.0, 3.0]])
    back = cam.image_to_plane(cam.project(wall), ((0.0, 2.0, 0.0), 24.0))  # unnormalised normal
    np.testing.assert_allclose(back, wall, atol=1e-9)
    # the sky (above the horizon) never meets the ground in front of the camera
    sky = cam.image_to_ground([[400.0, 0.0]])
    horizon_v = cam.project([cam.center_m + 1e6 * np.array([0, 1, 0])])[0, 1]
    assert horizon_v > 0 and np.isnan(sky).all()
    with pytest.raises(ValueError, match="normal is zero"):
        cam.image_to_plane([[1.0, 1.0]], ((0, 0, 0), 1.0))


def test_image_to_ground_height():
    cam = _camera()
    p = np.array([[2.0, 6.0, 1.7]])
    np.testing.assert_allclose(cam.image_to_ground(cam.project(p), z_m=1.7), p, atol=1e-9)


def test_center_and_look_at():
    cam = _camera()
    np.testing.assert_allclose(cam.center_m, [3.0, -20.0, 8.0], atol=1e-12)
    target_px = cam.project([[0.0, 5.0, 0.0]])[0]
    np.testing.assert_allclose(target_px, [410.0, 295.0], atol=1e-9)
    R = look_at_rotation([0, 0, 10], [0, 50, 0])
    assert R[1] @ np.array([0, 0, 1.0]) < 0  # image down is world down: level horizon
    with pytest.raises(ValueError, match="parallel"):
        look_at_rotation([0, 0, 10], [0, 0, 0])


def test_tsai_angles_round_trip():
    for rx, ry, rz in [(2.04, -0.89, -0.43), (math.radians(93.29), math.radians(5.39), -0.005)]:
        R = tsai_rotation(rx, ry, rz)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
        np.testing.assert_allclose(tsai_angles(R), (rx, ry, rz), atol=1e-14)


def test_from_tsai_matches_tsai_equations_by_hand():
    # Tsai's pipeline written out step by step for one point
    f, k, sx, dpx, dpy, cx, cy = 5.5, 5e-3, 1.09, 0.0051, 0.00465, 324.0, 282.0
    rx, ry, rz, T = 2.04, -0.89, -0.43, np.array([828.0, -3175.0, 35469.0])
    cam = Camera.from_tsai(focal_mm=f, kappa1_per_mm2=k, sx=sx, dpx_mm=dpx, dpy_mm=dpy,
                           cx_px=cx, cy_px=cy, rx=rx, ry=ry, rz=rz, t_mm=T, image_size=(768, 576))
    Xw = np.array([-4155.4, -7359.1, 0.0])  # mm
    Xc = tsai_rotation(rx, ry, rz) @ Xw + T
    Xu, Yu = f * Xc[0] / Xc[2], f * Xc[1] / Xc[2]
    # solve Xu = Xd (1 + k rd^2) along the ray by bisection on the scale
    lo, hi = 0.5, 1.0
    for _ in range(200):
        s = (lo + hi) / 2
        rd2 = (s * Xu) ** 2 + (s * Yu) ** 2
        lo, hi = (s, hi) if s * (1 + k * rd2) < 1 else (lo, s)
    Xd, Yd = s * Xu, s * Yu
    expected = [sx * Xd / dpx + cx, Yd / dpy + cy]
    np.testing.assert_allclose(cam.project(Xw[None] / 1000.0)[0], expected, atol=1e-8)
    p = cam.tsai_parameters()
    assert p["focal_mm"] == pytest.approx(f, rel=1e-14)
    assert p["kappa1_per_mm2"] == pytest.approx(k, rel=1e-12)
    assert p["sx"] == pytest.approx(sx, rel=1e-14)


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="rotation"):
        Camera(np.eye(3), np.ones((3, 3)), [0, 0, 0], (10, 10))
    with pytest.raises(ValueError, match="focal"):
        Camera(np.diag([0.0, 1.0, 1.0]), np.eye(3), [0, 0, 0], (10, 10))
    with pytest.raises(ValueError, match="image_size"):
        Camera(np.eye(3), np.eye(3), [0, 0, 0], (0, 10))
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        _camera().project(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="unknown distortion model"):
        distortion_from_dict({"model": "fisheye"})
    with pytest.raises(ValueError, match="4, 5 or 8"):
        OpenCVDistortion.from_coeffs([0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="cannot hold"):
        _camera(OpenCVDistortion(0.1)).tsai_parameters()


def test_vectorised_over_many_points():
    cam = _camera(TsaiDistortion(0.1))
    rng = np.random.default_rng(0)
    pts = np.c_[rng.uniform(-10, 10, 200_000), rng.uniform(0, 30, 200_000), np.zeros(200_000)]
    px = cam.project(pts)
    assert px.shape == (200_000, 2)
    ok = cam.in_image(px)
    back = cam.image_to_ground(px[ok])
    assert np.abs(back - pts[ok]).max() < 1e-6


def test_polynomial_lens_does_not_fold_far_points_into_the_image():
    # k1 < 0: r (1 + k1 r^2) peaks at r = 1 / sqrt(-3 k1); beyond it the polynomial folds back
    # and a point far off axis would land near the image centre. It must come out as NaN.
    lens = OpenCVDistortion(k1=-0.05)
    assert lens.max_radius == pytest.approx(1 / math.sqrt(0.15), abs=2e-3)
    cam = Camera.look_at([0.0, 0.0, 20.0], [0.0, 150.0, 0.0], (768, 576), fx=600.0,
                         distortion=lens)
    # 4.47 rad off axis (77 deg): the polynomial maps it to ~0, the image centre
    side = cam.center_m + 100.0 * (cam.optical_axis + 4.47 * cam.R[0])
    px = cam.project(side[None])
    assert np.isnan(px).all() and not cam.visible(side[None]).any()
    assert OpenCVDistortion(k1=0.1, k2=0.01).max_radius == math.inf


def test_resized_camera_sees_the_same_scene_scaled():
    cam = _camera(TsaiDistortion(0.1))
    big = cam.resized((1600, 1200))
    assert big.image_size == (1600, 1200)
    pts = _ground_grid(cam)
    np.testing.assert_allclose(big.project(pts), (cam.project(pts) + 0.5) * 2.0 - 0.5,
                               atol=1e-9)
    np.testing.assert_allclose(big.center_m, cam.center_m)
