"""One sequence prepared for evaluation: ids relabelled, ignored boxes removed, pairs scored.

:func:`prepare_sequence` turns ground-truth and tracker MOT rows into a :class:`SequenceData`,
the same information TrackEval's datasets hand to its metric classes (per-frame id arrays and
similarity matrices), plus a flat list of every same-frame (gt, tracker) pair so that the metrics
can do their whole-sequence sums without a Python loop.

Ignored ground truth ("zero-marked" rows, consider flag ``conf == 0``), three documented policies:

``"drop_matched"`` (default)
    In each frame the gt and tracker boxes are matched one to one (Hungarian, maximising similarity,
    pairs below the match threshold not allowed) over *all* gt boxes of the frame; tracker boxes
    matched to a zero-marked gt box are removed, then the zero-marked gt boxes are removed. A
    tracker is neither rewarded nor punished for following a person the benchmark does not count.
    This is TrackEval's MOT16/17/20 treatment of distractor classes, applied to the zero flag
    (MOT15 files, PETS09-S2L1 among them, have no class column).
``"drop"``
    Zero-marked gt boxes are removed, tracker boxes on them stay and count as false positives:
    TrackEval's exact MOT15 behaviour.
``"keep"``
    The flag is ignored and every gt box counts: py-motmetrics' default (``min_confidence=-1``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from pftrack.io.mot import CONF, FRAME, HEIGHT, ID, LEFT, X, Y, has_world, validate_mot_rows
from pftrack.metrics.similarity import box_iou, world_similarity

_EPS = np.finfo(float).eps
ZERO_MARKED_POLICIES = ("drop_matched", "drop", "keep")
METRICS = ("iou", "world")


@dataclass
class SequenceData:
    """A sequence ready for the metric functions (TrackEval's ``data`` dict, typed).

    Attributes
    ----------
    frames : ndarray, shape (F,), int64
        Frame numbers present in the gt or the tracks, ascending.
    gt_ids, tracker_ids : list of F int64 arrays
        Per frame, the ids present, relabelled to ``0..num_gt_ids-1`` / ``0..num_tracker_ids-1``
        (ascending order of the original ids), in file order within the frame.
    similarity : list of F arrays, shape (g_t, h_t)
        Per frame, similarity in [0, 1] of every gt box (rows) to every tracker box (columns).
    pair_gt, pair_tracker : ndarray, shape (P,), int64
        Every same-frame pair, as indices into the concatenation of ``gt_ids`` /
        ``tracker_ids`` over frames (the "detection" index).
    pair_sim : ndarray, shape (P,)
        Their similarity; ``similarity[f]`` is ``pair_sim[pair_start[f]:pair_start[f+1]]``
        reshaped to (g_t, h_t).
    gt_det_ids, tracker_det_ids : ndarray, int64
        The relabelled id of every gt / tracker detection (concatenated over frames).
    gt_id_map, tracker_id_map : ndarray, int64
        Original id of each relabelled id.
    metric : str
        ``"iou"`` or ``"world"``.
    zero_distance_m : float or None
        For ``"world"``, the distance (m) where the similarity reaches 0.
    num_ignored_gt, num_ignored_tracker : int
        Rows removed by the zero-marked policy.
    """

    frames: np.ndarray
    gt_ids: list[np.ndarray]
    tracker_ids: list[np.ndarray]
    similarity: list[np.ndarray]
    pair_gt: np.ndarray
    pair_tracker: np.ndarray
    pair_sim: np.ndarray
    gt_det_ids: np.ndarray
    tracker_det_ids: np.ndarray
    gt_id_map: np.ndarray
    tracker_id_map: np.ndarray
    metric: str = "iou"
    zero_distance_m: float | None = None
    num_ignored_gt: int = 0
    num_ignored_tracker: int = 0

    @property
    def num_frames(self) -> int:
        return len(self.frames)

    @property
    def num_gt_ids(self) -> int:
        return len(self.gt_id_map)

    @property
    def num_tracker_ids(self) -> int:
        return len(self.tracker_id_map)

    @property
    def num_gt_dets(self) -> int:
        return len(self.gt_det_ids)

    @property
    def num_tracker_dets(self) -> int:
        return len(self.tracker_det_ids)

    def to_trackeval(self) -> dict:
        """The same data as TrackEval's metric classes expect it (``eval_sequence(data)``)."""
        return {
            "gt_ids": self.gt_ids, "tracker_ids": self.tracker_ids,
            "similarity_scores": self.similarity,
            "num_timesteps": self.num_frames, "num_gt_ids": self.num_gt_ids,
            "num_tracker_ids": self.num_tracker_ids, "num_gt_dets": self.num_gt_dets,
            "num_tracker_dets": self.num_tracker_dets, "seq": "pftrack",
        }


def _features(rows: np.ndarray, metric: str) -> np.ndarray:
    if metric == "iou":
        return rows[:, LEFT:HEIGHT + 1]
    return rows[:, [X, Y]]


def _score_pairs(g_feat, t_feat, pg, pt, metric, zero_distance_m):
    if metric == "iou":
        return box_iou(g_feat[pg], t_feat[pt])
    return world_similarity(g_feat[pg], t_feat[pt], zero_distance_m)


def _frame_pairs(g_frames: np.ndarray, t_frames: np.ndarray):
    """All same-frame (gt row, tracker row) pairs of frame-sorted rows, gt-major per frame.

    Returns ``pair_gt, pair_tracker`` (row indices) and, per gt row, the number of tracker rows
    in its frame.
    """
    t_start = np.searchsorted(t_frames, g_frames, side="left")
    t_count = np.searchsorted(t_frames, g_frames, side="right") - t_start
    total = int(t_count.sum())
    pair_gt = np.repeat(np.arange(len(g_frames)), t_count)
    offsets = np.cumsum(t_count) - t_count  # first pair of each gt row
    within = np.arange(total) - np.repeat(offsets, t_count)
    pair_tracker = np.repeat(t_start, t_count) + within
    return pair_gt, pair_tracker


def _sort_by_frame(rows: np.ndarray) -> np.ndarray:
    return rows[np.argsort(rows[:, FRAME], kind="stable")]


def _matched_to_ignored(gt, tr, g_feat, t_feat, metric, zero_distance_m, sim_threshold):
    """Boolean mask over tracker rows matched (Hungarian, sim >= threshold) to a zero-marked gt."""
    remove = np.zeros(len(tr), bool)
    ignored = gt[:, CONF] == 0
    for f in np.unique(gt[ignored, FRAME]):
        gi = np.flatnonzero(gt[:, FRAME] == f)
        ti = np.flatnonzero(tr[:, FRAME] == f)
        if len(ti) == 0:
            continue
        sim = _score_pairs(g_feat, t_feat, gi[:, None], ti[None, :], metric, zero_distance_m)
        sim = np.where(sim < sim_threshold - _EPS, 0.0, sim)
        r, c = linear_sum_assignment(-sim)
        ok = sim[r, c] > _EPS
        r, c = r[ok], c[ok]
        remove[ti[c[ignored[gi[r]]]]] = True
    return remove


def prepare_sequence(gt_rows: np.ndarray, track_rows: np.ndarray, *, metric: str = "iou",
                     zero_distance_m: float | None = None, sim_threshold: float = 0.5,
                     zero_marked: str = "drop_matched") -> SequenceData:
    """Prepare one sequence for :mod:`pftrack.metrics`.

    Parameters
    ----------
    gt_rows, track_rows : array_like, shape (M, 6..10)
        MOT rows (see :mod:`pftrack.io.mot`); the gt's ``conf`` column is its consider flag.
    metric : {"iou", "world"}
        Score image boxes by IoU, or ground-plane positions (``x, y`` columns, metres) by
        ``max(0, 1 - d / zero_distance_m)``.
    zero_distance_m : float, optional
        Required for ``metric="world"``.
    sim_threshold : float
        Similarity a pair needs to be matched when finding tracker boxes on ignored gt.
    zero_marked : {"drop_matched", "drop", "keep"}
        Policy for gt rows with ``conf == 0`` (see the module docstring).

    Raises
    ------
    ValueError
        Unknown metric/policy, malformed rows, a repeated id in a frame, or world coordinates
        missing for ``metric="world"``.
    """
    if metric not in METRICS:
        raise ValueError(f"metric must be one of {METRICS}, got {metric!r}")
    if zero_marked not in ZERO_MARKED_POLICIES:
        raise ValueError(f"zero_marked must be one of {ZERO_MARKED_POLICIES}, got {zero_marked!r}")
    gt = _sort_by_frame(validate_mot_rows(gt_rows, "gt rows"))
    tr = _sort_by_frame(validate_mot_rows(track_rows, "track rows"))
    if metric == "world":
        if zero_distance_m is None or not zero_distance_m > 0:
            raise ValueError(f"metric='world' needs zero_distance_m > 0, got {zero_distance_m!r}")
        for name, rows in (("gt", gt), ("track", tr)):
            missing = int(np.sum(~has_world(rows)))
            if missing:
                raise ValueError(
                    f"metric='world': {missing} of {len(rows)} {name} rows have no world "
                    "position (x, y, z all -1); use metric='iou' or write world coordinates")

    n_ign_gt = n_ign_tr = 0
    if zero_marked != "keep":
        ignored = gt[:, CONF] == 0
        if zero_marked == "drop_matched" and ignored.any() and len(tr):
            remove = _matched_to_ignored(gt, tr, _features(gt, metric), _features(tr, metric),
                                         metric, zero_distance_m, sim_threshold)
            n_ign_tr = int(remove.sum())
            tr = tr[~remove]
        n_ign_gt = int(ignored.sum())
        gt = gt[~ignored]

    g_feat, t_feat = _features(gt, metric), _features(tr, metric)
    g_frames = gt[:, FRAME].astype(np.int64)
    t_frames = tr[:, FRAME].astype(np.int64)
    pair_gt, pair_tracker = _frame_pairs(g_frames, t_frames)
    pair_sim = _score_pairs(g_feat, t_feat, pair_gt, pair_tracker, metric, zero_distance_m)

    gt_id_map, gt_det_ids = np.unique(gt[:, ID].astype(np.int64), return_inverse=True)
    tr_id_map, tr_det_ids = np.unique(tr[:, ID].astype(np.int64), return_inverse=True)
    gt_det_ids = gt_det_ids.reshape(-1)
    tr_det_ids = tr_det_ids.reshape(-1)

    frames = np.union1d(g_frames, t_frames)
    g_bounds = np.searchsorted(g_frames, np.append(frames, np.iinfo(np.int64).max))
    t_bounds = np.searchsorted(t_frames, np.append(frames, np.iinfo(np.int64).max))
    # pairs are gt-major, so a frame's pairs start where its first gt row's pairs start
    pairs_before_gt = np.concatenate([[0], np.cumsum(np.bincount(pair_gt, minlength=len(gt)))])
    gt_ids, tracker_ids, similarity = [], [], []
    for k in range(len(frames)):
        g0, g1 = g_bounds[k], g_bounds[k + 1]
        t0, t1 = t_bounds[k], t_bounds[k + 1]
        gt_ids.append(gt_det_ids[g0:g1])
        tracker_ids.append(tr_det_ids[t0:t1])
        p0, p1 = pairs_before_gt[g0], pairs_before_gt[g1]
        similarity.append(pair_sim[p0:p1].reshape(g1 - g0, t1 - t0))

    return SequenceData(
        frames=frames, gt_ids=gt_ids, tracker_ids=tracker_ids, similarity=similarity,
        pair_gt=pair_gt, pair_tracker=pair_tracker, pair_sim=pair_sim,
        gt_det_ids=gt_det_ids, tracker_det_ids=tr_det_ids,
        gt_id_map=gt_id_map, tracker_id_map=tr_id_map, metric=metric,
        zero_distance_m=zero_distance_m if metric == "world" else None,
        num_ignored_gt=n_ign_gt, num_ignored_tracker=n_ign_tr,
    )
