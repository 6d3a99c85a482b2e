"""A ground-plane camera from person boxes (pftrack.geometry.people)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pftrack.geometry.alignment import compare_with_reference, rigid_align_2d
from pftrack.geometry.formats import load_camera
from pftrack.geometry.people import (
    PRIOR_HFOV_DEG,
    camera_from_parameters,
    estimate_camera_from_people,
    horizon_row,
    predicted_box_heights,
)
from pftrack.io.data import data_path
from pftrack.workflows.calibrate import measure_slants

SIZE = (768, 576)


def _people(cam, n, rng, height_sd=0.07, n_false=0):
    """Boxes of people standing on z = 0, seen by ``cam``, plus uniform false positives."""
    X = rng.uniform(-12, 12, 4 * n)
    Y = rng.uniform(6, 40, 4 * n)
    H = rng.normal(1.7, height_sd, 4 * n)
    foot = cam.project(np.column_stack([X, Y, np.zeros_like(X)]))
    head = cam.project(np.column_stack([X, Y, H]))
    ok = cam.in_image(foot, margin_px=3) & cam.in_image(head, margin_px=3)
    foot, head = foot[ok][:n], head[ok][:n]
    hh = foot[:, 1] - head[:, 1]
    boxes = np.column_stack([foot[:, 0] - 0.2 * hh, head[:, 1], 0.4 * hh, hh])
    if n_false:
        fb = np.column_stack([rng.uniform(0, 700, n_false), rng.uniform(5, 400, n_false),
                              rng.uniform(10, 60, n_false), rng.uniform(20, 160, n_false)])
        boxes = np.vstack([boxes, fb])
    return boxes, len(foot)


def test_parametrisation_matches_its_description():
    cam = camera_from_parameters(800.0, 20.0, 4.0, 5.0, SIZE)
    assert np.allclose(cam.center_m, [0, 0, 5.0])
    ax = cam.optical_axis
    assert math.degrees(math.asin(-ax[2])) == pytest.approx(20.0, abs=1e-9)
    assert ax[0] == pytest.approx(0.0, abs=1e-12) and ax[1] > 0
    # horizon: above the centre row by f tan(tilt), falling to the right for positive roll
    assert horizon_row(camera_from_parameters(800.0, 20.0, 0.0, 5.0, SIZE)) == pytest.approx(
        287.5 - 800 * math.tan(math.radians(20)), abs=1e-6)
    assert horizon_row(cam, 700) - horizon_row(cam, 0) == pytest.approx(
        700 * math.tan(math.radians(4.0)), rel=1e-6)
    # level camera: h = (v_foot - v_horizon) * H_p / H_c exactly
    lvl = camera_from_parameters(700.0, 0.0, 0.0, 4.0, SIZE)
    feet = np.array([[100.0, 300.0], [400.0, 450.0], [700.0, 560.0]])
    assert np.allclose(predicted_box_heights(lvl, feet, 1.7),
                       (feet[:, 1] - 287.5) * 1.7 / 4.0)


def test_recovers_a_known_camera_with_false_positives():
    rng = np.random.default_rng(3)
    cam = camera_from_parameters(900.0, 15.0, 3.0, 6.0, SIZE)
    boxes, n_true = _people(cam, 300, rng, n_false=40)
    fit = estimate_camera_from_people(boxes, SIZE, 1.7, rng=np.random.default_rng(0),
                                      fit_focal=True, n_bootstrap=30)
    assert fit.horizon_row == pytest.approx(horizon_row(cam), abs=6.0)
    assert fit.camera_height_m == pytest.approx(6.0, rel=0.05)
    assert fit.tilt_deg == pytest.approx(15.0, abs=3.0)
    assert fit.roll_deg == pytest.approx(3.0, abs=0.5)
    assert fit.focal_px == pytest.approx(900.0, rel=0.25)
    assert fit.focal_identified
    # the false positives: most rejected, the people kept
    assert fit.inliers[:n_true].mean() > 0.95
    assert fit.inliers[n_true:].mean() < 0.35
    # the 1-sigma values are finite, positive and cover the errors within 3 sigma
    for key, truth in [("horizon_row", horizon_row(cam)), ("camera_height_m", 6.0),
                       ("tilt_deg", 15.0), ("roll_deg", 3.0), ("focal_px", 900.0)]:
        sd = fit.uncertainty[key]
        assert 0 < sd < np.inf
        assert abs(getattr(fit, key) - truth) < 3 * sd + 1e-9, key
    # ground positions through the estimate agree with the truth after a rigid alignment
    feet = np.column_stack([boxes[:n_true, 0] + boxes[:n_true, 2] / 2,
                            boxes[:n_true, 1] + boxes[:n_true, 3]])
    truth_xy = cam.image_to_ground(feet)[:, :2]
    r = compare_with_reference(fit, cam, boxes[:n_true], truth_xy)
    assert r["median_error_m"] < 0.5
    assert r["horizon_error_px"] == pytest.approx(abs(fit.horizon_row - horizon_row(cam)),
                                                  abs=1e-6)


def test_known_focal_length_gives_the_camera_closely():
    rng = np.random.default_rng(5)
    cam = camera_from_parameters(1100.0, 18.0, -2.0, 8.0, SIZE)
    boxes, _ = _people(cam, 200, rng, height_sd=0.0)
    fit = estimate_camera_from_people(boxes, SIZE, focal_px=1100.0, n_bootstrap=0)
    assert fit.uncertainty_method == "jacobian"
    assert fit.focal_px == pytest.approx(1100.0) and fit.uncertainty["focal_px"] == 0.0
    assert fit.camera_height_m == pytest.approx(8.0, rel=1e-3)
    assert fit.tilt_deg == pytest.approx(18.0, abs=0.05)
    assert fit.roll_deg == pytest.approx(-2.0, abs=0.05)
    assert fit.inliers.all()
    # person height is a scale: 10 % taller people, 10 % higher camera, same angles
    fit2 = estimate_camera_from_people(boxes, SIZE, person_height_m=1.87, focal_px=1100.0,
                                       n_bootstrap=0)
    assert fit2.camera_height_m == pytest.approx(1.1 * fit.camera_height_m, rel=1e-3)
    assert fit2.tilt_deg == pytest.approx(fit.tilt_deg, abs=0.01)


def test_default_focal_is_the_documented_prior_and_says_so():
    rng = np.random.default_rng(7)
    cam = camera_from_parameters(927.0, 12.0, 0.0, 5.0, SIZE)
    boxes, _ = _people(cam, 150, rng)
    a = estimate_camera_from_people(boxes, SIZE, rng=np.random.default_rng(1), n_bootstrap=20)
    b = estimate_camera_from_people(boxes, SIZE, rng=np.random.default_rng(1), n_bootstrap=20)
    f0 = 384 / math.tan(math.radians(PRIOR_HFOV_DEG / 2))
    assert a.focal_px == pytest.approx(f0)
    assert not a.focal_identified
    assert any("prior" in n for n in a.notes)
    assert a.uncertainty["focal_px"] == pytest.approx(0.4 * f0)
    # with the prior the truth here, the rest comes back; same seed, same numbers
    assert a.camera_height_m == pytest.approx(5.0, rel=0.05)
    assert a.tilt_deg == pytest.approx(12.0, abs=1.5)
    assert a.summary() == b.summary()
    # the prior's spread is in the tilt's uncertainty: larger than the fixed-focal bootstrap's
    c = estimate_camera_from_people(boxes, SIZE, focal_px=f0, rng=np.random.default_rng(1),
                                    n_bootstrap=20)
    assert a.uncertainty["tilt_deg"] > 3 * c.uncertainty["tilt_deg"]


def test_people_lean_identifies_the_focal_length():
    # a long lens (HFOV 33 deg) the prior (45 deg) is 29 % off; the leans towards the vertical
    # vanishing point (as measure_slants reports them: du/dv, noisy, some missing) bring it back
    rng = np.random.default_rng(8)
    cam = camera_from_parameters(1300.0, 17.0, -3.0, 7.0, SIZE)
    boxes, n = _people(cam, 400, rng)
    feet = np.column_stack([boxes[:, 0] + boxes[:, 2] / 2, boxes[:, 1] + boxes[:, 3]])
    ground = cam.image_to_ground(feet)
    # lean of the upper 70 % of each person, from the projected body axis
    lo = cam.project(ground + [0, 0, 0.3 * 1.7])
    hi = cam.project(ground + [0, 0, 1.7])
    lean = (hi[:, 0] - lo[:, 0]) / (hi[:, 1] - lo[:, 1])
    slants = lean + rng.normal(0, 0.03, n)
    slants[rng.random(n) < 0.2] = np.nan
    fit = estimate_camera_from_people(boxes, SIZE, slants=slants, n_bootstrap=20,
                                      rng=np.random.default_rng(0))
    assert fit.slants_used == np.isfinite(slants[fit.inliers]).sum() > 250
    assert fit.focal_identified
    assert fit.focal_px == pytest.approx(1300.0, rel=0.08)
    assert fit.horizon_row == pytest.approx(horizon_row(cam), abs=8)
    assert fit.tilt_deg == pytest.approx(17.0, abs=1.0)
    assert abs(fit.focal_px - 1300.0) < 3 * fit.uncertainty["focal_px"] + 1e-9
    assert any("lean" in t for t in fit.notes)
    # without the leans the same boxes give the prior's focal length, 29 % off
    plain = estimate_camera_from_people(boxes, SIZE, n_bootstrap=0)
    assert plain.slants_used == 0 and plain.focal_px == pytest.approx(927.06, abs=0.01)
    # too few leans are not used, and say so
    few = np.full(n, np.nan)
    few[:10] = slants[:10]
    fit_few = estimate_camera_from_people(boxes, SIZE, slants=few, n_bootstrap=0)
    assert fit_few.slants_used == 0 and any("min_slants" in t for t in fit_few.notes)
    with pytest.raises(ValueError, match="slants has 3 values"):
        estimate_camera_from_people(boxes, SIZE, slants=[0.0, 0.1, 0.2])


def _distorted_scene(k1, seed, n=1500):
    """People seen by a tilted camera through a lens with OpenCV's radial ``k1`` (another model
    than the fitted one), boxed and leaned as the silhouettes give them: box columns at the
    body's middle with 25 % margins each side, the feet cut by 1 % of the height, 1.5 px of
    noise on the top and bottom rows, heights N(1.7, 0.07) m, leans of the top 85 % with
    0.04 of noise and a quarter not measured. Returns the camera, boxes, leans, the true foot
    pixels (as thin boxes) and ground positions."""
    from pftrack.geometry.camera import Camera, OpenCVDistortion
    from pftrack.geometry.people import _rotation

    rng = np.random.default_rng(seed)
    R = _rotation(math.radians(18.0), math.radians(-2.0))
    cam = Camera.from_pinhole(1000.0, 1000.0, 383.5, 287.5, R, -R @ np.array([0, 0, 7.0]),
                              SIZE, distortion=OpenCVDistortion(k1=k1))
    m = 8 * n
    ground = np.column_stack([rng.uniform(-15, 15, m), rng.uniform(5, 45, m), np.zeros(m)])
    tall = rng.normal(1.7, 0.07, m)

    def at(z):
        return cam.project(ground + np.column_stack([np.zeros((m, 2)), z]))

    foot, head = at(0 * tall), at(tall)
    ok = (cam.in_image(foot, margin_px=3) & cam.in_image(head, margin_px=3)
          & np.isfinite(foot).all(axis=1) & np.isfinite(head).all(axis=1))
    sel = np.flatnonzero(ok)[:n]
    assert len(sel) == n
    low, mid = at(0.15 * tall)[sel], at(0.5 * tall)[sel]
    foot, head = foot[sel], head[sel]
    lean = (head[:, 0] - low[:, 0]) / (head[:, 1] - low[:, 1])
    hh = foot[:, 1] - head[:, 1]
    top = head[:, 1] + rng.normal(0, 1.5, n)
    bottom = foot[:, 1] - 0.01 * hh + rng.normal(0, 1.5, n)
    boxes = np.column_stack([mid[:, 0] - 0.25 * hh, top, 0.5 * hh, bottom - top])
    slants = lean + rng.normal(0, 0.04, n)
    slants[rng.random(n) < 0.25] = np.nan
    truth = np.column_stack([foot[:, 0] - 1, foot[:, 1] - 10, np.full(n, 2.0),
                             np.full(n, 10.0)])
    return cam, boxes, slants, truth, ground[sel, :2]


def test_unmodelled_barrel_distortion_lengthens_the_focal_and_the_fit_removes_it():
    # barrel distortion straightens the leans at the image's sides: a pinhole fit puts the
    # vertical vanishing point too far, the focal length comes out long and the ground
    # positions drift by half a metre; fitting the distortion with the leans removes it
    errs = {"pinhole": [], "fitted": [], "pinhole0": [], "fitted0": []}
    for seed in range(3):
        for k1, tag in ((-0.2, ""), (0.0, "0")):
            cam, boxes, slants, truth, ground = _distorted_scene(k1, seed)
            for name, fd in (("pinhole", False), ("fitted", None)):
                fit = estimate_camera_from_people(boxes, SIZE, slants=slants, n_bootstrap=0,
                                                  slant_top_fraction=0.85, fit_distortion=fd,
                                                  rng=np.random.default_rng(0))
                r = compare_with_reference(fit, cam, truth, ground)
                errs[name + tag].append((fit.focal_px, r["median_error_m"],
                                         r["horizon_error_px"], fit.distortion_k))
                if fd is False:
                    assert fit.distortion_k == 0.0 and fit.camera.distortion.is_identity
                elif k1:
                    assert any("distortion" in t for t in fit.notes)
                    assert fit.camera.distortion.params()["kappa1"] > 0
    e = {k: np.asarray(v) for k, v in errs.items()}
    # the old estimator's bias (measured: focal 5-7 % long, median ground error 0.62-0.69 m)
    assert np.all(e["pinhole"][:, 0] > 1030) and np.all(e["pinhole"][:, 1] > 0.45)
    # with the distortion fitted (measured: focal within 0.5 %, 0.09-0.15 m, k 0.040-0.053;
    # the lens displaces the corner by 4.6 %)
    assert np.all(np.abs(e["fitted"][:, 0] - 1000) < 20)
    assert np.all(e["fitted"][:, 1] < 0.2) and e["fitted"][:, 1].mean() < 0.15
    assert np.all(e["fitted"][:, 2] < 3)
    assert np.all((e["fitted"][:, 3] > 0.03) & (e["fitted"][:, 3] < 0.07))
    # a pinhole lens: the distortion fitted stays near 0 and costs a few centimetres at most
    # (measured: |k| <= 0.0025, 0.085-0.108 m against 0.078-0.087 m)
    assert np.all(np.abs(e["fitted0"][:, 3]) < 0.006)
    assert np.all(e["fitted0"][:, 1] < e["pinhole0"][:, 1] + 0.04)
    assert np.all(e["fitted0"][:, 1] < 0.15)


def test_few_clicked_boxes_fix_roll_and_still_give_a_camera():
    cam = camera_from_parameters(927.0, 14.0, 0.0, 6.0, SIZE)
    boxes, _ = _people(cam, 5, np.random.default_rng(11), height_sd=0.03)
    boxes[:, 0] = np.clip(boxes[:, 0], 300, 400)  # all near the middle column
    fit = estimate_camera_from_people(boxes, SIZE, n_bootstrap=20)
    assert fit.roll_deg == 0.0 and fit.uncertainty["roll_deg"] == 0.0
    assert any("roll not fitted" in n for n in fit.notes)
    assert fit.camera_height_m == pytest.approx(6.0, rel=0.15)


@pytest.mark.parametrize("boxes,match", [
    (np.zeros((5, 3)), "shape"),
    ([[10, 10, 20, 50], [100, 100, 20, 60]], "at least 3"),
    ([[10, 100, 20, 50], [100, 101, 20, 50], [200, 100, 20, 50], [300, 100, 20, 51]],
     "several distances"),
    ([[10, 0, 20, 50], [100, 200, 20, 100], [200, 400, 20, 176]], "usable boxes"),
])
def test_bad_boxes_are_named(boxes, match):
    with pytest.raises(ValueError, match=match):
        estimate_camera_from_people(boxes, SIZE)


def test_rigid_align_2d_recovers_a_motion():
    rng = np.random.default_rng(2)
    src = rng.normal(size=(50, 2)) * 5
    a = math.radians(37.0)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    dst = src @ R.T + [3.0, -4.0]
    R2, t2 = rigid_align_2d(src, dst)
    assert np.allclose(R2, R) and np.allclose(t2, [3.0, -4.0])
    # a mirror image is not a rigid motion: no reflection is used
    R3, _ = rigid_align_2d(src * [1, -1], dst)
    assert np.linalg.det(R3) == pytest.approx(1.0)


def _pets_gt(a, b):
    gt = np.loadtxt(data_path("pets09", "gt.txt"), delimiter=",")
    return gt[(gt[:, 0] >= a) & (gt[:, 0] <= b) & (gt[:, 6] != 0)]


def test_pets_ground_truth_boxes_against_the_tsai_camera():
    # frames 1-100 of PETS 2009 S2.L1, boxes from the ground truth (an upper bound of quality);
    # measured: see docs/decisions/camera-from-people.md
    ref = load_camera(data_path("pets09", "View_001.xml"))
    gt = _pets_gt(1, 100)
    fit = estimate_camera_from_people(gt[:, 2:6], SIZE, 1.7, n_bootstrap=20)
    r = compare_with_reference(fit, ref, gt[:, 2:6], gt[:, 7:9])
    assert r["points"] == len(gt)
    assert r["median_error_m"] < 0.9
    assert r["horizon_error_px"] < 40
    assert fit.camera_height_m == pytest.approx(7.07, rel=0.15)
    # the people's lean measured in the video (MOG2 foreground) gives the focal length
    sl = measure_slants(data_path("pets09", "vtest.avi"), gt[:, 2:6], gt[:, 0])
    assert np.isfinite(sl).sum() > 300
    fit_l = estimate_camera_from_people(gt[:, 2:6], SIZE, 1.7, slants=sl, n_bootstrap=0)
    rl = compare_with_reference(fit_l, ref, gt[:, 2:6], gt[:, 7:9])
    assert fit_l.focal_px == pytest.approx(ref.fx, rel=0.25)
    assert rl["median_error_m"] < 0.3
    # given the true focal length the same boxes come within 0.3 m
    fit_f = estimate_camera_from_people(gt[:, 2:6], SIZE, 1.7, focal_px=ref.fx, n_bootstrap=0)
    rf = compare_with_reference(fit_f, ref, gt[:, 2:6], gt[:, 7:9])
    assert rf["median_error_m"] < 0.3
    assert rf["horizon_error_px"] < 25


# --------------------------------------------------------------------------------------------
# pftrack calib people
# --------------------------------------------------------------------------------------------


def _cli(capsys, *argv):
    import json

    from pftrack.cli import main

    capsys.readouterr()
    code = main(list(argv))
    out = capsys.readouterr()
    return code, (json.loads(out.out) if code == 0 and "--json" in argv else out)


def test_cli_people_from_a_detection_file_writes_the_camera(capsys, tmp_path):
    # the ground truth's boxes of frames 1-100 given as a MOTChallenge det file
    gt = _pets_gt(1, 100)
    det = tmp_path / "det.txt"
    det.write_text("".join(f"{int(r[0])},-1,{r[2]},{r[3]},{r[4]},{r[5]},1\n" for r in gt))
    out = tmp_path / "cam.yaml"
    code, r = _cli(capsys, "calib", "people", "--video", str(data_path("pets09", "vtest.avi")),
                   "--detections", str(det), "--frames", "1:100", "--bootstrap", "20",
                   "--out", str(out), "--reference", str(data_path("pets09", "View_001.xml")),
                   "--gt", str(data_path("pets09", "gt.txt")), "--json")
    assert code == 0
    assert r["boxes"] == len(gt) and r["inliers"] >= 0.95 * len(gt)
    assert r["reference"]["points"] == len(gt)
    # with the video the people's lean is measured and gives the focal length
    assert r["slants_used"] > 300 and r["focal_identified"]
    assert r["reference"]["median_error_m"] < 0.3 and r["reference"]["horizon_error_px"] < 50
    assert set(r["uncertainty"]) == {"horizon_row", "camera_height_m", "tilt_deg", "roll_deg",
                                     "focal_px", "distortion_k"}
    # the file is the project's camera format and holds the same camera
    cam = load_camera(out)
    assert cam.image_size == (768, 576)
    assert cam.center_m[2] == pytest.approx(r["camera_height_m"])
    assert horizon_row(cam, 383.5) == pytest.approx(r["horizon_row"])
    assert cam.metadata["people_fit"]["inliers"] == r["inliers"]
    # the lens's radial distortion, fitted with the leans, is in the file as Tsai's kappa1
    assert r["distortion_k"] != 0.0 and any("distortion" in t for t in r["notes"])
    assert cam.distortion.params()["kappa1"] == pytest.approx(
        r["distortion_k"] * r["focal_px"] ** 2 / (383.5 ** 2 + 287.5 ** 2))
    # --no-distortion: the same leans, a pinhole
    code, r3 = _cli(capsys, "calib", "people", "--video", str(data_path("pets09", "vtest.avi")),
                    "--detections", str(det), "--frames", "1:100", "--bootstrap", "0",
                    "--no-distortion", "--json")
    assert code == 0 and r3["slants_used"] == r["slants_used"] and r3["distortion_k"] == 0.0
    assert r3["uncertainty"]["distortion_k"] == 0.0
    # --no-lean: the focal-length prior
    code, r2 = _cli(capsys, "calib", "people", "--video", str(data_path("pets09", "vtest.avi")),
                    "--detections", str(det), "--frames", "1:100", "--bootstrap", "0",
                    "--no-lean", "--reference", str(data_path("pets09", "View_001.xml")),
                    "--gt", str(data_path("pets09", "gt.txt")), "--json")
    assert code == 0 and r2["slants_used"] == 0 and not r2["focal_identified"]
    assert r2["distortion_k"] == 0.0  # (no leans: not fitted)
    assert r2["reference"]["median_error_m"] < 0.9 and r2["reference"]["horizon_error_px"] < 40


def test_cli_people_with_the_lens_field_of_view_known(capsys, tmp_path):
    # the same boxes with the real camera's horizontal field of view (2 atan(384 / 1185) =
    # 35.9 deg): the focal length is then no prior and the ground error drops
    gt = _pets_gt(1, 100)
    det = tmp_path / "det.txt"
    det.write_text("".join(f"{int(r[0])},-1,{r[2]},{r[3]},{r[4]},{r[5]},1\n" for r in gt))
    ref = str(data_path("pets09", "View_001.xml"))
    code, r = _cli(capsys, "calib", "people", "--image-size", "768x576", "--detections",
                   str(det), "--hfov", "35.9", "--bootstrap", "0", "--reference", ref,
                   "--gt", str(data_path("pets09", "gt.txt")), "--frames", "1:100", "--json")
    assert code == 0 and r["focal_identified"]
    assert r["focal_px"] == pytest.approx(384 / math.tan(math.radians(35.9 / 2)))
    assert r["reference"]["median_error_m"] < 0.3
    code, out = _cli(capsys, "calib", "people", "--image-size", "768x576", "--detections",
                     str(det), "--hfov", "35.9", "--focal", "1000")
    assert code == 2 and "--hfov" in out.err


def test_cli_people_from_clicked_boxes(capsys, tmp_path):
    cam = camera_from_parameters(927.0, 14.0, 0.0, 6.0, SIZE)
    boxes, _ = _people(cam, 8, np.random.default_rng(4), height_sd=0.03)
    csv = tmp_path / "clicked.csv"
    csv.write_text("x,y,w,h\n" + "".join(f"{b[0]:.1f},{b[1]:.1f},{b[2]:.1f},{b[3]:.1f}\n"
                                         for b in boxes))
    code, r = _cli(capsys, "calib", "people", "--image-size", "768x576", "--boxes", str(csv),
                   "--bootstrap", "0", "--json")
    assert code == 0 and r["boxes"] == 8 and r["uncertainty_method"] == "jacobian"
    assert r["camera_height_m"] == pytest.approx(6.0, rel=0.1)
    assert r["horizon_row"] == pytest.approx(horizon_row(cam), abs=15)
    # a bad line is named with its file and line number
    csv.write_text("x,y,w,h\n10,20,30,40\n10,20,abc,40\n")
    code, out = _cli(capsys, "calib", "people", "--image-size", "768x576", "--boxes", str(csv))
    assert code == 2 and "line 3" in out.err and "clicked.csv" in out.err
    code, out = _cli(capsys, "calib", "people", "--boxes", str(csv))
    assert code == 2 and "--video" in out.err


@pytest.mark.slow
def test_cli_people_hog_detections_on_pets(capsys, tmp_path):
    # no labels: OpenCV's HOG people detector over frames 1-200 (every 8th), camera compared
    # with the real Tsai camera on the ground truth's feet of those frames
    code, r = _cli(capsys, "calib", "people", "--video", str(data_path("pets09", "vtest.avi")),
                   "--frames", "1:200", "--stride", "8", "--bootstrap", "20",
                   "--out", str(tmp_path / "cam.yaml"),
                   "--reference", str(data_path("pets09", "View_001.xml")),
                   "--gt", str(data_path("pets09", "gt.txt")), "--json")
    assert code == 0
    # measured with OpenCV's plain HOG (before hog-people was registered): 123 of 166 boxes,
    # 112 leans, f 1429 px, median 0.391 m, horizon error 0.8 px; with the registered
    # hog-people (its tightened boxes): 117 inliers, 110 leans, f 1304 px, median 0.139 m,
    # horizon error 34.6 px (the real horizon is 75 px above the image: a small tilt error)
    # the built-in hog-people detector is registered, so it is the one used
    assert r["source"].startswith("hog-people (registered detector)")
    assert r["inliers"] >= 80 and r["slants_used"] >= 60
    assert r["focal_px"] == pytest.approx(1185.0, rel=0.3)
    assert r["reference"]["median_error_m"] < 0.5
    assert r["reference"]["horizon_error_px"] < 45


def test_detect_people_uses_a_registered_hog_people_detector(tmp_path):
    from pftrack import hookimpl
    from pftrack.contracts.components import Detections, Detector
    from pftrack.host import Host
    from pftrack.scenes.video import write_test_clip
    from pftrack.workflows.calibrate import detect_people

    class _Fixed(Detector):
        def __init__(self, score: float = 2.0) -> None:
            self.score = score

        def detect(self, frame):
            return Detections([[frame.index, 5.0, 10.0, 30.0], [0.0, 0.0, 4.0, 8.0]],
                              [self.score, -1.0])

    class _Plugin:
        @hookimpl
        def pftrack_register_detectors(self, register):
            register("hog-people", _Fixed)

    video = tmp_path / "clip.avi"
    write_test_clip(video, tmp_path / "gt.txt", n_frames=7, size_wh=(80, 72))
    host = Host(load_entry_points=False, plugins=[("fake", _Plugin())])
    rows, name = detect_people(video, 2, 7, stride=2, host=host, min_score=0.0)
    assert name.startswith("hog-people")
    # frames 2, 4, 6; the negative-score box dropped; x holds the frame to show the order
    assert rows[:, 4].tolist() == [2, 4, 6] and rows[:, 0].tolist() == [2, 4, 6]
    assert np.allclose(rows[:, 1:4], [5.0, 10.0, 30.0]) and np.allclose(rows[:, 5], 2.0)
    # without one: OpenCV's HOG on the same clip (a white square: nobody)
    rows, name = detect_people(video, 1, 3, host=Host(load_entry_points=False))
    assert "OpenCV HOG" in name and rows.shape == (0, 6)
    with pytest.raises(ValueError, match="stride"):
        detect_people(video, 1, 3, stride=0, host=host)
    # frames smaller than HOG's window (OpenCV would crash): named, with the way out
    with pytest.raises(ValueError, match="smaller than the HOG window.*raise upscale"):
        detect_people(video, 1, 3, host=Host(load_entry_points=False), upscale=1.0)


def test_estimate_camera_from_video_with_given_boxes():
    from pftrack.workflows.calibrate import estimate_camera_from_video

    gt = _pets_gt(1, 60)
    video = data_path("pets09", "vtest.avi")
    boxes = np.column_stack([gt[:, 2:6], gt[:, 0]])
    fit, rows, source = estimate_camera_from_video(video, boxes, n_bootstrap=0)
    assert rows.shape == (len(gt), 6) and np.all(rows[:, 5] == 1) and "given" in source
    assert fit.slants_used > 100 and fit.focal_identified
    # the same without the lean: the prior, and the lean skipped when the focal is known
    fit0, _, _ = estimate_camera_from_video(video, boxes, lean=False, n_bootstrap=0)
    assert fit0.slants_used == 0 and not fit0.focal_identified
    fit1, _, _ = estimate_camera_from_video(video, boxes, focal_px=1185.0, n_bootstrap=0)
    assert fit1.slants_used == 0 and fit1.focal_px == pytest.approx(1185.0)
    with pytest.raises(ValueError, match=r"shape \(N, >=5\)"):
        estimate_camera_from_video(video, gt[:, 2:6])


# --------------------------------------------------------------------------------------------
# silhouettes: exact heights and leans from the moving pixels; people linked over frames
# --------------------------------------------------------------------------------------------


def _leaning_people_clip(path, n_frames=40, size=(320, 240)):
    """A grey background, empty for 20 frames (the background model learns it), then two
    leaning people (parallelograms, 90 and 60 px tall, leans +0.15 and -0.10 du/dv) walking
    across, and a blob beside the first; MJPG, 10 fps."""
    import cv2

    w, h = size
    truth = []  # frame, x_foot, foot_row (exclusive), height, lean
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (w, h))
    people = [(40.0, 200, 90, 0.15, 3.0), (200.0, 150, 60, -0.10, 2.0)]
    for f in range(1, n_frames + 1):
        img = np.full((h, w, 3), 90, np.uint8)
        for k, (x0, foot, ph, lean, vx) in enumerate(people if f > 20 else []):
            xf = x0 + vx * f
            width = 0.3 * ph
            rows = np.arange(foot - ph, foot)
            for v in rows:  # the axis leans: u = xf + lean * (v - foot)
                c = xf + lean * (v - foot)
                img[v, int(round(c - width / 2)):int(round(c + width / 2))] = 230
            if k == 0:  # a small blob to the right of the head: not the person
                img[foot - ph + 5:foot - ph + 15, int(xf + 22):int(xf + 28)] = 230
            truth.append([f, xf, foot, ph, lean])
        out.write(img)
    out.release()
    return np.asarray(truth)


def test_measure_silhouettes_gives_heights_and_leans_of_a_synthetic_clip(tmp_path):
    from pftrack.geometry.people_boxes import refine_boxes_by_silhouettes
    from pftrack.workflows.calibrate import measure_silhouettes

    video = tmp_path / "lean.avi"
    truth = _leaning_people_clip(video)
    # from 3 frames after they appear; not much later: MOG2's rate, 1 / frames seen, soon
    # learns the trailing side of these uniform, slow people into the background
    late = truth[(truth[:, 0] > 23) & (truth[:, 0] <= 32)]
    # detector-like boxes: 10 % too tall and 4 px low, widened, not leaning
    boxes = np.column_stack([late[:, 1] - 0.3 * late[:, 3], late[:, 2] - 1.1 * late[:, 3] + 4,
                             0.6 * late[:, 3], 1.1 * late[:, 3]])
    sil = measure_silhouettes(video, boxes, late[:, 0], warmup=25)
    assert np.isfinite(sil).all()
    # top and bottom rows within 2 px, leans within 0.03 (the blob is not the person), for
    # nearly all; an occasional hole in the foreground (a compression artefact) cuts one short
    top_err = np.abs(sil[:, 1] - (late[:, 2] - late[:, 3]))
    assert np.mean(top_err <= 2) >= 0.8 and np.median(top_err) <= 1
    assert np.all(np.abs(sil[:, 2] - late[:, 2]) <= 2)
    lean_ok = np.abs(sil[:, 0] - late[:, 4]) <= 0.03
    assert lean_ok.mean() >= 0.8 and np.median(np.abs(sil[:, 0] - late[:, 4])) < 0.015
    # the detector-like boxes get the silhouettes' rows; the cut ones are left as they were
    fixed, used = refine_boxes_by_silhouettes(boxes, sil)
    assert used.mean() >= 0.8 and np.all(np.abs(fixed[used, 3] - late[used, 3]) <= 3)
    assert np.array_equal(fixed[~used], boxes[~used])
    assert np.array_equal(fixed[:, [0, 2]], boxes[:, [0, 2]])
    # a silhouette far from its box's height (merged, cut) is not used
    bad = sil.copy()
    bad[:, 2] = bad[:, 1] + 1.35 * boxes[:, 3]
    fixed, used = refine_boxes_by_silhouettes(boxes, bad)
    assert not used.any() and np.array_equal(fixed, boxes)
    # no moving pixels in the box (a box on the background): not measured
    empty = measure_silhouettes(video, [[150.0, 20.0, 20.0, 50.0]], [30], warmup=25)
    assert np.isnan(empty).all()
    with pytest.raises(ValueError, match="2 boxes but 1 frames"):
        measure_silhouettes(video, boxes[:2], [30])


def test_silhouettes_measured_in_the_detection_pass_equal_their_own_pass(tmp_path):
    """pftrack track measures the camera's silhouettes while it detects (the frames decoded
    once): the same numbers as measure_silhouettes' own pass over the video, for the boxes
    estimate_camera chooses (every 2nd frame, scored >= min_score, background at half size)."""
    from pftrack.contracts.components import Detections
    from pftrack.workflows.calibrate import measure_silhouettes
    from pftrack.workflows.pipeline import iter_frames
    from pftrack.workflows.track import CalibrationSilhouettes

    video = tmp_path / "lean.avi"
    truth = _leaning_people_clip(video, n_frames=40)
    boxes = np.column_stack([truth[:, 1] - 0.3 * truth[:, 3],
                             truth[:, 2] - 1.1 * truth[:, 3] + 4,
                             0.6 * truth[:, 3], 1.1 * truth[:, 3]])
    scores = np.where(np.arange(len(truth)) % 3 == 0, 0.4, 0.9)  # some below min_score

    def dets(f):
        at = truth[:, 0] == f
        return Detections(boxes[at], scores[at])

    def fed(first, **kw):
        sil = CalibrationSilhouettes(0.5, **kw)
        for frame in iter_frames(video, first, None):
            sil.feed(frame.index, frame.image, dets(frame.index))
        return sil

    chosen = (scores >= 0.5) & ((truth[:, 0] - 1) % 2 == 0)
    own = measure_silhouettes(video, boxes[chosen], truth[chosen, 0], every=2, scale=0.5)
    sil = fed(1)
    got = sil.measured(1, int(chosen.sum()), 0.5, 600, 2, 0.5)
    assert got is not None and np.isfinite(own).sum() >= 10
    assert np.array_equal(got, own, equal_nan=True)
    # the camera estimate chose otherwise (other settings, other boxes): its own pass
    assert sil.measured(1, int(chosen.sum()), 0.5, 600, 1, 0.5) is None
    assert sil.measured(1, int(chosen.sum()), 0.6, 600, 2, 0.5) is None
    assert sil.measured(1, int(chosen.sum()) + 1, 0.5, 600, 2, 0.5) is None
    # frames from 15: the warm-up reaches before them, so this pass cannot stand in
    assert fed(15).measured(15, 1, 0.5, 600, 2, 0.5) is None


def test_link_boxes_follows_people_over_frames():
    from pftrack.geometry.people_boxes import link_boxes

    # two people moving 3 px a frame, listed in a shuffled order; frame 5 is missing
    rows = []
    for f in (1, 2, 3, 4, 6, 7):
        rows.append([10 + 3 * f, 50, 20, 50, f])
        rows.append([200 - 3 * f, 60, 24, 60, f])
    rows = np.asarray(rows, dtype=float)
    perm = np.random.default_rng(0).permutation(len(rows))
    ids = link_boxes(rows[perm, :4], rows[perm, 4])
    back = np.empty_like(ids)
    back[perm] = ids
    a, b = back[0::2], back[1::2]
    # one number per person while linked; the missing frame starts both anew
    assert len(set(a[:4])) == 1 and len(set(b[:4])) == 1 and a[0] != b[0]
    assert len(set(a[4:])) == 1 and len(set(a[4:]) | set(a[:4])) == 2
    assert len(set(back)) == 4
    # a box that jumped (IoU < min_iou) is someone new
    ids = link_boxes([[0, 0, 10, 10], [30, 0, 10, 10]], [1, 2])
    assert ids.tolist() == [0, 1]


def test_people_bootstrap_is_wider_when_a_persons_leans_share_an_error():
    # each of 25 people seen in 16 frames leans with their own bias (a posture): the boxes'
    # bootstrap treats 400 leans as independent, the people's one (groups) does not
    rng = np.random.default_rng(5)
    cam = camera_from_parameters(1200.0, 17.0, -2.0, 7.0, SIZE)
    boxes, n = _people(cam, 25, rng)
    reps = np.repeat(np.arange(n), 16)
    bx = boxes[reps] + rng.normal(0, 0.5, (len(reps), 4))
    feet = np.column_stack([bx[:, 0] + bx[:, 2] / 2, bx[:, 1] + bx[:, 3]])
    ground = cam.image_to_ground(feet)
    lo = cam.project(ground + [0, 0, 0.3 * 1.7])
    hi = cam.project(ground + [0, 0, 1.7])
    lean = (hi[:, 0] - lo[:, 0]) / (hi[:, 1] - lo[:, 1])
    slants = lean + rng.normal(0, 0.04, n)[reps] + rng.normal(0, 0.01, len(reps))
    kw = {"slants": slants, "n_bootstrap": 60, "rng": np.random.default_rng(0)}
    by_box = estimate_camera_from_people(bx, SIZE, **kw)
    kw["rng"] = np.random.default_rng(0)
    by_person = estimate_camera_from_people(bx, SIZE, groups=reps, **kw)
    # the same fit, a wider and more honest 1-sigma
    assert by_person.focal_px == pytest.approx(by_box.focal_px)
    assert by_person.uncertainty["focal_px"] > 2 * by_box.uncertainty["focal_px"]
    assert abs(by_person.focal_px - 1200.0) < 3 * by_person.uncertainty["focal_px"]
    import re

    people = [int(m) for t in by_person.notes for m in re.findall(r"of (\d+) people", t)]
    assert len(people) == 1 and 0.8 * n <= people[0] <= n
    with pytest.raises(ValueError, match="groups has 3 values"):
        estimate_camera_from_people(bx, SIZE, groups=[1, 2, 3])


@pytest.mark.slow
def test_pftrack_track_camera_on_pets_frames_1_200_is_within_half_a_metre():
    # what `pftrack track` does on a new video: hog-people over frames 1-200 (no labels), the
    # camera from every 2nd frame's confident people (silhouettes at half size, their lean);
    # scored against the real Tsai camera on the ground truth's feet of all 795 frames.
    # Measured: f 1202 px, 0.10-0.16 m, horizon 1-2 px (every frame); see
    # docs/decisions/camera-from-people.md
    import cv2
    from pftrack.workflows.pipeline import load_config
    from pftrack.workflows.track import detect_video, estimate_camera

    video = data_path("pets09", "vtest.avi")
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        dets, size, _ = detect_video(video, load_config("people-ground"), (1, 200))
    finally:
        cv2.setNumThreads(threads)
    fit, why = estimate_camera(dets, size, seed=0, video=video)
    assert fit is not None and "every 2" in why and "lean" in why
    gt = _pets_gt(1, 795)
    r = compare_with_reference(fit, load_camera(data_path("pets09", "View_001.xml")),
                               gt[:, 2:6], gt[:, 7:9])
    assert r["median_error_m"] <= 0.5
    assert r["horizon_error_px"] <= 25
    assert fit.camera_height_m == pytest.approx(7.07, rel=0.08)
    assert fit.focal_px == pytest.approx(1185.0, rel=0.2)
    # the people's bootstrap: an honest 1-sigma of tens of per cent of the focal's error
    assert abs(fit.focal_px - 1185.0) < 3 * fit.uncertainty["focal_px"]
    assert fit.slants_used >= 200
