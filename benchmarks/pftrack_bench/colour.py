"""The colour paper's Tables 1-4 on the ``walkers`` scene: time per frame and cumulative error for
the four colour likelihoods (Bhattacharyya and cross entropy, with and without background).

``pftrack bench colour --json`` runs N in {100, 500, 5000} samples and T in {1, 2, 3} targets
for all four likelihoods in one run. Frames are rendered into a list before any timing; drawing
is excluded; OpenCV runs on one thread. ``--slow-frames K`` limits the Bhattacharyya baselines at
N >= 5000 to the first K frames (their time per frame is then measured over those frames and
their cumulative errors cover only them; each row says how many frames it ran).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from pftrack_bench.protocol import Protocol

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="the built-in walkers scene (synthetic colour targets)",
    chosen_on="the colour paper's settings (500 particles, its likelihoods)",
    reported_on="the scene as rendered; speeds in frames per second of one core",
)


def _ints(text: str) -> list[int]:
    try:
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated integers, got {text!r}") from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--samples", type=_ints, default=[100, 500, 5000],
                        help="particles per target, comma-separated (default 100,500,5000)")
    parser.add_argument("--targets", type=_ints, default=[1, 2, 3],
                        help="numbers of targets, comma-separated (default 1,2,3)")
    parser.add_argument("--likelihoods", default="bhattacharyya,bhattacharyya-bg,"
                        "cross-entropy,cross-entropy-bg", help="comma-separated likelihoods")
    parser.add_argument("--seed", type=int, default=0, help="tracker seed (default 0)")
    parser.add_argument("--scene-seed", type=int, default=0, help="walkers scene seed")
    parser.add_argument("--frames", type=int, default=180, help="frames (default 180)")
    parser.add_argument("--slow-frames", type=int, default=None, metavar="K",
                        help="run the Bhattacharyya baselines at N >= 5000 on the first K "
                             "frames only (default: all)")
    parser.add_argument("--sigma", type=float, default=None,
                        help="random-walk noise per frame, px (default 4)")
    parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")


def run(args: argparse.Namespace) -> dict[str, Any]:
    import cv2
    from pftrack.host import get_host

    host = get_host()
    host.get("scene", "walkers")  # a clear error if the colour plugin is not loaded
    from pftrack_colour.experiment import DEFAULT_SIGMA_PX

    from pftrack_bench.colour_tables import walkers_tables

    names = [n.strip() for n in args.likelihoods.split(",") if n.strip()]
    for n in names:
        host.get("likelihood", n)
    if args.slow_frames is not None and args.slow_frames < 1:
        raise ValueError(f"--slow-frames must be >= 1, got {args.slow_frames}")
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        result = walkers_tables(
            names, args.samples, args.targets, scene_seed=args.scene_seed, seed=args.seed,
            sigma_px=DEFAULT_SIGMA_PX if args.sigma is None else args.sigma,
            n_frames=args.frames, slow_frames=args.slow_frames,
            progress=None if args.quiet else (lambda s: print(s, file=sys.stderr, flush=True)),
            host=host)
    finally:
        cv2.setNumThreads(threads)
    return result


def format_table(result: dict[str, Any]) -> str:
    from pftrack_bench.colour_tables import format_walkers_tables

    return format_walkers_tables(result)
