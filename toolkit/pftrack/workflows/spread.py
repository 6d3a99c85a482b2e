"""Uncertainty from the particle clouds: :class:`RecordSpread` fills each track record's
``xyxy_sd`` (the sd of its box corners, px) and ``world_cov`` (the covariance of its ground
position, m\u00b2) from the engine's particles, frame by frame."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from pftrack.contracts.components import TrackRecord

if TYPE_CHECKING:
    from pftrack.engine.tracker import MultiTargetTracker

__all__ = ["RecordSpread"]

#: A box corner sd (4,) or a ground covariance (2, 2) not known.
_NAN4 = np.full(4, np.nan)
_NAN22 = np.full((2, 2), np.nan)


@dataclass
class _Cloud:
    """Each live target's spread, by engine id: xyxy sd (4,) and, with a world frame, the
    ground covariance (2, 2)."""

    xyxy_sd: dict[int, np.ndarray]
    world_cov: dict[int, np.ndarray]


def _weighted_cov(x: np.ndarray, w: np.ndarray | None) -> np.ndarray:
    """(T, N, K) values with weights (T, N) (None: equal) -> (T, K, K) covariances."""
    if w is None:
        d = x - x.mean(axis=1, keepdims=True)
        return np.matmul(d.transpose(0, 2, 1), d) / x.shape[1]
    mean = np.matmul(w[:, None, :], x)  # (T, 1, K)
    d = x - mean
    return np.matmul((d * w[:, :, None]).transpose(0, 2, 1), d)


def _ground_points(observation: Any, particles: np.ndarray) -> np.ndarray | None:
    """Particles (M, D) -> ground x, y (M, 2) m through the observation model's vectorised
    mapping (``ground_points`` or ``points``), or None when it has none."""
    for name in ("ground_points", "points"):
        fn = getattr(observation, name, None)
        if callable(fn):
            return np.asarray(fn(particles), dtype=np.float64)[:, :2]
    return None


def _cloud(engine: MultiTargetTracker, world: bool) -> _Cloud:
    """The spread of every live target's particle cloud as the filter carries it into the next
    frame; the targets resampled this frame with as many particles, in one pass."""
    targets = engine.targets
    out = _Cloud({}, {})
    if not targets:
        return out
    n = engine.n_particles
    resampled = [i for i, t in enumerate(targets)
                 if t.resample_index is not None and t.particle_boxes_xywh_px is not None
                 and len(t.resample_index) == n == len(t.particles)  # type: ignore[arg-type]
                 and len(t.particle_boxes_xywh_px) == n]
    groups: list[tuple[list[int], np.ndarray, np.ndarray, np.ndarray | None]] = []
    if resampled:
        # the current particles' boxes: rows of the weighted particles' boxes they copy
        T = len(resampled)
        B = np.array([targets[i].particle_boxes_xywh_px for i in resampled])
        ri = np.array([targets[i].resample_index for i in resampled])
        ri += (np.arange(T) * n)[:, None]
        B = B.reshape(-1, 4).take(ri.ravel(), axis=0).reshape(T, n, 4)
        P = np.array([targets[i].particles for i in resampled]) if world else B
        groups.append((resampled, B, P, None))  # equal weights after resampling
    filters = getattr(engine, "_filters", {})
    done = set(resampled)
    for i, t in enumerate(targets):  # born this frame, or not resampled: one by one
        if i in done or t.particles is None or len(t.particles) == 0:
            continue
        p = np.asarray(t.particles, dtype=np.float64)
        f = filters.get(t.id)
        w = None if f is None else np.asarray(f.weights, dtype=np.float64)
        if w is not None and (len(w) != len(p) or np.all(w == w[0])):
            w = None
        groups.append(([i], np.array(engine.observation.to_boxes(p, t))[None], p[None],
                       None if w is None else w[None]))
    for idx, B, P, W in groups:
        X = B  # (T, N, 4) -> xyxy in place (B is this function's own array)
        X[..., 2:] += X[..., :2]
        if W is None:
            sd = X.std(axis=1)
        else:
            m = np.matmul(W[:, None, :], X)
            sd = np.sqrt(np.matmul(W[:, None, :], (X - m) ** 2))[:, 0]
        for k, i in enumerate(idx):
            out.xyxy_sd[targets[i].id] = sd[k]
        if world:
            g = _ground_points(engine.observation, P.reshape(-1, P.shape[2]))
            if g is not None:
                cov = _weighted_cov(g.reshape(P.shape[0], P.shape[1], 2), W)
                for k, i in enumerate(idx):
                    out.world_cov[targets[i].id] = cov[k]
    return out


class RecordSpread:
    """Fills each :class:`~pftrack.contracts.components.TrackRecord`'s ``xyxy_sd`` and
    ``world_cov`` from an engine's particle clouds, frame by frame: call :meth:`fill` with each
    :meth:`~pftrack.engine.tracker.MultiTargetTracker.step`'s records, right after the step.

    Image boxes of a fixed size centred on state axes 0 and 1 (``image-box``,
    ``image-box-sized``): each edge's sd is the centre's, half the record's ``extent`` (2 sd of
    the weighted particles); no particle pass. Otherwise (a camera) the spread of the cloud the
    filter carries into the next frame (after resampling): the sd of its particles' box
    coordinates and the covariance of their ground positions (through the observation model's
    ``ground_points`` or ``points``). A record output in a later frame than its own (a track's
    frames before its confirmation) gets the spread its target had in its own frame.

    Parameters
    ----------
    engine : MultiTargetTracker
    """

    def __init__(self, engine: MultiTargetTracker) -> None:
        from pftrack.builtin.image_box import ImageBoxObservation
        from pftrack.contracts.components import ObservationModel

        obs = type(engine.observation)
        self.world = obs.world_position is not ObservationModel.world_position
        self.cloud = self.world or obs.to_boxes is not ImageBoxObservation.to_boxes
        self._pending: dict[int, dict[int, tuple[np.ndarray, np.ndarray]]] = {}

    def fill(self, engine: MultiTargetTracker, records: list[TrackRecord], index: int) -> None:
        """Set ``xyxy_sd`` (and with a world frame ``world_cov``) of ``records``, the records
        ``engine.step`` returned for frame ``index``."""
        if not self.cloud:
            if records:
                half = 0.5 * np.array([r.extent[:2] for r in records], dtype=np.float64)
                for r, sd in zip(records, half[:, [0, 1, 0, 1]]):
                    r.xyxy_sd = sd
            return
        cloud = _cloud(engine, self.world)
        pending = self._pending
        for r in records:
            if r.frame == index:
                r.xyxy_sd = cloud.xyxy_sd.get(r.id, _NAN4)
                cov = cloud.world_cov.get(r.id)
            else:
                r.xyxy_sd, cov = pending.get(r.id, {}).get(r.frame, (_NAN4, None))
            if self.world:
                r.world_cov = _NAN22 if cov is None else cov
        # keep the spread of live targets not output in this frame; forget what was output
        out_last: dict[int, int] = {}
        for r in records:
            out_last[r.id] = max(out_last.get(r.id, 0), r.frame)
        for eid in list(pending):
            if eid not in cloud.xyxy_sd:
                del pending[eid]
        for eid, last in out_last.items():
            p = pending.get(eid)
            if p:
                for f in [f for f in p if f <= last]:
                    del p[f]
        for eid, sd in cloud.xyxy_sd.items():
            if out_last.get(eid) != index:
                pending.setdefault(eid, {})[index] = (sd, cloud.world_cov.get(eid, _NAN22))


