"""Compiled (numba) kernels for the particle-filter step at large particle counts.

At a million particles the numpy step is a dozen passes over memory plus the Gaussian noise,
and numpy's ``standard_normal`` loses much of its time to a branch that mispredicts half the
time (the sign of each ziggurat draw; the same ziggurat with a multiply by +-1.0 runs twice as
fast). The kernels here do the same arithmetic in one pass each and return the same numbers
bit for bit:

* :func:`constant_acceleration_predict`: noise draw and transition of
  :class:`pftrack_basic.motion.ConstantAccelerationMotion` in one pass. The normals are drawn
  by numpy's own algorithm (the ziggurat of ``random_standard_normal``, with its tables) from
  the Generator's PCG64 state, which is read before and written back after, so the Generator
  ends where ``standard_normal((N, 6))`` leaves it. Only an exact ``PCG64`` bit generator takes
  this path (``np.random.default_rng``'s); any other takes the numpy path;
* :func:`constant_velocity_update`: the deterministic part of
  :class:`pftrack_basic.motion.ConstantVelocity3DMotion`'s (and 2-D's) step, all targets' rows
  in one pass (``predict_rows``);
* :func:`centre_boxes`: the (N, 4) boxes of :class:`pftrack.builtin.image_box.ImageBoxObservation`
  (centre minus half the size, then the size), one row at a time;
* :func:`gaussian_centre_log_likelihood`: the box-centre Gaussian of
  :class:`pftrack_basic.gaussian.GaussianLikelihood` for one observed point;
* :func:`shifted_exp`: the shift and mask of :func:`pftrack.filter.normalize_log_weights`
  in one pass; the exponential stays numpy's;
* :func:`weighted_sum`: :func:`pftrack.filter.weighted_mean`'s einsum, whose sums over a
  C-contiguous (N, D) array run over the particles in order (numpy's einsum keeps the D axis
  innermost there), without einsum's iterator;
* :func:`weight_total` and :func:`systematic_indices`: :func:`pftrack.filter.systematic_resample`
  without its temporaries: the running sum (sequential in numpy too) is computed twice, once
  for the total and the checks, once while counting, instead of being stored.

No kernel uses fast-math, so no multiply-add is fused and every operation rounds as numpy's
does; the tests check the equality against the numpy path. Callers use a kernel only for
``n >= MIN_PARTICLES``, so small filters (the tracker's usual hundreds of particles) never load
numba. The kernels are compiled on first use and cached on disk (``cache=True``); set
``PFTRACK_NO_JIT=1`` to use the numpy path everywhere. numba is imported on first use: the
first large call in a process pays about a second (numba's import and the cache load; several
seconds when the cache is cold).
"""

from __future__ import annotations

import os
import sys

import numpy as np

__all__ = [
    "ENABLED",
    "estimate_resample_rows",
    "shift_rows_for_exp",
    "MIN_PARTICLES",
    "centre_boxes",
    "centre_boxes_rows",
    "constant_acceleration_predict",
    "constant_velocity_update",
    "gaussian_centre_log_likelihood",
    "pcg64_standard_normal",
    "prepare_generator",
    "random_walk_predict",
    "shifted_exp",
    "small_ready",
    "systematic_indices",
    "systematic_indices_rows",
    "use",
    "warm_up_small",
    "weight_total",
    "weighted_sum",
]

#: False when ``PFTRACK_NO_JIT`` is set: every function then takes its numpy path.
ENABLED = os.environ.get("PFTRACK_NO_JIT", "").strip().lower() not in ("1", "true", "yes")

#: Particle count from which the filter functions and the basic plugin use the kernels.
MIN_PARTICLES = 4097

_M64 = (1 << 64) - 1


def use(n: int) -> bool:
    """Whether a call on ``n`` particles takes the compiled path."""
    return ENABLED and n >= MIN_PARTICLES


_small_warm = False


def small_ready() -> bool:
    """Whether the kernels may also serve small particle counts (below
    :data:`MIN_PARTICLES`): only after :func:`warm_up_small` found numba already imported
    and loaded them, so a small filter never pays numba's import or a kernel's first load
    inside its timed loop. Used by the engine's per-frame calls on all targets at once
    (:meth:`RandomWalkMotion.predict_rows`, :func:`pftrack.filter.systematic_resample_rows`),
    whose numpy paths are a dozen calls of a few microseconds each."""
    return ENABLED and _small_warm


