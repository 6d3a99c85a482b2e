"""Motion models of the ``basic`` plugin: exact transitions (the coastal paper's eq. 5-7, the soccer
paper's eq. 2), noise levels and the adaptive noise of the soccer paper, initial spreads,
validation."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Target
from pftrack_basic.motion import (
    ConstantAccelerationMotion,
    ConstantVelocity2DMotion,
    ConstantVelocity3DMotion,
    RandomWalkMotion,
)

N = 200_000  # particles for the noise statistics: relative std error of a std ~ 0.16 %


def _target(frames_tracked=1, size=1.0):
    return Target(id=1, state=np.zeros(6), box_xywh_px=np.zeros(4), frames_tracked=frames_tracked,
                  size_m=size)


def test_random_walk_noise_has_the_stated_std_and_no_drift():
    rng = np.random.default_rng(0)
    s = np.tile([100.0, 50.0], (N, 1))
    out = RandomWalkMotion(sigma_px=3.0).predict(s, 1.0, rng)
    d = out - s
    assert np.allclose(d.mean(axis=0), 0.0, atol=0.03)
    assert np.allclose(d.std(axis=0), 3.0, rtol=0.01)
    # per-axis sigma and sqrt(dt) scaling
    d = RandomWalkMotion(sigma_px=(1.0, 4.0)).predict(s, 0.25, rng) - s
    assert np.allclose(d.std(axis=0), [0.5, 2.0], rtol=0.01)
    assert RandomWalkMotion().state_dim == 2 and RandomWalkMotion().position_dims == (0, 1)


@pytest.mark.parametrize("cls, k", [(ConstantVelocity2DMotion, 2), (ConstantVelocity3DMotion, 3)])
def test_constant_velocity_without_noise_is_F_of_eq6(cls, k):
    rng = np.random.default_rng(1)
    s = rng.normal(0, 5, (50, 2 * k))
    out = cls(position_noise=0.0).predict(s, 1.0, rng)
    f = np.eye(2 * k)
    f[:k, k:] = np.eye(k)  # eq. 6: position += velocity
    assert np.allclose(out, s @ f.T, atol=1e-12)
    big = rng.normal(0, 5, (20_000, 2 * k))
    assert np.allclose(cls(position_noise=0.0).predict(big, 1.0, rng), big @ f.T, atol=1e-12)
    out = cls(position_noise=0.0).predict(s, 0.5, rng)
    assert np.allclose(out[:, :k], s[:, :k] + 0.5 * s[:, k:])
    assert np.allclose(out[:, k:], s[:, k:])
    assert cls().position_dims == tuple(range(k)) and cls().state_dim == 2 * k


def test_constant_velocity_velocity_is_the_displacement_eq7():
    rng = np.random.default_rng(2)
    s = rng.normal(0, 5, (N, 6))
    dt = 0.5
    out = ConstantVelocity3DMotion(position_noise=(1.0, 2.0, 0.5)).predict(s, dt, rng)
    assert np.allclose(out[:, 3:], (out[:, :3] - s[:, :3]) / dt)
    noise = out[:, :3] - s[:, :3] - s[:, 3:] * dt
    assert np.allclose(noise.std(axis=0), np.array([1.0, 2.0, 0.5]) * np.sqrt(dt), rtol=0.01)
    # the textbook variant keeps the velocity and adds its own noise
    out = ConstantVelocity2DMotion(position_noise=1.0, velocity_noise=0.3,
                                   velocity_from_displacement=False).predict(s[:, :4], 1.0, rng)
    assert np.allclose((out[:, 2:] - s[:, 2:4]).std(axis=0), 0.3, rtol=0.01)
    assert np.allclose((out[:, :2] - s[:, :2] - s[:, 2:4]).std(axis=0), 1.0, rtol=0.01)


def test_constant_acceleration_without_noise_is_C_of_eq2():
    rng = np.random.default_rng(3)
    s = rng.normal(0, 2, (40, 6))
    m = ConstantAccelerationMotion(position_noise=0.0, velocity_noise=0.0, acceleration_noise=0.0)
    big = rng.normal(0, 2, (20_000, 6))  # large N runs a blocked, column-wise path
    for dt in (1.0, 0.04, 2.5):
        assert np.allclose(m.predict(s, dt, rng), s @ m.transition_matrix(dt).T, atol=1e-12)
        assert np.allclose(m.predict(big, dt, rng), big @ m.transition_matrix(dt).T, atol=1e-12)
    c = m.transition_matrix(0.5)
    assert c[0, 2] == 0.5 and c[0, 4] == 0.125 and c[2, 4] == 0.5 and c[4, 4] == 1.0
    # ten steps of constant acceleration: p = p0 + v0 t + a t^2 / 2
    x = np.array([[1.0, 2.0, 3.0, -1.0, 0.5, 0.2]])
    for _ in range(10):
        x = m.predict(x, 0.1, rng)
    t = 1.0
    assert np.allclose(x[0, :2], [1 + 3 * t + 0.25 * t * t, 2 - t + 0.1 * t * t])
    assert np.allclose(x[0, 2:4], [3 + 0.5 * t, -1 + 0.2 * t])


def test_constant_acceleration_with_a_manoeuvre_time_decays_the_acceleration():
    """acceleration_time T_a keeps exp(-dt / T_a) of the acceleration each step: an unobserved
    target stops accelerating and walks on at the speed it reached."""
    rng = np.random.default_rng(3)
    m = ConstantAccelerationMotion(position_noise=0.0, velocity_noise=0.0, acceleration_noise=0.0,
                                   acceleration_time=10.0)
    x0 = np.array([[1.0, 2.0, 3.0, -1.0, 0.5, 0.2]])
    x = x0
    for _ in range(20):
        x = m.predict(x, 1.0, rng)
    assert np.allclose(x[0, 4:], x0[0, 4:] * np.exp(-2.0), rtol=1e-12)
    # the velocity: v_k = v_{k-1} + a_{k-1}, written out
    v, a, p = x0[0, 2:4].copy(), x0[0, 4:].copy(), x0[0, :2].copy()
    for _ in range(20):
        p = p + v + 0.5 * a
        v, a = v + a, np.exp(-1 / 10) * a
    assert np.allclose(x[0, 2:4], v, rtol=1e-12) and np.allclose(x[0, :2], p, rtol=1e-12)
    # without it the acceleration stays (the paper); the velocity is never damped
    c = ConstantAccelerationMotion(acceleration_time=4.0).transition_matrix(2.0)
    assert c[4, 4] == pytest.approx(np.exp(-0.5)) and c[2, 2] == 1.0 and c[2, 4] == 2.0
    # large clouds take the same matrix (the compiled update writes out the undamped one)
    big = rng.normal(0, 2, (20_000, 6))
    assert np.allclose(m.predict(big, 0.5, rng), big @ m.transition_matrix(0.5).T, atol=1e-12)
    with pytest.raises(ValueError, match="acceleration_time"):
        ConstantAccelerationMotion(acceleration_time=0.0)


def test_damped_constant_acceleration_rows_equal_one_target_at_a_time():
    m = ConstantAccelerationMotion(position_noise=0.1, velocity_noise=0.5,
                                   acceleration_noise=0.1, acceleration_time=10.0)
    s = np.random.default_rng(1).normal(0, 3, (3, 50, 6))
    targets = [_target(frames_tracked=k + 1, size=1.0) for k in range(3)]
    rows = m.predict_rows(s, 1.0, np.random.default_rng(9), targets)
    one = np.random.default_rng(9)
    each = np.stack([m.predict(s[k], 1.0, one, targets[k]) for k in range(3)])
    assert np.array_equal(rows, each)


def test_constant_acceleration_noise_adapts_to_size_and_tracked_frames():
    """The soccer paper: position noise grows with the size; velocity and acceleration noise
    variances are inversely proportional to the consecutive tracked frames (floored at 1)."""
    m = ConstantAccelerationMotion(position_noise=0.1, velocity_noise=0.8, acceleration_noise=0.4)
    s = np.zeros((N, 6))

    def stds(target, dt=1.0):
        return (m.predict(s, dt, np.random.default_rng(4), target) - s).std(axis=0)

    base = stds(_target(frames_tracked=1, size=1.0))
    assert np.allclose(base, [0.1, 0.1, 0.8, 0.8, 0.4, 0.4], rtol=0.01)
    big = stds(_target(frames_tracked=1, size=1.8))
    assert np.allclose(big[:2], 0.18, rtol=0.01) and np.allclose(big[2:], base[2:], rtol=0.01)
    long = stds(_target(frames_tracked=16, size=1.0))
    assert np.allclose(long[:2], 0.1, rtol=0.01)
    assert np.allclose(long[2:], base[2:] / 4.0, rtol=0.01)  # variance / 16
    assert np.allclose(long[2:] ** 2 * 16, base[2:] ** 2, rtol=0.02)
    assert np.allclose(stds(_target(frames_tracked=0)), base, rtol=0.01)  # floor at 1
    assert np.allclose(stds(None), base, rtol=0.01)  # no target: size 1, one frame
    assert np.allclose(stds(_target(1), dt=0.25), base * 0.5, rtol=0.01)
    capped = ConstantAccelerationMotion(position_noise=0.1, velocity_noise=0.8,
                                        acceleration_noise=0.4, max_frames_tracked=4)
    assert np.allclose(capped.noise_std(1.0, _target(frames_tracked=100)),
                       [0.1, 0.1, 0.4, 0.4, 0.2, 0.2])
    with pytest.raises(ValueError, match="size_m"):
        m.noise_std(1.0, _target(size=float("nan")))


@pytest.mark.parametrize("model", [RandomWalkMotion(), ConstantVelocity2DMotion(),
                                   ConstantVelocity3DMotion(), ConstantAccelerationMotion()])
def test_init_states_gaussian_on_position_zero_derivatives(model):
    rng = np.random.default_rng(5)
    p = len(model.position_dims)
    pos = np.arange(1.0, p + 1.0) * 7.0
    s = model.init_states(pos, N, rng, spread=2.0)
    assert s.shape == (N, model.state_dim) and s.dtype == np.float64
    pd = list(model.position_dims)
    assert np.allclose(s[:, pd].mean(axis=0), pos, atol=0.03)
    assert np.allclose(s[:, pd].std(axis=0), 2.0, rtol=0.01)
    rest = [i for i in range(model.state_dim) if i not in pd]
    assert np.all(s[:, rest] == 0.0)
    # per-axis spread on positions; a spread per state axis spreads the derivatives too
    s = model.init_states(pos, N, rng, spread=np.arange(1.0, p + 1.0))
    assert np.allclose(s[:, pd].std(axis=0), np.arange(1.0, p + 1.0), rtol=0.01)
    if rest:
        full = np.full(model.state_dim, 0.5)
        s = model.init_states(pos, 1000, rng, spread=full)
        assert np.all(s[:, rest].std(axis=0) > 0.3)
    assert model.init_states(pos, 0, rng).shape == (0, model.state_dim)


@pytest.mark.parametrize("model", [RandomWalkMotion(), ConstantVelocity2DMotion(),
                                   ConstantVelocity3DMotion(), ConstantAccelerationMotion()])
def test_predict_is_seeded_and_leaves_its_input_alone(model):
    d = model.state_dim
    s = np.random.default_rng(6).normal(0, 1, (100, d))
    keep = s.copy()
    a = model.predict(s, 1.0, np.random.default_rng(9), _target(3, 1.5))
    b = model.predict(s, 1.0, np.random.default_rng(9), _target(3, 1.5))
    c = model.predict(s, 1.0, np.random.default_rng(10), _target(3, 1.5))
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.array_equal(s, keep) and not np.shares_memory(a, s)
    assert model.predict(np.zeros((0, d)), 1.0, np.random.default_rng(0)).shape == (0, d)


def test_bad_input_names_the_model_and_parameter():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"ConstantAccelerationMotion.predict.*\(N, 6\)"):
        ConstantAccelerationMotion().predict(np.zeros((3, 4)), 1.0, rng)
    with pytest.raises(ValueError, match="RandomWalkMotion.*dt"):
        RandomWalkMotion().predict(np.zeros((3, 2)), -1.0, rng)
    with pytest.raises(ValueError, match="ConstantVelocity3DMotion: position_noise"):
        ConstantVelocity3DMotion(position_noise=(1.0, 2.0)).predict(np.zeros((3, 6)), 1.0, rng)
    with pytest.raises(ValueError, match=r"RandomWalkMotion.*'sigma_px' must be .* >= 0"):
        RandomWalkMotion(sigma_px=-1.0)
    with pytest.raises(ValueError, match=r"ConstantAccelerationMotion.*'max_frames_tracked'"):
        ConstantAccelerationMotion(max_frames_tracked=0)
    with pytest.raises(ValueError, match="init_states: position must have 3"):
        ConstantVelocity3DMotion().init_states(np.zeros(2), 5, rng)
    with pytest.raises(ValueError, match="init_states: spread"):
        ConstantVelocity2DMotion().init_states(np.zeros(2), 5, rng, spread=np.ones(3))


def test_random_walk_predict_rows_equals_row_by_row_bit_for_bit():
    """The engine predicts every target in one call; the numbers are those of one predict per
    target in order (the default of every model, the override of the random walk)."""
    from pftrack.contracts.components import MotionModel

    m = RandomWalkMotion(sigma_px=(2.0, 3.0))
    states = np.random.default_rng(1).normal(size=(3, 50, 2)) * 40
    a = m.predict_rows(states, 0.5, np.random.default_rng(7), targets=[None] * 3)
    rng = np.random.default_rng(7)
    b = np.array([m.predict(s, 0.5, rng) for s in states])
    assert np.array_equal(a, b)
    # the base class's row loop gives the same numbers too
    c = MotionModel.predict_rows(m, states, 0.5, np.random.default_rng(7), [None] * 3)
    assert np.array_equal(a, c)
    with pytest.raises(ValueError, match=r"\(T, N, 2\)"):
        m.predict_rows(states[0], 1.0, np.random.default_rng(0))


@pytest.mark.parametrize("std", [[2.5, 2.5], [2.5, 0.7], [1.0, 1.0, 1.0, 3.0, 3.0, 3.0]])
@pytest.mark.parametrize("lead", [(500,), (3, 500), (1,)])
def test_noise_scaling_equals_the_broadcast_product(std, lead):
    """The random walk scales its noise by one scalar when both axes share a deviation: the
    same products as numpy's broadcast of the (D,) deviations, bit for bit."""
    from pftrack_basic.motion import _scale_axes

    std = np.asarray(std)
    z = np.random.default_rng(8).standard_normal(lead + std.shape)
    got = z.copy()
    _scale_axes(got, std)
    assert got.tobytes() == (z * std).tobytes()


