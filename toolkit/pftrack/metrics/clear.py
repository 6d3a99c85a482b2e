"""CLEAR MOT metrics (Bernardin & Stiefelhagen 2008) with TrackEval's exact definitions.

Per frame, gt and tracker boxes are matched by the Hungarian algorithm on a score that first keeps
the previous frame's matches (a +1000 bonus for a pair that was matched in the frame before) and
then maximises similarity; pairs with similarity below ``threshold`` cannot match. An identity
switch is counted when a gt id is matched to a tracker id other than the one it was last matched
to (any number of frames before). ``MOTA = (TP - FP - IDSW) / (TP + FN)``; ``MOTP`` is the mean
similarity of the matches (mean IoU for boxes; note that py-motmetrics reports the mean *distance*
``1 - IoU`` instead). MT/PT/ML: gt ids tracked in > 80 %, 20-80 %, < 20 % of their frames.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from pftrack.metrics.sequence import SequenceData

_EPS = np.finfo(float).eps
_FLOAT_FIELDS = ("MOTA", "MOTP", "MODA", "CLR_Re", "CLR_Pr", "MTR", "PTR", "MLR", "sMOTA", "CLR_F1")


def clear_metrics(seq: SequenceData, threshold: float = 0.5) -> dict[str, float]:
    """CLEAR MOT metrics of one sequence.

    Parameters
    ----------
    seq
        From :func:`pftrack.metrics.sequence.prepare_sequence`.
    threshold
        Minimum similarity of a match (IoU for boxes, ``1 - d / zero_distance`` for world points).

    Returns
    -------
    dict
        ``MOTA, MOTP, MODA, CLR_Re, CLR_Pr, CLR_F1, sMOTA, MTR, PTR, MLR`` (floats) and
        ``CLR_TP, CLR_FN, CLR_FP, IDSW, MT, PT, ML, Frag, CLR_Frames`` (ints), ``MOTP_sum``.
    """
    res: dict[str, float] = {k: 0 for k in
                             ("CLR_TP", "CLR_FN", "CLR_FP", "IDSW", "MT", "PT", "ML", "Frag")}
    res["MOTP_sum"] = 0.0
    res["CLR_Frames"] = seq.num_frames
    n_gt_ids = seq.num_gt_ids
    if seq.num_tracker_dets == 0 or seq.num_gt_dets == 0:
        res["CLR_FN"] = seq.num_gt_dets
        res["CLR_FP"] = seq.num_tracker_dets
        res["ML"] = n_gt_ids
        # TrackEval's early return: every ratio 0 except MLR (no MOTA of -FP for an empty gt)
        res.update({k: 0.0 for k in _FLOAT_FIELDS})
        res["MLR"] = 1.0
        return res

    gt_id_count = np.zeros(n_gt_ids)
    gt_matched_count = np.zeros(n_gt_ids)
    gt_frag_count = np.zeros(n_gt_ids)
    prev_tracker_id = np.full(n_gt_ids, np.nan)           # last match, any frame back (IDSW)
    prev_timestep_tracker_id = np.full(n_gt_ids, np.nan)  # match in the previous frame only
    tp = fn = fp = idsw = 0
    motp_sum = 0.0
    for gt_ids, tr_ids, sim in zip(seq.gt_ids, seq.tracker_ids, seq.similarity):
        if len(gt_ids) == 0:
            fp += len(tr_ids)
            continue
        if len(tr_ids) == 0:
            fn += len(gt_ids)
            gt_id_count[gt_ids] += 1
            continue
        score = 1000.0 * (tr_ids[None, :] == prev_timestep_tracker_id[gt_ids[:, None]]) + sim
        score[sim < threshold - _EPS] = 0
        rows, cols = linear_sum_assignment(-score)
        ok = score[rows, cols] > _EPS
        rows, cols = rows[ok], cols[ok]
        m_gt, m_tr = gt_ids[rows], tr_ids[cols]

        prev = prev_tracker_id[m_gt]
        idsw += int(np.sum(~np.isnan(prev) & (m_tr != prev)))

        gt_id_count[gt_ids] += 1
        gt_matched_count[m_gt] += 1
        not_previously_tracked = np.isnan(prev_timestep_tracker_id)
        prev_tracker_id[m_gt] = m_tr
        prev_timestep_tracker_id[:] = np.nan
        prev_timestep_tracker_id[m_gt] = m_tr
        gt_frag_count += not_previously_tracked & ~np.isnan(prev_timestep_tracker_id)

        tp += len(m_gt)
        fn += len(gt_ids) - len(m_gt)
        fp += len(tr_ids) - len(m_gt)
        if len(m_gt):
            motp_sum += float(sim[rows, cols].sum())

    present = gt_id_count > 0
    ratio = gt_matched_count[present] / gt_id_count[present]
    mt = int(np.sum(ratio > 0.8))
    pt = int(np.sum(ratio >= 0.2)) - mt
    res.update(CLR_TP=tp, CLR_FN=fn, CLR_FP=fp, IDSW=idsw, MT=mt, PT=pt, ML=n_gt_ids - mt - pt,
               Frag=int(np.sum(gt_frag_count[gt_frag_count > 0] - 1)), MOTP_sum=motp_sum)
    return _final(res)


def _final(res: dict) -> dict:
    tp, fn, fp, idsw = res["CLR_TP"], res["CLR_FN"], res["CLR_FP"], res["IDSW"]
    n_ids = res["MT"] + res["PT"] + res["ML"]
    res["MTR"] = res["MT"] / max(1.0, n_ids)
    res["PTR"] = res["PT"] / max(1.0, n_ids)
    res["MLR"] = res["ML"] / max(1.0, n_ids)
    res["CLR_Re"] = tp / max(1.0, tp + fn)
    res["CLR_Pr"] = tp / max(1.0, tp + fp)
    res["MODA"] = (tp - fp) / max(1.0, tp + fn)
    res["MOTA"] = (tp - fp - idsw) / max(1.0, tp + fn)
    res["MOTP"] = res["MOTP_sum"] / max(1.0, tp)
    res["sMOTA"] = (res["MOTP_sum"] - fp - idsw) / max(1.0, tp + fn)
    res["CLR_F1"] = tp / max(1.0, tp + 0.5 * fn + 0.5 * fp)
    return res
