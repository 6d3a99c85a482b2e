"""Log-weight normalisation, effective sample size, four resampling schemes and weighted estimates.

All functions are vectorised over particles; none touches global random state.

Resampling returns *indices* (shape (N,), intp) into the particle array, so one call serves any
state layout: ``particles = particles[idx]``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from pftrack.filter import _jit

__all__ = [
    "RESAMPLERS",
    "effective_sample_size",
    "multinomial_resample",
    "normalize_log_weight_rows",
    "normalize_log_weights",
    "resample",
    "residual_resample",
    "stratified_resample",
    "systematic_resample",
    "systematic_resample_rows",
    "weighted_extent",
    "weighted_mean",
    "weighted_variance",
]


#: exp(x) is exactly 0.0 below log(2**-1075) = -745.13...; numpy's vectorised exp takes a slow
#: path for such arguments, and sharply peaked likelihoods (the colour paper's cross entropy with
#: lambda = n) put most particles there
_EXP_ZERO_BELOW = -746.0


def _exp_normalised(shifted: np.ndarray) -> np.ndarray:
    """``exp(shifted)`` normalised along the last axis; ``shifted`` <= 0 with a 0 in each row.
    Arguments whose exponential is exactly zero are not evaluated (same numbers)."""
    w = np.zeros(shifted.shape)
    np.exp(shifted, out=w, where=shifted > _EXP_ZERO_BELOW)
    if w.ndim == 1:
        w /= w.sum()
    else:
        w /= w.sum(axis=-1, keepdims=True)
    return w


def normalize_log_weights(log_weights: np.ndarray) -> tuple[np.ndarray, bool]:
    """Normalised weights from log-weights, safely.

    Parameters
    ----------
    log_weights : ndarray, shape (N,) or (T, N)
        Unnormalised log-weights; ``-inf`` allowed, NaN treated as ``-inf``.

    Returns
    -------
    weights : ndarray, same shape, float64
        Non-negative, summing to 1 along the last axis. Where every weight of a row is zero or
        non-finite the row is uniform.
    ok : bool
        False when at least one row had no finite weight (the caller should recover: re-spread
        the particles) — the returned uniform row keeps NaN from propagating meanwhile.
    """
    lw = np.asarray(log_weights, dtype=np.float64)
    if lw.ndim == 1 and lw.size:
        # fast path (every frame, every target): a finite maximum means no NaN (max would be
        # NaN) and no +inf; the operations are those of the general path, so are the results
        m = float(lw.max())
        if -math.inf < m < math.inf:
            if _jit.use(lw.size):
                # the shift and the mask in one compiled pass, one array: the same numbers
                w = _jit.shifted_exp(lw, m, _EXP_ZERO_BELOW)
                w /= w.sum()
                return w, True
            return _exp_normalised(np.subtract(lw, m)), True
    lw = np.where(np.isnan(lw), -np.inf, lw)
    m = np.max(lw, axis=-1, keepdims=True)
    finite = np.isfinite(m)
    if lw.shape[-1] == 0:
        return lw.copy(), True
    shifted = np.where(finite, lw - np.where(finite, m, 0.0), -np.inf)
    # +inf anywhere: those particles share all the weight
    posinf = np.isposinf(m)
    if np.any(posinf):
        shifted = np.where(posinf, np.where(np.isposinf(lw), 0.0, -np.inf), shifted)
        finite = finite | posinf
    w = np.exp(shifted)
    s = np.sum(w, axis=-1, keepdims=True)
    good = finite & (s > 0) & np.isfinite(s)
    n = lw.shape[-1]
    w = np.where(good, w / np.where(good, s, 1.0), 1.0 / n)
    return w, bool(np.all(good))


def normalize_log_weight_rows(log_weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`normalize_log_weights` of every row of a (T, N) array at once, with one flag per
    row: one filter per target, all targets in one call.

    Returns
    -------
    weights : ndarray, shape (T, N), float64
        Row ``i`` equals ``normalize_log_weights(log_weights[i])[0]`` bit for bit.
    ok : ndarray, shape (T,), bool
        Row ``i``'s flag from :func:`normalize_log_weights`.
    """
    lw = np.asarray(log_weights, dtype=np.float64)
    if lw.ndim != 2:
        raise ValueError(f"normalize_log_weight_rows expects a (T, N) array, got shape "
                         f"{lw.shape}")
    t, n = lw.shape
    if t and n:
        m = lw.max(axis=1)
        if all(-math.inf < v < math.inf for v in m.tolist()):  # fast path, row by row
            return _exp_normalised(np.subtract(lw, m[:, None])), np.ones(t, dtype=bool)
    w = np.empty(lw.shape)
    ok = np.ones(t, dtype=bool)
    for i in range(t):
        w[i], ok[i] = normalize_log_weights(lw[i])
    return w, ok


