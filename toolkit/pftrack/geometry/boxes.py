"""Image boxes, the one home of their primitives: intersection over union, non-maximum
suppression, sub-boxes, foot points and clipping.

Boxes are ``(left, top, width, height)`` in pixels (``xywh``) unless a name says otherwise;
every function is vectorised over the leading axes.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["box_iou", "clip_boxes", "covered_fraction", "foot_points", "iou_matrix", "nms",
           "sub_boxes"]

_EPS = np.finfo(float).eps


def _intersection(a_xywh_px: np.ndarray, b_xywh_px: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The intersection area of boxes ``a`` and ``b`` (broadcast) and each one's area, all
    from the corners (TrackEval's order of operations), px^2."""
    a = np.asarray(a_xywh_px, dtype=np.float64)
    b = np.asarray(b_xywh_px, dtype=np.float64)
    ax0, ay0 = a[..., 0], a[..., 1]
    ax1, ay1 = ax0 + a[..., 2], ay0 + a[..., 3]
    bx0, by0 = b[..., 0], b[..., 1]
    bx1, by1 = bx0 + b[..., 2], by0 + b[..., 3]
    inter = (np.maximum(np.minimum(ax1, bx1) - np.maximum(ax0, bx0), 0)
             * np.maximum(np.minimum(ay1, by1) - np.maximum(ay0, by0), 0))
    return inter, (ax1 - ax0) * (ay1 - ay0), (bx1 - bx0) * (by1 - by0)


def box_iou(a_xywh_px: np.ndarray, b_xywh_px: np.ndarray) -> np.ndarray:
    """Intersection over union of image boxes, broadcast against each other.

    The arithmetic is TrackEval's (``_calculate_box_ious``) operation for operation: corners
    first, areas from the corners, an area or union under machine epsilon gives 0; so that
    thresholds landing exactly on a value (integer boxes at IoU 0.5) decide as TrackEval does.

    Parameters
    ----------
    a_xywh_px, b_xywh_px : array_like, shape (..., 4)
        Boxes (left, top, width, height) in pixels.

    Returns
    -------
    ndarray, shape (...), float64
        IoU in [0, 1]; 0 where either box has no area (a negative width or height included)
        and where a box is not a number.
    """
    inter, area_a, area_b = _intersection(a_xywh_px, b_xywh_px)
    union = area_a + area_b - inter
    ok = (area_a > _EPS) & (area_b > _EPS) & (union > _EPS)  # False for NaN too
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ok, inter / np.where(ok, union, 1.0), 0.0)


def covered_fraction(a_xywh_px: np.ndarray, b_xywh_px: np.ndarray) -> np.ndarray:
    """The fraction of each box ``a``'s area that box ``b`` covers (their intersection over
    ``a``'s area), broadcast against each other: how much of a person is behind another, how
    much of a candidate lies inside a tracked box.

    Parameters
    ----------
    a_xywh_px, b_xywh_px : array_like, shape (..., 4)
        Boxes (left, top, width, height) in pixels.

    Returns
    -------
    ndarray, shape (...), float64
        In [0, 1]; 0 where ``a`` has no area (areas from the corners, as :func:`box_iou`).
    """
    inter, area, _ = _intersection(a_xywh_px, b_xywh_px)
    ok = area > _EPS  # False for NaN too
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ok, inter / np.where(ok, area, 1.0), 0.0)


def iou_matrix(a_xywh_px: np.ndarray, b_xywh_px: np.ndarray) -> np.ndarray:
    """:func:`box_iou` of every box of ``a`` (A, 4) with every box of ``b`` (B, 4) -> (A, B)."""
    a = np.asarray(a_xywh_px, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b_xywh_px, dtype=np.float64).reshape(-1, 4)
    return box_iou(a[:, None, :], b[None, :, :])


def nms(boxes_xywh_px: np.ndarray, scores: np.ndarray, iou_threshold: float) -> np.ndarray:
    """Greedy non-maximum suppression (OpenCV's ``NMSBoxes``).

    Parameters
    ----------
    boxes_xywh_px : ndarray, shape (N, 4)
    scores : ndarray, shape (N,)
        Any real scores. OpenCV keeps only boxes scoring strictly above its score threshold,
        so the scores are shifted to 1 and above for it (their order is kept): every box takes
        part, the lowest-scoring one and a lone box too.
    iou_threshold : float
        A box whose IoU with a better kept one exceeds this is dropped.

    Returns
    -------
    ndarray, shape (K,), intp
        Indices of the kept boxes, best score first.
    """
    boxes = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    scores = np.asarray(scores, dtype=np.float64).reshape(-1)
    if len(boxes) == 0:
        return np.zeros(0, dtype=np.intp)
    import cv2

    shifted = scores - scores.min() + 1.0
    kept = cv2.dnn.NMSBoxes(boxes.tolist(), shifted.tolist(), 0.0, float(iou_threshold))
    idx = np.asarray(kept, dtype=np.intp).reshape(-1)
    return idx[np.argsort(-scores[idx], kind="stable")]


def sub_boxes(boxes_xywh_px: np.ndarray, region: Sequence[float] | None) -> np.ndarray:
    """The part ``region`` of each box.

    Parameters
    ----------
    boxes_xywh_px : ndarray, shape (N, 4)
    region : (fx0, fy0, fx1, fy1) or None
        Fractions of the box's width and height (e.g. ``(0.15, 0.15, 0.85, 0.55)``: a person's
        torso); None: the whole box.

    Returns
    -------
    ndarray, shape (N, 4), float64, xywh px (a new array).
    """
    b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    if region is None:
        return b.copy()
    fx0, fy0, fx1, fy1 = (float(v) for v in region)
    out = np.empty_like(b)
    out[:, 0] = b[:, 0] + fx0 * b[:, 2]
    out[:, 1] = b[:, 1] + fy0 * b[:, 3]
    out[:, 2] = (fx1 - fx0) * b[:, 2]
    out[:, 3] = (fy1 - fy0) * b[:, 3]
    return out


def foot_points(boxes_xywh_px: np.ndarray) -> np.ndarray:
    """Bottom-centre points ``(left + width / 2, top + height)`` of boxes (..., 4) -> (..., 2)."""
    b = np.asarray(boxes_xywh_px, dtype=np.float64)
    return np.stack([b[..., 0] + 0.5 * b[..., 2], b[..., 1] + b[..., 3]], axis=-1)


def clip_boxes(rects: np.ndarray, size_wh: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Clip integer rectangles (N, 4) ``(x0, y0, x1, y1)`` to an image of ``size_wh``.

    Returns
    -------
    clipped : ndarray, shape (N, 4), int64
        Clipped rectangles; a box wholly outside becomes an empty one (``x0 == x1`` or
        ``y0 == y1``) on the image border.
    n_pixels : ndarray, shape (N,), int64
        Pixels inside the image (0 for a box wholly outside).
    """
    r = np.asarray(rects, dtype=np.int64).reshape(-1, 4)
    w, h = size_wh
    # clipping both corners into the image keeps x0 <= x1 (clipping is monotone)
    c = np.minimum(np.maximum(r, 0), np.array([w, h, w, h], dtype=np.int64))
    wh = c[:, 2:] - c[:, :2]
    return c, wh[:, 0] * wh[:, 1]
