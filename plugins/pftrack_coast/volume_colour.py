"""Colour of the ``volumes`` track manager's tracks (:mod:`pftrack_coast.volumes`): HSV colour
histograms of image regions, the Bhattacharyya distance between them, and the histogram bin of
each pixel of a frame region (what ``mask.colour_share`` compares templates on).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["HSV_BINS", "bhattacharyya", "hsv_bin_image", "hsv_histogram", "pixel_bins"]

#: Bins of hue (0-180), saturation and value of the tracks' histograms.
HSV_BINS = (8, 4, 4)


def hsv_histogram(image: np.ndarray, box_xywh_px: np.ndarray, inner: float = 0.4,
                  bins: tuple[int, int, int] = HSV_BINS) -> np.ndarray | None:
    """Normalised HSV colour histogram of the central part of an image box.

    Parameters
    ----------
    image : ndarray, shape (H, W, 3), uint8
        BGR picture.
    box_xywh_px : ndarray, shape (4,)
        (left, top, width, height), pixels.
    inner : float
        Fraction of the box's width kept about its centre (its height is kept from 5 % to
        95 %): the region is mostly the intruder, not the background beside it.
    bins : tuple of int
        Bins of hue (0-180), saturation and value.

    Returns
    -------
    ndarray, shape (prod(bins),) or None
        The histogram (sums to 1); None when the region holds fewer than 16 pixels of the image.
    """
    import cv2

    b = np.asarray(box_xywh_px, dtype=np.float64)
    if b.shape != (4,) or not np.isfinite(b).all():
        return None
    h_img, w_img = image.shape[:2]
    cx = b[0] + 0.5 * b[2]
    x0, x1 = int(max(cx - 0.5 * inner * b[2], 0)), int(min(cx + 0.5 * inner * b[2], w_img))
    y0, y1 = int(max(b[1] + 0.05 * b[3], 0)), int(min(b[1] + 0.95 * b[3], h_img))
    if (x1 - x0) * (y1 - y0) < 16:
        return None
    hsv = cv2.cvtColor(np.ascontiguousarray(image[y0:y1, x0:x1]), cv2.COLOR_BGR2HSV)
    nh, ns, nv = bins
    lut_h, lut_s, lut_v = _hsv_luts(nh, ns, nv)
    hsv = hsv.reshape(-1, 3)
    # (min(h nh // 180, nh - 1) ns + s ns // 256) nv + v nv // 256, from three tables
    idx = lut_h.take(hsv[:, 0])
    idx += lut_s.take(hsv[:, 1])
    idx += lut_v.take(hsv[:, 2])
    hist = np.bincount(idx, minlength=nh * ns * nv).astype(np.float64)
    return hist / hist.sum()


_HSV_LUTS: dict[tuple[int, int, int], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _hsv_luts(nh: int, ns: int, nv: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each 8-bit hue, saturation and value's share of its histogram bin index (integers, the
    smallest unsigned type that holds every index)."""
    key = (nh, ns, nv)
    if key not in _HSV_LUTS:
        n = nh * ns * nv
        dtype = np.uint8 if n <= 256 else np.uint16 if n <= 65536 else np.intp
        g = np.arange(256, dtype=np.intp)
        _HSV_LUTS[key] = (
            (np.minimum(g * nh // 180, nh - 1) * ns * nv).astype(dtype),
            (g * ns // 256 * nv).astype(dtype),
            (g * nv // 256).astype(dtype))
    return _HSV_LUTS[key]


def bhattacharyya(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Bhattacharyya distance sqrt(1 - sum sqrt(p q)) between histograms (last axis)."""
    bc = np.sqrt(np.asarray(p) * np.asarray(q)).sum(axis=-1)
    return np.sqrt(np.clip(1.0 - bc, 0.0, None))


def hsv_bin_image(image: np.ndarray | None, boxes_xywh_px: list[np.ndarray],
                  ) -> tuple[np.ndarray, int, int] | None:
    """The :func:`hsv_histogram` bin (of :data:`HSV_BINS`) of each pixel of ``image`` in the box
    that holds every one of ``boxes_xywh_px`` (each (4,), finite; pixels), clipped to the image.

    Returns
    -------
    tuple or None
        ``(bins, left, top)``: bins (h, w) of the region whose top-left pixel is (left, top);
        None for no image, an image that is not 8-bit BGR, no box, or a box off the image.
    """
    import cv2

    img = image
    if img is None or img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8 or \
            not boxes_xywh_px:
        return None
    g = np.array(boxes_xywh_px)
    h, w = img.shape[:2]
    x0, y0 = (int(max(math.floor(v), 0)) for v in g[:, :2].min(axis=0))
    x1 = int(min(math.ceil(float((g[:, 0] + g[:, 2]).max())) + 1, w))
    y1 = int(min(math.ceil(float((g[:, 1] + g[:, 3]).max())) + 1, h))
    if not (x1 > x0 and y1 > y0):
        return None
    hsv = cv2.cvtColor(np.ascontiguousarray(img[y0:y1, x0:x1]), cv2.COLOR_BGR2HSV)
    lut_h, lut_s, lut_v = _hsv_luts(*HSV_BINS)
    idx = lut_h.take(hsv[:, :, 0])
    idx += lut_s.take(hsv[:, :, 1])
    idx += lut_v.take(hsv[:, :, 2])
    return idx, x0, y0


def pixel_bins(bin_image: tuple[np.ndarray, int, int] | None, px: np.ndarray,
               ) -> tuple[np.ndarray, np.ndarray]:
    """The bins of :func:`hsv_bin_image`'s region under pixels ``px`` (N, 2), and which of the
    pixels lie in the region (NaN: not); no region: no bins, none in it."""
    if bin_image is None:
        return np.zeros(0, dtype=np.intp), np.zeros(len(px), dtype=np.bool_)
    idx, x0, y0 = bin_image
    with np.errstate(invalid="ignore"):
        u = np.floor(px[:, 0]) - x0
        v = np.floor(px[:, 1]) - y0
        ok = (u >= 0) & (u < idx.shape[1]) & (v >= 0) & (v < idx.shape[0])
    return idx[v[ok].astype(np.intp), u[ok].astype(np.intp)], ok
