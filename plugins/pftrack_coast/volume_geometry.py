"""Geometry of the ``volumes`` track manager (:mod:`pftrack_coast.volumes`): the support-plane
correction of a particle cloud (its footprint, size and image box from its pixels, for an object
resting on a plane), cuboids' corners and image boxes, a cloud's quantile box.

One view cannot place a point along its ray, so the particle cloud of an intruder stretches along
the rays through it (the coastal paper's Table 1: a 2.3 m deep boat estimated 63 m deep).
Intruders rest on a support plane (sea level, the ground), so the lowest image row of the cloud
is the front of the footprint on that plane: back-projected, it fixes the distance. The cloud's
image box then gives the width across the view (its bottom corners on the plane) and the height
(the top row on the vertical over the back of the footprint). The depth along the view cannot be
seen from one view at a grazing angle (a 2.3 m deep boat at 300 m from 20 m up moves its top edge
by a third of a pixel); it comes from a footprint prior (:func:`footprint_size`): a rectangle
whose long side is ``aspect`` times the short one, turned by its heading.

The image box of a cloud spans its 2 % to 98 % quantiles per image axis, widened to the ends of a
uniform spread with those quantiles.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera

__all__ = ["cloud_box", "cuboid_box", "cuboid_boxes", "cuboid_corners", "footprint_size",
           "support_plane_estimate"]


def footprint_size(across_m: float, aspect: float, heading_deg: float | None) -> tuple[float,
                                                                                       float]:
    """Footprint extents (across the view, along it) of a rectangle whose long side is
    ``aspect`` times its short one and points ``heading_deg`` from the across-view direction,
    given its measured extent across the view.

    A rectangle L x W (L = aspect W) turned by phi spans ``L |cos phi| + W |sin phi|`` across
    the view and ``L |sin phi| + W |cos phi|`` along it. ``heading_deg`` None: phi = 0.
    """
    phi = 0.0 if heading_deg is None else math.radians(float(heading_deg))
    c, s = abs(math.cos(phi)), abs(math.sin(phi))
    a = float(aspect)
    w = float(across_m) / (a * c + s)
    return float(across_m), w * (a * s + c)


def _finite_rows(px: np.ndarray) -> np.ndarray:
    """``np.isfinite(px).all(axis=1)`` of pixels (N, 2), by columns (a reduction over a
    2-wide axis is numpy's slow path)."""
    return np.isfinite(px[:, 0]) & np.isfinite(px[:, 1])


def _axes(camera: Camera, ground_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors (3,) across and along the view on the horizontal plane at ``ground_xy``."""
    c = camera.center_m
    along = np.array([ground_xy[0] - c[0], ground_xy[1] - c[1], 0.0])
    n = float(np.hypot(along[0], along[1]))
    along = np.array([0.0, 1.0, 0.0]) if n == 0 else along / n
    across = np.array([along[1], -along[0], 0.0])
    return across, along


def support_plane_estimate(camera: Camera, pixels: np.ndarray, *, support_z_m: float = 0.0,
                           aspect: float = 1.0, heading_deg: float | None = None,
                           max_height_m: float = 50.0, quantile: float = 0.02,
                           ) -> dict[str, Any] | None:
    """An object's footprint centre, size and image box from the image positions of its
    particles, for an object resting on the plane ``z = support_z_m`` (see the module docstring).

    Parameters
    ----------
    camera : Camera
    pixels : ndarray, shape (N, 2)
        The particles' image positions (NaN rows ignored), equally weighted.
    support_z_m, aspect, heading_deg
        The support plane's height, the footprint's long/short ratio and its heading from the
        across-view direction (degrees, None: 0).
    max_height_m : float
        Heights are searched up to this.
    quantile : float
        The cloud's image box spans its ``quantile`` to ``1 - quantile`` quantiles per axis,
        widened to the ends of a uniform spread with those quantiles (outlying particles do not
        stretch it).

    Returns
    -------
    dict or None
        ``footprint_m`` (3,) the footprint's centre on the plane, ``centre_m`` (3,) the object's
        centre, ``size_m`` (3,) width across the view, height, depth along it, ``box_xywh_px``
        (4,) the cloud's image box, ``across``/``along`` (3,) the view's unit axes; None when
        the cloud's foot row does not meet the plane in front of the camera.
    """
    base = _support_base(camera, pixels, float(support_z_m), quantile)
    if base is None:
        return None
    return _support_finish(camera, base, aspect=aspect, heading_deg=heading_deg,
                           max_height_m=max_height_m)


def _support_base(camera: Camera, pixels: np.ndarray, z: float, quantile: float,
                  finite: bool = False) -> dict[str, Any] | None:
    """:func:`support_plane_estimate`'s part that does not depend on the footprint's shape:
    the cloud's image box, its foot row on the plane, the view's axes there and the width
    across the view (None: no footprint). ``finite``: the pixels are known to be finite."""
    px = np.asarray(pixels, dtype=np.float64)
    if not finite:
        px = px[np.isfinite(px).all(axis=1)]
    if len(px) < 2:
        return None
    (u0, v0), (u1, v1), mid = _cloud_ends(px, quantile)
    g = camera.image_to_ground(np.array([[mid[0], v1], [u0, v1], [u1, v1]]), z_m=z)
    if not np.isfinite(g).all():
        return None
    g[:, 2] = z  # on the plane exactly (the intersection leaves rounding)
    front = g[0]
    across, along = _axes(camera, front[:2])
    width = float(abs(np.dot(g[2] - g[1], across)))
    return {"z": z, "ends": (u0, v0, u1, v1), "front": front, "across": across,
            "along": along, "width": width}


_HEIGHTS = np.linspace(0.0, 50.0, 65)  # the heights searched by default (read only)
_HEIGHTS.flags.writeable = False


def _support_finish(camera: Camera, base: dict[str, Any], *, aspect: float = 1.0,
                    heading_deg: float | None = None, max_height_m: float = 50.0,
                    ) -> dict[str, Any]:
    """:func:`support_plane_estimate` from its :func:`_support_base`, for a footprint shape."""
    z, (u0, v0, u1, v1) = base["z"], base["ends"]
    front, across, along = base["front"], base["across"], base["along"]
    width, depth = footprint_size(base["width"], aspect, heading_deg)
    back = front + depth * along
    # the top row on the vertical over the back of the footprint (the top edge seen last)
    hz = _HEIGHTS if float(max_height_m) == 50.0 else np.linspace(0.0, float(max_height_m), 65)
    col = np.repeat(back[None], len(hz), axis=0)
    col[:, 2] = z + hz
    vv = camera.project(col)[:, 1]
    ok = np.isfinite(vv)
    height = 0.0
    if ok.sum() >= 2:
        vs, hs = vv[ok], hz[ok]
        order = np.argsort(vs)
        height = float(np.interp(v0, vs[order], hs[order]))
    foot = front + 0.5 * depth * along
    centre = foot.copy()
    centre[2] = z + 0.5 * height
    return {"footprint_m": foot, "centre_m": centre,
            "size_m": np.array([width, height, depth]),
            "box_xywh_px": np.array([u0, v0, u1 - u0, v1 - v0]),
            "across": across, "along": along}


def cuboid_box(camera: Camera, centre_m: np.ndarray, size_m: np.ndarray, across: np.ndarray,
               along: np.ndarray) -> np.ndarray:
    """Image bounding box (4,) of a cuboid with ``size_m`` (across, height, along) about
    ``centre_m``, its faces along the view's axes (NaN when a corner is behind the camera)."""
    return cuboid_boxes(camera, np.asarray(centre_m, float)[None],
                        np.asarray(size_m, float)[None], across, along)[0]


def cuboid_corners(centres_m: np.ndarray, sizes_m: np.ndarray, across: np.ndarray,
                   along: np.ndarray) -> np.ndarray:
    """The 8 corners (K, 8, 3) of K cuboids with sizes (K, 3) (across, height, along) about
    centres (K, 3), faces along the view's axes; corner k has + half-size along across / along
    / up where bit 0 / 1 / 2 of k is set (the order of
    :meth:`pftrack.geometry.volumes.CuboidVolume.corners`, so its edge list applies)."""
    bits = (np.arange(8)[:, None] >> np.arange(3)[None, :]) & 1
    s = bits - 0.5  # (8, 3): across, along, up
    c = np.asarray(centres_m, dtype=np.float64)
    z = np.asarray(sizes_m, dtype=np.float64)
    up = np.array([0.0, 0.0, 1.0])
    return (c[:, None, :] + (s[None, :, 0:1] * z[:, None, 0:1]) * across
            + (s[None, :, 2:3] * z[:, None, 1:2]) * up
            + (s[None, :, 1:2] * z[:, None, 2:3]) * along)


def cloud_box(pixels: np.ndarray, quantile: float = 0.02) -> np.ndarray:
    """The image box (4,) of a particle cloud's pixels (N, 2), finite rows: its ``quantile``
    to ``1 - quantile`` quantiles per axis, widened to the ends of a uniform spread with those
    quantiles (outlying particles do not stretch it)."""
    lo, hi, _ = _cloud_ends(pixels, quantile)
    return np.concatenate([lo, hi - lo])


def _cloud_ends(pixels: np.ndarray, quantile: float,
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`cloud_box`'s (left, top), (right, bottom) and middle."""
    q = float(quantile)
    lo, hi = _quantiles(pixels, q, 1.0 - q)
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo) / (1.0 - 2.0 * q)  # a uniform spread's ends
    return mid - half, mid + half, mid


def _quantiles(x: np.ndarray, q0: float, q1: float) -> tuple[np.ndarray, np.ndarray]:
    """``np.quantile(x, [q0, q1], axis=0)`` of finite ``x`` (N, K), N >= 1, as two (K,)
    arrays: the same numbers (numpy's "linear" method: the order statistics at the floor of
    ``(N - 1) q`` and the next, and its interpolation), from one partition and no more."""
    n = len(x)
    idx = []
    for q in (q0, q1):
        v = (n - 1) * q
        prev = int(math.floor(v))
        if v >= n - 1:
            prev = nxt = n - 1
        elif v < 0:
            prev = nxt = 0
        else:
            nxt = prev + 1
        idx.append((v, prev, nxt))
    part = np.partition(x, sorted({i for _, a, b in idx for i in (a, b)}), axis=0)
    out = []
    for v, prev, nxt in idx:
        a, b = part[prev], part[nxt]
        t = v - prev
        d = b - a
        out.append(b - d * (1 - t) if t >= 0.5 else a + d * t)  # numpy's _lerp
    return out[0], out[1]


def cuboid_boxes(camera: Camera, centres_m: np.ndarray, sizes_m: np.ndarray, across: np.ndarray,
                 along: np.ndarray) -> np.ndarray:
    """:func:`cuboid_box` of K cuboids (K, 3) at once: (K, 4), one projection."""
    c = np.asarray(centres_m, dtype=np.float64)
    corners = cuboid_corners(c, sizes_m, across, along).reshape(-1, 3)
    p = camera.project(corners).reshape(len(c), 8, 2)
    behind = ~camera.in_front(corners).reshape(len(c), 8).all(axis=1)
    lo, hi = p.min(axis=1), p.max(axis=1)
    out = np.concatenate([lo, hi - lo], axis=1)
    out[behind] = np.nan
    return out


def _clip_into(volume: Any, points: np.ndarray) -> np.ndarray:
    """Points (N, 3) moved into a cuboid along its own axes (the nearest inside point)."""
    local = volume.to_local(points)
    half = 0.5 * np.asarray(volume.size_m, dtype=np.float64)
    return volume.to_world(np.clip(local, -half, half))
