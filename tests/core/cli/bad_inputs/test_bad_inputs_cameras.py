"""Catalogue: bad camera files in each format (Tsai XML, pftrack YAML, OpenCV FileStorage,
Open3D JSON), through ``pftrack calib show``, ``pftrack calib convert`` and ``pftrack run
--camera``; and calib's other inputs (chessboard images, point correspondences). Each case
asserts exit 2, a one-line message naming the file (or the option) at fault, and that nothing on
disk changed (no converted camera, no run output)."""

from __future__ import annotations

from pathlib import Path

import pytest

from ._catalogue import assert_untouched, one_line, snapshot

ROOT = Path(__file__).resolve().parents[4]

TSAI = """<?xml version="1.0" encoding="UTF-8"?>
<Camera name="View_001">
<Geometry width="768" height="576" ncx="7.95e+02" nfx="7.52e+02" dx="4.85e-03" dy="4.65e-03"
 dpx="5.1273271277e-03" dpy="4.65e-03"/>
<Intrinsic focal="5.5549183034e+00" kappa1="5.1113043639e-03" cx="3.2422149053e+02"
 cy="2.8256650051e+02" sx="1.0937855397e+00"/>
<Extrinsic tx="8.2873214225e+02" ty="-3.1754796051e+03" tz="3.5469298547e+04"
 rx="2.0405458695e+00" ry="-8.9337703748e-01" rz="-4.3056124791e-01"/>
</Camera>
"""

PFTRACK = """format: pftrack-camera
version: 1
name: View_001
image_size: [768, 576]
K:
- [1185.0, 0.0, 324.2]
- [0.0, 1194.6, 282.5]
- [0.0, 0.0, 1.0]
R:
- [0.5695786714284309, -0.8203123526929572, -0.05165056701691645]
- [-0.2616077659883548, -0.12135625670168282, -0.9575145094117046]
- [0.7791928604834657, 0.5588920315934919, -0.283722017462328]
t_m: [0.82873214225, -3.1754796051, 35.469298547]
distortion: {model: tsai, kappa1: 0.15772011860650012}
"""

OPENCV = """%YAML:1.0
---
image_width: 768
image_height: 576
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 1185.0, 0., 324.2, 0., 1194.6, 282.5, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ -0.157, 0.073, 0.0, 0.0, -0.036 ]
extrinsic_parameters: !!opencv-matrix
   rows: 1
   cols: 6
   dt: d
   data: [ 1.67, -0.915, 0.615, 0.828, -3.175, 35.469 ]
"""

OPEN3D = """{"class_name": "PinholeCameraParameters",
 "extrinsic": [0.5695786714284309, -0.2616077659883548, 0.7791928604834657, 0.0,
   -0.8203123526929572, -0.12135625670168282, 0.5588920315934919, 0.0,
   -0.05165056701691645, -0.9575145094117046, -0.283722017462328, 0.0,
   0.82873214225, -3.1754796051, 35.469298547, 1.0],
 "intrinsic": {"height": 576, "width": 768,
   "intrinsic_matrix": [1167.7, 0.0, 0.0, 0.0, 1180.4, 0.0, 323.8, 282.5, 1.0]},
 "version_major": 1, "version_minor": 0}
"""

GOOD = {"xml": TSAI, "yaml": PFTRACK, "opencv.yml": OPENCV, "json": OPEN3D}

