"""Training the linear SVM person detector (:func:`train_svm_model`): positives from the
ground-truth boxes and their mirror images, random negatives away from every box, and rounds of
hard-negative mining with the detector itself. Also importable from :mod:`pftrack_world.detector`.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import numpy as np
from pftrack.contracts.components import (
    Frame,
)
from pftrack.geometry.boxes import iou_matrix, nms

from pftrack_world.svm_model import (
    FEATURES,
    MIN_TRAIN_RECALL,
    SVMModel,
    TrainingRecallWarning,
    _window_rect,
    crop_windows,
    heights_from_boxes,
    window_features,
)

if TYPE_CHECKING:
    from pftrack_world.detector import SVMDetector

__all__ = ["train_svm_model"]


def _grey(image: np.ndarray) -> np.ndarray:
    import cv2

    return image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)


def _random_negatives(grey: np.ndarray, avoid: np.ndarray, n: int, heights: np.ndarray,
                      aspect: float, neg_iou: float, rng: np.random.Generator) -> np.ndarray:
    """Up to ``n`` random person-shaped boxes with IoU < neg_iou against ``avoid``."""
    ih, iw = grey.shape[:2]
    m = 4 * n + 8
    h = rng.choice(heights, size=m) * rng.uniform(0.7, 1.4, size=m)
    w = h * aspect
    x = rng.uniform(-0.1, 1.0, size=m) * (iw - w * 0.9)
    y = rng.uniform(-0.1, 1.0, size=m) * (ih - h * 0.9)
    cand = np.stack([x, y, w, h], axis=1)
    if len(avoid):
        cand = cand[iou_matrix(cand, avoid).max(axis=1) < neg_iou]
    return cand[:n]


def train_svm_model(frames: Iterable[Frame], boxes_by_frame: dict[int, np.ndarray],
                    rng: np.random.Generator, *,
                    ignore_by_frame: dict[int, np.ndarray] | None = None,
                    feature: str = "hog", window_wh: tuple[int, int] = (32, 64),
                    occupancy: float = 0.8, C: float = 0.01, n_negatives: int = 8000,
                    hard_negative_rounds: int = 1, neg_iou: float = 0.3, max_hard: int = 20000,
                    detector: SVMDetector | None = None, progress: bool = False) -> SVMModel:
    """Train a linear SVM window classifier from frames and ground-truth boxes.

    See the module docstring for the sampling; the returned weights are scaled to unit norm so
    the detector's scores are distances to the decision boundary. ``detector`` (its scale and
    NMS settings) is used for hard-negative mining; a default :class:`SVMDetector` otherwise.
    """
    from sklearn.svm import LinearSVC

    if feature not in FEATURES:
        raise ValueError(f"unknown detector feature {feature!r}; known: {', '.join(FEATURES)}")
    if not 0 < occupancy <= 1:
        raise ValueError(f"occupancy must be in (0, 1], got {occupancy}")
    ignore_by_frame = ignore_by_frame or {}
    W, H = int(window_wh[0]), int(window_wh[1])
    all_boxes = [np.asarray(b, float).reshape(-1, 4) for b in boxes_by_frame.values()]
    all_boxes = [b for b in all_boxes if len(b)]
    if not all_boxes:
        raise ValueError("train_svm_model: no ground-truth boxes to learn from")
    stacked = np.concatenate(all_boxes)
    aspect = float(np.median(stacked[:, 2] / stacked[:, 3]))
    bh = occupancy * H
    bw = aspect * bh
    box_in_window = ((W - bw) / 2.0, (H - bh) / 2.0, bw, bh)
    heights = stacked[:, 3]
    n_frames_with_boxes = sum(1 for b in all_boxes)
    per_frame_neg = max(1, int(np.ceil(n_negatives / max(n_frames_with_boxes, 1))))

    pos_crops, neg_crops, kept = [], [], []
    n_seen = 0
    it = frames
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(frames, desc="detector: sampling", unit="frame")
    for frame in it:
        boxes = np.asarray(boxes_by_frame.get(frame.index, np.zeros((0, 4))), float).reshape(-1, 4)
        if len(boxes) == 0:
            continue
        grey = _grey(frame.image)
        ign = np.asarray(ignore_by_frame.get(frame.index, np.zeros((0, 4))), float).reshape(-1, 4)
        pos_crops.append(crop_windows(grey, _window_rect(boxes, box_in_window, (W, H)), (W, H)))
        negs = _random_negatives(grey, np.concatenate([boxes, ign]), per_frame_neg, heights,
                                 aspect, neg_iou, rng)
        neg_crops.append(crop_windows(grey, _window_rect(negs, box_in_window, (W, H)), (W, H)))
        if n_seen % 4 == 0:
            kept.append((grey, np.concatenate([boxes, ign])))
        n_seen += 1
    if not pos_crops:
        raise ValueError("train_svm_model: none of the frames has ground-truth boxes")
    pos = np.concatenate(pos_crops)
    pos = np.concatenate([pos, pos[:, :, ::-1]])  # mirror images
    neg = np.concatenate(neg_crops)
    Xp, Xn = window_features(pos, feature), window_features(neg, feature)

    def train(xp: np.ndarray, xn: np.ndarray) -> tuple[np.ndarray, float, float]:
        X = np.concatenate([xp, xn])
        y = np.r_[np.ones(len(xp)), -np.ones(len(xn))]
        clf = LinearSVC(C=C, loss="hinge", dual=True, max_iter=20000, random_state=0)
        clf.fit(X, y)
        w = clf.coef_.ravel().astype(np.float64)
        b = float(clf.intercept_[0])
        norm = float(np.linalg.norm(w))
        if not (np.isfinite(norm) and norm > 0):
            raise ValueError("train_svm_model: the training windows carry no signal (blank "
                             "frames? positives and negatives have the same features): nothing "
                             "to learn")
        acc = float(np.mean(np.sign(X @ w + b) == y))
        return (w / norm).astype(np.float32), b / norm, acc

    w, b, acc = train(Xp, Xn)
    info: dict[str, Any] = {"n_positive": len(Xp), "n_random_negative": len(Xn),
                            "n_frames": int(n_seen), "C": C, "aspect": aspect,
                            "occupancy": occupancy, "train_accuracy": acc}
    model = SVMModel(w, b, feature, (W, H), box_in_window, info)
    hard_total = 0
    # hard negatives are mined where the detector will look at run time: the camera's scale
    # band at each row when the detector has one, else the band the training boxes themselves
    # give (heights_from_boxes), so training without --camera mines the same kind of windows
    # instead of every scale at every row
    expected = None
    rounds = int(hard_negative_rounds)
    if rounds > 0 and kept and (detector is None or detector._camera() is None):
        ih, iw = kept[0][0].shape[:2]
        expected = heights_from_boxes(stacked, (iw, ih))
        if not np.any(np.isfinite(expected[1])):
            expected = None  # degenerate boxes: fall back to the plain pyramid
    if rounds > 0:
        info["mining_scales"] = ("camera" if detector is not None and detector._camera()
                                 is not None else "training boxes" if expected is not None
                                 else "pyramid")
    for _ in range(rounds):
        from pftrack_world.detector import SVMDetector

        det = (detector.clone() if detector is not None else SVMDetector())
        det.set_model(model)
        if expected is not None:
            det.expected_heights_ = expected
        hard = []
        for grey, avoid in kept:
            boxes, scores = det.score_windows(grey, threshold=-0.1)
            if len(boxes) == 0:
                continue
            keep = nms(boxes, scores, 0.5)
            boxes = boxes[keep]
            if len(avoid):
                boxes = boxes[iou_matrix(boxes, avoid).max(axis=1) < neg_iou]
            if len(boxes):
                hard.append(crop_windows(grey, _window_rect(boxes, box_in_window, (W, H)),
                                         (W, H)))
        if not hard:
            break
        hard_crops = np.concatenate(hard)
        if len(hard_crops) > max_hard:
            hard_crops = hard_crops[rng.choice(len(hard_crops), max_hard, replace=False)]
        hard_total += len(hard_crops)
        Xn = np.concatenate([Xn, window_features(hard_crops, feature)])
        w, b, acc = train(Xp, Xn)
        model = SVMModel(w, b, feature, (W, H), box_in_window, info)
    info["n_hard_negative"] = int(hard_total)
    info["train_accuracy"] = acc
    # accuracy is dominated by the many negatives: a model that rejects everything scores
    # 99 %; what matters is whether it finds its own positives at the detection threshold
    thr = float(detector.threshold) if detector is not None else 0.0
    recall = float(np.mean(Xp @ model.weights.astype(np.float64) + model.bias >= thr))
    info["train_recall_positives"] = recall
    if recall < MIN_TRAIN_RECALL:
        import warnings

        warnings.warn(
            f"svm detector: the trained model finds only {100 * recall:.1f} % of its own "
            f"{len(Xp)} training positives at threshold {thr:g} (training accuracy "
            f"{100 * acc:.2f} % is dominated by the {len(Xn)} negatives): it cannot separate "
            "people from background here. Train on more frames/boxes (--frames), raise C, "
            "or use the training-free hog-people detector", TrainingRecallWarning,
            stacklevel=2)
    return model
