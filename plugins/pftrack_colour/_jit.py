"""Compiled (numba) kernels for the cross-entropy likelihoods' common case.

The numpy/OpenCV path of :mod:`pftrack_colour.likelihoods` makes some forty array calls per
target and frame (crop, split, three look-up tables, a gather, patches for other targets'
boxes, an integral image, a four-corner gather). At a few hundred particles per target those
calls, not the pixels, are the cost. Each kernel here does one target's (or the background's)
whole pass over its pixels in one call and returns the same numbers bit for bit: the same
bin formula, the same float32 per-pixel values, the integral image summed in float64 in the
order ``cv2.integral`` sums it, the box sums combined in the order
:meth:`~pftrack_colour.histograms.ParticleRegion.box_sums` combines them. The tests check the
equality against the numpy path.

The kernels cover same-size boxes wholly inside the image, with other targets' stripes that do
not overlap each other (per-pair tables); everything else takes the numpy path. They are
compiled on first use and cached on disk (``cache=True``); set ``PFTRACK_NO_JIT=1`` to use the
numpy path everywhere. numba is imported on first use, not when the plugin loads.
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["ENABLED", "fixed_layout", "grid_histogram", "value_box_sums", "warm_up"]

#: False when ``PFTRACK_NO_JIT`` is set: every likelihood then takes its numpy path.
ENABLED = os.environ.get("PFTRACK_NO_JIT", "").strip().lower() not in ("1", "true", "yes")


def _fixed_layout(boxes_xywh, img_w, img_h):  # pragma: no cover - compiled
    """Same-size boxes wholly inside the image, laid out as
    :class:`~pftrack_colour.histograms.ParticleRegion` lays them out (each coordinate rounded
    half up, ``floor(v + 0.5)``; the region is the boxes' bounding rectangle).

    Returns ``(ok, x0, y0, x1, y1, bw, bh, xs, ys)``: ``ok`` False when the boxes are not all
    of one size, not all inside the image, not finite, or there are none; else the region
    (image pixels, end exclusive), the box size and each box's top-left corner in region
    pixels, (N,) int64.
    """
    n = boxes_xywh.shape[0]
    xs = np.empty(n, np.int64)
    ys = np.empty(n, np.int64)
    if n == 0:
        return False, 0, 0, 0, 0, 0, 0, xs, ys
    w0 = np.floor(boxes_xywh[0, 2] + 0.5)
    h0 = np.floor(boxes_xywh[0, 3] + 0.5)
    if not (abs(w0) < 1e9 and abs(h0) < 1e9):  # False for NaN too
        return False, 0, 0, 0, 0, 0, 0, xs, ys
    lo_x = lo_y = 1e300
    hi_x = hi_y = -1e300
    for i in range(n):
        x = np.floor(boxes_xywh[i, 0] + 0.5)
        y = np.floor(boxes_xywh[i, 1] + 0.5)
        if not (abs(x) < 1e9 and abs(y) < 1e9):
            return False, 0, 0, 0, 0, 0, 0, xs, ys
        if np.floor(boxes_xywh[i, 2] + 0.5) != w0 or np.floor(boxes_xywh[i, 3] + 0.5) != h0:
            return False, 0, 0, 0, 0, 0, 0, xs, ys
        lo_x = min(lo_x, x)
        lo_y = min(lo_y, y)
        hi_x = max(hi_x, x)
        hi_y = max(hi_y, y)
        xs[i] = np.int64(x)
        ys[i] = np.int64(y)
    bw = max(1, np.int64(w0))
    bh = max(1, np.int64(h0))
    x0, y0 = np.int64(lo_x), np.int64(lo_y)
    x1, y1 = np.int64(hi_x) + bw, np.int64(hi_y) + bh
    if x0 < 0 or y0 < 0 or x1 > img_w or y1 > img_h:
        return False, 0, 0, 0, 0, 0, 0, xs, ys
    for i in range(n):
        xs[i] -= x0
        ys[i] -= y0
    return True, x0, y0, x1, y1, bw, bh, xs, ys


def _value_box_sums(region_bgr, lut0, lut1, lut2, table, ov_rects, ov_tables, xs, ys, oy, sh,
                   bw):  # pragma: no cover - compiled
    """Sums over same-size boxes of a per-pixel value looked up by colour bin.

    Parameters
    ----------
    region_bgr : (rows, cols, 3) uint8
        The pixels the boxes cover (any strides).
    lut0, lut1, lut2 : (256,) int
        Per image channel, the channel value's share of the bin index (their sum is the bin).
    table : (m,) float32
        Value of a pixel by its bin.
    ov_rects : (K, 4) int64
        Rectangles ``(x0, y0, x1, y1)`` in region pixels, pairwise disjoint, whose pixels take
        their value from ``ov_tables[k]`` instead.
    ov_tables : (K, m) float32
    xs, ys : (N,) int64
        Each box's top-left corner in region pixels.
    oy, sh, bw : int
        Sum over rows ``oy`` to ``oy + sh`` of each box and its ``bw`` columns.

    Returns
    -------
    (N,) float64
    """
    rows, cols = region_bgr.shape[0], region_bgr.shape[1]
    ii = np.empty((rows + 1, cols + 1), np.float64)
    for x in range(cols + 1):
        ii[0, x] = 0.0
    bins = np.empty(cols, np.int64)
    vals = np.empty(cols, np.float32)
    n_ov = ov_rects.shape[0]
    for y in range(rows):
        for x in range(cols):
            b = (np.int64(lut0[region_bgr[y, x, 0]]) + np.int64(lut1[region_bgr[y, x, 1]])
                 + np.int64(lut2[region_bgr[y, x, 2]]))
            bins[x] = b
            vals[x] = table[b]
        for k in range(n_ov):
            if ov_rects[k, 1] <= y < ov_rects[k, 3]:
                for x in range(ov_rects[k, 0], ov_rects[k, 2]):
                    vals[x] = ov_tables[k, bins[x]]
        # cv2.integral's order: a running row sum added to the row above
        s = 0.0
        ii[y + 1, 0] = 0.0
        for x in range(cols):
            s += np.float64(vals[x])
            ii[y + 1, x + 1] = ii[y, x + 1] + s
    n = xs.shape[0]
    out = np.empty(n, np.float64)
    for i in range(n):
        x0 = xs[i]
        y0 = ys[i] + oy
        out[i] = ((ii[y0 + sh, x0 + bw] - ii[y0, x0 + bw]) - ii[y0 + sh, x0]) + ii[y0, x0]
    return out


def _grid_histogram(image_bgr, stride, lut0, lut1, lut2, grid_rects, n_bins
                   ):  # pragma: no cover - compiled
    """Bin counts of every ``stride``-th pixel in each direction (from (0, 0)) outside the
    rectangles ``grid_rects`` ((K, 4) ``(gx0, gy0, gx1, gy1)``, end exclusive, in grid
    coordinates: grid cell (gx, gy) is image pixel (gx * stride, gy * stride)).

    Returns (n_bins,) float64 counts.
    """
    h, w = image_bgr.shape[0], image_bgr.shape[1]
    counts = np.zeros(n_bins, np.int64)
    n_rects = grid_rects.shape[0]
    gw = (w + stride - 1) // stride
    skip = np.zeros(gw, np.bool_)
    for gy in range((h + stride - 1) // stride):
        row = image_bgr[gy * stride]
        masked = False
        for k in range(n_rects):
            if grid_rects[k, 1] <= gy < grid_rects[k, 3]:
                if not masked:
                    skip[:] = False
                    masked = True
                for gx in range(max(grid_rects[k, 0], 0), min(grid_rects[k, 2], gw)):
                    skip[gx] = True
        for gx in range(gw):
            if not (masked and skip[gx]):
                x = gx * stride
                counts[lut0[row[x, 0]] + lut1[row[x, 1]] + lut2[row[x, 2]]] += 1
    return counts.astype(np.float64)


def _compiled(name: str):
    fn = _kernels.get(name)
    if fn is None:
        from numba import njit  # imported here: half a second that plugin listing need not pay

        fn = _kernels[name] = njit(cache=True, nogil=True)(globals()["_" + name])
    return fn


def value_box_sums(*args):
    """Compiled :func:`_value_box_sums` (see there)."""
    return _compiled("value_box_sums")(*args)


def fixed_layout(*args):
    """Compiled :func:`_fixed_layout` (see there)."""
    return _compiled("fixed_layout")(*args)


def grid_histogram(*args):
    """Compiled :func:`_grid_histogram` (see there)."""
    return _compiled("grid_histogram")(*args)


_kernels: dict = {}


def warm_up() -> None:
    """Compile (or load from the disk cache) the kernels for the array types the likelihoods
    pass, so that the first frame of a timed run does not pay for it. Cheap after the first
    call."""
    global _warm
    if _warm or not ENABLED:
        return
    lut = np.zeros(256, dtype=np.int16)
    frame = np.zeros((4, 6, 3), dtype=np.uint8)
    table = np.zeros((1, 8), dtype=np.float32)
    rects = np.zeros((0, 4), dtype=np.int64)
    corners = np.zeros(1, dtype=np.int64)
    for region in (frame, frame[:, 1:4]):  # contiguous and strided crops
        value_box_sums(region, lut, lut, lut, table[0], rects, table[:0], corners, corners, 0,
                       2, 2)
    grid_histogram(frame, 2, lut, lut, lut, rects, 8)
    fixed_layout(np.zeros((1, 4)), 6, 4)
    _warm = True


_warm = False
