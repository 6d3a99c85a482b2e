"""Detections from elsewhere: MOTChallenge ``det.txt`` files -> per-frame
:class:`~pftrack.contracts.components.Detections`.

A ``det.txt`` has one detection per line, ``frame,id,left,top,width,height,conf[,x,y,z]``
(MOTChallenge: ``id`` is -1, ``conf`` the detector's score; frames numbered from 1 as the
ground truth's, MOT frame N = video frame N - 1). Any MOT file reads (a ``gt.txt`` or another
tracker's ``tracks.txt`` too): ids are ignored. A missing ``conf`` column (or -1 written for it)
reads as score 1; other scores are kept as they are.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from pftrack.contracts.components import Detections

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera

__all__ = ["detections_to_mot", "read_detections", "write_detections"]


def read_detections(path: str | os.PathLike[str], camera: Camera | None = None,
                    min_score: float | None = None) -> dict[int, Detections]:
    """Per-frame detections of a MOTChallenge detection file.

    Parameters
    ----------
    path : str or path
        The file (``frame,id,left,top,width,height,conf[,x,y,z]``).
    camera : Camera, optional
        With a ground-plane camera, each detection's foot point (bottom centre) is
        back-projected to z = 0 (``points_world_m``), as the built-in detectors do; NaN for a
        foot point on or above the camera's horizon (no ground under it: such a detection
        starts no track, see
        :meth:`~pftrack.builtin.world_observation.CameraBoxObservation.position_from_box`).
    min_score : float, optional
        Rows whose ``conf`` is below this are dropped.

    Returns
    -------
    dict {frame: Detections}
        Frames with no row are absent (the pipeline reads them as no detection).

    Raises
    ------
    FileNotFoundError, ValueError
        A missing or malformed file (the message names the file and line).
    """
    from pftrack.io.mot import read_mot

    rows = read_mot(path, check_unique=False)
    if len(rows) and np.any(rows[:, 4] * rows[:, 5] <= 0):
        bad = int(np.flatnonzero(rows[:, 4] * rows[:, 5] <= 0)[0])
        raise ValueError(f"detections {path}: row {bad + 1} has an empty box "
                         f"(width {rows[bad, 4]}, height {rows[bad, 5]})")
    # -1 is MOTChallenge's "no score"; any other value is the detector's own, negative ones
    # included (a linear detector's margin)
    scores = np.where(rows[:, 6] == -1.0, 1.0, rows[:, 6])
    if min_score is not None:
        keep = scores >= float(min_score)
        rows, scores = rows[keep], scores[keep]
    frames = rows[:, 0].astype(np.int64)
    order = np.argsort(frames, kind="stable")
    rows, scores, frames = rows[order], scores[order], frames[order]
    uniq, start = np.unique(frames, return_index=True)
    bounds = np.r_[start, len(frames)]
    points = None
    if camera is not None and len(rows):
        feet = np.stack([rows[:, 2] + 0.5 * rows[:, 4], rows[:, 3] + rows[:, 5]], axis=1)
        points = camera.image_to_ground(feet)
    out: dict[int, Detections] = {}
    for k, f in enumerate(uniq):
        a, b = bounds[k], bounds[k + 1]
        out[int(f)] = Detections(rows[a:b, 2:6].copy(), scores[a:b].copy(),
                                 None if points is None else points[a:b].copy())
    return out


def detections_to_mot(detections: dict[int, Detections]) -> np.ndarray:
    """MOT rows (M, 10) of per-frame detections (id -1, conf = score, world columns the
    ground points or -1): what :func:`read_detections` reads back. A detection without a
    ground point (none given, or its foot point above the camera's horizon: NaN) gets -1 in
    all three world columns, never NaN."""
    parts = []
    for f in sorted(detections):
        d = detections[f]
        n = len(d.scores)
        if n == 0:
            continue
        r = np.full((n, 10), -1.0)
        r[:, 0] = f
        r[:, 2:6] = d.boxes_xywh_px
        r[:, 6] = d.scores
        if d.points_world_m is not None:
            pts = np.asarray(d.points_world_m, dtype=np.float64)
            r[:, 7:10] = np.where(np.isfinite(pts).all(axis=1, keepdims=True), pts, -1.0)
        parts.append(r)
    return np.concatenate(parts) if parts else np.zeros((0, 10))


def write_detections(path: str | os.PathLike[str], detections: dict[int, Detections]):
    """Write per-frame detections as a MOTChallenge ``det.txt`` (id -1), atomically."""
    import io

    from pftrack.io.atomic import atomic_write_text

    rows = detections_to_mot(detections)
    buf = io.StringIO()
    np.savetxt(buf, rows, fmt=["%d", "%d"] + ["%.6g"] * 8, delimiter=",")
    return atomic_write_text(path, buf.getvalue())