def test_random_walk_rows_equal_one_target_at_a_time_with_per_axis_noise():
    """(T, N, 2) in one call: the numbers T successive single-target calls draw, with one
    deviation for both axes and with one per axis."""
    for sigma in (3.0, (3.0, 1.5)):
        m = RandomWalkMotion(sigma_px=sigma)
        s = np.random.default_rng(1).normal(100.0, 5.0, (3, 400, 2))
        a, b = np.random.default_rng(4), np.random.default_rng(4)
        rows = m.predict_rows(s, 1.0, a)
        one = np.array([m.predict(s[i], 1.0, b) for i in range(3)])
        assert rows.tobytes() == one.tobytes()
        assert a.random() == b.random()


def test_random_walk_noise_follows_sigma_and_dt_changes_between_steps():
    """The deviations are kept between steps, but a changed ``sigma_px`` or ``dt`` is used at
    once and a bad value still raises."""
    m = RandomWalkMotion(sigma_px=2.0)
    s = np.zeros((20000, 2))
    for sigma, dt in ((2.0, 1.0), (2.0, 1.0), (5.0, 1.0), (5.0, 0.25), ((1.0, 3.0), 1.0)):
        m.sigma_px = sigma
        d = m.predict(s, dt, np.random.default_rng(0))
        want = np.broadcast_to(np.asarray(sigma, float) * np.sqrt(dt), (2,))
        np.testing.assert_allclose(d.std(axis=0), want, rtol=0.03)
    m.sigma_px = 2.0
    with pytest.raises(ValueError, match="dt must be finite and >= 0"):
        m.predict(s, -1.0, np.random.default_rng(0))
    m.sigma_px = float("nan")
    with pytest.raises(ValueError, match="sigma_px must be finite"):
        m.predict(s, 1.0, np.random.default_rng(0))


