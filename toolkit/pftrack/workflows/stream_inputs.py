"""What :meth:`pftrack.workflows.stream.Tracker.update` accepts, read and checked: a
supervision ``sv.Detections``, a :class:`~pftrack.contracts.components.Detections`, or an
``(N, 4|5|6)`` array of boxes (``x1, y1, x2, y2[, score[, class_id]]`` pixels, or another
layout), turned into the boxes, scores and classes the engine takes; a bad row is a
``ValueError`` that names it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from pftrack.contracts.components import Detections


@dataclass
class _Input:
    """One frame's detections, checked: boxes (left, top, width, height) px as the engine
    takes them, scores, classes, and the world points a Detections carried."""

    xywh: np.ndarray
    scores: np.ndarray
    classes: np.ndarray
    points: np.ndarray | None
    supervision: bool


def _is_supervision(obj: Any) -> bool:
    return type(obj).__module__.split(".")[0] == "supervision" and hasattr(obj, "xyxy")


def _class_column(values: Any, n: int, arg: str) -> np.ndarray:
    if values is None:
        return np.zeros(n, dtype=np.int64)
    c = np.asarray(values)
    if c.shape != (n,):
        raise ValueError(f"update({arg}): {n} boxes but class_id of shape {c.shape}")
    if c.dtype.kind not in "iu":
        cf = np.asarray(c, dtype=np.float64)
        bad = ~np.isfinite(cf) | (cf != np.round(cf))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"update({arg}): row {i}: class_id {c[i]} is not an integer")
        c = cf
    c = c.astype(np.int64)
    if (c < 0).any():
        i = int(np.flatnonzero(c < 0)[0])
        raise ValueError(f"update({arg}): row {i}: class_id {int(c[i])} is negative")
    return c


def _parse(det: Any, layout: str, frame_index: int, class_id: Any) -> _Input:
    """Any accepted detections -> :class:`_Input` (shape, finiteness and size checked)."""
    arg = "detections"
    points = None
    sv_in = False
    if det is None:
        xywh, scores, classes = np.zeros((0, 4)), np.zeros(0), np.zeros(0, np.int64)
    elif isinstance(det, Detections):
        xywh, scores = det.boxes_xywh_px, det.scores
        classes = _class_column(class_id, len(scores), arg)
        points = det.points_world_m
    elif _is_supervision(det):
        sv_in = True
        xyxy = np.asarray(det.xyxy, dtype=np.float64).reshape(-1, 4)
        n = len(xyxy)
        scores = (np.ones(n) if det.confidence is None
                  else np.asarray(det.confidence, dtype=np.float64).reshape(-1))
        classes = _class_column(det.class_id if class_id is None else class_id, n, arg)
        xywh = np.concatenate([xyxy[:, :2], xyxy[:, 2:] - xyxy[:, :2]], axis=1)
    else:
        try:
            a = np.asarray(det, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"update({arg}): expected an (N, 4|5|6) array, MOTChallenge rows, "
                             f"a pftrack.Detections or an sv.Detections, got "
                             f"{type(det).__name__}") from None
        if a.size == 0:
            a = a.reshape(0, 10 if layout == "mot" else 4)
        if layout == "mot":
            if a.ndim != 2 or not 6 <= a.shape[1] <= 10:
                raise ValueError(f"update({arg}, layout='mot'): expected MOTChallenge rows "
                                 f"(N, 6..10) frame, id, left, top, width, height[, conf, x, y, "
                                 f"z], got shape {a.shape}")
            wrong = a[:, 0] != frame_index
            if wrong.any():
                i = int(np.flatnonzero(wrong)[0])
                raise ValueError(f"update({arg}, layout='mot'): row {i} is of frame "
                                 f"{a[i, 0]:g}, this update is frame {frame_index} (pass "
                                 f"rows[rows[:, 0] == {frame_index}])")
            xywh = a[:, 2:6]
            scores = (np.where(a[:, 6] < 0, 1.0, a[:, 6]) if a.shape[1] > 6
                      else np.ones(len(a)))
            classes = _class_column(class_id, len(a), arg)
        elif layout == "xyxy":
            if a.ndim != 2 or a.shape[1] not in (4, 5, 6):
                raise ValueError(f"update({arg}): expected an (N, 4), (N, 5) or (N, 6) array "
                                 f"x1, y1, x2, y2[, score[, class_id]], got shape {a.shape}")
            xywh = np.concatenate([a[:, :2], a[:, 2:4] - a[:, :2]], axis=1)
            scores = a[:, 4] if a.shape[1] > 4 else np.ones(len(a))
            cls_col = a[:, 5] if a.shape[1] > 5 else class_id
            if a.shape[1] > 5 and class_id is not None:
                raise ValueError(f"update({arg}): class_id given twice (column 5 and the "
                                 "class_id argument)")
            if a.shape[1] > 5 and not np.isfinite(a[:, 5]).all():
                i = int(np.flatnonzero(~np.isfinite(a[:, 5]))[0])
                raise ValueError(f"update({arg}): row {i} has a NaN or infinite value: "
                                 f"{a[i].tolist()}")
            classes = _class_column(cls_col, len(a), arg)
        else:
            raise ValueError(f"update(layout={layout!r}): choose 'xyxy' or 'mot'")
    xywh = np.asarray(xywh, dtype=np.float64).reshape(-1, 4)
    scores = np.asarray(scores, dtype=np.float64).reshape(-1)
    if len(scores) != len(xywh):
        raise ValueError(f"update({arg}): {len(xywh)} boxes but {len(scores)} scores")
    bad = ~(np.isfinite(xywh).all(axis=1) & np.isfinite(scores))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"update({arg}): row {i} has a NaN or infinite value (box "
                         f"{_xyxy_text(xywh[i])}, score {scores[i]})")
    bad = (xywh[:, 2] <= 0) | (xywh[:, 3] <= 0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"update({arg}): row {i} has a negative or zero size (box "
                         f"{_xyxy_text(xywh[i])}: width {xywh[i, 2]:g}, height "
                         f"{xywh[i, 3]:g} px; x2 must exceed x1 and y2 y1)")
    return _Input(xywh, scores, classes, points, sv_in)


def _xyxy_text(b: np.ndarray) -> str:
    x, y, w, h = (float(v) for v in b)
    return f"x1 {x:g}, y1 {y:g}, x2 {x + w:g}, y2 {y + h:g}"


def _check_inside(inp: _Input, size_wh: tuple[int, int]) -> None:
    """A box wholly outside the image cannot be a detection of it: ValueError naming the row."""
    w, h = size_wh
    b = inp.xywh
    out = (b[:, 0] >= w) | (b[:, 1] >= h) | (b[:, 0] + b[:, 2] <= 0) | (b[:, 1] + b[:, 3] <= 0)
    if out.any():
        i = int(np.flatnonzero(out)[0])
        raise ValueError(f"update(detections): row {i} lies wholly outside the {w}x{h} image "
                         f"(box {_xyxy_text(b[i])})")
