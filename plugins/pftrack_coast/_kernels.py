"""numba kernels of the volume tracker (:mod:`pftrack_coast.volumes`) and the eigenspace
likelihood (:mod:`pftrack_coast.likelihood`). This module imports numba; they import it on
first use (``PFTRACK_NO_JIT=1``: their numpy paths).

Each kernel does, in one pass over the particles, what its caller's numpy path does in several:
comparisons, ``floor`` and the same float operations in the same order (no fast-math), so the
results are the same bit for bit; the tests compare both paths.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_JIT = {"cache": True, "nogil": True}


@njit(**_JIT)  # type: ignore[call-overload]
def region_mask(local, lim, px, lo, hi, gate, out):  # pragma: no cover - compiled
    """``out[i]``: particle ``i`` lies in the cuboid (``|local[i, j]| <= lim[j]`` for the 3
    axes) and, when ``gate``, its pixel ``px[i]`` lies in the box ``lo[0]``-``hi[0]``
    (inclusive), else in none of the boxes ``lo[b]``-``hi[b]`` (B, 2). NaN pixels lie in no
    box."""
    n, nb = local.shape[0], lo.shape[0]
    for i in range(n):
        ok = abs(local[i, 0]) <= lim[0] and abs(local[i, 1]) <= lim[1] \
            and abs(local[i, 2]) <= lim[2]
        if ok and nb:
            u, v = px[i, 0], px[i, 1]
            hit = False
            for b in range(nb):
                if u >= lo[b, 0] and v >= lo[b, 1] and u <= hi[b, 0] and v <= hi[b, 1]:
                    hit = True
                    break
            ok = hit if gate else not hit
        out[i] = ok


@njit(**_JIT)  # type: ignore[call-overload]
def blocks_of_pixels(px, block_size, rows, cols, ok, idx):  # pragma: no cover - compiled
    """:func:`pftrack_coast.likelihood._blocks_of_pixels` in one pass: ``ok`` (N,) whether
    pixel ``i`` falls in the block grid, ``idx[:count]`` the block indices ``row * cols + col``
    of those that do, in order; returns ``count``."""
    m = 0
    for i in range(px.shape[0]):
        c = np.floor(px[i, 0] / block_size)
        r = np.floor(px[i, 1] / block_size)
        inside = np.isfinite(c) and np.isfinite(r) and c >= 0 and c < cols and r >= 0 \
            and r < rows
        ok[i] = inside
        if inside:
            idx[m] = int(r * cols + c)
            m += 1
    return m


def warm_up() -> None:
    """Load every kernel (from numba's cache, or compile it) with tiny arguments of the types
    the callers pass, so that the first frame does not pay for it."""
    px = np.zeros((1, 2))
    region_mask(np.zeros((1, 3)), np.ones(3), px, np.zeros((1, 2)), np.ones((1, 2)), True,
                np.empty(1, dtype=np.bool_))
    blocks_of_pixels(px, 8.0, 1, 1, np.empty(1, dtype=np.bool_), np.empty(1, dtype=np.intp))
    for dtype in (np.uint8, np.uint16, np.float64):
        gather_blocks(np.zeros((2, 2), dtype=dtype), np.zeros(1, dtype=np.intp), 2, 1,
                      np.empty((1, 4)))


@njit(**_JIT)  # type: ignore[call-overload]
def gather_blocks(grey, blocks, bs, cols, out):  # pragma: no cover - compiled
    """``out[k]`` (bs * bs,) float64: the pixels of block ``blocks[k]`` (``row * cols +
    col``) of the frame ``grey`` (H, W, any real dtype), row-major (a copy: exact)."""
    for k in range(blocks.shape[0]):
        r0 = (blocks[k] // cols) * bs
        c0 = (blocks[k] % cols) * bs
        for i in range(bs):
            for j in range(bs):
                out[k, i * bs + j] = grey[r0 + i, c0 + j]