def effective_sample_size(weights: np.ndarray) -> np.ndarray | float:
    """ESS = 1 / sum(w^2) of normalised weights, along the last axis."""
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim == 1:
        return 1.0 / float(np.square(w).sum())  # the same pairwise sum as below, fewer calls
    ess = 1.0 / np.sum(w * w, axis=-1)
    return float(ess) if np.ndim(ess) == 0 else ess


def _cumsum_normalised(weights: np.ndarray) -> np.ndarray:
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 1:
        w = w.reshape(-1)
    if len(w) == 0:
        raise ValueError("resampling needs at least one weight, got an empty array")
    c = np.add.accumulate(w)  # np.cumsum's loop without its dispatch overhead
    total = float(c[-1])
    if not 0.0 < total < math.inf or w.min() < 0:  # NaN fails the first test
        raise ValueError(f"resampling weights must be non-negative with a positive finite sum "
                         f"(got sum {total}, min {w.min()}); normalise them with "
                         "normalize_log_weights first")
    c *= 1.0 / total
    c[-1] = 1.0  # guard the last bin against round-off
    return c


def _indices_from_cumulative(cum: np.ndarray, n: int) -> np.ndarray:
    """Sorted indices (n,) from cumulative copy counts ``cum`` (non-decreasing, last == n):
    particle i is copied ``cum[i] - cum[i-1]`` times. O(N): index j is ``#{i : cum[i] <= j}``."""
    return np.add.accumulate(np.bincount(cum, minlength=n + 1)[:n])


def multinomial_resample(weights: np.ndarray, rng: np.random.Generator,
                         n: int | None = None) -> np.ndarray:
    """Independent draws from the categorical distribution ``weights``.

    The ``n`` uniforms are drawn directly in sorted order (normalised cumulative sums of
    exponentials are uniform order statistics), so the look-up walks the CDF once; the indices
    come out sorted.
    """
    n = len(weights) if n is None else int(n)
    c = _cumsum_normalised(weights)
    s = np.cumsum(rng.standard_exponential(n + 1))
    u = s[:-1]
    u *= 1.0 / s[-1]
    return np.searchsorted(c, u, side="right").astype(np.intp, copy=False)


def systematic_resample(weights: np.ndarray, rng: np.random.Generator,
                        n: int | None = None) -> np.ndarray:
    """One uniform offset ``u``, ``n`` evenly spaced pointers ``(u + j) / n`` (lowest variance of
    the four, O(N)).

    Particle i (CDF bin ``[c_{i-1}, c_i)``) receives the pointers with ``j < n c_i - u``, so its
    cumulative count is ``ceil(n c_i - u)``: no search, one pass.
    """
    n = len(weights) if n is None else int(n)
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim == 1 and _jit.use(max(len(w), n)):
        # compiled: the total, then every count and index in one pass, without the
        # temporaries; the same operations on the same numbers as below
        w = np.ascontiguousarray(w)
        total, nonneg = _jit.weight_total(w) if len(w) else (0.0, True)
        if not 0.0 < total < math.inf or not nonneg:
            _cumsum_normalised(w)  # raises, with the message
        return _jit.systematic_indices(w, 1.0 / total, n, rng.random())
    c = _cumsum_normalised(w)
    u = rng.random()
    c *= n
    c -= u
    np.ceil(c, out=c)
    cum = c.astype(np.intp)
    # c >= 0 and u < 1 give cum >= 0; only round-off in c can push a count above n
    np.minimum(cum, n, out=cum)
    return _indices_from_cumulative(cum, n)


