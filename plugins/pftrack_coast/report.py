"""Pictures of the block eigenspace model (PNG bytes, off-screen matplotlib): a frame with its
r_D map, its intruder blocks against the ground-truth mask, and the dimension D of each block.
Used by ``notebooks/04_block_eigenspace.ipynb``."""

from __future__ import annotations

import io

import numpy as np

from pftrack_coast.eigenspace import BlockEigenspaceModel, block_fractions

__all__ = ["dims_png", "frame_png"]


def _png(fig) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", dpi=100, bbox_inches="tight")
    finally:
        plt.close(fig)
    return buf.getvalue()


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
    return _png(fig)


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
    return _png(fig)