# (case id, suffix, old, new); "" old: replace the whole text by new
CASES = [
    ("tsai-focal-inf", "xml", 'focal="5.5549183034e+00"', 'focal="inf"'),
    ("tsai-focal-nan", "xml", 'focal="5.5549183034e+00"', 'focal="nan"'),
    ("tsai-focal-zero", "xml", 'focal="5.5549183034e+00"', 'focal="0"'),
    ("tsai-focal-negative", "xml", 'focal="5.5549183034e+00"', 'focal="-5"'),
    ("tsai-focal-word", "xml", 'focal="5.5549183034e+00"', 'focal="long"'),
    ("tsai-no-intrinsic", "xml", "<Intrinsic", "<Intrinsics"),
    ("tsai-width-zero", "xml", 'width="768"', 'width="0"'),
    ("tsai-width-word", "xml", 'width="768"', 'width="wide"'),
    ("tsai-tz-inf", "xml", 'tz="3.5469298547e+04"', 'tz="inf"'),
    ("tsai-dpx-zero", "xml", 'dpx="5.1273271277e-03"', 'dpx="0"'),
    ("tsai-sx-zero", "xml", 'sx="1.0937855397e+00"', 'sx="0"'),
    ("tsai-truncated", "xml", "</Camera>", ""),
    ("tsai-empty", "xml", "", " "),
    ("yaml-K-inf", "yaml", "[1185.0, 0.0, 324.2]", "[.inf, 0.0, 324.2]"),
    ("yaml-K-nan", "yaml", "[0.0, 1194.6, 282.5]", "[0.0, .nan, 282.5]"),
    ("yaml-fy-zero", "yaml", "[0.0, 1194.6, 282.5]", "[0.0, 0.0, 282.5]"),
    ("yaml-K-not-upper", "yaml", "[0.0, 0.0, 1.0]\nR", "[0.0, 2.0, 1.0]\nR"),
    ("yaml-R-not-rotation", "yaml", "[0.5695786714284309,", "[1.5695786714284309,"),
    ("yaml-t-short", "yaml", "t_m: [0.82873214225, -3.1754796051, 35.469298547]",
     "t_m: [0.8, -3.1]"),
    ("yaml-t-nan", "yaml", "t_m: [0.82873214225,", "t_m: [.nan,"),
    ("yaml-size-negative", "yaml", "image_size: [768, 576]", "image_size: [-768, 576]"),
    ("yaml-size-inf", "yaml", "image_size: [768, 576]", "image_size: [.inf, 576]"),
    ("yaml-size-word", "yaml", "image_size: [768, 576]", "image_size: big"),
    ("yaml-distortion-unknown", "yaml", "model: tsai", "model: fisheye9"),
    ("yaml-format-wrong", "yaml", "format: pftrack-camera", "format: other-camera"),
    ("yaml-not-yaml", "yaml", "", "K: [unclosed\n"),
    ("yaml-list", "yaml", "", "- 1\n- 2\n"),
    ("opencv-rows-2", "opencv.yml", "rows: 3\n   cols: 3", "rows: 2\n   cols: 3"),
    ("opencv-word", "opencv.yml", "1185.0,", "focal,"),
    ("opencv-no-matrix", "opencv.yml", "camera_matrix:", "camera_matrx:"),
    ("opencv-width-zero", "opencv.yml", "image_width: 768", "image_width: 0"),
    ("opencv-garbage", "opencv.yml", "", "%YAML:1.0\n---\n: : :\n"),
    ("opencv-fx-inf", "opencv.yml", "1185.0,", ".Inf,"),
    ("json-not-json", "json", "", "{not json"),
    ("json-width-negative", "json", '"width": 768', '"width": -768'),
    ("json-extrinsic-short", "json", "35.469298547, 1.0]", "35.469298547]"),
    ("json-K-nan", "json", "[1167.7,", "[NaN,"),
    ("json-no-intrinsic", "json", '"intrinsic"', '"intrinsics"'),
    ("json-list", "json", "", "[1, 2, 3]"),
]


def _bad(tmp_path: Path, suffix: str, old: str, new: str) -> Path:
    text = GOOD[suffix]
    text = new if old == "" else text.replace(old, new)
    assert text != GOOD[suffix]
    p = tmp_path / f"camera.{suffix}"
    p.write_text(text)
    return p


@pytest.mark.parametrize("suffix", sorted(GOOD))
def test_the_good_cameras_load(tmp_path, cli, suffix):
    """The originals the cases spoil are valid (so each case fails for its own spoiling)."""
    p = tmp_path / f"camera.{suffix}"
    p.write_text(GOOD[suffix])
    r = cli("calib", "show", p, "--json")
    assert r.rc == 0, r.err


@pytest.mark.parametrize(("suffix", "old", "new"), [c[1:] for c in CASES],
                         ids=[c[0] for c in CASES])
def test_bad_camera_calib_show(tmp_path, cli, suffix, old, new):
    bad = _bad(tmp_path, suffix, old, new)
    before = snapshot(tmp_path)
    r = cli("calib", "show", bad, "--json")
    assert r.rc == 2
    assert str(bad) in one_line(r.err)
    assert not r.out.strip().startswith("{")  # no camera printed (Open3D may warn on stdout)
    assert_untouched(before, tmp_path)


@pytest.mark.parametrize(("suffix", "old", "new"), [c[1:] for c in CASES[::2]],
                         ids=[c[0] for c in CASES[::2]])
def test_bad_camera_calib_convert_writes_nothing(tmp_path, cli, suffix, old, new):
    bad = _bad(tmp_path, suffix, old, new)
    (tmp_path / "old.yaml").write_text("previous output\n")
    before = snapshot(tmp_path)
    r = cli("calib", "convert", bad, tmp_path / "old.yaml")
    assert r.rc == 2
    assert str(bad) in one_line(r.err)
    assert_untouched(before, tmp_path)


