"""Similarity between ground-truth and tracker boxes or world points, the way TrackEval scores them.

Both functions work *elementwise* on paired inputs (row ``i`` of ``a`` against row ``i`` of ``b``)
so that all candidate pairs of a whole sequence are scored in one vectorised call; broadcast the
inputs (``a[:, None]``, ``b[None, :]``) for a full matrix. The arithmetic follows TrackEval's
``_calculate_box_ious`` and ``_calculate_euclidean_similarity`` operation for operation, so that
thresholds that land exactly on a value (integer boxes at IoU 0.5) decide the same way.
"""

from __future__ import annotations

import numpy as np

from pftrack.geometry.boxes import box_iou

__all__ = ["box_iou", "world_similarity"]

_EPS = np.finfo(float).eps


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
