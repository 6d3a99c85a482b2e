"""Comparing an estimated camera with a reference one: their world frames differ by a rigid
motion in the ground plane (:func:`rigid_align_2d`), so ground positions are compared after
aligning them (:func:`ground_error_after_alignment`, :func:`compare_with_reference`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pftrack.geometry.boxes import foot_points
from pftrack.geometry.camera import Camera
from pftrack.geometry.people import horizon_row

__all__ = ["compare_with_reference", "ground_error_after_alignment", "rigid_align_2d"]


def rigid_align_2d(source: Any, target: Any) -> tuple[np.ndarray, np.ndarray]:
    """Best rotation and translation (no scale, no reflection) taking 2-D ``source`` points onto
    ``target`` in the least-squares sense (Kabsch / Procrustes).

    Returns
    -------
    R : ndarray, shape (2, 2)
    t : ndarray, shape (2,)
        ``target ~ source @ R.T + t``.
    """
    s = np.asarray(source, dtype=np.float64).reshape(-1, 2)
    t = np.asarray(target, dtype=np.float64).reshape(-1, 2)
    if len(s) != len(t) or len(s) < 2:
        raise ValueError(f"rigid_align_2d: need >= 2 matching points, got {len(s)} and {len(t)}")
    ms, mt = s.mean(axis=0), t.mean(axis=0)
    H = (s - ms).T @ (t - mt)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    R = Vt.T @ np.diag([1.0, d]) @ U.T
    return R, mt - ms @ R.T


def ground_error_after_alignment(camera: Camera, feet_px: Any, world_xy_m: Any
                                 ) -> dict[str, float]:
    """Back-project foot pixels with ``camera`` onto z = 0, align the result to the reference
    ground positions ``world_xy_m`` with the best 2-D rigid motion (:func:`rigid_align_2d`, no
    scale) and measure the distances.

    Returns
    -------
    dict
        ``median_m``, ``p90_m``, ``mean_m``, ``points`` (used: those whose ray met the ground),
        ``missed`` (rays above the horizon), ``rotation_deg`` of the alignment.
    """
    feet = np.asarray(feet_px, dtype=np.float64).reshape(-1, 2)
    ref = np.asarray(world_xy_m, dtype=np.float64).reshape(-1, 2)
    g = camera.image_to_ground(feet)[:, :2]
    ok = np.all(np.isfinite(g), axis=1)
    if ok.sum() < 2:
        raise ValueError(f"ground_error_after_alignment: only {int(ok.sum())} foot points meet "
                         "the ground through this camera")
    R, t = rigid_align_2d(g[ok], ref[ok])
    err = np.linalg.norm(g[ok] @ R.T + t - ref[ok], axis=1)
    return {"median_m": float(np.median(err)), "p90_m": float(np.percentile(err, 90)),
            "mean_m": float(err.mean()), "points": int(ok.sum()), "missed": int((~ok).sum()),
            "rotation_deg": float(math.degrees(math.atan2(R[1, 0], R[0, 0])))}


def compare_with_reference(camera_or_fit: Any, reference: Camera, boxes_xywh: Any,
                           world_xy_m: Any) -> dict[str, float]:
    """How far an estimated camera is from a reference (e.g. a surveyed) one.

    Parameters
    ----------
    camera_or_fit : Camera or PeopleCameraFit
        The estimated camera.
    reference : Camera
        The reference camera (lens distortion allowed).
    boxes_xywh : array_like, shape (N, >=4)
        Ground-truth person boxes; their foot points (bottom centre) are back-projected.
    world_xy_m : array_like, shape (N, 2)
        The same people's ground positions in the reference's world frame, metres.

    Returns
    -------
    dict
        ``median_error_m``, ``p90_error_m`` (after the best 2-D rigid alignment of the
        estimated ground positions onto ``world_xy_m``: the estimated camera's world frame is
        arbitrary up to a ground-plane rigid motion; no scale is fitted), ``points``,
        ``horizon_error_px`` (absolute difference of the horizon rows at the image's centre
        column, the reference's pinhole part), ``horizon_row_px``, ``reference_horizon_row_px``,
        ``camera_height_m``, ``reference_camera_height_m``.
    """
    cam = getattr(camera_or_fit, "camera", camera_or_fit)
    b = np.asarray(boxes_xywh, dtype=np.float64)
    feet = foot_points(b)
    g = ground_error_after_alignment(cam, feet, world_xy_m)
    col = (cam.width - 1) / 2
    hz, hz_ref = horizon_row(cam, col), horizon_row(reference, col)
    return {"median_error_m": g["median_m"], "p90_error_m": g["p90_m"], "points": g["points"],
            "horizon_error_px": abs(hz - hz_ref), "horizon_row_px": hz,
            "reference_horizon_row_px": hz_ref, "camera_height_m": float(cam.center_m[2]),
            "reference_camera_height_m": float(reference.center_m[2])}