def warm_up_small() -> bool:
    """Load the kernels :func:`small_ready` gates, when numba is already imported (a plugin's
    own kernels, e.g. the colour likelihoods', imported it); else do nothing. Returns
    :func:`small_ready`. The engine calls it once, when it is built."""
    global _small_warm
    if _small_warm or not ENABLED or "numba" not in sys.modules:
        return _small_warm
    k = _k()
    k.pcg64_standard_normal(np.zeros(1), np.zeros(4, dtype=np.uint64))
    w = np.full((1, 2), 0.5)
    totals = np.empty(1)
    k.weight_totals_rows(w, totals)
    k.systematic_indices_rows(w, 1.0 / totals, np.zeros(1), np.empty((1, 3), dtype=np.intp))
    lw = np.zeros((1, 2))
    pos = np.zeros(2, dtype=np.intp)
    k.shift_rows_for_exp(lw, np.zeros((1, 2)), -746.0, np.empty(2), pos, np.empty(1))
    p = np.zeros((1, 2, 2))
    k.random_walk_predict(p.reshape(-1), np.ones(2), np.empty(4), np.zeros(4, dtype=np.uint64))
    k.centre_boxes_rows(p, np.ones((1, 2)), np.ones((1, 2)), np.empty((1, 2, 4)))
    k.estimate_resample_rows(np.ones(2)[:1], pos[:1], np.empty((1, 2)), p, np.zeros(1),
                             np.empty((1, 2)), np.empty((1, 2)), np.empty((1, 3), dtype=np.intp),
                             np.empty_like(p))
    _small_warm = True
    return True


_kernel_module = None


def _k():
    global _kernel_module
    if _kernel_module is None:
        from pftrack.filter import _kernels  # numba: imported on first use

        _kernel_module = _kernels
    return _kernel_module


# bit generator -> (it, its state words in place or None, their order): a few kept (PCG64 takes
# no weak reference; holding the last few generators alive costs nothing worth counting)
_pcg64_words_cache: dict[int, tuple[np.random.PCG64, np.ndarray | None, np.ndarray | None]] = {}


