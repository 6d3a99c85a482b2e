"""What every colour likelihood of :mod:`pftrack_colour.likelihoods` shares:
:class:`ColourLikelihood`, the base class that takes each target's template histogram ``q``
from its initial box (eq. 5), the background histogram every frame (eq. 15, 20), the stripes
(``parts``), the sub-box (``region``) and the template update. The likelihoods, their equations
and the conventions (clipping, histogram floor, background stride) are described in
:mod:`pftrack_colour.likelihoods`, where they all import from.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

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
