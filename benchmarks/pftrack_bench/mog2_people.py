"""``mog2`` blob boxes against its person boxes (``person_height_m``) through cameras, on PETS
2009 S2.L1.

``pftrack bench mog2-people --json`` runs MOG2 once over the frames (default settings, learning
from frame 1) and makes, from each frame's same foreground mask, the blob boxes and the person
boxes through each camera (``--camera``, repeatable; default the real Tsai camera
``View_001.xml``; e.g. also a ``pftrack calib people`` camera file). Recall and precision at IoU
0.5 of every box against the visible ground-truth people
(:func:`pftrack_bench.fresh_video.detector_recall_precision`: one-to-one Hungarian
matching per frame; a box matched to a flag-0 person counts neither way).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from pftrack_bench.protocol import Protocol

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="PETS 2009 S2.L1 with its Tsai camera",
    chosen_on="nothing is tuned: OpenCV MOG2's defaults, a 1.7 m person",
    reported_on="frames 201-795 (MOG2 learns from frame 1)",
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--data", default=None,
                        help="folder holding pets09/ (default: $PFTRACK_DATA or ../shared/data)")
    parser.add_argument("--frames", default="201:795", metavar="A:B",
                        help="frames scored, ground-truth numbering (default 201:795); MOG2 "
                             "learns from frame 1 on")
    parser.add_argument("--camera", action="append", default=None, metavar="FILE",
                        help="camera file for the person boxes (repeatable; default the real "
                             "View_001.xml)")
    parser.add_argument("--person-height", type=float, default=1.7, metavar="M",
                        help="person height of the person boxes (default 1.7 m)")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


def run(args: argparse.Namespace) -> dict[str, Any]:
    import cv2
    from pftrack.contracts.components import Detections
    from pftrack.geometry.formats import load_camera
    from pftrack.io.data import pets09_files
    from pftrack.io.frames import parse_frames
    from pftrack.workflows.pipeline import iter_frames, read_ground_truth
    from pftrack_basic.background import BackgroundSubtractionDetector, person_boxes

    from pftrack_bench.fresh_video import detector_recall_precision

    video, gt, real = pets09_files(args.data)
    first, last = parse_frames(args.frames)
    paths = args.camera or [str(real)]
    cams = {str(p): load_camera(p) for p in paths}
    det = BackgroundSubtractionDetector()
    blob: dict[int, Detections] = {}
    person: dict[str, dict[int, Detections]] = {p: {} for p in cams}
    if not args.quiet:
        print(f"mog2-people: MOG2 over frames 1:{last} ...", file=sys.stderr, flush=True)
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        for frame in iter_frames(video, 1, last):
            mask = det.foreground_mask(frame)
            if frame.index < first or det.frames_seen_ <= int(det.warmup_frames):
                continue
            _, _, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
            stats = stats[1:]
            area = stats[:, cv2.CC_STAT_AREA].astype(np.float64)
            keep = area >= float(det.min_area_px)
            boxes = stats[keep, :4].astype(np.float64)
            blob[frame.index] = Detections(
                boxes, area[keep] / np.maximum(boxes[:, 2] * boxes[:, 3], 1.0))
            for p, cam in cams.items():
                person[p][frame.index] = person_boxes(
                    mask, boxes, cam, float(args.person_height), float(det.person_aspect),
                    float(det.merge_slack), float(det.split_ratio))
    finally:
        cv2.setNumThreads(threads)
    gt_rows = read_ground_truth(gt, first, last if last is not None else 10**9)
    last_seen = max(blob) if blob else first
    rows = [{"boxes": "blob", "camera": None,
             **detector_recall_precision(gt_rows, blob, 0.0)}]
    for p in cams:
        rows.append({"boxes": "person", "camera": p,
                     **detector_recall_precision(gt_rows, person[p], 0.0)})
    return {"frames": f"{first}:{last_seen}", "person_height_m": float(args.person_height),
            "rows": rows}


def format_table(result: dict[str, Any]) -> str:
    lines = [f"PETS 2009 S2.L1 frames {result['frames']}: mog2 boxes at IoU 0.5",
             f"{'boxes':<8s}{'recall':>8s}{'precision':>11s}  camera"]
    for r in result["rows"]:
        lines.append(f"{r['boxes']:<8s}{r['detector_recall']:8.3f}"
                     f"{r['detector_precision']:11.3f}  {r['camera'] or '-'}")
    return "\n".join(lines)
