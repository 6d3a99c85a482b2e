"""Multi-object tracking scores of a track file against ground truth: CLEAR, Identity and HOTA.

:func:`evaluate` is the one entry point (the ``pftrack eval`` command calls it). Definitions are
TrackEval's (see :mod:`pftrack.metrics.clear`, :mod:`~pftrack.metrics.identity`,
:mod:`~pftrack.metrics.hota`); on the TUD-Campus and TUD-Stadtmitte sequences shipped with
py-motmetrics the figures equal TrackEval's and py-motmetrics' published ones (see the tests).

Two ways to score a pair of detections:

``metric="iou"``
    Image boxes, similarity = IoU; ``threshold`` (default 0.5) is the IoU a CLEAR / Identity match
    needs. HOTA sweeps its own alphas over the IoU.
``metric="world"``
    Ground-plane positions (``x, y`` columns, metres), similarity
    ``max(0, 1 - d / (2 * threshold))``: a CLEAR / Identity match is a hit when the distance
    ``d <= threshold`` metres (default 1 m), exactly TrackEval's position-only convention (its
    ``zero_distance = 2`` m with similarity threshold 0.5). HOTA sweeps alpha over that
    similarity, i.e. over distances from 1.9 x threshold down to 0.1 x threshold. ``MOTP`` stays
    the mean similarity; ``MOTP_m`` is the mean matched distance in metres.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pftrack.io.mot import MotTable
from pftrack.metrics.clear import clear_metrics
from pftrack.metrics.hota import hota_metrics
from pftrack.metrics.identity import identity_metrics
from pftrack.metrics.sequence import prepare_sequence

#: Keys every :func:`evaluate` result has at the top level, in display order.
SUMMARY_KEYS: tuple[str, ...] = ("HOTA", "DetA", "AssA", "LocA", "MOTA", "MOTP", "IDF1", "IDP",
                                 "IDR", "IDSW", "FP", "FN", "TP", "MT", "PT", "ML", "Frag")
_HOTA_MEANS = ("HOTA", "DetA", "AssA", "DetRe", "DetPr", "AssRe", "AssPr", "LocA", "OWTA")
DEFAULT_THRESHOLD = {"iou": 0.5, "world": 1.0}


def evaluate(gt_rows: np.ndarray | MotTable, track_rows: np.ndarray | MotTable, *,
             metric: str = "iou", threshold: float | None = None,
             zero_marked: str = "drop_matched") -> dict[str, Any]:
    """Score tracks against ground truth with CLEAR (MOTA, MOTP), Identity (IDF1) and HOTA.

    Parameters
    ----------
    gt_rows, track_rows : ndarray, shape (M, 6..10), or MotTable
        MOTChallenge rows ``frame, id, left, top, width, height, conf, x, y, z`` (pixels, metres),
        e.g. from :func:`pftrack.io.mot.read_mot`. The gt's ``conf`` is its consider flag.
    metric : {"iou", "world"}
        Image-box IoU or ground-plane distance (see the module docstring).
    threshold : float, optional
        Match threshold: IoU for ``"iou"`` (default 0.5), metres for ``"world"`` (default 1.0).
    zero_marked : {"drop_matched", "drop", "keep"}
        What to do with gt rows flagged 0 (see :mod:`pftrack.metrics.sequence`): by default they
        are dropped together with the tracker boxes matched to them in their frame.

    Returns
    -------
    dict
        Flat, JSON-ready: ``MOTA, MOTP, IDF1, IDP, IDR, IDSW, HOTA, DetA, AssA, LocA`` and the
        other CLEAR / Identity / HOTA fields (HOTA family averaged over the 19 alphas, as TrackEval
        reports it), counts (``FP, FN, TP, MT, PT, ML, Frag, IDTP, IDFP, IDFN``), ``HOTA(0)``,
        ``LocA(0)``, and the set-up: ``metric, threshold, zero_marked, num_frames, num_gt_dets,
        num_tracker_dets, num_gt_ids, num_tracker_ids, num_ignored_gt, num_ignored_tracker``
        (and ``MOTP_m`` for ``"world"``).

    Raises
    ------
    ValueError
        Unknown metric or policy, a non-positive threshold, malformed rows, or missing world
        coordinates for ``metric="world"``.
    """
    if metric not in DEFAULT_THRESHOLD:
        raise ValueError(f"metric must be 'iou' or 'world', got {metric!r}")
    thr = DEFAULT_THRESHOLD[metric] if threshold is None else float(threshold)
    if metric == "iou" and not 0 < thr <= 1:
        raise ValueError(f"threshold for metric='iou' is an IoU in (0, 1], got {thr!r}")
    if metric == "world" and not thr > 0:
        raise ValueError(f"threshold for metric='world' is a distance in metres > 0, got {thr!r}")
    gt = gt_rows.rows if isinstance(gt_rows, MotTable) else gt_rows
    tr = track_rows.rows if isinstance(track_rows, MotTable) else track_rows

    sim_thr = thr if metric == "iou" else 0.5
    zero_distance = 2.0 * thr if metric == "world" else None
    seq = prepare_sequence(gt, tr, metric=metric, zero_distance_m=zero_distance,
                           sim_threshold=sim_thr, zero_marked=zero_marked)
    clear = clear_metrics(seq, threshold=sim_thr)
    ident = identity_metrics(seq, threshold=sim_thr)
    hota = hota_metrics(seq)

    out: dict[str, Any] = {}
    for k in _HOTA_MEANS:
        out[k] = float(np.mean(hota[k]))  # type: ignore[call-overload]
    out.update({"HOTA(0)": hota["HOTA(0)"], "LocA(0)": hota["LocA(0)"]})
    for k in ("MOTA", "MOTP", "MODA", "sMOTA", "MTR", "PTR", "MLR"):
        out[k] = float(clear[k])
    out["Recall"] = float(clear["CLR_Re"])
    out["Precision"] = float(clear["CLR_Pr"])
    out["CLR_F1"] = float(clear["CLR_F1"])
    for k in ("IDF1", "IDP", "IDR"):
        out[k] = float(ident[k])
    out.update(IDSW=int(clear["IDSW"]), FP=int(clear["CLR_FP"]), FN=int(clear["CLR_FN"]),
               TP=int(clear["CLR_TP"]), MT=int(clear["MT"]), PT=int(clear["PT"]),
               ML=int(clear["ML"]), Frag=int(clear["Frag"]), IDTP=int(ident["IDTP"]),
               IDFP=int(ident["IDFP"]), IDFN=int(ident["IDFN"]))
    if metric == "world":
        out["MOTP_m"] = float((1.0 - out["MOTP"]) * zero_distance) if out["TP"] else float("nan")
    out.update(metric=metric, threshold=thr, zero_marked=zero_marked,
               num_frames=seq.num_frames, num_gt_dets=seq.num_gt_dets,
               num_tracker_dets=seq.num_tracker_dets, num_gt_ids=seq.num_gt_ids,
               num_tracker_ids=seq.num_tracker_ids, num_ignored_gt=seq.num_ignored_gt,
               num_ignored_tracker=seq.num_ignored_tracker)
    return out


def format_table(result: dict[str, Any]) -> str:
    """A two-line text table of an :func:`evaluate` result (percentages for the scores)."""
    heads, cells = [], []
    for k in SUMMARY_KEYS:
        v = result[k]
        heads.append(k)
        cells.append(f"{100 * v:.2f}" if isinstance(v, float) else str(v))
    widths = [max(len(h), len(c)) for h, c in zip(heads, cells)]
    line1 = "  ".join(h.rjust(w) for h, w in zip(heads, widths))
    line2 = "  ".join(c.rjust(w) for c, w in zip(cells, widths))
    unit = "IoU" if result["metric"] == "iou" else "m"
    foot = (f"metric={result['metric']} threshold={result['threshold']:g} {unit}  "
            f"frames={result['num_frames']} gt={result['num_gt_dets']} boxes/"
            f"{result['num_gt_ids']} ids  tracks={result['num_tracker_dets']} boxes/"
            f"{result['num_tracker_ids']} ids  ignored gt={result['num_ignored_gt']} "
            f"tracks={result['num_ignored_tracker']} ({result['zero_marked']})")
    if "MOTP_m" in result:
        foot += f"  MOTP_m={result['MOTP_m']:.3f}"
    return f"{line1}\n{line2}\n{foot}"
