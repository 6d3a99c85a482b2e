"""Pictures of the block eigenspace model (PNG bytes, off-screen matplotlib): a frame with its
r_D map, its intruder blocks against the ground-truth mask, and the dimension D of each block.
Used by ``notebooks/04_block_eigenspace.ipynb``."""

from __future__ import annotations

import numpy as np
from pftrack.io.images import figure_png

from pftrack_coast.eigenspace import BlockEigenspaceModel, block_fractions

__all__ = ["dims_png", "frame_png", "intruders_image"]


def frame_png(model: BlockEigenspaceModel, image: np.ndarray, truth: np.ndarray | None = None,
              title: str = "") -> bytes:
    """Three panels: the frame; log10(1 + r_D) per block; the intruder blocks (red) over the
    ground-truth blocks (at least a quarter foreground, green; yellow where both)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    res = model.score(image)
    grey = model.grey(image) if model.frame_offset == "none" else image
    fig, ax = plt.subplots(1, 3, figsize=(13, 3.6), constrained_layout=True)
    ax[0].imshow(grey, cmap="gray")
    ax[0].set_title(f"{title} frame".strip())
    im = ax[1].imshow(np.log10(1.0 + res.r_map), cmap="magma")
    ax[1].set_title("log10(1 + r_D) per block")
    fig.colorbar(im, ax=ax[1], fraction=0.046)
    rgb = np.zeros(res.intruder_mask.shape + (3,))
    rgb[..., 0] = res.intruder_mask
    if truth is not None:
        gt = block_fractions(truth, int(model.block_size)) >= 0.25
        rgb[..., 1] = gt[: rgb.shape[0], : rgb.shape[1]]
    ax[2].imshow(rgb)
    ax[2].set_title("found (red), truth (green), both (yellow)")
    for a in ax:
        a.set_xticks([])
        a.set_yticks([])
    return figure_png(fig, dpi=100, tight=True)


def dims_png(model: BlockEigenspaceModel, title: str = "") -> bytes:
    """The eigenspace dimension D of each block (eq. 1); blocks borrowing a neighbour's
    eigenspace are outlined."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    rows, cols = model.grid_shape_
    d = model.dims_.reshape(rows, cols)
    fig, ax = plt.subplots(figsize=(5, 5 * rows / max(cols, 1) + 0.6))
    im = ax.imshow(d, cmap="viridis")
    fig.colorbar(im, ax=ax, fraction=0.046, label="D")
    borrowed = (model.source_ != np.arange(rows * cols)).reshape(rows, cols)
    ys, xs = np.nonzero(borrowed)
    ax.scatter(xs, ys, s=6, c="red", marker="s", label="borrowed eigenspace")
    if len(xs):
        ax.legend(loc="lower right", fontsize=7)
    ax.set_title(f"{title} eigenspace dimension D per block".strip())
    ax.set_xticks([])
    ax.set_yticks([])
    return figure_png(fig, dpi=100, tight=True)


def intruders_image(image_bgr: np.ndarray, camera, volumes, engine, estimates,
                    frame_index: int, *, groups: bool = True) -> np.ndarray:
    """The coastal paper's figures 2-3 on a frame: the volumes (yellow), each track's particles
    (white), the detection groups' particles (red, ``groups``), each estimate's corrected cuboid
    projected (green) with its id. ``estimates`` is :attr:`VolumeTracks.estimates_`;
    ``engine`` the engine right after ``frame_index`` was tracked. Returns a BGR copy."""
    import cv2
    from pftrack.render.overlay import draw_points, draw_volume, draw_world_polylines

    img = np.ascontiguousarray(image_bgr).copy()
    for v in volumes:
        img = draw_volume(img, camera, v, ground_lines=False, thickness=1)
    tracks = engine.tracks
    for t in engine.targets:
        is_group = t.id in tracks.groups_
        if is_group and not groups:
            continue
        px = camera.project(t.particles[:, :3])
        colour = np.array([[0, 0, 255]] if is_group else [[255, 255, 255]], np.uint8)
        img = draw_points(img, px[::2], np.repeat(colour, len(px[::2]), axis=0), 1)
    for e in estimates:
        if e["frame"] != frame_index or "size_m" not in e:
            continue
        from pftrack.geometry.volumes import _BOX_EDGES

        from pftrack_coast.volume_geometry import _axes, cuboid_corners

        across, along = _axes(camera, e["footprint_m"][:2])
        centre = e["footprint_m"] + np.array([0.0, 0.0, 0.5 * e["size_m"][1]])
        corners = cuboid_corners(centre[None], e["size_m"][None], across, along)[0]
        img = draw_world_polylines(img, camera, list(corners[_BOX_EDGES]), (0, 255, 0), 2,
                                   step_m=0.05)
        u, v = camera.project(centre[None] + np.array([[0, 0, 0.5 * e["size_m"][1]]]))[0]
        if np.isfinite(u):
            cv2.putText(img, str(e["id"]), (int(u) - 6, int(v) - 4), cv2.FONT_HERSHEY_SIMPLEX,
                        0.5, (0, 255, 0), 1, cv2.LINE_AA)
    return img
