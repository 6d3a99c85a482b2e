"""Drawing layers shared by the top view and the 3D view (pyvista meshes from geometry)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pftrack.geometry.clouds import ParticleCloud
from pftrack.geometry.volumes import Volume
from pftrack.render._pyvista import polyline_cells, pv, segment_cells
from pftrack.render.colours import track_colours_rgb
from pftrack.render.tracks import dashed_segments

MARKING_RGB = (70, 140, 70)  # field lines / footprint: muted green
VOLUME_EDGE_RGB = (90, 90, 90)


def _uniform_rgb(n: int, rgb: Sequence[int]) -> np.ndarray:
    return np.tile(np.asarray(rgb, dtype=np.uint8), (n, 1))


def add_lines(p: pv.Plotter, mesh: pv.PolyData, cell_rgb: np.ndarray, width: float) -> None:
    if mesh.n_points == 0:
        return
    mesh.cell_data["rgb"] = np.asarray(cell_rgb, dtype=np.uint8)
    p.add_mesh(mesh, scalars="rgb", rgb=True, line_width=width, lighting=False,
               show_scalar_bar=False)


def add_ground_lines(p: pv.Plotter, volume: Volume, width: float, z: float = 0.0) -> None:
    lines = [pl + [0.0, 0.0, z] for pl in volume.ground_lines().values()]
    mesh = polyline_cells(lines)
    add_lines(p, mesh, _uniform_rgb(mesh.n_cells, MARKING_RGB), width)


def add_volume_edges(p: pv.Plotter, volume: Volume, width: float) -> None:
    mesh = segment_cells(volume.edges())
    add_lines(p, mesh, _uniform_rgb(mesh.n_cells, VOLUME_EDGE_RGB), width)


def add_tracks(p: pv.Plotter, tracks: dict[int, np.ndarray], width: float, z: float,
               dashed: float | None = None) -> None:
    """Tracks coloured by id; solid polylines, or dashes of length ``dashed`` metres."""
    ids = sorted(tracks)
    if not ids:
        return
    colours = track_colours_rgb(np.array(ids))
    if dashed is None:
        lines = [np.asarray(tracks[i], float).reshape(-1, 3) + [0, 0, z] for i in ids]
        keep = [len(pl) >= 2 for pl in lines]
        mesh = polyline_cells(lines)
        add_lines(p, mesh, colours[np.array(keep)], width)
    else:
        segs = [dashed_segments(np.asarray(tracks[i], float).reshape(-1, 3) + [0, 0, z],
                                dashed) for i in ids]
        counts = np.array([len(s) for s in segs])
        mesh = segment_cells(np.concatenate(segs) if counts.sum() else np.zeros((0, 2, 3)))
        add_lines(p, mesh, np.repeat(colours, counts, axis=0), width)


def add_track_ends(p: pv.Plotter, tracks: dict[int, np.ndarray], z: float, font_size: int,
                   point_size: float, box_xy: np.ndarray | None = None) -> None:
    """A dot at each track's start and its id at its end.

    ``box_xy`` (shape (2, 2): [[x0, y0], [x1, y1]] metres) drops the id labels whose end lies
    outside the shown box (labels are 2D overlays, which clipping planes do not cut).
    """
    ids = [i for i in sorted(tracks) if len(tracks[i])]
    if not ids:
        return
    starts = np.array([np.asarray(tracks[i], float).reshape(-1, 3)[0] for i in ids]) + [0, 0, z]
    ends = np.array([np.asarray(tracks[i], float).reshape(-1, 3)[-1] for i in ids]) + [0, 0, z]
    dots = pv.PolyData(starts)
    dots.point_data["rgb"] = track_colours_rgb(np.array(ids))
    p.add_mesh(dots, scalars="rgb", rgb=True, point_size=point_size, lighting=False,
               render_points_as_spheres=False, show_scalar_bar=False)
    if box_xy is not None:
        inside = np.all((ends[:, :2] >= box_xy[0]) & (ends[:, :2] <= box_xy[1]), axis=1)
        ends, ids = ends[inside], [i for i, k in zip(ids, inside) if k]
    if len(ids):
        p.add_point_labels(ends, [str(i) for i in ids], font_size=font_size, bold=True,
                           text_color="black", shape=None, show_points=False,
                           always_visible=True)


def clip_new_actors(p: pv.Plotter, before: set[str], box_xy: np.ndarray) -> None:
    """Cut every 3D actor added since ``before`` (the renderer's actor names) to the box
    ``[[x0, y0], [x1, y1]]`` in world metres, with four VTK clipping planes on its mapper."""
    import vtk

    planes = []
    for origin, normal in (((box_xy[0, 0], 0, 0), (1, 0, 0)), ((box_xy[1, 0], 0, 0), (-1, 0, 0)),
                           ((0, box_xy[0, 1], 0), (0, 1, 0)), ((0, box_xy[1, 1], 0), (0, -1, 0))):
        plane = vtk.vtkPlane()
        plane.SetOrigin(*map(float, origin))
        plane.SetNormal(*map(float, normal))
        planes.append(plane)
    for name, actor in p.renderer.actors.items():
        if name in before:
            continue
        mapper = actor.GetMapper() if hasattr(actor, "GetMapper") else None
        if mapper is not None and hasattr(mapper, "AddClippingPlane"):
            for plane in planes:
                mapper.AddClippingPlane(plane)


def add_clouds(p: pv.Plotter, clouds: Sequence[ParticleCloud], point_size: float,
               flatten_z: float | None = None) -> None:
    """Particles coloured by weight (viridis, scaled by the largest weight of all clouds)."""
    clouds = [c for c in clouds if len(c)]
    if not clouds:
        return
    vmax = max(float(c.weights.max()) for c in clouds)  # type: ignore[union-attr]
    pts = np.vstack([c.points_world_m for c in clouds]).copy()
    rgb = np.vstack([c.colours(vmax) for c in clouds])
    if flatten_z is not None:
        pts[:, 2] = flatten_z
    # draw light particles first so the heavy ones end on top
    order = np.argsort(np.concatenate([c.weights for c in clouds]), kind="stable")
    mesh = pv.PolyData(pts[order])
    mesh.point_data["rgb"] = rgb[order]
    p.add_mesh(mesh, scalars="rgb", rgb=True, point_size=point_size, lighting=False,
               render_points_as_spheres=False, show_scalar_bar=False)


def gather_bounds(volume: Volume | None, groups: Sequence[np.ndarray]) -> np.ndarray:
    """Axis-aligned bounds (2, 3) of the volume's ground lines/edges and point groups."""
    parts = [np.asarray(g, float).reshape(-1, 3) for g in groups if np.size(g)]
    if volume is not None:
        parts.append(volume.bounds())
        parts += [pl for pl in volume.ground_lines().values()]
    if not parts:
        return np.array([[-1.0, -1.0, 0.0], [1.0, 1.0, 0.0]])
    allp = np.vstack(parts)
    allp = allp[np.all(np.isfinite(allp), axis=1)]
    return np.stack([allp.min(axis=0), allp.max(axis=0)])
