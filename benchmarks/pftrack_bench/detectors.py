"""Person detectors side by side on PETS 2009 S2.L1 and MOT17-09: recall and precision at IoU
0.5 by box height and at the frame's edge, and time per frame on one core.

``pftrack bench detectors --json`` runs each detector (``--detector NAME[:P=V,...]``,
repeatable; default ``hog-people`` and ``ssdlite-people``, each with its default parameters
and no camera, as ``pftrack track`` meets a new video) on every ``--every``-th frame of

* PETS 2009 S2.L1 (768 x 576): counted ground truth = rows with flag 1; a detection matched
  to a flag-0 row (a partly hidden person) counts neither way;
* MOT17-09 (1920 x 1080), MOT17's rule: counted = rows with ``consider`` 1 and class 1
  (pedestrian); a detection left unmatched that overlaps a row of class 2, 7, 8 or 12 (person
  on vehicle, static person, distractor, reflection) by IoU >= 0.5 is removed before scoring.

Each frame: detections and counted boxes matched one to one (Hungarian on IoU, a pair at
IoU >= 0.5 is a hit). Recall is counted by the ground-truth box's height (``HEIGHT_BINS_PX``)
and for ground-truth boxes touching the frame's edge (within ``EDGE_PX``); precision by the
detection's height.

Settings and where they were chosen: a detector reports detections down to its own threshold
(``hog-people``: 0.5, ``ssdlite-people``: 0.3, calibrated probabilities); the ``ssdlite-people``
scores' logistic map was fitted on the training part (PETS 1-400, MOT17-09 1-262; the fit is
printed again as ``calibration``); the *precision-matched* comparison takes, on PETS 1-400,
the lowest ``ssdlite-people`` score whose precision reaches ``hog-people``'s precision there,
and reports both on the test part. Every figure is on the test part: PETS 401-795 and
MOT17-09 263-525, except the ``train`` block.

Speed: each detector on ``--speed-frames`` frames at 640 x 480 (PETS resized), 768 x 576 (PETS)
and 1920 x 1080 (MOT17-09), OpenCV on one thread, CPU time of the process per frame (ms) and the
ratio to the first detector run in the same process; ``hog-people`` first sees 10 frames
untimed, while it learns its scale bands.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from pftrack_bench.protocol import Protocol

#: Box-height bins (ground-truth height for recall, detection height for precision). Unit: px.
HEIGHT_BINS_PX = (0.0, 60.0, 100.0, 200.0, 400.0, np.inf)
#: A ground-truth box touches the frame's edge when it is within this of a border. Unit: px.
EDGE_PX = 2.0
#: MOT17 classes whose matches are removed before scoring (MOT17's rule).
MOT17_IGNORED_CLASSES = (2, 7, 8, 12)
#: Training / test split (ground-truth frame numbers).
SPLITS = {"pets09": ((1, 400), (401, 795)), "mot17-09": ((1, 262), (263, 525))}

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="PETS 2009 S2.L1 (768 x 576) and MOT17-09 (1920 x 1080, MOT17's rule for "
         "distractors)",
    chosen_on="PETS frames 1-400 and MOT17-09 frames 1-262 (the ssdlite-people "
              "score calibration and the precision-matched threshold)",
    reported_on="PETS frames 401-795 and MOT17-09 frames 263-525, every 5th frame",
    chosen_frames={k: v[0] for k, v in SPLITS.items()},
    reported_frames={k: v[1] for k, v in SPLITS.items()},
)
#: Every detector reports down to this score; higher thresholds are applied afterwards.
LOW_SCORE = 0.05
SPEED_SIZES = ((640, 480), (768, 576), (1920, 1080))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--data", default=None,
                        help="folder holding pets09/ and mot17-09/ (default: $PFTRACK_DATA or "
                             "../shared/data)")
    parser.add_argument("--detector", action="append", default=None, metavar="NAME[:P=V,...]",
                        help="detector plugin to measure, optionally with parameters "
                             "(e.g. ssdlite-people:input_height=384); repeatable; default "
                             "hog-people and ssdlite-people; the first is the baseline of the "
                             "speed ratios and the precision-matched comparison")
    parser.add_argument("--every", type=int, default=5, metavar="K",
                        help="score every K-th frame (default 5)")
    parser.add_argument("--speed-frames", type=int, default=10, metavar="N",
                        help="frames timed at each size (default 10; 0: no timing)")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


# --------------------------------------------------------------------------------------------
# Scoring
# --------------------------------------------------------------------------------------------


def _bin(heights: np.ndarray) -> np.ndarray:
    return np.searchsorted(np.asarray(HEIGHT_BINS_PX[1:-1]), heights, side="right")


def bin_names() -> list[str]:
    """The height bins' labels (``"0-60"``, ..., ``"400+"``)."""
    e = HEIGHT_BINS_PX
    return [f"{e[i]:.0f}-{e[i + 1]:.0f}" if np.isfinite(e[i + 1]) else f"{e[i]:.0f}+"
            for i in range(len(e) - 1)]


