"""numba kernels of :mod:`pftrack.filter._jit` (this module imports numba; ``_jit`` imports it
on first use). See ``_jit`` for what each kernel computes and why it equals the numpy path."""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit
from numba.core import types
from numba.extending import intrinsic

# numpy's ziggurat tables (numpy/random/src/distributions/ziggurat_constants.h), as numba ships
# them for its own port of Generator.standard_normal
from numba.np.random._constants import (
    fi_double,
    ki_double,
    wi_double,
    ziggurat_nor_inv_r,
    ziggurat_nor_r,
)

_JIT = {"cache": True, "nogil": True}

# Every output array comes from the caller, allocated by numpy: numpy asks the kernel for huge
# pages on large arrays (madvise), numba's allocator does not, and first-touch page faults of a
# 48 MB array then cost more than the kernel itself.

# PCG64's 128-bit LCG multiplier (numpy/random/src/pcg64/pcg64.h), high and low 64 bits
_MUL_HI = np.uint64(2549297995355413924)
_MUL_LO = np.uint64(4865540595714422341)
_U0 = np.uint64(0)
_U1 = np.uint64(1)
_U8 = np.uint64(8)
_U11 = np.uint64(11)
_U58 = np.uint64(58)
_U63 = np.uint64(63)
_UFF = np.uint64(0xFF)
_M52 = np.uint64(0x000FFFFFFFFFFFFF)
_TO_DOUBLE = 1.0 / 9007199254740992.0  # next_double: (next_uint64 >> 11) * 2**-53
_SIGN = np.array([1.0, -1.0])  # x * +-1.0 is exact: the same value as numpy's "if sign: x = -x"


@intrinsic
def _umulh(typingctx, a, b):  # pragma: no cover - compiled
    """High 64 bits of the 128-bit product of two uint64."""
    sig = types.uint64(types.uint64, types.uint64)

    def codegen(context, builder, signature, args):
        i128 = ir.IntType(128)
        p = builder.mul(builder.zext(args[0], i128), builder.zext(args[1], i128))
        return builder.trunc(builder.lshr(p, ir.Constant(i128, 64)), ir.IntType(64))

    return sig, codegen


@njit(inline="always", **_JIT)  # type: ignore[call-overload]
def _step(hi, lo, inc_hi, inc_lo):  # pragma: no cover - compiled
    """PCG64's state update ``state = state * MUL + inc`` (mod 2**128) on (hi, lo) halves."""
    p_lo = lo * _MUL_LO
    p_hi = _umulh(lo, _MUL_LO) + lo * _MUL_HI + hi * _MUL_LO
    n_lo = p_lo + inc_lo
    carry = _U1 if n_lo < p_lo else _U0
    return p_hi + inc_hi + carry, n_lo


@njit(inline="always", **_JIT)  # type: ignore[call-overload]
def _output(hi, lo):  # pragma: no cover - compiled
    """PCG64's XSL-RR output of a state: ``rotr64(hi ^ lo, hi >> 58)``."""
    x = hi ^ lo
    r = hi >> _U58
    return (x >> r) | (x << ((-r) & _U63))


@njit(inline="always", **_JIT)  # type: ignore[call-overload]
def _normal(hi, lo, inc_hi, inc_lo):  # pragma: no cover - compiled
    """One ``random_standard_normal`` (numpy/random/src/distributions/distributions.c): the
    ziggurat, drawing from PCG64 as numpy's ``next_uint64``/``next_double`` do. Returns
    ``(x, hi, lo)``, the new state after the draws it consumed."""
    while True:  # numpy's loop: a candidate, accepted at once 99.3 % of the time
        hi, lo = _step(hi, lo, inc_hi, inc_lo)
        r = _output(hi, lo)
        idx = r & _UFF
        r >>= _U8
        rabs = (r >> _U1) & _M52
        x = (rabs * wi_double[idx]) * _SIGN[r & _U1]
        if rabs < ki_double[idx]:
            return x, hi, lo
        if idx == 0:  # the tail
            while True:
                hi, lo = _step(hi, lo, inc_hi, inc_lo)
                u1 = (_output(hi, lo) >> _U11) * _TO_DOUBLE
                hi, lo = _step(hi, lo, inc_hi, inc_lo)
                u2 = (_output(hi, lo) >> _U11) * _TO_DOUBLE
                xx = -ziggurat_nor_inv_r * np.log1p(-u1)
                yy = -np.log1p(-u2)
                if yy + yy > xx * xx:
                    break
            if (rabs >> _U8) & _U1:
                return -(ziggurat_nor_r + xx), hi, lo
            return ziggurat_nor_r + xx, hi, lo
        hi, lo = _step(hi, lo, inc_hi, inc_lo)
        u = (_output(hi, lo) >> _U11) * _TO_DOUBLE
        if (fi_double[idx - 1] - fi_double[idx]) * u + fi_double[idx] < np.exp(-0.5 * x * x):
            return x, hi, lo
        # rejected: a new candidate


