"""``pftrack eval GT TRACKS``: score a MOTChallenge track file against ground truth.

Prints HOTA, MOTA, IDF1 and friends as a table, or with ``--json`` a JSON object whose top-level
keys include MOTA, MOTP, IDF1, IDP, IDR, IDSW, HOTA, DetA, AssA (see
:func:`pftrack.metrics.evaluate`), and under ``plugin_metrics`` every metric a plugin registered
(hook ``pftrack_register_metrics``): ``{name: {figure: value}}``, or ``{name: {"error": ...}}``
for one that raised. ``--out FILE`` also writes the JSON, atomically.
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

    gt = read_mot(args.gt, allow_empty=False, what="ground truth")
    tracks = read_mot(args.tracks, what="tracks")
    try:
        result = evaluate(gt, tracks, metric=args.metric, threshold=args.threshold,
                          zero_marked=args.zero_marked)
    except ValueError as exc:
        raise ValueError(f"{args.gt} vs {args.tracks}: {exc}") from None
    extra = plugin_metrics(gt, tracks, metric=args.metric, threshold=args.threshold,
                           zero_marked=args.zero_marked)
    if extra:
        result["plugin_metrics"] = extra
    text = json.dumps(result, indent=2, default=float)
    if args.out:
        atomic_write_text(args.out, text + "\n")
    if args.json:
        print(text)
    else:
        print(format_table(result))
        for name, figures in extra.items():
            print(f"{name}: " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                          for k, v in figures.items()))
    return 0


def plugin_metrics(gt, tracks, **options) -> dict:
    """Every registered metric's figures on ``gt`` and ``tracks`` (MOT arrays): ``{name:
    {figure: value}}``. Each metric gets the options its signature takes; one that raises is
    reported as ``{"error": "Type: message"}`` and the others still run."""
    import inspect

    from pftrack.host import get_host

    out: dict = {}
    for entry in sorted(get_host().registry.entries("metric"), key=lambda e: e.name):
        fn = entry.obj
        try:
            params = inspect.signature(fn).parameters
            takes_all = any(p.kind is p.VAR_KEYWORD for p in params.values())
            kw = {k: v for k, v in options.items() if takes_all or k in params}
            value = fn(gt, tracks, **kw)
            if not isinstance(value, dict):
                raise TypeError(f"returned {type(value).__name__}, expected a dict")
            out[entry.name] = {str(k): (float(v) if isinstance(v, (int, float)) else v)
                               for k, v in value.items()}
        except Exception as exc:  # noqa: BLE001 - one plugin's metric must not stop the rest
            out[entry.name] = {"error": f"{type(exc).__name__}: {exc}", "plugin": entry.plugin}
    return out
