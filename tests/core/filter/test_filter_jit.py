"""The compiled (numba) path of the filter step (:mod:`pftrack.filter._jit`) returns the numpy
path's numbers bit for bit and leaves the Generator where the numpy path leaves it; under
``PFTRACK_NO_JIT=1`` the numpy path runs."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from pftrack.contracts.components import Target
from pftrack.filter import (
    _jit,
    normalize_log_weights,
    systematic_resample,
    weighted_extent,
    weighted_mean,
)
from pftrack_basic.gaussian import GaussianLikelihood
from pftrack_basic.motion import ConstantAccelerationMotion

pytestmark = pytest.mark.skipif(not _jit.ENABLED, reason="PFTRACK_NO_JIT is set")

BIG = _jit.MIN_PARTICLES + 3


@pytest.fixture
def numpy_path(monkeypatch):
    """Call ``numpy_path(fn, *args)`` to run ``fn`` with the kernels switched off."""

    def run(fn, *args, **kw):
        with monkeypatch.context() as m:
            m.setattr(_jit, "ENABLED", False)
            return fn(*args, **kw)

    return run


def _same_generator_state(a: np.random.Generator, b: np.random.Generator) -> bool:
    """Whether ``a`` and ``b`` are in the same state (compared by value: Philox's state holds
    arrays); advances neither."""
    sa, sb = a.bit_generator.state, b.bit_generator.state
    return repr(sa) == repr(sb)


@pytest.mark.parametrize("seed", [0, 1, 12345])
@pytest.mark.parametrize("n", [1, 7, 1000, 200_001])
def test_pcg64_normals_are_numpys(seed, n):
    a, b = np.random.default_rng(seed), np.random.default_rng(seed)
    a.integers(0, 10, dtype=np.uint32)  # a buffered 32-bit half: has_uint32 must survive
    b.integers(0, 10, dtype=np.uint32)
    out = np.empty(n)
    assert _jit.pcg64_standard_normal(a, out)
    assert np.array_equal(out, b.standard_normal(n))
    assert _same_generator_state(a, b)
    assert a.integers(0, 2**32, dtype=np.uint32) == b.integers(0, 2**32, dtype=np.uint32)


def test_pcg64_normals_cover_the_ziggurat_tail_and_rejections():
    a, b = np.random.default_rng(7), np.random.default_rng(7)
    out = np.empty(2_000_000)
    _jit.pcg64_standard_normal(a, out)
    ref = b.standard_normal(len(out))
    assert np.abs(ref).max() > 3.6  # the tail (|x| > r = 3.654...) is reached
    assert np.array_equal(out, ref) and _same_generator_state(a, b)


def test_pcg64_state_is_read_and_written_in_place(monkeypatch):
    """The kernels read the generator's state words in place (no ``bg.state`` round trip) on
    this platform, and that path and the dictionary path give numpy's numbers and state, also
    across a ``bg.state`` assignment and other draws in between."""
    a = np.random.default_rng(11)
    words, perm = _jit._pcg64_words(a.bit_generator)
    assert words is not None and sorted(perm.tolist()) == [0, 1, 2, 3]
    real_dict_path = _jit._with_state_dict

    def no_dict(*args):
        raise AssertionError("the bg.state dictionary path was taken")

    monkeypatch.setattr(_jit, "_with_state_dict", no_dict)
    b = np.random.default_rng(11)
    for _ in range(3):
        out = np.empty(1001)
        assert _jit.pcg64_standard_normal(a, out)
        assert np.array_equal(out, b.standard_normal(1001))
        assert a.random() == b.random()  # numpy draws in between see the written state
    monkeypatch.setattr(_jit, "_with_state_dict", real_dict_path)
    st = np.random.default_rng(99).bit_generator.state
    a.bit_generator.state = st  # an assignment lands in the same memory
    b.bit_generator.state = st
    out = np.empty(5)
    _jit.pcg64_standard_normal(a, out)
    assert np.array_equal(out, b.standard_normal(5)) and _same_generator_state(a, b)
    # the dictionary path (another memory layout) gives the same
    monkeypatch.setattr(_jit, "_pcg64_words", lambda bg: (None, None))
    _jit.pcg64_standard_normal(a, out)
    assert np.array_equal(out, b.standard_normal(5)) and _same_generator_state(a, b)


def test_other_bit_generators_are_not_handled():
    rng = np.random.Generator(np.random.Philox(3))
    before = repr(rng.bit_generator.state)
    assert not _jit.pcg64_standard_normal(rng, np.empty(10))
    assert repr(rng.bit_generator.state) == before


def _target(frames=3, size=1.0):
    t = Target(id=1, state=np.zeros(6), box_xywh_px=np.zeros(4), frames_tracked=frames,
               size_m=size)
    t.observation_px = np.array([203.0, 148.0])
    return t


@pytest.mark.parametrize("n", [BIG, 100_001])
@pytest.mark.parametrize("dt", [1.0, 0.37, 0.0])
@pytest.mark.parametrize("bitgen", [np.random.PCG64, np.random.Philox])
def test_constant_acceleration_predict_equals_the_numpy_path(numpy_path, n, dt, bitgen):
    states = np.random.default_rng(1).normal(0.0, 50.0, (n, 6))
    model = ConstantAccelerationMotion(position_noise=(2.0, 0.5), velocity_noise=1.0,
                                       acceleration_noise=0.3)
    target = _target(frames=4, size=1.7)
    a, b = np.random.Generator(bitgen(5)), np.random.Generator(bitgen(5))
    got = model.predict(states, dt, a, target)
    ref = numpy_path(model.predict, states, dt, b, target)
    assert got.shape == (n, 6) and got.dtype == np.float64
    assert np.array_equal(got, ref)
    assert _same_generator_state(a, b)
    # a non-contiguous input gives the same numbers
    wide = np.zeros((n, 8))
    wide[:, 1:7] = states
    a2 = np.random.Generator(bitgen(5))
    assert np.array_equal(model.predict(wide[:, 1:7], dt, a2, target), ref)


@pytest.mark.parametrize("n", [BIG, 100_001])
def test_gaussian_likelihood_equals_the_numpy_path(numpy_path, n):
    rng = np.random.default_rng(2)
    boxes = np.empty((n, 4))
    boxes[:, :2] = rng.normal(180.0, 20.0, (n, 2))
    boxes[:, 2:] = rng.uniform(10.0, 40.0, (n, 2))
    lik = GaussianLikelihood(sigma_px=3.7)
    target = _target()
    got = lik.log_likelihood(boxes, target)
    assert np.array_equal(got, numpy_path(lik.log_likelihood, boxes, target))
    # Fortran-ordered boxes too
    assert np.array_equal(lik.log_likelihood(np.asfortranarray(boxes), target), got)


@pytest.mark.parametrize("n", [BIG, 100_001])
@pytest.mark.parametrize("layout", ["c", "fortran", "strided"])
@pytest.mark.parametrize("size_from_target", [False, True])
def test_image_boxes_equal_the_numpy_path(numpy_path, n, layout, size_from_target):
    from pftrack.builtin.image_box import ImageBoxObservation

    rng = np.random.default_rng(4)
    states = rng.normal(180.0, 60.0, (n, 6))
    if layout == "fortran":
        states = np.asfortranarray(states)
    elif layout == "strided":
        wide = np.zeros((n, 9))
        wide[:, 2:8] = states
        states = wide[:, 2:8]
    obs = ImageBoxObservation(29.3, 41.7)
    target = _target()
    if size_from_target:
        target.box_wh_px = (17.1, 33.3)
    got = obs.to_boxes(states, target)
    ref = numpy_path(obs.to_boxes, states, target)
    assert got.shape == (n, 4) and got.dtype == np.float64 and got.flags.c_contiguous
    assert np.array_equal(got, ref)
    w, h = (17.1, 33.3) if size_from_target else (29.3, 41.7)
    assert np.array_equal(got[:, 2:], np.broadcast_to([w, h], (n, 2)))
    # x - w/2 in float64: the centre comes back within an ulp of the box's scale
    assert np.allclose(got[:, 0] + 0.5 * w, states[:, 0], rtol=0, atol=1e-12)


@pytest.mark.parametrize("n_draws", [None, BIG + 1000, 3 * BIG, 5000])
@pytest.mark.parametrize("kind", ["peaked", "flat", "zeros"])
def test_systematic_resample_equals_the_numpy_path(numpy_path, n_draws, kind):
    rng = np.random.default_rng(3)
    if kind == "peaked":
        lw = -0.5 * rng.normal(0.0, 4.0, BIG) ** 2
        w = np.exp(lw - lw.max())
    elif kind == "flat":
        w = rng.uniform(0.5, 1.0, BIG)
    else:
        w = rng.uniform(0.0, 1.0, BIG)
        w[rng.random(BIG) < 0.8] = 0.0
        w[-50:] = 0.0  # trailing empty bins
    w /= w.sum()
    a, b = np.random.default_rng(9), np.random.default_rng(9)
    got = systematic_resample(w, a, n_draws)
    ref = numpy_path(systematic_resample, w, b, n_draws)
    assert got.dtype == ref.dtype == np.intp
    assert np.array_equal(got, ref) and _same_generator_state(a, b)


@pytest.mark.parametrize("shape", [(1, 7), (3, 500), (4, BIG)])
@pytest.mark.parametrize("kind", ["peaked", "flat", "zeros"])
def test_systematic_resample_rows_equals_the_numpy_path(numpy_path, monkeypatch, shape, kind):
    """The compiled rows (small counts once warmed up, large counts always) give the numpy
    rows path's indices, which are T successive 1-D calls' indices, and leave the Generator
    where it leaves it."""
    from pftrack.filter import systematic_resample_rows

    monkeypatch.setattr(_jit, "_small_warm", True)
    rng = np.random.default_rng(3)
    t, n = shape
    if kind == "peaked":
        lw = -0.5 * rng.normal(0.0, 4.0, shape) ** 2
        w = np.exp(lw - lw.max(axis=1, keepdims=True))
    elif kind == "flat":
        w = rng.uniform(0.5, 1.0, shape)
    else:
        w = rng.uniform(0.0, 1.0, shape)
        w[rng.random(shape) < 0.8] = 0.0
        w[:, 0] = 1.0  # every row keeps some weight
        w[:, -min(n - 1, 50):] = 0.0  # trailing empty bins
    w /= w.sum(axis=1, keepdims=True)
    a, b, c = (np.random.default_rng(9) for _ in range(3))
    got = systematic_resample_rows(w, a)
    ref = numpy_path(systematic_resample_rows, w, b)
    one_by_one = numpy_path(lambda: np.array([systematic_resample(r, c) for r in w]))
    assert got.shape == shape and got.dtype == np.intp
    assert np.array_equal(got, ref) and np.array_equal(ref, one_by_one)
    assert _same_generator_state(a, b) and _same_generator_state(b, c)


def test_systematic_resample_rows_rejects_bad_weights_like_the_numpy_path(numpy_path,
                                                                          monkeypatch):
    from pftrack.filter import systematic_resample_rows

    monkeypatch.setattr(_jit, "_small_warm", True)
    good = np.full(5, 0.2)
    for bad in (np.array([0.5, -0.1, 0.6, 0.0, 0.0]), np.array([np.nan, 0.5, 0.5, 0.0, 0.0]),
                np.zeros(5), np.array([np.inf, 0.0, 0.0, 0.0, 0.0])):
        w = np.array([good, bad])
        msgs = []
        for fn in (systematic_resample_rows, lambda *a: numpy_path(systematic_resample_rows, *a)):
            rng = np.random.default_rng(0)
            with pytest.raises(ValueError, match="resampling weights") as e:
                fn(w, rng)
            msgs.append(str(e.value))
            assert _same_generator_state(rng, np.random.default_rng(0))  # nothing drawn
        assert msgs[0] == msgs[1]


@pytest.mark.parametrize("shape", [(3, 500, 2), (1, 1), (2, 7, 2)])
def test_small_normal_draws_equal_numpys(monkeypatch, shape):
    from pftrack_basic.motion import _standard_normal

    _jit.warm_up_small()
    monkeypatch.setattr(_jit, "_small_warm", True)
    a, b = np.random.default_rng(21), np.random.default_rng(21)
    got = _standard_normal(a, shape)
    assert got.shape == shape and np.array_equal(got, b.standard_normal(shape))
    assert _same_generator_state(a, b)
    philox = np.random.Generator(np.random.Philox(2))  # not PCG64: numpy draws
    assert np.array_equal(_standard_normal(philox, shape),
                          np.random.Generator(np.random.Philox(2)).standard_normal(shape))


def test_systematic_resample_rejects_bad_weights_like_the_numpy_path(numpy_path):
    rng = np.random.default_rng(0)
    for bad in (np.zeros(BIG), np.full(BIG, np.nan), np.r_[np.ones(BIG - 1), np.inf],
                np.r_[np.ones(BIG - 1), -1.0]):
        with pytest.raises(ValueError, match="non-negative") as e1:
            systematic_resample(bad, rng)
        with pytest.raises(ValueError, match="non-negative") as e2:
            numpy_path(systematic_resample, bad, rng)
        assert str(e1.value) == str(e2.value)
    with pytest.raises(ValueError, match="at least one weight"):
        systematic_resample(np.zeros(0), rng, BIG)


@pytest.mark.parametrize("kind", ["gaussian", "underflow", "with-inf", "nan", "all-inf"])
def test_normalize_log_weights_equals_the_numpy_path(numpy_path, kind):
    rng = np.random.default_rng(4)
    lw = -0.5 * rng.normal(0.0, 3.0, BIG) ** 2 - 7.0
    if kind == "underflow":  # most arguments below log(2**-1075): exactly 0, not evaluated
        lw *= 300.0
    elif kind == "with-inf":
        lw[::7] = -np.inf
    elif kind == "nan":
        lw[5] = np.nan
    elif kind == "all-inf":
        lw[:] = -np.inf
    w, ok = normalize_log_weights(lw)
    w_ref, ok_ref = numpy_path(normalize_log_weights, lw)
    assert ok == ok_ref and np.array_equal(w, w_ref)
    if kind == "underflow":
        assert 0 < np.count_nonzero(w) < BIG


@pytest.mark.parametrize("n", [BIG, 8193, 100_001, 1_000_000])
@pytest.mark.parametrize("d", [2, 6])
def test_weighted_mean_equals_einsum(numpy_path, n, d):
    rng = np.random.default_rng(n + d)
    states = rng.normal(150.0, 40.0, (n, d))
    states[::3, 0] *= -1.0
    w = rng.random(n)
    w[::11] = 0.0
    w /= w.sum()
    got = weighted_mean(states, w)
    assert np.array_equal(got, numpy_path(weighted_mean, states, w))
    assert np.array_equal(got, np.einsum("n,nd->d", w, states))
    # a strided view takes einsum itself; the extent (einsum of a fresh array) agrees too
    wide = np.zeros((n, d + 1))
    wide[:, :d] = states
    assert np.allclose(weighted_mean(wide[:, :d], w), got, rtol=1e-14)
    assert np.array_equal(weighted_extent(states, w), numpy_path(weighted_extent, states, w))


def test_no_jit_environment_variable_selects_the_numpy_path():
    code = ("from pftrack.filter import _jit; "
            "print(_jit.ENABLED, _jit.use(10**6))")
    env = dict(os.environ, PFTRACK_NO_JIT="1")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["False", "False"]
    assert _jit.use(_jit.MIN_PARTICLES) and not _jit.use(_jit.MIN_PARTICLES - 1)


@pytest.mark.parametrize("n", [1, 7, 8, 9, 127, 128, 129, 300, 1000, 4099])
def test_pairwise_sum_is_numpys(n):
    """The engine's kernels normalise weights with numpy's pairwise summation order."""
    k = _jit._k()
    rng = np.random.default_rng(n)
    for _ in range(20):
        a = rng.random(n) ** rng.integers(1, 60)
        a[rng.random(n) < 0.4] = 0.0
        assert k.pairwise_sum(a, 0, n) == a.sum()
        assert k.pairwise_sum(np.r_[1e300, a], 1, n) == a.sum()  # from an offset


def _step4_numpy(lw_raw, logw, p, rng):
    """The engine's step 4 through the numpy functions (the general path)."""
    from pftrack.filter import normalize_log_weight_rows, systematic_resample_rows

    best = lw_raw.max(axis=1)
    w, ok = normalize_log_weight_rows(lw_raw + logw)
    states = weighted_mean(p, w)
    extents = weighted_extent(p, w, states)
    idx = systematic_resample_rows(w, rng)
    resampled = np.array([p[r].take(idx[r], axis=0) for r in range(len(p))])
    return ok, best, w, states, extents, idx, resampled


