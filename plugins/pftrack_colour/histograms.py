"""Colour quantisation, box geometry and the per-frame region machinery of the colour likelihoods.

Everything here works on BGR ``uint8`` frames (OpenCV's order) and integer pixel boxes:

* :class:`ColourBins` maps pixels to histogram bins (the colour paper: RGB, 8 x 8 x 8 = 512 bins)
  with one look-up table per channel; no Python loop per pixel.
* :func:`integer_boxes` turns particle boxes ``(left, top, width, height)`` in float pixels into
  the integer pixel rectangles the likelihoods read (clipping them to the image:
  :func:`pftrack.geometry.boxes.clip_boxes`).
* :class:`ParticleRegion` is the image region that one target's particles cover in one frame (the
  bounding rectangle of their boxes, clipped to the image). The fast likelihoods build an integral
  image over it once per frame and target, then read any box sum with four look-ups; the baselines
  gather each box's bin indices from it to build one histogram per particle, as the paper does.

Pixel convention: pixel ``(row, col)`` covers ``[col, col + 1) x [row, row + 1)`` in image
coordinates; a box ``(left, top, width, height)`` covers the pixels whose columns are
``round(left) .. round(left) + round(width) - 1`` (rows likewise), ``round`` being round-half-up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

__all__ = [
    "COLOUR_SPACES",
    "ColourBins",
    "ParticleRegion",
    "integer_boxes",
    "normalise_histogram",
    "subsample",
]

#: Colour spaces: OpenCV conversion from BGR (None: none) and the value range of each channel.
#: Channels are taken in the space's own order (R, G, B for "rgb"; H, S, V for "hsv"...).
COLOUR_SPACES: dict[str, tuple[int | None, tuple[int, int, int], tuple[int, int, int]]] = {
    # name: (cv2 conversion code, channel order in the converted image, channel value ranges)
    "rgb": (None, (2, 1, 0), (256, 256, 256)),
    "bgr": (None, (0, 1, 2), (256, 256, 256)),
    "hsv": (cv2.COLOR_BGR2HSV, (0, 1, 2), (180, 256, 256)),
    "lab": (cv2.COLOR_BGR2Lab, (0, 1, 2), (256, 256, 256)),
    "ycrcb": (cv2.COLOR_BGR2YCrCb, (0, 1, 2), (256, 256, 256)),
}


@dataclass(frozen=True)
class ColourBins:
    """Pixel -> histogram bin index.

    Parameters
    ----------
    bins : int or (int, int, int)
        Bins per channel (the colour paper: 8, i.e. 8 x 8 x 8 = 512 bins). Each between 1 and 256.
    colour_space : {"rgb", "bgr", "hsv", "lab", "ycrcb"}
        Space the histogram is taken in; frames are BGR and converted with OpenCV.

    Notes
    -----
    Bin of a pixel with channel values ``(c0, c1, c2)`` (in the colour space's channel order) is
    ``b(c0) * n1 * n2 + b(c1) * n2 + b(c2)`` with ``b(c) = floor(c * n_k / range_k)``.
    """

    bins: int | tuple[int, int, int] = 8
    colour_space: str = "rgb"
    _lut: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        space = str(self.colour_space).lower()
        if space not in COLOUR_SPACES:
            raise ValueError(f"colour_space {self.colour_space!r} is not one of "
                             f"{sorted(COLOUR_SPACES)}")
        nb = (self.bins,) * 3 if np.isscalar(self.bins) else tuple(self.bins)
        if len(nb) != 3 or any(int(b) != b or not 1 <= b <= 256 for b in nb):
            raise ValueError(f"bins must be an int or three ints in 1..256, got {self.bins!r}")
        nb = tuple(int(b) for b in nb)
        _, order, ranges = COLOUR_SPACES[space]
        mult = (nb[1] * nb[2], nb[2], 1)
        m = nb[0] * nb[1] * nb[2]
        dtype = np.int16 if m <= np.iinfo(np.int16).max else np.int32
        lut = np.zeros((1, 256, 3), dtype=dtype)
        v = np.arange(256)
        for k in range(3):  # k: colour-space channel; order[k]: its index in the image
            b = np.minimum(v * nb[k] // ranges[k], nb[k] - 1)
            lut[0, :, order[k]] = b * mult[k]
        object.__setattr__(self, "_lut", lut)
        # one single-channel table per image channel: cv2.LUT on one channel with a 16-bit
        # table is about three times faster than on three channels
        object.__setattr__(self, "_luts", tuple(np.ascontiguousarray(lut[:, :, j])
                                                for j in range(3)))
        object.__setattr__(self, "_flat_luts", tuple(t.reshape(-1) for t in self._luts))
        object.__setattr__(self, "_shape", nb)
        object.__setattr__(self, "_code", COLOUR_SPACES[space][0])
        # cv2.calcHist bins an 8-bit channel through floor(v * n / range) in double precision:
        # exact (the formula above) when the range is 256, a power of two
        object.__setattr__(self, "_calchist", (list(order), list(nb), [0, 256] * 3)
                           if all(r == 256 for r in ranges) else None)

    @property
    def shape(self) -> tuple[int, int, int]:
        """Bins per channel."""
        return self._shape  # type: ignore[attr-defined]

    @property
    def channel_luts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per channel of the (converted) image, (256,) int tables whose sum over a pixel's
        three channels is its bin index (the kernels in :mod:`pftrack_colour._jit` read
        them)."""
        return self._flat_luts  # type: ignore[attr-defined]

    @property
    def conversion(self) -> int | None:
        """OpenCV conversion code from BGR applied before binning (None: none)."""
        return self._code  # type: ignore[attr-defined]

    @property
    def n_bins(self) -> int:
        """Total number of bins m."""
        a, b, c = self.shape
        return a * b * c

    def __call__(self, image_bgr: np.ndarray) -> np.ndarray:
        """Bin index of every pixel.

        Parameters
        ----------
        image_bgr : ndarray, shape (H, W, 3), uint8
            BGR pixels (any 2-D slice of a frame).

        Returns
        -------
        ndarray, shape (H, W), int16 or int32
            Bin indices in ``[0, n_bins)``.
        """
        img = np.asarray(image_bgr)
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise ValueError(f"expected a BGR uint8 image (H, W, 3), got {img.dtype} {img.shape}")
        if img.shape[0] == 0 or img.shape[1] == 0:
            return np.zeros(img.shape[:2], dtype=self._lut.dtype)
        code = self._code  # type: ignore[attr-defined]
        if code is not None:
            img = cv2.cvtColor(np.ascontiguousarray(img), code)
        elif img.strides[1:] != (3, 1):  # OpenCV reads row-strided views, not others
            img = np.ascontiguousarray(img)
        # split first (a crop of the frame is read in place), then one table per channel
        c0, c1, c2 = cv2.split(img)
        l0, l1, l2 = self._luts  # type: ignore[attr-defined]
        return cv2.add(cv2.add(cv2.LUT(c0, l0), cv2.LUT(c1, l1)), cv2.LUT(c2, l2))

    def histogram(self, image_bgr: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        """Bin counts of the pixels of ``image_bgr`` (where ``mask``, (H, W) bool or uint8, is
        nonzero): shape (n_bins,), float64.

        One ``cv2.calcHist`` call when it bins exactly as :meth:`__call__` does (channel ranges
        of 256), else the bin image and ``np.bincount``; the counts are the same.
        """
        img = np.asarray(image_bgr)
        if mask is not None:
            mask = np.asarray(mask)
            if mask.shape != img.shape[:2]:
                raise ValueError(f"mask shape {mask.shape} does not match the image's "
                                 f"{img.shape[:2]}")
        spec = self._calchist  # type: ignore[attr-defined]
        if spec is None or img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            bins = self(img)
            if mask is not None:
                bins = bins[mask.astype(bool, copy=False)]
            return np.bincount(bins.ravel(), minlength=self.n_bins).astype(np.float64)
        code = self._code  # type: ignore[attr-defined]
        img = np.ascontiguousarray(img)
        if code is not None:
            img = cv2.cvtColor(img, code)
        if mask is not None:
            if mask.dtype == bool:
                mask = mask.view(np.uint8)
            elif mask.dtype != np.uint8:
                mask = (mask != 0).view(np.uint8)
            mask = np.ascontiguousarray(mask)
        channels, sizes, ranges = spec
        h = cv2.calcHist([img], channels, mask, sizes, ranges)  # float32, exact below 2**24
        return h.reshape(-1).astype(np.float64)


def subsample(image: np.ndarray, stride: int) -> np.ndarray:
    """Every ``stride``-th pixel in each direction, starting at (0, 0): ``image[::s, ::s]``.

    Same pixels as the slice, as a contiguous array, through OpenCV's nearest-neighbour resize
    (several times faster than copying the strided view with numpy).
    """
    s = int(stride)
    if s == 1:
        return image
    h, w = image.shape[:2]
    out = cv2.resize(image, None, fx=1.0 / s, fy=1.0 / s, interpolation=cv2.INTER_NEAREST)
    if out.shape[:2] != (-(-h // s), -(-w // s)):  # rounding of odd sizes: take the slice
        out = np.ascontiguousarray(image[::s, ::s])
    return out


def normalise_histogram(counts: np.ndarray, eps: float) -> np.ndarray:
    """Counts -> a probability histogram with an additive floor.

    ``h = (p + eps) / (1 + m * eps)`` with ``p = counts / counts.sum()`` and ``m`` bins, so every
    bin is at least ``eps / (1 + m eps)`` and the logarithm of a colour never seen is finite
    (``log(1e-4) ~ -9.2`` for the default floor: an unseen colour costs about as much as nine
    seen colours with probability 1/e^1 gain). An empty histogram gives the uniform one.

    Parameters
    ----------
    counts : ndarray, shape (..., m)
    eps : float
        The floor, >= 0.

    Returns
    -------
    ndarray, shape (..., m), float64, summing to 1 along the last axis.
    """
    c = np.asarray(counts, dtype=np.float64)
    m = c.shape[-1]
    if c.ndim == 1:  # every frame (background): the same operations without the masking
        total = float(c.sum())
        p = c / total if total > 0 else np.full(m, 1.0 / m)
        p += eps
        p /= 1.0 + m * eps
        return p
    s = c.sum(axis=-1, keepdims=True)
    p = np.divide(c, s, out=np.full_like(c, 1.0 / m), where=s > 0)
    return (p + eps) / (1.0 + m * eps)


def integer_boxes(boxes_xywh_px: np.ndarray) -> np.ndarray:
    """Float boxes (N, 4) xywh px -> integer rectangles (N, 4) ``(x0, y0, x1, y1)``, end exclusive.

    ``x0 = round(left)``, ``x1 = x0 + max(1, round(width))`` (round-half-up); not clipped.
    """
    b = np.floor(np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4) + 0.5)
    if len(b) and not np.abs(b).max() < 1e9:  # False for NaN too
        if not np.isfinite(b).all():
            raise ValueError("particle boxes contain NaN or infinite values")
        # far-away particles: keep the arithmetic in int64 without changing what they cover
        b = np.clip(b, -1e9, 1e9)
    out = np.empty((len(b), 4), dtype=np.int64)
    out[:, :2] = b[:, :2]
    out[:, 2:] = b[:, :2] + np.maximum(b[:, 2:], 1.0)
    return out


_ROWS = np.array([3, 1, 3, 1])  # y1, y0, y1, y0
_COLS = np.array([2, 2, 0, 0])  # x1, x1, x0, x0
_CORNER_SIGNS = np.array([1.0, -1.0, -1.0, 1.0])


class ParticleRegion:
    """The image region that one target's particle boxes cover in one frame.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8
    boxes_xywh_px : ndarray, shape (N, 4), float
        Particle boxes ``(left, top, width, height)`` in pixels, possibly outside the image;
        they are rounded to integer rectangles as :func:`integer_boxes` does.

    Attributes
    ----------
    x0, y0, x1, y1 : int
        The region in image pixels (end exclusive): the bounding rectangle of the boxes, clipped
        to the image (empty when every box is outside it).
    all_inside : bool
        Every box lies wholly inside the image (then no box needs clipping).

    Notes
    -----
    The common case, every box of the same size (a target's particles under a fixed-size
    observation model), takes a fast path: box sums are read from one "box-filtered" integral
    image with a single look-up per particle, and per-particle arithmetic runs on (2, N) arrays
    (numpy is several times slower on the columns of an (N, 4) array; this runs for every
    target in every frame). Boxes of different sizes use four look-ups per box.
    """

    #: a padded region larger than this many times the image falls back to per-box corners
    _MAX_PAD_FACTOR = 4.0

    def __init__(self, image_bgr: np.ndarray, boxes_xywh_px: np.ndarray) -> None:
        h, w = image_bgr.shape[:2]
        self.image = image_bgr
        self._size_wh = (w, h)
        b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
        self._n = len(b)
        self._boxes = b
        self._cache: dict[str, Any] = {}
        self.fixed_size: tuple[int, int] | None = None
        if self._n == 0:
            self.x0 = self.y0 = self.x1 = self.y1 = 0
            self.all_inside = True
            return
        # (4, N) rows left, top, width, height, rounded half up
        bt = np.add(b.T, 0.5, order="C")
        np.floor(bt, out=bt)
        lo = bt.min(axis=1).tolist()
        hi = bt.max(axis=1).tolist()
        if not all(map(math.isfinite, lo + hi)):
            raise ValueError("particle boxes contain NaN or infinite values")
        if lo[2] == hi[2] and lo[3] == hi[3] and max(map(abs, lo + hi)) < 1e9:
            bw, bh = max(1, int(lo[2])), max(1, int(lo[3]))
            self.fixed_size = (bw, bh)
            self._xy = bt[:2]  # (2, N) top-left corners
            # padded region: the boxes' bounding rectangle, unclipped
            self._pad = (int(lo[0]), int(lo[1]), int(hi[0]) + bw, int(hi[1]) + bh)
            px0, py0, px1, py1 = self._pad
            self.all_inside = px0 >= 0 and py0 >= 0 and px1 <= w and py1 <= h
            self.x0, self.x1 = min(max(px0, 0), w), min(max(px1, 0), w)
            self.y0, self.y1 = min(max(py0, 0), h), min(max(py1, 0), h)
            if self.x1 <= self.x0 or self.y1 <= self.y0:
                self.x0 = self.y0 = self.x1 = self.y1 = 0
            return
        self._general()

    # -- general (any box sizes) ------------------------------------------------------------

    def _rows(self) -> np.ndarray:
        """(4, N) float64 rows x0, y0, x1, y1 of the integer rectangles, unclipped."""
        r = self._cache.get("rows")
        if r is None:
            b = np.add(self._boxes.T, 0.5, order="C")
            np.floor(b, out=b)
            np.maximum(b[2:], 1.0, out=b[2:])
            b[2:] += b[:2]
            if b.size and not (b.max() < 1e9 and b.min() > -1e9):  # False for NaN too
                if not np.isfinite(b).all():
                    raise ValueError("particle boxes contain NaN or infinite values")
                b = np.clip(b, -1e9, 1e9)
            r = self._cache["rows"] = b
        return r

    def _clipped_rows(self) -> np.ndarray:
        c = self._cache.get("clipped")
        if c is None:
            w, h = self._size_wh
            # clipping both corners into the image keeps x0 <= x1 (clipping is monotone)
            c = np.minimum(np.maximum(self._rows(), 0.0),
                           np.array([[w], [h], [w], [h]], dtype=np.float64))
            self._cache["clipped"] = c
        return c

    def _general(self) -> None:
        c = self._clipped_rows()
        inside = self.inside
        self.all_inside = bool(inside.all())
        if self.all_inside:
            lo, hi = c[:2].min(axis=1), c[2:].max(axis=1)
        elif inside.any():
            lo, hi = c[:2, inside].min(axis=1), c[2:, inside].max(axis=1)
        else:
            lo = hi = np.zeros(2)
        self.x0, self.y0 = int(lo[0]), int(lo[1])
        self.x1, self.y1 = int(hi[0]), int(hi[1])

    # -- per-box quantities -----------------------------------------------------------------

    def __len__(self) -> int:
        return self._n

    @property
    def rects(self) -> np.ndarray:
        """Integer rectangles (N, 4) ``(x0, y0, x1, y1)``, unclipped."""
        return self._rows().T.astype(np.int64)

    @property
    def clipped(self) -> np.ndarray:
        """The rectangles clipped to the image, (N, 4) int64."""
        return self._clipped_rows().T.astype(np.int64)

    @property
    def n_pixels(self) -> np.ndarray:
        """Each box's pixel count inside the image, (N,) float64 (an integer)."""
        n = self._cache.get("n_pixels")
        if n is None:
            if self.fixed_size is not None and self.all_inside:
                n = np.full(self._n, float(self.fixed_size[0] * self.fixed_size[1]))
            else:
                c = self._clipped_rows()
                n = (c[2] - c[0]) * (c[3] - c[1])
            self._cache["n_pixels"] = n
        return n

    @property
    def inside(self) -> np.ndarray:
        """``n_pixels > 0``, (N,) bool (False for NaN boxes too)."""
        if self.fixed_size is not None and self.all_inside:
            return np.ones(self._n, dtype=bool)
        return self.n_pixels > 0

    @property
    def box_area(self) -> np.ndarray | float:
        """Each box's pixel count, unclipped: a float for same-size boxes, else (N,)."""
        if self.fixed_size is not None:
            return float(self.fixed_size[0] * self.fixed_size[1])
        r = self._rows()
        return (r[2] - r[0]) * (r[3] - r[1])

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the region."""
        return self.y1 - self.y0, self.x1 - self.x0

    def pixels(self) -> np.ndarray:
        """The region's pixels, (rows, cols, 3) uint8 (a view of the frame)."""
        return self.image[self.y0:self.y1, self.x0:self.x1]

    def part_rows(self, part: tuple[int, int] | None = None) -> np.ndarray:
        """(4, N) float64 rows x0, y0, x1, y1 of each box's part, unclipped.

        ``part=(k, P)``: the k-th of P horizontal stripes of the integer box, rows
        ``y0 + (k h) // P`` to ``y0 + ((k + 1) h) // P`` (None: the whole box).
        """
        r = self._rows()
        if part is None:
            return r
        k, p = part
        h = r[3] - r[1]
        out = r.copy()
        out[1] = r[1] + (k * h) // p
        out[3] = r[1] + ((k + 1) * h) // p
        return out

    def part_pixels(self, part: tuple[int, int] | None = None) -> np.ndarray:
        """Each box part's pixel count inside the image, (N,) float64."""
        if part is None:
            return self.n_pixels
        w, h = self._size_wh
        c = np.minimum(np.maximum(self.part_rows(part), 0.0),
                       np.array([[w], [h], [w], [h]], dtype=np.float64))
        return (c[2] - c[0]) * (c[3] - c[1])

    def box_sums(self, values: np.ndarray, part: tuple[int, int] | None = None) -> np.ndarray:
        """Sum of ``values`` over each box's in-image pixels, O(1) per box (integral image).

        Parameters
        ----------
        values : ndarray, shape (rows, cols), float
            One value per pixel of the region.
        part : (k, P), optional
            Sum over the k-th of P horizontal stripes of each box (see :meth:`part_rows`).

        Returns
        -------
        ndarray, shape (N,), float64 (0 for boxes wholly outside the image).
        """
        rows, cols = self.shape
        if rows == 0 or cols == 0:
            return np.zeros(self._n)
        v = np.asarray(values, dtype=np.float32)
        if self.fixed_size is not None:
            px0, py0, px1, py1 = self._pad
            w, h = self._size_wh
            bw, bh = self.fixed_size
            oy, sh = 0, bh
            if part is not None:
                k, p = part
                oy = (k * bh) // p
                sh = ((k + 1) * bh) // p - oy
                if sh <= 0:
                    return np.zeros(self._n)
            if not self.all_inside:
                if (px1 - px0) * (py1 - py0) > self._MAX_PAD_FACTOR * w * h:
                    return self._corner_sums(v, part)
                # pixels outside the image are zero: the sums are those of the clipped boxes
                padded = np.zeros((py1 - py0, px1 - px0), dtype=np.float32)
                padded[self.y0 - py0:self.y1 - py0, self.x0 - px0:self.x1 - px0] = v
                v = padded
            ii = cv2.integral(v, sdepth=cv2.CV_64F)
            # each box's four corners in the integral image of the padded region, gathered
            # with one take; the sum is ((bottom-right - top-right) - bottom-left) + top-left
            stride = ii.shape[1]
            g = ii.ravel().take(self._corner_index(stride, oy, sh, bw))
            out = g[0]
            out -= g[1]
            out -= g[2]
            out += g[3]
            return out
        return self._corner_sums(v, part)

    def _corner_index(self, stride: int, oy: int, sh: int, bw: int) -> np.ndarray:
        """Flat indices (4, N) of the bottom-right, top-right, bottom-left and top-left corners
        of each same-size box's ``bw x sh`` window starting ``oy`` rows below its top, in a
        row-major array of ``stride`` columns laid over the padded region."""
        px0, py0 = self._pad[:2]
        top_left = (oy - py0) * stride - px0
        xy = self._xy[1] * float(stride)  # exact: integers well below 2**53
        xy += self._xy[0]
        offsets = np.array([top_left + sh * stride + bw, top_left + bw,
                            top_left + sh * stride, top_left], dtype=np.float64)
        return np.add.outer(offsets, xy).astype(np.intp)

    def _corner_sums(self, v: np.ndarray, part: tuple[int, int] | None = None) -> np.ndarray:
        rows, cols = self.shape
        ii = cv2.integral(np.ascontiguousarray(v), sdepth=cv2.CV_64F).ravel()
        stride = cols + 1
        # clip to the region (which holds every box's in-image pixels); empty boxes give 0
        c = self.part_rows(part) - np.array([[self.x0], [self.y0], [self.x0], [self.y0]],
                                            dtype=np.float64)
        c = np.minimum(np.maximum(c, 0.0), np.array([[cols], [rows], [cols], [rows]], float))
        c[2] = np.maximum(c[2], c[0])
        c[3] = np.maximum(c[3], c[1])
        # corners (bottom-right, top-right, bottom-left, top-left) -> flat integral indices
        idx = (c[_ROWS] * stride + c[_COLS]).astype(np.intp)
        return _CORNER_SIGNS @ ii[idx]

    def box_histograms(self, bin_image: np.ndarray, n_bins: int,
                       part: tuple[int, int] | None = None) -> np.ndarray:
        """Bin counts of every box's in-image pixels: the paper's per-sample histogram (eq. 7).

        Each box's pixel indices are gathered from the region's bin image (one fancy index of
        shape (N, h * w) for the largest box; smaller boxes mask their extra entries), pixels
        outside the image go to an extra bin that is dropped, and one ``np.bincount`` counts
        them all.

        Parameters
        ----------
        bin_image : ndarray, shape (rows, cols), int
            Bin indices of the region's pixels; values ``>= n_bins`` are counted in no bin.
        n_bins : int
        part : (k, P), optional
            Count the k-th of P horizontal stripes of each box (see :meth:`part_rows`).

        Returns
        -------
        ndarray, shape (N, n_bins), float64
        """
        n = len(self)
        rows, cols = self.shape
        out_bin = n_bins  # sentinel: outside the image or masked
        if n == 0:
            return np.zeros((0, n_bins))
        if rows == 0 or cols == 0:
            return np.zeros((n, n_bins))
        r = self.part_rows(part).astype(np.int64)
        widths = r[2] - r[0]
        heights = r[3] - r[1]
        bw, bh = int(widths.max()), int(heights.max())
        if bw <= 0 or bh <= 0:
            return np.zeros((n, n_bins))
        # pad the region by the largest box so every box that reaches into the image lies
        # wholly inside the padded array; the padding holds the sentinel bin
        px0, py0 = self.x0 - bw, self.y0 - bh
        pcols = (self.x1 - px0) + bw
        prows = (self.y1 - py0) + bh
        padded = np.full((prows, pcols), out_bin, dtype=np.int32)
        padded[bh:bh + rows, bw:bw + cols] = np.minimum(bin_image, out_bin)
        # boxes wholly outside the padded array are moved into it (they read only sentinels:
        # such a box has no pixel in the region, hence none in the image)
        ox = np.minimum(np.maximum(r[0], px0), px0 + pcols - bw) - px0
        oy = np.minimum(np.maximum(r[1], py0), py0 + prows - bh) - py0
        ys, xs = np.mgrid[0:bh, 0:bw]
        offsets = (ys * pcols + xs).ravel()
        vals = padded.ravel()[(oy * pcols + ox)[:, None] + offsets[None, :]]
        if np.any(widths != bw) or np.any(heights != bh):
            ok = ((xs.ravel()[None, :] < widths[:, None])
                  & (ys.ravel()[None, :] < heights[:, None]))
            vals = np.where(ok, vals, out_bin)
        moved = (ox != r[0] - px0) | (oy != r[1] - py0)
        if moved.any():
            vals = np.where(moved[:, None], out_bin, vals)
        keys = (np.arange(n, dtype=np.int64) * (n_bins + 1))[:, None] + vals
        counts = np.bincount(keys.ravel(), minlength=n * (n_bins + 1))
        return counts.reshape(n, n_bins + 1)[:, :n_bins].astype(np.float64)