def systematic_resample_rows(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """:func:`systematic_resample` of every row of a (T, N) array: indices (T, N), row ``i``
    equal to what the ``i``-th of T successive ``systematic_resample(weights[i], rng)`` calls
    returns (the T offsets come from one ``rng.random(T)``, the same numbers)."""
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 2 or w.shape[1] == 0:
        raise ValueError(f"systematic_resample_rows expects a (T, N) array with N >= 1, got "
                         f"shape {w.shape}")
    t, n = w.shape
    if _jit.small_ready() or _jit.use(n):
        # compiled, row by row: the 1-D kernel's numbers, which are the numpy path's
        idx = _jit.systematic_indices_rows(w, rng)
        if idx is not None:
            return idx
    c = np.add.accumulate(w, axis=1)
    total = c[:, -1].tolist()
    if not all(0.0 < v < math.inf for v in total) or (t and w.min() < 0):  # NaN fails too
        raise ValueError(f"resampling weights must be non-negative with a positive finite sum "
                         f"in every row (got sums {total}, min {w.min()}); normalise them with "
                         "normalize_log_weight_rows first")
    c *= (1.0 / c[:, -1])[:, None]  # the right side is evaluated before c changes
    c[:, -1] = 1.0  # guard the last bin against round-off
    u = rng.random(t)
    c *= n
    c -= u[:, None]  # type: ignore[index]
    np.ceil(c, out=c)
    cum = c.astype(np.intp)
    np.minimum(cum, n, out=cum)
    # one bincount for every row: row i's counts live in bins i (n + 1) .. i (n + 1) + n
    cum += (np.arange(t, dtype=np.intp) * (n + 1))[:, None]
    counts = np.bincount(cum.ravel(), minlength=t * (n + 1)).reshape(t, n + 1)[:, :n]
    return np.add.accumulate(counts, axis=1)


def stratified_resample(weights: np.ndarray, rng: np.random.Generator,
                        n: int | None = None) -> np.ndarray:
    """One uniform draw in each of ``n`` equal strata: pointers ``(j + u_j) / n``.

    O(N): below ``c_i`` lie every pointer of the ``m = floor(n c_i)`` strata wholly below it,
    plus pointer m when ``u_m < n c_i - m``.
    """
    n = len(weights) if n is None else int(n)
    c = _cumsum_normalised(weights)
    u = np.empty(n + 1)
    rng.random(out=u[:n])
    u[n] = np.inf  # sentinel: no pointer beyond the last stratum
    c *= n
    cum = c.astype(np.intp)  # floor: c >= 0
    np.clip(cum, 0, n, out=cum)
    c -= cum
    cum += u[cum] < c
    return _indices_from_cumulative(cum, n)


def residual_resample(weights: np.ndarray, rng: np.random.Generator,
                      n: int | None = None) -> np.ndarray:
    """Deterministic copies ``floor(n w_i)``, the remainder drawn multinomially from the
    residual weights. Indices come out sorted."""
    w = np.asarray(weights, dtype=np.float64)
    n = len(w) if n is None else int(n)
    c = _cumsum_normalised(w)  # validates
    nw = np.diff(c, prepend=0.0) * n
    counts = np.floor(nw).astype(np.intp)
    rest = n - int(counts.sum())
    if rest > 0:
        resid = nw - counts
        if not resid.sum() > 0:
            resid = np.full(len(w), 1.0 / len(w))
        counts += np.bincount(multinomial_resample(resid, rng, rest), minlength=len(w))
    return _indices_from_cumulative(np.cumsum(counts), n)


RESAMPLERS: dict[str, Callable[..., np.ndarray]] = {
    "multinomial": multinomial_resample,
    "systematic": systematic_resample,
    "stratified": stratified_resample,
    "residual": residual_resample,
}


def resample(weights: np.ndarray, rng: np.random.Generator, scheme: str = "systematic",
             n: int | None = None) -> np.ndarray:
    """Resampling indices by ``scheme`` (one of :data:`RESAMPLERS`)."""
    try:
        fn = RESAMPLERS[scheme]
    except KeyError:
        raise ValueError(f"resampling scheme {scheme!r} unknown; choose one of "
                         f"{sorted(RESAMPLERS)}") from None
    return fn(np.asarray(weights, dtype=np.float64), rng, n)


def weighted_mean(states: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Estimate as the weighted mean of the particles (the colour paper's eq. 12, the coastal
    paper's eq. 8-9).

    ``states`` (N, D), ``weights`` (N,) normalised -> (D,); or one filter per row:
    ``states`` (T, N, D), ``weights`` (T, N) -> (T, D), row ``i`` equal to the (N, D) result
    for ``states[i]`` bit for bit.
    """
    # einsum, not BLAS gemv: OpenBLAS threads stall on a loaded machine (16 ms instead of 0.3 ms
    # at 100k particles) and a (D,) reduction gains nothing from them
    w = np.asarray(weights, dtype=np.float64)
    s = np.asarray(states, dtype=np.float64)
    if (w.ndim == 1 and s.ndim == 2 and s.flags.c_contiguous and len(s) == len(w)
            and _jit.use(len(w))):
        return _jit.weighted_sum(w, s)  # einsum's order of summation, compiled
    return np.einsum(_EINSUM[w.ndim], w, s)


_EINSUM = {1: "n,nd->d", 2: "tn,tnd->td"}


def weighted_variance(states: np.ndarray, weights: np.ndarray,
                      mean: np.ndarray | None = None) -> np.ndarray:
    """Weighted variance per state axis, (N, D) and (N,) -> (D,); or (T, N, D) and (T, N)
    -> (T, D), one filter per row."""
    w = np.asarray(weights, dtype=np.float64)
    mean = weighted_mean(states, w) if mean is None else np.asarray(mean, dtype=np.float64)
    d = np.subtract(states, mean if w.ndim == 1 else mean[:, None, :])
    d *= d
    return np.einsum(_EINSUM[w.ndim], w, d)


def weighted_extent(states: np.ndarray, weights: np.ndarray,
                    mean: np.ndarray | None = None) -> np.ndarray:
    """Size estimate ``l = 2 sqrt(sum_i g_i (x_i - x_0)^2)`` per axis (the coastal paper's eq. 10);
    shapes as :func:`weighted_variance`."""
    e = np.sqrt(weighted_variance(states, weights, mean))
    e *= 2.0
    return e
