"""A 3D view of volumes and particle clouds (pyvista, off-screen, deterministic).

The camera is fixed by the scene's bounds: it looks at the centre of everything drawn from a
direction given by ``azimuth_deg`` / ``elevation_deg`` (degrees; azimuth from the world +x axis
towards +y, elevation above the ground plane) at a distance that fits the bounds, z up. The same
input gives the same pixels. Volumes are drawn by their edges (grey) and ground lines (green),
particles as points coloured by weight (viridis), trajectories on the ground in their ids'
colours, and cameras as frusta (dark red): the centre, the rays through the four image corners
down to the ground (or to ``frustum_far_m``), and the image border's footprint on the ground.
Axes are labelled in metres.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pftrack.geometry.camera import Camera
from pftrack.geometry.clouds import ParticleCloud
from pftrack.geometry.volumes import Volume
from pftrack.io.images import write_png
from pftrack.render import _layers
from pftrack.render._pyvista import (
    plotter,
    polyline_cells,
    pv,
    screenshot,
    segment_cells,
)

__all__ = ["camera_frustum", "render_view3d"]

#: Camera frusta (RGB): dark red.
CAMERA_RGB = (170, 30, 30)


def camera_frustum(camera: Camera, far_m: float, border_step_px: float = 8.0
                   ) -> tuple[np.ndarray, list[np.ndarray]]:
    """Line geometry of a camera's view, world metres.

    Parameters
    ----------
    camera : Camera
    far_m : float
        Rays that miss the ground (z = 0) within this distance stop there.
    border_step_px : float
        Sampling step along the image border for the ground footprint (pixels).

    Returns
    -------
    segments : ndarray, shape (8, 2, 3)
        The four corner rays (centre -> ground or far point) and the image rectangle drawn at
        5 % of ``far_m`` in front of the centre.
    footprint : list of ndarray, shape (K, 3)
        The image border back-projected onto the ground, broken where it misses the ground or
        lies beyond ``far_m`` (lens distortion bends it).
    """
    w, h = camera.image_size
    corners = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
    origin, dirs = camera.rays(corners)
    c = origin[0]
    ground = camera.image_to_ground(corners)
    dist = np.linalg.norm(ground - c, axis=1)
    hit = np.all(np.isfinite(ground), axis=1) & (dist <= far_m)
    ends = np.where(hit[:, None], ground, c + far_m * dirs)
    near = c + 0.05 * far_m * dirs
    rays = np.stack([np.broadcast_to(c, ends.shape), ends], axis=1)
    rect = np.stack([near, np.roll(near, -1, axis=0)], axis=1)
    # image border, clockwise from the top-left corner, then back-projected
    n_u = max(2, int(np.ceil(w / border_step_px)) + 1)
    n_v = max(2, int(np.ceil(h / border_step_px)) + 1)
    u = np.linspace(-0.5, w - 0.5, n_u)
    v = np.linspace(-0.5, h - 0.5, n_v)
    border = np.vstack([np.column_stack([u, np.full(n_u, -0.5)]),
                        np.column_stack([np.full(n_v, w - 0.5), v]),
                        np.column_stack([u[::-1], np.full(n_u, h - 0.5)]),
                        np.column_stack([np.full(n_v, -0.5), v[::-1]])])
    g = camera.image_to_ground(border)
    ok = np.all(np.isfinite(g), axis=1)
    ok[ok] = np.linalg.norm(g[ok] - c, axis=1) <= far_m
    # split into runs of valid points
    start = ok & ~np.concatenate([[False], ok[:-1]])
    run = np.cumsum(start) - 1
    idx = np.flatnonzero(ok)
    pieces = np.split(g[idx], np.flatnonzero(np.diff(run[idx])) + 1) if len(idx) else []
    return np.concatenate([rays, rect]), [pc for pc in pieces if len(pc) >= 2]


def render_view3d(
    out: str | os.PathLike[str] | None = None,
    *,
    volumes: Sequence[Volume] = (),
    clouds: Sequence[ParticleCloud] = (),
    tracks: dict[int, np.ndarray] | None = None,
    cameras: Sequence[Camera] = (),
    frustum_far_m: float | None = None,
    axes: bool = True,
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
    tracks : dict of int to ndarray, shape (K, 3), optional
        Trajectories (world metres) drawn as lines in their ids' colours.
    cameras : sequence of Camera
        Drawn as frusta (see :func:`camera_frustum`).
    frustum_far_m : float, optional
        How far corner rays that miss the ground are drawn; default twice the distance from the
        first camera to the centre of everything else drawn (50 m when nothing else is). The
        view is framed on the content, the camera centres and the ground footprints, not on
        rays that go off into the sky.
    axes : bool
        Labelled axes (metres) around the scene's bounds.
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
    volumes, clouds, cameras = list(volumes), list(clouds), list(cameras)
    tracks = tracks or {}
    if not volumes and not any(len(c) for c in clouds) and not tracks and not cameras:
        raise ValueError("render_view3d: nothing to draw (no volumes, particles, tracks or "
                         "cameras)")
    content = [v.bounds() for v in volumes] + [c.points_world_m for c in clouds] + \
        [np.asarray(t, float).reshape(-1, 3) for t in tracks.values()]
    frusta = []
    if cameras:
        if frustum_far_m is None:
            if any(np.size(g) for g in content):
                mid = _layers.gather_bounds(None, content).mean(axis=0)
                frustum_far_m = 2.0 * float(np.linalg.norm(cameras[0].center_m - mid))
            else:
                frustum_far_m = 50.0
        framed = []
        for cam_ in cameras:
            segs, foot = camera_frustum(cam_, float(frustum_far_m))
            frusta.append((segs, foot))
            ends = segs[:4, 1]
            framed += [cam_.center_m[None, :], ends[np.abs(ends[:, 2]) < 1e-6]] + foot
        content += framed
    b = _layers.gather_bounds(None, content)
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
        _layers.add_tracks(p, tracks, width=max(1.0, 2.0 * scale), z=0.0)
        for segs, foot in frusta:
            width = max(1.0, 1.5 * scale)
            mesh = segment_cells(segs)
            _layers.add_lines(p, mesh, np.tile(np.array(CAMERA_RGB, np.uint8), (mesh.n_cells, 1)),
                              width)
            fmesh = polyline_cells(foot)
            _layers.add_lines(p, fmesh,
                              np.tile(np.array(CAMERA_RGB, np.uint8), (fmesh.n_cells, 1)), width)
            centre_pt = pv.PolyData(segs[0, 0][None, :])
            p.add_mesh(centre_pt, color=CAMERA_RGB, point_size=max(4.0, 8.0 * scale),
                       render_points_as_spheres=True, lighting=False)
        if axes:
            p.show_bounds(bounds=[float(b[0, 0]), float(b[1, 0]), float(b[0, 1]),  # type: ignore[call-arg]
                                  float(b[1, 1]), float(b[0, 2]), float(b[1, 2])],
                          xtitle="x (m)", ytitle="y (m)", ztitle="z (m)", grid=None,
                          location="outer", color="black", font_size=max(8, round(12 * scale)),
                          n_xlabels=4, n_ylabels=4, n_zlabels=3, fmt="%.0f",
                          use_2d=True, use_3d_text=False)
        if title:
            p.add_text(title, position="upper_edge", font_size=max(6, round(9 * scale)),
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
        write_png(Path(out), img[:, :, ::-1])
    return img
