"""pftrack.filter: resampling is unbiased, the low-variance schemes beat multinomial, weights are
normalised safely, estimates have the right numbers, everything is seeded."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.filter import (
    RESAMPLERS,
    effective_sample_size,
    normalize_log_weights,
    resample,
    weighted_extent,
    weighted_mean,
    weighted_variance,
)
from scipy import stats

SCHEMES = ["multinomial", "systematic", "stratified", "residual"]
W = np.array([0.31, 0.02, 0.0, 0.17, 0.105, 0.045, 0.2, 0.15])  # one zero weight
RUNS = 4000


def _counts(scheme: str, w: np.ndarray, runs: int = RUNS, n: int | None = None,
            seed: int = 0) -> np.ndarray:
    """Copies of each particle, (runs, len(w)), over seeded runs."""
    rng = np.random.default_rng(seed)
    return np.stack([np.bincount(resample(w, rng, scheme, n), minlength=len(w))
                     for _ in range(runs)])


@pytest.mark.parametrize("scheme", SCHEMES)
def test_each_scheme_is_unbiased(scheme):
    n = 20
    w = W / W.sum()
    c = _counts(scheme, w, n=n)
    assert np.all(c.sum(axis=1) == n)
    expected = n * w
    mean = c.mean(axis=0)
    nz = w > 0
    # chi-square of the mean counts against n w with the multinomial variance n w (1 - w),
    # an upper bound for every scheme's variance; 7 degrees of freedom
    se2 = n * w[nz] * (1 - w[nz]) / RUNS
    chi2 = float(np.sum((mean[nz] - expected[nz]) ** 2 / se2))
    assert chi2 < stats.chi2.ppf(0.999, nz.sum()), (chi2, mean, expected)
    assert np.all(c[:, ~nz] == 0)  # a zero weight is never drawn


def test_low_variance_schemes_beat_multinomial():
    n = 20
    w = W / W.sum()
    var = {s: _counts(s, w, n=n, seed=1).var(axis=0).sum() for s in SCHEMES}
    # multinomial: sum_i n w_i (1 - w_i)
    assert var["multinomial"] == pytest.approx(n * np.sum(w * (1 - w)), rel=0.1)
    for s in ("systematic", "stratified", "residual"):
        assert var[s] < 0.6 * var["multinomial"], var
    assert var["systematic"] <= var["stratified"] + 0.05, var


def test_systematic_counts_are_floor_or_ceil_and_residual_keeps_the_floor():
    rng = np.random.default_rng(2)
    w = rng.random(500) ** 3
    w /= w.sum()
    n = 500
    for _ in range(50):
        c = np.bincount(resample(w, rng, "systematic"), minlength=len(w))
        assert np.all((c == np.floor(n * w)) | (c == np.ceil(n * w)))
        c = np.bincount(resample(w, rng, "residual"), minlength=len(w))
        assert np.all(c >= np.floor(n * w))
        c = np.bincount(resample(w, rng, "stratified"), minlength=len(w))
        assert np.all(np.abs(c - n * w) < 2.0)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_indices_shape_dtype_range_and_degenerate_weights(scheme):
    rng = np.random.default_rng(3)
    w = rng.random(1000)
    w /= w.sum()
    idx = resample(w, rng, scheme)
    assert idx.shape == (1000,) and idx.dtype == np.intp
    assert idx.min() >= 0 and idx.max() < 1000
    assert resample(w, rng, scheme, n=37).shape == (37,)
    assert resample(w, rng, scheme, n=0).shape == (0,)
    one = np.zeros(50)
    one[17] = 1.0
    assert np.all(resample(one, rng, scheme) == 17)
    assert np.all(resample(np.ones(1), rng, scheme, n=5) == 0)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_seeded_and_free_of_global_random_state(scheme):
    w = np.random.default_rng(4).random(1000)
    w /= w.sum()
    np.random.seed(0)
    before = np.random.get_state()[1].copy()
    a = resample(w, np.random.default_rng(11), scheme)
    b = resample(w, np.random.default_rng(11), scheme)
    c = resample(w, np.random.default_rng(12), scheme)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.array_equal(np.random.get_state()[1], before)


def test_bad_scheme_and_bad_weights_are_rejected():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="resampling scheme 'bogus' unknown.*systematic"):
        resample(np.ones(3) / 3, rng, "bogus")
    for bad in (np.zeros(4), np.array([0.5, np.nan]), np.array([1.0, -0.5]), np.zeros(0)):
        for s in SCHEMES:
            with pytest.raises(ValueError, match="weight"):
                resample(bad, rng, s)
    assert set(RESAMPLERS) == set(SCHEMES)


def test_normalize_log_weights_values():
    w, ok = normalize_log_weights(np.log([1.0, 3.0, 4.0]))
    assert ok and np.allclose(w, [0.125, 0.375, 0.5])
    # far from 0: shifted before exp, no overflow or underflow to all-zero
    w, ok = normalize_log_weights(np.array([1000.0, 1000.0 + np.log(3.0)]))
    assert ok and np.allclose(w, [0.25, 0.75])
    w, ok = normalize_log_weights(np.array([-2000.0, -2000.0]))
    assert ok and np.allclose(w, [0.5, 0.5])
    w, ok = normalize_log_weights(np.array([0.0, -np.inf, np.nan, 0.0]))
    assert ok and np.allclose(w, [0.5, 0.0, 0.0, 0.5])


def test_normalize_log_weights_degenerate_rows_become_uniform_and_flag():
    for lw in (np.full(4, -np.inf), np.full(4, np.nan),
               np.array([np.nan, -np.inf, np.nan, -np.inf])):
        w, ok = normalize_log_weights(lw)
        assert not ok
        assert np.allclose(w, 0.25) and not np.any(np.isnan(w))
    # (T, N): each row on its own; one bad row flags the whole call
    lw = np.array([[0.0, np.log(3.0)], [-np.inf, -np.inf]])
    w, ok = normalize_log_weights(lw)
    assert not ok and np.allclose(w, [[0.25, 0.75], [0.5, 0.5]])
    # +inf particles share all the weight
    w, ok = normalize_log_weights(np.array([np.inf, 0.0, np.inf]))
    assert ok and np.allclose(w, [0.5, 0.0, 0.5])


def test_effective_sample_size():
    assert effective_sample_size(np.full(100, 0.01)) == pytest.approx(100.0)
    assert effective_sample_size(np.eye(1, 10)[0]) == pytest.approx(1.0)
    assert effective_sample_size(np.array([0.5, 0.25, 0.25])) == pytest.approx(1 / 0.375)
    assert np.allclose(effective_sample_size(np.array([[0.5, 0.5], [1.0, 0.0]])), [2.0, 1.0])


def test_weighted_mean_variance_extent_numbers():
    states = np.array([[0.0, 0.0, 5.0], [2.0, 4.0, 5.0]])
    w = np.array([0.25, 0.75])
    assert np.allclose(weighted_mean(states, w), [1.5, 3.0, 5.0])
    assert np.allclose(weighted_variance(states, w), [0.75, 3.0, 0.0])
    # the coastal paper's eq. 10: l = 2 sqrt(sum g_i (x_i - x_0)^2)
    assert np.allclose(weighted_extent(states, w), [2 * np.sqrt(0.75), 2 * np.sqrt(3.0), 0.0])
    # uniform weights over a big Gaussian cloud: extent -> 2 sigma
    rng = np.random.default_rng(5)
    cloud = rng.normal([1.0, -2.0], [3.0, 0.5], (200_000, 2))
    u = np.full(len(cloud), 1.0 / len(cloud))
    assert np.allclose(weighted_mean(cloud, u), [1.0, -2.0], atol=0.02)
    assert np.allclose(weighted_extent(cloud, u), [6.0, 1.0], rtol=0.01)


def test_row_functions_equal_one_filter_at_a_time_bit_for_bit():
    """The (T, N) forms the tracker uses for T targets: every row is the single-filter result,
    and systematic_resample_rows draws the numbers T successive calls would."""
    from pftrack.filter import normalize_log_weight_rows, systematic_resample_rows

    rng = np.random.default_rng(3)
    for k in range(200):
        t, n, d = int(rng.integers(1, 5)), int(rng.integers(1, 700)), int(rng.integers(1, 4))
        lw = rng.normal(0.0, 10.0 ** rng.uniform(0, 4), (t, n))  # many exp() underflows
        if k % 4 == 0:
            lw[rng.integers(t)] = -np.inf  # a row with no finite weight
        if k % 6 == 0:
            lw[rng.integers(t), rng.integers(n)] = np.nan
        w, ok = normalize_log_weight_rows(lw)
        for i in range(t):
            wi, oki = normalize_log_weights(lw[i])
            assert np.array_equal(w[i], wi) and ok[i] == oki
        if not ok.all():
            continue
        seed = int(rng.integers(1 << 31))
        idx = systematic_resample_rows(w, np.random.default_rng(seed))
        one = np.random.default_rng(seed)
        for i in range(t):
            assert np.array_equal(idx[i], resample(w[i], one, "systematic"))
        p = rng.normal(50.0, 10.0, (t, n, d))
        mean = weighted_mean(p, w)
        ext = weighted_extent(p, w, mean)
        for i in range(t):
            assert np.array_equal(mean[i], weighted_mean(p[i], w[i]))
            assert np.array_equal(ext[i], weighted_extent(p[i], w[i]))


def test_row_functions_reject_bad_shapes_and_weights():
    from pftrack.filter import normalize_log_weight_rows, systematic_resample_rows

    with pytest.raises(ValueError, match=r"\(T, N\)"):
        normalize_log_weight_rows(np.zeros(5))
    with pytest.raises(ValueError, match=r"\(T, N\)"):
        systematic_resample_rows(np.zeros((2, 0)), np.random.default_rng(0))
    with pytest.raises(ValueError, match="non-negative"):
        systematic_resample_rows(np.array([[0.5, 0.5], [0.0, 0.0]]), np.random.default_rng(0))
    with pytest.raises(ValueError, match="non-negative"):
        systematic_resample_rows(np.array([[1.5, -0.5]]), np.random.default_rng(0))
