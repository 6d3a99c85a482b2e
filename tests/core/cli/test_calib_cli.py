"""``pftrack calib``: the JSON the done-when checks read."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import ROOT
from pftrack.cli import main
from pftrack.geometry.calibration import rotation_angle_deg, soccer_pitch_keypoints
from pftrack.geometry.formats import load_camera
from pftrack.io.data import data_dir, data_path

PETS_XML = str(data_path("pets09", "View_001.xml"))
PETS_GT = str(data_path("pets09", "gt.txt"))


def _run(capsys, *argv: str) -> dict:
    capsys.readouterr()
    assert main(list(argv)) == 0
    return json.loads(capsys.readouterr().out)


def test_check_pets(capsys):
    # done-when 1 (measured: median 2.153 px, p90 2.509, max 2.820; back-projection 0.123 m)
    r = _run(capsys, "calib", "check", PETS_XML, "--gt", PETS_GT, "--json")
    assert set(r) >= {"points", "median_px", "p90_px", "max_px", "backprojection_median_m",
                      "backprojection_p90_m"}
    assert r["points"] == 4650
    assert 2.0 <= r["median_px"] <= 2.5 and r["max_px"] <= 2.9
    assert r["backprojection_median_m"] <= 0.15


@pytest.mark.parametrize("name,exact", [("v.yaml", True), ("v.xml", True),
                                        ("v.opencv.yml", False), ("v.json", False)])
def test_convert_then_check_agrees(capsys, tmp_path, name, exact):
    # done-when 2 through the CLI
    out = str(tmp_path / name)
    rep = _run(capsys, "calib", "convert", PETS_XML, out, "--json")
    assert rep["exact"] is exact
    if not exact:
        assert rep["lost"] and rep["residual_max_px"] > 0
    r0 = _run(capsys, "calib", "check", PETS_XML, "--gt", PETS_GT, "--json")
    r1 = _run(capsys, "calib", "check", out, "--gt", PETS_GT, "--json")
    tol = rep["residual_max_px"] if not exact else 1e-6
    for k in ("median_px", "p90_px", "max_px"):
        assert abs(r1[k] - r0[k]) <= tol, k


def test_convert_says_what_is_lost(capsys, tmp_path):
    assert main(["calib", "convert", PETS_XML, str(tmp_path / "p.json")]) == 0
    text = capsys.readouterr().out
    assert "approximate" in text and "cannot hold lens distortion" in text and "residual" in text


def test_chessboard_cli(capsys, tmp_path):
    # done-when 3 (measured: fx 536.109, rms 0.4088 px)
    ims = sorted(str(p) for p in (data_dir() / "chessboard").glob("left*.jpg"))
    out = tmp_path / "left.opencv.yml"
    r = _run(capsys, "calib", "chessboard", *ims, "--board", "9x6", "--square", "0.025",
             "--fix-aspect", "--out", str(out), "--json")
    assert r["views"] == 13
    assert r["fx"] == pytest.approx(535.92, rel=0.005) and r["fy"] == r["fx"]
    assert r["rms_px"] <= 0.45 and len(r["dist"]) == 5
    cam = load_camera(out)
    assert cam.fx == pytest.approx(r["fx"], rel=1e-12)


def test_points_cli_round_trip(capsys, tmp_path):
    # done-when 4 through the CLI: pitch line intersections from the shipped camera, 0.5 px noise
    truth = load_camera(ROOT / "calib" / "soccer_camera.yaml")
    X = np.array(list(soccer_pitch_keypoints().values()))
    x = truth.project(X) + np.random.default_rng(2009).normal(0.0, 0.5, (len(X), 2))
    csv = tmp_path / "pitch.csv"
    csv.write_text("name,X,Y,Z,u,v\n" + "".join(
        f"p{i},{a:.3f},{b:.3f},{c:.3f},{u:.3f},{v:.3f}\n"
        for i, ((a, b, c), (u, v)) in enumerate(zip(X, x))))
    out = tmp_path / "soccer.yaml"
    r = _run(capsys, "calib", "points", str(csv), "--image-size", "1280x720", "--lens", "tsai",
             "--out", str(out), "--json")
    assert r["points"] == 35 and len(r["residuals"]) == 35
    errs = np.array([p["error_px"] for p in r["residuals"]])
    assert np.sqrt(np.mean(errs**2)) == pytest.approx(r["rms_px"], rel=1e-9)
    assert 0.4 < r["rms_px"] < 0.85 and r["max_px"] < 2.0  # measured 0.766 / 1.715 px
    got = load_camera(out)
    assert np.linalg.norm(got.center_m - truth.center_m) < 0.5
    assert rotation_angle_deg(got.R, truth.R) < 0.2
    assert got.fx == pytest.approx(truth.fx, rel=0.01)


def test_errors_are_one_line(capsys, tmp_path):
    assert main(["calib", "check", str(tmp_path / "none.xml"), "--gt", PETS_GT]) == 2
    assert "none.xml not found" in capsys.readouterr().err
    bad = tmp_path / "gt.txt"
    bad.write_text("1,2,3,4,5,6\n")
    assert main(["calib", "check", PETS_XML, "--gt", str(bad)]) == 2
    assert "10 columns" in capsys.readouterr().err
