"""Seed 003's block eigenspace background model against OpenCV's background subtractors on real
water, campus and thermal video: precision, recall, F-measure and PWC at pixel and block level,
frames per second, and the thermal clip's first detection.

Sequences (``../shared/data``, or ``--data``):

* ``zodiac`` (real infrared sea, 50 frames) and ``ocean`` (real beach, 30 frames): train on the
  first half (the eigenspace model on the blocks the masks mark as background; the OpenCV models
  see the same frames first), test on the second half against the per-frame masks;
* ``pets09`` (PETS 2009 S2.L1): background = pixels outside every ground-truth box inflated by
  ``--pets-margin`` px on each side; train on frames 1-400, test on 401-795, every
  ``--pets-step``-th frame of each range (the OpenCV models see every frame of the training
  range, so their running models stay continuous);
* ``thermal`` (``thermal/animal_entry.cptv``, 16-bit LWIR): the model trained on frames 1-35;
  the first later frame with an intruder block and the frames with one before it (the animal
  enters at frame 42). The eigenspace model runs with ``frame_offset="median"`` there (not in
  the paper: the camera's level drifts; without it nearly every block is flagged).

Pixel level: a method's foreground mask (the eigenspace model's: the pixels of its intruder
blocks) against the ground truth, summed over the test frames (the CDnet measures; PWC = 100
(FP + FN) / all). Block level (``--block`` px blocks): a ground-truth block is foreground when at
least a quarter of its pixels are; a method's block is foreground when at least a quarter of its
pixels are (the eigenspace model's intruder blocks as they are). Frames per second: test frames
only, one thread (OpenCV's threads set to 1).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

SEQUENCES = ("zodiac", "ocean", "pets09", "thermal")
GT_BLOCK_FRACTION = 0.25


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--data", default=None,
                        help="folder holding water/, pets09/, thermal/ (default: $PFTRACK_DATA "
                             "or ../shared/data)")
    parser.add_argument("--sequences", default=",".join(SEQUENCES),
                        help="comma-separated, from " + ", ".join(SEQUENCES))
    parser.add_argument("--methods", default="eigenspace,mog2,knn,cnt,gsoc",
                        help="eigenspace, mog2, knn and, with opencv-contrib, cnt, gsoc, gmg, "
                             "lsbp, mog")
    parser.add_argument("--block", type=int, default=8, help="block size, px (default 8)")
    parser.add_argument("--pets-margin", type=int, default=8,
                        help="px added around each PETS ground-truth box (default 8)")
    parser.add_argument("--pets-step", type=int, default=8,
                        help="use every K-th PETS frame for training and testing (default 8)")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


# -- data ------------------------------------------------------------------------------------


def load_water(folder: str | Path) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """A water sequence's grey frames (uint8) and foreground masks (bool), in frame order."""
    return _water(Path(folder))


def _water(folder: Path) -> tuple[list[np.ndarray], list[np.ndarray]]:
    import cv2

    inputs = sorted((folder / "input").glob("frame_*.jpg"),
                    key=lambda p: int(p.stem.split("_")[1]))
    if not inputs:
        raise FileNotFoundError(f"no frames in {folder / 'input'}")
    frames, masks = [], []
    for p in inputs:
        k = int(p.stem.split("_")[1])
        img = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        gt = cv2.imread(str(folder / "groundtruth" / f"gt{k:04d}.png"), cv2.IMREAD_GRAYSCALE)
        if img is None or gt is None:
            raise FileNotFoundError(f"{folder}: frame {k} or its mask could not be read")
        frames.append(img)
        masks.append(gt > 127)
    return frames, masks


def _pets(folder: Path, step: int, margin: int,
          ) -> tuple[list[np.ndarray], list[np.ndarray], list[bool]]:
    """Grey frames 1..795 (every frame: the OpenCV models need a continuous stream), masks of
    the inflated boxes, and which frames are used (every ``step``-th)."""
    import cv2
    from pftrack.io.mot import read_mot
    from pftrack.scenes.video import VideoScene

    from pftrack_coast.detector import boxes_to_mask

    gt = read_mot(folder / "gt.txt")
    frames, masks, used = [], [], []
    for f in VideoScene(str(folder / "vtest.avi")).frames():
        img = cv2.cvtColor(f.image, cv2.COLOR_BGR2GRAY)
        b = gt[gt[:, 0] == f.index, 2:6].copy()
        b[:, :2] -= margin
        b[:, 2:] += 2 * margin
        frames.append(img)
        masks.append(boxes_to_mask(b, img.shape))
        used.append((f.index - 1) % step == 0 if f.index <= 400 else (f.index - 401) % step == 0)
    return frames, masks, used


