"""``pftrack run CONFIG``: track a video with a configuration and write tracks, metrics, report.

CONFIG is a YAML file or the name of a registered preset (``pftrack presets`` lists them). Writes,
atomically, ``OUT/tracks.txt`` (MOTChallenge CSV; frame numbers as in the ground truth, 1-based,
MOT frame N = video frame N-1; world columns x, y, z in metres for ground-plane state),
``OUT/tracks_uncertainty.csv`` (per row of tracks.txt: the box coordinates' standard deviations
in pixels and the ground position's covariance in m^2, from each track's particle cloud),
``OUT/metrics.json`` when ``--gt`` is given (MOTA, IDF1, HOTA on image boxes, ground-plane error,
the soccer paper's 5 px accuracy, seconds per frame) and ``OUT/report/*.png`` (overlays, and image
trajectories beside the top view). A progress bar shows on stderr unless ``--quiet``.
"""

from __future__ import annotations

import argparse
import json
import sys

from pftrack.cli import _args


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "run", help="track a video with a configuration (YAML file or preset name)",
        description="Track a video with a configuration and write OUT/tracks.txt (MOTChallenge), "
                    "OUT/tracks_uncertainty.csv (each row's box sd in px and ground covariance "
                    "in m^2), OUT/metrics.json (with --gt) and OUT/report/*.png.")
    p.add_argument("config", metavar="CONFIG", help="YAML file or preset name (pftrack presets)")
    p.add_argument("--video", required=True, help="video file (anything OpenCV decodes)")
    p.add_argument("--camera", default=None,
                   help="camera file (PETS Tsai XML, pftrack YAML, OpenCV, Open3D JSON); "
                        "needed for ground-plane (state: world) configurations")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--gt", default=None, help="MOTChallenge ground truth: also write metrics.json")
    p.add_argument("--frames", default=None, metavar="A:B",
                   help="frames A..B inclusive, ground-truth numbering (1-based); default all")
    p.add_argument("--detector-model", default=None, metavar="MODEL",
                   help="detector model file (pftrack detector train)")
    p.add_argument("--detections", default=None, metavar="FILE",
                   help="MOTChallenge det.txt (frame,id,left,top,width,height,conf): track these "
                        "detections instead of running the configuration's detector")
    p.add_argument("--seed", type=_args.seed, default=0, help="random seed (default 0)")
    p.add_argument("--no-report", action="store_true", help="do not draw report images")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    from pftrack.workflows.pipeline import run_pipeline

    result = run_pipeline(args.config, video=args.video, camera=args.camera, out_dir=args.out,
                          gt=args.gt, frames=args.frames, detector_model=args.detector_model,
                          seed=args.seed, progress=False if args.quiet else "pftrack run",
                          report=not args.no_report,
                          detections=args.detections)
    _say_why(args, result)
    if not args.quiet:
        summary = {"tracks": str(result.out_dir / "tracks.txt"), "frames": result.n_frames,  # type: ignore[operator]
                   "rows": len(result.rows),
                   "ids": len(set(result.rows[:, 1].astype(int))) if len(result.rows) else 0,
                   **result.timing}
        if result.metrics is not None:
            keys = ("MOTA", "IDF1", "HOTA", "median_error_m", "p90_error_m", "accuracy_5px")
            summary.update({k: result.metrics[k] for k in keys if k in result.metrics})
        print(json.dumps(summary, indent=2, default=float))
        sys.stdout.flush()
    return 0


def _say_why(args: argparse.Namespace, result) -> None:
    """A run with no track says why and which parameter to change (stderr)."""
    from pftrack.workflows.pipeline import load_config
    from pftrack.workflows.track import explain_no_tracks

    cfg = load_config(args.config)
    dets = result.detections if (result.detections or cfg.get("detector")
                                 or args.detections) else None
    for msg in explain_no_tracks(cfg, result.rows, dets, result.n_frames):
        print(f"pftrack run: {msg}", file=sys.stderr)