@pytest.mark.parametrize("t, n, d", [(1, 1, 2), (3, 500, 2), (2, 9, 3), (4, 129, 6),
                                     (3, 4099, 2)])
@pytest.mark.parametrize("uniform", [True, False])
def test_the_fused_step_equals_the_numpy_functions(numpy_path, t, n, d, uniform):
    """shift_rows_for_exp, numpy's exp and estimate_resample_rows give the weights,
    estimates, extents, resampling indices, resampled particles and the Generator state of
    normalize_log_weight_rows, weighted_mean, weighted_extent and systematic_resample_rows,
    bit for bit: sharply peaked log-likelihoods (most weights exactly zero, some subnormal),
    -inf particles, a zero-weight particle that is not finite."""
    rng = np.random.default_rng(t * n * d)
    for trial in range(8):
        lw = -np.abs(rng.normal(0.0, 10.0 ** rng.uniform(0, 3.5), (t, n)))
        lw[rng.random((t, n)) < 0.1] = -np.inf
        lw[:, 0] = rng.normal(0, 5, t)  # every row has a finite maximum
        logw = (np.full((1, n), np.log(1.0 / n)) if uniform
                else np.log(rng.dirichlet(np.ones(n), size=t)))
        p = rng.normal(0.0, 50.0, (t, n, d))
        if trial == 1 and n > 3:
            lw[0, 2] = -np.inf  # weight exactly 0 ...
            p[0, 2, 0] = np.inf  # ... times inf: NaN in the numpy path too
        seed = int(rng.integers(1 << 30))
        want = numpy_path(_step4_numpy, lw, logw, p, np.random.default_rng(seed))
        assert want[0].all()
        status, vals, pos, best = _jit.shift_rows_for_exp(lw, logw, -746.0)
        assert status == 0
        np.exp(vals, out=vals)
        g = np.random.default_rng(seed)
        u = g.random(t)
        w, states, extents, idx, resampled = _jit.estimate_resample_rows(vals, pos, p, u)
        assert best.tobytes() == want[1].tobytes()
        for got, ref in zip((w, states, extents, idx, resampled), want[2:]):
            assert got.shape == ref.shape and got.dtype == ref.dtype
            assert got.tobytes() == ref.tobytes()
        if trial == 1 and n > 3:
            assert np.isnan(states[0, 0])
        ref_rng = np.random.default_rng(seed)
        numpy_path(_step4_numpy, lw, logw, p, ref_rng)
        assert g.random() == ref_rng.random()  # the same draws


