"""Rotations of :class:`pftrack.geometry.camera.Camera` (world to camera frame): from Tsai's
angles and back, and one that looks from a point at another.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def tsai_rotation(rx: float, ry: float, rz: float) -> np.ndarray:
    """Rotation matrix from Tsai's angles (radians), as in Tsai's own C code (Willson's).

    ``R = Rz(rz) @ Ry(ry) @ Rx(rx)``; it maps world to camera coordinates.

    Returns
    -------
    ndarray, shape (3, 3)
    """
    sa, ca = math.sin(rx), math.cos(rx)
    sb, cb = math.sin(ry), math.cos(ry)
    sg, cg = math.sin(rz), math.cos(rz)
    return np.array(
        [
            [cb * cg, cg * sa * sb - ca * sg, sg * sa + ca * cg * sb],
            [cb * sg, sa * sb * sg + ca * cg, ca * sb * sg - cg * sa],
            [-sb, cb * sa, ca * cb],
        ]
    )


def tsai_angles(R: np.ndarray) -> tuple[float, float, float]:
    """Inverse of :func:`tsai_rotation`: (rx, ry, rz) in radians with ry in [-pi/2, pi/2]."""
    R = np.asarray(R, dtype=np.float64)
    ry = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    rz = math.atan2(R[1, 0], R[0, 0])
    rx = math.atan2(R[2, 1], R[2, 2])
    return rx, ry, rz


def look_at_rotation(eye: Sequence[float], target: Sequence[float],
                     up: Sequence[float] = (0.0, 0.0, 1.0)) -> np.ndarray:
    """World-to-camera rotation of a camera at ``eye`` looking at ``target`` (OpenCV frame).

    The camera's y axis points down along ``-up`` projected on the image plane, so the horizon
    is level.
    """
    eye = np.asarray(eye, dtype=np.float64)  # type: ignore[assignment]
    z = np.asarray(target, dtype=np.float64) - eye
    if np.linalg.norm(z) == 0:
        raise ValueError("look_at_rotation: eye and target coincide")
    z /= np.linalg.norm(z)
    x = np.cross(z, np.asarray(up, dtype=np.float64))
    if np.linalg.norm(x) < 1e-12:
        raise ValueError("look_at_rotation: viewing direction is parallel to up")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z])