@njit(**_JIT)  # type: ignore[call-overload]
def pcg64_standard_normal(out, state):  # pragma: no cover - compiled
    """Fill ``out`` (1-D, contiguous) with ``Generator(PCG64).standard_normal``'s numbers;
    ``state`` (4,) uint64 ``(hi, lo, inc_hi, inc_lo)`` is advanced in place."""
    hi, lo, inc_hi, inc_lo = state[0], state[1], state[2], state[3]
    for i in range(out.shape[0]):
        out[i], hi, lo = _normal(hi, lo, inc_hi, inc_lo)
    state[0] = hi
    state[1] = lo


@njit(**_JIT)  # type: ignore[call-overload]
def random_walk_predict(states, std, out, state):  # pragma: no cover - compiled
    """``out = states + std * standard_normal`` over flat contiguous ``states`` and ``out``
    whose last axis has ``len(std)`` values: the normals of :func:`pcg64_standard_normal` in
    order, each times its axis's deviation, then plus the state (the products and sums of
    ``out *= std; out += states``)."""
    hi, lo, inc_hi, inc_lo = state[0], state[1], state[2], state[3]
    d = std.shape[0]
    for i in range(out.shape[0]):
        x, hi, lo = _normal(hi, lo, inc_hi, inc_lo)
        x = x * std[i % d]
        out[i] = x + states[i]
    state[0] = hi
    state[1] = lo


_BLOCK = 2048  # rows per block of constant_acceleration_predict: 96 kB, in cache


@njit(**_JIT)  # type: ignore[call-overload]
def constant_acceleration_predict(states, std, dt, half, out, state):  # pragma: no cover
    """The (N, 6) constant-acceleration step with the noise drawn in row order, as
    ``standard_normal((N, 6))`` draws it, and each output computed as the numpy path does::

        p = ((z_p std_p + p) + dt v) + half a
        v = (z_v std_v + v) + dt a
        a = z_a std_a + a

    Block by block: the normals of a block first (a tight loop), then its transition. ``out``
    (N, 6) C-contiguous is written.
    """
    n = states.shape[0]
    flat = out.reshape(6 * n)
    hi, lo, inc_hi, inc_lo = state[0], state[1], state[2], state[3]
    for b0 in range(0, n, _BLOCK):
        b1 = min(b0 + _BLOCK, n)
        for j in range(6 * b0, 6 * b1):
            flat[j], hi, lo = _normal(hi, lo, inc_hi, inc_lo)
        for i in range(b0, b1):
            for a in range(2):
                p = states[i, a]
                v = states[i, 2 + a]
                c = states[i, 4 + a]
                out[i, a] = ((out[i, a] * std[a] + p) + dt * v) + half * c
                out[i, 2 + a] = (out[i, 2 + a] * std[2 + a] + v) + dt * c
                out[i, 4 + a] = out[i, 4 + a] * std[4 + a] + c
    state[0] = hi
    state[1] = lo


@njit(**_JIT)  # type: ignore[call-overload]
def gaussian_centre_log_likelihood(boxes, ox, oy, scale, out):  # pragma: no cover - compiled
    """``out = ((b0 + 0.5 b2 - ox)^2 + (b1 + 0.5 b3 - oy)^2) * scale`` per box row, in the numpy
    path's order of operations."""
    n = boxes.shape[0]
    for i in range(n):
        dx = (boxes[i, 0] + 0.5 * boxes[i, 2]) - ox
        dy = (boxes[i, 1] + 0.5 * boxes[i, 3]) - oy
        out[i] = (dx * dx + dy * dy) * scale


@njit(**_JIT)  # type: ignore[call-overload]
def centre_boxes(states, hw, hh, w, h, out):  # pragma: no cover - compiled
    """``out[i] = (s0 - hw, s1 - hh, w, h)`` per state row: the boxes of
    :meth:`pftrack.builtin.image_box.ImageBoxObservation.to_boxes` (``hw = 0.5 w``, ``hh = 0.5 h``),
    written row by row in one pass."""
    n = states.shape[0]
    for i in range(n):
        out[i, 0] = states[i, 0] - hw
        out[i, 1] = states[i, 1] - hh
        out[i, 2] = w
        out[i, 3] = h


