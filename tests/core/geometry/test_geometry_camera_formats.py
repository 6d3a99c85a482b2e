"""Camera files: PETS 2009 Tsai XML, OpenCV FileStorage, Open3D JSON, pftrack YAML, and the
shipped calib/ cameras."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT
from pftrack.geometry.calibration import check_against_mot, read_mot_world
from pftrack.geometry.camera import Camera, NoDistortion, OpenCVDistortion, TsaiDistortion
from pftrack.geometry.formats import (
    convert_camera,
    guess_format,
    load_camera,
    pixel_grid,
    save_camera,
)
from pftrack.io.data import data_path

PETS_XML = data_path("pets09", "View_001.xml")
PETS_GT = data_path("pets09", "gt.txt")
CALIB = ROOT / "calib"

SUFFIX = {"pftrack": "cam.yaml", "tsai": "cam.xml", "opencv": "cam.opencv.yml",
          "open3d": "cam.json"}


@pytest.fixture(scope="module")
def pets() -> Camera:
    return load_camera(PETS_XML)


@pytest.fixture(scope="module")
def pets_points() -> tuple[np.ndarray, np.ndarray]:
    return read_mot_world(PETS_GT)


def test_pets_camera_reads_tsai_parameters(pets):
    assert pets.image_size == (768, 576)
    assert isinstance(pets.distortion, TsaiDistortion)
    p = pets.tsai_parameters()
    assert p["focal_mm"] == pytest.approx(5.5549183034, rel=1e-12)
    assert p["kappa1_per_mm2"] == pytest.approx(5.1113043639e-03, rel=1e-12)
    assert p["sx"] == pytest.approx(1.0937855397, rel=1e-12)
    assert p["t_mm"] == pytest.approx([828.73214225, -3175.4796051, 35469.298547], rel=1e-12)
    # fx = sx f / dpx, fy = f / dpy
    assert pets.fx == pytest.approx(1.0937855397 * 5.5549183034 / 5.1273271277e-03, rel=1e-14)
    assert pets.fy == pytest.approx(5.5549183034 / 4.65e-03, rel=1e-14)
    # the camera stands some 7 m above the ground, looking down onto it
    assert 5.0 < pets.center_m[2] < 10.0 and pets.optical_axis[2] < -0.2


def test_pets_camera_lands_on_ground_truth_foot_points(pets):
    # done-when 1: README says median 2.2 px, max 2.9 px; we measure 2.153 / 2.820 px and
    # 0.123 m median ground error back-projecting the foot points.
    r = check_against_mot(pets, PETS_GT)
    assert r["points"] == 4650
    assert 2.0 <= r["median_px"] <= 2.5
    assert r["p90_px"] <= 2.7 and r["max_px"] <= 2.9
    assert 0.05 <= r["backprojection_median_m"] <= 0.15
    assert r["backprojection_p90_m"] <= 0.25
    assert r["not_projectable"] == 0


@pytest.mark.parametrize("fmt", ["pftrack", "tsai", "opencv", "open3d"])
def test_pets_round_trip_through_every_format(tmp_path, pets, pets_points, fmt):
    # done-when 2: exact formats change no projection by more than 1e-6 px; the others by no
    # more than the residual the conversion reports.
    _, world = pets_points
    path = tmp_path / SUFFIX[fmt]
    if fmt in ("opencv", "open3d"):
        with pytest.raises(ValueError, match="cannot hold"):
            save_camera(pets, path, fmt)
        assert not path.exists()
    report = save_camera(pets, path, approximate=True)
    assert guess_format(path) == fmt
    back = load_camera(path)
    grid = pixel_grid(pets.image_size, 8.0)
    ground = pets.image_to_ground(grid)
    ground = ground[np.isfinite(ground).all(axis=1)]
    pts = np.concatenate([world, ground])
    diff = np.linalg.norm(back.project(pts) - pets.project(pts), axis=1).max()
    if fmt in ("pftrack", "tsai"):
        assert report.exact and report.residual_max_px == 0.0
        assert diff <= 1e-6
    else:
        assert not report.exact and report.lost
        assert diff <= report.residual_max_px + 1e-9
    # calib check on the converted file agrees with the original within the residual
    r0, r1 = check_against_mot(pets, PETS_GT), check_against_mot(back, PETS_GT)
    tol = max(report.residual_max_px, 1e-9)
    assert abs(r1["median_px"] - r0["median_px"]) <= tol
    assert abs(r1["max_px"] - r0["max_px"]) <= tol


def test_conversion_residuals_are_what_we_measured(pets):
    # Tsai -> OpenCV (k1, k2, p1, p2, k3): well under a thousandth of a pixel for PETS
    cv_cam, rep = convert_camera(pets, "opencv")
    assert isinstance(cv_cam.distortion, OpenCVDistortion) and cv_cam.distortion.coeffs.size == 5
    assert 1e-5 < rep.residual_max_px < 2e-3
    assert rep.fitted["k1"] == pytest.approx(-0.1577, abs=2e-3)  # ~ -kappa1_norm
    # Tsai -> pinhole (Open3D) cannot model the lens: several pixels at the corners
    pin, rep3 = convert_camera(pets, "open3d")
    assert isinstance(pin.distortion, NoDistortion)
    assert 5.0 < rep3.residual_max_px < 12.0 and rep3.residual_rms_px < rep3.residual_max_px
    assert any("cannot hold lens distortion" in s for s in rep3.lost)
    # and back: the fitted OpenCV lens converts to Tsai with the same small residual
    ts, rep4 = convert_camera(cv_cam, "tsai")
    assert ts.distortion.kappa1 == pytest.approx(pets.distortion.kappa1, rel=1e-3)
    assert rep4.residual_max_px < 2e-3


def test_strong_tsai_lens_goes_rational_in_opencv():
    cam = load_camera(CALIB / "soccer_camera.yaml")
    _, rep_std = convert_camera(cam, "opencv", opencv_model="standard")
    auto, rep = convert_camera(cam, "opencv")
    assert rep_std.residual_max_px > 5.0  # 5 coefficients cannot follow kappa1 = 0.36
    assert auto.distortion.coeffs.size == 8 and rep.residual_max_px < 0.01
    assert any("rational" in s for s in rep.lost)


def test_opencv_file_from_calibrate_camera_tools():
    cam = load_camera(data_path("chessboard", "left_intrinsics.yml"))
    assert guess_format(data_path("chessboard", "left_intrinsics.yml")) == "opencv"
    assert cam.image_size == (640, 480)
    assert cam.fx == pytest.approx(535.91573396163199) and cam.fy == cam.fx
    assert cam.distortion.coeffs == pytest.approx(
        [-0.26637260909660682, -0.038588898922304653, 1.7831947042852964e-03,
         -2.8122100441115472e-04, 0.23839153080878486])
    assert cam.metadata["avg_reprojection_error_px"] == pytest.approx(0.3926, abs=1e-4)
    np.testing.assert_array_equal(cam.R, np.eye(3))  # 13 views: no single pose


def test_opencv_and_open3d_round_trip_exact_for_what_they_hold(tmp_path):
    cam = Camera.look_at([1.0, -8.0, 3.0], [0.5, 4.0, 0.0], (640, 480), fx=512.3, fy=515.1,
                         cx=330.2, cy=241.7, distortion=OpenCVDistortion(-0.21, 0.04, 1e-3,
                                                                         -2e-3, 0.01))
    pts = np.c_[np.mgrid[-3:3:7j, 1:9:9j].reshape(2, -1).T, np.zeros(63)]
    for fmt in ("opencv", "pftrack"):
        path = tmp_path / SUFFIX[fmt]
        assert save_camera(cam, path).exact
        back = load_camera(path)
        assert np.abs(back.project(pts) - cam.project(pts)).max() < 1e-9
    pin = cam.with_distortion(NoDistortion())
    assert save_camera(pin, tmp_path / "p.json").exact
    back = load_camera(tmp_path / "p.json")
    np.testing.assert_allclose(back.K, pin.K, rtol=1e-15)
    assert np.abs(back.project(pts) - pin.project(pts)).max() < 1e-9


def test_pftrack_yaml_is_bit_exact(tmp_path, pets):
    save_camera(pets, tmp_path / "c.yaml")
    back = load_camera(tmp_path / "c.yaml")
    assert back == pets
    assert back.metadata["tsai_sensor"] == pets.metadata["tsai_sensor"]
    # and via Tsai XML, Tsai's own numbers come back
    save_camera(back, tmp_path / "c.xml")
    again = load_camera(tmp_path / "c.xml")
    for k, v in pets.tsai_parameters().items():
        assert again.tsai_parameters()[k] == pytest.approx(v, rel=1e-12, abs=1e-12)


def test_shipped_soccer_camera_views_the_whole_pitch():
    cam = load_camera(CALIB / "soccer_camera.yaml")
    assert cam.image_size == (1280, 720)
    np.testing.assert_allclose(cam.center_m, [35.04, -67.73, 16.01], atol=0.01)
    assert cam.fx == pytest.approx(3.155433 / 0.005)
    g = np.mgrid[0:105:106j, 0:68:69j].reshape(2, -1).T
    pitch = np.c_[g, np.zeros(len(g))]
    assert cam.visible(pitch).all()
    px = cam.project(pitch)
    assert px[:, 1].min() > 360  # the lower half of the image, as in the paper
    # players are visible: a 1.8 m player is ~8 px tall at the far side, ~16 px at the near one
    far = cam.project([[26.0, 68.0, 0.0], [26.0, 68.0, 1.8]])
    near = cam.project([[26.0, 0.0, 0.0], [26.0, 0.0, 1.8]])
    assert 6 < far[0, 1] - far[1, 1] < 10 and 13 < near[0, 1] - near[1, 1] < 20


def test_shipped_coast_camera_views_both_volumes():
    from pftrack.geometry.volumes import load_volumes

    cam = load_camera(CALIB / "coast_camera.yaml")
    vols = load_volumes(CALIB / "volumes.yaml")
    assert cam.image_size == (768, 576)
    np.testing.assert_allclose(cam.center_m, [0.0, 0.0, 20.0], atol=1e-9)
    for name in ("near", "far"):
        assert cam.visible(vols[name].corners()).all(), name
    near_px = cam.project(vols["near"].corners())
    assert np.ptp(near_px[:, 0]) > 200  # 43 m wide at 100 m: a sizeable target area
    assert vols["pitch_corner"].frame == "corner"


def test_errors_name_the_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.yaml"):
        load_camera(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: pftrack-camera\nimage_size: [10, 10]\nK: [[1, 0, 0]]\n")
    with pytest.raises(ValueError, match="bad.yaml"):
        load_camera(bad)
    xml = tmp_path / "bad.xml"
    xml.write_text('<Camera><Geometry width="10" height="10" dpx="1" dpy="1"/>'
                   '<Intrinsic focal="1" kappa1="0" cx="0" cy="0"/><Extrinsic/></Camera>')
    with pytest.raises(ValueError, match="bad.xml.*sx"):
        load_camera(xml)
    with pytest.raises(ValueError, match="cannot tell"):
        save_camera(load_camera(PETS_XML), tmp_path / "cam.txt")
    with pytest.raises(ValueError, match="unknown camera format"):
        load_camera(PETS_XML, format="colmap")
