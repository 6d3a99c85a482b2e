"""The walkers demo end to end: track the three walkers with cross entropy + background, beside
the paper's Bhattacharyya + background baseline, and write tracks, metrics and report pictures.

``pftrack demo --out DIR`` calls :func:`run_demo`; the notebook calls the same function.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from pftrack.host import Host, get_host
from pftrack.io.atomic import atomic_write_text
from pftrack.io.images import write_png

from pftrack_colour.experiment import centre_errors, cumulative_errors, first_boxes, track
from pftrack_colour.report import WALKER_COLOURS_BGR as DRAW_COLOURS_BGR
from pftrack_colour.report import draw_frame, draw_trajectories, line_chart, montage

__all__ = ["run_demo"]


def run_demo(out: str | Path, *, seed: int = 0, n_frames: int = 180, n_particles: int = 500,
             baseline: str | None = "bhattacharyya-bg", tracker_seed: int = 0,
             progress: Callable[[str], None] | None = None,
             host: Host | None = None) -> dict[str, Any]:
    """Run the walkers scene end to end and write the report into ``out``.

    Writes ``tracks.csv`` (MOTChallenge, cross entropy + background), ``tracks_<baseline>.csv``,
    ``metrics.json``, ``overlays.png`` (four frames with boxes and particles, like the paper's
    Fig. 4), ``trajectories.png`` (image plane) and ``error_curve.png`` (per-frame centre error
    of each walker). Every file is written atomically.

    Returns
    -------
    dict
        ``{"files": {name: path}, "metrics": {...}}``.
    """
    from pftrack.io.mot import write_mot
    from pftrack.metrics import evaluate

    host = host or get_host()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    say = progress or (lambda s: None)
    scene = host.build("scene", {"type": "walkers", "params": {"seed": seed,
                                                               "n_frames": n_frames}})
    frames = list(scene.frames())
    gt = scene.ground_truth()
    names = scene.target_names
    starts = first_boxes(gt)
    n = len(frames)
    # the paper's Fig. 4 shows frames 1, 78 and 134; shorter runs show four evenly spaced
    show = ([1, 78, 134, n] if n > 134 else
            sorted({int(v) for v in np.linspace(1, n, 4).round()}))
    methods = ["cross-entropy-bg"] + ([baseline] if baseline else [])
    runs = {}
    metrics: dict[str, Any] = {
        "scene": {"name": "walkers", "seed": seed, "frames": n,
                  "image_px": [scene.width, scene.height], "targets": names},
        "tracker": {"particles": n_particles, "seed": tracker_seed,
                    "motion": "random walk (sigma 4 px/frame)", "box_px": [30, 30]},
        "timing": "tracking only (frames rendered before timing, drawing after)",
        "methods": {},
    }
    for m in methods:
        say(f"tracking {n} frames with {m} ({n_particles} particles per walker)...")
        run = track(frames, m, starts, n_particles=n_particles, seed=tracker_seed,
                    snapshot_frames=show, host=host)  # snapshots: the weighted samples
        runs[m] = run
        errs = centre_errors(run.rows, gt, ids=list(names), hold_last=True)
        scores = evaluate(gt, run.rows)
        metrics["methods"][m] = {
            "cumulative_error_px": cumulative_errors(run.rows, gt, names),
            "mean_error_px": {names[i]: float(np.nanmean(e)) for i, e in errs.items()},
            "max_error_px": {names[i]: float(np.nanmax(e)) for i, e in errs.items()},
            "seconds_per_frame": run.seconds_per_frame,
            "frames_per_second": run.frames_per_second,
            "MOTA": float(scores["MOTA"]), "IDF1": float(scores["IDF1"]),
            "HOTA": float(scores["HOTA"]),
        }
    files: dict[str, Path] = {}
    main = runs["cross-entropy-bg"]
    files["tracks"] = write_mot(out / "tracks.csv", main.rows)
    if baseline:
        files[f"tracks_{baseline}"] = write_mot(out / f"tracks_{baseline}.csv",
                                                runs[baseline].rows)
    files["metrics"] = atomic_write_text(out / "metrics.json",
                                         json.dumps(metrics, indent=2) + "\n")
    # pictures
    say("drawing...")
    by_index = {f.index: f for f in frames}
    panels = []
    for k in show:
        rows = main.rows[main.rows[:, 0] == k]
        panels.append(draw_frame(by_index[k].image, rows, particles=main.snapshots.get(k),
                                 gt_rows=gt[gt[:, 0] == k], colours=DRAW_COLOURS_BGR,
                                 names=names, scale=2, title=f"frame {k}"))
    files["overlays"] = write_png(out / "overlays.png", montage(panels, cols=2))
    files["trajectories"] = write_png(out / "trajectories.png", draw_trajectories(
        scene.background(), main.rows, gt, colours=DRAW_COLOURS_BGR, names=names, scale=2,
        title="walkers: cross entropy + background, image-plane trajectories"))
    errs = {m: centre_errors(runs[m].rows, gt, ids=list(names), hold_last=True)
            for m in methods}
    top = max(float(np.nanmax(e)) for v in errs.values() for e in v.values())
    charts = []
    for tid, name in names.items():
        col = DRAW_COLOURS_BGR[tid]
        pale = tuple(int(c + (255 - c) * 0.55) for c in col)
        series = []
        for m, c, thick in zip(methods, (col, pale), (2, 1)):
            e = errs[m][tid]
            series.append((f"{m} (total {np.nansum(e):.0f} px)", np.arange(1, len(e) + 1), e,
                           c if m == "cross-entropy-bg" else (90, 90, 90), thick))
        charts.append(line_chart(series, size_wh=(760, 230), ymax=top * 1.05,
                                 title=f"{name} walker: centre error per frame "
                                       f"({n_particles} particles)",
                                 xlabel="frame", ylabel="px"))
    files["error_curve"] = write_png(out / "error_curve.png", montage(charts, cols=1))
    return {"files": {k: str(v) for k, v in files.items()}, "metrics": metrics}


# -- ``pftrack demo`` (registered by the plugin as the default demo) ---------------------------


def add_arguments(parser) -> None:
    """Options of ``pftrack demo walkers``."""
    parser.add_argument("--seed", type=int, default=0, help="scene seed (default 0)")
    parser.add_argument("--frames", type=int, default=180, help="frames to render (default 180)")
    parser.add_argument("--particles", type=int, default=500,
                        help="particles per walker (default 500)")
    parser.add_argument("--no-baseline", action="store_true",
                        help="skip the Bhattacharyya + background comparison run")


def run_cli(args) -> int:
    """``pftrack demo``: track the synthetic walkers and print the figures and the files."""
    import sys

    if args.frames < 1:
        raise ValueError(f"--frames must be >= 1, got {args.frames}")
    if args.particles < 1:
        raise ValueError(f"--particles must be >= 1, got {args.particles}")
    with np.errstate(over="ignore"):  # a best log-likelihood far below 0 overflows exp harmlessly
        result = run_demo(args.out, seed=args.seed, n_frames=args.frames,
                          n_particles=args.particles,
                          baseline=None if args.no_baseline else "bhattacharyya-bg",
                          progress=lambda s: print(s, file=sys.stderr, flush=True))
    for m, v in result["metrics"]["methods"].items():
        errs = ", ".join(f"{k} {e:.0f}" for k, e in v["cumulative_error_px"].items())
        print(f"{m}: cumulative error px {errs}; {v['frames_per_second']:.0f} frames/s; "
              f"MOTA {v['MOTA']:.3f}, IDF1 {v['IDF1']:.3f}, HOTA {v['HOTA']:.3f}")
    print("wrote:")
    for name, path in result["files"].items():
        print(f"  {name:<26s} {path}")
    return 0