@njit(**_JIT)  # type: ignore[call-overload]
def centre_boxes_rows(states, half, wh, out):  # pragma: no cover - compiled
    """:func:`centre_boxes` of every target (row) of ``states`` (T, N, D), each with its own
    half size ``half`` (T, 2) and size ``wh`` (T, 2); ``out`` (T, N, 4)."""
    for t in range(states.shape[0]):
        hw = half[t, 0]
        hh = half[t, 1]
        w = wh[t, 0]
        h = wh[t, 1]
        for i in range(states.shape[1]):
            out[t, i, 0] = states[t, i, 0] - hw
            out[t, i, 1] = states[t, i, 1] - hh
            out[t, i, 2] = w
            out[t, i, 3] = h


@njit(**_JIT)  # type: ignore[call-overload]
def weight_total(w):  # pragma: no cover - compiled
    """The last running sum of ``w`` (``np.add.accumulate(w)[-1]``: summed in order, the same
    number) and whether every weight is >= 0 (False for NaN too)."""
    s = 0.0
    ok = True
    for i in range(w.shape[0]):
        x = w[i]
        if not x >= 0.0:
            ok = False
        s = x if i == 0 else s + x
    return s, ok


@njit(**_JIT)  # type: ignore[call-overload]
def systematic_indices(w, inv_total, n, u, idx):  # pragma: no cover - compiled
    """Indices of systematic resampling of the weights ``w``: with ``c_i`` the running sum
    (recomputed here in :func:`weight_total`'s order, so without an (N,) array), particle
    i's cumulative count is ``min(ceil((c_i inv_total) n - u), n)`` (``c`` of the last particle
    taken as exactly 1), and index j is ``#{i : count_i <= j}``, as
    :func:`pftrack.filter.core.systematic_resample` computes them: a count per bin (scattered,
    no branch), then their running sum. ``idx`` (n + 1,) intp is the work space; the indices
    are ``idx[:n]``."""
    m = w.shape[0]
    for j in range(n + 1):
        idx[j] = 0
    s = 0.0
    for i in range(m - 1):
        s = w[i] if i == 0 else s + w[i]
        v = s * inv_total
        v = v * n
        v = v - u
        idx[min(np.intp(np.ceil(v)), n)] += 1
    v = 1.0 * n
    idx[min(np.intp(np.ceil(v - u)), n)] += 1
    run = 0
    for j in range(n):
        run += idx[j]
        idx[j] = run


@njit(**_JIT)  # type: ignore[call-overload]
def weight_totals_rows(w, totals):  # pragma: no cover - compiled
    """:func:`weight_total` of every row of a C-contiguous (T, N) ``w`` into ``totals`` (T,);
    returns whether every weight is >= 0 (False for NaN too)."""
    ok = True
    for r in range(w.shape[0]):
        total, nonneg = weight_total(w[r])
        totals[r] = total
        ok = ok and nonneg
    return ok


@njit(**_JIT)  # type: ignore[call-overload]
def systematic_indices_rows(w, inv_totals, u, idx):  # pragma: no cover - compiled
    """:func:`systematic_indices` of every row of a C-contiguous (T, N) ``w`` with its own
    ``inv_totals[r]`` and offset ``u[r]``; ``idx`` (T, N + 1) intp, the indices in
    ``idx[:, :N]``."""
    n = w.shape[1]
    for r in range(w.shape[0]):
        systematic_indices(w[r], inv_totals[r], n, u[r], idx[r])


@njit(**_JIT)  # type: ignore[call-overload]
def shift_for_exp(lw, m, zero_below, out, mask):  # pragma: no cover - compiled
    """``d = lw - m``; where ``d > zero_below``: ``out = d``, ``mask = True``; elsewhere
    ``out = 0.0``, ``mask = False``. ``np.exp(out, out=out, where=mask)`` then gives
    :func:`pftrack.filter.core._exp_normalised`'s unnormalised weights."""
    for i in range(lw.shape[0]):
        d = lw[i] - m
        keep = d > zero_below
        mask[i] = keep
        out[i] = d if keep else 0.0


