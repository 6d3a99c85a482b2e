"""Log-weight normalisation, effective sample size, four resampling schemes and weighted estimates.

All functions are vectorised over particles; none touches global random state.

Resampling returns *indices* (shape (N,), intp) into the particle array, so one call serves any
state layout: ``particles = particles[idx]``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = [
    "RESAMPLERS",
    "effective_sample_size",
    "multinomial_resample",
    "normalize_log_weights",
    "resample",
    "residual_resample",
    "stratified_resample",
    "systematic_resample",
    "weighted_extent",
    "weighted_mean",
    "weighted_variance",
]


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


def effective_sample_size(weights: np.ndarray) -> np.ndarray | float:
    """ESS = 1 / sum(w^2) of normalised weights, along the last axis."""
    w = np.asarray(weights, dtype=np.float64)
    ess = 1.0 / np.sum(w * w, axis=-1)
    return float(ess) if np.ndim(ess) == 0 else ess


def _cumsum_normalised(weights: np.ndarray) -> np.ndarray:
    c = np.cumsum(weights)
    c /= c[-1]
    c[-1] = 1.0  # guard the last bin against round-off
    return c


def multinomial_resample(weights: np.ndarray, rng: np.random.Generator,
                         n: int | None = None) -> np.ndarray:
    """Independent draws from the categorical distribution ``weights``."""
    n = len(weights) if n is None else n
    c = _cumsum_normalised(weights)
    return np.searchsorted(c, rng.random(n), side="right").astype(np.intp)


def systematic_resample(weights: np.ndarray, rng: np.random.Generator,
                        n: int | None = None) -> np.ndarray:
    """One uniform offset, ``n`` evenly spaced pointers (lowest variance of the four, O(N))."""
    n = len(weights) if n is None else n
    c = _cumsum_normalised(weights)
    u = (rng.random() + np.arange(n)) / n
    return np.searchsorted(c, u, side="right").astype(np.intp)


def stratified_resample(weights: np.ndarray, rng: np.random.Generator,
                        n: int | None = None) -> np.ndarray:
    """One uniform draw in each of ``n`` equal strata."""
    n = len(weights) if n is None else n
    c = _cumsum_normalised(weights)
    u = (rng.random(n) + np.arange(n)) / n
    return np.searchsorted(c, u, side="right").astype(np.intp)


def residual_resample(weights: np.ndarray, rng: np.random.Generator,
                      n: int | None = None) -> np.ndarray:
    """Deterministic copies ``floor(n w_i)``, the remainder drawn multinomially from the
    residual weights."""
    w = np.asarray(weights, dtype=np.float64)
    n = len(w) if n is None else n
    counts = np.floor(n * w).astype(np.intp)
    idx = np.repeat(np.arange(len(w), dtype=np.intp), counts)
    rest = n - len(idx)
    if rest > 0:
        resid = n * w - counts
        total = resid.sum()
        if total <= 0:
            resid = np.full(len(w), 1.0 / len(w))
        idx = np.concatenate([idx, multinomial_resample(resid, rng, rest)])
    return idx


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
    """Estimate as the weighted mean of the particles (seed 000 eq. 12, seed 003 eq. 8-9).

    ``states`` (N, D), ``weights`` (N,) normalised -> (D,).
    """
    return np.asarray(weights, dtype=np.float64) @ np.asarray(states, dtype=np.float64)


def weighted_variance(states: np.ndarray, weights: np.ndarray,
                      mean: np.ndarray | None = None) -> np.ndarray:
    """Weighted variance per state axis, (N, D) and (N,) -> (D,)."""
    mean = weighted_mean(states, weights) if mean is None else mean
    d = states - mean
    return np.asarray(weights) @ (d * d)


def weighted_extent(states: np.ndarray, weights: np.ndarray,
                    mean: np.ndarray | None = None) -> np.ndarray:
    """Size estimate ``l = 2 sqrt(sum_i g_i (x_i - x_0)^2)`` per axis (seed 003 eq. 10)."""
    return 2.0 * np.sqrt(weighted_variance(states, weights, mean))
