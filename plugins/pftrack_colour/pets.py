"""Every person of PETS 2009 S2.L1, tracked from their first ground-truth box: pftrack's
cross entropy with background against OpenCV's ``TrackerMIL`` and ``TrackerCSRT``.

Protocol (the same for every method):

* each ground-truth id starts at its first ground-truth frame from its ground-truth box and is
  tracked until its ground truth ends (pftrack also ends a track whose estimate leaves the image
  or whose box has looked more like background than like the person for 30 frames);
* a method's box for a person in a frame is the box it reported (OpenCV: when ``update`` returned
  ``True``);
* **success rate**: fraction of ground-truth boxes (all persons, all frames where the person is
  in the ground truth) whose method box has IoU >= 0.5 with it; a frame without a box fails;
* **mean centre error**: mean over the same ground-truth boxes of the centre distance (px); a
  frame without a box uses the method's latest earlier box for that person;
* **updates per second**: person-updates (one person, one frame) per second of the method's own
  calls (``init`` + ``update`` for OpenCV, the tracker's calls for pftrack); **frames per second**:
  video frames per second of the same time. Decoding is excluded: every method streams the video
  and only its calls are timed. OpenCV runs on one thread;
* MOTA, IDF1, HOTA: :func:`pftrack.metrics.evaluate` of all the method's boxes, as one track per
  person, against the whole ground truth (IoU >= 0.5; flag-0 rows handled as the metrics module
  does).

pftrack's settings (:data:`PETS_LIKELIHOOD`, :data:`PETS_TRACKER`) go beyond the paper where a
colour model of a whole person box fails on this footage (most people wear dark clothes on grey
pavement, and a 25 x 70 px box holds much pavement): the colour model reads the central part of
the box in three stripes, and the box size follows the perspective of the flat ground, fitted
to the boxes the tracks were started from (nothing else from the ground truth is used).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
from pftrack.contracts.components import Frame
from pftrack.geometry.boxes import box_iou

from pftrack_colour.experiment import (
    first_boxes,
    implementation,
    last_frames,
    track,
    track_boxes,
)

__all__ = [
    "PETS_LIKELIHOOD",
    "PETS_TRACKER",
    "pets_experiment",
    "pets_markdown",
    "pets_overlay",
    "pets_scene",
    "run_opencv",
    "score",
]

#: The colour model for PETS people (~25 x 70 px, mostly dark clothes on grey pavement): the
#: central part of the ground-truth box (less pavement in the template) cut into three stripes
#: (head and shoulders, coat, trousers), cross entropy with background, each person weighted
#: on their own as in eq. 22 (``overlap="independent"``: people in PETS pass close to each
#: other, and the joint weighting that suits the ``walkers`` scene lets one steal another's
#: particles; docs/decisions/pets-colour-model.md).
PETS_LIKELIHOOD: dict[str, Any] = {
    "type": "cross-entropy-bg",
    "params": {"region": (0.2, 0.1, 0.8, 0.9), "parts": 3, "overlap": "independent"},
}
#: Tracker settings for PETS (keyword arguments of :func:`~pftrack_colour.experiment.track`):
#: random walk of 6 px a frame, 300 particles a person; each box starts at the person's first
#: ground-truth size and follows the perspective fitted to the start boxes (people nearer the
#: camera, lower in the image, are taller); a track ends after 30 consecutive frames in which
#: no particle's box looks more like the person than like the background (log-likelihood < 0).
PETS_TRACKER: dict[str, Any] = {"n_particles": 300, "sigma_px": 6.0, "box_size_px": None,
                                "perspective": True, "min_log_likelihood": 0.0,
                                "max_misses": 30}


def pets_scene(frames: tuple[int, int] | None = None, data: str | Path | None = None):
    """The PETS 2009 S2.L1 video scene (``vtest.avi`` + ``gt.txt``), optionally a frame slice
    ``(first, last)`` in ground-truth numbering (1..795)."""
    from pftrack.io.data import data_dir
    from pftrack.scenes.video import VideoScene

    folder = Path(data) if data is not None else data_dir() / "pets09"
    video, gt = folder / "vtest.avi", folder / "gt.txt"
    for p in (video, gt):
        if not p.is_file():
            raise FileNotFoundError(f"PETS 2009 S2.L1 file {p} not found (set PFTRACK_DATA to "
                                    "the folder holding pets09/)")
    first, last = (1, None) if frames is None else frames
    return VideoScene(str(video), str(gt), first=first, last=last)


def run_opencv(frames: Iterable[Frame], kind: str,
               starts: dict[int, list[tuple[int, np.ndarray]]], ends: dict[int, int],
               ) -> dict[str, Any]:
    """Track each person with its own OpenCV tracker (``"mil"`` or ``"csrt"``).

    Returns ``{"rows": MOT rows, "seconds", "n_frames", "n_updates"}``; only ``init`` and
    ``update`` calls are timed.
    """
    import cv2

    makers: dict[str, Callable[[], Any]] = {"mil": cv2.TrackerMIL_create,
                                            "csrt": cv2.TrackerCSRT_create}
    if kind not in makers:
        raise ValueError(f"unknown OpenCV tracker {kind!r}; use one of {sorted(makers)}")
    live: dict[int, Any] = {}
    rows = []
    seconds = 0.0
    n_frames = 0
    n_updates = 0
    clock = time.perf_counter
    for frame in frames:
        h, w = frame.image.shape[:2]
        t0 = clock()
        for tid, box in starts.get(frame.index, ()):
            x, y, bw, bh = (round(float(v)) for v in box)
            # OpenCV wants the box inside the image
            x0, y0 = max(x, 0), max(y, 0)
            x1, y1 = min(x + bw, w), min(y + bh, h)
            tracker = makers[kind]()
            tracker.init(frame.image, (x0, y0, max(x1 - x0, 1), max(y1 - y0, 1)))
            live[tid] = tracker
            rows.append([frame.index, tid, x0, y0, x1 - x0, y1 - y0, 1, -1, -1, -1])
            n_updates += 1
        started = {tid for tid, _ in starts.get(frame.index, ())}
        for tid, tracker in list(live.items()):
            if tid in started:
                continue
            ok, box = tracker.update(frame.image)
            n_updates += 1
            if ok:
                rows.append([frame.index, tid, *box, 1, -1, -1, -1])
        for tid in list(live):
            if ends.get(tid, np.inf) <= frame.index:
                del live[tid]
        seconds += clock() - t0
        n_frames += 1
    return {"rows": np.asarray(rows, float).reshape(-1, 10), "seconds": seconds,
            "n_frames": n_frames, "n_updates": n_updates}


def score(track_rows: np.ndarray, gt_rows: np.ndarray) -> dict[str, Any]:
    """Success rate, mean centre error (see the module docstring) and MOTA / IDF1 / HOTA."""
    from pftrack.metrics import evaluate

    iou = []
    for g, e in track_boxes(track_rows, gt_rows).values():
        iou.append(box_iou(np.nan_to_num(g), np.nan_to_num(e)))
    iou_all = np.concatenate(iou) if iou else np.zeros(0)
    err = []
    per_person = {}
    for g, e in track_boxes(track_rows, gt_rows, hold_last=True).values():
        d = np.hypot(e[:, 0] + e[:, 2] / 2 - g[:, 0] - g[:, 2] / 2,
                     e[:, 1] + e[:, 3] / 2 - g[:, 1] - g[:, 3] / 2)
        err.append(d)
    for tid, i in zip(track_boxes(track_rows, gt_rows), iou):
        per_person[int(tid)] = float(np.mean(i >= 0.5)) if len(i) else float("nan")
    err_all = np.concatenate(err) if err else np.zeros(0)
    m = evaluate(gt_rows, track_rows) if len(track_rows) else {"MOTA": float("nan"),
                                                               "IDF1": 0.0, "HOTA": 0.0}
    return {
        "mean_center_error_px": float(np.nanmean(err_all)) if np.isfinite(err_all).any()
        else float("nan"),
        "success_rate": float(np.mean(iou_all >= 0.5)) if len(iou_all) else float("nan"),
        "MOTA": float(m["MOTA"]), "IDF1": float(m["IDF1"]), "HOTA": float(m["HOTA"]),
        "success_per_person": per_person,
        "gt_boxes": len(iou_all),
    }


def pets_experiment(methods: Iterable[str] = ("cross-entropy-bg", "mil", "csrt"),
                    frames: tuple[int, int] | None = None, *, data: str | Path | None = None,
                    likelihood: dict[str, Any] | None = None,
                    tracker: dict[str, Any] | None = None, seed: int = 0,
                    repeats: int = 1, keep_tracks: bool = False,
                    progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run each method over the sequence (or a slice) and score it.

    Parameters
    ----------
    methods
        ``"cross-entropy-bg"`` (pftrack with :data:`PETS_LIKELIHOOD`), ``"mil"``, ``"csrt"``.
    frames : (first, last), optional
        Ground-truth frame numbers to run (default: all 795).
    likelihood, tracker : dict, optional
        Override :data:`PETS_LIKELIHOOD` / :data:`PETS_TRACKER` (``tracker`` updates it).
    seed, repeats : int
        pftrack is random: it runs with seeds ``seed .. seed + repeats - 1`` and its row reports
        the mean of every figure over the runs, the runs themselves under ``"runs"``.
    keep_tracks : bool
        Also return each method's MOT rows under ``"tracks"`` (for drawing; pftrack: the first
        seed's).

    Returns
    -------
    dict
        ``{"rows": [{method, mean_center_error_px, success_rate, updates_per_second,
        frames_per_second, MOTA, IDF1, HOTA, ...}], "setup": {...}}``.
    """
    scene = pets_scene(frames, data)
    gt = scene.ground_truth()
    if gt is None or len(gt) == 0:
        raise ValueError(f"no ground truth in frames {frames}")
    starts = first_boxes(gt)
    ends = last_frames(gt)
    lik = likelihood or PETS_LIKELIHOOD
    trk = dict(PETS_TRACKER)
    trk.update(tracker or {})
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    rows = []
    tracks = {}
    for method in methods:
        runs = []
        for k in range(repeats if method == "cross-entropy-bg" else 1):
            if method in ("mil", "csrt"):
                out = run_opencv(scene.frames(), method, starts, ends)
                track_rows, seconds = out["rows"], out["seconds"]
                n_frames, n_updates = out["n_frames"], out["n_updates"]
            elif method == "cross-entropy-bg":
                run = track(scene.frames(), lik, starts, ends=ends, seed=seed + k, **trk)
                track_rows, seconds = run.rows, run.seconds
                n_frames, n_updates = run.n_frames, run.n_updates
            else:
                raise ValueError(f"unknown method {method!r}; use cross-entropy-bg, mil or csrt")
            s = score(track_rows, gt)
            tracks.setdefault(method, track_rows)
            runs.append({
                "seed": seed + k if method == "cross-entropy-bg" else None,
                "mean_center_error_px": s["mean_center_error_px"],
                "success_rate": s["success_rate"],
                "updates_per_second": n_updates / seconds if seconds > 0 else float("inf"),
                "frames_per_second": n_frames / seconds if seconds > 0 else float("inf"),
                "MOTA": s["MOTA"], "IDF1": s["IDF1"], "HOTA": s["HOTA"],
                "seconds": seconds, "frames": n_frames, "person_updates": n_updates,
                "success_per_person": s["success_per_person"],
            })
        row: dict[str, Any] = {"method": method}
        for key in ("mean_center_error_px", "success_rate", "updates_per_second",
                    "frames_per_second", "MOTA", "IDF1", "HOTA", "seconds"):
            row[key] = float(np.mean([r[key] for r in runs]))
        row["frames"] = runs[0]["frames"]
        row["person_updates"] = runs[0]["person_updates"]
        row["success_per_person"] = runs[0]["success_per_person"]
        if len(runs) > 1:
            row["runs"] = [{k: v for k, v in r.items() if k != "success_per_person"}
                           for r in runs]
        rows.append(row)
        if progress is not None:
            progress(f"{method:>17s}: success {row['success_rate']:.3f}, centre error "
                     f"{row['mean_center_error_px']:.1f} px, {row['updates_per_second']:.0f} "
                     f"updates/s, {row['frames_per_second']:.1f} frames/s, MOTA "
                     f"{row['MOTA']:.3f}, IDF1 {row['IDF1']:.3f}, HOTA {row['HOTA']:.3f}"
                     + (f" (mean of {len(runs)} seeds)" if len(runs) > 1 else ""))
    f0 = int(gt[:, 0].min())
    f1 = int(gt[:, 0].max()) if frames is None or frames[1] is None else int(frames[1])
    out = {
        "rows": rows,
        "setup": {
            "sequence": "PETS 2009 S2.L1 (vtest.avi, gt.txt)", "frames": [f0, f1],
            "persons": len(ends), "gt_boxes": len(gt),
            "pftrack": {"likelihood": lik, **{k: v for k, v in trk.items()},
                        "seeds": list(range(seed, seed + repeats))},
            "protocol": "each id from its first GT box until its GT ends; success = IoU >= 0.5 "
                        "over all GT boxes; centre error holds a method's last box; decoding "
                        "excluded from timing; OpenCV on one thread",
            "implementation": implementation(),
        },
    }
    if keep_tracks:
        out["tracks"] = tracks
        out["ground_truth"] = gt
    return out


