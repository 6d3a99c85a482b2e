"""The coastal paper's block eigenspace background model against OpenCV's background subtractors on
real water, campus and thermal video: precision, recall, F-measure and PWC at pixel and block level,
frames per second, and on a thermal clip with annotated boxes the entry, false alarms on empty
frames, recall and block precision, with and without a simulated camera recalibration.

Sequences (``../shared/data``, or ``--data``):

* ``zodiac`` (real infrared sea, 50 frames) and ``ocean`` (real beach, 30 frames): train on the
  first half (the eigenspace model on the blocks the masks mark as background; the OpenCV models
  see the same frames first), test on the second half against the per-frame masks;
* ``pets09`` (PETS 2009 S2.L1): background = pixels outside every ground-truth box inflated by
  ``--pets-margin`` px on each side; train on frames 1-400, test on 401-795, every
  ``--pets-step``-th frame of each range (the OpenCV models see every frame of the training
  range, so their running models stay continuous);
* ``thermal`` (``--thermal-clip``, default ``thermal/animal_entry.cptv``, 16-bit LWIR counts)
  against the animal's boxes of ``--thermal-annotation`` (a MOT file; for the default clip the
  reference boxes shipped in ``pftrack_coast/data/animal_entry_gt.txt``, made by thresholding
  against the camera's stored empty background frame and checked by eye). The eigenspace model
  (``frame_offset="median"``: the camera's level drifts) trains on ``--thermal-train`` frames
  with the annotated boxes masked out of its background (or refuses such frames); MOG2 and KNN
  see those frames first, then the test frames (all the others, in order), as float counts
  less each frame's median. Per method: the first frame from the entry with a flagged block on the
  animal, false alarms on the frames known to be empty (any flagged block), recall (frames
  with the animal where a flagged block touches its box) and block precision (flagged blocks
  touching a box / all flagged blocks, over the frames with the animal), and which of the
  goals (:data:`THERMAL_GOALS`) are met. With ``--thermal-recalibration simulated`` or
  ``both`` the test frames from the middle one on carry a simulated flat-field correction
  (:func:`pftrack_coast.thermal.simulate_recalibration`; training frames are always taken as
  recorded: the model was trained before the event), and the eigenspace model runs through a
  :class:`~pftrack_coast.recalibration.RecalibrationGuard` (``--thermal-guard``; a pause of
  more than 5 frame intervals, a level step of ``--thermal-level-step`` counts, a quarter of
  the blocks flagged, or the camera's own FFC time changing) whose messages are printed. The
  camera's stored background frames are scored by the model alone, not as part of the live
  stream.

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

from pftrack_bench.protocol import Protocol

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="real infrared sea (zodiac), a beach (ocean), PETS 2009 S2.L1 and a 16-bit "
         "thermal clip with its annotated boxes",
    chosen_on="the first half of each sequence trains the models (PETS frames "
              "1-400); OpenCV's subtractors keep their defaults",
    reported_on="the second half of each sequence (PETS 401-795); the thermal clip's "
                "frames after its training frames",
)


SEQUENCES = ("zodiac", "ocean", "pets09", "thermal")
#: the methods that take the thermal clip's float frames (counts less each frame's median)
THERMAL_METHODS = ("eigenspace", "mog2", "knn")
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
    parser.add_argument("--untrained", choices=("ignore", "nearest"), default="ignore",
                        help="the eigenspace model's rule for blocks without enough background "
                             "samples (default ignore: never intruders)")
    parser.add_argument("--pictures", default=None, metavar="DIR",
                        help="write a PNG per sequence of where the eigenspace model's "
                             "untrained blocks are")
    parser.add_argument("--thermal-clip", default=None, metavar="PATH",
                        help="a .cptv file or a folder of 16-bit frames (default: "
                             "DATA/thermal/animal_entry.cptv)")
    parser.add_argument("--thermal-annotation", default=None, metavar="MOT",
                        help="MOT file of the animal's boxes, frame = the clip's 0-based frame "
                             "number; a '# frames: N' line says every frame 0..N-1 is annotated "
                             "(a frame without a row is empty). Default for animal_entry.cptv: "
                             "the annotation shipped with pftrack (checked by the clip's "
                             "sha256); required for any other clip")
    parser.add_argument("--thermal-train", default="alternate", metavar="FRAMES",
                        help="training frames: A:B (inclusive), A:B:STEP or A,B,C; 'alternate' "
                             "(default): every second live frame from the second on (the "
                             "camera's stored background frames are never trained on); the "
                             "other frames are tested")
    parser.add_argument("--thermal-boxes-in-training", choices=("mask", "refuse"),
                        default="mask",
                        help="training frames with annotated boxes: 'mask' (default) keeps "
                             "the boxes, grown by --thermal-margin, out of the eigenspace "
                             "model's background; 'refuse' is an error")
    parser.add_argument("--thermal-margin", type=float, default=4.0,
                        help="px added to each side of a box masked in training (default 4: "
                             "the animal's warm outline)")
    parser.add_argument("--thermal-entry", type=int, default=None,
                        help="frame the animal enters (default: the annotation's first box)")
    parser.add_argument("--thermal-empty", default=None, metavar="FRAMES",
                        help="frames known to be empty (default: the annotated frames without "
                             "a box)")
    parser.add_argument("--thermal-recalibration", choices=("none", "simulated", "both"),
                        default="both",
                        help="run on the clip as recorded, with a simulated flat-field "
                             "correction (level -33 counts, a new per-pixel pattern, a 1.6 s "
                             "pause), or both (default)")
    parser.add_argument("--thermal-recal-at", type=int, default=None,
                        help="frame of the simulated recalibration (default: the middle test "
                             "frame)")
    parser.add_argument("--thermal-guard", choices=("on", "off"), default="on",
                        help="the eigenspace model watches for recalibrations and re-baselines "
                             "(default on; see pftrack_coast.recalibration)")
    parser.add_argument("--thermal-level-step", type=float, default=15.0,
                        help="median-level step between frames, counts, taken as a "
                             "recalibration (default 15)")
    parser.add_argument("--thermal-adapt-rate", type=float, default=0.02,
                        help="the eigenspace model's block means away from the animal follow "
                             "each sound frame by this fraction (default 0.02; 0: never)")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the simulated recalibration's pattern (default 0)")
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
                untrained: str = "ignore", info: dict[str, Any] | None = None,
                ) -> Iterator[tuple[np.ndarray, np.ndarray, float]]:
    """Yield (pixel mask, block mask, seconds) per test frame; the eigenspace model is put in
    ``info["model"]``."""
    if method == "eigenspace":
        import warnings

        from pftrack_coast.eigenspace import BlockEigenspaceModel

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # untrained blocks are counted in the result
            model = BlockEigenspaceModel(block_size=bs, frame_offset=frame_offset,
                                         untrained=untrained).fit(train, train_masks)
        if info is not None:
            info["model"] = model
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
           untrained: str = "ignore", pictures: str | None = None) -> list[dict[str, Any]]:
    pix_c, blk_c = _Counts(), _Counts()
    seconds = 0.0
    n = 0
    info: dict[str, Any] = {}
    for (pix, blocks, dt), truth in zip(_run_method(method, train, train_masks, iter(test), bs,
                                                    untrained=untrained, info=info),
                                        test_masks):
        pix_c.add(pix, truth)
        gt_blocks = _blocks(truth, bs)
        blk_c.add(blocks[: gt_blocks.shape[0], : gt_blocks.shape[1]], gt_blocks)
        seconds += dt
        n += 1
    fps = n / seconds if seconds > 0 else float("inf")
    extra: dict[str, Any] = {}
    if "model" in info:
        model = info["model"]
        extra = {"untrained": untrained, "untrained_blocks": len(model.untrained_blocks_)}
        if pictures:
            from pftrack_coast.eigenspace import untrained_picture

            untrained_picture(model, Path(pictures) / f"{sequence}_untrained_blocks.png",
                              image=train[0])
    return [{"sequence": sequence, "method": method, "level": level, **c.figures(),
             "frames": n, "frames_per_second": fps, **extra}
            for level, c in (("pixel", pix_c), ("block", blk_c))]


# -- thermal: a clip with annotated boxes ----------------------------------------------------

THERMAL_GOALS = {
    "entry_within_3": "first detection within 3 frames of the entry",
    "no_false_alarm": "no detection on the frames known to be empty",
    "recall_0.95": "recall >= 0.95 on the frames with the animal",
    "precision_0.9": "block precision >= 0.9 on the frames with the animal",
}


def frame_spec(spec: str, n: int, option: str) -> list[int]:
    """Frame numbers from ``A:B`` (inclusive), ``A:B:STEP`` or ``A,B,C``, each inside
    ``0..n-1``; ValueError naming ``option`` otherwise."""
    out: list[int] = []
    try:
        for part in (p.strip() for p in spec.split(",") if p.strip()):
            if ":" in part:
                bits = [int(b) for b in part.split(":")]
                if len(bits) not in (2, 3) or (len(bits) == 3 and bits[2] < 1):
                    raise ValueError(part)
                out.extend(range(bits[0], bits[1] + 1, bits[2] if len(bits) == 3 else 1))
            else:
                out.append(int(part))
    except ValueError:
        raise ValueError(f"{option}: {spec!r} is not A:B, A:B:STEP or A,B,C (frame numbers)"
                         ) from None
    bad = [k for k in out if not 0 <= k < n]
    if bad or not out:
        raise ValueError(f"{option}: {spec!r} gives {'no frame' if not out else bad[:5]}; the "
                         f"clip has frames 0-{n - 1}")
    return sorted(set(out))


def _read_annotation(path: Path, clip_path: Path, n: int,
                     ) -> tuple[dict[int, np.ndarray], int | None]:
    """Boxes per frame from a MOT file (frame = the clip's 0-based frame number) and the
    number of frames it annotates (its ``# frames: N`` line), checking its ``# clip sha256:``
    line against the clip when it has one."""
    import hashlib

    from pftrack.io.mot import read_mot

    rows = read_mot(path)
    annotated = digest = None
    for line in path.read_text(encoding="utf-8-sig").splitlines():
        if line.startswith("# frames:"):
            annotated = int(line.split(":")[1].split()[0])
        elif line.startswith("# clip sha256:"):
            digest = line.split(":", 1)[1].strip()
    if digest is not None and clip_path.is_file():
        got = hashlib.sha256(clip_path.read_bytes()).hexdigest()
        if got != digest:
            raise ValueError(f"--thermal-annotation {path} was made for another clip (sha256 "
                             f"{digest[:12]}...) than {clip_path} ({got[:12]}...); give the "
                             "annotation of this clip")
    if len(rows) and (rows[:, 0].min() < 0 or rows[:, 0].max() >= n):
        raise ValueError(f"--thermal-annotation {path}: frames {int(rows[:, 0].min())}-"
                         f"{int(rows[:, 0].max())}, the clip {clip_path} has 0-{n - 1}")
    boxes = {int(k): rows[rows[:, 0] == k, 2:6] for k in np.unique(rows[:, 0])}
    return boxes, annotated


def _touched(boxes: np.ndarray, grid: tuple[int, int], bs: int) -> np.ndarray:
    """(rows, cols) bool: blocks that share at least one pixel with any of the boxes."""
    out = np.zeros(grid, bool)
    for x, y, w, h in np.asarray(boxes, float).reshape(-1, 4):  # a box or two per frame
        c0, r0 = int(np.floor(x)) // bs, int(np.floor(y)) // bs
        c1, r1 = (int(np.ceil(x + w)) - 1) // bs, (int(np.ceil(y + h)) - 1) // bs
        out[max(r0, 0):r1 + 1, max(c0, 0):c1 + 1] = True
    return out


def _thermal_setup(args: argparse.Namespace, root: Path) -> dict[str, Any]:
    from pftrack_coast.thermal import DEFAULT_ANNOTATION, read_thermal

    default_clip = root / "thermal" / "animal_entry.cptv"
    clip_path = Path(args.thermal_clip) if args.thermal_clip else default_clip
    clip = read_thermal(clip_path)
    n = len(clip.frames)
    if args.thermal_annotation:
        ann = Path(args.thermal_annotation)
    elif clip_path.name == default_clip.name:
        ann = DEFAULT_ANNOTATION  # checked against the clip by its sha256 line
    else:
        raise ValueError(f"--thermal-annotation: {clip_path} has no annotation (a CPTV file's "
                         "reader gives no track boxes); give a MOT file of its boxes")
    boxes, annotated = _read_annotation(ann, clip_path, n)
    if annotated is not None and annotated != n:
        raise ValueError(f"--thermal-annotation {ann} annotates {annotated} frames, the clip "
                         f"{clip_path} has {n}")
    live = [k for k in range(n) if not clip.background[k]]
    if args.thermal_train == "alternate":
        train = live[1::2]
    else:
        train = frame_spec(args.thermal_train, n, "--thermal-train")
    with_boxes = [k for k in train if k in boxes]
    if with_boxes and args.thermal_boxes_in_training == "refuse":
        raise ValueError(f"--thermal-train: the annotation {ann} has the animal in training "
                         f"frames {_ranges(with_boxes)}; train on empty frames or pass "
                         "--thermal-boxes-in-training mask")
    test = [k for k in range(n) if k not in set(train)]
    if not test:
        raise ValueError("--thermal-train: every frame is a training frame; none is left to test")
    entry = int(args.thermal_entry) if args.thermal_entry is not None else (
        min(boxes) if boxes else None)
    if entry is None:
        raise ValueError(f"--thermal-annotation {ann} has no box: no entry to measure")
    empty = (frame_spec(args.thermal_empty, n, "--thermal-empty") if args.thermal_empty
             else [k for k in range(n) if k not in boxes])
    overlap = sorted(set(empty) & set(boxes))
    if overlap:
        raise ValueError(f"--thermal-empty: frames {_ranges(overlap)} have boxes in {ann}")
    at = int(args.thermal_recal_at) if args.thermal_recal_at is not None else test[len(test) // 2]
    return {"clip": clip, "clip_path": clip_path, "annotation": ann, "boxes": boxes,
            "train": train, "test": test, "entry": entry, "empty": empty,
            "train_with_boxes": with_boxes, "recal_at": at}


def _ranges(ks: list[int]) -> str:
    """'1-5, 9, 12-14' of sorted frame numbers ('2-170 every 2nd' for a stepped range)."""
    out, ks = [], sorted(ks)
    steps = set(np.diff(ks).tolist())
    if len(ks) > 2 and len(steps) == 1 and steps != {1}:
        return f"{ks[0]}-{ks[-1]} step {steps.pop()}"
    i = 0
    while i < len(ks):
        j = i
        while j + 1 < len(ks) and ks[j + 1] == ks[j] + 1:
            j += 1
        out.append(f"{ks[i]}" if i == j else f"{ks[i]}-{ks[j]}")
        i = j + 1
    return ", ".join(out)


def _thermal_eigenspace(setup: dict[str, Any], bs: int, args: argparse.Namespace) -> Any:
    import warnings

    from pftrack_coast.detector import boxes_to_mask
    from pftrack_coast.eigenspace import BlockEigenspaceModel

    clip, boxes, m = setup["clip"], setup["boxes"], float(args.thermal_margin)
    frames = [clip.frames[k] for k in setup["train"]]
    masks = [boxes_to_mask(boxes[k] + np.array([-m, -m, 2 * m, 2 * m]), clip.frames[k].shape)
             if k in boxes else None for k in setup["train"]]
    model = BlockEigenspaceModel(block_size=bs, frame_offset="median",
                                 untrained=args.untrained)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the untrained blocks are in the result
        model.fit(frames, masks)
    return model


def _thermal_method(method: str, setup: dict[str, Any], clip: Any, model: Any, bs: int,
                    args: argparse.Namespace) -> dict[str, Any]:
    """One method on the test frames of ``clip`` (the recorded or the simulated one): per test
    frame the flagged blocks against the blocks the boxes touch."""
    import copy

    base = setup["clip"]
    grid = (base.frames[0].shape[0] // bs, base.frames[0].shape[1] // bs)
    guard = None
    messages: list[str] = []
    if method == "eigenspace":
        model = copy.deepcopy(model)  # re-baselining changes it
        if args.thermal_guard == "on":
            from pftrack_coast.recalibration import RecalibrationGuard

            live = ~clip.background
            dt = np.diff(clip.times_s[live])
            gap = 5.0 * float(np.median(dt)) if len(dt) and np.isfinite(dt).all() else None
            guard = RecalibrationGuard(model, level_step=args.thermal_level_step, gap_s=gap,
                                       adapt_rate=args.thermal_adapt_rate, warn=False)
    else:
        sub = _opencv(method)()
        for k in setup["train"]:
            sub.apply(_thermal_float(base.frames[k]))
    flagged: dict[int, np.ndarray] = {}
    seconds = 0.0
    prev_ffc = None
    for k in setup["test"]:
        img = clip.frames[k]
        t0 = time.perf_counter()
        if method == "eigenspace":
            if guard is None or clip.background[k]:
                # the camera's stored background image is no live frame: scored as it is
                res = model.score(img)
            else:
                ffc = clip.ffc_s[k]
                hint = ("the camera's last FFC time changed" if prev_ffc is not None and
                        np.isfinite(ffc) and ffc != prev_ffc else None)
                prev_ffc = ffc if np.isfinite(ffc) else prev_ffc
                res = guard.score(img, time_s=float(clip.times_s[k]), hint=hint, frame=k)
            blocks = res.intruder_mask
        else:
            blocks = _blocks(sub.apply(_thermal_float(img)) > 127, bs)
        seconds += time.perf_counter() - t0
        flagged[k] = blocks[: grid[0], : grid[1]]
    if guard is not None:
        messages = list(guard.messages)
    return _thermal_figures(method, setup, flagged, grid, bs, seconds, messages)


def _thermal_float(img: np.ndarray) -> np.ndarray:
    """A thermal frame for OpenCV's subtractors: float32 counts less the frame's median (the
    same global-level compensation as the eigenspace model's ``frame_offset="median"``)."""
    g = img.astype(np.float32)
    return g - np.float32(np.median(g[::4, ::4]))


def _thermal_figures(method: str, setup: dict[str, Any], flagged: dict[int, np.ndarray],
                     grid: tuple[int, int], bs: int, seconds: float, messages: list[str],
                     ) -> dict[str, Any]:
    boxes, entry = setup["boxes"], setup["entry"]
    with_animal = [k for k in setup["test"] if k in boxes]
    empty = [k for k in setup["test"] if k in set(setup["empty"])]
    found, correct, total = [], 0, 0
    per_frame = []  # [frame, flagged blocks, of them touching a box] per frame with the animal
    for k in with_animal:
        touch = _touched(boxes[k], grid, bs)
        hit = flagged[k] & touch
        found.append(bool(hit.any()))
        correct += int(hit.sum())
        total += int(flagged[k].sum())
        per_frame.append([int(k), int(flagged[k].sum()), int(hit.sum())])
    first_test = next((k for k in setup["test"] if k >= entry), None)
    first = next((k for k, f in zip(with_animal, found) if f and k >= entry), None)
    delay = None if first is None or first_test is None else first - first_test
    fa = [k for k in empty if flagged[k].any()]
    recall = sum(found) / len(found) if found else 0.0
    precision = correct / total if total else 0.0
    goals = {"entry_within_3": delay is not None and delay <= 3,
             "no_false_alarm": bool(empty) and not fa,
             "recall_0.95": bool(found) and recall >= 0.95,
             "precision_0.9": total > 0 and precision >= 0.9}
    n = len(setup["test"])
    return {"method": method, "entry_frame": entry, "first_test_frame_from_entry": first_test,
            "first_detection_frame": first, "delay_frames": delay,
            "empty_frames": len(empty), "false_alarm_frames": len(fa),
            "false_alarm_frame_list": fa, "frames_with_animal": len(with_animal),
            "frames_found": int(sum(found)), "recall": recall, "block_precision": precision,
            "flagged_blocks": total, "missed_frames": [k for k, f in zip(with_animal, found)
                                                       if not f],
            "frames_per_second": n / seconds if seconds > 0 else float("inf"),
            "per_frame_flagged_on_animal": per_frame, "goals": goals, "messages": messages}


def _thermal(args: argparse.Namespace, root: Path, methods: list[str], bs: int,
             say: Callable[[str], None]) -> dict[str, Any]:
    from pftrack_coast.thermal import simulate_recalibration

    setup = _thermal_setup(args, root)
    clip = setup["clip"]
    # the thermal frames are float counts; OpenCV's contrib subtractors take 8-bit images only
    skipped = {m: "takes 8-bit images only; the clip holds 16-bit counts"
               for m in methods if m not in THERMAL_METHODS}
    methods = [m for m in methods if m in THERMAL_METHODS]
    model = _thermal_eigenspace(setup, bs, args) if "eigenspace" in methods else None
    conditions = {"none": ["recorded"], "simulated": ["simulated"],
                  "both": ["recorded", "simulated"]}[args.thermal_recalibration]
    runs = []
    for cond in conditions:
        c = clip if cond == "recorded" else simulate_recalibration(
            clip, setup["recal_at"], rng=np.random.default_rng(args.seed))
        for m in methods:
            say(f"background: thermal {m} ({cond})")
            runs.append({"clip": cond, **_thermal_method(m, setup, c, model, bs, args)})
    out: dict[str, Any] = {
        "skipped_methods": skipped,
        "clip_file": str(setup["clip_path"]), "annotation": str(setup["annotation"]),
        "frames": len(clip.frames), "train_frames": _ranges(setup["train"]),
        "train_frames_with_animal_masked": _ranges(setup["train_with_boxes"]),
        "test_frames": len(setup["test"]), "entry_frame": setup["entry"],
        "empty_frames": _ranges(setup["empty"]),
        "recalibration_at": setup["recal_at"] if "simulated" in conditions else None,
        "untrained": args.untrained, "goals": THERMAL_GOALS, "runs": runs}
    if model is not None:
        out["untrained_blocks"] = model.untrained_blocks_.tolist()
        out["eigenspace_model"] = model.describe()
        if args.pictures:
            from pftrack_coast.eigenspace import untrained_picture

            img = clip.frames[setup["train"][0]]
            p = untrained_picture(model, Path(args.pictures) / "thermal_untrained_blocks.png",
                                  image=img)
            out["untrained_picture"] = str(p)
    return out

def run(args: argparse.Namespace) -> dict[str, Any]:
    import cv2
    from pftrack.io.data import data_dir

    # a Namespace built by hand (a notebook, a script) gets the command's defaults for the
    # options it leaves out
    defaults = argparse.ArgumentParser(add_help=False)
    add_arguments(defaults)
    args = argparse.Namespace(**{**vars(defaults.parse_args([])), **vars(args)})

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
                out["thermal"] = _thermal(args, root, methods, args.block, say)
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
                                   args.block, args.untrained, args.pictures))
    finally:
        cv2.setNumThreads(threads)
    out["setup"] = {"block": args.block, "gt_block_fraction": GT_BLOCK_FRACTION,
                    "untrained": args.untrained,
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
        lines.append("")
        lines.append(f"thermal: {t['clip_file']} ({t['frames']} frames), boxes from "
                     f"{t['annotation']}")
        lines.append(f"  trained on frames {t['train_frames']} (the animal masked in "
                     f"{t['train_frames_with_animal_masked'] or 'none'}), "
                     f"{t['test_frames']} test frames; entry at frame {t['entry_frame']}; "
                     f"empty frames {t['empty_frames'] or 'none'}")
        if "untrained_blocks" in t:
            ub = t["untrained_blocks"]
            lines.append(f"  eigenspace model: {len(ub)} untrained block(s) "
                         f"{[tuple(b) for b in ub][:12]} (untrained={t['untrained']})"
                         + (f", picture {t['untrained_picture']}" if "untrained_picture" in t
                            else ""))
        if t["recalibration_at"] is not None:
            lines.append(f"  simulated recalibration at frame {t['recalibration_at']}")
        head = (f"  {'clip':<10} {'method':<10} {'first':>5} {'delay':>5} {'FA/empty':>8} "
                f"{'recall':>6} {'blockP':>6} {'fps':>7}  goals met")
        lines += [head, "  " + "-" * (len(head) - 2)]
        for r in t["runs"]:
            met = [g for g, ok in r["goals"].items() if ok]
            lines.append(
                f"  {r['clip']:<10} {r['method']:<10} {str(r['first_detection_frame']):>5} "
                f"{str(r['delay_frames']):>5} "
                f"{r['false_alarm_frames']:>3}/{r['empty_frames']:<4} {r['recall']:6.3f} "
                f"{r['block_precision']:6.3f} {r['frames_per_second']:7.1f}  "
                f"{len(met)}/{len(r['goals'])} {' '.join(met)}")
            for msg in r["messages"]:
                lines.append(f"      {msg}")
        lines.append("  goals: " + "; ".join(f"{k}: {v}" for k, v in t["goals"].items()))
    return "\n".join(lines)