def test_the_fused_step_reports_nan_and_rows_without_a_finite_weight():
    lw = np.zeros((2, 5))
    logw = np.zeros((1, 5))
    lw[1, 2] = np.nan
    assert _jit.shift_rows_for_exp(lw, logw, -746.0)[0] == 1
    lw[1, 2] = np.inf
    assert _jit.shift_rows_for_exp(lw, logw, -746.0)[0] == 1
    lw[1] = -np.inf
    assert _jit.shift_rows_for_exp(lw, logw, -746.0)[0] == 2


@pytest.mark.parametrize("n", [1, 300])
def test_image_boxes_of_rows_equal_the_numpy_path(numpy_path, monkeypatch, n):
    from pftrack.builtin.image_box import ImageBoxObservation

    monkeypatch.setattr(_jit, "_small_warm", True)  # as once a likelihood imported numba
    obs = ImageBoxObservation(12.0, 20.0)
    targets = [Target(id=i, state=np.zeros(2), box_xywh_px=np.zeros(4)) for i in range(3)]
    targets[1].box_wh_px = (7.25, 31.5)
    s = np.random.default_rng(n).normal(100.0, 30.0, (3, n, 4))
    got = obs.to_boxes_rows(s, targets)
    want = numpy_path(obs.to_boxes_rows, s, targets)
    assert got.tobytes() == want.tobytes()
    assert got[1, 0].tolist() == [s[1, 0, 0] - 3.625, s[1, 0, 1] - 15.75, 7.25, 31.5]