# -- measures --------------------------------------------------------------------------------


class _Counts:
    def __init__(self) -> None:
        self.tp = self.fp = self.fn = self.tn = 0

    def add(self, pred: np.ndarray, truth: np.ndarray) -> None:
        p, t = np.asarray(pred, bool), np.asarray(truth, bool)
        tp = int(np.count_nonzero(p & t))
        fp = int(np.count_nonzero(p & ~t))
        fn = int(np.count_nonzero(~p & t))
        self.tp += tp
        self.fp += fp
        self.fn += fn
        self.tn += p.size - tp - fp - fn

    def figures(self) -> dict[str, float]:
        prec = self.tp / (self.tp + self.fp) if self.tp + self.fp else 0.0
        rec = self.tp / (self.tp + self.fn) if self.tp + self.fn else 0.0
        f = 2 * prec * rec / (prec + rec) if prec + rec else 0.0
        total = self.tp + self.fp + self.fn + self.tn
        return {"precision": prec, "recall": rec, "f_measure": f,
                "pwc": 100.0 * (self.fp + self.fn) / max(total, 1)}


def _blocks(mask: np.ndarray, bs: int) -> np.ndarray:
    from pftrack_coast.eigenspace import block_fractions

    return block_fractions(mask, bs) >= GT_BLOCK_FRACTION


# -- methods ---------------------------------------------------------------------------------


def _opencv(name: str) -> Callable[[], Any]:
    import cv2

    makers = {"mog2": lambda: cv2.createBackgroundSubtractorMOG2(detectShadows=False),
              "knn": lambda: cv2.createBackgroundSubtractorKNN(detectShadows=False)}
    contrib = {"cnt": "createBackgroundSubtractorCNT", "gsoc": "createBackgroundSubtractorGSOC",
               "gmg": "createBackgroundSubtractorGMG", "lsbp": "createBackgroundSubtractorLSBP",
               "mog": "createBackgroundSubtractorMOG"}
    if name in makers:
        return makers[name]
    if name in contrib and hasattr(cv2, "bgsegm") and hasattr(cv2.bgsegm, contrib[name]):
        return getattr(cv2.bgsegm, contrib[name])
    raise ValueError(f"background method {name!r} is not available (known: eigenspace, mog2, "
                     "knn; with opencv-contrib: cnt, gsoc, gmg, lsbp, mog)")


def _run_method(method: str, train: list[np.ndarray], train_masks: list[np.ndarray],
                test: Iterator[np.ndarray], bs: int, frame_offset: str = "none",
                ) -> Iterator[tuple[np.ndarray, np.ndarray, float]]:
    """Yield (pixel mask, block mask, seconds) per test frame."""
    if method == "eigenspace":
        import warnings

        from pftrack_coast.eigenspace import BlockEigenspaceModel

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # untrained blocks are counted in the result
            model = BlockEigenspaceModel(block_size=bs, frame_offset=frame_offset).fit(
                train, train_masks)
        for img in test:
            t0 = time.perf_counter()
            res = model.score(img)
            dt = time.perf_counter() - t0
            blocks = res.intruder_mask
            pix = np.zeros(img.shape[:2], bool)
            h, w = blocks.shape[0] * bs, blocks.shape[1] * bs
            pix[:h, :w] = np.repeat(np.repeat(blocks, bs, axis=0), bs, axis=1)
            yield pix, blocks, dt
        return
    sub = _opencv(method)()
    for img in train:
        sub.apply(img)
    for img in test:
        t0 = time.perf_counter()
        fg = sub.apply(img)
        dt = time.perf_counter() - t0
        pix = fg > 127
        yield pix, _blocks(pix, bs), dt


def _score(sequence: str, method: str, train, train_masks, test, test_masks, bs: int,
           ) -> list[dict[str, Any]]:
    pix_c, blk_c = _Counts(), _Counts()
    seconds = 0.0
    n = 0
    for (pix, blocks, dt), truth in zip(_run_method(method, train, train_masks, iter(test), bs),
                                        test_masks):
        pix_c.add(pix, truth)
        gt_blocks = _blocks(truth, bs)
        blk_c.add(blocks[: gt_blocks.shape[0], : gt_blocks.shape[1]], gt_blocks)
        seconds += dt
        n += 1
    fps = n / seconds if seconds > 0 else float("inf")
    return [{"sequence": sequence, "method": method, "level": level, **c.figures(),
             "frames": n, "frames_per_second": fps}
            for level, c in (("pixel", pix_c), ("block", blk_c))]