@pytest.mark.parametrize("model", [ConstantVelocity3DMotion(position_noise=0.1),
                                   ConstantVelocity3DMotion(position_noise=(0.1, 0.2, 0.05),
                                                            velocity_noise=0.3,
                                                            velocity_from_displacement=False),
                                   ConstantVelocity2DMotion(position_noise=2.0)])
def test_constant_velocity_predict_rows_equals_one_target_at_a_time(model):
    """The engine predicts all targets in one call: the numbers (and the Generator's state
    after) of one predict per target in order, bit for bit; a state that is not (T, N, D) is
    named."""
    d = model.state_dim
    s = np.random.default_rng(2).normal(0.0, 3.0, (3, 1500, d))
    a, b = np.random.default_rng(11), np.random.default_rng(11)
    rows = model.predict_rows(s, 0.5, a, [None] * 3)
    one = np.array([model.predict(s[i], 0.5, b) for i in range(3)])
    assert rows.tobytes() == one.tobytes()
    assert a.random() == b.random()
    with pytest.raises(ValueError, match=rf"predict_rows: states must have shape \(T, N, {d}\)"):
        model.predict_rows(s[0], 1.0, a, [None])


def test_constant_acceleration_predict_rows_equals_one_target_at_a_time():
    """All targets in one call, each with its own adaptive noise (size, tracked frames): the
    numbers and the Generator's state of one predict per target, bit for bit; bad input is
    named as predict names it."""
    model = ConstantAccelerationMotion(position_noise=0.3, velocity_noise=1.0,
                                       acceleration_noise=0.3, max_frames_tracked=5)
    targets = [_target(frames_tracked=f, size=s) for f, s in ((0, 1.0), (3, 1.7), (9, 0.4))]
    s = np.random.default_rng(4).normal(0.0, 2.0, (3, 200, 6))
    a, b = np.random.default_rng(8), np.random.default_rng(8)
    rows = model.predict_rows(s, 0.04, a, targets)
    one = np.array([model.predict(s[i], 0.04, b, target=t) for i, t in enumerate(targets)])
    assert rows.tobytes() == one.tobytes()
    assert a.random() == b.random()
    std = model.noise_std_rows(0.04, targets)
    assert std.tobytes() == np.array([model.noise_std(0.04, t) for t in targets]).tobytes()
    targets[1].size_m = float("nan")
    with pytest.raises(ValueError, match="target .* has size_m=nan"):
        model.predict_rows(s, 0.04, a, targets)
    with pytest.raises(ValueError, match=r"predict_rows: states must have shape \(T, N, 6\)"):
        model.predict_rows(s[:2], 0.04, a, targets)
