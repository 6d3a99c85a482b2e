"""Kinematic motion models: random walk, constant velocity (2-D, 3-D) and adaptive constant
acceleration, vectorised over particles.

Each model maps particle states ``(N, D)`` to new states ``(N, D)`` given a time step ``dt`` and a
``numpy.random.Generator``; none touches global random state or modifies its input.

Noise is given per unit of ``dt`` and scaled by ``sqrt(dt)`` (a Wiener process), so ``dt = 1``
(one frame) draws exactly the stated standard deviation.

Models
------
:class:`RandomWalkMotion` (``random-walk``)
    The colour paper: the box centre ``(x, y)`` in pixels moves by Gaussian noise only.
:class:`ConstantVelocity2DMotion`, :class:`ConstantVelocity3DMotion` (``constant-velocity-2d/3d``)
    The coastal paper's eq. 5-7: ``x_t = F x_{t-1} + W`` with the velocity taken as the displacement
    just made (eq. 7), state ``(x, y[, z], vx, vy[, vz])``.
:class:`ConstantAccelerationMotion` (``constant-acceleration``)
    The soccer paper's eq. 1-2: state ``[p_x, p_y, v_x, v_y, a_x, a_y]``, ``x_t = C x_{t-dt} +
    noise`` with adaptive noise: the position noise grows with the target's size, the velocity and
    acceleration noise *variances* are inversely proportional to the number of consecutive tracked
    frames.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from pftrack.contracts.components import MotionModel, Param, Target
from pftrack.filter import _jit

# below this many particles a (N, D) @ (D, D) product beats column-wise updates; above, the
# updates run on blocks of this many rows so that a block stays in cache
_SMALL_N = 4096
_BLOCK_ROWS = 4096

__all__ = [
    "ConstantAccelerationMotion",
    "ConstantVelocity2DMotion",
    "ConstantVelocity3DMotion",
    "RandomWalkMotion",
]


def _check_states(model: MotionModel, states: np.ndarray) -> np.ndarray:
    s = np.asarray(states, dtype=np.float64)
    d = model.state_dim
    if s.ndim != 2 or s.shape[1] != d:
        raise ValueError(f"{type(model).__name__}.predict: states must have shape (N, {d}), "
                         f"got {s.shape}")
    return s


def _check_dt(model: MotionModel, dt: float) -> float:
    dt = float(dt)
    if not np.isfinite(dt) or dt < 0:
        raise ValueError(f"{type(model).__name__}.predict: dt must be finite and >= 0, got {dt}")
    return dt


def _axis_std(model: MotionModel, param: str, n_axes: int) -> np.ndarray:
    """A noise parameter (float, or one value per axis) as an (n_axes,) array, validated."""
    raw = getattr(model, param)
    if isinstance(raw, (int, float)) and not isinstance(raw, bool):
        if not (math.isfinite(raw) and raw >= 0):  # fast path: called every predict
            raise ValueError(f"{type(model).__name__}: {param} must be finite and >= 0, "
                             f"got {raw!r}")
        return np.full(n_axes, float(raw))
    try:
        std = np.broadcast_to(np.asarray(raw, dtype=np.float64), (n_axes,)).copy()
    except ValueError:
        raise ValueError(f"{type(model).__name__}: {param} must be a number or {n_axes} numbers, "
                         f"got {raw!r}") from None
    if not np.all(np.isfinite(std)) or np.any(std < 0):
        raise ValueError(f"{type(model).__name__}: {param} must be finite and >= 0, got {raw!r}")
    return std


def _scale_axes(out: np.ndarray, std: np.ndarray) -> None:
    """``out *= std`` over the last axis (D,), in place, with the same products; one scalar
    multiply when every axis has the same deviation (numpy's broadcast of a (D,) operand runs
    an inner loop of length D: at the engine's few thousand numbers, several times slower)."""
    vals = std.tolist()
    if all(v == vals[0] for v in vals):
        out *= vals[0]
    else:
        out *= std


def _standard_normal(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """``rng.standard_normal(shape)``: the same numbers and the same Generator state after,
    drawn by the compiled ziggurat when the engine has loaded it for small counts (about half
    numpy's per-call cost at a few thousand draws)."""
    if _jit.small_ready() or _jit.use(math.prod(shape)):
        out = np.empty(shape)
        if _jit.pcg64_standard_normal(rng, out):
            return out
    return rng.standard_normal(shape)


def _noisy_update(states: np.ndarray, std: np.ndarray, rng: np.random.Generator,
                  update: Callable[[np.ndarray, np.ndarray], None]) -> np.ndarray:
    """``out = noise * std`` then ``update(out.T, states.T)`` adds the deterministic part.

    Runs block by block over rows (the Generator fills the blocks in order, so the numbers are
    those of one ``standard_normal((N, D))`` call): each block's columns are updated while in
    cache. ``update`` works on transposed views, one strided 1-D loop per term, which avoids
    both multi-threaded BLAS (whose threads stall on a busy machine) and (N, 2) slices (whose
    inner loop has length 2).
    """
    out = np.empty(states.shape)
    for a in range(0, len(states), _BLOCK_ROWS):
        o = out[a:a + _BLOCK_ROWS]
        rng.standard_normal(out=o)
        o *= std
        update(o.T, states[a:a + _BLOCK_ROWS].T)
    return out


def _init_states(model: MotionModel, position: np.ndarray, n: int, rng: np.random.Generator,
                 spread: float | np.ndarray) -> np.ndarray:
    """``n`` states: Gaussian around ``position`` on the position dims, zero elsewhere.

    ``spread`` is a standard deviation: a number, one per position axis (P,), or one per state
    axis (D,) to spread the derivatives too.
    """
    d = model.state_dim
    pos_dims = list(model.position_dims)
    p = np.asarray(position, dtype=np.float64).reshape(-1)
    if p.shape != (len(pos_dims),):
        raise ValueError(f"{type(model).__name__}.init_states: position must have "
                         f"{len(pos_dims)} values, got shape {np.shape(position)}")
    n = int(n)
    if n < 0:
        raise ValueError(f"{type(model).__name__}.init_states: n must be >= 0, got {n}")
    sp = np.asarray(spread, dtype=np.float64).reshape(-1)
    scale = np.zeros(d)
    if sp.size == d and d != len(pos_dims):
        scale[:] = sp
    elif sp.size in (1, len(pos_dims)):
        scale[pos_dims] = sp
    else:
        raise ValueError(f"{type(model).__name__}.init_states: spread must be a number, "
                         f"{len(pos_dims)} or {d} numbers, got shape {np.shape(spread)}")
    if not np.all(np.isfinite(scale)) or np.any(scale < 0):
        raise ValueError(f"{type(model).__name__}.init_states: spread must be finite and >= 0, "
                         f"got {spread!r}")
    out = rng.standard_normal((n, d))
    out *= scale
    out[:, pos_dims] += p
    return out


class RandomWalkMotion(MotionModel):
    """Gaussian random walk of the box centre in the image plane (the colour paper).

    State ``(x, y)``: box centre in pixels. Each step adds independent ``N(0, sigma_px^2 dt)``
    noise to each coordinate; ``dt`` is in frames.

    {params}
    """

    sigma_px: float | tuple[float, float] = Param(
        3.0, "Noise standard deviation per frame (per axis when two values).",
        unit="px per √dt", low=0.0, length=2)

    @property
    def state_dim(self) -> int:
        return 2

    def _std(self, dt: float) -> np.ndarray:
        """The (2,) noise deviations for a step of ``dt``, validated; kept for a number
        ``sigma_px`` and the same ``dt`` (every frame of a run), so the checks and the square
        root run once."""
        raw = self.sigma_px
        key = (raw, dt) if type(raw) in (int, float) and type(dt) in (int, float) else None
        hit = self.__dict__.get("_noise_std")
        if key is not None and hit is not None and hit[0] == key:
            return hit[1]
        std = _axis_std(self, "sigma_px", 2) * np.sqrt(_check_dt(self, dt))
        if key is not None:
            std.flags.writeable = False
            self._noise_std = (key, std)
        return std

    def predict(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                target: Target | None = None) -> np.ndarray:
        s = _check_states(self, states)
        std = self._std(dt)
        out = _standard_normal(rng, s.shape)
        _scale_axes(out, std)
        out += s
        return out

    def predict_rows(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                     targets=None) -> np.ndarray:
        """All targets at once: the noise does not depend on the target, and one
        ``standard_normal((T, N, 2))`` draws the numbers T row-by-row calls would."""
        s = np.asarray(states, dtype=np.float64)
        if s.ndim != 3 or s.shape[2] != 2:
            raise ValueError(f"RandomWalkMotion.predict_rows: states must have shape (T, N, 2), "
                             f"got {s.shape}")
        std = self._std(dt)
        if (_jit.small_ready() or _jit.use(s.size)) and std.shape == (s.shape[2],):
            out = _jit.random_walk_predict(s, std, rng)  # one pass: the same numbers
            if out is not None:
                return out
        out = _standard_normal(rng, s.shape)
        _scale_axes(out, std)
        out += s
        return out

    def init_states(self, position: np.ndarray, n: int, rng: np.random.Generator,
                    spread: float | np.ndarray = 1.0) -> np.ndarray:
        return _init_states(self, position, n, rng, spread)


class _ConstantVelocityMotion(MotionModel):
    """Constant velocity in ``_ndim`` dimensions (the coastal paper's eq. 5-7).

    State ``(x, y[, z], vx, vy[, vz])``: positions, then velocities in position units per unit of
    ``dt``. Per step::

        p_t = p_{t-1} + v_{t-1} dt + N(0, position_noise^2 dt)        (eq. 5-6, F with dt)
        v_t = (p_t - p_{t-1}) / dt + N(0, velocity_noise^2 dt)        (eq. 7 when
                                                                       velocity_from_displacement)

    With ``velocity_from_displacement=False`` the velocity is carried over instead,
    ``v_t = v_{t-1} + N(0, velocity_noise^2 dt)`` (the textbook nearly-constant-velocity model).

    {params}
    """

    _ndim: int = 2

    position_noise: float | tuple[float, ...] = Param(
        1.0, "Position noise standard deviation per unit of dt (per axis when a sequence), in "
        "the position unit (pixels or metres).", unit="state units per √dt", low=0.0)
    velocity_noise: float | tuple[float, ...] = Param(
        0.0, "Extra velocity noise standard deviation per unit of dt (per axis when a "
        "sequence); 0 follows the paper exactly.", unit="state units/dt per √dt", low=0.0)
    velocity_from_displacement: bool = Param(
        True, "The coastal paper's eq. 7: the new velocity is the displacement just made.")

    @property
    def state_dim(self) -> int:
        return 2 * self._ndim

    @property
    def position_dims(self) -> tuple[int, ...]:
        return tuple(range(self._ndim))

    @property
    def velocity_dims(self) -> tuple[int, ...]:
        """The state entries of the velocity (position units per unit of ``dt``)."""
        return tuple(range(self._ndim, 2 * self._ndim))

    def predict(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                target: Target | None = None) -> np.ndarray:
        s = _check_states(self, states)
        dt, update, std = self._transition(dt)
        return _noisy_update(s, std, rng, update)

    def _transition(self, dt: float) -> tuple[float, Callable[[np.ndarray, np.ndarray], None],
                                              np.ndarray]:
        """The checked ``dt``, the deterministic update ``update(noise.T, states.T)`` (in
        place on the scaled noise) and the noise's standard deviations (D,)."""
        dt = _check_dt(self, dt)
        k = self._ndim
        sq = np.sqrt(dt)
        std = np.concatenate([_axis_std(self, "position_noise", k),
                              _axis_std(self, "velocity_noise", k)]) * sq
        from_displacement = bool(self.velocity_from_displacement) and dt > 0

        def update(o: np.ndarray, x: np.ndarray) -> None:  # o, x: (D, rows) views
            for i in range(k):
                if from_displacement:
                    # displacement = v dt + position noise; the new velocity is displacement / dt
                    o[k + i] += o[i] / dt
                o[k + i] += x[k + i]
                o[i] += x[i]
                o[i] += dt * x[k + i]

        return dt, update, std

    def predict_rows(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                     targets: Sequence[Target]) -> np.ndarray:
        """Every target's particles at once: (T, N, D) -> (T, N, D), equal to T successive
        :meth:`predict` calls bit for bit (the noise does not depend on the target: one
        ``standard_normal((T, N, D))`` draws the numbers the T calls would, and each update
        is elementwise)."""
        s = np.asarray(states, dtype=np.float64)
        if s.ndim != 3:
            raise ValueError(f"{type(self).__name__}.predict_rows: states must have shape "
                             f"(T, N, {self.state_dim}), got {s.shape}")
        flat = _check_states(self, s.reshape(-1, s.shape[2]))
        dt, update, std = self._transition(dt)
        out = _standard_normal(rng, flat.shape)  # (the compiled ziggurat: numpy's numbers)
        if _jit.small_ready() or _jit.use(out.size):  # one compiled pass, the same numbers
            _jit.constant_velocity_update(out, flat, std, self._ndim, dt,
                                          bool(self.velocity_from_displacement) and dt > 0)
        else:
            out *= std
            update(out.T, flat.T)
        return out.reshape(s.shape)

    def init_states(self, position: np.ndarray, n: int, rng: np.random.Generator,
                    spread: float | np.ndarray = 1.0) -> np.ndarray:
        return _init_states(self, position, n, rng, spread)


class ConstantVelocity2DMotion(_ConstantVelocityMotion):
    __doc__ = (_ConstantVelocityMotion.__doc__ or "").replace(
        "in ``_ndim`` dimensions", "in 2-D, state (x, y, vx, vy)")
    _ndim = 2


class ConstantVelocity3DMotion(_ConstantVelocityMotion):
    __doc__ = (_ConstantVelocityMotion.__doc__ or "").replace(
        "in ``_ndim`` dimensions", "in 3-D, state (x, y, z, vx, vy, vz)")
    _ndim = 3


class ConstantAccelerationMotion(MotionModel):
    """Constant acceleration with adaptive noise (the soccer paper's eq. 1-2).

    State ``x = [p_x, p_y, v_x, v_y, a_x, a_y]`` (eq. 1): position, velocity and acceleration on
    the ground plane (world metres and seconds for the soccer paper, or pixels and frames in the
    image). Transition over ``dt`` (the paper's alpha), eq. 2::

        x_t = C x_{t-dt} + Upsilon,
        C = [[I, dt I, dt^2/2 I], [0, I, dt I], [0, 0, I]]

    with zero-mean Gaussian noise ``Upsilon = (eps_p, eps_v, eps_a)`` independent per axis. The
    paper: "the position noise variance sigma_p^2 changes with the size of the target; the velocity
    and acceleration noise variances sigma_v^2, sigma_a^2 are inversely proportional to the number
    of consecutive successfully tracked frames", so particles converge the longer a target is
    tracked. Here, with ``s = target.size_m`` and ``n = max(target.frames_tracked, 1)`` (capped at
    ``max_frames_tracked`` when given)::

        sigma_p = position_noise * s          (std proportional to the size)
        sigma_v = velocity_noise / sqrt(n)    (variance proportional to 1 / n)
        sigma_a = acceleration_noise / sqrt(n)

    each per unit of ``dt`` and scaled by ``sqrt(dt)``. Without a target, ``s = 1`` and ``n = 1``.

    {params}
    """

    position_noise: float | tuple[float, float] = Param(
        0.1, "Position noise std per unit of target size (per unit of dt; per axis when two "
        "values).", unit="target sizes per √dt", low=0.0, length=2)
    velocity_noise: float | tuple[float, float] = Param(
        0.5, "Velocity noise std for a target tracked for one frame (per unit of dt; per axis "
        "when two values).", unit="state units/dt per √dt", low=0.0, length=2)
    acceleration_noise: float | tuple[float, float] = Param(
        0.5, "Acceleration noise std for a target tracked for one frame (per unit of dt; per "
        "axis when two values).", unit="state units/dt² per √dt", low=0.0, length=2)
    max_frames_tracked: int | None = Param(
        None, "Cap on n so the derivative noise never falls below noise / sqrt(cap); None (the "
        "paper) lets it shrink without bound.", unit="frames", low=1)
    acceleration_time: float | None = Param(
        None, "How long an acceleration lasts (Singer's manoeuvre time constant): each step "
        "keeps exp(-dt / acceleration_time) of it, so a target that goes unobserved is "
        "predicted to stop speeding up or turning after about this long instead of "
        "accelerating for ever; None keeps it constant (the paper).", unit="dt",
        low=0.0, low_open=True)

    @property
    def state_dim(self) -> int:
        return 6

    @property
    def velocity_dims(self) -> tuple[int, ...]:
        """The state entries of the velocity ``(v_x, v_y)``."""
        return (2, 3)

    def noise_std(self, dt: float = 1.0, target: Target | None = None) -> np.ndarray:
        """Noise standard deviations (6,) for one step of ``dt`` given ``target``."""
        dt = _check_dt(self, dt)
        size = 1.0 if target is None else float(target.size_m)
        n = 1 if target is None else max(int(target.frames_tracked), 1)
        if self.max_frames_tracked is not None:
            n = min(n, int(self.max_frames_tracked))
        if not np.isfinite(size) or size < 0:
            raise ValueError(f"ConstantAccelerationMotion: target {getattr(target, 'id', '?')} "
                             f"has size_m={size}; it must be finite and >= 0")
        std = np.empty(6)
        std[0:2] = _axis_std(self, "position_noise", 2) * (size * math.sqrt(dt))
        root = math.sqrt(dt / n)
        std[2:4] = _axis_std(self, "velocity_noise", 2) * root
        std[4:6] = _axis_std(self, "acceleration_noise", 2) * root
        return std

    def noise_std_rows(self, dt: float, targets: Sequence[Target]) -> np.ndarray:
        """:meth:`noise_std` of every target at once, (T, 6), row ``i`` equal to
        ``noise_std(dt, targets[i])`` bit for bit."""
        dt = _check_dt(self, dt)
        size = np.array([float(t.size_m) for t in targets], dtype=np.float64)
        n = np.array([max(int(t.frames_tracked), 1) for t in targets], dtype=np.int64)
        if self.max_frames_tracked is not None:
            np.minimum(n, int(self.max_frames_tracked), out=n)
        bad = ~(np.isfinite(size) & (size >= 0))
        if bad.any():
            self.noise_std(dt, targets[int(np.flatnonzero(bad)[0])])  # raises, naming it
        std = np.empty((len(size), 6))
        scale = (size * math.sqrt(dt))[:, None]
        std[:, 0:2] = _axis_std(self, "position_noise", 2)[None, :] * scale
        root = np.sqrt(dt / n)[:, None]
        std[:, 2:4] = _axis_std(self, "velocity_noise", 2)[None, :] * root
        std[:, 4:6] = _axis_std(self, "acceleration_noise", 2)[None, :] * root
        return std

    def _damped(self) -> bool:
        return self.acceleration_time is not None

    def transition_matrix(self, dt: float) -> np.ndarray:
        """C of eq. 2 for a step ``dt``, shape (6, 6).

        With ``acceleration_time`` ``T_a``, the factor ``r_a = exp(-dt / T_a)`` scales the
        acceleration's rows: ``p' = p + dt v + dt^2/2 a``, ``v' = v + dt a``, ``a' = r_a a``.
        """
        c = np.eye(6)
        c[0, 2] = c[1, 3] = c[2, 4] = c[3, 5] = dt
        c[0, 4] = c[1, 5] = 0.5 * dt * dt
        if self.acceleration_time is not None:
            c[4:6] *= math.exp(-dt / float(self.acceleration_time))
        return c

    def predict(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                target: Target | None = None) -> np.ndarray:
        s = _check_states(self, states)
        std = self.noise_std(dt, target)
        dt = float(dt)
        if len(s) <= _SMALL_N or self._damped():
            # one small matrix product: cheapest in per-call overhead (the compiled and the
            # blocked updates below write out the undamped C)
            out = rng.standard_normal(s.shape)
            out *= std
            out += s @ self.transition_matrix(dt).T
            return out
        if _jit.use(len(s)):
            # one compiled pass: the same draws and the same arithmetic as below
            out = _jit.constant_acceleration_predict(s, std, dt, rng)
            if out is not None:
                return out
        half = 0.5 * dt * dt

        def update(o: np.ndarray, x: np.ndarray) -> None:  # C x, written out per column
            for i in range(2):
                o[i] += x[i]
                o[i] += dt * x[2 + i]
                o[i] += half * x[4 + i]
                o[2 + i] += x[2 + i]
                o[2 + i] += dt * x[4 + i]
                o[4 + i] += x[4 + i]

        return _noisy_update(s, std, rng, update)

    def predict_rows(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                     targets: Sequence[Target]) -> np.ndarray:
        """Every target's particles at once: (T, N, D) -> (T, N, D), equal to T successive
        :meth:`predict` calls bit for bit: one ``standard_normal((T, N, 6))`` draws the
        numbers the T calls would, each row scaled by its target's noise
        (:meth:`noise_std_rows`), then one ``C x`` product per row (the calls' products)."""
        s = np.asarray(states, dtype=np.float64)
        if s.ndim != 3 or s.shape[2] != 6 or len(s) != len(targets):
            raise ValueError(f"ConstantAccelerationMotion.predict_rows: states must have shape "
                             f"(T, N, 6) with T = {len(targets)} targets, got {s.shape}")
        if s.shape[1] > _SMALL_N and not self._damped():
            # large clouds: each target's compiled or blocked update
            return super().predict_rows(s, dt, rng, targets)
        std = self.noise_std_rows(dt, targets)
        # the compiled ziggurat (numpy's numbers) only once the engine loaded it: the T
        # targets' few thousand draws never pay for loading numba
        out = _standard_normal(rng, s.shape) if _jit.small_ready() else \
            rng.standard_normal(s.shape)
        out *= std[:, None, :]
        out += s @ self.transition_matrix(float(dt)).T
        return out

    def init_states(self, position: np.ndarray, n: int, rng: np.random.Generator,
                    spread: float | np.ndarray = 1.0) -> np.ndarray:
        return _init_states(self, position, n, rng, spread)
