"""Generic detection-to-track association on box overlap or centre distance: optimal (Hungarian)
and greedy.

Both compare each live target's current box estimate (``Target.box_xywh_px``) with every
detection box, gate implausible pairs, and return an
:class:`~pftrack.contracts.components.Assignment` in which each target and each detection is used
at most once. (The score-based association of seed 001, eq. 3-4, lives in the ``world`` plugin.)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pftrack.contracts.components import Assignment, Associator, Detections, Param, Target
from pftrack.geometry.boxes import iou_matrix

__all__ = ["GreedyIoUAssociator", "HungarianIoUAssociator", "centre_distance"]

_METRICS = ("iou", "distance")


def centre_distance(a_xywh: np.ndarray, b_xywh: np.ndarray) -> np.ndarray:
    """Euclidean distance (T, K) in pixels between the centres of boxes (T, 4) and (K, 4)."""
    a = np.asarray(a_xywh, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b_xywh, dtype=np.float64).reshape(-1, 4)
    ca = a[:, :2] + 0.5 * a[:, 2:]
    cb = b[:, :2] + 0.5 * b[:, 2:]
    return np.sqrt(np.sum((ca[:, None, :] - cb[None, :, :]) ** 2, axis=-1))


class _BoxAssociator(Associator):
    """Shared cost matrix and gate of the two box associators."""

    metric: str = Param("iou", "Compare boxes by overlap (iou) or by centre distance.",
                        choices=_METRICS)
    min_iou: float = Param(0.3, "Gate for metric iou: pairs with IoU below are not matched.",
                           unit="1", low=0.0, high=1.0)
    max_distance_px: float = Param(
        50.0, "Gate for metric distance: pairs whose centres are farther apart are not matched.",
        unit="px", low=0.0)

    def cost_matrix(self, targets: Sequence[Target],
                    detections: Detections) -> tuple[np.ndarray, np.ndarray]:
        """Cost (T, K) (lower is better) and the gate (T, K) bool of admissible pairs.

        ``metric="iou"``: cost ``1 - IoU``, admissible when ``IoU >= min_iou``;
        ``metric="distance"``: cost = centre distance in pixels, admissible when
        ``<= max_distance_px``.
        """
        tb = np.array([np.asarray(t.box_xywh_px, dtype=np.float64).reshape(4) for t in targets]
                      ).reshape(-1, 4)
        db = detections.boxes_xywh_px
        if self.metric == "iou":
            iou = iou_matrix(tb, db)
            return 1.0 - iou, iou >= float(self.min_iou)
        dist = centre_distance(tb, db)
        return dist, dist <= float(self.max_distance_px)


class HungarianIoUAssociator(_BoxAssociator):
    """Minimum-total-cost one-to-one matching (``scipy.optimize.linear_sum_assignment``).

    Pairs outside the gate are never matched: they get a cost larger than any admissible
    assignment can reach, and are dropped from the optimal solution afterwards.

    {params}
    """

    def associate(self, targets: Sequence[Target], detections: Detections) -> Assignment:
        from scipy.optimize import linear_sum_assignment

        n_t, n_d = len(targets), len(detections)
        if n_t == 0 or n_d == 0:
            return Assignment.from_matches(np.zeros((0, 2), np.intp), n_t, n_d)
        cost, ok = self.cost_matrix(targets, detections)
        finite_max = float(np.max(np.where(ok, cost, 0.0)))
        big = (finite_max + 1.0) * (min(n_t, n_d) + 1)
        c = np.where(ok, cost, big)
        rows, cols = linear_sum_assignment(c)
        keep = ok[rows, cols]
        return Assignment.from_matches(np.stack([rows[keep], cols[keep]], axis=1), n_t, n_d)


class GreedyIoUAssociator(_BoxAssociator):
    """Greedy matching: repeatedly take the admissible pair of lowest cost (highest IoU or
    nearest centres), then remove its target and detection. Ties go to the lower indices.

    {params}
    """

    def associate(self, targets: Sequence[Target], detections: Detections) -> Assignment:
        n_t, n_d = len(targets), len(detections)
        if n_t == 0 or n_d == 0:
            return Assignment.from_matches(np.zeros((0, 2), np.intp), n_t, n_d)
        cost, ok = self.cost_matrix(targets, detections)
        ti, di = np.nonzero(ok)
        order = np.lexsort((di, ti, cost[ti, di]))  # by cost, then target, then detection
        used_t = np.zeros(n_t, bool)
        used_d = np.zeros(n_d, bool)
        matches = []
        for k in order:  # over admissible pairs (targets x detections), never particles
            t, d = ti[k], di[k]
            if not used_t[t] and not used_d[d]:
                used_t[t] = used_d[d] = True
                matches.append((t, d))
                if len(matches) == min(n_t, n_d):
                    break
        return Assignment.from_matches(matches, n_t, n_d)
