"""``pftrack demo --out DIR``: the first thing to run. Tracks the three walkers of the synthetic
``walkers`` scene (seed 000's experiment) with cross entropy + background and the paper's
Bhattacharyya baseline, and writes the tracks (MOTChallenge CSV), the metrics (JSON) and report
pictures (frames with boxes and particles, trajectories, per-frame error curves)."""

from __future__ import annotations

import argparse
import sys


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("demo", help="track the synthetic walkers and write a report",
                              description=__doc__)
    p.add_argument("--out", required=True, help="output folder (created)")
    p.add_argument("--seed", type=int, default=0, help="scene seed (default 0)")
    p.add_argument("--frames", type=int, default=180, help="frames to render (default 180)")
    p.add_argument("--particles", type=int, default=500,
                   help="particles per walker (default 500)")
    p.add_argument("--no-baseline", action="store_true",
                   help="skip the Bhattacharyya + background comparison run")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    import numpy as np

    from pftrack.host import get_host

    host = get_host()
    host.get("scene", "walkers")  # a clear error if the colour plugin is not loaded
    from pftrack_colour.demo import run_demo

    if args.frames < 1:
        raise ValueError(f"--frames must be >= 1, got {args.frames}")
    if args.particles < 1:
        raise ValueError(f"--particles must be >= 1, got {args.particles}")
    with np.errstate(over="ignore"):  # a best log-likelihood far below 0 overflows exp harmlessly
        result = run_demo(args.out, seed=args.seed, n_frames=args.frames,
                          n_particles=args.particles,
                          baseline=None if args.no_baseline else "bhattacharyya-bg",
                          progress=lambda s: print(s, file=sys.stderr, flush=True), host=host)
    for m, v in result["metrics"]["methods"].items():
        errs = ", ".join(f"{k} {e:.0f}" for k, e in v["cumulative_error_px"].items())
        print(f"{m}: cumulative error px {errs}; {v['frames_per_second']:.0f} frames/s; "
              f"MOTA {v['MOTA']:.3f}, IDF1 {v['IDF1']:.3f}, HOTA {v['HOTA']:.3f}")
    print("wrote:")
    for name, path in result["files"].items():
        print(f"  {name:<26s} {path}")
    return 0
