"""``pftrack eval GT TRACKS``: score a MOTChallenge track file against ground truth.

Prints HOTA, MOTA, IDF1 and friends as a table, or with ``--json`` a JSON object whose top-level
keys include MOTA, MOTP, IDF1, IDP, IDR, IDSW, HOTA, DetA, AssA (see
:func:`pftrack.metrics.evaluate`). ``--out FILE`` also writes the JSON, atomically.
"""

from __future__ import annotations

import argparse
import json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "eval", help="score a track file against ground truth (HOTA, MOTA, IDF1)",
        description="Score MOTChallenge tracks against ground truth with TrackEval's CLEAR, "
                    "Identity and HOTA definitions.")
    p.add_argument("gt", metavar="GT", help="ground-truth MOTChallenge CSV (gt.txt)")
    p.add_argument("tracks", metavar="TRACKS", help="tracker output, MOTChallenge CSV")
    p.add_argument("--metric", choices=("iou", "world"), default="iou",
                   help="score image boxes by IoU, or ground-plane positions (x, y columns, "
                        "metres) by distance (default: iou)")
    p.add_argument("--threshold", type=float, default=None,
                   help="match threshold: IoU for --metric iou (default 0.5), metres for "
                        "--metric world (default 1.0)")
    p.add_argument("--zero-marked", choices=("drop_matched", "drop", "keep"),
                   default="drop_matched",
                   help="gt rows flagged 0: drop them and the tracks matched to them "
                        "(default), drop only the gt (TrackEval MOT15), or keep them")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--out", help="also write the JSON result to this file (atomically)")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    from pftrack.io.atomic import atomic_write_text
    from pftrack.io.mot import read_mot
    from pftrack.metrics.mot import evaluate, format_table

    gt = read_mot(args.gt)
    tracks = read_mot(args.tracks)
    try:
        result = evaluate(gt, tracks, metric=args.metric, threshold=args.threshold,
                          zero_marked=args.zero_marked)
    except ValueError as exc:
        raise ValueError(f"{args.gt} vs {args.tracks}: {exc}") from None
    text = json.dumps(result, indent=2)
    if args.out:
        atomic_write_text(args.out, text + "\n")
    print(text if args.json else format_table(result))
    return 0