@pytest.mark.parametrize(("suffix", "old", "new"), [c[1:] for c in CASES[1::5]],
                         ids=[c[0] for c in CASES[1::5]])
def test_bad_camera_stops_a_run(work, cli, suffix, old, new):
    bad = _bad(work.dir, suffix, old, new)
    before = snapshot(work.dir)
    r = cli("run", "pets09-ground", "--video", work.video, "--camera", bad, "--out", work.out,
            "--quiet")
    assert r.rc == 2
    assert str(bad) in one_line(r.err)
    assert_untouched(before, work.dir)


def test_convert_from_a_wrong_format(tmp_path, cli):
    """Reading a pftrack YAML camera as OpenCV FileStorage (OpenCV's parser raised SystemError)."""
    src = tmp_path / "cam.yaml"
    src.write_text(PFTRACK)
    before = snapshot(tmp_path)
    r = cli("calib", "convert", src, tmp_path / "o.yaml", "--from-format", "opencv")
    assert r.rc == 2
    line = one_line(r.err)
    assert str(src) in line and "'opencv'" in line
    assert_untouched(before, tmp_path)


@pytest.mark.parametrize("fmt", ["tsai", "open3d", "bogus"])
def test_show_with_a_wrong_format(tmp_path, cli, fmt):
    src = tmp_path / "cam.yaml"
    src.write_text(PFTRACK)
    r = cli("calib", "show", src, "--format", fmt)
    assert r.rc == 2
    line = one_line(r.err)
    assert (str(src) in line) or (fmt in line)


def test_missing_camera(tmp_path, cli):
    r = cli("calib", "show", tmp_path / "none.yaml")
    assert r.rc == 2 and "none.yaml" in one_line(r.err)


# ---- calib's other inputs -------------------------------------------------------------------

POINTS = {
    "collinear": "".join(f"{i},0,0,{10 + 10 * i},{10 + 3 * i}\n" for i in range(8)),
    "identical": "0,0,0,10,10\n" * 8,
    "pixels-collinear": "".join(f"{i % 3},{i // 3},0,{10 + 10 * i},10\n" for i in range(8)),
    "nan": "0,0,0,nan,10\n" + "".join(f"{i},{i * i},0,{10 * i},{5 * i}\n" for i in range(1, 8)),
    "too-few": "0,0,0,10,10\n1,0,0,20,10\n",
    "words": "a,b,c,d,e\n",
}


@pytest.mark.parametrize("case", sorted(POINTS))
def test_bad_point_correspondences(tmp_path, cli, case):
    csv = tmp_path / "points.csv"
    csv.write_text("X,Y,Z,u,v\n" + POINTS[case])
    before = snapshot(tmp_path)
    r = cli("calib", "points", csv, "--image-size", "640x480", "--out", tmp_path / "c.yaml")
    assert r.rc == 2
    assert str(csv) in one_line(r.err)
    assert_untouched(before, tmp_path)


@pytest.mark.parametrize("square", ["nan", "inf", "0", "-0.02", "two"])
def test_bad_chessboard_square(tmp_path, cli, square):
    img = tmp_path / "board.png"
    img.write_bytes(b"not used")
    before = snapshot(tmp_path)
    r = cli("calib", "chessboard", img, "--square", square, "--out", tmp_path / "c.yaml")
    assert r.rc == 2
    assert "--square" in one_line(r.err)
    assert_untouched(before, tmp_path)


def test_chessboard_image_missing(tmp_path, cli):
    r = cli("calib", "chessboard", tmp_path / "none.png", "--out", tmp_path / "c.yaml")
    assert r.rc == 2 and "none.png" in one_line(r.err)
    assert list(tmp_path.iterdir()) == []


def test_chessboard_not_images(tmp_path, cli):
    imgs = []
    for i in range(3):
        p = tmp_path / f"b{i}.png"
        p.write_text("not an image")
        imgs.append(p)
    before = snapshot(tmp_path)
    r = cli("calib", "chessboard", *imgs, "--out", tmp_path / "c.yaml")
    assert r.rc == 2
    line = one_line(r.err)
    assert "b0.png" in line or "board" in line
    assert_untouched(before, tmp_path)


def test_soccer_ground_takes_the_run_camera(work, cli):
    """``pftrack run soccer-ground --camera calib/soccer_camera.yaml`` failed with a TypeError in
    ``pitch-blob`` (a Camera where a path was expected)."""
    r = cli("run", "soccer-ground", "--video", work.video, "--camera",
            ROOT / "calib" / "soccer_camera.yaml", "--frames", "1:3", "--out", work.out,
            "--quiet", "--no-report")
    assert r.rc == 0, r.err
    assert (work.out / "tracks.txt").is_file() and not (work.out / "metrics.json").exists()
