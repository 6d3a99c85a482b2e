"""HOTA (Luiten et al., IJCV 2021) with TrackEval's exact definitions.

For each localisation threshold alpha in 0.05, 0.10, ..., 0.95 (TrackEval's
``np.arange(0.05, 0.99, 0.05)``): per frame, gt and tracker detections are matched by the Hungarian
algorithm on ``global_alignment(gt_id, tracker_id) * similarity`` (the alignment being the
soft Jaccard overlap of the two whole tracks) and a match is a true positive when its similarity is
``>= alpha``. ``DetA = TP / (TP + FN + FP)``; ``AssA`` is the mean over TPs of the Jaccard index of
the TP's gt track and tracker track; ``HOTA_alpha = sqrt(DetA * AssA)``; ``LocA`` the mean
similarity of the TPs. The reported scalars are the means over the 19 alphas, as TrackEval
reports them. The Hungarian matching does not depend on alpha, so it runs once per frame; all
counting over alphas and the whole-sequence sums are vectorised.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from pftrack.metrics.sequence import SequenceData

_EPS = np.finfo(float).eps
ALPHAS: np.ndarray = np.arange(0.05, 0.99, 0.05)


def hota_metrics(seq: SequenceData) -> dict[str, object]:
    """HOTA and its sub-metrics for one sequence.

    Parameters
    ----------
    seq
        From :func:`pftrack.metrics.sequence.prepare_sequence`.

    Returns
    -------
    dict
        Per-alpha arrays, shape (19,): ``HOTA, DetA, AssA, DetRe, DetPr, AssRe, AssPr, LocA, OWTA,
        HOTA_TP, HOTA_FN, HOTA_FP``; scalars ``HOTA(0), LocA(0), HOTALocA(0)`` (alpha = 0.05);
        ``alphas``. Take ``np.mean`` of an array for the usual single figure.
    """
    A = len(ALPHAS)
    G, T = seq.num_gt_ids, seq.num_tracker_ids
    n_gt, n_tr = seq.num_gt_dets, seq.num_tracker_dets
    if n_tr == 0 or n_gt == 0:  # TrackEval's early return
        res: dict[str, Any] = {k: np.zeros(A) for k in (
            "HOTA", "DetA", "AssA", "DetRe", "DetPr", "AssRe", "AssPr", "OWTA", "HOTA_TP")}
        res["HOTA_FN"] = np.full(A, float(n_gt))
        res["HOTA_FP"] = np.full(A, float(n_tr))
        res["LocA"] = np.ones(A)
        res.update({"HOTA(0)": 0.0, "LocA(0)": 1.0, "HOTALocA(0)": 0.0, "alphas": ALPHAS.copy()})
        return res

    # -- whole-sequence soft alignment between ids (vectorised over all same-frame pairs) --
    s = seq.pair_sim
    row_sum = np.bincount(seq.pair_gt, weights=s, minlength=n_gt)       # per gt detection
    col_sum = np.bincount(seq.pair_tracker, weights=s, minlength=n_tr)  # per tracker detection
    denom = row_sum[seq.pair_gt] + col_sum[seq.pair_tracker] - s
    ok = denom > 0 + _EPS
    sim_iou = np.zeros_like(s)
    sim_iou[ok] = s[ok] / denom[ok]
    pg = seq.gt_det_ids[seq.pair_gt]
    pt = seq.tracker_det_ids[seq.pair_tracker]
    potential = np.bincount(pg * T + pt, weights=sim_iou, minlength=G * T).reshape(G, T)
    gt_id_count = np.bincount(seq.gt_det_ids, minlength=G).astype(float)[:, None]
    tr_id_count = np.bincount(seq.tracker_det_ids, minlength=T).astype(float)[None, :]
    alignment = potential / (gt_id_count + tr_id_count - potential)

    # -- per-frame matching (independent of alpha) --
    m_gt, m_tr, m_sim = [], [], []
    for gt_ids, tr_ids, sim in zip(seq.gt_ids, seq.tracker_ids, seq.similarity):
        if len(gt_ids) == 0 or len(tr_ids) == 0:
            continue
        score = alignment[gt_ids[:, None], tr_ids[None, :]] * sim
        rows, cols = linear_sum_assignment(-score)
        m_gt.append(gt_ids[rows])
        m_tr.append(tr_ids[cols])
        m_sim.append(sim[rows, cols])
    mg = np.concatenate(m_gt) if m_gt else np.zeros(0, np.int64)
    mt = np.concatenate(m_tr) if m_tr else np.zeros(0, np.int64)
    ms = np.concatenate(m_sim) if m_sim else np.zeros(0)

    # -- counting for every alpha at once --
    hit = ms[None, :] >= ALPHAS[:, None] - _EPS                         # (A, P)
    tp = hit.sum(axis=1).astype(float)
    loc_sum = (hit * ms[None, :]).sum(axis=1)
    a_idx, p_idx = np.nonzero(hit)
    matches = np.bincount(a_idx * (G * T) + mg[p_idx] * T + mt[p_idx],
                          minlength=A * G * T).reshape(A, G, T).astype(float)
    tp_safe = np.maximum(1, tp)
    ass_a = matches / np.maximum(1, gt_id_count + tr_id_count - matches)
    ass_re = matches / np.maximum(1, gt_id_count)
    ass_pr = matches / np.maximum(1, tr_id_count)
    res = {
        "HOTA_TP": tp,
        "HOTA_FN": n_gt - tp,
        "HOTA_FP": n_tr - tp,
        "AssA": (matches * ass_a).sum(axis=(1, 2)) / tp_safe,
        "AssRe": (matches * ass_re).sum(axis=(1, 2)) / tp_safe,
        "AssPr": (matches * ass_pr).sum(axis=(1, 2)) / tp_safe,
        "LocA": np.maximum(1e-10, loc_sum) / np.maximum(1e-10, tp),
    }
    return _final(res)


def _final(res: dict) -> dict:
    tp, fn, fp = res["HOTA_TP"], res["HOTA_FN"], res["HOTA_FP"]
    res["DetRe"] = tp / np.maximum(1, tp + fn)
    res["DetPr"] = tp / np.maximum(1, tp + fp)
    res["DetA"] = tp / np.maximum(1, tp + fn + fp)
    res["HOTA"] = np.sqrt(res["DetA"] * res["AssA"])
    res["OWTA"] = np.sqrt(res["DetRe"] * res["AssA"])
    res["HOTA(0)"] = float(res["HOTA"][0])
    res["LocA(0)"] = float(res["LocA"][0])
    res["HOTALocA(0)"] = res["HOTA(0)"] * res["LocA(0)"]
    res["alphas"] = ALPHAS.copy()
    return res
