"""numba kernels of the EMD and NCC likelihoods (:mod:`pftrack_world.likelihoods`). This module
imports numba; the likelihoods import it on first use (``PFTRACK_NO_JIT=1``: their numpy paths).

At the tracker's usual 200 particles per target, the numpy paths of
:meth:`~pftrack_world.likelihoods.EMDLikelihood.distance` and
:meth:`~pftrack_world.likelihoods.NCCLikelihood.ncc` are some twenty array calls each per target
and frame on arrays of a few hundred KB (grid samples, a bincount, cumulative sums; a corner
gather, masked means, products), and those calls are the cost. Each kernel here does a target's
particles in one pass and returns the same numbers bit for bit: the same float operations in
the same order (no fast-math), sums over an axis in numpy's own pairwise order
(:func:`pftrack.filter._kernels.pairwise_sum`), so that every figure of the pipelines that use
them stays identical; the tests compare both paths.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from pftrack.filter._kernels import pairwise_sum as _pairwise

_JIT = {"cache": True, "nogil": True}


@njit(**_JIT)  # type: ignore[call-overload]
def emd_distances(quantised, sb, gw, gh, bins, template, out):  # pragma: no cover - compiled
    """:meth:`EMDLikelihood.distance` for the windows ``sb`` (N, 4) (the boxes' histogrammed
    regions, xywh px): ``out[i]`` the per-channel exact 1-D EMD between the histogram of the
    ``gw x gh`` grid samples of ``quantised`` (H, W, 3) uint8 bin indices and ``template``
    (3, bins), averaged over channels and divided by ``bins - 1``; NaN where no sample lies in
    the image."""
    H, W = quantised.shape[0], quantised.shape[1]
    n = sb.shape[0]
    xi = np.empty(gw, np.int64)
    yi = np.empty(gh, np.int64)
    vx = np.empty(gw, np.bool_)
    vy = np.empty(gh, np.bool_)
    counts = np.empty((3, bins))
    tcum = np.empty((3, bins))
    diff = np.empty(bins)
    per = np.empty(3)
    for c in range(3):
        acc = template[c, 0]
        tcum[c, 0] = acc
        for b in range(1, bins):
            acc = acc + template[c, b]
            tcum[c, b] = acc
    for i in range(n):
        for j in range(gw):
            xs = np.floor(sb[i, 0] + sb[i, 2] * ((j + 0.5) / gw))
            ok = np.isfinite(xs) and xs >= 0 and xs < W
            vx[j] = ok
            xi[j] = np.int64(xs) if ok else 0
        for j in range(gh):
            ys = np.floor(sb[i, 1] + sb[i, 3] * ((j + 0.5) / gh))
            ok = np.isfinite(ys) and ys >= 0 and ys < H
            vy[j] = ok
            yi[j] = np.int64(ys) if ok else 0
        counts[:] = 0.0
        k = 0
        for a in range(gh):
            if not vy[a]:
                continue
            for b in range(gw):
                if vx[b]:
                    for c in range(3):
                        counts[c, quantised[yi[a], xi[b], c]] += 1.0
                    k += 1
        if k == 0:
            out[i] = np.nan
            continue
        kk = np.float64(k)
        for c in range(3):
            acc = counts[c, 0] / kk
            diff[0] = abs(acc - tcum[c, 0])
            for b in range(1, bins):
                acc = acc + counts[c, b] / kk
                diff[b] = abs(acc - tcum[c, b])
            per[c] = _pairwise(diff, 0, bins)
        out[i] = (_pairwise(per, 0, 3) / 3.0) / (bins - 1)


@njit(**_JIT)  # type: ignore[call-overload]
def ncc_values(integral, sb, gw, gh, template, min_valid, out):  # pragma: no cover - compiled
    """:meth:`NCCLikelihood.ncc` for the windows ``sb`` (N, 4) (xywh px): ``out[i]`` the
    normalised cross-correlation in [-1, 1] of the ``gw x gh`` cell means of the window (from
    ``integral`` (H+1, W+1), cells with no pixel in the image left out) with ``template``
    (gh * gw,), over the valid cells; NaN when fewer than ``min_valid`` of the cells are
    valid."""
    H, W = integral.shape[0] - 1, integral.shape[1] - 1
    n = sb.shape[0]
    k = gw * gh
    xe = np.empty(gw + 1, np.int64)
    ye = np.empty(gh + 1, np.int64)
    vals = np.empty(k)
    m = np.empty(k)
    t1 = np.empty(k)
    t2 = np.empty(k)
    di = np.empty(k)
    dt = np.empty(k)
    for i in range(n):
        x0, y0, w, h = sb[i, 0], sb[i, 1], sb[i, 2], sb[i, 3]
        bad = not (np.isfinite(x0) and np.isfinite(y0) and np.isfinite(w) and np.isfinite(h))
        if bad:
            x0 = y0 = w = h = 0.0
        for j in range(gw + 1):
            v = np.floor(x0 + w * (j / gw) + 0.5)
            xe[j] = np.int64(min(max(v, 0.0), np.float64(W)))
        for j in range(gh + 1):
            v = np.floor(y0 + h * (j / gh) + 0.5)
            ye[j] = np.int64(min(max(v, 0.0), np.float64(H)))
        for a in range(gh):
            for b in range(gw):
                c = a * gw + b
                area = (ye[a + 1] - ye[a]) * (xe[b + 1] - xe[b])
                if area > 0 and not bad:
                    s = ((integral[ye[a + 1], xe[b + 1]] - integral[ye[a], xe[b + 1]])
                         - integral[ye[a + 1], xe[b]]) + integral[ye[a], xe[b]]
                    vals[c] = s / np.float64(area)
                    m[c] = 1.0
                else:
                    vals[c] = 0.0
                    m[c] = 0.0
        cnt = _pairwise(m, 0, k)
        nn = max(cnt, 1.0)
        for c in range(k):
            t1[c] = vals[c] * m[c]
            t2[c] = template[c] * m[c]
        mi = _pairwise(t1, 0, k) / nn
        mt = _pairwise(t2, 0, k) / nn
        for c in range(k):
            di[c] = (vals[c] - mi) * m[c]
            dt[c] = (template[c] - mt) * m[c]
        for c in range(k):
            t1[c] = di[c] * dt[c]
        num = _pairwise(t1, 0, k)
        for c in range(k):
            t1[c] = di[c] * di[c]
            t2[c] = dt[c] * dt[c]
        den = np.sqrt(_pairwise(t1, 0, k) * _pairwise(t2, 0, k))
        r = num / den if den > 1e-12 else 0.0
        if cnt < min_valid * k:
            r = np.nan
        elif r < -1.0:
            r = -1.0
        elif r > 1.0:
            r = 1.0
        out[i] = r


def warm_up() -> None:
    """Load both kernels (from numba's cache, or compile them) with tiny arguments of the types
    the likelihoods pass, so that the first frame does not pay for it."""
    box = np.array([[0.0, 0.0, 2.0, 2.0]])
    out = np.empty(1)
    emd_distances(np.zeros((2, 2, 3), np.uint8), box, 1, 1, 2, np.full((3, 2), 0.5), out)
    ncc_values(np.zeros((3, 3)), box, 1, 1, np.zeros(1), 0.5, out)
