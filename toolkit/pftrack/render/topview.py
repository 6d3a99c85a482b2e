"""Top view of the ground plane: a volume or pitch, trajectories by track id, particles.

The picture looks straight down the world z axis with a parallel projection, x to the right and
y up (world metres), with a metre grid and axis labels. Trajectories are coloured by track id
(:mod:`pftrack.render.colours`), the estimate solid, the ground truth dashed; each track starts
at a dot and ends at its id. Particles are points coloured by weight (viridis). The output is an
(H, W, 3) uint8 RGB image, and a PNG when ``out`` is given; the same input gives the same pixels.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pftrack.geometry.clouds import ParticleCloud
from pftrack.geometry.volumes import Volume
from pftrack.io.images import write_png
from pftrack.render import _layers
from pftrack.render._pyvista import plotter, polyline_cells, screenshot

__all__ = ["draw_legend", "nice_step", "render_topview"]


def draw_legend(image_rgb: np.ndarray, entries: Sequence[tuple[str, Sequence[int], str]],
                scale: float = 1.0) -> np.ndarray:
    """Draw a legend box in the lower-right corner, fully inside the picture (OpenCV).

    Parameters
    ----------
    image_rgb : ndarray, shape (H, W, 3), uint8
    entries : sequence of (label, (r, g, b), kind)
        ``kind`` is ``"line"``, ``"dash"`` or ``"dot"``.
    scale : float
        Size factor (1.0 for a 600 px picture).

    Returns
    -------
    ndarray, shape (H, W, 3), uint8
        A copy with the legend.
    """
    import cv2

    img = np.ascontiguousarray(image_rgb).copy()
    if not entries:
        return img
    h, w = img.shape[:2]
    font, fscale = cv2.FONT_HERSHEY_SIMPLEX, max(0.3, 0.42 * scale)
    thick = 1
    sizes = [cv2.getTextSize(lbl, font, fscale, thick)[0] for lbl, _, _ in entries]
    text_h = max(s[1] for s in sizes)
    row_h = round(text_h * 1.9)
    sym_w = round(22 * max(scale, 0.5))
    pad = max(3, round(5 * scale))
    box_w = min(w - 2, pad * 3 + sym_w + max(s[0] for s in sizes))
    box_h = min(h - 2, pad * 2 + row_h * len(entries))
    x1, y1 = w - 1 - pad, h - 1 - pad
    x0, y0 = max(0, x1 - box_w), max(0, y1 - box_h)
    region = img[y0:y1 + 1, x0:x1 + 1].astype(np.float64)
    img[y0:y1 + 1, x0:x1 + 1] = np.round(0.15 * region + 0.85 * 255).astype(np.uint8)
    cv2.rectangle(img, (x0, y0), (x1, y1), (120, 120, 120), 1)
    for k, (label, rgb, kind) in enumerate(entries):
        cy = y0 + pad + row_h * k + row_h // 2
        sx0, sx1 = x0 + pad, x0 + pad + sym_w
        colour = tuple(int(c) for c in rgb)
        lw = max(1, round(2 * scale))
        if kind == "dot":
            cv2.circle(img, ((sx0 + sx1) // 2, cy), max(2, lw + 1), colour, -1)
        elif kind == "dash":
            n = 3
            xs = np.linspace(sx0, sx1, 2 * n)
            for i in range(n):
                cv2.line(img, (int(xs[2 * i]), cy), (int(xs[2 * i + 1]), cy), colour, lw)
        else:
            cv2.line(img, (sx0, cy), (sx1, cy), colour, lw)
        cv2.putText(img, label, (sx1 + pad, cy + text_h // 2), font, fscale, (0, 0, 0), thick,
                    cv2.LINE_AA)
    return img


def nice_step(span: float, target_lines: int = 8) -> float:
    """A round grid spacing (1, 2 or 5 x 10^k) giving about ``target_lines`` lines over span."""
    raw = max(span, 1e-9) / max(target_lines, 1)
    k = np.floor(np.log10(raw))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10**k >= raw:
            return float(m * 10**k)
    return float(10 ** (k + 1))


def render_topview(
    out: str | os.PathLike[str] | None = None,
    *,
    tracks: dict[int, np.ndarray] | None = None,
    ground_truth: dict[int, np.ndarray] | None = None,
    volume: Volume | None = None,
    clouds: Sequence[ParticleCloud] = (),
    size_wh: tuple[int, int] = (1024, 768),
    title: str | None = None,
    bounds_m: np.ndarray | None = None,
    label_ids: bool = True,
    legend: bool = True,
    track_label: str = "estimate",
    ellipses: dict[int, tuple[np.ndarray, np.ndarray]] | None = None,
    ellipse_sd: float = 2.0,
) -> np.ndarray:
    """Render the ground plane seen from above.

    Parameters
    ----------
    out : path, optional
        PNG to write (atomically).
    tracks : dict of int to ndarray, shape (K, 3)
        Estimated trajectories, world metres (z is ignored in the picture), drawn solid.
    ground_truth : dict of int to ndarray, shape (K, 3), optional
        Ground-truth trajectories, drawn dashed in their ids' colours.
    volume : Volume, optional
        Drawn by its ground lines (pitch markings, or the footprint of a cuboid).
    clouds : sequence of ParticleCloud
        Particles, coloured by weight.
    size_wh : (int, int)
        Picture size in pixels.
    title : str, optional
    bounds_m : ndarray, shape (2, 2) or (2, 3), optional
        World x/y range to show; default: everything drawn, plus a margin.
    label_ids, legend : bool
        Write the id at each track's end; show the legend (estimate / ground truth / particles).
    track_label : str
        What the legend calls ``tracks`` (e.g. "ground truth" when only the truth is drawn).
    ellipses : dict of int to (ndarray (2,), ndarray (2, 2)), optional
        Per track id, a ground position (m) and its covariance (m^2)
        (:attr:`pftrack.Tracks.world_xy`, :attr:`pftrack.Tracks.world_cov`): drawn as
        ``ellipse_sd``-standard-deviation ellipses in the id's colour.
    ellipse_sd : float
        Standard deviations of the ellipses (2: 86 % of a Gaussian's mass). Unit: 1.

    Returns
    -------
    ndarray, shape (H, W, 3), uint8
        The picture, RGB.
    """
    tracks = tracks or {}
    ground_truth = ground_truth or {}
    ellipses = ellipses or {}
    outlines: dict[int, np.ndarray] = {}
    if ellipses:
        from pftrack.render.ellipses import covariance_ellipses

        eids = sorted(ellipses)
        ring = covariance_ellipses(np.array([ellipses[i][0] for i in eids]).reshape(-1, 2),
                                   np.array([ellipses[i][1] for i in eids]).reshape(-1, 2, 2),
                                   k=float(ellipse_sd))
        outlines = {i: np.column_stack([r, np.zeros(len(r))]) for i, r in zip(eids, ring)
                    if np.isfinite(r).all()}
    w_px, h_px = int(size_wh[0]), int(size_wh[1])
    scale = min(w_px, h_px) / 600.0  # line widths and fonts relative to a 600 px picture
    if bounds_m is None:
        b = _layers.gather_bounds(volume, list(tracks.values()) + list(ground_truth.values())
                                  + [c.points_world_m for c in clouds]
                                  + list(outlines.values()))
    else:
        b = np.asarray(bounds_m, dtype=np.float64)[:, :2]
        b = np.column_stack([b, [0.0, 0.0]])
    lo, hi = b[0, :2], b[1, :2]
    span = np.maximum(hi - lo, 1.0)
    step = nice_step(float(max(span)), 8)
    margin = 0.04 * span + step * 0.2
    # lay out in pixels: the framed data box, with fixed room (scaled with the picture) on the
    # left for the y labels, below for the x labels and the legend rows, above for the title
    n_legend = (bool(tracks) + bool(ground_truth) + bool(len(clouds)) + (volume is not None)
                + bool(outlines) if legend else 0)
    ls = max(scale, 0.7)  # fonts have a minimum size, so the label room does too
    left_px, right_px = 72 * ls, 12 * ls
    top_px = (32 if title else 12) * ls
    bottom_px = (44 * ls + (20 * n_legend + 8) * scale) if n_legend else 44 * ls
    box_lo, box_hi = lo - margin, hi + margin
    avail = np.array([w_px - left_px - right_px, h_px - top_px - bottom_px])
    if np.any(avail < 8):
        raise ValueError(f"render size {w_px}x{h_px} px is too small for the labels")
    mpp = float(max((box_hi - box_lo) / avail))  # metres per pixel, same on both axes
    box_c = (box_lo + box_hi) / 2
    centre = np.array([box_c[0] - (left_px - right_px) / 2 * mpp,
                       box_c[1] + (top_px - bottom_px) / 2 * mpp])
    parallel_scale = h_px / 2 * mpp

    with plotter((w_px, h_px)) as p:
        # grid every `step` metres over the data range
        gx = np.arange(np.ceil((lo[0] - margin[0]) / step), np.floor((hi[0] + margin[0]) / step)
                       + 1) * step
        gy = np.arange(np.ceil((lo[1] - margin[1]) / step), np.floor((hi[1] + margin[1]) / step)
                       + 1) * step
        y0, y1 = lo[1] - margin[1], hi[1] + margin[1]
        x0, x1 = lo[0] - margin[0], hi[0] + margin[0]
        grid = [np.array([[x, y0, -0.05], [x, y1, -0.05]]) for x in gx] + \
               [np.array([[x0, y, -0.05], [x1, y, -0.05]]) for y in gy]
        gmesh = polyline_cells(grid)
        _layers.add_lines(p, gmesh, np.full((gmesh.n_cells, 3), 225, np.uint8), 1.0)
        frame = polyline_cells([np.array([[x0, y0, -0.04], [x1, y0, -0.04], [x1, y1, -0.04],
                                          [x0, y1, -0.04], [x0, y0, -0.04]])])
        _layers.add_lines(p, frame, np.full((1, 3), 120, np.uint8), 1.0)
        fs = max(7, round(11 * scale))
        if len(gx):
            p.add_point_labels(np.column_stack([gx, np.full(len(gx), y0 - 16 * ls * mpp),
                                                np.zeros(len(gx))]),
                               [f"{v:g}" for v in gx], font_size=fs, bold=False, shape=None,
                               show_points=False, text_color="black", always_visible=True,
                               justification_horizontal="center")
        if len(gy):
            p.add_point_labels(np.column_stack([np.full(len(gy), x0 - 5 * ls * mpp), gy,
                                                np.zeros(len(gy))]),
                               [f"{v:g}" for v in gy], font_size=fs, bold=False, shape=None,
                               show_points=False, text_color="black", always_visible=True,
                               justification_horizontal="right",
                               justification_vertical="center")
        p.add_point_labels(np.array([[(x0 + x1) / 2, y0 - 36 * ls * mpp, 0.0]]),
                           ["x (m)"], font_size=fs + 1, bold=True, shape=None, show_points=False,
                           text_color="black", always_visible=True,
                           justification_horizontal="center")
        ylab_x = max(centre[0] + (22 * ls - w_px / 2) * mpp, x0 - 50 * ls * mpp)
        p.add_point_labels(np.array([[ylab_x, (y0 + y1) / 2, 0.0]]),
                           ["y (m)"], font_size=fs + 1, bold=True, shape=None, show_points=False,
                           text_color="black", always_visible=True,
                           justification_horizontal="center", justification_vertical="center")

        # everything drawn in world coordinates from here on is cut to the framed box, so a
        # zoomed view (bounds_m) does not spill over the axis labels and the legend
        box_xy = np.array([[x0, y0], [x1, y1]])
        data_from = set(p.renderer.actors)
        if volume is not None:
            _layers.add_ground_lines(p, volume, width=max(1.0, 2.0 * scale), z=0.0)
        _layers.add_clouds(p, list(clouds), point_size=max(2.0, 3.0 * scale), flatten_z=0.01)
        _layers.add_tracks(p, ground_truth, width=max(1.0, 2.0 * scale), z=0.02,
                           dashed=0.012 * float(max(span)))
        _layers.add_tracks(p, tracks, width=max(1.5, 2.5 * scale), z=0.03)
        _layers.add_tracks(p, outlines, width=max(1.0, 1.5 * scale), z=0.04)
        if label_ids:
            _layers.add_track_ends(p, tracks if tracks else ground_truth, z=0.05,
                                   font_size=max(7, round(10 * scale)),
                                   point_size=max(3.0, 6.0 * scale), box_xy=box_xy)
        _layers.clip_new_actors(p, data_from, box_xy)
        if title:
            p.add_text(title, position="upper_edge", font_size=max(6, round(9 * scale)),
                       color="black")
        cam = p.camera
        cam.parallel_projection = True
        cam.focal_point = (float(centre[0]), float(centre[1]), 0.0)
        cam.position = (float(centre[0]), float(centre[1]), 1000.0)
        cam.up = (0.0, 1.0, 0.0)
        cam.parallel_scale = parallel_scale
        cam.clipping_range = (1.0, 2000.0)
        img = screenshot(p)
    if legend:
        entries = []
        if tracks:
            entries.append((f"{track_label} (solid, colour = id)", (0, 0, 0), "line"))
        if ground_truth:
            entries.append(("ground truth (dashed)", (128, 128, 128), "dash"))
        if len(clouds):
            entries.append(("particles (viridis = weight)", (33, 145, 140), "dot"))
        if volume is not None:
            entries.append((str(volume.name), _layers.MARKING_RGB, "line"))
        if outlines:
            entries.append((f"{ellipse_sd:g} sd of the position (colour = id)", (0, 0, 0),
                            "line"))
        img = draw_legend(img, entries, scale)
    if out is not None:
        write_png(Path(out), img[:, :, ::-1])
    return img
