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

__all__ = ["ENABLED", "fixed_layout", "frame_background", "grid_histogram", "value_box_sums",
           "value_box_sums_rows", "warm_up"]

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

    Each grid row is read in the runs between the rectangles that cross it (no per-pixel
    mask); integer counts, so the order does not matter.

    A first pass loads one byte in every 63 of each grid row (every cache line of a contiguous
    row) before any counting: those loads do not depend on one another, so the memory system
    fetches the lines of a frame not yet in cache side by side, where the counting loop, one
    dependent look-up and increment after another, would wait for them a few at a time (on
    the ``walkers`` frames, rendered before the clock starts and so out of cache: about half
    the kernel's time). Their sum is kept in the returned array's spare element (so the
    compiler cannot drop the loads); the counts do not change.

    Returns (n_bins,) float64 counts.
    """
    h, w = image_bgr.shape[0], image_bgr.shape[1]
    n_rows = (h + stride - 1) // stride
    touched = np.int64(0)
    for gy in range(n_rows):
        row = image_bgr[gy * stride]
        for x in range(0, w, 21):  # 21 px x 3 bytes: every 64-byte line at least once
            touched += np.int64(row[x, 0])
    counts = np.zeros(n_bins, np.int64)
    n_rects = grid_rects.shape[0]
    gw = (w + stride - 1) // stride
    lo = np.empty(max(n_rects, 1), np.int64)
    hi = np.empty(max(n_rects, 1), np.int64)
    for gy in range(n_rows):
        row = image_bgr[gy * stride]
        n_span = 0
        for k in range(n_rects):
            if grid_rects[k, 1] <= gy < grid_rects[k, 3]:
                a = max(grid_rects[k, 0], 0)
                b = min(grid_rects[k, 2], gw)
                if b > a:
                    lo[n_span] = a
                    hi[n_span] = b
                    n_span += 1
        gx = 0
        while gx < gw:
            stop = gw  # the next masked column at or after gx
            inside = False
            for k in range(n_span):
                if lo[k] <= gx < hi[k]:
                    inside = True
                    break
                if gx < lo[k] < stop:
                    stop = lo[k]
            if inside:  # skip every span covering gx
                end = gx
                moved = True
                while moved:
                    moved = False
                    for k in range(n_span):
                        if lo[k] <= end < hi[k]:
                            end = hi[k]
                            moved = True
                gx = end
                continue
            for g in range(gx, stop):
                x = g * stride
                counts[np.int64(lut0[row[x, 0]]) + np.int64(lut1[row[x, 1]])
                       + np.int64(lut2[row[x, 2]])] += 1
            gx = stop
    out = np.empty(n_bins + 1, np.float64)
    for b in range(n_bins):
        out[b] = np.float64(counts[b])
    out[n_bins] = np.float64(touched)
    return out[:n_bins]


def _frame_background(image_bgr, stride, lut0, lut1, lut2, boxes, n_bins, rects, with_counts,
                      eps, hist, scaled):  # pragma: no cover - compiled
    """Per frame: each target's integer colour box and the background histogram outside them.

    ``rects`` (T, 4) int64 receives ``(x0, y0, x1, y1)`` of each box of ``boxes`` (T, 4) xywh
    px, rounded as :func:`pftrack_colour.likelihoods._integer_rect` rounds (``floor(v + 0.5)``,
    width and height at least 1). With ``with_counts``, the counts of :func:`_grid_histogram`
    over the grid cells outside those boxes (every cell when that leaves none).

    With the counts, also ``hist`` (m,) = :func:`pftrack_colour.histograms.normalise_histogram`
    of them with floor ``eps`` (their total is an exact integer: any order of summation gives
    it) and ``scaled`` (m,) = the counts times ``stride ** 2``, the same numbers.

    Returns ``(ok, counts)``: ``ok`` False (nothing else meaningful) when a box coordinate
    plus 0.5 is not within 1e9 (far away, NaN or infinite: the caller's general path).
    """
    n_t = boxes.shape[0]
    for i in range(n_t):
        for c in range(4):
            if not abs(boxes[i, c] + 0.5) < 1e9:
                return False, np.zeros(n_bins, np.float64)
    grid = np.empty((n_t, 4), np.int64)
    n_grid = 0
    for i in range(n_t):
        x0 = np.int64(np.floor(boxes[i, 0] + 0.5))
        y0 = np.int64(np.floor(boxes[i, 1] + 0.5))
        bw = np.int64(np.floor(boxes[i, 2] + 0.5))
        bh = np.int64(np.floor(boxes[i, 3] + 0.5))
        rects[i, 0] = x0
        rects[i, 1] = y0
        rects[i, 2] = x0 + max(bw, 1)
        rects[i, 3] = y0 + max(bh, 1)
        # grid column j samples image column j * stride: those inside [x0, x1)
        gx0 = (max(rects[i, 0], 0) + stride - 1) // stride
        gx1 = (max(rects[i, 2], 0) + stride - 1) // stride
        gy0 = (max(rects[i, 1], 0) + stride - 1) // stride
        gy1 = (max(rects[i, 3], 0) + stride - 1) // stride
        if gx1 > gx0 and gy1 > gy0:
            grid[n_grid, 0] = gx0
            grid[n_grid, 1] = gy0
            grid[n_grid, 2] = gx1
            grid[n_grid, 3] = gy1
            n_grid += 1
    if not with_counts:
        return True, np.zeros(n_bins, np.float64)
    counts = _grid_histogram_nb(image_bgr, stride, lut0, lut1, lut2, grid[:n_grid], n_bins)
    if n_grid > 0:
        empty = True
        for b in range(n_bins):
            if counts[b] != 0.0:
                empty = False
                break
        if empty:  # targets cover the whole image
            counts = _grid_histogram_nb(image_bgr, stride, lut0, lut1, lut2, grid[:0], n_bins)
    total = 0.0
    for b in range(n_bins):
        total += counts[b]
    area = np.float64(stride * stride)
    div = 1.0 + n_bins * eps
    for b in range(n_bins):
        scaled[b] = counts[b] * area
        p = counts[b] / total if total > 0 else 1.0 / n_bins
        p = p + eps
        hist[b] = p / div
    return True, counts


def _value_box_sums_rows(image_bgr, lut0, lut1, lut2, tables, boxes, own_ids, rects, rect_ids,
                         pair_tables, combo_masks, combo_tables, overlays, lam, out, done
                         ):  # pragma: no cover - compiled
    """Every target's log-likelihoods in one call: for target ``i``, what
    :func:`_fixed_layout`, the other targets' stripes over its region and :func:`_value_box_sums`
    (once per stripe, the stripes' sums added in stripe order) give, then ``lam``; the same
    numbers bit for bit.

    Parameters
    ----------
    image_bgr : (H, W, 3) uint8
        The frame (no colour conversion).
    lut0, lut1, lut2 : (256,) int
        Per image channel, the channel value's share of the bin index.
    tables : (T, P, m) float32
        Each target's per-stripe value tables.
    boxes : (T, N, 4) float64
        Each target's particle colour boxes (xywh px).
    own_ids : (T,) int64
        The targets' ids.
    rects : (K, 4) int64
        Every live target's colour box this frame, ``(x0, y0, x1, y1)`` image pixels, end
        exclusive; ``rect_ids`` (K,) their ids (a target's own box is skipped).
    pair_tables : (T, P, K, P, m) float32
        Value of a pixel of target ``i``'s stripe ``k`` under stripe ``kk`` of box ``r``.
    combo_masks : (C,) int64
        Sets of two or more stripes (bit ``r * P + kk`` for stripe ``kk`` of box ``r``) that
        cover common pixels; ``combo_tables`` (T, P, C, m) float32 the value of a pixel of
        target ``i``'s stripe ``k`` under exactly that set.
    overlays : bool
        Whether other targets' boxes change the values (False: ``rects`` are not read).
    lam : float
        ``λ``; <= 0: ``λ = n``, the sums themselves.
    out : (T, N) float64
        Written for the targets done.
    done : (T,) bool
        False for a target the kernel does not cover (boxes of different sizes or leaving the
        image, pixels under a set of stripes with no combo table): the caller takes the
        general path.
    """
    n_t = boxes.shape[0]
    n_parts = tables.shape[1]
    img_h, img_w = image_bgr.shape[0], image_bgr.shape[1]
    n_rects = rects.shape[0] if overlays else 0
    ov = np.empty((max(n_rects * n_parts, 1), 4), np.int64)
    ov_src = np.empty((max(n_rects * n_parts, 1), 2), np.int64)
    for i in range(n_t):
        done[i] = False
        ok, x0, y0, x1, y1, bw, bh, xs, ys = _fixed_layout_nb(boxes[i], img_w, img_h)
        if not ok:
            continue
        # other targets' stripes over the region (the order of ColourLikelihood._coverage)
        n_ov = 0
        for r in range(n_rects):
            if rect_ids[r] == own_ids[i]:
                continue
            cx0 = max(rects[r, 0], x0)
            cx1 = min(rects[r, 2], x1)
            if cx1 <= cx0:
                continue
            rh = rects[r, 3] - rects[r, 1]
            for kk in range(n_parts):
                ry0 = rects[r, 1] + (kk * rh) // n_parts
                ry1 = rects[r, 1] + ((kk + 1) * rh) // n_parts
                cy0 = max(ry0, y0)
                cy1 = min(ry1, y1)
                if cy1 > cy0:
                    ov[n_ov, 0] = cx0 - x0
                    ov[n_ov, 1] = cy0 - y0
                    ov[n_ov, 2] = cx1 - x0
                    ov[n_ov, 3] = cy1 - y0
                    ov_src[n_ov, 0] = r
                    ov_src[n_ov, 1] = kk
                    n_ov += 1
        disjoint = True
        for a in range(1, n_ov):
            for b in range(a):
                if (ov[a, 1] < ov[b, 3] and ov[b, 1] < ov[a, 3]
                        and ov[a, 0] < ov[b, 2] and ov[b, 0] < ov[a, 2]):
                    disjoint = False
        if not disjoint and n_rects * n_parts > 62:
            continue  # the sets of stripes do not fit a bit mask
        rows = y1 - y0
        cols = x1 - x0
        region = image_bgr[y0:y1, x0:x1]
        n = xs.shape[0]
        sums = np.zeros(n, np.float64)
        ii = np.empty((rows + 1, cols + 1), np.float64)
        bins = np.empty(cols, np.int64)
        vals = np.empty(cols, np.float32)
        cover = np.zeros(cols if not disjoint else 0, np.int64)  # stripes over each pixel
        count = np.zeros(cols if not disjoint else 0, np.int64)
        last = np.zeros(cols if not disjoint else 0, np.int64)
        missing = False
        for k in range(n_parts):
            oy = (k * bh) // n_parts
            sh = ((k + 1) * bh) // n_parts - oy
            if sh <= 0:
                continue  # zeros: sums + 0.0 leaves them as they are
            table = tables[i, k]
            ii[0, :] = 0.0
            for y in range(rows):
                pix = region[y]
                for x in range(cols):
                    b = (np.int64(lut0[pix[x, 0]]) + np.int64(lut1[pix[x, 1]])
                         + np.int64(lut2[pix[x, 2]]))
                    bins[x] = b
                    vals[x] = table[b]
                if disjoint:
                    for o in range(n_ov):
                        if ov[o, 1] <= y < ov[o, 3]:
                            pt = pair_tables[i, k, ov_src[o, 0], ov_src[o, 1]]
                            for x in range(ov[o, 0], ov[o, 2]):
                                vals[x] = pt[bins[x]]
                else:
                    # each pixel's set of stripes: one stripe reads its pair table, several
                    # the table of that set
                    crossed = False
                    for o in range(n_ov):
                        if ov[o, 1] <= y < ov[o, 3]:
                            if not crossed:
                                cover[:] = 0
                                count[:] = 0
                                crossed = True
                            bit = np.int64(1) << (ov_src[o, 0] * n_parts + ov_src[o, 1])
                            for x in range(ov[o, 0], ov[o, 2]):
                                cover[x] |= bit
                                count[x] += 1
                                last[x] = o
                    if crossed:
                        for x in range(cols):
                            c = count[x]
                            if c == 1:
                                o = last[x]
                                vals[x] = pair_tables[i, k, ov_src[o, 0], ov_src[o, 1],
                                                      bins[x]]
                            elif c > 1:
                                found = -1
                                for q in range(combo_masks.shape[0]):
                                    if combo_masks[q] == cover[x]:
                                        found = q
                                        break
                                if found < 0:
                                    missing = True
                                    break
                                vals[x] = combo_tables[i, k, found, bins[x]]
                    if missing:
                        break
                # cv2.integral's order: a running row sum added to the row above
                above = ii[y]
                here = ii[y + 1]
                here[0] = 0.0
                acc = 0.0
                for x in range(cols):
                    acc += np.float64(vals[x])
                    here[x + 1] = above[x + 1] + acc
            if missing:
                break
            for j in range(n):
                bx = xs[j]
                by = ys[j] + oy
                box = ((ii[by + sh, bx + bw] - ii[by, bx + bw]) - ii[by + sh, bx]) + ii[by, bx]
                if k == 0:
                    sums[j] = box
                else:
                    sums[j] = sums[j] + box
        if missing:
            continue  # a set of stripes without its table: the general path
        if lam > 0:
            area = np.float64(max(bw * bh, 1))
            for j in range(n):
                out[i, j] = lam * sums[j] / area
        else:
            for j in range(n):
                out[i, j] = sums[j]
        done[i] = True


# compiled kernels that other kernels call, bound by _compiled before those are compiled
_fixed_layout_nb = None
_grid_histogram_nb = None


def _compiled(name: str):
    fn = _kernels.get(name)
    if fn is None:
        from numba import njit  # imported here: half a second that plugin listing need not pay

        if name == "value_box_sums_rows":  # calls the layout kernel: compiled first
            globals()["_fixed_layout_nb"] = _compiled("fixed_layout")
        if name == "frame_background":  # calls the histogram kernel: compiled first
            globals()["_grid_histogram_nb"] = _compiled("grid_histogram")
        fn = _kernels[name] = njit(cache=True, nogil=True)(globals()["_" + name])
    return fn


def value_box_sums(*args):
    """Compiled :func:`_value_box_sums` (see there)."""
    return _compiled("value_box_sums")(*args)


def fixed_layout(*args):
    """Compiled :func:`_fixed_layout` (see there)."""
    return _compiled("fixed_layout")(*args)


def value_box_sums_rows(*args):
    """Compiled :func:`_value_box_sums_rows` (see there)."""
    return _compiled("value_box_sums_rows")(*args)


def frame_background(*args):
    """Compiled :func:`_frame_background` (see there)."""
    return _compiled("frame_background")(*args)


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
    grid_histogram(frame[1:3, 1:4], 1, lut, lut, lut, rects, 8)  # a box's pixels (templates)
    fixed_layout(np.zeros((1, 4)), 6, 4)
    frame_background(frame, 2, lut, lut, lut, np.ones((1, 4)), 8, np.empty((1, 4), np.int64),
                     True, 1e-4, np.empty(8), np.empty(8))
    boxes = np.zeros((1, 1, 4))
    boxes[..., 2:] = 1.0
    value_box_sums_rows(frame, lut, lut, lut, np.zeros((1, 1, 8), np.float32), boxes,
                        np.ones(1, np.int64), rects, np.zeros(0, np.int64),
                        np.zeros((1, 1, 0, 1, 8), np.float32), np.zeros(0, np.int64),
                        np.zeros((1, 1, 0, 8), np.float32), True, 0.0, np.empty((1, 1)),
                        np.empty(1, np.bool_))
    _warm = True


_warm = False
