"""Particle clouds: weighted particle positions in the world frame, to and from Open3D and PLY.

A :class:`ParticleCloud` is ``points_world_m`` (N, 3) metres with ``weights`` (N,) (importance
weights; any non-negative numbers, normalised or not) and an optional per-particle ``labels``
(N,) integer (e.g. the target id a particle belongs to).

How the weights survive a round trip
------------------------------------
* Colours are for looking only: weights are mapped through a fixed colormap
  (:data:`WEIGHT_COLORMAP`, matplotlib's viridis, weights scaled by their maximum, 0 -> dark
  purple, max -> yellow). A colour cannot be turned back into a weight exactly.
* The exact weights travel as a custom float64 per-point attribute ``weights`` of an
  ``open3d.t.geometry.PointCloud`` (and ``labels`` as int32), which Open3D writes to and reads
  from binary PLY as ``property double weights`` -- bit for bit. :meth:`ParticleCloud.to_open3d`
  gives that tensor cloud; :meth:`ParticleCloud.to_legacy_open3d` the classic
  ``open3d.geometry.PointCloud`` for Open3D's visualisers, whose only free per-point slot,
  the normals, carries the weight in normal x (normals y, z are 0). Both readers recover weights
  exactly.
* PLY colours are written as uchar red/green/blue so other viewers (MeshLab, CloudCompare) show
  them.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "WEIGHT_COLORMAP",
    "ParticleCloud",
    "load_ply",
    "save_ply",
    "weights_to_colours",
]

#: The fixed colormap for weights (name in matplotlib's registry).
WEIGHT_COLORMAP = "viridis"

_LUT: np.ndarray | None = None


def _lut() -> np.ndarray:
    """(256, 3) uint8 viridis table, built once (matplotlib comes with pyvista)."""
    global _LUT
    if _LUT is None:
        from matplotlib import colormaps

        cmap = colormaps[WEIGHT_COLORMAP]
        _LUT = np.round(cmap(np.linspace(0.0, 1.0, 256))[:, :3] * 255).astype(np.uint8)
    return _LUT


def weights_to_colours(weights: np.ndarray, vmax: float | None = None) -> np.ndarray:
    """Weights -> RGB colours through :data:`WEIGHT_COLORMAP`.

    Parameters
    ----------
    weights : ndarray, shape (N,)
        Non-negative weights.
    vmax : float, optional
        The weight shown as the top colour (default: the largest weight; all-zero -> bottom).

    Returns
    -------
    ndarray, shape (N, 3), uint8
    """
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    top = float(np.max(w)) if vmax is None and len(w) else float(vmax or 0.0)
    t = np.clip(w / top, 0.0, 1.0) if top > 0 else np.zeros_like(w)
    return _lut()[np.round(t * 255).astype(np.intp)]


@dataclass(eq=False)
class ParticleCloud:
    """Weighted particles in the world frame.

    Parameters
    ----------
    points_world_m : ndarray, shape (N, 3), float64
        Particle positions, world metres.
    weights : ndarray, shape (N,), float64, optional
        Importance weights (>= 0, finite). Default: uniform 1/N.
    labels : ndarray, shape (N,), int, optional
        Per-particle label (target id, or -1 for none).
    """

    points_world_m: np.ndarray
    weights: np.ndarray | None = None
    labels: np.ndarray | None = None

    def __post_init__(self) -> None:
        p = np.asarray(self.points_world_m, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError(f"ParticleCloud: points_world_m must be (N, 3), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError("ParticleCloud: points_world_m has NaN or inf")
        n = len(p)
        if self.weights is None:
            w = np.full(n, 1.0 / n) if n else np.zeros(0)
        else:
            w = np.asarray(self.weights, dtype=np.float64).reshape(-1)
        if w.shape != (n,):
            raise ValueError(f"ParticleCloud: {n} points but {w.shape[0]} weights")
        if not np.all(np.isfinite(w)) or np.any(w < 0):
            raise ValueError("ParticleCloud: weights must be finite and >= 0")
        if self.labels is not None:
            lab = np.asarray(self.labels).reshape(-1)
            if lab.shape != (n,) or not np.issubdtype(lab.dtype, np.integer):
                raise ValueError(f"ParticleCloud: labels must be (N,) integers, got "
                                 f"{lab.shape} {lab.dtype}")
            self.labels = lab.astype(np.int64)
        self.points_world_m, self.weights = p, w

    def __len__(self) -> int:
        return len(self.points_world_m)

    @classmethod
    def concatenate(cls, clouds: list[ParticleCloud]) -> ParticleCloud:
        """One cloud from several (labels are kept where all have them, else dropped)."""
        if not clouds:
            return cls(np.zeros((0, 3)))
        labels = None
        if all(c.labels is not None for c in clouds):
            labels = np.concatenate([c.labels for c in clouds])
        return cls(np.vstack([c.points_world_m for c in clouds]),
                   np.concatenate([c.weights for c in clouds]), labels)

    def colours(self, vmax: float | None = None) -> np.ndarray:
        """(N, 3) uint8 colours of the weights (see :func:`weights_to_colours`)."""
        return weights_to_colours(self.weights, vmax)  # type: ignore[arg-type]

    # -- Open3D ---------------------------------------------------------------------------
    def to_open3d(self) -> Any:
        """``open3d.t.geometry.PointCloud`` with ``positions`` (float64), ``colors`` (uint8),
        ``weights`` (float64, (N, 1)) and, when set, ``labels`` (int32, (N, 1))."""
        import open3d as o3d

        pc = o3d.t.geometry.PointCloud(o3d.core.Tensor(self.points_world_m))  # type: ignore[call-overload]
        pc.point.colors = o3d.core.Tensor(self.colours())  # type: ignore[call-overload]
        pc.point.weights = o3d.core.Tensor(self.weights[:, None].copy())  # type: ignore[call-overload, index]
        if self.labels is not None:
            pc.point.labels = o3d.core.Tensor(self.labels.astype(np.int32)[:, None].copy())  # type: ignore[call-overload]
        return pc

    def to_legacy_open3d(self) -> Any:
        """Classic ``open3d.geometry.PointCloud``: colours from the weights and the exact
        weight in normal x (the legacy cloud has no custom attributes; labels are lost)."""
        import open3d as o3d

        pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(self.points_world_m))
        pc.colors = o3d.utility.Vector3dVector(self.colours().astype(np.float64) / 255.0)
        normals = np.zeros((len(self), 3))
        normals[:, 0] = self.weights
        pc.normals = o3d.utility.Vector3dVector(normals)
        return pc

    @classmethod
    def from_open3d(cls, pcd: Any) -> ParticleCloud:
        """From a tensor or legacy Open3D point cloud made by :meth:`to_open3d` /
        :meth:`to_legacy_open3d` (or any cloud: then weights are uniform)."""
        import open3d as o3d

        if isinstance(pcd, o3d.t.geometry.PointCloud):
            pts = pcd.point.positions.numpy().astype(np.float64)
            w = pcd.point.weights.numpy().reshape(-1) if "weights" in pcd.point else None
            lab = pcd.point.labels.numpy().reshape(-1) if "labels" in pcd.point else None
            return cls(pts, w, lab)
        if isinstance(pcd, o3d.geometry.PointCloud):
            pts = np.asarray(pcd.points, dtype=np.float64)
            w = np.asarray(pcd.normals)[:, 0].copy() if pcd.has_normals() else None
            return cls(pts, w)
        raise TypeError(f"from_open3d: expected an Open3D point cloud, got {type(pcd).__name__}")

    # -- files ----------------------------------------------------------------------------
    def save_ply(self, path: str | os.PathLike[str]) -> Path:
        """Write a binary PLY (atomically) with positions, colours, weights and labels."""
        return save_ply(path, self)

    @classmethod
    def load_ply(cls, path: str | os.PathLike[str]) -> ParticleCloud:
        return load_ply(path)


def save_ply(path: str | os.PathLike[str], cloud: ParticleCloud) -> Path:
    """Write ``cloud`` to ``path`` (.ply, binary little-endian), atomically."""
    import open3d as o3d

    from pftrack.io.atomic import atomic_write_with

    path = Path(path)
    if path.suffix.lower() != ".ply":
        raise ValueError(f"save_ply: {path} must end in .ply")
    if len(cloud) == 0:
        raise ValueError(f"save_ply: refusing to write an empty cloud to {path}")
    pc = cloud.to_open3d()

    def write(tmp: Path) -> None:
        if not o3d.t.io.write_point_cloud(str(tmp), pc, write_ascii=False):  # type: ignore[arg-type]
            raise OSError(f"Open3D could not write {path}")

    return atomic_write_with(path, write)


def load_ply(path: str | os.PathLike[str]) -> ParticleCloud:
    """Read a PLY written by :func:`save_ply` (or any PLY: then weights are uniform)."""
    import open3d as o3d

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"point cloud {path} not found")
    pc = o3d.t.io.read_point_cloud(str(path))  # type: ignore[arg-type]
    if pc.is_empty():
        # Open3D returns an empty cloud (not an error) for a file it cannot parse
        raise ValueError(f"{path}: no points read (not a valid PLY point cloud)")
    return ParticleCloud.from_open3d(pc)
