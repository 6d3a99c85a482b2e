"""Sample third-party pftrack plugin (test fixture).

It shows the whole surface a plugin author needs: components subclassing the contracts in
:mod:`pftrack.components`, registered through ``pftrack_register_*`` hooks, exposed through the
``pftrack`` entry-point group in ``pyproject.toml``. The project's tests install it into a temporary
folder and check that ``pftrack plugins`` lists it, that it builds and runs, and that the
``PFTRACK_DISABLE_*`` environment variables block it.
"""

from __future__ import annotations

import numpy as np

from pftrack import hookimpl
from pftrack.components import Likelihood, MotionModel, Target

__version__ = "0.3.1"


class DriftMotion(MotionModel):
    """Image-plane state (x, y) in pixels drifting by a constant velocity plus Gaussian noise.

    Parameters
    ----------
    velocity_px : tuple of float
        Drift (vx, vy) in pixels per unit of ``dt``.
    sigma_px : float
        Noise standard deviation in pixels per unit of ``dt``.
    """

    def __init__(self, velocity_px: tuple[float, float] = (1.0, 0.0), sigma_px: float = 1.0):
        self.velocity_px = velocity_px
        self.sigma_px = sigma_px

    @property
    def state_dim(self) -> int:
        return 2

    def predict(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                target: Target | None = None) -> np.ndarray:
        s = np.asarray(states, dtype=np.float64).reshape(-1, 2)
        noise = rng.standard_normal(s.shape) * (self.sigma_px * np.sqrt(dt))
        return s + np.asarray(self.velocity_px, dtype=np.float64) * dt + noise

    def init_states(self, position: np.ndarray, n: int, rng: np.random.Generator,
                    spread: float | np.ndarray = 1.0) -> np.ndarray:
        p = np.asarray(position, dtype=np.float64).reshape(2)
        return p + rng.standard_normal((n, 2)) * np.asarray(spread, dtype=np.float64)


class BoxAreaLikelihood(Likelihood):
    """Prefers boxes whose area is close to ``area_px`` (a toy likelihood).

    ``log L = -((w h - area_px) / scale_px)^2 / 2`` for boxes (N, 4) xywh px.
    """

    def __init__(self, area_px: float = 400.0, scale_px: float = 100.0):
        self.area_px = area_px
        self.scale_px = scale_px

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
        z = (b[:, 2] * b[:, 3] - self.area_px) / self.scale_px
        return -0.5 * z * z


@hookimpl
def pftrack_register_motion_models(register):
    register("sample-drift", DriftMotion)


@hookimpl
def pftrack_register_likelihoods(register):
    register("sample-box-area", BoxAreaLikelihood)
