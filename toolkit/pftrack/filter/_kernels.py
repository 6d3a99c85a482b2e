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
    :meth:`pftrack.tracker.ImageBoxObservation.to_boxes` (``hw = 0.5 w``, ``hh = 0.5 h``),
    written row by row in one pass."""
    n = states.shape[0]
    for i in range(n):
        out[i, 0] = states[i, 0] - hw
        out[i, 1] = states[i, 1] - hh
        out[i, 2] = w
        out[i, 3] = h


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