def pets_overlay(result: dict[str, Any], frame_index: int, data: str | Path | None = None,
                 ) -> np.ndarray:
    """One PETS frame with every method's boxes side by side (from a
    :func:`pets_experiment` result run with ``keep_tracks=True``) and the ground truth."""
    from pftrack_colour.report import draw_frame, montage

    if "tracks" not in result:
        raise ValueError("pets_overlay needs a pets_experiment(..., keep_tracks=True) result")
    frame = next(iter(pets_scene((frame_index, frame_index), data).frames()))
    gt = result["ground_truth"]
    panels = []
    for method, rows in result["tracks"].items():
        panels.append(draw_frame(frame.image, rows[rows[:, 0] == frame_index],
                                 gt_rows=gt[gt[:, 0] == frame_index],
                                 title=f"{method}, frame {frame_index}"))
    return montage(panels, cols=min(len(panels), 3))


def pets_markdown(result: dict[str, Any]) -> str:
    """The PETS comparison as a Markdown table."""
    s = result["setup"]
    lines = [(f"{s['sequence']}: frames {s['frames'][0]}-{s['frames'][1]}, {s['persons']} "
              f"persons, {s['gt_boxes']} ground-truth boxes\n"),
             "| method | centre error px | success | updates / s | frames / s | MOTA | IDF1 "
             "| HOTA |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in result["rows"]:
        lines.append(f"| {r['method']} | {r['mean_center_error_px']:.1f} | "
                     f"{r['success_rate']:.3f} | {r['updates_per_second']:.0f} | "
                     f"{r['frames_per_second']:.1f} | {r['MOTA']:.3f} | {r['IDF1']:.3f} | "
                     f"{r['HOTA']:.3f} |")
    return "\n".join(lines)