@njit(**_JIT)  # type: ignore[call-overload]
def weighted_sum(w, s, out):  # pragma: no cover - compiled
    """``out[k] = sum_i w[i] s[i, k]``, each sum running over i in order from 0.0, as
    ``np.einsum("n,nd->d", w, s)`` sums a C-contiguous ``s`` (the tests check it)."""
    d = s.shape[1]
    for k in range(d):
        out[k] = 0.0
    for i in range(s.shape[0]):
        wi = w[i]
        for k in range(d):
            out[k] += wi * s[i, k]


@njit(**_JIT)  # type: ignore[call-overload]
def shift_rows_for_exp(lw, logw, zero_below, vals, pos, best):  # pragma: no cover - compiled
    """The engine's step 4 up to the exponential, every target (row) at once.

    ``lw`` (T, N) are the likelihood's log-likelihoods, ``logw`` (R, N) the log-weights
    (R = 1: one row for every target). ``best[r]`` = ``lw[r].max()``; ``x = lw + logw``;
    ``d = x - x.max()`` per row; the ``d > zero_below`` (those whose exponential is not
    exactly 0) go to ``vals`` in row-major order with their flat index in ``pos``, so that
    ``np.exp`` of them, scattered into zeros, gives
    :func:`pftrack.filter.core._exp_normalised`'s unnormalised weights (the same numbers as
    its masked ``np.exp``, which costs more: one inner loop per run of kept values).

    Returns ``(status, count)``: status 0 when done (``count`` values kept); 1 (nothing else
    meaningful) when ``lw`` holds NaN or +inf; 2 when a row of ``x`` has no finite maximum
    (the caller's general path re-spreads that target).
    """
    t, n = lw.shape
    last = logw.shape[0] - 1
    for r in range(t):
        b = -np.inf
        for i in range(n):
            v = lw[r, i]
            if not v < np.inf:
                return 1, 0
            if v > b:
                b = v
        best[r] = b
    count = 0
    x = np.empty(n)
    for r in range(t):
        lr = logw[min(r, last)]
        m = -np.inf
        for i in range(n):
            xi = lw[r, i] + lr[i]
            x[i] = xi
            if xi > m:
                m = xi
        if not (-np.inf < m < np.inf):  # NaN can only come from logw: the general path
            return 2, 0
        for i in range(n):
            d = x[i] - m
            if d > zero_below:
                vals[count] = d
                pos[count] = r * n + i
                count += 1
    return 0, count


@njit(**_JIT)  # type: ignore[call-overload]
def _pairwise_block(a, lo, n):  # pragma: no cover - compiled
    """numpy's pairwise sum of ``a[lo:lo + n]`` for ``n <= 128``: in order below 8, else eight
    running sums combined as ``((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))``, then the
    remainder in order."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    r0 = a[lo]
    r1 = a[lo + 1]
    r2 = a[lo + 2]
    r3 = a[lo + 3]
    r4 = a[lo + 4]
    r5 = a[lo + 5]
    r6 = a[lo + 6]
    r7 = a[lo + 7]
    i = 8
    top = n - n % 8
    while i < top:
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit(**_JIT)  # type: ignore[call-overload]
def pairwise_sum(a, lo, n):  # pragma: no cover - compiled
    """``a[lo:lo + n].sum()`` in numpy's pairwise order (``pairwise_sum`` of
    numpy/_core/src/umath/loops_utils.h.src: above 128 numbers, the halves split at a multiple
    of 8 and summed left + right; :func:`_pairwise_block` below). The recursion is unrolled on
    an explicit stack: numba's disk cache does not load recursive functions safely."""
    if n <= 128:
        return _pairwise_block(a, lo, n)
    los = np.empty(64, np.int64)
    ns = np.empty(64, np.int64)
    stage = np.zeros(64, np.int64)
    left = np.empty(64, np.float64)
    sp = 0
    los[0] = lo
    ns[0] = n
    while True:
        m = ns[sp]
        if m > 128:  # descend into the left half
            n2 = m // 2
            n2 -= n2 % 8
            sp += 1
            los[sp] = los[sp - 1]
            ns[sp] = n2
            stage[sp] = 0
            continue
        ret = _pairwise_block(a, los[sp], m)
        while True:  # hand the sum up until a parent still needs its right half
            if sp == 0:
                return ret
            sp -= 1
            if stage[sp] == 0:
                left[sp] = ret
                stage[sp] = 1
                n2 = ns[sp] // 2
                n2 -= n2 % 8
                sp += 1
                los[sp] = los[sp - 1] + n2
                ns[sp] = ns[sp - 1] - n2
                stage[sp] = 0
                break
            ret = left[sp] + ret


