"""The engine's track records as arrays: MOTChallenge rows and each record's uncertainty, in
the same row order (written by :mod:`pftrack.io.mot` and :mod:`pftrack.io.outputs`)."""


from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from pftrack.contracts.components import (
    TrackRecord,
)


def records_to_mot(records: Iterable[TrackRecord]) -> np.ndarray:
    """MOTChallenge rows (M, 10): frame, id, left, top, width, height, conf, x, y, z
    (world columns -1 when unknown)."""
    rows = []
    for r in records:
        w = r.world_m if r.world_m is not None else (-1.0, -1.0, -1.0)
        rows.append([r.frame, r.id, *r.box_xywh_px, r.confidence, *w])
    return np.asarray(rows, dtype=np.float64).reshape(-1, 10)


UNCERTAINTY_COLUMNS = ("frame", "id", "x1_sd", "y1_sd", "x2_sd", "y2_sd", "world_var_x",
                       "world_cov_xy", "world_var_y")


def records_uncertainty(records: Iterable[TrackRecord]) -> np.ndarray:
    """The spread of each record's estimate (M, 9), rows in the order of
    :func:`records_to_mot`'s: frame, id, the standard deviations of the box's x1, y1, x2, y2
    (pixels) and the ground covariance's var_x, cov_xy, var_y (m^2); NaN where a record has
    none (``TrackRecord.xyxy_sd``, ``TrackRecord.world_cov``: filled by
    :class:`pftrack.workflows.spread.RecordSpread`). Written beside ``tracks.txt`` as
    ``tracks_uncertainty.csv`` (:func:`pftrack.io.outputs.write_track_uncertainty`)."""
    rows = []
    nan4 = (math.nan,) * 4
    for r in records:
        sd = nan4 if r.xyxy_sd is None else r.xyxy_sd
        c = r.world_cov
        cov = (math.nan,) * 3 if c is None else (c[0][0], c[0][1], c[1][1])
        rows.append([r.frame, r.id, *sd, *cov])
    return np.asarray(rows, dtype=np.float64).reshape(-1, 9)
