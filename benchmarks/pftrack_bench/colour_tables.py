"""The colour paper's Tables 1-4 on the ``walkers`` scene as library calls: run every likelihood
at every sample and target count (:func:`walkers_tables`), and print the tables as text
(:func:`format_walkers_tables`, ``pftrack bench colour``) or Markdown (:func:`walkers_markdown`,
the notebook ``01_cross_entropy.ipynb``).

Timing covers tracking only: frames are rendered before the clock starts, and drawing happens
afterwards.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from pftrack.host import Host

__all__ = ["LIKELIHOODS", "PAPER", "format_walkers_tables", "walkers_markdown", "walkers_tables"]

#: The four likelihoods of the colour paper, baseline first (``pftrack_colour.experiment``'s).
LIKELIHOODS = ("bhattacharyya", "bhattacharyya-bg", "cross-entropy", "cross-entropy-bg")

#: The paper's Tables 1-4 (seconds for 180 frames and cumulative error in px; Bh = eq. 23,
#: Cr = eq. 24, both with background; Core2 T5500 1.66 GHz, image I/O included).
PAPER: dict[str, Any] = {
    "seconds_180_frames": {
        (100, 1): (15.0, 2.61), (100, 2): (29.1, 4.32), (100, 3): (64.8, 7.59),
        (500, 1): (70.5, 6.89), (500, 2): (142.0, 12.6), (500, 3): (322.0, 23.8),
    },
    "cumulative_error_px": {  # (samples, targets) -> {name: (Bh, Cr)}
        (100, 1): {"blue": (748, 554)},
        (100, 2): {"blue": (760, 581), "red": (878, 344)},
        (100, 3): {"blue": (732, 621), "red": (837, 354), "purple": (904, 546)},
        (500, 1): {"blue": (725, 560)},
        (500, 2): {"blue": (718, 562), "red": (813, 315)},
        (500, 3): {"blue": (734, 557), "red": (842, 336), "purple": (890, 542)},
    },
}


def walkers_tables(likelihoods: Sequence[str] = LIKELIHOODS,
                   samples: Sequence[int] = (100, 500, 5000),
                   targets: Sequence[int] = (1, 2, 3), *, scene_seed: int = 0, seed: int = 0,
                   sigma_px: float = 4.0, n_frames: int = 180,
                   slow_frames: int | None = None,
                   slow: Sequence[str] = ("bhattacharyya", "bhattacharyya-bg"),
                   progress: Callable[[str], None] | None = None,
                   host: Host | None = None) -> dict[str, Any]:
    """The paper's Tables 1-4 on the ``walkers`` scene.

    Every likelihood tracks the first ``T`` people (blue, red, purple) with ``N`` samples, each
    started from its first ground-truth box (30 x 30 px torso), through ``n_frames`` frames
    rendered before the clock starts.

    Parameters
    ----------
    slow_frames : int, optional
        Track only this many frames with the ``slow`` likelihoods at N >= 5000 (their time per
        frame is measured over those frames; their cumulative errors cover only them and the
        rows say so in ``frames``).

    Returns
    -------
    dict
        ``{"rows": [{likelihood, samples, targets, frames, seconds_per_frame,
        frames_per_second, likelihood_seconds_per_frame, cumulative_error_px: {name: px}}],
        "ratios": [{samples, targets, pair, ratio}], "setup": {...}}``.
    """
    from pftrack.host import get_host
    from pftrack_colour.experiment import cumulative_errors, first_boxes, implementation, track

    host = host or get_host()
    scene = host.build("scene", {"type": "walkers",
                                 "params": {"seed": scene_seed, "n_frames": n_frames}})
    frames = list(scene.frames())  # rendered once, before any clock starts
    gt = scene.ground_truth()
    names = scene.target_names
    rows = []
    for n in samples:
        for t_count in targets:
            ids = list(range(1, t_count + 1))
            starts = first_boxes(gt, ids)
            for name in likelihoods:
                use = frames
                if slow_frames is not None and name in slow and n >= 5000:
                    use = frames[:slow_frames]
                run = track(use, name, starts, n_particles=n, sigma_px=sigma_px, seed=seed,
                            host=host)
                errs = cumulative_errors(run.rows, gt, {i: names[i] for i in ids},
                                         frames=[f.index for f in use])
                row = {
                    "likelihood": name, "samples": n, "targets": t_count, "frames": len(use),
                    "seconds_per_frame": run.seconds_per_frame,
                    "frames_per_second": run.frames_per_second,
                    "likelihood_seconds_per_frame": run.likelihood_seconds / max(len(use), 1),
                    "cumulative_error_px": errs,
                }
                rows.append(row)
                if progress is not None:
                    progress(f"{name:>17s} N={n:<5d} T={t_count}: "
                             f"{row['seconds_per_frame'] * 1e3:9.2f} ms/frame, errors "
                             + ", ".join(f"{k} {v:.0f}" for k, v in errs.items()))
    ratios = []
    by = {(r["likelihood"], r["samples"], r["targets"]): r for r in rows}
    for n in samples:
        for t_count in targets:
            for bh, cr in (("bhattacharyya", "cross-entropy"),
                           ("bhattacharyya-bg", "cross-entropy-bg")):
                a, b = by.get((bh, n, t_count)), by.get((cr, n, t_count))
                if a and b:
                    ratios.append({"samples": n, "targets": t_count, "pair": f"{bh} / {cr}",
                                   "ratio": a["seconds_per_frame"] / b["seconds_per_frame"]})
    return {
        "rows": rows,
        "ratios": ratios,
        "setup": {
            "scene": "walkers", "scene_seed": scene_seed, "tracker_seed": seed,
            "frames": n_frames, "image_px": [scene.width, scene.height], "box_px": [30, 30],
            "motion": f"random walk, sigma {sigma_px} px/frame", "resampling": "systematic, "
            "every frame", "init_spread_px": 1.0,
            "timing": "tracking only: frames rendered into a list before timing; drawing "
                      "excluded; one thread (cv2.setNumThreads(1))",
            "slow_frames": slow_frames,
            "implementation": implementation(),
        },
    }


def format_walkers_tables(result: dict[str, Any]) -> str:
    """Plain-text Tables 1-4 (time per frame, Bh / Cr ratio, cumulative errors)."""
    rows = result["rows"]
    lines = []
    samples = sorted({r["samples"] for r in rows})
    names = ["blue", "red", "purple"]
    for n in samples:
        sub = [r for r in rows if r["samples"] == n]
        lines.append(f"N = {n} samples")
        lines.append(f"  {'likelihood':<18s}{'T':>2s}{'frames':>7s}{'ms/frame':>11s}"
                     f"{'frames/s':>10s}{'lik ms/f':>10s}  cumulative error px "
                     "(blue, red, purple)")
        for r in sorted(sub, key=lambda r: (r["targets"], LIKELIHOODS.index(r["likelihood"])
                                            if r["likelihood"] in LIKELIHOODS else 9)):
            e = r["cumulative_error_px"]
            errs = "  ".join(f"{e[k]:7.0f}" if k in e else f"{'-':>7s}" for k in names)
            lines.append(f"  {r['likelihood']:<18s}{r['targets']:>2d}{r['frames']:>7d}"
                         f"{r['seconds_per_frame'] * 1e3:11.2f}{r['frames_per_second']:10.1f}"
                         f"{r['likelihood_seconds_per_frame'] * 1e3:10.2f}  {errs}")
        for q in result.get("ratios", []):
            if q["samples"] == n:
                lines.append(f"  T={q['targets']} {q['pair']}: {q['ratio']:.1f}x")
        lines.append("")
    lines.append("Timing: " + result.get("setup", {}).get("timing", ""))
    if result.get("setup", {}).get("implementation"):
        lines.append("Implementation: " + result["setup"]["implementation"])
    return "\n".join(lines)


def walkers_markdown(result: dict[str, Any]) -> str:
    """Tables 1-4 as Markdown: per N, one row per (targets, likelihood) with time per frame,
    frames per second and each walker's cumulative error, then the Bh / Cr time ratios."""
    out = []
    for n in sorted({r["samples"] for r in result["rows"]}):
        out.append(f"**N = {n} samples**\n")
        out.append("| targets | likelihood | frames | ms / frame | frames / s | blue px | red px "
                   "| purple px |")
        out.append("|---:|---|---:|---:|---:|---:|---:|---:|")
        rows = [r for r in result["rows"] if r["samples"] == n]
        rows.sort(key=lambda r: (r["targets"], LIKELIHOODS.index(r["likelihood"])
                                 if r["likelihood"] in LIKELIHOODS else 9))
        for r in rows:
            e = r["cumulative_error_px"]
            errs = " | ".join(f"{e[k]:.0f}" if k in e else "-" for k in ("blue", "red", "purple"))
            out.append(f"| {r['targets']} | {r['likelihood']} | {r['frames']} | "
                       f"{r['seconds_per_frame'] * 1e3:.2f} | {r['frames_per_second']:.0f} | "
                       f"{errs} |")
        ratios = [q for q in result.get("ratios", []) if q["samples"] == n]
        if ratios:
            out.append("")
            out.append("Time ratios: " + "; ".join(
                f"T={q['targets']} {q['pair']} = {q['ratio']:.1f}x" for q in ratios))
        out.append("")
    return "\n".join(out)