def _thermal(path: Path, bs: int) -> dict[str, Any]:
    from cptv import CPTVReader

    from pftrack_coast.eigenspace import BlockEigenspaceModel

    with open(path, "rb") as fh:
        pix = [np.asarray(f.pix) for f in CPTVReader(fh)]
    model = BlockEigenspaceModel(block_size=bs, frame_offset="median")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit(pix[1:36])
    flagged = [int(model.score(p).intruder_mask.sum()) for p in pix[36:]]
    first = next((36 + k for k, c in enumerate(flagged) if c > 0), None)
    return {"train_frames": "1-35", "animal_enters_frame": 42,
            "first_detection_frame": first,
            "false_alarm_frames_before": (sum(1 for c in flagged[: first - 36] if c) if first
                                          is not None else None),
            "frames_with_detection_from_42": sum(1 for c in flagged[42 - 36:] if c),
            "frames_from_42": len(flagged) - (42 - 36),
            "frame_offset": "median"}


def run(args: argparse.Namespace) -> dict[str, Any]:
    import cv2
    from pftrack.data import data_dir

    root = Path(args.data) if args.data else data_dir()
    seqs = [s.strip() for s in args.sequences.split(",") if s.strip()]
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = set(seqs) - set(SEQUENCES)
    if unknown:
        raise ValueError(f"--sequences: unknown {sorted(unknown)}; known: {list(SEQUENCES)}")
    for m in methods:
        if m != "eigenspace":
            _opencv(m)
    if args.block < 2 or args.pets_step < 1 or args.pets_margin < 0:
        raise ValueError("--block must be >= 2, --pets-step >= 1, --pets-margin >= 0")
    say = (lambda s: None) if args.quiet else (lambda s: print(s, file=sys.stderr, flush=True))
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    rows: list[dict[str, Any]] = []
    out: dict[str, Any] = {"rows": rows}
    try:
        for seq in seqs:
            if seq == "thermal":
                say("background: thermal")
                out["thermal"] = _thermal(root / "thermal" / "animal_entry.cptv", args.block)
                continue
            if seq == "pets09":
                frames, masks, used = _pets(root / "pets09", args.pets_step, args.pets_margin)
                train_idx = list(range(400))
                test_idx = [k for k in range(400, len(frames)) if used[k]]
                # the eigenspace model learns from every step-th training frame; the OpenCV
                # models see the whole training stream
                train_eig = [k for k in train_idx if used[k]]
            else:
                frames, masks = _water(root / "water" / seq)
                half = len(frames) // 2
                train_idx = train_eig = list(range(half))
                test_idx = list(range(half, len(frames)))
            for m in methods:
                say(f"background: {seq} {m}")
                tr = train_eig if m == "eigenspace" else train_idx
                rows.extend(_score(seq, m, [frames[k] for k in tr], [masks[k] for k in tr],
                                   [frames[k] for k in test_idx], [masks[k] for k in test_idx],
                                   args.block))
    finally:
        cv2.setNumThreads(threads)
    out["setup"] = {"block": args.block, "gt_block_fraction": GT_BLOCK_FRACTION,
                    "pets_margin_px": args.pets_margin, "pets_step": args.pets_step,
                    "protocol": "water: train first half, test second half; pets09: train "
                                "1-400, test 401-795 (every pets_step-th frame); fps over "
                                "test frames, one OpenCV thread"}
    return out


def format_table(result: dict[str, Any]) -> str:
    head = (f"{'sequence':<8} {'method':<10} {'level':<6} {'P':>6} {'R':>6} {'F':>6} "
            f"{'PWC':>6} {'fps':>8}")
    lines = [head, "-" * len(head)]
    for r in result["rows"]:
        lines.append(f"{r['sequence']:<8} {r['method']:<10} {r['level']:<6} "
                     f"{r['precision']:6.3f} {r['recall']:6.3f} {r['f_measure']:6.3f} "
                     f"{r['pwc']:6.2f} {r['frames_per_second']:8.1f}")
    t = result.get("thermal")
    if t:
        lines.append(f"thermal: first detection at frame {t['first_detection_frame']} (animal "
                     f"enters at {t['animal_enters_frame']}), {t['false_alarm_frames_before']} "
                     f"false-alarm frames before it; detections in "
                     f"{t['frames_with_detection_from_42']} of {t['frames_from_42']} frames "
                     "from 42")
    return "\n".join(lines)
