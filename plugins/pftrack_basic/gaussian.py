"""A cheap Gaussian likelihood of the box centre: for synthetic tests, benchmarks and for tracking
from detections alone.

It reads no pixels: the log-likelihood of a particle is a Gaussian in the distance between its
box centre and an observed point, so it costs a few array operations per particle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pftrack.contracts.components import Detections, Frame, Likelihood, Param, Target
from pftrack.filter import _jit

__all__ = ["GaussianLikelihood"]


class GaussianLikelihood(Likelihood):
    """Isotropic Gaussian in the distance from the particle's box centre to an observation.

    ``log L = -||c - o||^2 / (2 sigma_px^2)`` with ``c`` the box centre ``(left + w/2, top + h/2)``
    in pixels. The observation ``o`` (pixels) of a target is, in order of precedence:

    1. ``target.observation_px``: a point (2,) the caller sets (synthetic data, tests);
    2. ``target.detection.box_xywh_px``: the centre of the detection the tracker's
       associator matched to the target;
    3. when ``use_all_detections`` is true and :meth:`begin_frame` received detections: the
       nearest detection centre to each particle (a max over detections of the Gaussian);
    4. otherwise the observation is missing and every particle gets ``missing_log_likelihood``
       (default 0: the weights are left as they are).

    Boxes may lie partly or wholly outside the image; only their centres are used.

    {params}
    """

    sigma_px: float = Param(5.0, "Standard deviation of the observation noise.", unit="px",
                            low=0.0, low_open=True)
    use_all_detections: bool = Param(
        True, "Fall back on the nearest of all the frame's detections (rule 3).")
    missing_log_likelihood: float = Param(
        0.0, "Log-likelihood of every particle when there is no observation (-inf allowed).",
        unit="log-likelihood", high=math.inf, high_open=True, finite=False)

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        """Keep the centres (K, 2) px of this frame's detections in ``detection_centres_px_``."""
        if detections is None or len(detections) == 0:
            self.detection_centres_px_ = np.zeros((0, 2))
        else:
            b = detections.boxes_xywh_px
            self.detection_centres_px_ = b[:, :2] + 0.5 * b[:, 2:]

    def _observation(self, target: Target) -> np.ndarray | None:
        obs = target.observation_px
        if obs is not None:
            o = np.asarray(obs, dtype=np.float64).reshape(-1)
            if o.shape != (2,) or not np.all(np.isfinite(o)):
                raise ValueError(f"GaussianLikelihood: target {target.id} has "
                                 f"observation_px={obs!r}; expected 2 finite numbers (px)")
            return o[None, :]
        det = target.detection
        if det is not None:
            b = np.asarray(det.box_xywh_px, dtype=np.float64).reshape(4)
            return (b[:2] + 0.5 * b[2:])[None, :]
        if self.use_all_detections:
            centres = getattr(self, "detection_centres_px_", None)
            if centres is not None and len(centres):
                return centres
        return None

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        sigma = float(self.sigma_px)
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        if b.ndim != 2 or b.shape[1] != 4:
            raise ValueError(f"GaussianLikelihood: boxes must have shape (N, 4), got {b.shape}")
        obs = self._observation(target)
        if obs is None:
            return np.full(len(b), float(self.missing_log_likelihood))
        if len(obs) == 1 and _jit.use(len(b)):
            # one compiled pass, the same operations in the same order as below
            return _jit.gaussian_centre_log_likelihood(b, obs[0, 0], obs[0, 1],
                                                       -0.5 / (sigma * sigma))
        cx = b[:, 0] + 0.5 * b[:, 2]
        cy = b[:, 1] + 0.5 * b[:, 3]
        if len(obs) == 1:
            dx = cx - obs[0, 0]
            dy = cy - obs[0, 1]
            d2 = dx * dx + dy * dy
        else:
            dx = cx[:, None] - obs[None, :, 0]
            dy = cy[:, None] - obs[None, :, 1]
            d2 = np.min(dx * dx + dy * dy, axis=1)
        d2 *= -0.5 / (sigma * sigma)
        return d2