def _pcg64_words(bg: np.random.PCG64) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The generator's 128-bit state and increment as a (4,) uint64 array over its own memory
    (numpy's ``pcg64_random_t``, found through ``bg.ctypes.state_address``) and the order
    ``perm`` such that ``words[perm]`` is ``(hi, lo, inc_hi, inc_lo)``; ``(None, None)`` when
    the memory does not hold exactly the state ``bg.state`` reports (another layout: the
    caller goes through ``bg.state``). Reading and writing the words in place replaces the
    ``bg.state`` dictionary round trip (a few microseconds a call)."""
    hit = _pcg64_words_cache.get(id(bg))
    if hit is not None and hit[0] is bg:
        return hit[1], hit[2]
    words = perm = None
    try:
        import ctypes

        addr = ctypes.c_void_p.from_address(bg.ctypes.state_address).value  # pcg64_state.pcg_state
        if addr:
            mem = np.ctypeslib.as_array((ctypes.c_uint64 * 4).from_address(addr))
            st = bg.state["state"]
            want = [st["state"] >> 64, st["state"] & _M64, st["inc"] >> 64, st["inc"] & _M64]
            got = [int(v) for v in mem]
            # __uint128_t halves little-endian (low first), or numpy's {high, low} struct
            fits = [order for order in ((1, 0, 3, 2), (0, 1, 2, 3))
                    if [got[i] for i in order] == want]
            if len(fits) == 1:
                words, perm = mem, np.array(fits[0], dtype=np.intp)
    except (AttributeError, TypeError, ValueError, OSError):  # no ctypes view: the dict path
        words = perm = None
    if len(_pcg64_words_cache) >= 4:
        _pcg64_words_cache.clear()
    _pcg64_words_cache[id(bg)] = (bg, words, perm)
    return words, perm


def prepare_generator(rng: np.random.Generator) -> None:
    """Find ``rng``'s state words now (:func:`_pcg64_words`: a ctypes look-up, the first in a
    process costs milliseconds) so that its first compiled draw, inside a timed loop, does not
    pay for it. The engine calls it when it is built; a no-op for other bit generators."""
    bg = rng.bit_generator
    if ENABLED and type(bg) is np.random.PCG64:
        _pcg64_words(bg)


def _with_pcg64(rng: np.random.Generator, kernel, *args) -> bool:
    """Run ``kernel(*args, state)`` with ``state`` the (4,) uint64 PCG64 state of ``rng``,
    written back afterwards; False (nothing run) when ``rng`` does not draw from an exact
    ``PCG64``."""
    bg = rng.bit_generator
    if type(bg) is not np.random.PCG64:
        return False
    words, perm = _pcg64_words(bg)
    with bg.lock:
        if words is not None and perm is not None:  # the state words in place
            state = words[perm]  # (hi, lo, inc_hi, inc_lo), a copy
            kernel(*args, state)
            words[perm[0]] = state[0]
            words[perm[1]] = state[1]
            return True
        _with_state_dict(bg, kernel, args)
    return True


def _with_state_dict(bg: np.random.PCG64, kernel, args: tuple) -> None:
    """:func:`_with_pcg64` through ``bg.state`` (read, run, write back); the caller holds the
    lock."""
    st = bg.state
    s, inc = st["state"]["state"], st["state"]["inc"]
    state = np.array([s >> 64, s & _M64, inc >> 64, inc & _M64], dtype=np.uint64)
    kernel(*args, state)
    st["state"]["state"] = (int(state[0]) << 64) | int(state[1])
    bg.state = st  # has_uint32 / uinteger as they were: next64 leaves them alone


def pcg64_standard_normal(rng: np.random.Generator, out: np.ndarray) -> bool:
    """``rng.standard_normal(out=out)`` (same numbers, same Generator state after) for a
    C-contiguous float64 ``out``; False (nothing drawn) when ``rng`` is not PCG64-based."""
    flat = out.reshape(-1)  # a view: out is contiguous
    return _with_pcg64(rng, _k().pcg64_standard_normal, flat)


def constant_acceleration_predict(states: np.ndarray, std: np.ndarray, dt: float,
                                  rng: np.random.Generator) -> np.ndarray | None:
    """New (N, 6) states, equal bit for bit to the numpy path of
    ``ConstantAccelerationMotion.predict`` for N > 4096 (blocks of ``standard_normal``, then
    ``o *= std`` and the column updates); None when ``rng`` is not PCG64-based."""
    s = np.ascontiguousarray(states, dtype=np.float64)
    sd = np.ascontiguousarray(std, dtype=np.float64)
    dt = float(dt)
    out = np.empty(s.shape)
    if _with_pcg64(rng, _k().constant_acceleration_predict, s, sd, dt, 0.5 * dt * dt, out):
        return out
    return None


def random_walk_predict(states: np.ndarray, std: np.ndarray,
                        rng: np.random.Generator) -> np.ndarray | None:
    """``states + std * rng.standard_normal(states.shape)`` (``std`` per last axis) in one
    pass, the numbers and the Generator state of the numpy path; None (nothing drawn) when
    ``rng`` is not PCG64-based."""
    s = np.ascontiguousarray(states, dtype=np.float64)
    sd = np.array(std, dtype=np.float64)  # a writable copy: one compiled signature
    out = np.empty(s.shape)
    if _with_pcg64(rng, _k().random_walk_predict, s.reshape(-1), sd, out.reshape(-1)):
        return out
    return None


def constant_velocity_update(out: np.ndarray, states: np.ndarray, std: np.ndarray, k: int,
                             dt: float, from_displacement: bool) -> None:
    """The deterministic part of ``_ConstantVelocityMotion``'s step on its drawn noise ``out``
    (M, 2k, C-contiguous), in place: the numbers of its numpy path (``out *= std`` and the
    column updates) in one pass."""
    _k().constant_velocity_update(out, np.ascontiguousarray(states, dtype=np.float64),
                                  np.ascontiguousarray(std, dtype=np.float64), int(k),
                                  float(dt), bool(from_displacement))


def gaussian_centre_log_likelihood(boxes: np.ndarray, ox: float, oy: float,
                                   scale: float) -> np.ndarray:
    """(N,) ``((cx - ox)^2 + (cy - oy)^2) * scale`` of the box centres, as
    :meth:`GaussianLikelihood.log_likelihood` computes them with numpy."""
    b = np.ascontiguousarray(boxes, dtype=np.float64)
    out = np.empty(len(b))
    _k().gaussian_centre_log_likelihood(b, float(ox), float(oy), float(scale), out)
    return out


def centre_boxes(states: np.ndarray, w: float, h: float) -> np.ndarray:
    """(N, 4) boxes ``(x - 0.5 w, y - 0.5 h, w, h)`` of the states' first two columns (the box
    centres), as :meth:`pftrack.builtin.image_box.ImageBoxObservation.to_boxes` computes them with
    numpy, in one pass instead of four strided ones."""
    s = np.asarray(states, dtype=np.float64)
    out = np.empty((len(s), 4))
    w, h = float(w), float(h)
    _k().centre_boxes(s, 0.5 * w, 0.5 * h, w, h, out)
    return out


def weight_total(w: np.ndarray) -> tuple[float, bool]:
    """``(np.add.accumulate(w)[-1], all(w >= 0))`` of a contiguous 1-D float64 array."""
    total, ok = _k().weight_total(w)
    return float(total), bool(ok)


def systematic_indices(w: np.ndarray, inv_total: float, n: int, u: float) -> np.ndarray:
    """Systematic resampling indices (n,) of the weights ``w`` (see the kernel)."""
    n = int(n)
    idx = np.empty(n + 1, dtype=np.intp)
    _k().systematic_indices(w, float(inv_total), n, float(u), idx)
    return idx[:n]


def systematic_indices_rows(w: np.ndarray, rng: np.random.Generator) -> np.ndarray | None:
    """Systematic resampling indices (T, N) of every row of the weights (T, N), row ``r`` what
    the ``r``-th of T successive 1-D calls returns (the offsets from one ``rng.random(T)``,
    drawn after the check as the numpy path draws them); None (nothing drawn) when a row's
    weights are negative, NaN or sum to zero or infinity (the numpy path then raises)."""
    w = np.ascontiguousarray(w, dtype=np.float64)
    t, n = w.shape
    totals = np.empty(t)
    k = _k()
    if not k.weight_totals_rows(w, totals):
        return None
    if not all(0.0 < v < np.inf for v in totals.tolist()):
        return None
    u = rng.random(t)
    idx = np.empty((t, n + 1), dtype=np.intp)
    k.systematic_indices_rows(w, 1.0 / totals, u, idx)
    return idx[:, :n]


def shifted_exp(lw: np.ndarray, m: float, zero_below: float) -> np.ndarray:
    """``exp(lw - m)`` of a 1-D float64 array, 0.0 where ``lw - m <= zero_below`` (not
    evaluated): the subtraction and the mask in one compiled pass, then numpy's own ``exp``
    (whose last-bit rounding is numpy's: SIMD or libm by CPU), writing in place."""
    lw = np.ascontiguousarray(lw, dtype=np.float64)
    out = np.empty(len(lw))
    mask = np.empty(len(lw), dtype=bool)
    _k().shift_for_exp(lw, float(m), float(zero_below), out, mask)
    np.exp(out, out=out, where=mask)
    return out


def weighted_sum(w: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(D,) ``np.einsum("n,nd->d", w, s)`` for float64 ``w`` (N,) and C-contiguous ``s``
    (N, D)."""
    out = np.empty(s.shape[1])
    _k().weighted_sum(np.ascontiguousarray(w), s, out)
    return out


def shift_rows_for_exp(lw: np.ndarray, logw: np.ndarray, zero_below: float,
                       ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """The engine's log-weights of every target up to the exponential (see the kernel
    :func:`pftrack.filter._kernels.shift_rows_for_exp`): ``(status, shifted, positions,
    best (T,))`` with ``shifted`` (K,) the shifted log-weights whose exponential is not 0 and
    ``positions`` (K,) their flat indices; ``status`` 0: done, 1: ``lw`` holds NaN or +inf,
    2: a row has no finite maximum. ``lw`` (T, N) and ``logw`` (R, N), R = 1 or T,
    C-contiguous float64."""
    vals = np.empty(lw.size)
    pos = np.empty(lw.size, dtype=np.intp)
    best = np.empty(lw.shape[0])
    status, count = _k().shift_rows_for_exp(lw, logw, float(zero_below), vals, pos, best)
    return int(status), vals[:count], pos[:count], best


def estimate_resample_rows(vals: np.ndarray, pos: np.ndarray, p: np.ndarray, u: np.ndarray,
                           ) -> tuple[np.ndarray, ...]:
    """From the exponentials ``vals`` at flat positions ``pos`` (zeros elsewhere): every
    target's normalised weights (T, N), estimate, extent, systematic resampling indices
    (offsets ``u`` (T,)) and resampled particles from ``p`` (T, N, D), D >= 2 (see the kernel
    :func:`pftrack.filter._kernels.estimate_resample_rows`): ``(weights, states (T, D),
    extents (T, D), indices (T, N), resampled (T, N, D))``."""
    t, n, d = p.shape
    w = np.empty((t, n))
    states = np.empty((t, d))
    extents = np.empty((t, d))
    idx = np.empty((t, n + 1), dtype=np.intp)
    resampled = np.empty(p.shape)
    _k().estimate_resample_rows(vals, pos, w, p, u, states, extents, idx, resampled)
    return w, states, extents, idx[:, :n].copy(), resampled


def centre_boxes_rows(states: np.ndarray, half: np.ndarray, wh: np.ndarray) -> np.ndarray:
    """(T, N, 4) boxes ``(x - half_w, y - half_h, w, h)`` of C-contiguous float64 ``states``
    (T, N, D), row ``t`` with ``half[t]`` and ``wh[t]`` ((T, 2) float64): the numbers of
    :meth:`pftrack.builtin.image_box.ImageBoxObservation.to_boxes_rows`'s numpy path in one pass."""
    out = np.empty(states.shape[:2] + (4,))
    _k().centre_boxes_rows(states, half, wh, out)
    return out
