"""The colour tracker for a user's own boxes on PETS 2009 S2.L1: ``people-colour`` against the
same preset with its colour term weighted 0 and against ``people-image``, on the same
detections.

``pftrack bench people-colour --json`` runs the registered ``hog-people`` detector once over the
frames (or reads ``--detections det.txt``), then tracks them with each configuration for each
seed (``--seeds``, default 0,1,2) and scores MOTA, IDF1, HOTA (IoU 0.5,
:func:`pftrack.workflows.pipeline.evaluate_tracks`); each row is the mean over the seeds, with the
per-seed figures under ``runs``. ``--frames`` default 201:795: the presets were tuned on frames
1-200. Tracking frames per second exclude detection and include decoding.
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
from typing import Any

import numpy as np

from pftrack_bench.protocol import Protocol, add_part_argument, checked_frames

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="PETS 2009 S2.L1, the hog-people detector's boxes",
    chosen_on="frames 1-200 (the people-colour preset's colour weight and gates)",
    reported_on="frames 201-795, tracking seeds 0-2",
    chosen_frames={"": (1, 200)}, reported_frames={"": (201, 795)},
)


#: (row name, preset, change): the configurations compared.
CONFIGS = (("people-colour", "people-colour", None),
           ("people-colour, colour weight 0", "people-colour", "no-colour"),
           ("people-image", "people-image", None))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--data", default=None,
                        help="folder holding pets09/ (default: $PFTRACK_DATA or ../shared/data)")
    add_part_argument(parser, PROTOCOL)
    parser.add_argument("--frames", default=None, metavar="A:B",
                        help="frames, ground-truth numbering, inside the part (default: the "
                             "part's, 201:795)")
    parser.add_argument("--detections", default=None, metavar="FILE",
                        help="MOTChallenge det.txt to track (default: run hog-people once)")
    parser.add_argument("--seeds", default="0,1,2", help="tracking seeds (default 0,1,2)")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


def _no_colour(cfg: dict[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(cfg)
    terms = out["likelihood"]["params"]["terms"]
    colour = [t for t in terms if "cross-entropy" in str(t["likelihood"])]
    if len(colour) != 1:
        raise ValueError("bench people-colour: the people-colour preset has no single "
                         "cross-entropy term to weight 0")
    colour[0]["weight"] = 0.0
    return out


def run(args: argparse.Namespace) -> dict[str, Any]:
    import cv2
    from pftrack.io.data import pets09_files
    from pftrack.io.detections import read_detections
    from pftrack.io.frames import parse_frames
    from pftrack.workflows.pipeline import load_config, run_pipeline
    from pftrack.workflows.track import detect_video

    frames = checked_frames("people-colour", PROTOCOL, args)
    video, gt, _ = pets09_files(args.data)
    first, last = parse_frames(frames)
    seeds = [int(s) for s in str(args.seeds).split(",") if s.strip()]
    if not seeds:
        raise ValueError(f"bench people-colour: --seeds {args.seeds!r} names no seed")
    log = (lambda *a: None) if args.quiet else (lambda *a: print(*a, file=sys.stderr,
                                                                  flush=True))
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        if args.detections is not None:
            dets = read_detections(args.detections)
            dets = {f: d for f, d in dets.items()
                    if f >= first and (last is None or f <= last)}
            source = str(args.detections)
        else:
            log(f"people-colour: hog-people over frames {frames} ...")
            dets, _, _ = detect_video(video, load_config("people-colour"), (first, last))
            source = "hog-people (threshold 0.5)"
        rows = []
        for name, preset, change in CONFIGS:
            cfg = load_config(preset)
            if change == "no-colour":
                cfg = _no_colour(cfg)
            runs = []
            for seed in seeds:
                log(f"people-colour: {name}, seed {seed} ...")
                t0 = time.perf_counter()
                res = run_pipeline(cfg, video=video, gt=gt, frames=(first, last), seed=seed,
                                   detections=dets, progress=False, report=False)
                wall = time.perf_counter() - t0
                m = res.metrics or {}
                runs.append({"seed": seed, **{k: m.get(k) for k in
                                              ("MOTA", "IDF1", "HOTA", "IDSW", "FP", "FN")},
                             "frames_per_second": res.n_frames / max(wall, 1e-12)})
            mean = {k: float(np.mean([r[k] for r in runs])) for k in runs[0] if k != "seed"}
            rows.append({"name": name, "preset": preset, **mean, "runs": runs})
    finally:
        cv2.setNumThreads(threads)
    return {"frames": f"{first}:{last}", "detections": source, "seeds": seeds, "rows": rows,
            "tuned_on": "frames {}-{}".format(*PROTOCOL.chosen_frames[""])}


def format_table(result: dict[str, Any]) -> str:
    lines = [f"PETS 2009 S2.L1 frames {result['frames']}, detections: {result['detections']}, "
             f"mean of seeds {result['seeds']}",
             f"{'configuration':<32s}{'MOTA':>7s}{'IDF1':>7s}{'HOTA':>7s}{'IDSW':>7s}"
             f"{'FP':>7s}{'FN':>7s}{'fps':>7s}"]
    for r in result["rows"]:
        lines.append(f"{r['name']:<32s}{r['MOTA']:7.3f}{r['IDF1']:7.3f}{r['HOTA']:7.3f}"
                     f"{r['IDSW']:7.1f}{r['FP']:7.0f}{r['FN']:7.0f}"
                     f"{r['frames_per_second']:7.1f}")
    return "\n".join(lines)
