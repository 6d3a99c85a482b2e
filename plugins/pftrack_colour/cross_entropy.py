"""The cross-entropy likelihoods of the colour paper: ``cross-entropy``
(:class:`CrossEntropyLikelihood`, eq. 13-19) and ``cross-entropy-bg``
(:class:`CrossEntropyBackgroundLikelihood`, eq. 20-22 and 24), O(1) per particle through one
integral image per frame and target (:mod:`pftrack_colour.likelihoods` describes them with the
Bhattacharyya baselines; they import from there as well).
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np
from pftrack.contracts.components import Param, Target

from pftrack_colour import _jit
from pftrack_colour.histograms import (
    ParticleRegion,
)
from pftrack_colour.template import _NO_MASKS, _OVERLAP_MODES, ColourLikelihood, _Bounds


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
