"""Tracking scores: CLEAR (MOTA, MOTP), Identity (IDF1) and HOTA with TrackEval's definitions,
on image boxes (IoU) or ground-plane positions (metres), and the measures the source papers report.

Entry point: :func:`evaluate` (``pftrack eval`` on the command line). Building blocks:
:func:`~pftrack.metrics.sequence.prepare_sequence` then :func:`clear_metrics`,
:func:`identity_metrics`, :func:`hota_metrics`. Paper measures live in :mod:`pftrack.metrics.paper`.
"""

from pftrack.metrics.clear import clear_metrics
from pftrack.metrics.hota import hota_metrics
from pftrack.metrics.identity import identity_matching, identity_metrics
from pftrack.metrics.mot import SUMMARY_KEYS, evaluate, format_table
from pftrack.metrics.paper import (
    accuracy_within,
    adjusted_rand_index,
    cumulative_pixel_error,
    match_ids,
    points_by_target,
    size_error,
)
from pftrack.metrics.sequence import SequenceData, prepare_sequence
from pftrack.metrics.similarity import box_iou, world_similarity

__all__ = [
    "SUMMARY_KEYS",
    "SequenceData",
    "accuracy_within",
    "adjusted_rand_index",
    "box_iou",
    "clear_metrics",
    "cumulative_pixel_error",
    "evaluate",
    "format_table",
    "hota_metrics",
    "identity_matching",
    "identity_metrics",
    "match_ids",
    "points_by_target",
    "prepare_sequence",
    "size_error",
    "world_similarity",
]
