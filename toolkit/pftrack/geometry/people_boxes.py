"""Person boxes prepared for a camera fit (:mod:`pftrack.geometry.people`): boxes linked into
people across frames (:func:`link_boxes`, for a bootstrap over people) and boxes whose rows are
their silhouettes' (:func:`refine_boxes_by_silhouettes`)."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["SILHOUETTE_HEIGHT_RANGE", "link_boxes", "refine_boxes_by_silhouettes"]

#: Silhouette heights further than this factor from their box's height are not trusted
#: (:func:`refine_boxes_by_silhouettes`): a merged, cut or shadowed silhouette.
SILHOUETTE_HEIGHT_RANGE = (0.75, 1.3)


def link_boxes(boxes_xywh: Any, frames: Any, min_iou: float = 0.3, max_gap: int = 1
               ) -> np.ndarray:
    """Which person each box is: boxes in consecutive frames linked greedily by overlap.

    A minimal tracker for the camera fit (no camera yet): in every frame, pairs of a box of the
    previous frame and one of this frame are taken in decreasing IoU while the IoU is at least
    ``min_iou``, each box at most once; an unlinked box starts a new person, and a gap of more
    than ``max_gap`` frames without boxes ends everyone.

    Parameters
    ----------
    boxes_xywh : array_like, shape (N, >=4)
        Boxes in pixels.
    frames : array_like, shape (N,)
        Frame of each box.
    min_iou : float
        Least overlap of a link. Unit: 1.
    max_gap : int
        Frames from one frame with boxes to the next that still link (1: consecutive frames;
        2 for boxes of every other frame). Unit: frames.

    Returns
    -------
    ndarray of int, shape (N,)
        A person number per box, from 0.
    """
    from pftrack.geometry.boxes import iou_matrix

    b = np.asarray(boxes_xywh, dtype=np.float64).reshape(-1, np.shape(boxes_xywh)[-1])[:, :4]
    fr = np.asarray(frames, dtype=np.int64).reshape(-1)
    if len(fr) != len(b):
        raise ValueError(f"link_boxes: {len(b)} boxes but {len(fr)} frames")
    ids = np.full(len(b), -1, dtype=np.int64)
    order = np.argsort(fr, kind="stable")
    uniq, starts = np.unique(fr[order], return_index=True)
    bounds = np.r_[starts, len(order)]
    prev = np.zeros(0, dtype=np.int64)
    prev_frame = None
    n_people = 0
    for j, f in enumerate(uniq):
        cur = order[bounds[j]:bounds[j + 1]]
        if len(prev) and prev_frame is not None and f - prev_frame <= max_gap:
            iou = iou_matrix(b[prev], b[cur])
            flat = np.argsort(-iou, axis=None, kind="stable")
            flat = flat[iou.ravel()[flat] >= min_iou]
            free_p = np.ones(len(prev), dtype=bool)
            free_c = np.ones(len(cur), dtype=bool)
            for i, k in zip(*np.divmod(flat, len(cur)), strict=True):
                if free_p[i] and free_c[k]:
                    ids[cur[k]] = ids[prev[i]]
                    free_p[i] = free_c[k] = False
        new = cur[ids[cur] < 0]
        ids[new] = np.arange(n_people, n_people + len(new))
        n_people += len(new)
        prev, prev_frame = cur, f
    return ids


def refine_boxes_by_silhouettes(boxes_xywh: Any, silhouettes: Any,
                                height_range: tuple[float, float] = SILHOUETTE_HEIGHT_RANGE
                                ) -> tuple[np.ndarray, np.ndarray]:
    """Boxes whose top and bottom rows are their silhouettes'
    (:func:`~pftrack.workflows.calibrate.measure_silhouettes`).

    Parameters
    ----------
    boxes_xywh : array_like, shape (N, >=4)
        The detector's boxes, pixels.
    silhouettes : array_like, shape (N, 3)
        ``slant, top, bottom`` of each box.
    height_range : (float, float)
        A silhouette is used when its height is within these factors of the box's (else it is
        merged with another person, cut by an occluder, or a shadow). Unit: 1.

    Returns
    -------
    boxes : ndarray, shape (N, 4)
        ``x, y, w, h``: the columns are the box's, the rows the silhouette's where used.
    used : ndarray of bool, shape (N,)
        Which boxes were refined.
    """
    b = np.asarray(boxes_xywh, dtype=np.float64).reshape(-1, np.shape(boxes_xywh)[-1])[:, :4]
    s = np.asarray(silhouettes, dtype=np.float64).reshape(-1, 3)
    if len(s) != len(b):
        raise ValueError(f"refine_boxes_by_silhouettes: {len(b)} boxes but {len(s)} "
                         "silhouettes")
    with np.errstate(invalid="ignore"):
        ratio = (s[:, 2] - s[:, 1]) / b[:, 3]
        used = (ratio >= height_range[0]) & (ratio <= height_range[1])
    out = b.copy()
    out[used, 1] = s[used, 1]
    out[used, 3] = s[used, 2] - s[used, 1]
    return out, used
