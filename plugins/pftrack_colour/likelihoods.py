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

The base class every colour likelihood shares is in :mod:`pftrack_colour.template`, the
cross-entropy likelihoods in :mod:`pftrack_colour.cross_entropy`; this module holds the
Bhattacharyya baselines, and every likelihood imports from here.
"""

from __future__ import annotations

import numpy as np
from pftrack.contracts.components import Param

from pftrack_colour.cross_entropy import (  # noqa: F401 (_disjoint: read by the tests)
    CrossEntropyBackgroundLikelihood,
    CrossEntropyLikelihood,
    _disjoint,
)
from pftrack_colour.template import (  # noqa: F401 (_integer_rect: named by the kernels' docs)
    ColourLikelihood,
    _integer_rect,
)

__all__ = [
    "BhattacharyyaBackgroundLikelihood",
    "BhattacharyyaLikelihood",
    "ColourLikelihood",
    "CrossEntropyBackgroundLikelihood",
    "CrossEntropyLikelihood",
]


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

