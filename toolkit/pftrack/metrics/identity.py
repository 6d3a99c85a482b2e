"""Identity metrics IDF1, IDP, IDR (Ristani et al. 2016) with TrackEval's exact definitions.

Each gt id is matched to at most one tracker id for the whole sequence, by the Hungarian algorithm
on the number of detections they would get wrong (ID false negatives + ID false positives); two
detections of a matched id pair agree in a frame when their similarity is ``>= threshold``.
``IDF1 = IDTP / (IDTP + (IDFP + IDFN) / 2)``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from pftrack.metrics.sequence import SequenceData

_BIG = 1e10


def identity_metrics(seq: SequenceData, threshold: float = 0.5) -> dict[str, float]:
    """Identity metrics of one sequence.

    Parameters
    ----------
    seq
        From :func:`pftrack.metrics.sequence.prepare_sequence`.
    threshold
        Minimum similarity for two detections to agree.

    Returns
    -------
    dict
        ``IDF1, IDP, IDR`` (floats), ``IDTP, IDFN, IDFP`` (ints).
    """
    res: dict[str, float] = {"IDTP": 0, "IDFN": 0, "IDFP": 0}
    if seq.num_tracker_dets == 0 or seq.num_gt_dets == 0:
        res["IDFN"], res["IDFP"] = seq.num_gt_dets, seq.num_tracker_dets
        res.update(IDF1=0.0, IDP=0.0, IDR=0.0)  # TrackEval's early return
        return res
    fn, fp, rows, cols = _id_assignment(seq, threshold)
    gt_count = np.bincount(seq.gt_det_ids, minlength=seq.num_gt_ids)
    idfn = int(fn[rows, cols].sum())
    idfp = int(fp[rows, cols].sum())
    idtp = int(gt_count.sum()) - idfn
    res.update(IDTP=idtp, IDFN=idfn, IDFP=idfp)
    res["IDR"] = idtp / max(1.0, idtp + idfn)
    res["IDP"] = idtp / max(1.0, idtp + idfp)
    res["IDF1"] = idtp / max(1.0, idtp + 0.5 * idfp + 0.5 * idfn)
    return res


def _id_assignment(seq: SequenceData, threshold: float):
    """TrackEval's (G + T) square assignment: cost matrices ``fn, fp`` and the optimal rows, cols.

    Row ``g < G`` / column ``t < T`` are ids; column ``T + g`` leaves gt id ``g`` unmatched and
    row ``G + t`` leaves tracker id ``t`` unmatched.
    """
    G, T = seq.num_gt_ids, seq.num_tracker_ids
    hit = seq.pair_sim >= threshold
    g = seq.gt_det_ids[seq.pair_gt[hit]]
    t = seq.tracker_det_ids[seq.pair_tracker[hit]]
    potential = np.bincount(g * T + t, minlength=G * T).reshape(G, T).astype(float)
    gt_count = np.bincount(seq.gt_det_ids, minlength=G).astype(float)
    tr_count = np.bincount(seq.tracker_det_ids, minlength=T).astype(float)
    fn = np.zeros((G + T, G + T))
    fp = np.zeros((G + T, G + T))
    fp[G:, :T] = _BIG
    fn[:G, T:] = _BIG
    fn[:G, :T] = gt_count[:, None] - potential
    fn[np.arange(G), T + np.arange(G)] = gt_count
    fp[:G, :T] = tr_count[None, :] - potential
    fp[G + np.arange(T), np.arange(T)] = tr_count
    rows, cols = linear_sum_assignment(fn + fp)
    return fn, fp, rows, cols


def identity_matching(seq: SequenceData, threshold: float = 0.5) -> dict[int, int]:
    """The IDF1-optimal one-to-one map from gt ids to tracker ids (original ids).

    Gt ids left unmatched, or matched to a tracker id with which they never agree in a frame, are
    absent from the map.
    """
    if seq.num_gt_dets == 0 or seq.num_tracker_dets == 0:
        return {}
    G, T = seq.num_gt_ids, seq.num_tracker_ids
    fn, _, rows, cols = _id_assignment(seq, threshold)
    gt_count = np.bincount(seq.gt_det_ids, minlength=G)
    out = {}
    for r, c in zip(rows, cols):
        if r < G and c < T and fn[r, c] < gt_count[r]:  # at least one agreeing frame
            out[int(seq.gt_id_map[r])] = int(seq.tracker_id_map[c])
    return out
