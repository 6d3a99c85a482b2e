"""``pftrack calib``: check, calibrate and convert cameras.

* ``calib check CAMERA --gt GT.txt`` -- project a MOTChallenge ground truth's world positions
  (columns 8-10, metres, ground plane z = 0) and compare with the boxes' foot points (bottom
  centre); back-project the foot points onto z = 0 and compare with the world positions.
* ``calib chessboard IMAGE... --board 9x6 --square 0.025 [--fix-aspect] --out CAMERA``
* ``calib points WORLD_PIXELS.csv --image-size WxH --out CAMERA`` (CSV header X,Y,Z,u,v)
* ``calib convert IN OUT [--format F]`` -- says what the target format cannot hold and the
  residual of any refit.
* ``calib show CAMERA`` -- the camera's parameters.

With ``--json`` each prints one JSON object (the figures checks read).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WxH (e.g. 1280x720), got {text!r}") from None
    if w <= 0 or h <= 0:
        raise argparse.ArgumentTypeError(f"size must be positive, got {text!r}")
    return w, h


def _pair(text: str) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X,Y (e.g. 640,360), got {text!r}") from None
    return a, b


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("calib", help="check, calibrate and convert cameras",
                       description=__doc__.split("\n\n")[1] if __doc__ else None,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    csub = p.add_subparsers(dest="calib_command", metavar="ACTION")

    c = csub.add_parser("check", help="compare a camera with ground-truth world positions")
    c.add_argument("camera", help="camera file (pftrack YAML, Tsai XML, OpenCV, Open3D JSON)")
    c.add_argument("--gt", required=True, help="MOTChallenge file with world columns x,y,z (m)")
    c.add_argument("--format", help="camera format if not guessed")
    c.add_argument("--flagged-only", action="store_true",
                   help="only rows whose flag column (7th) is not 0")
    c.add_argument("--json", action="store_true", help="print the figures as JSON")
    c.set_defaults(func=_check)

    b = csub.add_parser("chessboard", help="calibrate from chessboard images")
    b.add_argument("images", nargs="+", help="image files")
    b.add_argument("--board", type=_size, default=(9, 6),
                   help="inner corners COLSxROWS (default 9x6)")
    b.add_argument("--square", type=float, default=0.025, help="square side in metres")
    b.add_argument("--fix-aspect", action="store_true", help="fx = fy (CALIB_FIX_ASPECT_RATIO)")
    b.add_argument("--radial-terms", type=int, default=3, choices=(1, 2, 3))
    b.add_argument("--out", help="write the camera here (format from the name or --format)")
    b.add_argument("--format", help="output format: pftrack, tsai, opencv, open3d")
    b.add_argument("--json", action="store_true")
    b.set_defaults(func=_chessboard)

    q = csub.add_parser("points", help="calibrate from world <-> pixel correspondences")
    q.add_argument("csv", help="CSV with header X,Y,Z,u,v (metres, pixels)")
    q.add_argument("--image-size", type=_size, required=True, help="WxH in pixels")
    q.add_argument("--lens", choices=("opencv", "tsai", "none"), default="opencv")
    q.add_argument("--method", choices=("auto", "pnp", "calibrate", "dlt"), default="auto")
    q.add_argument("--camera", help="known intrinsics (and lens): solve the pose only")
    q.add_argument("--principal-point", type=_pair, help="CX,CY to fix (default image centre)")
    q.add_argument("--free-principal-point", action="store_true",
                   help="fit the principal point (needs non-coplanar points)")
    q.add_argument("--free-aspect", action="store_true", help="fit fx and fy separately")
    q.add_argument("--radial-terms", type=int, default=1, choices=(1, 2, 3))
    q.add_argument("--tangential", action="store_true", help="fit p1, p2 (OpenCV lens)")
    q.add_argument("--out", help="write the camera here (format from the name or --format)")
    q.add_argument("--format", help="output format: pftrack, tsai, opencv, open3d")
    q.add_argument("--json", action="store_true")
    q.set_defaults(func=_points)

    v = csub.add_parser("convert", help="convert a camera file to another format")
    v.add_argument("input")
    v.add_argument("output")
    v.add_argument("--format", help="output format (default: from the output name)")
    v.add_argument("--from-format", help="input format (default: guessed)")
    v.add_argument("--json", action="store_true")
    v.set_defaults(func=_convert)

    s = csub.add_parser("show", help="print a camera's parameters")
    s.add_argument("camera")
    s.add_argument("--format")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=_show)

    p.set_defaults(func=lambda a: (p.print_help(), 2)[1])


def _emit(result: dict[str, Any], as_json: bool, text: str) -> int:
    if as_json:
        print(json.dumps(result, indent=2, default=float))
    else:
        print(text)
    sys.stdout.flush()
    return 0


def _save(camera: Camera, path: str | None, fmt: str | None) -> dict[str, Any] | None:
    if not path:
        return None
    from pftrack.geometry.formats import save_camera

    report = save_camera(camera, path, fmt, approximate=True)
    return {"path": path, **report.to_dict()}


def _check(args: argparse.Namespace) -> int:
    from pftrack.geometry.calibration import check_against_mot
    from pftrack.geometry.formats import load_camera

    cam = load_camera(args.camera, args.format)
    r = check_against_mot(cam, args.gt, flagged_only=args.flagged_only)
    text = (f"{args.camera} vs {args.gt}: {r['points']} points\n"
            f"  projection of world positions to foot points: median {r['median_px']:.3f} px, "
            f"p90 {r['p90_px']:.3f} px, max {r['max_px']:.3f} px\n"
            f"  foot points back-projected to z=0: median {r['backprojection_median_m']:.3f} m, "
            f"p90 {r['backprojection_p90_m']:.3f} m")
    return _emit(r, args.json, text)


def _chessboard(args: argparse.Namespace) -> int:
    from pftrack.geometry.calibration import calibrate_chessboard

    res = calibrate_chessboard(args.images, args.board, args.square, fix_aspect=args.fix_aspect,
                               radial_terms=args.radial_terms)
    cam = res.camera
    out = {"views": len(res.views), "rms_px": res.rms_px, "fx": cam.fx, "fy": cam.fy,
           "cx": cam.cx, "cy": cam.cy, "dist": cam.distortion.coeffs.tolist(),  # type: ignore[attr-defined]
           "per_view_rms_px": res.per_view_rms_px, "skipped": res.notes,
           "saved": _save(cam, args.out, args.format)}
    text = (f"{len(res.views)} views, rms {res.rms_px:.4f} px\n"
            f"  fx {cam.fx:.3f} fy {cam.fy:.3f} cx {cam.cx:.3f} cy {cam.cy:.3f}\n"
            f"  dist {[round(v, 6) for v in out['dist']]}"
            + "".join(f"\n  {n}" for n in res.notes)
            + (f"\n  written to {args.out}" if args.out else ""))
    return _emit(out, args.json, text)


def _points(args: argparse.Namespace) -> int:
    from pftrack.geometry.calibration import calibrate_points, read_correspondences
    from pftrack.geometry.formats import load_camera

    X, x = read_correspondences(args.csv)
    guess = load_camera(args.camera) if args.camera else None
    res = calibrate_points(
        X, x, args.image_size, lens=args.lens, camera=guess, method=args.method,
        fix_principal_point=False if args.free_principal_point else None,
        principal_point=args.principal_point, fix_aspect=not args.free_aspect,
        radial_terms=args.radial_terms, tangential=args.tangential)
    out = res.summary()
    err = res.errors_px
    out["residuals"] = [
        {"i": i, "X": float(X[i, 0]), "Y": float(X[i, 1]), "Z": float(X[i, 2]),
         "u": float(x[i, 0]), "v": float(x[i, 1]), "du_px": float(res.residuals_px[i, 0]),
         "dv_px": float(res.residuals_px[i, 1]), "error_px": float(err[i])}
        for i in range(len(X))]
    out["saved"] = _save(res.camera, args.out, args.format)
    lines = [(f"{res.method}: {len(X)} points, rms {res.rms_px:.4f} px, "
              f"max {err.max():.4f} px"),
             (f"  fx {res.camera.fx:.3f} fy {res.camera.fy:.3f} cx {res.camera.cx:.3f} "
              f"cy {res.camera.cy:.3f} lens {res.camera.distortion!r}"),
             f"  camera centre (m) {res.camera.center_m.round(3).tolist()}",
             "     i         X         Y         Z         u         v   error_px"]
    lines += [f"  {i:4d} {X[i, 0]:9.3f} {X[i, 1]:9.3f} {X[i, 2]:9.3f} {x[i, 0]:9.2f} "
              f"{x[i, 1]:9.2f} {err[i]:10.4f}" for i in range(len(X))]
    lines += [f"  {n}" for n in res.notes]
    if args.out:
        lines.append(f"  written to {args.out}")
    return _emit(out, args.json, "\n".join(lines))


def _convert(args: argparse.Namespace) -> int:
    from pftrack.geometry.formats import guess_format, load_camera, save_camera

    cam = load_camera(args.input, args.from_format)
    fmt = args.format or guess_format(args.output, for_writing=True)
    report = save_camera(cam, args.output, fmt, approximate=True)
    out = {"input": args.input, "output": args.output, "format": fmt, **report.to_dict()}
    if report.exact:
        text = f"{args.input} -> {args.output} ({fmt}): exact"
    else:
        text = f"{args.input} -> {args.output} ({fmt}): approximate\n" + "\n".join(
            f"  {n}" for n in report.lost)
    return _emit(out, args.json, text)


def _show(args: argparse.Namespace) -> int:
    from pftrack.geometry.formats import camera_to_dict, load_camera

    cam = load_camera(args.camera, args.format)
    d = camera_to_dict(cam)
    d["center_m"] = cam.center_m.tolist()
    d["optical_axis"] = cam.optical_axis.tolist()
    return _emit(d, args.json, repr(cam))
