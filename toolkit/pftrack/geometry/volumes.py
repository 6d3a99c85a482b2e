"""World volumes: the regions of the world (metres) in which particles live and are drawn.

A :class:`Volume` answers three vectorised questions about points in the world frame
(``points_world_m``, shape (N, 3), metres): is each point inside (:meth:`Volume.contains`), give
me ``n`` points uniformly inside (:meth:`Volume.sample`), and what are your edges
(:meth:`Volume.edges`, line segments for drawing, shape (E, 2, 3)).

Two kinds are built in:

* :class:`CuboidVolume` -- an oriented box (Open3D's ``OrientedBoundingBox`` under the hood, see
  :meth:`CuboidVolume.to_open3d`); the coastal paper's two detection volumes are
  :func:`coast_volumes`.
* :class:`SoccerPitchVolume` -- a 105 x 68 m pitch (by default) with a height for the players, plus
  its markings as polylines on the ground (:meth:`SoccerPitchVolume.markings`).

World frame conventions
-----------------------
z is up and the ground is z = 0 everywhere.

* Soccer pitch (``frame="centre"``, default): origin at the centre spot, x along the length
  (touch lines run along x, the goal lines are x = -/+ length/2), y across the width
  (touch lines at y = -/+ width/2). ``frame="corner"`` puts the origin at the corner
  (x in [0, length], y in [0, width]) as some tracking providers do.
* The coastal paper coast: origin at the foot of the camera mast on the sea level, y horizontal away
  from the camera (the viewing direction), x to the right along the shore, z up. A volume "at D m"
  has its centre D metres from the camera along y.

Volumes YAML
------------
:func:`load_volumes` reads a simple file (``calib/*.yaml`` style)::

    volumes:
      - name: near                # unique name
        type: cuboid
        center_m: [0, 100, 3]     # box centre, world metres
        size_m: [43, 10, 6]       # full extent along the box's own x, y, z axes
        yaw_deg: 0                # optional rotation about z (or rotation: 3x3 matrix rows)
      - name: pitch
        type: pitch
        length_m: 105
        width_m: 68
        height_m: 2.5             # optional, the players' volume above the grass
        frame: centre             # optional, centre | corner

A top-level list (without the ``volumes:`` key) is accepted too.
"""

from __future__ import annotations

import os
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "CuboidVolume",
    "SoccerPitchVolume",
    "Volume",
    "builtin_volumes",
    "load_volumes",
    "resolve_volume",
    "sample_polyline",
    "save_volumes",
    "coast_volumes",
]

# Index pairs into the corner order of :meth:`CuboidVolume.corners` (bit k of the corner index
# set => + half-size along local axis k): the 12 edges of a box.
_BOX_EDGES = np.array(
    [[0, 1], [2, 3], [4, 5], [6, 7],  # along local x
     [0, 2], [1, 3], [4, 6], [5, 7],  # along local y
     [0, 4], [1, 5], [2, 6], [3, 7]],  # along local z
    dtype=np.intp,
)


def _as_points(points_world_m: Any, what: str = "points_world_m") -> np.ndarray:
    p = np.asarray(points_world_m, dtype=np.float64)
    if p.ndim == 1 and p.shape[0] == 3:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"{what} must have shape (N, 3), got {p.shape}")
    return p