@njit(**_JIT)  # type: ignore[call-overload]
def estimate_resample_rows(vals, pos, w, p, u, states, extents, idx, resampled
                           ):  # pragma: no cover - compiled
    """The engine's step 4 after the exponential, every target (row) at once, with the numbers
    of the numpy path:

    * ``w`` (T, N): the exponentials ``vals`` at the flat indices ``pos`` (what
      :func:`shift_rows_for_exp` kept), zeros elsewhere, normalised in place by their sum in
      numpy's pairwise order (``w /= w.sum(axis=-1, keepdims=True)``);
    * ``states`` (T, D): ``np.einsum("tn,tnd->td", w, p)``, each sum running over the
      particles in order from 0.0 (einsum's order for D >= 2; the caller checks D);
    * ``extents`` (T, D): :func:`pftrack.filter.core.weighted_extent`, ``2 sqrt(sum w (p -
      state)^2)`` summed the same way;
    * ``idx`` (T, N + 1) intp: :func:`systematic_indices` of each row with offset ``u[r]``
      and its total from :func:`weight_total` (``idx[:, :N]`` are the indices);
    * ``resampled`` (T, N, D): ``p[r, idx[r, j]]``.
    """
    t, n, d = p.shape
    flat = w.reshape(t * n)
    for j in range(flat.shape[0]):
        flat[j] = 0.0
    for j in range(pos.shape[0]):
        flat[pos[j]] = vals[j]
    for r in range(t):
        row = w[r]
        s = pairwise_sum(row, 0, n)
        for i in range(n):
            row[i] = row[i] / s
        for k in range(d):
            states[r, k] = 0.0
            extents[r, k] = 0.0
        # a zero weight adds +-0.0 to a running sum that is never -0.0: nothing, unless the
        # particle is not finite (0 * inf is NaN); sharply peaked weights are mostly zeros
        finite = True
        for i in range(n):
            for k in range(d):
                if not abs(p[r, i, k]) < np.inf:
                    finite = False
        if d == 2:  # the image plane: the two running sums in registers
            s0 = 0.0
            s1 = 0.0
            for i in range(n):
                wi = row[i]
                if wi == 0.0 and finite:
                    continue
                s0 += wi * p[r, i, 0]
                s1 += wi * p[r, i, 1]
            v0 = 0.0
            v1 = 0.0
            for i in range(n):
                wi = row[i]
                if wi == 0.0 and finite:
                    continue
                dv = p[r, i, 0] - s0
                dv = dv * dv
                v0 += wi * dv
                dv = p[r, i, 1] - s1
                dv = dv * dv
                v1 += wi * dv
            states[r, 0] = s0
            states[r, 1] = s1
            extents[r, 0] = v0
            extents[r, 1] = v1
        else:
            for i in range(n):
                wi = row[i]
                if wi == 0.0 and finite:
                    continue
                for k in range(d):
                    states[r, k] += wi * p[r, i, k]
            for i in range(n):
                wi = row[i]
                if wi == 0.0 and finite:
                    continue
                for k in range(d):
                    dv = p[r, i, k] - states[r, k]
                    dv = dv * dv
                    extents[r, k] += wi * dv
        for k in range(d):
            e = np.sqrt(extents[r, k])
            extents[r, k] = e * 2.0
        total, _ = weight_total(row)
        systematic_indices(row, 1.0 / total, n, u[r], idx[r])
        for j in range(n):
            src = idx[r, j]
            for k in range(d):
                resampled[r, j, k] = p[r, src, k]


@njit(**_JIT)  # type: ignore[call-overload]
def constant_velocity_update(out, states, std, k, dt, from_displacement):  # pragma: no cover
    """``_ConstantVelocityMotion``'s step on drawn noise ``out`` (M, 2k), in place: ``out *=
    std``, then per axis i the column updates of its numpy path, in their order (velocity
    from the displacement, plus the old velocity; position plus the old position and the
    old velocity times dt), one row at a time."""
    d = out.shape[1]
    for r in range(out.shape[0]):
        for j in range(d):
            out[r, j] *= std[j]
        for i in range(k):
            if from_displacement:
                out[r, k + i] += out[r, i] / dt
            out[r, k + i] += states[r, k + i]
            out[r, i] += states[r, i]
            out[r, i] += dt * states[r, k + i]
