"""A 3D view of volumes and particle clouds (pyvista, off-screen, deterministic).

The camera is fixed by the scene's bounds: it looks at the centre of everything drawn from a
direction given by ``azimuth_deg`` / ``elevation_deg`` (degrees; azimuth from the world +x axis
towards +y, elevation above the ground plane) at a distance that fits the bounds, z up. The same
input gives the same pixels. Volumes are drawn by their edges (grey) and ground lines (green),
particles as points coloured by weight (viridis).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pftrack.geometry.clouds import ParticleCloud
from pftrack.geometry.volumes import Volume
from pftrack.render import _layers
from pftrack.render._pyvista import plotter, screenshot, write_png

__all__ = ["render_view3d"]


def render_view3d(
    out: str | os.PathLike[str] | None = None,
    *,
    volumes: Sequence[Volume] = (),
    clouds: Sequence[ParticleCloud] = (),
    size_wh: tuple[int, int] = (800, 600),
    azimuth_deg: float = -60.0,
    elevation_deg: float = 30.0,
    title: str | None = None,
    point_size: float = 3.0,
) -> np.ndarray:
    """Render volumes and particle clouds in perspective from a fixed viewpoint.

    Parameters
    ----------
    out : path, optional
        PNG to write (atomically).
    volumes : sequence of Volume
        World metres.
    clouds : sequence of ParticleCloud
        World metres, coloured by weight.
    size_wh : (int, int)
        Picture size, pixels.
    azimuth_deg, elevation_deg : float
        Viewing direction (from the scene centre towards the camera), degrees.
    title : str, optional
    point_size : float
        Particle size, pixels.

    Returns
    -------
    ndarray, shape (H, W, 3), uint8
        The picture, RGB.
    """
    volumes, clouds = list(volumes), list(clouds)
    if not volumes and not any(len(c) for c in clouds):
        raise ValueError("render_view3d: nothing to draw (no volumes, no particles)")
    b = _layers.gather_bounds(None, [v.bounds() for v in volumes]
                              + [c.points_world_m for c in clouds])
    centre = b.mean(axis=0)
    radius = max(float(np.linalg.norm(b[1] - b[0])) / 2.0, 1e-3)
    az, el = np.deg2rad(azimuth_deg), np.deg2rad(elevation_deg)
    direction = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    view_angle = 30.0
    dist = radius / np.sin(np.deg2rad(view_angle) / 2) * 1.05
    w_px, h_px = int(size_wh[0]), int(size_wh[1])
    scale = min(w_px, h_px) / 600.0
    with plotter((w_px, h_px)) as p:
        for v in volumes:
            _layers.add_ground_lines(p, v, width=max(1.0, 1.5 * scale))
            _layers.add_volume_edges(p, v, width=max(1.0, 2.0 * scale))
        _layers.add_clouds(p, clouds, point_size=max(1.0, point_size * scale))
        if title:
            p.add_text(title, position="upper_edge", font_size=max(6, int(round(9 * scale))),
                       color="black")
        cam = p.camera
        cam.parallel_projection = False
        cam.view_angle = view_angle
        cam.focal_point = tuple(float(c) for c in centre)
        cam.position = tuple(float(c) for c in centre + dist * direction)
        cam.up = (0.0, 0.0, 1.0)
        cam.clipping_range = (max(dist - 2 * radius, dist * 1e-3), dist + 2 * radius)
        img = screenshot(p)
    if out is not None:
        write_png(Path(out), img)
    return img
