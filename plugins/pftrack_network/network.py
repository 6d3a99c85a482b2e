"""The camera-network paper's exchange types: a :class:`Tracklet` (one person seen by one camera)
and a :class:`CameraNetwork` (cameras joined by edges that carry a gamma-distributed transit time),
with the network's file format, its picture and Camera Dropout (sec. 3.2).

File format (``.json``, or ``.yaml``/``.yml``; the same keys in both)::

    format: pftrack-camera-network
    version: 1
    cameras:                       # every camera, by a unique name
      - {name: "c00", x_m: 12.5, y_m: 40.0}
    edges:                         # undirected; the same pair may appear several times
      - {u: "c00", v: "c03", k: 12.0, theta_s: 8.1}

``x_m``, ``y_m``: the camera's position on the floor plan, metres (drawing only). ``k``: the
gamma distribution's shape; ``theta_s``: its scale, seconds (mean transit ``k * theta_s`` s).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

FORMAT = "pftrack-camera-network"
VERSION = 1

__all__ = ["CameraNetwork", "Tracklet", "camera_dropout"]


@dataclass(eq=False)
class Tracklet:
    """One person's image sequence from one camera.

    Attributes
    ----------
    camera : str
        Name of the camera (a node of the :class:`CameraNetwork`).
    t_start_s, t_end_s : float
        Times of the first and last image, seconds on the network's common clock.
    images : list of ndarray (H, W, 3) uint8
        The person's images, BGR (OpenCV's order); sizes may differ.
    rows : ndarray (M, 10), optional
        The MOTChallenge rows the images were cut from (frame, id, left, top, width, height,
        conf, x, y, z; pixels), when the tracklet comes from a tracker's output.
    person : int, optional
        The true person, when known (experiments); never read by a linker.
    """

    camera: str
    t_start_s: float
    t_end_s: float
    images: list[np.ndarray] = field(default_factory=list)
    rows: np.ndarray | None = None
    person: int | None = None

    def __post_init__(self) -> None:
        self.camera = str(self.camera)
        self.t_start_s = float(self.t_start_s)
        self.t_end_s = float(self.t_end_s)
        if not np.isfinite(self.t_start_s) or not np.isfinite(self.t_end_s) \
                or self.t_end_s < self.t_start_s:
            raise ValueError(f"tracklet on camera {self.camera!r}: t_start_s={self.t_start_s} "
                             f"and t_end_s={self.t_end_s} must be finite with t_end_s >= "
                             "t_start_s")
        for i, im in enumerate(self.images):
            if not (isinstance(im, np.ndarray) and im.dtype == np.uint8 and im.ndim == 3
                    and im.shape[2] == 3 and im.shape[0] >= 2 and im.shape[1] >= 2):
                raise ValueError(f"tracklet on camera {self.camera!r}: image {i} must be an "
                                 f"(H, W, 3) uint8 BGR array with H, W >= 2, got "
                                 f"{getattr(im, 'shape', type(im))} "
                                 f"{getattr(im, 'dtype', '')}")


class CameraNetwork:
    """Cameras on a floor plan and the routes between them (a networkx ``MultiGraph``).

    Each edge joins two cameras a person can walk between without entering a third camera's
    view, with the transit time from leaving one view to entering the other distributed as
    gamma(shape ``k``, scale ``theta_s`` seconds). Parallel edges are allowed: Camera Dropout
    adds a second route between two cameras with its own parameters.

    Parameters
    ----------
    graph : networkx.MultiGraph, optional
        Nodes with attributes ``x_m``, ``y_m``; edges with ``k`` and ``theta_s``. Copied.
    """

    def __init__(self, graph: Any = None) -> None:
        import networkx as nx

        self.graph = nx.MultiGraph() if graph is None else nx.MultiGraph(graph)

    # -- building ---------------------------------------------------------------------------

    def add_camera(self, name: str, x_m: float = 0.0, y_m: float = 0.0) -> None:
        """Add a camera at ``(x_m, y_m)`` metres; a name already present is an error."""
        name = str(name)
        if name in self.graph:
            raise ValueError(f"camera {name!r} is already in the network")
        self.graph.add_node(name, x_m=float(x_m), y_m=float(y_m))

    def add_edge(self, u: str, v: str, k: float, theta_s: float) -> None:
        """Add a route between cameras ``u`` and ``v`` (kept beside any existing one)."""
        u, v = str(u), str(v)
        for c in (u, v):
            if c not in self.graph:
                raise ValueError(f"edge {u!r}-{v!r}: camera {c!r} is not in the network")
        if u == v:
            raise ValueError(f"edge {u!r}-{v!r}: a camera cannot be joined to itself")
        if not (np.isfinite(k) and np.isfinite(theta_s) and k > 0 and theta_s > 0):
            raise ValueError(f"edge {u!r}-{v!r}: k={k} and theta_s={theta_s} must be > 0")
        self.graph.add_edge(u, v, k=float(k), theta_s=float(theta_s))

    # -- reading ----------------------------------------------------------------------------

    @property
    def cameras(self) -> list[str]:
        """Camera names, in insertion order."""
        return list(self.graph.nodes)

    def position_m(self, camera: str) -> tuple[float, float]:
        d = self.graph.nodes[camera]
        return d["x_m"], d["y_m"]

    def neighbours(self, camera: str) -> list[str]:
        """Cameras joined to ``camera`` by at least one edge."""
        return list(self.graph.adj[camera])

    def edge_params(self, u: str, v: str) -> list[tuple[float, float]]:
        """``[(k, theta_s), ...]`` of every edge joining ``u`` and ``v`` (empty if none)."""
        data = self.graph.get_edge_data(u, v)
        return [] if data is None else [(e["k"], e["theta_s"]) for e in data.values()]

    def edge_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every edge as arrays ``(u_index, v_index, k, theta_s)``, indices into
        :attr:`cameras`."""
        index = {c: i for i, c in enumerate(self.graph.nodes)}
        rows = [(index[u], index[v], d["k"], d["theta_s"])
                for u, v, d in self.graph.edges(data=True)]
        if not rows:
            return (np.zeros(0, int), np.zeros(0, int), np.zeros(0), np.zeros(0))
        a = np.array(rows, dtype=float)
        return a[:, 0].astype(int), a[:, 1].astype(int), a[:, 2], a[:, 3]

    def joined_edges(self) -> np.ndarray:
        """(n_edges,) bool in :meth:`edge_arrays`' order: True for edges Camera Dropout added
        (:func:`camera_dropout` marks them ``joined=True``; a network read from a file has
        none)."""
        return np.array([bool(d.get("joined", False)) for _, _, d in self.graph.edges(data=True)],
                        dtype=bool)

    def number_of_edges(self) -> int:
        return self.graph.number_of_edges()

    def copy(self) -> CameraNetwork:
        return CameraNetwork(self.graph)

    def __repr__(self) -> str:
        return (f"CameraNetwork({self.graph.number_of_nodes()} cameras, "
                f"{self.graph.number_of_edges()} edges)")

    # -- file -------------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        return {
            "format": FORMAT, "version": VERSION,
            "cameras": [{"name": c, "x_m": d["x_m"], "y_m": d["y_m"]}
                        for c, d in self.graph.nodes(data=True)],
            "edges": [{"u": u, "v": v, "k": d["k"], "theta_s": d["theta_s"]}
                      for u, v, d in self.graph.edges(data=True)],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "camera network") -> CameraNetwork:
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise ValueError(f"{where}: not a {FORMAT} file (its 'format' key must be {FORMAT!r})")
        if data.get("version") != VERSION:
            raise ValueError(f"{where}: version {data.get('version')!r} not supported "
                             f"(expected {VERSION})")
        net = cls()
        try:
            for c in data.get("cameras") or []:
                net.add_camera(c["name"], c.get("x_m", 0.0), c.get("y_m", 0.0))
            for e in data.get("edges") or []:
                net.add_edge(e["u"], e["v"], e["k"], e["theta_s"])
        except KeyError as exc:
            raise ValueError(f"{where}: a camera or edge lacks the key {exc}") from None
        except (ValueError, TypeError) as exc:
            raise ValueError(f"{where}: {exc}") from None
        return net

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the network to ``path`` (``.json``, ``.yaml`` or ``.yml``), atomically."""
        from pftrack.io.atomic import atomic_write_text

        path = Path(path)
        suffix = path.suffix.lower()
        if suffix == ".json":
            text = json.dumps(self.to_dict(), indent=1)
        elif suffix in (".yaml", ".yml"):
            import yaml

            text = yaml.safe_dump(self.to_dict(), sort_keys=False)
        else:
            raise ValueError(f"{path}: camera network files end in .json, .yaml or .yml")
        return atomic_write_text(path, text)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> CameraNetwork:
        """Read a network written by :meth:`save` (or by hand in the same format)."""
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"camera network file not found: {path}")
        text = path.read_text()
        if path.suffix.lower() == ".json":
            try:
                data = json.loads(text)
            except json.JSONDecodeError as exc:
                raise ValueError(f"{path}: not valid JSON: {exc}") from None
        else:
            import yaml

            try:
                data = yaml.safe_load(text)
            except yaml.YAMLError as exc:
                raise ValueError(f"{path}: not valid YAML: {exc}") from None
        return cls.from_dict(data, where=str(path))

    # -- picture ----------------------------------------------------------------------------

    def draw(self, ax: Any = None, *, title: str | None = None,
             dropped: Iterable[str] = (), reference: CameraNetwork | None = None,
             edge_labels: bool | None = None) -> Any:
        """Draw the network on a matplotlib axes (a new figure when ``ax`` is None).

        Cameras sit at their floor-plan positions, edges are labelled with their mean transit
        ``k * theta_s`` in seconds, and parallel edges are drawn as separate arcs. ``dropped``
        cameras of ``reference`` (a sub-network's parent) are drawn as dashed circles.
        Edges of ``reference`` are blue, edges it lacks (added by dropout) orange.
        ``edge_labels``: write the mean transits (default: when there are at most 40 edges).

        Returns
        -------
        matplotlib.axes.Axes
        """
        import matplotlib.pyplot as plt
        from matplotlib.patches import FancyArrowPatch

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 6))
        ref = reference if reference is not None else self
        for c in dropped:
            x, y = ref.position_m(c)
            ax.scatter([x], [y], s=420, facecolors="none", edgecolors="0.5", linestyles="--",
                       zorder=3)
            ax.annotate(c, (x, y), ha="center", va="center", fontsize=7, color="0.5", zorder=4)
        if edge_labels is None:
            edge_labels = self.number_of_edges() <= 40
        seen: dict[tuple[str, str], int] = {}
        for u, v, d in self.graph.edges(data=True):
            key = (min(u, v), max(u, v))
            n = seen.get(key, 0)
            seen[key] = n + 1
            original = (d["k"], d["theta_s"]) in ref.edge_params(u, v)
            rad = 0.0 if n == 0 else 0.18 * (1 + (n - 1) // 2) * (1 if n % 2 else -1)
            (x0, y0), (x1, y1) = self.position_m(key[0]), self.position_m(key[1])
            ax.add_patch(FancyArrowPatch((x0, y0), (x1, y1), arrowstyle="-",
                                         connectionstyle=f"arc3,rad={rad}",
                                         color="tab:blue" if original else "tab:orange",
                                         lw=1.2, zorder=1, shrinkA=9, shrinkB=9))
            mx, my = (x0 + x1) / 2 - rad * (y1 - y0) / 2, (y0 + y1) / 2 + rad * (x1 - x0) / 2
            if edge_labels:
                ax.annotate(f"{d['k'] * d['theta_s']:.0f}s", (mx, my), fontsize=6, ha="center",
                            va="center", color="0.25", zorder=2)
        xy = np.array([self.position_m(c) for c in self.cameras]).reshape(-1, 2)
        ax.scatter(xy[:, 0], xy[:, 1], s=420, c="white", edgecolors="k", zorder=3)
        for c, (x, y) in zip(self.cameras, xy):
            ax.annotate(c, (x, y), ha="center", va="center", fontsize=7, zorder=4)
        allxy = np.array([ref.position_m(c) for c in ref.cameras]).reshape(-1, 2)
        if len(allxy):
            pad = 0.08 * max(np.ptp(allxy[:, 0]), np.ptp(allxy[:, 1]), 1.0)
            ax.set_xlim(allxy[:, 0].min() - pad, allxy[:, 0].max() + pad)
            ax.set_ylim(allxy[:, 1].min() - pad, allxy[:, 1].max() + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(title or f"{len(self.cameras)} cameras, {self.number_of_edges()} edges")
        return ax

    def save_picture(self, path: str | os.PathLike[str], **kwargs: Any) -> Path:
        """Draw the network (:meth:`draw` options) into a PNG file, atomically."""
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        from pftrack.io.atomic import atomic_write_with

        fig, ax = plt.subplots(figsize=(6, 6))
        try:
            self.draw(ax, **kwargs)
            fig.tight_layout()
            return atomic_write_with(path, lambda p: fig.savefig(p, dpi=110))
        finally:
            plt.close(fig)


def camera_dropout(network: CameraNetwork, n_dropped: int, rng: np.random.Generator, *,
                   transit_sum: str = "parameters", max_parallel: int | None = 4
                   ) -> tuple[CameraNetwork, list[str]]:
    """Camera Dropout (sec. 3.2): a sub-network with ``n_dropped`` random cameras removed.

    Repeated ``n_dropped`` times: pick a remaining camera c_j at random; for every pair of its
    neighbours (c_k, c_l), k != l, and every pair of edges (c_k, c_j), (c_j, c_l), add an edge
    (c_k, c_l) whose transit parameters combine theirs; existing edges between c_k and c_l
    are kept, so a pair may carry several. Then remove c_j and its edges. Added edges carry the
    attribute ``joined=True`` (:meth:`CameraNetwork.joined_edges`), so a sub-network's tracker
    can tell them from the real routes.

    Parameters
    ----------
    network : CameraNetwork
        Left unchanged.
    n_dropped : int
        C_d, in ``[0, number of cameras)``.
    rng : numpy.random.Generator
    transit_sum : {"parameters", "moments"}
        ``"parameters"`` (the paper's words): ``k = k_kj + k_jl``, ``theta = theta_kj +
        theta_jl``. ``"moments"``: the gamma with the mean and variance of the sum of the two
        transit times (``k theta`` and ``k theta^2`` add up), which is exact when the scales
        are equal; the paper's rule roughly doubles the mean of a two-hop route.
        :class:`~pftrack_network.linkers.TrajectoryEnsemble` uses ``"moments"`` by default
        (its docstring has the measurements).
    max_parallel : int or None
        At most this many edges per camera pair: a new combined edge beyond it is not added
        (the combined edges are added shortest mean transit first; edges already present are
        never removed). Without a cap the parallel edges multiply with every removal
        (thousands after 7 of 16 cameras; memory runs out at 11). None: no cap.

    Returns
    -------
    sub : CameraNetwork
    dropped : list of str
        The removed cameras, in the order they were removed.
    """
    cams = network.cameras
    if not 0 <= int(n_dropped) < len(cams):
        raise ValueError(f"n_dropped={n_dropped} must be in [0, {len(cams)}) for a network of "
                         f"{len(cams)} cameras")
    if transit_sum not in ("parameters", "moments"):
        raise ValueError(f"transit_sum must be 'parameters' or 'moments', got {transit_sum!r}")
    g = network.graph.copy()
    dropped: list[str] = []
    remaining = list(cams)
    for _ in range(int(n_dropped)):
        j = remaining.pop(int(rng.integers(len(remaining))))
        incident: dict[str, set[tuple[float, float]]] = {}
        for _, nb, d in g.edges(j, data=True):
            incident.setdefault(nb, set()).add((d["k"], d["theta_s"]))
        nbs = list(incident)
        for a in range(len(nbs)):
            for b in range(a + 1, len(nbs)):
                ck, cl = nbs[a], nbs[b]
                new = {_combine(p, q, transit_sum) for p in incident[ck] for q in incident[cl]}
                data = g.get_edge_data(ck, cl) or {}
                have = {(d["k"], d["theta_s"]) for d in data.values()}
                room = len(new) if max_parallel is None else max(int(max_parallel) - len(data), 0)
                for k, theta in sorted(new - have, key=lambda kt: kt[0] * kt[1])[:room]:
                    g.add_edge(ck, cl, k=k, theta_s=theta, joined=True)
        g.remove_node(j)
        dropped.append(j)
    sub = CameraNetwork()
    sub.graph = g  # already a private copy: no second one
    return sub, dropped


def _combine(p: tuple[float, float], q: tuple[float, float], how: str) -> tuple[float, float]:
    (k1, t1), (k2, t2) = p, q
    if how == "parameters":
        return (k1 + k2, t1 + t2)
    mean, var = k1 * t1 + k2 * t2, k1 * t1 * t1 + k2 * t2 * t2
    return (mean * mean / var, var / mean)


def tracklet_cameras(tracklets: Sequence[Tracklet]) -> list[str]:
    return [t.camera for t in tracklets]
