"""Similarity between ground-truth and tracker boxes or world points, the way TrackEval scores them.

Both functions work *elementwise* on paired inputs (row ``i`` of ``a`` against row ``i`` of ``b``)
so that all candidate pairs of a whole sequence are scored in one vectorised call; broadcast the
inputs (``a[:, None]``, ``b[None, :]``) for a full matrix. The arithmetic follows TrackEval's
``_calculate_box_ious`` and ``_calculate_euclidean_similarity`` operation for operation, so that
thresholds that land exactly on a value (integer boxes at IoU 0.5) decide the same way.
"""

from __future__ import annotations

import numpy as np

_EPS = np.finfo(float).eps


def box_iou(a_xywh_px: np.ndarray, b_xywh_px: np.ndarray) -> np.ndarray:
    """Intersection over union of image boxes.

    Parameters
    ----------
    a_xywh_px, b_xywh_px : array_like, shape (..., 4)
        Boxes (left, top, width, height) in pixels; broadcast against each other.

    Returns
    -------
    ndarray, shape (...)
        IoU in [0, 1]; 0 where either box has zero area.
    """
    a = np.asarray(a_xywh_px, dtype=np.float64)
    b = np.asarray(b_xywh_px, dtype=np.float64)
    ax0, ay0 = a[..., 0], a[..., 1]
    ax1, ay1 = ax0 + a[..., 2], ay0 + a[..., 3]
    bx0, by0 = b[..., 0], b[..., 1]
    bx1, by1 = bx0 + b[..., 2], by0 + b[..., 3]
    inter = (np.maximum(np.minimum(ax1, bx1) - np.maximum(ax0, bx0), 0)
             * np.maximum(np.minimum(ay1, by1) - np.maximum(ay0, by0), 0))
    area_a = (ax1 - ax0) * (ay1 - ay0)
    area_b = (bx1 - bx0) * (by1 - by0)
    union = area_a + area_b - inter
    inter = np.where((area_a <= _EPS) | (area_b <= _EPS) | (union <= _EPS), 0.0, inter)
    union = np.where(union <= _EPS, 1.0, union)
    return inter / union


def world_similarity(a_xy_m: np.ndarray, b_xy_m: np.ndarray, zero_distance_m: float) -> np.ndarray:
    """Distance-based similarity of world points: ``max(0, 1 - d / zero_distance_m)``.

    TrackEval's convention for position-only data: with ``zero_distance_m = 2`` a similarity
    threshold of 0.5 is a hit within 1 m.

    Parameters
    ----------
    a_xy_m, b_xy_m : array_like, shape (..., D)
        Points in metres (D = 2 for the ground plane); broadcast against each other.
    zero_distance_m : float
        Distance in metres at which the similarity reaches 0.

    Returns
    -------
    ndarray, shape (...)
        Similarity in [0, 1].
    """
    if not zero_distance_m > 0:
        raise ValueError(f"zero_distance_m must be > 0, got {zero_distance_m!r}")
    d = np.linalg.norm(np.asarray(a_xy_m, float) - np.asarray(b_xy_m, float), axis=-1)
    return np.maximum(0, 1 - d / zero_distance_m)