def match_frame(det: np.ndarray, counted: np.ndarray, ignored: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """One frame: (hit per counted box (G,) bool, state per detection (K,) int: 1 hit,
    0 false positive, -1 removed: unmatched but on an ignored box by IoU >= 0.5)."""
    from pftrack.geometry.boxes import iou_matrix
    from scipy.optimize import linear_sum_assignment

    hit = np.zeros(len(counted), bool)
    state = np.zeros(len(det), int)
    if len(det) and len(counted):
        iou = iou_matrix(counted, det)
        r, c = linear_sum_assignment(-iou)
        ok = iou[r, c] >= 0.5
        hit[r[ok]] = True
        state[c[ok]] = 1
    rest = state == 0
    if len(ignored) and rest.any():
        on = iou_matrix(det[rest], ignored).max(axis=1) >= 0.5
        idx = np.flatnonzero(rest)
        state[idx[on]] = -1
    return hit, state


def ground_truth(rows: np.ndarray, video: str) -> tuple[np.ndarray, np.ndarray]:
    """(counted rows' mask, ignored rows' mask) of MOT rows under the video's rule."""
    if video == "mot17-09":
        counted = (rows[:, 6] == 1) & (rows[:, 7] == 1)
        ignored = np.isin(rows[:, 7], MOT17_IGNORED_CLASSES)
    else:
        counted = rows[:, 6] == 1
        ignored = rows[:, 6] == 0
    return counted, ignored


def score(gt_rows: np.ndarray, detections: dict[int, tuple[np.ndarray, np.ndarray]],
          video: str, size_wh: tuple[int, int], min_score: float,
          frames: tuple[int, int]) -> dict[str, Any]:
    """Recall and precision at IoU 0.5 of the detections (score >= ``min_score``) of the
    frames in ``frames`` (inclusive) that were run: overall, by height bin, at the edge."""
    nb = len(HEIGHT_BINS_PX) - 1
    g_n, g_hit = np.zeros(nb, int), np.zeros(nb, int)
    d_n, d_tp = np.zeros(nb, int), np.zeros(nb, int)
    e_n = e_hit = 0
    W, H = size_wh
    for f in sorted(detections):
        if not frames[0] <= f <= frames[1]:
            continue
        boxes, scores = detections[f]
        det = boxes[scores >= min_score]
        rows = gt_rows[gt_rows[:, 0] == f]
        counted, ignored = ground_truth(rows, video)
        gb = rows[counted, 2:6]
        hit, state = match_frame(det, gb, rows[ignored, 2:6])
        gbin = _bin(gb[:, 3])
        np.add.at(g_n, gbin, 1)
        np.add.at(g_hit, gbin, hit.astype(int))
        used = state >= 0
        dbin = _bin(det[used, 3])
        np.add.at(d_n, dbin, 1)
        np.add.at(d_tp, dbin, (state[used] == 1).astype(int))
        edge = (gb[:, 0] <= EDGE_PX) | (gb[:, 1] <= EDGE_PX) | \
            (gb[:, 0] + gb[:, 2] >= W - EDGE_PX) | (gb[:, 1] + gb[:, 3] >= H - EDGE_PX)
        e_n += int(edge.sum())
        e_hit += int(hit[edge].sum())

    def ratio(a: float, b: float) -> float | None:
        return float(a) / float(b) if b else None

    names = bin_names()
    return {
        "recall": ratio(g_hit.sum(), g_n.sum()), "precision": ratio(d_tp.sum(), d_n.sum()),
        "gt_boxes": int(g_n.sum()), "detections": int(d_n.sum()),
        "recall_by_height": {n: ratio(g_hit[i], g_n[i]) for i, n in enumerate(names)},
        "gt_by_height": {n: int(g_n[i]) for i, n in enumerate(names)},
        "precision_by_height": {n: ratio(d_tp[i], d_n[i]) for i, n in enumerate(names)},
        "detections_by_height": {n: int(d_n[i]) for i, n in enumerate(names)},
        "recall_at_edge": ratio(e_hit, e_n), "gt_at_edge": e_n,
    }


def labelled_scores(gt_rows: np.ndarray, detections: dict[int, tuple[np.ndarray, np.ndarray]],
                    video: str, frames: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(score, label) of every detection of ``frames`` that counts (label 1: a hit at IoU 0.5
    with all detections matched at once; removed detections left out)."""
    s_all, y_all = [], []
    for f in sorted(detections):
        if not frames[0] <= f <= frames[1]:
            continue
        boxes, scores = detections[f]
        rows = gt_rows[gt_rows[:, 0] == f]
        counted, ignored = ground_truth(rows, video)
        _, state = match_frame(boxes, rows[counted, 2:6], rows[ignored, 2:6])
        s_all.append(scores[state >= 0])
        y_all.append(state[state >= 0] == 1)
    return (np.concatenate(s_all) if s_all else np.zeros(0),
            np.concatenate(y_all) if y_all else np.zeros(0, bool))


def threshold_for_precision(scores: np.ndarray, labels: np.ndarray, precision: float
                            ) -> float | None:
    """The lowest score whose detections (score >= it) reach ``precision``; None if none."""
    order = np.argsort(-scores, kind="stable")
    s, y = scores[order], labels[order].astype(float)
    prec = np.cumsum(y) / np.arange(1, len(y) + 1)
    ok = np.flatnonzero(prec >= precision)
    if not len(ok):
        return None
    return float(s[ok[-1]])


def fit_logistic(z: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(offset, scale) of ``P(y) = 1 / (1 + exp(-(z - offset) / scale))`` by maximum
    likelihood (Newton steps on the slope and intercept)."""
    a, b = 1.0, 0.0  # P = sigmoid(a z + b)
    yf = y.astype(float)
    for _ in range(50):
        p = 1.0 / (1.0 + np.exp(-(a * z + b)))
        g = np.array([np.sum((p - yf) * z), np.sum(p - yf)])
        w = p * (1 - p)
        Hm = np.array([[np.sum(w * z * z), np.sum(w * z)], [np.sum(w * z), np.sum(w)]])
        step = np.linalg.solve(Hm + 1e-9 * np.eye(2), g)
        a, b = a - step[0], b - step[1]
        if np.abs(step).max() < 1e-10:
            break
    return float(-b / a), float(1.0 / a)


# --------------------------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------------------------


def _videos(data: str | None) -> dict[str, tuple[Path, Path]]:
    from pftrack.io.data import data_dir, pets09_files

    video, gt, _ = pets09_files(data)
    root = Path(data) if data is not None else data_dir()
    m = root / "mot17-09"
    mv, mg = m / "MOT17-09.mp4", m / "gt" / "gt.txt"
    for p in (mv, mg):
        if not p.is_file():
            raise FileNotFoundError(f"{p} not found: set PFTRACK_DATA or --data to the folder "
                                    "holding mot17-09/")
    return {"pets09": (video, gt), "mot17-09": (mv, mg)}


def parse_spec(spec: str) -> tuple[str, dict[str, Any]]:
    """``"NAME"`` or ``"NAME:P=V,P=V"`` -> (name, parameters; values read as YAML scalars);
    ``ValueError`` naming ``--detector`` when a parameter has no ``=``."""
    import yaml

    name, _, rest = spec.partition(":")
    params: dict[str, Any] = {}
    for item in filter(None, (x.strip() for x in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq or not key.strip():
            raise ValueError(f"bench detectors: --detector {spec}: parameters are P=V, got "
                             f"{item!r}")
        params[key.strip()] = yaml.safe_load(value)
    return name.strip(), params


def _make(spec: str, low: bool) -> Any:
    """A fresh detector from ``spec`` (:func:`parse_spec`; unnamed parameters at their
    defaults; ``low``: reporting down to :data:`LOW_SCORE`, for thresholds applied
    afterwards)."""
    from pftrack.contracts.components import RunContext
    from pftrack.workflows.pipeline import build_detector

    name, params = parse_spec(spec)
    det = build_detector({"detector": {"type": name, "params": params}})
    if low and "threshold" in det.get_params():
        det.set_params(threshold=LOW_SCORE)
        det.setup(RunContext())
    return det


def _read_mot(path: Path) -> np.ndarray:
    rows = np.loadtxt(path, delimiter=",", ndmin=2)
    if rows.shape[1] < 10:
        rows = np.hstack([rows, np.zeros((len(rows), 10 - rows.shape[1]))])
    return rows


def run_detectors(names: list[str], videos: dict[str, tuple[Path, Path]], every: int,
                  quiet: bool) -> dict[str, dict[str, dict[int, tuple[np.ndarray, np.ndarray]]]]:
    """{detector: {video: {frame: (boxes, scores)}}} on every ``every``-th frame (from 1)."""
    from pftrack.workflows.pipeline import iter_frames

    out: dict[str, dict[str, dict[int, tuple[np.ndarray, np.ndarray]]]] = {n: {} for n in names}
    for vname, (video, _) in videos.items():
        dets = {n: _make(n, low=True) for n in names}
        last = SPLITS[vname][1][1]
        for n in names:
            out[n][vname] = {}
        t0 = time.time()
        for frame in iter_frames(video, 1, last):
            if (frame.index - 1) % every:
                continue
            for n, d in dets.items():
                r = d.detect(frame)
                out[n][vname][frame.index] = (r.boxes_xywh_px.copy(), r.scores.copy())
            if not quiet and frame.index % (every * 20) == 1:
                print(f"detectors: {vname} frame {frame.index}/{last} "
                      f"({time.time() - t0:.0f} s)", file=sys.stderr, flush=True)
    return out


def time_detectors(names: list[str], videos: dict[str, tuple[Path, Path]], n_frames: int
                   ) -> list[dict[str, Any]]:
    """CPU ms per frame of each detector at each of :data:`SPEED_SIZES`, and ratios to the
    first detector."""
    import cv2
    from pftrack.contracts.components import Frame
    from pftrack.workflows.pipeline import iter_frames

    rows = []
    for W, H in SPEED_SIZES:
        src = "mot17-09" if W > 768 else "pets09"
        video = videos[src][0]
        warm = 10
        imgs = []
        for frame in iter_frames(video, 1, warm + n_frames):
            img = frame.image
            if img.shape[1] != W or img.shape[0] != H:
                img = cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA)
            imgs.append(img)
        row: dict[str, Any] = {"size": f"{W}x{H}", "source": src, "frames": n_frames,
                               "ms_per_frame": {}, "ratio_to_first": {}}
        for n in names:
            d = _make(n, low=False)
            for i in range(warm):  # hog-people learns its scale bands; the network loads
                d.detect(Frame(i + 1, imgs[i]))
            t0 = time.process_time()
            for i in range(warm, warm + n_frames):
                d.detect(Frame(i + 1, imgs[i]))
            row["ms_per_frame"][n] = 1000.0 * (time.process_time() - t0) / n_frames
        base = row["ms_per_frame"][names[0]]
        row["ratio_to_first"] = {n: v / base for n, v in row["ms_per_frame"].items()}
        rows.append(row)
    return rows


def run(args: argparse.Namespace) -> dict[str, Any]:
    import cv2

    names = args.detector or ["hog-people", "ssdlite-people"]
    if int(args.every) < 1:
        raise ValueError(f"bench detectors: --every is a whole number >= 1, got {args.every}")
    videos = _videos(args.data)
    sizes = {"pets09": (768, 576), "mot17-09": (1920, 1080)}
    gts = {v: _read_mot(g) for v, (_, g) in videos.items()}
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        dets = run_detectors(names, videos, int(args.every), bool(args.quiet))
        speed = time_detectors(names, videos, int(args.speed_frames)) \
            if int(args.speed_frames) > 0 else []
    finally:
        cv2.setNumThreads(threads)
    result: dict[str, Any] = {"every": int(args.every), "detectors": names,
                              "height_bins_px": bin_names(), "edge_px": EDGE_PX,
                              "splits": {v: {"train": list(s[0]), "test": list(s[1])}
                                         for v, s in SPLITS.items()},
                              "test": {}, "train": {}, "speed": speed}
    defaults = {n: float(_make(n, low=False).get_params().get("threshold", LOW_SCORE))
                for n in names}
    for n in names:
        result["test"][n], result["train"][n] = {}, {}
        for v in videos:
            tr, te = SPLITS[v]
            result["test"][n][v] = score(gts[v], dets[n][v], v, sizes[v], defaults[n], te)
            result["train"][n][v] = score(gts[v], dets[n][v], v, sizes[v], defaults[n], tr)
        result["test"][n]["threshold"] = defaults[n]
    # the precision-matched comparison: thresholds on PETS 1-400, figures on the test parts
    base = names[0]
    p_base = result["train"][base]["pets09"]["precision"]
    matched: dict[str, Any] = {"baseline": base, "baseline_threshold": defaults[base],
                               "precision_train_pets09": p_base, "detectors": {}}
    for n in names[1:]:
        s, y = labelled_scores(gts["pets09"], dets[n]["pets09"], "pets09",
                               SPLITS["pets09"][0])
        thr = threshold_for_precision(s, y, p_base) if p_base is not None else None
        entry: dict[str, Any] = {"threshold": thr}
        if thr is not None:
            thr = max(thr, LOW_SCORE)
            for v in videos:
                entry[v] = score(gts[v], dets[n][v], v, sizes[v], thr, SPLITS[v][1])
        matched["detectors"][n] = entry
    result["precision_matched"] = matched
    # the logistic map of ssdlite-people's logits, refitted on the training parts
    if "ssdlite-people" in names:
        d = _make("ssdlite-people", low=False)
        zs, ys = [], []
        for v in videos:
            s, y = labelled_scores(gts[v], dets["ssdlite-people"][v], v, SPLITS[v][0])
            p = np.clip(s, 1e-12, 1 - 1e-12)
            # back to the logit through the detector's own map
            zs.append(float(d.score_offset) + float(d.score_scale) * np.log(p / (1 - p)))
            ys.append(y)
        z, y = np.concatenate(zs), np.concatenate(ys)
        if len(z) >= 10 and 0 < y.sum() < len(y):
            off, scale = fit_logistic(z, y)
            result["calibration"] = {"detector": "ssdlite-people", "score_offset": off,
                                     "score_scale": scale, "detections": int(len(z)),
                                     "note": "fitted on the training parts, detections with "
                                             f"score >= {LOW_SCORE}"}
    return result


def _f(x: float | None, fmt: str = "5.2f") -> str:
    """``x`` formatted, or a dash as wide (no such box: no figure)."""
    if x is not None:
        return format(x, fmt)
    width = fmt.split(".")[0]
    return "-".rjust(int(width) if width.isdigit() else 1)


def format_table(result: dict[str, Any]) -> str:
    bins = result["height_bins_px"]
    lines = [f"Detectors at IoU 0.5, every {result['every']}th frame, test parts "
             f"(PETS {result['splits']['pets09']['test']}, MOT17-09 "
             f"{result['splits']['mot17-09']['test']})"]
    nw = max(16, max(len(n) for n in result["detectors"]) + 1)
    head = f"{'detector':<{nw}s}{'video':<10s}{'thr':>5s}{'rec':>6s}{'prec':>6s}" + \
        "".join(f"{b:>9s}" for b in bins) + f"{'edge':>7s}"
    lines.append("recall by ground-truth box height (px); edge: boxes touching the frame's edge")
    lines.append(head)

    def row(name: str, v: str, thr: float, s: dict[str, Any]) -> str:
        return (f"{name:<{nw}s}{v:<10s}{thr:5.2f}{_f(s['recall'], '6.3f')}"
                f"{_f(s['precision'], '6.3f')}"
                + "".join(f"{_f(s['recall_by_height'][b], '9.3f')}" for b in bins)
                + f"{_f(s['recall_at_edge'], '7.3f')}")

    for n, per in result["test"].items():
        for v in ("pets09", "mot17-09"):
            lines.append(row(n, v, per["threshold"], per[v]))
    pm = result["precision_matched"]
    lines.append(f"precision-matched (threshold at {pm['baseline']}'s PETS 1-400 precision "
                 f"{_f(pm['precision_train_pets09'], '.3f')}):")
    for n, e in pm["detectors"].items():
        if e.get("threshold") is None:
            lines.append(f"{n:<{nw}s} never reaches that precision")
            continue
        for v in ("pets09", "mot17-09"):
            lines.append(row(n, v, e["threshold"], e[v]))
    lines.append("ground-truth boxes per bin: " + ", ".join(
        f"{v}: " + " ".join(str(result['test'][result['detectors'][0]][v]['gt_by_height'][b])
                           for b in bins)
        + f" edge {result['test'][result['detectors'][0]][v]['gt_at_edge']}"
        for v in ("pets09", "mot17-09")))
    if result["speed"]:
        lines.append("CPU time per frame, one thread (ms; ratio to the first detector)")
        for r in result["speed"]:
            lines.append(f"  {r['size']:<10s}" + "  ".join(
                f"{n} {r['ms_per_frame'][n]:.0f} ms ({r['ratio_to_first'][n]:.2f})"
                for n in result["detectors"]))
    if "calibration" in result:
        c = result["calibration"]
        lines.append(f"ssdlite-people logistic map refitted on the training parts: offset "
                     f"{c['score_offset']:.3f}, scale {c['score_scale']:.3f} "
                     f"({c['detections']} detections)")
    return "\n".join(lines)
