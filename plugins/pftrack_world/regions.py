"""Reading many particle windows at once: cell means through an integral image, and pixel
samples on a regular grid. Both are vectorised over particles (no Python loop over boxes).

Boxes are (left, top, width, height) in pixels and may reach outside the image; cells and samples
that fall outside are flagged invalid rather than clamped to the border.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["cell_means", "check_region", "grid_samples", "integral_image"]


def check_region(region: Sequence[float] | None, owner: str) -> None:
    """Raise ValueError naming ``owner`` unless ``region`` is None or valid fractions."""
    if region is None:
        return
    r = tuple(float(v) for v in region)
    if len(r) != 4 or not (0 <= r[0] < r[2] <= 1 and 0 <= r[1] < r[3] <= 1):
        raise ValueError(f"{owner}: region must be fractions (fx0, fy0, fx1, fy1) with "
                         f"0 <= fx0 < fx1 <= 1 and 0 <= fy0 < fy1 <= 1, got {region!r}")


def integral_image(image: np.ndarray) -> np.ndarray:
    """Summed-area table (H+1, W+1) float64 of a single-channel image (cv2.integral)."""
    import cv2

    return cv2.integral(np.ascontiguousarray(image), sdepth=cv2.CV_64F)


def cell_means(integral: np.ndarray, boxes_xywh_px: np.ndarray,
               grid_wh: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """Mean image value over each cell of a ``gw x gh`` grid laid over each box.

    Cell edges are rounded to whole pixels and clipped to the image; the mean is the exact area
    average over the clipped cell (no aliasing however large the box is relative to the grid).
    Neighbouring cells share their edges, so one gather of the ``(gh + 1) x (gw + 1)`` corners
    per box serves every cell.

    Parameters
    ----------
    integral : ndarray, shape (H+1, W+1)
        :func:`integral_image` of the frame.
    boxes_xywh_px : ndarray, shape (N, 4)
    grid_wh : (int, int)
        Cells across and down.

    Returns
    -------
    means : ndarray, shape (N, gh, gw) float64
        0 where a cell is invalid.
    valid : ndarray, shape (N, gh, gw) bool
        False where the cell has no pixel inside the image (outside it, or narrower than a
        pixel once rounded).
    """
    gw, gh = int(grid_wh[0]), int(grid_wh[1])
    H, W = integral.shape[0] - 1, integral.shape[1] - 1
    b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    n = len(b)
    bad = ~np.all(np.isfinite(b), axis=1)
    if np.any(bad):
        b = np.where(bad[:, None], 0.0, b)
    xe = np.floor(b[:, 0:1] + b[:, 2:3] * (np.arange(gw + 1) / gw)[None, :] + 0.5)
    ye = np.floor(b[:, 1:2] + b[:, 3:4] * (np.arange(gh + 1) / gh)[None, :] + 0.5)
    xe = np.clip(xe, 0, W).astype(np.intp)  # (N, gw+1)
    ye = np.clip(ye, 0, H).astype(np.intp)  # (N, gh+1)
    flat = ye[:, :, None] * (W + 1) + xe[:, None, :]
    S = np.take(integral, flat)  # (N, gh+1, gw+1) corner sums
    s = S[:, 1:, 1:] - S[:, :-1, 1:] - S[:, 1:, :-1] + S[:, :-1, :-1]
    area = (np.diff(ye, axis=1)[:, :, None] * np.diff(xe, axis=1)[:, None, :])
    valid = area > 0
    if np.any(bad):
        valid &= ~bad[:, None, None]
    means = np.where(valid, s / np.maximum(area, 1), 0.0)
    return means.reshape(n, gh, gw), valid.reshape(n, gh, gw)


def grid_samples(image: np.ndarray, boxes_xywh_px: np.ndarray,
                 grid_wh: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """The pixel at the centre of each cell of a ``gw x gh`` grid over each box (nearest pixel).

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
    boxes_xywh_px : ndarray, shape (N, 4)
    grid_wh : (int, int)

    Returns
    -------
    values : ndarray, shape (N, gh * gw[, C]), the image's dtype (pixel (0, 0) where invalid)
    valid : ndarray, shape (N, gh * gw) bool
    """
    gw, gh = int(grid_wh[0]), int(grid_wh[1])
    H, W = image.shape[:2]
    b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    fx = (np.arange(gw) + 0.5) / gw
    fy = (np.arange(gh) + 0.5) / gh
    with np.errstate(invalid="ignore"):
        xs = np.floor(b[:, 0:1] + b[:, 2:3] * fx[None, :])  # (N, gw)
        ys = np.floor(b[:, 1:2] + b[:, 3:4] * fy[None, :])  # (N, gh)
    vx = np.isfinite(xs) & (xs >= 0) & (xs < W)
    vy = np.isfinite(ys) & (ys >= 0) & (ys < H)
    xi = np.where(vx, xs, 0).astype(np.intp)
    yi = np.where(vy, ys, 0).astype(np.intp)
    valid = (vy[:, :, None] & vx[:, None, :]).reshape(len(b), gh * gw)
    flat = (yi[:, :, None] * W + xi[:, None, :]).reshape(len(b), gh * gw)
    rest = image.shape[2:]
    vals = np.take(image.reshape((H * W,) + rest), flat, axis=0)
    return vals, valid