class Volume(ABC):
    """A closed region of the world frame (metres), vectorised over points."""

    name: str

    @abstractmethod
    def contains(self, points_world_m: np.ndarray) -> np.ndarray:
        """Whether each point lies inside (boundary included).

        Parameters
        ----------
        points_world_m : ndarray, shape (N, 3)
            World coordinates in metres.

        Returns
        -------
        ndarray, shape (N,), bool
        """

    @abstractmethod
    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` points drawn uniformly inside the volume: (n, 3) float64, world metres."""

    @abstractmethod
    def edges(self) -> np.ndarray:
        """Line segments outlining the volume: (E, 2, 3) float64, world metres."""

    @abstractmethod
    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]``: (2, 3), metres."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """The YAML entry that :func:`load_volumes` reads back into an equal volume."""

    def ground_lines(self) -> dict[str, np.ndarray]:
        """Named polylines on the ground (z = 0) to draw in a top view: ``{name: (K, 3)}``.

        Default: the volume's footprint (its bottom face outline)."""
        e = self.edges()
        bottom = e[np.all(np.isclose(e[:, :, 2], self.bounds()[0, 2]), axis=1)]
        if len(bottom) == 0:
            return {}
        return {"footprint": _chain_segments(bottom)}


def _chain_segments(segments: np.ndarray) -> np.ndarray:
    """Join segments that form one closed loop into a polyline (K+1, 3) (small E only)."""
    segs = [s for s in segments]
    path = [segs[0][0], segs[0][1]]
    used = {0}
    while len(used) < len(segs):
        tail = path[-1]
        for i, s in enumerate(segs):
            if i in used:
                continue
            if np.allclose(s[0], tail):
                path.append(s[1])
            elif np.allclose(s[1], tail):
                path.append(s[0])
            else:
                continue
            used.add(i)
            break
        else:  # not a single loop: give the segments back as they are (first one only chained)
            break
    return np.array(path)


def _rotation_z(yaw_deg: float) -> np.ndarray:
    a = np.deg2rad(yaw_deg)
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(eq=False)
class CuboidVolume(Volume):
    """An oriented box in the world frame.

    Parameters
    ----------
    center_m : array-like, shape (3,)
        Box centre, world metres.
    size_m : array-like, shape (3,)
        Full extent along the box's own axes (length, depth, height), metres; all > 0.
    rotation : array-like, shape (3, 3), optional
        Box-to-world rotation: column k is the box's axis k in world coordinates. Default identity
        (axis-aligned). This is Open3D's ``OrientedBoundingBox.R``.
    name : str

    Notes
    -----
    Geometry (containment, corners, sampling) is computed with numpy so it is vectorised and
    exact; :meth:`to_open3d` / :meth:`from_open3d` convert to and from
    ``open3d.geometry.OrientedBoundingBox`` (same centre, R, extent), and the tests check that
    :meth:`contains` agrees with ``get_point_indices_within_bounding_box``.
    """

    center_m: np.ndarray
    size_m: np.ndarray
    rotation: np.ndarray | None = None
    name: str = "cuboid"

    def __post_init__(self) -> None:
        c = np.asarray(self.center_m, dtype=np.float64)
        s = np.asarray(self.size_m, dtype=np.float64)
        if c.shape != (3,) or not np.all(np.isfinite(c)):
            raise ValueError(f"volume {self.name!r}: center_m must be 3 finite numbers, got {c}")
        if s.shape != (3,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ValueError(f"volume {self.name!r}: size_m must be 3 positive numbers, got {s}")
        r = np.eye(3) if self.rotation is None else np.asarray(self.rotation, dtype=np.float64)
        if r.shape != (3, 3) or not np.allclose(r.T @ r, np.eye(3), atol=1e-6) \
                or np.linalg.det(r) < 0:
            raise ValueError(f"volume {self.name!r}: rotation must be a proper 3x3 rotation matrix")
        self.center_m, self.size_m, self.rotation = c, s, r

    # -- construction helpers -------------------------------------------------------------
    @classmethod
    def from_bounds(cls, lower_m: Any, upper_m: Any, name: str = "cuboid") -> CuboidVolume:
        """Axis-aligned box from its lower and upper corners (metres)."""
        lo, hi = np.asarray(lower_m, float), np.asarray(upper_m, float)
        return cls((lo + hi) / 2.0, hi - lo, None, name)

    @classmethod
    def from_yaw(cls, center_m: Any, size_m: Any, yaw_deg: float = 0.0,
                 name: str = "cuboid") -> CuboidVolume:
        """Box rotated by ``yaw_deg`` degrees about the world z axis (counter-clockwise seen
        from above)."""
        return cls(center_m, size_m, _rotation_z(yaw_deg), name)

    @classmethod
    def from_open3d(cls, obb: Any, name: str = "cuboid") -> CuboidVolume:
        """From an ``open3d.geometry.OrientedBoundingBox`` (or axis-aligned box)."""
        if hasattr(obb, "R"):
            return cls(np.asarray(obb.center), np.asarray(obb.extent), np.asarray(obb.R), name)
        return cls.from_bounds(np.asarray(obb.min_bound), np.asarray(obb.max_bound), name)

    def to_open3d(self) -> Any:
        """``open3d.geometry.OrientedBoundingBox`` with the same centre, rotation and extent."""
        import open3d as o3d

        return o3d.geometry.OrientedBoundingBox(self.center_m, self.rotation, self.size_m)  # type: ignore[arg-type]

    # -- Volume API -----------------------------------------------------------------------
    def to_local(self, points_world_m: np.ndarray) -> np.ndarray:
        """World metres (N, 3) -> box coordinates (N, 3): origin at the centre, box axes."""
        p = _as_points(points_world_m)
        return (p - self.center_m) @ self.rotation

    def to_world(self, points_local_m: np.ndarray) -> np.ndarray:
        """Box coordinates (N, 3) -> world metres (N, 3)."""
        return _as_points(points_local_m, "points_local_m") @ self.rotation.T + self.center_m  # type: ignore[union-attr]

    def contains(self, points_world_m: np.ndarray) -> np.ndarray:
        local = self.to_local(points_world_m)
        # a hair of tolerance so that corners and sampled boundary points count as inside
        tol = 1e-9 * max(1.0, float(np.max(np.abs(self.center_m))))
        return np.all(np.abs(local) <= self.size_m / 2.0 + tol, axis=1)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        if not isinstance(rng, np.random.Generator):
            raise TypeError("sample: rng must be a numpy.random.Generator")
        if n < 0:
            raise ValueError(f"sample: n must be >= 0, got {n}")
        local = rng.uniform(-0.5, 0.5, size=(int(n), 3)) * self.size_m
        return self.to_world(local) if n else np.zeros((0, 3))

    def corners(self) -> np.ndarray:
        """The 8 corners (8, 3), world metres; corner k has + half-size on local axis j when
        bit j of k is set."""
        bits = (np.arange(8)[:, None] >> np.arange(3)[None, :]) & 1
        return self.to_world((bits - 0.5) * self.size_m)

    def edges(self) -> np.ndarray:
        return self.corners()[_BOX_EDGES]

    def bounds(self) -> np.ndarray:
        c = self.corners()
        return np.stack([c.min(axis=0), c.max(axis=0)])

    @property
    def volume_m3(self) -> float:
        return float(np.prod(self.size_m))

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"name": self.name, "type": "cuboid",
                             "center_m": self.center_m.tolist(), "size_m": self.size_m.tolist()}
        if not np.allclose(self.rotation, np.eye(3)):  # type: ignore[arg-type]
            d["rotation"] = self.rotation.tolist()  # type: ignore[union-attr]
        return d


# ---------------------------------------------------------------------------------------------
# Soccer pitch
# ---------------------------------------------------------------------------------------------

#: FIFA Laws of the Game dimensions, metres.
GOAL_WIDTH_M = 7.32
GOAL_AREA_DEPTH_M = 5.5
PENALTY_AREA_DEPTH_M = 16.5
PENALTY_SPOT_DISTANCE_M = 11.0
CIRCLE_RADIUS_M = 9.15
CORNER_ARC_RADIUS_M = 1.0
SPOT_RADIUS_M = 0.11


def sample_polyline(vertices_m: np.ndarray, step_m: float) -> np.ndarray:
    """Resample a polyline so that consecutive points are at most ``step_m`` apart.

    The original vertices are kept (corners stay sharp); each segment gets
    ``ceil(length / step_m)`` sub-segments. Vectorised over segments.

    Parameters
    ----------
    vertices_m : ndarray, shape (K, D)
    step_m : float
        Largest spacing, same unit as the vertices; > 0.

    Returns
    -------
    ndarray, shape (K', D)
    """
    v = np.asarray(vertices_m, dtype=np.float64)
    if step_m <= 0:
        raise ValueError(f"sample_polyline: step_m must be > 0, got {step_m}")
    if len(v) < 2:
        return v.copy()
    d = np.diff(v, axis=0)
    n = np.maximum(1, np.ceil(np.linalg.norm(d, axis=1) / step_m).astype(np.intp))
    seg = np.repeat(np.arange(len(d)), n)
    start = np.concatenate([[0], np.cumsum(n)[:-1]])
    t = (np.arange(n.sum()) - np.repeat(start, n)) / np.repeat(n, n)
    pts = v[seg] + t[:, None] * d[seg]
    return np.vstack([pts, v[-1:]])


def _arc(cx: float, cy: float, r: float, a0: float, a1: float, step_m: float) -> np.ndarray:
    """Circular arc on z = 0 from angle a0 to a1 (radians, counter-clockwise), (K, 3)."""
    k = max(8, int(np.ceil(abs(a1 - a0) * r / step_m)))
    a = np.linspace(a0, a1, k + 1)
    return np.stack([cx + r * np.cos(a), cy + r * np.sin(a), np.zeros_like(a)], axis=1)


@dataclass(eq=False)
class SoccerPitchVolume(Volume):
    """A soccer pitch: the players' volume above it and its markings on the ground.

    Parameters
    ----------
    length_m, width_m : float
        Pitch size between the outer edges of the lines (FIFA: 100-110 x 64-75 m; 105 x 68 default).
    height_m : float
        Height of the volume above the grass in which player particles live (metres).
    margin_m : float
        Run-off included in the volume around the touch and goal lines (the markings do not move).
    frame : {"centre", "corner"}
        World origin: the centre spot (x in [-L/2, L/2], y in [-W/2, W/2]) or a corner
        (x in [0, L], y in [0, W]). x is along the length, y across, z up, in both.
    name : str

    Notes
    -----
    :meth:`markings` returns the standard FIFA lines as polylines on z = 0: touch and goal lines
    (``boundary``), ``halfway_line``, ``centre_circle``, ``centre_spot``, per end
    (``_left`` at -x, ``_right`` at +x) the ``penalty_area``, ``goal_area``, ``penalty_spot``,
    ``penalty_arc`` (the part of the 9.15 m circle about the penalty spot outside the penalty area)
    and the four ``corner_arc`` s. Spots are drawn as 0.11 m circles. Lines are sampled every
    ``step_m`` so that projecting them through a distorting lens shows the curvature.
    """

    length_m: float = 105.0
    width_m: float = 68.0
    height_m: float = 2.5
    margin_m: float = 0.0
    frame: str = "centre"
    name: str = "pitch"

    def __post_init__(self) -> None:
        for k in ("length_m", "width_m", "height_m"):
            v = float(getattr(self, k))
            if not np.isfinite(v) or v <= 0:
                raise ValueError(f"volume {self.name!r}: {k} must be > 0, got {v}")
            setattr(self, k, v)
        self.margin_m = float(self.margin_m)
        if self.margin_m < 0:
            raise ValueError(f"volume {self.name!r}: margin_m must be >= 0")
        if self.frame not in ("centre", "corner"):
            raise ValueError(f"volume {self.name!r}: frame must be 'centre' or 'corner', "
                             f"got {self.frame!r}")
        if self.length_m < 2 * PENALTY_AREA_DEPTH_M + 2 * CIRCLE_RADIUS_M \
                or self.width_m < GOAL_WIDTH_M + 2 * PENALTY_AREA_DEPTH_M:
            raise ValueError(f"volume {self.name!r}: {self.length_m} x {self.width_m} m is too "
                             "small for standard markings")

    @property
    def origin_offset_m(self) -> np.ndarray:
        """World position of the centre spot (3,)."""
        if self.frame == "corner":
            return np.array([self.length_m / 2.0, self.width_m / 2.0, 0.0])
        return np.zeros(3)

    def as_cuboid(self) -> CuboidVolume:
        """The players' volume as an axis-aligned :class:`CuboidVolume`."""
        m = self.margin_m
        half = np.array([self.length_m / 2 + m, self.width_m / 2 + m])
        c = self.origin_offset_m
        return CuboidVolume.from_bounds([c[0] - half[0], c[1] - half[1], 0.0],
                                        [c[0] + half[0], c[1] + half[1], self.height_m],
                                        name=self.name)

    def contains(self, points_world_m: np.ndarray) -> np.ndarray:
        return self.as_cuboid().contains(points_world_m)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return self.as_cuboid().sample(n, rng)

    def edges(self) -> np.ndarray:
        return self.as_cuboid().edges()

    def bounds(self) -> np.ndarray:
        return self.as_cuboid().bounds()

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "type": "pitch", "length_m": self.length_m,
                "width_m": self.width_m, "height_m": self.height_m, "margin_m": self.margin_m,
                "frame": self.frame}

    def ground_lines(self) -> dict[str, np.ndarray]:
        return self.markings()

    def penalty_spots(self) -> np.ndarray:
        """The centre spot and the two penalty spots (3, 3), world metres."""
        hl = self.length_m / 2
        d = hl - PENALTY_SPOT_DISTANCE_M
        return np.array([[0.0, 0, 0], [-d, 0, 0], [d, 0, 0]]) + self.origin_offset_m

    def markings(self, step_m: float = 0.5) -> dict[str, np.ndarray]:
        """The pitch markings as polylines on the ground.

        Parameters
        ----------
        step_m : float
            Largest spacing between consecutive polyline points (metres).

        Returns
        -------
        dict of str to ndarray, shape (K, 3)
            Named polylines in world metres, z = 0 (closed ones repeat their first point).
        """
        hl, hw = self.length_m / 2, self.width_m / 2
        gw = GOAL_WIDTH_M / 2
        out: dict[str, np.ndarray] = {}

        def poly(pts: list[list[float]]) -> np.ndarray:
            a = np.array([[x, y, 0.0] for x, y in pts])
            return sample_polyline(a, step_m)

        out["boundary"] = poly([[-hl, -hw], [hl, -hw], [hl, hw], [-hl, hw], [-hl, -hw]])
        out["halfway_line"] = poly([[0, -hw], [0, hw]])
        out["centre_circle"] = _arc(0, 0, CIRCLE_RADIUS_M, 0, 2 * np.pi, step_m)
        out["centre_spot"] = _arc(0, 0, SPOT_RADIUS_M, 0, 2 * np.pi, step_m)
        # penalty arc: circle of 9.15 m about the spot, outside the area (|x| < hl - 16.5)
        arc_half = np.arccos((PENALTY_AREA_DEPTH_M - PENALTY_SPOT_DISTANCE_M) / CIRCLE_RADIUS_M)
        for side, sgn in (("left", -1.0), ("right", 1.0)):
            gx = sgn * hl  # goal line
            pa = gx - sgn * PENALTY_AREA_DEPTH_M
            pw = gw + PENALTY_AREA_DEPTH_M
            ga = gx - sgn * GOAL_AREA_DEPTH_M
            aw = gw + GOAL_AREA_DEPTH_M
            out[f"penalty_area_{side}"] = poly([[gx, -pw], [pa, -pw], [pa, pw], [gx, pw]])
            out[f"goal_area_{side}"] = poly([[gx, -aw], [ga, -aw], [ga, aw], [gx, aw]])
            sx = gx - sgn * PENALTY_SPOT_DISTANCE_M
            out[f"penalty_spot_{side}"] = _arc(sx, 0, SPOT_RADIUS_M, 0, 2 * np.pi, step_m)
            # the arc faces the centre: angle 0 (toward +x) for the left end, pi for the right
            a_mid = 0.0 if sgn < 0 else np.pi
            out[f"penalty_arc_{side}"] = _arc(sx, 0, CIRCLE_RADIUS_M, a_mid - arc_half,
                                              a_mid + arc_half, step_m)
        for name, cx, cy, a0 in (("corner_arc_bl", -hl, -hw, 0.0),
                                 ("corner_arc_br", hl, -hw, np.pi / 2),
                                 ("corner_arc_tr", hl, hw, np.pi),
                                 ("corner_arc_tl", -hl, hw, 1.5 * np.pi)):
            out[name] = _arc(cx, cy, CORNER_ARC_RADIUS_M, a0, a0 + np.pi / 2, step_m)
        off = self.origin_offset_m
        return {k: v + off for k, v in out.items()}


# ---------------------------------------------------------------------------------------------
# Named volumes and the YAML loader
# ---------------------------------------------------------------------------------------------


def coast_volumes() -> dict[str, CuboidVolume]:
    """The coastal paper's two coastal detection volumes (sec. 5.1), in the coast frame.

    ``near``: 43 m across x 10 m deep x 6 m high, centred 100 m from the camera;
    ``far``: 170 m x 310 m deep x 9 m high, centred 300 m from the camera (it spans
    145-455 m, inside the paper's 100-500 m surveillance range). Both stand on the sea level
    (z from 0 up). Frame: origin at the camera mast foot, y away from the camera, z up.
    """
    return {
        "near": CuboidVolume([0.0, 100.0, 3.0], [43.0, 10.0, 6.0], None, "near"),  # type: ignore[arg-type]
        "far": CuboidVolume([0.0, 300.0, 4.5], [170.0, 310.0, 9.0], None, "far"),  # type: ignore[arg-type]
    }


def builtin_volumes() -> dict[str, Volume]:
    """The named volumes that need no file: ``pitch`` (105 x 68 m), ``near`` and ``far``
    (the coastal paper)."""
    out: dict[str, Volume] = {"pitch": SoccerPitchVolume()}
    out.update(coast_volumes())
    return out


def _volume_from_dict(d: dict[str, Any], where: str) -> Volume:
    if not isinstance(d, dict):
        raise ValueError(  # noqa: TRY004 - bad file content, reported as a user error
            f"{where}: each volume must be a mapping, got {type(d).__name__}")
    d = dict(d)
    name = str(d.pop("name", "") or "")
    if not name:
        raise ValueError(f"{where}: a volume has no 'name'")
    kind = d.pop("type", "cuboid")
    try:
        if kind == "cuboid":
            rot = d.pop("rotation", None)
            yaw = d.pop("yaw_deg", None)
            if rot is not None and yaw is not None:
                raise ValueError("give 'rotation' or 'yaw_deg', not both")
            if yaw is not None:
                rot = _rotation_z(float(yaw))
            center, size = d.pop("center_m"), d.pop("size_m")
            if d:
                raise ValueError(f"unknown keys {sorted(d)}")
            return CuboidVolume(center, size, rot, name)
        if kind == "pitch":
            allowed = {"length_m", "width_m", "height_m", "margin_m", "frame"}
            if set(d) - allowed:
                raise ValueError(f"unknown keys {sorted(set(d) - allowed)}")
            return SoccerPitchVolume(name=name, **d)
    except KeyError as exc:
        raise ValueError(f"{where}: volume {name!r} lacks {exc.args[0]!r}") from None
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{where}: volume {name!r}: {exc}") from None
    raise ValueError(f"{where}: volume {name!r} has unknown type {kind!r} (cuboid, pitch)")


def load_volumes(path: str | os.PathLike[str]) -> dict[str, Volume]:
    """Read a volumes YAML file (format in the module docstring) into ``{name: Volume}``."""
    import yaml

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"volumes file {path} not found")
    try:
        doc = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{path}: not valid YAML: {exc}") from None
    if isinstance(doc, dict):
        if "volumes" not in doc:
            raise ValueError(f"{path}: no 'volumes' list")
        doc = doc["volumes"]
    if not isinstance(doc, list) or not doc:
        raise ValueError(f"{path}: 'volumes' must be a non-empty list")
    out: dict[str, Volume] = {}
    for entry in doc:
        v = _volume_from_dict(entry, str(path))
        if v.name in out:
            raise ValueError(f"{path}: duplicate volume name {v.name!r}")
        out[v.name] = v
    return out


def save_volumes(path: str | os.PathLike[str], volumes: dict[str, Volume] | list[Volume]) -> Path:
    """Write volumes to a YAML file (atomically) that :func:`load_volumes` reads back."""
    import yaml

    from pftrack.io.atomic import atomic_write_text

    vols = list(volumes.values()) if isinstance(volumes, dict) else list(volumes)
    text = yaml.safe_dump({"volumes": [v.to_dict() for v in vols]}, sort_keys=False)
    return atomic_write_text(path, text)


def resolve_volume(spec: str | os.PathLike[str] | Volume,
                   search: list[str | os.PathLike[str]] | None = None) -> Volume:
    """A volume from a CLI-style spec.

    Parameters
    ----------
    spec : str, path or Volume
        ``"pitch"``, ``"near"``, ``"far"`` (built in), a name defined in one of the ``search``
        YAML files, or a YAML file path (``FILE`` -- its only/first volume -- or ``FILE:NAME``).
    search : list of paths, optional
        Volumes YAML files whose names are looked up; missing files are skipped. Default: the volume
        files the loaded plugins register (``pftrack_register_volumes``, their package data).
    """
    if isinstance(spec, Volume):
        return spec
    s = str(spec)
    file_part, _, name_part = s.partition(":") if not Path(s).exists() else (s, "", "")
    if file_part.endswith((".yaml", ".yml")) or Path(file_part).exists():
        vols = load_volumes(file_part)
        if name_part:
            if name_part not in vols:
                raise ValueError(f"{file_part}: no volume named {name_part!r}; "
                                 f"have {sorted(vols)}")
            return vols[name_part]
        return next(iter(vols.values()))
    builtins = builtin_volumes()
    if s in builtins:
        return builtins[s]
    files = search if search is not None else _plugin_volume_files()
    seen: list[str] = list(builtins)
    for f in files:
        if not Path(f).exists():
            continue
        try:
            vols = load_volumes(f)
        except ValueError:
            continue
        if s in vols:
            return vols[s]
        seen += list(vols)
    raise ValueError(f"unknown volume {s!r}: not a file and not one of {sorted(set(seen))}")


def _plugin_volume_files() -> list[Path]:
    """The volume files the loaded plugins ship (``pftrack_register_volumes``)."""
    from pftrack.host import get_host

    host = get_host()
    return [Path(host.get("volumes", n)) for n in host.names("volumes")]
