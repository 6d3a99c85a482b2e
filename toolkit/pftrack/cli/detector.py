"""``pftrack detector``: train and inspect sliding-window SVM detector models.

``pftrack detector train --video V --gt GT --frames 1:400 --out MODEL.npz`` trains the detector a
configuration names (default: the ``pets09-ground`` preset's ``svm`` with its training options):
positives are the ground-truth boxes with flag 1 (and their mirror images), negatives random
windows overlapping no box (seeded), plus one round of hard negatives. The model is saved as
``.npz`` without pickle. ``pftrack detector info MODEL.npz`` prints what a model holds.
"""

from __future__ import annotations

import argparse
import json
import sys

from pftrack.cli import _args


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("detector", help="train or inspect an SVM detector model")
    dsub = p.add_subparsers(dest="detector_command", metavar="ACTION")
    t = dsub.add_parser("train", help="train a detector on ground-truth boxes and save it",
                        description="Train the configured sliding-window SVM detector on a "
                                    "video's ground-truth boxes and save the model (.npz).")
    t.add_argument("--video", required=True, help="video file")
    t.add_argument("--gt", required=True, help="MOTChallenge ground truth of the video")
    t.add_argument("--frames", default=None, metavar="A:B",
                   help="training frames, ground-truth numbering (default: the config's, "
                        "else all)")
    t.add_argument("--out", required=True, metavar="MODEL", help="model file to write (.npz)")
    t.add_argument("--config", default="pets09-ground",
                   help="configuration whose detector to train (YAML or preset name; default "
                        "pets09-ground)")
    t.add_argument("--camera", default=None,
                   help="camera file: hard-negative mining scans the camera's scales")
    t.add_argument("--feature", choices=("hog", "grey"), default=None,
                   help="window feature (default: the config's; grey = the paper's grey levels)")
    t.add_argument("--seed", type=_args.seed, default=None, help="seed of the negative sampling")
    t.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    t.set_defaults(func=train_handler)
    i = dsub.add_parser("info", help="print a model's parameters and training record")
    i.add_argument("model", metavar="MODEL")
    i.add_argument("--config", default="pets09-ground",
                   help="configuration whose detector reads the model (default pets09-ground)")
    i.set_defaults(func=info_handler)
    p.set_defaults(func=lambda a: (p.print_help(), 2)[1])


def train_handler(args: argparse.Namespace) -> int:
    from pftrack.workflows.pipeline import load_config, train_detector

    cfg = load_config(args.config)
    det = cfg.get("detector") or {}
    if not det:
        raise ValueError(f"config {args.config}: no detector to train")
    train = det.get("train") or {}
    frames = args.frames or train.get("frames")
    seed = args.seed if args.seed is not None else int(train.get("seed", 0))
    params = {"feature": args.feature} if args.feature else {}
    fitted = train_detector(args.video, args.gt, frames, out=args.out, cfg=cfg,  # type: ignore[arg-type]
                            camera=args.camera, params=params, seed=seed,
                            progress=not args.quiet)
    if not args.quiet:
        print(json.dumps({"model": str(args.out), **fitted.describe()}, indent=2,
                         default=float))
        sys.stdout.flush()
    return 0


def info_handler(args: argparse.Namespace) -> int:
    from pathlib import Path

    from pftrack.workflows.pipeline import build_detector, load_config

    if not Path(args.model).is_file():
        raise FileNotFoundError(f"detector model {args.model} not found")
    cfg = load_config(args.config)
    det = build_detector(cfg)
    if det is None:
        raise ValueError(f"config {args.config}: no detector")
    det.load(args.model)
    print(json.dumps({"model": args.model, **det.describe()}, indent=2, default=float))
    return 0
