"""The accuracy measures the four source papers report, as plain vectorised functions.

* The colour paper (cross-entropy likelihood): cumulative pixel error per target, the sum over
  frames of the Euclidean distance between the estimated and the ground-truth centre
  (:func:`cumulative_pixel_error`).
* The soccer paper (3D soccer particle filter, sec. 4.1): per person, the fraction of the frames in
  which the person is visible where the estimate (projected into the image) lies within 5 px of the
  ground-truth point; the score is the mean over people (:func:`accuracy_within`).
* The coastal paper (coastal surveillance, table 1): per-axis absolute and relative error of an
  estimated object size against the true size (:func:`size_error`).
* The camera-network paper (camera dropout / trajectory ensemble, eq. 10): Adjusted Rand Index of
  tracklet labels against the true person labels, with unassigned ("NA") tracklets handled as
  documented (:func:`adjusted_rand_index`).

The array functions take per-frame, per-target points of shape (F, K, 2) in pixels with NaN where
a target has no value in a frame; :func:`points_by_target` builds such arrays from MOT rows (ids
matched directly or through the IDF1-optimal id map, :func:`match_ids`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pftrack.io.mot import FRAME, HEIGHT, ID, LEFT, TOP, WIDTH, validate_mot_rows

__all__ = [
    "accuracy_within",
    "adjusted_rand_index",
    "cumulative_pixel_error",
    "match_ids",
    "points_by_target",
    "size_error",
]


def _pair_points(est: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    est = np.asarray(est, dtype=np.float64)
    truth = np.asarray(truth, dtype=np.float64)
    if est.shape != truth.shape or est.shape[-1] != 2 or est.ndim not in (2, 3):
        raise ValueError("estimated and truth points must both have shape (F, 2) or (F, K, 2), "
                         f"got {est.shape} and {truth.shape}")
    return est, truth


def cumulative_pixel_error(estimated_px: np.ndarray, truth_px: np.ndarray) -> np.ndarray | float:
    """The colour paper's accuracy: per target, the sum over frames of the centre distance in
    pixels.

    Parameters
    ----------
    estimated_px, truth_px : array_like, shape (F, 2) or (F, K, 2)
        Estimated and ground-truth centres (u, v) in pixels for F frames (and K targets). Frames
        where either is NaN (target absent or not annotated) are left out of the sum.

    Returns
    -------
    float or ndarray, shape (K,)
        Cumulative error in pixels (lower is better).
    """
    est, truth = _pair_points(estimated_px, truth_px)
    d = np.linalg.norm(est - truth, axis=-1)
    total = np.nansum(d, axis=0)
    return float(total) if est.ndim == 2 else total


def accuracy_within(estimated_px: np.ndarray, truth_px: np.ndarray, radius_px: float = 5.0
                    ) -> tuple[float, np.ndarray]:
    """The soccer paper's accuracy (sec. 4.1): fraction of visible frames tracked within
    ``radius_px``.

    Parameters
    ----------
    estimated_px, truth_px : array_like, shape (F, K, 2) (or (F, 2) for one person)
        Estimated points (the world estimate projected into the image) and ground-truth points,
        pixels. A NaN ground truth means the person is not visible in that frame and the frame is
        not counted; a NaN estimate in a visible frame counts as a miss.
    radius_px : float
        Hit radius in pixels (5 in the paper); a hit is ``distance <= radius_px``.

    Returns
    -------
    mean : float
        Mean over the people who are visible at least once of their hit fraction (NaN when
        nobody is visible).
    per_person : ndarray, shape (K,)
        Hit fraction per person (NaN for a person never visible).
    """
    est, truth = _pair_points(estimated_px, truth_px)
    if est.ndim == 2:
        est, truth = est[:, None], truth[:, None]
    if not radius_px > 0:
        raise ValueError(f"radius_px must be > 0, got {radius_px!r}")
    visible = ~np.isnan(truth).any(axis=-1)
    d = np.linalg.norm(est - truth, axis=-1)
    hit = visible & (d <= radius_px)  # NaN distance compares False: a miss
    n_visible = visible.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        per = np.where(n_visible > 0, hit.sum(axis=0) / n_visible, np.nan)
    mean = float(np.nanmean(per)) if np.any(n_visible > 0) else float("nan")
    return mean, per


def size_error(estimated_size: np.ndarray, true_size: np.ndarray) -> dict[str, np.ndarray]:
    """The coastal paper's size comparison: per-axis absolute and relative error.

    Parameters
    ----------
    estimated_size, true_size : array_like, shape (..., D)
        Object extents per axis (e.g. width, height, depth in metres: the coastal paper estimates
        ``l = 2 sqrt(weighted variance)`` per axis of the particle cloud).

    Returns
    -------
    dict
        ``abs``: ``|est - true|`` (same unit), ``rel``: ``|est - true| / true`` (NaN where the
        true size is 0), ``ratio``: ``est / true``, each of shape (..., D).
    """
    est = np.asarray(estimated_size, dtype=np.float64)
    true = np.asarray(true_size, dtype=np.float64)
    try:
        est, true = np.broadcast_arrays(est, true)
    except ValueError:
        raise ValueError(f"estimated_size {est.shape} and true_size {true.shape} do not "
                         "broadcast") from None
    if np.any(true < 0) or np.any(est < 0):
        raise ValueError("sizes must be non-negative")
    err = np.abs(est - true)
    with np.errstate(invalid="ignore", divide="ignore"):
        safe = np.where(true > 0, true, np.nan)
        return {"abs": err, "rel": err / safe, "ratio": est / safe}


def _is_na(x: Any) -> bool:
    if x is None:
        return True
    if isinstance(x, str):
        return x.strip().upper() in ("NA", "NAN", "")
    try:
        return bool(np.isnan(x))
    except (TypeError, ValueError):
        return False


def adjusted_rand_index(true_labels: Sequence[Any], predicted_labels: Sequence[Any], *,
                        na: str = "singleton") -> float:
    """The camera-network paper's score: Adjusted Rand Index of predicted tracklet labels (eq. 10).

    Parameters
    ----------
    true_labels, predicted_labels : sequence, length n
        Per tracklet, the true person and the predicted trajectory label (any hashable values).
        A predicted label that is None, NaN or the string ``"NA"`` means the tracklet was not
        assigned (in the camera-network paper, a tracklet of a dropped camera).
    na : {"singleton", "drop"}
        ``"singleton"`` (default): every unassigned tracklet is a cluster of its own, so leaving
        tracklets unassigned is penalised like splitting them off. ``"drop"``: unassigned
        tracklets are removed from both labelings before scoring (ARI of the assigned ones only).
        True labels must not be NA.

    Returns
    -------
    float
        ARI in [-1, 1]; 1 for identical partitions, about 0 for random ones
        (``sklearn.metrics.adjusted_rand_score``).
    """
    from sklearn.metrics import adjusted_rand_score

    if na not in ("singleton", "drop"):
        raise ValueError(f"na must be 'singleton' or 'drop', got {na!r}")
    true = list(true_labels)
    pred = list(predicted_labels)
    if len(true) != len(pred):
        raise ValueError(f"true_labels ({len(true)}) and predicted_labels ({len(pred)}) differ "
                         "in length")
    if any(_is_na(t) for t in true):
        raise ValueError("true_labels contain NA: every tracklet needs its true person")
    is_na = [_is_na(p) for p in pred]
    if na == "drop":
        keep = [i for i, m in enumerate(is_na) if not m]
        true = [true[i] for i in keep]
        pred_codes = [repr(pred[i]) for i in keep]
    else:
        pred_codes = [f"\0NA{i}" if m else repr(p) for i, (p, m) in enumerate(zip(pred, is_na))]
    true_codes = [repr(t) for t in true]
    if not true_codes:
        return float("nan")
    return float(adjusted_rand_score(true_codes, pred_codes))


# --------------------------------------------------------------------------------------------
# From MOT rows to per-target point arrays

def _points(rows: np.ndarray, point: str) -> np.ndarray:
    u = rows[:, LEFT] + rows[:, WIDTH] / 2
    if point == "centre":
        v = rows[:, TOP] + rows[:, HEIGHT] / 2
    elif point == "foot":
        v = rows[:, TOP] + rows[:, HEIGHT]
    else:
        raise ValueError(f"point must be 'centre' or 'foot', got {point!r}")
    return np.column_stack([u, v])


def match_ids(gt_rows: np.ndarray, track_rows: np.ndarray, *, metric: str = "iou",
              threshold: float | None = None) -> dict[int, int]:
    """The IDF1-optimal one-to-one map from gt ids to track ids (see
    :func:`pftrack.metrics.identity.identity_matching`); zero-marked gt rows count as ordinary."""
    from pftrack.metrics.identity import identity_matching
    from pftrack.metrics.mot import DEFAULT_THRESHOLD
    from pftrack.metrics.sequence import prepare_sequence

    thr = DEFAULT_THRESHOLD[metric] if threshold is None else float(threshold)
    seq = prepare_sequence(gt_rows, track_rows, metric=metric,
                           zero_distance_m=2 * thr if metric == "world" else None,
                           zero_marked="keep")
    return identity_matching(seq, threshold=thr if metric == "iou" else 0.5)


def points_by_target(gt_rows: np.ndarray, track_rows: np.ndarray, *,
                     id_map: Mapping[int, int] | str | None = None, point: str = "centre"
                     ) -> dict[str, np.ndarray]:
    """Align estimated and ground-truth image points per frame and gt target.

    Parameters
    ----------
    gt_rows, track_rows : array_like, shape (M, 6..10)
        MOT rows (pixels).
    id_map : mapping gt id -> track id, "match", or None
        None: a gt id is tracked by the track of the same id (one filter per person, as in seeds
        000 and 001). ``"match"``: the IDF1-optimal map (:func:`match_ids`). Gt ids absent from a
        mapping get NaN estimates.
    point : {"centre", "foot"}
        Box centre (the colour paper) or bottom centre, the ground contact point (the soccer paper
        compares the projected ground position).

    Returns
    -------
    dict
        ``frames`` (F,) int, ``gt_ids`` (K,) int, ``truth_px`` and ``estimated_px`` (F, K, 2)
        with NaN where the gt target or its track has no box in a frame.
    """
    gt = validate_mot_rows(gt_rows, "gt rows")
    tr = validate_mot_rows(track_rows, "track rows")
    if isinstance(id_map, str):
        if id_map != "match":
            raise ValueError(f"id_map must be a mapping, 'match' or None, got {id_map!r}")
        id_map = match_ids(gt, tr)
    frames = np.unique(gt[:, FRAME]).astype(np.int64)
    gt_ids = np.unique(gt[:, ID]).astype(np.int64)
    F, K = len(frames), len(gt_ids)
    truth = np.full((F, K, 2), np.nan)
    est = np.full((F, K, 2), np.nan)
    fi = np.searchsorted(frames, gt[:, FRAME])
    ki = np.searchsorted(gt_ids, gt[:, ID])
    truth[fi, ki] = _points(gt, point)

    # the gt id each track row estimates (a sentinel when its track estimates nobody)
    none = np.iinfo(np.int64).min
    track_ids = tr[:, ID].astype(np.int64)
    if id_map is None:
        target_gt = track_ids
    else:
        src = np.array([int(t) for t in id_map.values()], dtype=np.int64)
        dst = np.array([int(g) for g in id_map], dtype=np.int64)
        order = np.argsort(src)
        src, dst = src[order], dst[order]
        pos = np.minimum(np.searchsorted(src, track_ids), max(len(src) - 1, 0))
        found = (src[pos] == track_ids) if len(src) else np.zeros(len(tr), bool)
        target_gt = np.where(found, dst[pos] if len(src) else none, none)
    col = np.minimum(np.searchsorted(gt_ids, target_gt), max(K - 1, 0))
    row = np.minimum(np.searchsorted(frames, tr[:, FRAME]), max(F - 1, 0))
    valid = np.zeros(len(tr), bool)
    if K and F:
        valid = (gt_ids[col] == target_gt) & (frames[row] == tr[:, FRAME])
    est[row[valid], col[valid]] = _points(tr[valid], point)
    return {"frames": frames, "gt_ids": gt_ids, "truth_px": truth, "estimated_px": est}
