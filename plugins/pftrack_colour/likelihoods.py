"""Colour-histogram likelihoods of the colour paper (Kamijo et al., cross entropy for fast
multi-object particle-filter tracking).

Four likelihoods, all built on a per-target template colour histogram ``q`` taken from the
target's initial box (eq. 5; RGB 8 x 8 x 8 by default), registered under these names:

* ``bhattacharyya`` (:class:`BhattacharyyaLikelihood`): eq. 7-9, one histogram per sample,
  O(w h) per particle;
* ``bhattacharyya-bg`` (:class:`BhattacharyyaBackgroundLikelihood`): eq. 23, two histograms per
  sample (target and background), O(w h);
* ``cross-entropy`` (:class:`CrossEntropyLikelihood`): eq. 13-19, O(1);
* ``cross-entropy-bg`` (:class:`CrossEntropyBackgroundLikelihood`): eq. 20-22 and 24, O(1).

The Bhattacharyya baselines build each sample's histogram as the paper does (gather the box's
bin indices and count them, :meth:`~pftrack_colour.histograms.ParticleRegion.box_histograms`),
vectorised over particles.

The cross-entropy likelihoods never build a sample histogram. With ``λ = n`` (the box's pixel
count) eq. 18 says ``log P = Σ_{x in box} log q(bin(x))`` and eq. 21 ``log L = Σ_{x in box}
log(q / h_back)(bin(x)) + const``. Once per frame and target the pixels of the region the
target's particles cover are mapped to that per-pixel value and one integral image is taken;
then each particle costs one look-up (four for boxes of different sizes), so 5,000 particles
cost little more than 500. The common case (same-size boxes wholly inside the image) runs in
compiled kernels (:mod:`pftrack_colour._jit`) with the same numbers bit for bit.

Clipping: a box that leaves the image is clipped. A cross-entropy box's log-likelihood is ``λ``
times the mean per-pixel term over its in-image pixels; a Bhattacharyya sample histogram is
normalised by its in-image pixel count. A box wholly outside the image has log-likelihood
``-inf``.

Histogram floor: every histogram (template, background) is smoothed as
``(p + eps) / (1 + m eps)`` (:func:`~pftrack_colour.histograms.normalise_histogram`; ``eps = 1e-4``
by default), so the logarithm of a colour never seen is finite (about -9.2).

Background (eq. 15, 20): every frame, :meth:`~ColourLikelihood.begin_frame` takes the histogram
of every pixel outside all targets' current colour boxes (their last estimates), on a grid of
every ``background_stride``-th pixel in each direction (default 3: one pixel in nine). The L1
distance between that estimate and the full histogram is about 0.05 on the ``walkers`` frames and
0.02 on PETS 2009. Strides 2 and 4 divide the walkers' 20 px paving period and over-sample its
joints (L1 0.11 and 0.32): a regular grid aliases with regular texture, pick a stride prime to it.

Beyond the paper (all optional, off by default except where said):

* ``parts``: the box is cut into ``parts`` horizontal stripes, each with its own template (a
  person's shirt and trousers); the log-likelihood sums over the stripes. Still O(1) per
  particle and stripe.
* ``region``: the colour model reads only a sub-box (fractions of the box), e.g. a torso.
* ``update_rate``: template update ``q <- (1 - a) q + a p(estimate)`` (the paper keeps q fixed).
* ``overlap`` (``cross-entropy-bg``): how pixels inside another target's box count (joint
  weighting, see :class:`CrossEntropyBackgroundLikelihood`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import cv2
import numpy as np
from pftrack.contracts.components import Detections, Frame, Likelihood, Param, Target
from pftrack.geometry.boxes import sub_boxes

from pftrack_colour import _jit
from pftrack_colour.histograms import (
    COLOUR_SPACES,
    ColourBins,
    ParticleRegion,
    integer_boxes,
    normalise_histogram,
    subsample,
)

__all__ = [
    "BhattacharyyaBackgroundLikelihood",
    "BhattacharyyaLikelihood",
    "ColourLikelihood",
    "CrossEntropyBackgroundLikelihood",
    "CrossEntropyLikelihood",
]

_OVERLAP_MODES = ("mixture", "product", "independent")
_NO_MASKS = np.zeros(0, dtype=np.int64)  # no sets of stripes (writable: the kernels' signature)

class ColourLikelihood(Likelihood):
    """Shared machinery: binning, templates, per-frame background; not registered itself.

    Declares the parameters every colour likelihood shares
    (:class:`pftrack.contracts.components.Param`); subclasses declare their own the same way (their
    ``__init__`` and the ``Parameters`` section of their docstring are generated) and implement
    :meth:`_log_likelihood`.

    Attributes
    ----------
    binner_ : ColourBins
        Pixel -> bin map, built from ``bins`` and ``colour_space`` on first use.
    templates_ : dict[int, ndarray (parts, m)]
        Each live target's template histograms q, one per stripe (floored, each sums to 1).
    target_rects_ : dict[int, ndarray (4,)]
        Each live target's colour box this frame (its last estimate), integer x0, y0, x1, y1.
    background_ : ndarray (m,)
        This frame's background histogram (background likelihoods only).
    image_ : ndarray (H, W, 3) uint8
        The frame being weighted.
    """

    uses_background = False
    needs_own_counts = False

    bins: int | tuple[int, int, int] = Param(8, "Bins per channel (8: 8 x 8 x 8 = 512 bins, "
                                                "the paper).", unit="count", low=1, high=256,
                                             length=3)
    colour_space: str = Param("rgb", 'Colour space of the histograms, one of "rgb" (the '
                                     'paper), "hsv", "lab", "ycrcb", "bgr".',
                              choices=tuple(COLOUR_SPACES))
    eps: float = Param(1e-4, "Histogram floor (see the module docstring).", unit="1", low=0.0,
                       low_open=True)
    region: tuple[float, float, float, float] | None = Param(
        None, "Part of each box the colour model reads, as fractions (fx0, fy0, fx1, fy1) of "
              "its width and height (e.g. (0.15, 0.1, 0.85, 0.9)); None: the whole box.", unit="1",
        low=0.0, high=1.0, length=4)
    parts: int = Param(1, "Horizontal stripes of the colour box, each with its own template "
                          "(1: the paper).", unit="count", low=1)
    update_rate: float = Param(0.0, "Template update q <- (1 - a) q + a p(estimate) once per "
                                    "frame, from the previous frame at the target's last "
                                    "estimate; 0 (the paper): never.", unit="1/frame",
                              low=0.0, high=1.0)

    # -- set-up -------------------------------------------------------------------------------

    def _check_relations(self) -> None:
        region = self.region
        if region is not None:
            r = tuple(float(v) for v in region)
            if not (r[0] < r[2] and r[1] < r[3]):
                raise ValueError(f"{type(self).__name__}: region must be fractions (fx0, fy0, "
                                 f"fx1, fy1) with 0 <= fx0 < fx1 <= 1 and 0 <= fy0 < fy1 <= 1, "
                                 f"got {region!r}")

    def _setup(self) -> ColourBins:
        """Validate the parameters and build the binner (again if they changed)."""
        raw = self.__dict__.get("_setup_raw")
        if (raw is not None and raw[0] is self.bins and raw[1] is self.colour_space
                and raw[2] is self.region and raw[3] is self.parts
                and self.__dict__.get("binner_") is not None):
            return self.binner_  # the same immutable values as at the last check (per frame)
        key = (self.bins if np.isscalar(self.bins) else tuple(self.bins), self.colour_space,
               self.region if self.region is None else tuple(self.region), self.parts)
        if getattr(self, "binner_", None) is None or self._setup_key != key:
            self._validate_params()  # attributes may have been set directly since
            self.binner_ = ColourBins(key[0], key[1])
            self._setup_key = key
            self._parts = [None] if self.parts == 1 else [(k, int(self.parts))
                                                          for k in range(int(self.parts))]
        if not hasattr(self, "templates_"):
            self.templates_: dict[int, np.ndarray] = {}
            self.target_rects_: dict[int, np.ndarray] = {}
            self.values_: dict[int, np.ndarray] = {}
            self.prev_image_: np.ndarray | None = None
        immutable = (type(self.bins) in (int, tuple) and type(self.region) in (type(None), tuple)
                     and type(self.colour_space) is str and type(self.parts) is int)
        self._setup_raw = ((self.bins, self.colour_space, self.region, self.parts)
                           if immutable else None)
        return self.binner_

    def _colour_boxes(self, boxes_xywh_px: np.ndarray) -> np.ndarray:
        return sub_boxes(boxes_xywh_px, self.region)

    def _box_counts(self, image: np.ndarray, box_xywh_px: np.ndarray) -> np.ndarray:
        """Bin counts of the in-image pixels of one box's colour stripes, (parts, m)."""
        binner = self.binner_
        if (_jit.ENABLED and self.parts == 1 and self.region is None
                and binner.conversion is None and image.ndim == 3 and image.dtype == np.uint8):
            # one whole box inside the image: its pixels counted in one compiled pass (integer
            # counts: those of the rounded box ParticleRegion reads, in any order)
            x0, y0, x1, y1 = _integer_rect(box_xywh_px).tolist()
            if 0 <= x0 and 0 <= y0 and x1 <= image.shape[1] and y1 <= image.shape[0]:
                counts = _jit.grid_histogram(image[y0:y1, x0:x1], 1, *binner.channel_luts,
                                             np.zeros((0, 4), dtype=np.int64), binner.n_bins)
                return counts[None]
        region = ParticleRegion(image, self._colour_boxes(np.asarray(box_xywh_px, float)[None]))
        m = self.binner_.n_bins
        if region.n_pixels[0] == 0:
            return np.zeros((len(self._parts), m))
        bins = self.binner_(region.pixels())
        return np.stack([region.box_histograms(bins, m, part)[0] for part in self._parts])

    def template(self, target_id: int) -> np.ndarray:
        """Template histograms of a live target, shape (parts, m)."""
        try:
            return self.templates_[target_id]
        except (KeyError, AttributeError):
            raise KeyError(f"{type(self).__name__}: no template for target {target_id}; "
                           "init_target was not called for it") from None

    # -- life cycle ---------------------------------------------------------------------------

    def init_target(self, frame: Frame, target: Target) -> None:
        """Template from the target's box in its first frame (eq. 5), one per stripe."""
        self._setup()
        counts = self._box_counts(frame.image, target.box_xywh_px)
        if counts.sum() == 0:
            raise ValueError(f"{type(self).__name__}: target {target.id} starts with box "
                             f"{np.round(target.box_xywh_px, 1).tolist()} wholly outside the "
                             f"{frame.size_wh[0]}x{frame.size_wh[1]} image")
        self.templates_[target.id] = normalise_histogram(counts, self.eps)
        self.values_.pop(target.id, None)
        self._value_rows = None

    def end_target(self, target: Target) -> None:
        self.__dict__.get("_log_templates", {}).pop(target.id, None)
        self._value_rows = None
        if hasattr(self, "templates_"):
            self.templates_.pop(target.id, None)
            self.target_rects_.pop(target.id, None)
            self.values_.pop(target.id, None)

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        """Per frame: template update (option), each target's current colour box and, for the
        background likelihoods, the background histogram outside all of them."""
        self._setup()
        live = [t for t in targets if t.id in self.templates_]
        if self.update_rate > 0 and self.prev_image_ is not None:
            # blend in the histogram at the last estimate, in the frame it was estimated in
            a = float(self.update_rate)
            for t in live:
                counts = self._box_counts(self.prev_image_, t.box_xywh_px)
                if counts.sum() > 0:
                    self.templates_[t.id] = ((1 - a) * self.templates_[t.id]
                                             + a * normalise_histogram(counts, self.eps))
        self.image_ = frame.image
        self._rect_rows = None
        ids = [t.id for t in live]
        if not self._compiled_frame(frame.image, live, ids):
            if self.region is None:  # a handful of boxes: rounded one by one (same numbers)
                self.target_rects_ = {t.id: _integer_rect(t.box_xywh_px) for t in live}
            elif live:
                boxes = self._colour_boxes(np.array([t.box_xywh_px for t in live], dtype=float))
                self.target_rects_ = dict(zip((t.id for t in live), integer_boxes(boxes)))
            else:
                self.target_rects_ = {}
            if self.uses_background:
                self._background(frame.image)
        rows = self._value_tables(ids) if ids else None
        if rows is None:
            self.values_ = {i: self._value_table(i) for i in ids}
            self._value_rows = None
        else:  # one (T, parts, m) stack; each target's table is its row
            self.values_ = dict(zip(ids, rows))
            self._value_rows = (ids, rows)
        self.prev_image_ = frame.image if self.update_rate > 0 else None

    def _compiled_frame(self, image: np.ndarray, live: list[Target], ids: list[int]) -> bool:
        """The targets' colour boxes (``target_rects_``) and, for the background likelihoods,
        the background histogram in one compiled call
        (:func:`pftrack_colour._jit.frame_background`: the numbers of the general path); False
        (nothing done) where it does not apply."""
        binner = self.binner_
        if (not live or not _jit.ENABLED or self.region is not None or self.needs_own_counts
                or binner.conversion is not None or image.ndim != 3
                or not image.flags.c_contiguous):
            return False
        boxes = np.array([t.box_xywh_px for t in live], dtype=np.float64)
        if boxes.shape != (len(live), 4):
            return False
        rects = np.empty((len(live), 4), dtype=np.int64)
        s = int(self.background_stride) if self.uses_background else 1
        m = binner.n_bins
        hist, scaled = np.empty(m), np.empty(m)
        ok, counts = _jit.frame_background(image, s, *binner.channel_luts, boxes, m, rects,
                                           self.uses_background, float(self.eps), hist, scaled)
        if not ok:
            return False
        self.target_rects_ = dict(zip(ids, rects))
        self._rect_rows = (ids, rects, np.array(ids, dtype=np.int64))
        if self.uses_background:  # _set_background's numbers, the normalisation compiled
            self.background_counts_ = scaled
            self.background_ = hist
            self.log_background_ = np.log(hist)
            self.own_counts_ = {}
        return True

    def _value_table(self, target_id: int) -> np.ndarray | None:
        """Per-frame, per-target table (parts, m); default none."""
        return None

    def _value_tables(self, ids: list[int]) -> np.ndarray | None:
        """Per-frame tables of several targets at once, (T, parts, m), row ``i`` equal to
        ``_value_table(ids[i])``; None: made one by one."""
        return None

    def _log_template_rows(self, ids: list[int]) -> np.ndarray:
        """``np.log`` of the targets' templates stacked, (T, parts, m), kept while the
        templates are unchanged."""
        qs = [self.template(i) for i in ids]
        hit = self.__dict__.get("_log_rows")
        if hit is None or len(hit[0]) != len(qs) or not all(a is b for a, b in zip(hit[0], qs)):
            hit = self._log_rows = (qs, np.log(np.array(qs)))
        return hit[1]

    def _log_template(self, target_id: int) -> np.ndarray:
        """``np.log`` of a target's templates (parts, m), kept while the template is unchanged
        (templates are replaced, never modified in place)."""
        cache = self.__dict__.setdefault("_log_templates", {})
        q = self.template(target_id)
        hit = cache.get(target_id)
        if hit is None or hit[0] is not q:
            hit = cache[target_id] = (q, np.log(q))
        return hit[1]

    def _background(self, image: np.ndarray) -> None:
        """Background histogram from every ``background_stride``-th pixel outside all targets'
        current colour boxes (eq. 15, 20); for the Bhattacharyya background term also, per
        target, the counts of its own box's grid pixels that no other target covers."""
        s = int(self.background_stride)
        binner = self.binner_
        m = binner.n_bins
        slices = {}
        for tid, r in self.target_rects_.items():
            # grid column j samples image column j*s: those inside [x0, x1)
            gx0, gx1 = -(-max(int(r[0]), 0) // s), -(-max(int(r[2]), 0) // s)
            gy0, gy1 = -(-max(int(r[1]), 0) // s), -(-max(int(r[3]), 0) // s)
            if gx1 > gx0 and gy1 > gy0:
                slices[tid] = (slice(gy0, gy1), slice(gx0, gx1))
        if not self.needs_own_counts and _jit.ENABLED and binner.conversion is None:
            # the counts alone, read off the frame's grid pixels in one compiled pass
            luts = binner.channel_luts
            rects = np.array([(sx.start, sy.start, sx.stop, sy.stop)
                              for sy, sx in slices.values()], dtype=np.int64).reshape(-1, 4)
            counts = _jit.grid_histogram(image, s, *luts, rects, m)
            if len(rects) and not counts.any():  # targets cover the whole image
                counts = _jit.grid_histogram(image, s, *luts, rects[:0], m)
            self._set_background(counts, s)
            return
        sub = subsample(image, s)
        if not self.needs_own_counts:
            # the counts alone: one masked histogram call (same counts as the bin image path)
            keep = None
            if slices:
                keep = np.ones(sub.shape[:2], dtype=np.uint8)
                for sl in slices.values():
                    keep[sl] = 0
            counts = binner.histogram(sub, keep)
            if keep is not None and not counts.any():  # targets cover the whole image
                counts = binner.histogram(sub)
            self._set_background(counts, s)
            return
        grid = binner(sub)
        cover = None
        if slices:
            cover = np.zeros(grid.shape, dtype=np.uint8)
            for sl in slices.values():
                cover[sl] += 1
            counts = np.bincount(grid[cover == 0], minlength=m).astype(np.float64)
        else:
            counts = np.bincount(grid.ravel(), minlength=m).astype(np.float64)
        if counts.sum() == 0:  # targets cover the whole image: no background evidence
            counts = np.bincount(grid.ravel(), minlength=m).astype(np.float64)
        self._set_background(counts, s)
        if self.needs_own_counts and cover is not None:
            for tid, sl in slices.items():
                only = grid[sl][cover[sl] == 1]
                self.own_counts_[tid] = np.bincount(only, minlength=m).astype(np.float64) * (s * s)

    def _set_background(self, counts: np.ndarray, stride: int) -> None:
        """The background histogram from the grid's bin counts (m,)."""
        self.background_counts_ = counts * (stride * stride)  # estimated full-resolution counts
        self.background_ = normalise_histogram(counts, self.eps)
        self.log_background_ = np.log(self.background_)
        self.own_counts_ = {}

    def _coverage(self, region: ParticleRegion, target_id: int,
                  ) -> list[tuple[int, int, tuple[slice, slice]]]:
        """Other targets' colour stripes that intersect ``region``: (id, stripe, slices)."""
        out = []
        p = len(self._parts)
        for tid, r in self.target_rects_.items():
            if tid == target_id:
                continue
            r0, r1, r2, r3 = r.tolist()
            x0, x1 = max(r0, region.x0), min(r2, region.x1)
            if x1 <= x0:
                continue
            h = r3 - r1
            for k in range(p):
                ry0 = r1 + (k * h) // p
                ry1 = r1 + ((k + 1) * h) // p
                y0, y1 = max(ry0, region.y0), min(ry1, region.y1)
                if y1 > y0:
                    out.append((tid, k, (slice(y0 - region.y0, y1 - region.y0),
                                         slice(x0 - region.x0, x1 - region.x0))))
        return out

    # -- weighting ----------------------------------------------------------------------------

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        image = getattr(self, "image_", None)
        if image is None:
            raise RuntimeError(f"{type(self).__name__}: begin_frame was not called before "
                               "log_likelihood")
        q = self.template(target.id)
        boxes = np.asarray(boxes_xywh_px, dtype=np.float64)
        if self.region is not None:
            boxes = self._colour_boxes(boxes)
        out = self._compiled_log_likelihood(image, boxes, target.id)
        if out is not None:
            return out
        region = ParticleRegion(image, boxes)
        if len(region) == 0:
            return np.zeros(0)
        out = self._log_likelihood(region, q, target.id)
        if region.all_inside:
            return out
        return np.where(region.inside, out, -np.inf)

    def _log_likelihood(self, region: ParticleRegion, q: np.ndarray,
                        target_id: int) -> np.ndarray:
        raise NotImplementedError

    def _compiled_log_likelihood(self, image: np.ndarray, boxes: np.ndarray,
                                 target_id: int) -> np.ndarray | None:
        """The log-likelihoods through :mod:`pftrack_colour._jit` where that applies (same
        numbers as :meth:`_log_likelihood`), else None; default: never."""
        return None

    def __getstate__(self) -> dict[str, Any]:
        # the frames being weighted are not part of a pickled likelihood
        d = dict(self.__dict__)
        for k in ("image_", "prev_image_"):
            if k in d:
                d[k] = None
        return d


class _Bounds(NamedTuple):
    """A region's extent in image pixels (end exclusive), as :class:`ParticleRegion` has it."""

    x0: int
    y0: int
    x1: int
    y1: int


def _integer_rect(box_xywh_px: np.ndarray) -> np.ndarray:
    """``integer_boxes(box[None])[0]`` for one box, with Python scalars (begin_frame rounds a
    handful of boxes per frame; numpy's per-call cost dominates there)."""
    v = [c + 0.5 for c in np.asarray(box_xywh_px, dtype=np.float64).reshape(4).tolist()]
    if not all(abs(c) < 1e9 for c in v):  # far away, NaN or infinite: the vectorised rules
        return integer_boxes(np.asarray(box_xywh_px, dtype=np.float64)[None])[0]
    x0, y0, w, h = (math.floor(c) for c in v)
    return np.array([x0, y0, x0 + max(w, 1), y0 + max(h, 1)], dtype=np.int64)


def _bhattacharyya(counts: np.ndarray, n: np.ndarray, sqrt_q: np.ndarray) -> np.ndarray:
    """sqrt(1 - Σ sqrt(q p)) for sample counts (N, m) normalised by n (N,)."""
    bc = np.sqrt(counts / np.maximum(n, 1.0)[:, None]) @ sqrt_q
    return np.sqrt(np.clip(1.0 - bc, 0.0, None))


def _mean_over_parts(dist: list[np.ndarray], pixels: list[np.ndarray]) -> np.ndarray:
    """Mean of per-stripe distances over the stripes that have in-image pixels."""
    if len(dist) == 1:
        return dist[0]
    d = np.stack(dist)
    has = np.stack(pixels) > 0
    return (d * has).sum(axis=0) / np.maximum(has.sum(axis=0), 1)


class BhattacharyyaLikelihood(ColourLikelihood):
    """Bhattacharyya-distance likelihood (eq. 7-9), the paper's baseline.

    ``log P = -λ B(q, p)``, ``B = sqrt(1 - Σ_i sqrt(q(i) p(i)))``, with ``p`` each sample's colour
    histogram (eq. 7) built per particle (vectorised gather and bincount) and normalised by its
    in-image pixel count. With ``parts > 1``, B is the mean over the stripes.

    {params}
    """

    lam: float = Param(20.0, "λ of eq. 9 (dimensionless).", unit="1", low=0.0, low_open=True)

    def _log_likelihood(self, region, q, target_id):
        binner = self.binner_
        bins = binner(region.pixels())
        dist, pixels = [], []
        for k, part in enumerate(self._parts):
            counts = region.box_histograms(bins, binner.n_bins, part)
            n = region.part_pixels(part)
            dist.append(_bhattacharyya(counts, n, np.sqrt(q[k])))
            pixels.append(n)
        return -float(self.lam) * _mean_over_parts(dist, pixels)


class BhattacharyyaBackgroundLikelihood(ColourLikelihood):
    """Bhattacharyya with background (eq. 23), the paper's baseline with background.

    ``log P = -λ (B(q, p) + B(h_back, p_back))``: ``p`` is the sample's histogram, ``p_back`` the
    histogram of the background if the target stood at the sample (everything outside the other
    targets' current boxes and the sample's box), ``h_back`` this frame's background histogram
    (outside all targets' current boxes). Both sample histograms are built per particle.

    {params}
    """

    uses_background = True
    needs_own_counts = True

    lam: float = Param(20.0, "λ of eq. 23 (dimensionless).", unit="1", low=0.0, low_open=True)
    background_stride: int = Param(3, "The background histogram reads every "
                                      "background_stride-th pixel in each direction.", unit="px",
                                   low=1)

    def _log_likelihood(self, region, q, target_id):
        binner = self.binner_
        m = binner.n_bins
        bins = binner(region.pixels()).astype(np.int32)
        # pixels inside another target's box: bin + m (they belong to the sample's histogram
        # but not to the background it displaces)
        for _, _, sl in self._coverage(region, target_id):
            sub = bins[sl]
            bins[sl] = np.where(sub < m, sub + m, sub)
        dist, pixels = [], []
        free = 0.0
        for k, part in enumerate(self._parts):
            counts = region.box_histograms(bins, 2 * m, part)
            n = region.part_pixels(part)
            dist.append(_bhattacharyya(counts[:, :m] + counts[:, m:], n, np.sqrt(q[k])))
            pixels.append(n)
            free = free + counts[:, :m]
        b_target = _mean_over_parts(dist, pixels)
        # background with the sample's box: everything outside the other targets' boxes ...
        g = self.background_counts_ + self.own_counts_.get(target_id, 0.0)
        back = np.clip(g[None, :] - free, 0.0, None)  # ... minus what the sample's box covers
        s = back.sum(axis=1)
        b_back = _bhattacharyya(back, s, np.sqrt(self.background_))
        return -float(self.lam) * (b_target + b_back)


class CrossEntropyLikelihood(ColourLikelihood):
    """Cross-entropy likelihood (eq. 13-19), O(1) per particle.

    ``log P = -λ H(p, q) = λ Σ_i p(i) log q(i)``; with ``λ = n`` (``lam=None``, the paper's
    choice) this is ``Σ_{x in box} log q(bin(x))`` (eq. 18), read from an integral image of
    ``log q(bin(x))`` over the region the particles cover. With ``parts > 1`` each stripe's
    pixels use their stripe's template.

    {params}
    """

    lam: float | None = Param(None, "λ of eq. 13; None: the box's pixel count n (eq. 18).",
                              unit="1", low=0.0, low_open=True)
    method: str = Param("integral", '"integral" (default): O(1) per particle. "histogram": '
                                    "build each sample's histogram and take eq. 14 literally "
                                    "(same numbers; for checking and for timing).",
                        choices=("integral", "histogram"))

    def prepare(self) -> None:
        """Validate the parameters and load the compiled kernels (compiling them on the
        process's first use), so that the first frame does not pay for it."""
        self._setup()
        if self.method == "integral":
            _jit.warm_up()

    def _value_table(self, target_id: int) -> np.ndarray:
        """Per-bin value whose sum over a box's pixels is the log-likelihood (λ = n), one row
        per stripe, float32."""
        return self._log_template(target_id).astype(np.float32)

    def _value_tables(self, ids: list[int]) -> np.ndarray:
        return self._log_template_rows(ids).astype(np.float32)

    def _log_likelihood(self, region, q, target_id):
        binner = self.binner_
        table = self._table(target_id)
        bins = binner(region.pixels())
        sums = 0.0
        if self.method == "histogram":
            for k, part in enumerate(self._parts):
                sums = sums + region.box_histograms(bins, binner.n_bins, part) @ table[k]
        else:
            for k, part in enumerate(self._parts):
                box = region.box_sums(self._value_image(region, bins, table, k, target_id), part)
                # integral-image sums are never -0.0, so 0.0 + box would be box bit for bit
                sums = box if k == 0 else sums + box
        if self.lam is None and region.all_inside:  # λ = n: the sum itself (eq. 18, 21)
            return sums
        lam = region.box_area if self.lam is None else float(self.lam)
        return lam * sums / np.maximum(region.n_pixels, 1.0)

    def _compiled_log_likelihood(self, image, boxes, target_id):
        """Same-size boxes wholly inside the image: one compiled call lays the boxes out and
        one per stripe sums the per-pixel values through an integral image (the numbers of the
        integral path bit for bit, without its forty-odd array calls per target)."""
        if self.method != "integral" or not _jit.ENABLED or boxes.ndim != 2 \
                or boxes.shape[1] != 4:
            return None
        h, w = image.shape[:2]
        ok, x0, y0, x1, y1, bw, bh, xs, ys = _jit.fixed_layout(boxes, w, h)
        if not ok:
            return None
        overlays = self._overlays(_Bounds(x0, y0, x1, y1), target_id)
        if overlays is None:
            return None
        table = self._table(target_id)
        binner = self.binner_
        pixels = image[y0:y1, x0:x1]
        if binner.conversion is not None:
            pixels = cv2.cvtColor(np.ascontiguousarray(pixels), binner.conversion)
        l0, l1, l2 = binner.channel_luts
        rects, tables = overlays
        sums = None
        for k, part in enumerate(self._parts):
            oy, sh = 0, bh
            if part is not None:
                oy = (part[0] * bh) // part[1]
                sh = ((part[0] + 1) * bh) // part[1] - oy
            if sh <= 0:
                box = np.zeros(len(xs))
            else:
                box = _jit.value_box_sums(pixels, l0, l1, l2, table[k], rects, tables[k], xs,
                                          ys, oy, sh, bw)
            sums = box if k == 0 else sums + box
        if self.lam is None:  # λ = n: the sum itself (eq. 18, 21)
            return sums
        return float(self.lam) * sums / float(max(bw * bh, 1))  # n = bw bh for every box

    def log_likelihood_rows(self, boxes_xywh_px: np.ndarray,
                            targets: Sequence[Target]) -> np.ndarray:
        """Every target's log-likelihoods in one call, (T, N, 4) boxes -> (T, N): one compiled
        pass (:func:`pftrack_colour._jit.value_box_sums_rows`) lays out each target's boxes,
        finds the other targets' stripes over them and sums the per-pixel values through an
        integral image, target after target. Row ``i`` equals ``log_likelihood(
        boxes_xywh_px[i], targets[i])`` bit for bit; a target the kernel does not cover (boxes
        leaving the image or of different sizes, pixels under two other targets, a colour
        conversion, the ``histogram`` method) takes :meth:`log_likelihood`."""
        boxes = np.asarray(boxes_xywh_px, dtype=np.float64)
        n_t = len(targets)
        if boxes.ndim != 3 or boxes.shape[0] != n_t or boxes.shape[2] != 4:
            raise ValueError(f"{type(self).__name__}.log_likelihood_rows: boxes must have shape "
                             f"(T, N, 4) with T = {n_t} targets, got {boxes.shape}")
        image = getattr(self, "image_", None)
        if image is None:
            raise RuntimeError(f"{type(self).__name__}: begin_frame was not called before "
                               "log_likelihood_rows")
        binner = self.binner_
        if (not n_t or self.method != "integral" or not _jit.ENABLED
                or binner.conversion is not None or not image.flags.c_contiguous):
            return super().log_likelihood_rows(boxes, targets)
        ids = [t.id for t in targets]
        frame_rows = self.__dict__.get("_rect_rows")
        ids_arr = frame_rows[2] if frame_rows is not None and frame_rows[0] == ids else \
            np.array(ids, dtype=np.int64)
        tables = self._table_rows(ids)
        cboxes = boxes if self.region is None else \
            self._colour_boxes(boxes.reshape(-1, 4)).reshape(boxes.shape)
        if not cboxes.flags.c_contiguous:
            cboxes = np.ascontiguousarray(cboxes)
        rects, rect_ids, pairs = self._pair_rows(ids)
        out = np.empty(boxes.shape[:2])
        done = np.empty(n_t, dtype=np.bool_)
        l0, l1, l2 = binner.channel_luts
        lam = 0.0 if self.lam is None else float(self.lam)
        overlays = pairs.shape[2] > 0
        no_masks = _NO_MASKS
        _jit.value_box_sums_rows(image, l0, l1, l2, tables, cboxes, ids_arr, rects, rect_ids,
                                 pairs, no_masks, pairs[:, :, :0, 0], overlays, lam, out, done)
        if False not in done.tolist():  # every target done (a list: cheaper than .all() for few)
            return out
        left = np.flatnonzero(~done)
        if overlays:  # pixels under several stripes: again with the tables of those sets
            masks, combos = self._combo_rows(ids, rects, rect_ids)
            if len(masks):
                sub = np.empty((len(left), out.shape[1]))
                sub_done = np.empty(len(left), dtype=np.bool_)
                _jit.value_box_sums_rows(image, l0, l1, l2, tables[left], cboxes[left],
                                         ids_arr[left], rects, rect_ids, pairs[left], masks,
                                         combos[left], True, lam, sub, sub_done)
                out[left[sub_done]] = sub[sub_done]
                left = left[~sub_done]
        for i in left.tolist():
            out[i] = self.log_likelihood(boxes[i], targets[i])
        return out

    def _table_rows(self, ids: list[int]) -> np.ndarray:
        """This frame's value tables of the targets ``ids``, (T, parts, m) float32,
        C-contiguous (begin_frame's stack when it made them for these targets)."""
        rows = self.__dict__.get("_value_rows")
        if rows is not None and rows[0] == ids:
            return rows[1]
        return np.array([self._table(i) for i in ids], dtype=np.float32)

    def _pair_rows(self, ids: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Other targets' colour boxes for the compiled batch: their rectangles (K, 4) int64,
        their ids (K,) and the per-pair tables (T, parts, K, parts, m) float32 (K = 0: no
        pixel takes another table)."""
        m = self.binner_.n_bins
        p = len(self._parts)
        return (np.zeros((0, 4), dtype=np.int64), np.zeros(0, dtype=np.int64),
                np.zeros((len(ids), p, 0, p, m), dtype=np.float32))

    def _combo_rows(self, ids: list[int], rects: np.ndarray, rect_ids: np.ndarray,
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Sets of two or more other targets' stripes that cover common pixels, as bit masks
        (C,) int64 (bit ``r * parts + kk``: stripe ``kk`` of box ``r``), and the value tables
        (T, parts, C, m) float32 of a pixel under exactly such a set; none by default (no
        pixel takes another table)."""
        p = len(self._parts)
        return (np.zeros(0, dtype=np.int64),
                np.zeros((len(ids), p, 0, self.binner_.n_bins), dtype=np.float32))

    def _table(self, target_id: int) -> np.ndarray:
        """This frame's value table (parts, m) of a target (made now for one born after
        begin_frame)."""
        table = self.values_.get(target_id)
        if table is None:
            table = self.values_[target_id] = self._value_table(target_id)
        return table

    def _overlays(self, region: ParticleRegion | _Bounds, target_id: int,
                  ) -> tuple[np.ndarray, list[np.ndarray]] | None:
        """Rectangles of the region whose pixels take their value from another table, (K, 4)
        int64 ``(x0, y0, x1, y1)``, and per stripe the (K, m) float32 tables; None: the
        compiled path cannot express this region's values."""
        m = self.binner_.n_bins
        empty = np.zeros((0, m), dtype=np.float32)
        return np.zeros((0, 4), dtype=np.int64), [empty] * len(self._parts)

    def _value_image(self, region: ParticleRegion, bins: np.ndarray, table: np.ndarray,
                     part: int, target_id: int) -> np.ndarray:
        """Per-pixel value of the region for stripe ``part``, (rows, cols) float32."""
        return table[part][bins]


class CrossEntropyBackgroundLikelihood(CrossEntropyLikelihood):
    """Cross entropy with background by the fast equivalent (eq. 20-22, 24), O(1) per particle.

    ``log L = λ / n Σ_{x in box} log(q / h_back)(bin(x)) + const`` (eq. 21 with λ = n): only the
    pixels the particles cover are read, through an integral image.

    Joint weighting (eq. 15): the background excludes all targets' current boxes. Pixels of a
    sample's box that lie inside another target's current box are not background whether or not
    the sample covers them; ``overlap`` says how they count:

    * ``"mixture"`` (default): such a pixel is explained by the mixture of the histograms of the
      targets covering it, and the sample adds its own: ``log((q + S) / (K + 1)) - log(S / K)``
      with ``S`` the sum of the ``K`` covering targets' histograms at the pixel's colour. An
      occluding target's colours cost the sample little (``log 1/2``); its own colours seen in
      front of another target still count for it.
    * ``"product"``: eq. 15 read literally (the targets' histograms multiply): ``log q``.
    * ``"independent"``: eq. 22 per target, as if no other target existed: ``log(q / h_back)``.

    {params}
    """

    uses_background = True

    lam: float | None = Param(None, "λ of eq. 13; None: the box's pixel count n (eq. 18, "
                                    "21).", unit="1", low=0.0, low_open=True)
    method: str = Param("integral", 'As CrossEntropyLikelihood ("histogram" needs '
                                    'overlap="independent").', choices=("integral", "histogram"))
    background_stride: int = Param(3, "The background histogram reads every "
                                      "background_stride-th pixel in each direction.", unit="px",
                                   low=1)
    overlap: str = Param("mixture", 'How pixels under another target count: "mixture", '
                                    '"product" or "independent" (above).', choices=_OVERLAP_MODES)

    def _check_relations(self) -> None:
        super()._check_relations()
        if self.method == "histogram" and self.overlap != "independent":
            raise ValueError(f"{type(self).__name__}: method='histogram' computes eq. 21 "
                             "literally and needs overlap='independent'")

    def _value_table(self, target_id: int) -> np.ndarray:
        return (self._log_template(target_id) - self.log_background_).astype(np.float32)

    def _value_tables(self, ids: list[int]) -> np.ndarray:
        lq = self._log_template_rows(ids)
        # the float64 difference cast to float32 as it is written: astype's numbers, one pass
        return np.subtract(lq, self.log_background_, out=np.empty(lq.shape, dtype=np.float32),
                           casting="same_kind")

    def _log_likelihood(self, region, q, target_id):
        self._cover_cache = None  # per call: the other targets' coverage of this region
        return super()._log_likelihood(region, q, target_id)

    def _overlays(self, region, target_id):
        if self.overlap == "independent":
            return super()._overlays(region, target_id)
        cover = self._coverage(region, target_id)
        if not cover:
            return super()._overlays(region, target_id)
        if not _disjoint(cover):
            return None  # pixels under two other targets: the general (masked) path
        rects = np.array([(sx.start, sy.start, sx.stop, sy.stop) for _, _, (sy, sx) in cover],
                         dtype=np.int64)
        tables = [np.array([self._pair_table(target_id, k, tid, other) for tid, other, _ in cover])
                  for k in range(len(self._parts))]
        return rects, tables

    def _value_image(self, region, bins, table, part, target_id):
        values = table[part][bins]
        if self.overlap == "independent":
            return values
        if self._cover_cache is None:
            cover = self._coverage(region, target_id)
            if _disjoint(cover):
                # each covered pixel lies under one other target's stripe: its value is a
                # function of its bin alone, read from a per-pair table (same numbers)
                self._cover_cache = (cover, None, None, None)
            else:
                self._cover_cache = (None, *self._cover_sums(region, bins, target_id, cover))
        cover, covered, s_cov, k_cov = self._cover_cache
        if cover is not None:
            for tid, k, sl in cover:
                values[sl] = self._pair_table(target_id, part, tid, k)[bins[sl]]
            return values
        qk = self.template(target_id)[part].astype(np.float32)
        qv = qk[bins[covered]]
        if self.overlap == "product":
            values[covered] = np.log(qv)
        else:  # mixture
            values[covered] = np.log((qv + s_cov) / (k_cov + 1.0)) - np.log(s_cov / k_cov)
        return values

    def _pair_rows(self, ids: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.overlap == "independent" or not self.target_rects_:
            return super()._pair_rows(ids)
        rect_ids = list(self.target_rects_)
        tp = self.templates_
        try:
            own = [tp[i] for i in ids]
            others = own if rect_ids == ids else [tp[i] for i in rect_ids]
        except KeyError:
            own = [self.template(i) for i in ids]  # raises, naming the target
            others = [self.template(i) for i in rect_ids]
        hit = self.__dict__.get("_pair_stack")
        if (hit is not None and hit[0] == ids and hit[1] == rect_ids
                and all(a is b for a, b in zip(hit[2], own))
                and (others is own or all(a is b for a, b in zip(hit[3], others)))):
            pairs = hit[4]
        else:
            p = len(self._parts)
            pairs = np.zeros((len(ids), p, len(rect_ids), p, self.binner_.n_bins),
                             dtype=np.float32)
            for i, tid in enumerate(ids):
                for r, oid in enumerate(rect_ids):
                    if oid != tid:
                        for k in range(p):
                            for kk in range(p):
                                pairs[i, k, r, kk] = self._pair_table(tid, k, oid, kk)
            self._pair_stack = (ids, rect_ids, own, others, pairs)
        frame_rows = self.__dict__.get("_rect_rows")
        if frame_rows is not None and frame_rows[0] == rect_ids:  # begin_frame's arrays
            return frame_rows[1], frame_rows[2], pairs
        rects = np.array(list(self.target_rects_.values()), dtype=np.int64).reshape(-1, 4)
        return rects, np.array(rect_ids, dtype=np.int64), pairs

    def _combo_rows(self, ids: list[int], rects: np.ndarray, rect_ids: np.ndarray,
                    ) -> tuple[np.ndarray, np.ndarray]:
        p = len(self._parts)
        k_rects = len(rects)
        if self.overlap == "independent" or k_rects < 2 or k_rects * p > 62:
            return super()._combo_rows(ids, rects, rect_ids)
        # every stripe's rectangle, in the order of _coverage (box, then stripe)
        stripes = []
        for r0, r1, r2, r3 in rects.tolist():
            h = r3 - r1
            for kk in range(p):
                stripes.append((r0, r1 + (kk * h) // p, r2, r1 + ((kk + 1) * h) // p))
        n = len(stripes)
        meets = [[a != b and stripes[a][0] < stripes[b][2] and stripes[b][0] < stripes[a][2]
                  and stripes[a][1] < stripes[b][3] and stripes[b][1] < stripes[a][3]
                  for b in range(n)] for a in range(n)]
        # sets of rectangles that meet pairwise share pixels (boxes: Helly in each axis)
        sets: list[tuple[int, ...]] = []
        frontier = [(a, b) for a in range(n) for b in range(a + 1, n) if meets[a][b]]
        while frontier and len(sets) < 256:
            sets.extend(frontier)
            frontier = [c + (d,) for c in frontier for d in range(c[-1] + 1, n)
                        if all(meets[e][d] for e in c)]
        if not sets or len(sets) >= 256:
            return super()._combo_rows(ids, rects, rect_ids)
        rid = rect_ids.tolist()
        masks = np.array([sum(1 << g for g in c) for c in sets], dtype=np.int64)
        tables = np.zeros((len(ids), p, len(sets), self.binner_.n_bins), dtype=np.float32)
        for i, tid in enumerate(ids):
            for c, members in enumerate(sets):
                cover = [(rid[g // p], g % p) for g in members]
                if any(oid == tid for oid, _ in cover):
                    continue  # a target's own stripes never cover its samples' pixels
                for k in range(p):
                    tables[i, k, c] = self._combo_table(tid, k, cover)
        return masks, tables

    def _combo_table(self, target_id: int, part: int, cover: list[tuple[int, int]],
                     ) -> np.ndarray:
        """Value (m,) float32 of a pixel of stripe ``part`` of ``target_id``'s sample under the
        stripes ``cover`` ((id, stripe), in the order of _coverage): what the general path
        (:meth:`_cover_sums`, :meth:`_value_image`) computes, S summed in that order, K their
        number. Kept while the templates are unchanged."""
        cache = self.__dict__.setdefault("_combo_tables", {})
        key = (target_id, part, tuple(cover))
        qs = (self.template(target_id),) + tuple(self.template(o) for o, _ in cover)
        hit = cache.get(key)
        if hit is not None and all(a is b for a, b in zip(hit[0], qs)):
            return hit[1]
        qk = qs[0][part].astype(np.float32)
        if self.overlap == "product":
            table = np.log(qk)
        else:  # mixture
            s_cov = np.zeros(len(qk), dtype=np.float32)
            for (_, kk), q in zip(cover, qs[1:]):
                s_cov += q[kk].astype(np.float32)
            k_cov = np.full(len(qk), len(cover), dtype=np.float32)
            table = np.log((qk + s_cov) / (k_cov + 1.0)) - np.log(s_cov / k_cov)
        cache[key] = (qs, table)
        return table

    def _pair_table(self, target_id: int, part: int, other_id: int, other_part: int,
                    ) -> np.ndarray:
        """Value (m,) float32 of a pixel of stripe ``part`` of ``target_id``'s sample that lies
        under stripe ``other_part`` of ``other_id``'s box only: what the general path computes
        with ``S = q_other`` and ``K = 1``. Kept while both templates are unchanged."""
        cache = self.__dict__.setdefault("_pair_tables", {})
        key = (target_id, part, other_id, other_part)
        q_own, q_other = self.template(target_id), self.template(other_id)
        hit = cache.get(key)
        if hit is not None and hit[0] is q_own and hit[1] is q_other:
            return hit[2]
        qk = q_own[part].astype(np.float32)
        if self.overlap == "product":
            table = np.log(qk)
        else:  # mixture, K = 1
            s_cov = q_other[other_part].astype(np.float32)
            k_cov = np.ones(1, dtype=np.float32)
            table = np.log((qk + s_cov) / (k_cov + 1.0)) - np.log(s_cov / k_cov)
        cache[key] = (q_own, q_other, table)
        return table

    def end_target(self, target: Target) -> None:
        super().end_target(target)
        cache = getattr(self, "_pair_tables", None)
        if cache:
            for key in [k for k in cache if target.id in (k[0], k[2])]:
                del cache[key]
        combos = getattr(self, "_combo_tables", None)
        if combos:
            for key in [k for k in combos
                        if k[0] == target.id or any(o == target.id for o, _ in k[2])]:
                del combos[key]

    def _cover_sums(self, region, bins, target_id, cover=None):
        """Pixels of the region inside other targets' boxes, with S (sum of their histograms at
        each pixel's colour) and K (how many cover it)."""
        if cover is None:
            cover = self._coverage(region, target_id)
        if not cover:
            return None, None, None
        rows, cols = region.shape
        s_sum = np.zeros((rows, cols), dtype=np.float32)
        k = np.zeros((rows, cols), dtype=np.float32)
        for tid, part, sl in cover:
            s_sum[sl] += self.template(tid)[part].astype(np.float32)[bins[sl]]
            k[sl] += 1.0
        covered = k > 0
        return covered, s_sum[covered], k[covered]


def _disjoint(cover: list[tuple[int, int, tuple[slice, slice]]]) -> bool:
    """No two of the rectangles (row slice, column slice) overlap."""
    for i in range(1, len(cover)):
        ys, xs = cover[i][2]
        for _, _, (ys2, xs2) in cover[:i]:
            if (ys.start < ys2.stop and ys2.start < ys.stop
                    and xs.start < xs2.stop and xs2.start < xs.stop):
                return False
    return True


