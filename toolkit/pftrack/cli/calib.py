"""``pftrack calib``: check, calibrate and convert cameras.

* ``calib check CAMERA --gt GT.txt`` -- project a MOTChallenge ground truth's world positions
  (columns 8-10, metres, ground plane z = 0) and compare with the boxes' foot points (bottom
  centre); back-project the foot points onto z = 0 and compare with the world positions.
* ``calib chessboard IMAGE... --board 9x6 --square 0.025 [--fix-aspect] --out CAMERA``
* ``calib points WORLD_PIXELS.csv --image-size WxH --out CAMERA`` (CSV header X,Y,Z,u,v)
* ``calib convert IN OUT [--format F]`` -- says what the target format cannot hold and the
  residual of any refit.
* ``calib show CAMERA`` -- the camera's parameters.
* ``calib people --video V [--boxes CSV | --detections det.txt] [--frames A:B]
  [--person-height 1.7] --out CAMERA`` -- a ground-plane camera from person boxes (clicked,
  a MOTChallenge detection file, or found by the HOG people detector over the video), with the
  1-sigma of each figure; ``--reference CAM --gt GT`` compares it with a known camera.

With ``--json`` each prints one JSON object (the figures checks read).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING, Any

from pftrack.cli import _args

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


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (v > 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return v


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
    b.add_argument("--square", type=_positive, default=0.025, help="square side in metres")
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

    e = csub.add_parser(
        "people", help="estimate a ground-plane camera from the people in a video",
        description="Estimate a pinhole ground-plane camera (horizon, height, tilt, roll; focal "
                    "length from the people's lean in the video when boxes have frames, else a "
                    "45 deg field-of-view prior, unless --focal/--hfov) from person boxes, "
                    "assuming a mean person height. Boxes: --boxes (a CSV of "
                    "x,y,w,h[,frame] you clicked), --detections (MOTChallenge det.txt), or, "
                    "with neither, people detected over the video (a registered 'hog-people' "
                    "detector if there is one, else OpenCV's HOG people detector).")
    e.add_argument("--video", help="the video (its frame size; the frames to detect in)")
    e.add_argument("--image-size", type=_size, help="WxH when no --video is given")
    src = e.add_mutually_exclusive_group()
    src.add_argument("--boxes", help="CSV of person boxes x,y,w,h[,frame] (pixels)")
    src.add_argument("--detections", help="MOTChallenge det.txt (frame,id,x,y,w,h,score,...)")
    e.add_argument("--frames", default=None, metavar="A:B",
                   help="frames A..B inclusive (1-based) to use or detect in; default all")
    e.add_argument("--stride", type=_args.positive_int, default=4,
                   help="detect in every Nth frame (default 4)")
    e.add_argument("--min-score", type=float, default=None,
                   help="drop detections scoring below this (default: keep all)")
    e.add_argument("--person-height", type=float, default=1.7,
                   help="mean person height in metres (default 1.7)")
    e.add_argument("--focal", type=float, default=None,
                   help="known focal length in pixels (else the prior, or --fit-focal)")
    e.add_argument("--hfov", type=float, default=None, metavar="DEG",
                   help="known horizontal field of view in degrees (sets --focal)")
    e.add_argument("--fit-focal", action="store_true",
                   help="fit the focal length from the boxes (undistorted video, tight boxes)")
    e.add_argument("--no-lean", action="store_true",
                   help="do not measure people's lean in the video (the focal length then "
                        "comes from the prior unless --focal/--hfov)")
    e.add_argument("--no-distortion", action="store_true",
                   help="a pinhole: do not fit the lens's radial distortion with the leans "
                        "(fitted by default whenever the leans are used)")
    e.add_argument("--silhouettes", action=argparse.BooleanOptionalAction, default=None,
                   help="fit from the people's silhouettes in the moving pixels (their top and "
                        "bottom rows, their lean) rather than the boxes' rows (default: on when "
                        "people are detected here, off for --boxes / --detections)")
    e.add_argument("--bootstrap", type=_args.non_negative_int, default=100,
                   help="bootstrap refits for the uncertainty (0: from the Jacobian)")
    e.add_argument("--seed", type=_args.seed, default=0, help="seed of the RANSAC and bootstrap")
    e.add_argument("--out", help="write the camera here (pftrack YAML unless --format)")
    e.add_argument("--format", help="output format: pftrack, tsai, opencv, open3d")
    e.add_argument("--save-boxes", help="write the boxes used (x,y,w,h,frame,score,inlier) here")
    e.add_argument("--reference", help="a known camera to compare with (needs --gt)")
    e.add_argument("--gt", help="MOTChallenge ground truth with world x,y (m) for --reference")
    e.add_argument("--json", action="store_true")
    e.set_defaults(func=_people)

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
    from pftrack.io.outputs import check_input_file, check_output_file

    if args.out:
        check_output_file(args.out, "--out")
    for image in args.images:
        check_input_file(image, "image")
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
    import cv2

    from pftrack.geometry.calibration import calibrate_points, read_correspondences
    from pftrack.geometry.formats import load_camera
    from pftrack.io.outputs import check_output_file

    if args.out:
        check_output_file(args.out, "--out")
    X, x = read_correspondences(args.csv)
    guess = load_camera(args.camera) if args.camera else None
    try:
        res = calibrate_points(
            X, x, args.image_size, lens=args.lens, camera=guess, method=args.method,
            fix_principal_point=False if args.free_principal_point else None,
            principal_point=args.principal_point, fix_aspect=not args.free_aspect,
            radial_terms=args.radial_terms, tangential=args.tangential)
    except (ValueError, cv2.error) as exc:
        raise ValueError(f"{args.csv}: {' '.join(str(exc).split())}") from None
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
    from pftrack.io.outputs import check_output_file

    check_output_file(args.output, "output")
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


def _people(args: argparse.Namespace) -> int:
    import numpy as np

    from pftrack.geometry.alignment import compare_with_reference
    from pftrack.geometry.people import estimate_camera_from_people
    from pftrack.io.box_files import read_boxes_csv, read_detection_boxes
    from pftrack.io.frames import parse_frames
    from pftrack.workflows.calibrate import estimate_camera_from_video

    first, last = parse_frames(args.frames)
    if args.video:
        from pftrack.scenes.video import VideoScene

        frame = next(iter(VideoScene(args.video, first=first, last=first).frames()), None)
        if frame is None:
            raise ValueError(f"--video {args.video}: no frame {first} could be read")
        size = frame.size_wh
        if args.image_size and tuple(args.image_size) != size:
            raise ValueError(f"--image-size {args.image_size} differs from --video's {size}")
    elif args.image_size:
        size = tuple(args.image_size)
    else:
        raise ValueError("calib people: give --video (or --image-size with --boxes or "
                         "--detections)")
    focal = args.focal
    if args.hfov is not None:
        if focal is not None:
            raise ValueError("calib people: give --focal or --hfov, not both")
        if not 0 < args.hfov < 180:
            raise ValueError(f"calib people: --hfov must be in (0, 180) degrees, got {args.hfov}")
        import math

        focal = (size[0] / 2) / math.tan(math.radians(args.hfov) / 2)
    if args.reference and not args.gt:
        raise ValueError("calib people: --reference needs --gt (world positions to compare)")
    if args.boxes:
        rows = read_boxes_csv(args.boxes)
        if args.frames is not None and np.any(rows[:, 4] > 0):
            keep = (rows[:, 4] >= first) & ((rows[:, 4] <= last) if last else True)
            rows = rows[keep]
        rows = np.column_stack([rows, np.ones(len(rows))])
        source = f"boxes {args.boxes}"
    elif args.detections:
        rows = read_detection_boxes(args.detections, first, last, args.min_score)
        source = f"detections {args.detections}"
    else:
        if not args.video:
            raise ValueError("calib people: detecting people needs --video")
        rows, source = None, ""
    if rows is not None and len(rows) == 0:
        raise ValueError(f"calib people: no person boxes from {source}; lower --min-score, "
                         "widen --frames or give --boxes")
    fit_kw = {"focal_px": focal, "fit_focal": args.fit_focal, "n_bootstrap": args.bootstrap,
              "fit_distortion": False if args.no_distortion else None}
    rng = np.random.default_rng(args.seed)
    if args.video and (rows is None or np.all(rows[:, 4] >= 1)):
        # detection (when no boxes), the people's lean and the fit, as a library call
        fit, rows, found = estimate_camera_from_video(
            args.video, rows, first, last, args.stride, args.person_height, rng,
            lean=not args.no_lean, silhouettes=args.silhouettes,
            min_score=args.min_score or 0.0, **fit_kw)
        source = source or found
    else:
        if rows is None:
            raise ValueError("calib people: give --video, or --boxes / --detections")
        fit = estimate_camera_from_people(rows[:, :4], size, args.person_height, rng,
                                             **fit_kw)
    if rows is None:  # (estimate_camera_from_video returns the rows it found)
        raise RuntimeError("calib people: no person boxes")
    out = fit.summary()
    out["source"] = source
    out["image_size"] = list(size)
    out["saved"] = _save(fit.camera, args.out, args.format)
    if args.save_boxes:
        from pftrack.io.atomic import atomic_write_text

        lines = ["x,y,w,h,frame,score,inlier"] + [
            f"{r[0]:.2f},{r[1]:.2f},{r[2]:.2f},{r[3]:.2f},{int(r[4])},{r[5]:.4f},{int(k)}"
            for r, k in zip(rows, fit.inliers)]
        atomic_write_text(args.save_boxes, "\n".join(lines) + "\n")
        out["boxes_file"] = args.save_boxes
    if args.reference:
        from pftrack.geometry.formats import load_camera
        from pftrack.io.mot import read_mot

        ref = load_camera(args.reference)
        gt = read_mot(args.gt)
        gt = gt[gt[:, 6] != 0]
        if args.frames is not None:
            gt = gt[(gt[:, 0] >= first) & ((gt[:, 0] <= last) if last else True)]
        if not np.all(np.isfinite(gt[:, 7:9])) or np.all(gt[:, 7:9] == -1):
            raise ValueError(f"--gt {args.gt}: no world x,y columns (8-9) to compare with")
        out["reference"] = {"camera": args.reference, "gt": args.gt,
                            **compare_with_reference(fit, ref, gt[:, 2:6], gt[:, 7:9])}
    u = fit.uncertainty
    lines = [(f"{fit.inliers.sum()} of {len(rows)} boxes used ({source}), "
             f"person height {fit.person_height_m:g} m"),
             (f"  horizon row   {fit.horizon_row:9.1f} +- {u['horizon_row']:.1f} px "
             "(at the centre column)"),
             f"  camera height {fit.camera_height_m:9.2f} +- {u['camera_height_m']:.2f} m",
             f"  tilt          {fit.tilt_deg:9.2f} +- {u['tilt_deg']:.2f} deg",
             f"  roll          {fit.roll_deg:9.2f} +- {u['roll_deg']:.2f} deg",
             f"  focal length  {fit.focal_px:9.1f} +- {u['focal_px']:.1f} px"
             + _focal_source(fit),
             (f"  distortion k  {fit.distortion_k:9.4f} +- {u['distortion_k']:.4f} "
             "(radial, relative displacement at the image corner; 0: pinhole)"),
             (f"  box height spread (1-sigma, relative) {fit.residual_sd:.3f}; "
             f"1-sigma by {fit.uncertainty_method}")]
    lines += [f"  note: {n}" for n in fit.notes]
    if args.reference:
        r = out["reference"]
        lines.append(f"  vs {args.reference}: ground error median {r['median_error_m']:.3f} m, "
                     f"p90 {r['p90_error_m']:.3f} m over {r['points']} ground-truth feet "
                     f"(after the best 2-D rigid alignment, no scale); horizon error "
                     f"{r['horizon_error_px']:.1f} px")
    if args.out:
        lines.append(f"  written to {args.out}")
    return _emit(out, args.json, "\n".join(lines))


def _focal_source(fit) -> str:
    """Where the focal length printed comes from, in the words of ``fit.notes``."""
    if fit.slants_used:
        return (f" (from {fit.slants_used} leans)" if fit.focal_identified else
                f" (fitted to {fit.slants_used} leans, not identified)")
    return "" if fit.focal_identified else " (prior)"
