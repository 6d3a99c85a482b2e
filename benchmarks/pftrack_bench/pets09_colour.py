"""Every person of PETS 2009 S2.L1 from their first ground-truth box: pftrack's cross entropy
with background against OpenCV's TrackerMIL and TrackerCSRT, initialised identically.

``pftrack bench pets09-colour --json`` prints, per method, the mean centre error (px), the
success rate (IoU >= 0.5 with the ground truth over every frame where a person is present),
person-updates and video frames per second (decoding excluded; OpenCV on one thread) and MOTA,
IDF1 and HOTA of the whole set of tracks (``pftrack.metrics.evaluate``); pftrack's row is the
mean of ``--repeats`` seeds (default 3), each listed under ``runs``. ``--frames A:B`` runs
a slice (ground-truth numbering, 1..795; default: the whole sequence, about 3 minutes on one
core, most of it MIL and CSRT). Data: ``$PFTRACK_DATA/pets09`` (default ``../shared/data``).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from pftrack_bench.protocol import Protocol

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="PETS 2009 S2.L1, every person started from their first ground-truth box",
    chosen_on="all 795 frames: the colour region, its three stripes and the "
              "per-person weighting were compared on the whole sequence (no held-out "
              "part); OpenCV's trackers keep their defaults",
    reported_on="all 795 frames, tracking seeds 0-2",
)


def _frames(text: str) -> tuple[int, int | None]:
    try:
        a, _, b = text.partition(":")
        first = int(a) if a.strip() else 1
        last = int(b) if b.strip() else None
    except ValueError:
        raise argparse.ArgumentTypeError(f"--frames must be A:B (ground-truth frame numbers), "
                                         f"got {text!r}") from None
    if first < 1 or (last is not None and last < first):
        raise argparse.ArgumentTypeError(f"--frames {text!r}: need 1 <= A <= B")
    return first, last


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--frames", type=_frames, default=None, metavar="A:B",
                        help="ground-truth frames to run (default: all, 1:795)")
    parser.add_argument("--methods", default="cross-entropy-bg,mil,csrt",
                        help="comma-separated: cross-entropy-bg, mil, csrt (default: all three)")
    parser.add_argument("--seed", type=int, default=0, help="pftrack's first tracker seed")
    parser.add_argument("--repeats", type=int, default=3,
                        help="pftrack runs (seeds seed..seed+R-1); its row is their mean "
                             "(default 3; each run takes seconds)")
    parser.add_argument("--particles", type=int, default=None,
                        help="pftrack particles per person (default 300)")
    parser.add_argument("--sigma", type=float, default=None,
                        help="pftrack random-walk noise per frame, px (default 6)")
    parser.add_argument("--data", default=None, help="folder holding vtest.avi and gt.txt "
                        "(default: $PFTRACK_DATA/pets09)")
    parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")


def run(args: argparse.Namespace) -> dict[str, Any]:
    import cv2
    from pftrack.host import get_host

    get_host().get("likelihood", "cross-entropy-bg")  # a clear error without the plugin
    from pftrack_colour.pets import pets_experiment

    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    bad = [m for m in methods if m not in ("cross-entropy-bg", "mil", "csrt")]
    if bad:
        raise ValueError(f"--methods: unknown {bad}; use cross-entropy-bg, mil, csrt")
    tracker = {}
    if args.particles is not None:
        tracker["n_particles"] = args.particles
    if args.sigma is not None:
        tracker["sigma_px"] = args.sigma
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        return pets_experiment(
            methods, args.frames, data=args.data, tracker=tracker, seed=args.seed,
            repeats=args.repeats,
            progress=None if args.quiet else (lambda s: print(s, file=sys.stderr, flush=True)))
    finally:
        cv2.setNumThreads(threads)


def format_table(result: dict[str, Any]) -> str:
    s = result["setup"]
    lines = [(f"{s['sequence']}, frames {s['frames'][0]}-{s['frames'][1]}, {s['persons']} "
              f"persons, {s['gt_boxes']} ground-truth boxes"),
             (f"{'method':<18s}{'centre err px':>14s}{'success':>9s}{'updates/s':>11s}"
              f"{'frames/s':>10s}{'MOTA':>8s}{'IDF1':>7s}{'HOTA':>7s}")]
    for r in result["rows"]:
        lines.append(f"{r['method']:<18s}{r['mean_center_error_px']:14.1f}"
                     f"{r['success_rate']:9.3f}{r['updates_per_second']:11.1f}"
                     f"{r['frames_per_second']:10.1f}{r['MOTA']:8.3f}{r['IDF1']:7.3f}"
                     f"{r['HOTA']:7.3f}")
    for r in result["rows"]:
        if "runs" in r:
            lines.append(f"{r['method']}: mean of {len(r['runs'])} seeds; success per seed "
                         + ", ".join(f"{x['success_rate']:.3f}" for x in r["runs"])
                         + "; centre error per seed "
                         + ", ".join(f"{x['mean_center_error_px']:.1f}" for x in r["runs"]))
    lines.append("Protocol: " + s["protocol"])
    return "\n".join(lines)
