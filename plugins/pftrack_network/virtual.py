"""The camera-network paper's virtual camera-network data (sec. 4.1) with real person images.

A dataset: 16 cameras on a plane, a random connected network over them (a random spanning tree
of the Delaunay triangulation plus a random share of its other edges), gamma transit parameters
from the edge length (mean = length / walking speed, a fixed shape), and 24 people entering one
after another (gaps drawn uniformly in [20 s, 5 min]) who walk random routes (no immediate
turning back unless at a dead end) until they have passed at least 7 distinct cameras,
lingering in each view for a drawn time and taking a gamma-drawn transit time on each edge.

Person images are real: CAVIAR4REID (``reid/caviar4reid`` of the shared data; Cheng et al.,
BMVC 2011), whose 50 people seen by two real cameras have images 001-010 from one camera and
011-020 from the other. Each virtual camera is mapped to one of the two real cameras and each
virtual person to one CAVIAR person, so a tracklet of person p on camera c holds
images of p from c's real camera. No image is shared between two tracklets of one person: a
person's 10 images from a real camera (9 for CAVIAR person 29's first camera, whose images
002 and 003 are pixel-identical) are partitioned, in a seeded random order, among all of
that person's tracklets on virtual cameras showing it; with n such tracklets each gets
``min(images_per_tracklet, 10 // n)`` images (3, 2 or 1; the share is equal, so no tracklet's
eq. 7 maximum runs over more pairs than another's of the same person and camera). A person
whose walk would pass an 11th time through virtual cameras of one real camera (no image left)
leaves the network there: the walk is cut before that tracklet, so that person may see fewer
than ``min_cameras`` cameras (on the benchmark's seeds 0-4, 3 of 120 people; on the tuning
seeds 1000-1002, 3 of 72). Across the two real cameras images never repeat either (the
viewpoint and light differ, which is the appearance change the paper's method is about).

``image_reuse=True`` is the earlier protocol, kept to reproduce its figures and known
to be flawed: each tracklet draws its images from the person's 10 independently, so 68-73 % of
same-person pairs through the same real camera share an identical image (appearance 1), which
inflates every method that compares appearance. The walks, times and cameras of both protocols
are the same for a seed (the same draws), apart from the cut walks; only the images differ.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from pftrack_network.network import CameraNetwork, Tracklet

__all__ = ["VirtualDataset", "load_caviar4reid", "make_dataset", "random_network"]

WALK_SPEED_M_S = 1.2
TRANSIT_SHAPE = 10.0


@lru_cache(maxsize=4)
def _caviar(folder: str) -> dict[int, tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]]:
    import cv2

    root = Path(folder)
    if not root.is_dir():
        raise FileNotFoundError(f"CAVIAR4REID folder not found: {root} (set PFTRACK_DATA or "
                                "--data to the folder holding reid/caviar4reid)")
    by_person: dict[int, list[Path]] = {}
    for p in sorted(root.glob("*_*.jpg")):
        by_person.setdefault(int(p.stem.split("_")[0]), []).append(p)
    out = {}
    for pid, paths in sorted(by_person.items()):
        if len(paths) != 20:
            continue  # seen by one real camera only
        imgs = []
        for p in paths:
            im = cv2.imread(str(p), cv2.IMREAD_COLOR)
            if im is None:
                raise ValueError(f"{p}: not a readable image")
            imgs.append(im)
        out[pid] = (tuple(imgs[:10]), tuple(imgs[10:]))
    if not out:
        raise ValueError(f"{root}: no person with 20 images (PPPP_NNN.jpg) found")
    return out


def load_caviar4reid(folder: str | os.PathLike[str] | None = None
                     ) -> dict[int, tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]]:
    """CAVIAR4REID's two-camera people: ``{person: (camera A images, camera B images)}``, 10
    BGR uint8 images each (cached per folder).

    Parameters
    ----------
    folder : path, optional
        Default: ``reid/caviar4reid`` under :func:`pftrack.io.data.data_dir`.
    """
    if folder is None:
        from pftrack.io.data import data_dir

        folder = data_dir() / "reid" / "caviar4reid"
    return _caviar(str(Path(folder).resolve()))


def random_network(rng: np.random.Generator, n_cameras: int = 16, size_m: float = 360.0,
                   extra_edge_prob: float = 0.35, shape: float = TRANSIT_SHAPE,
                   speed_m_s: float = WALK_SPEED_M_S) -> CameraNetwork:
    """A random connected camera network on a ``size_m`` square.

    Cameras are placed uniformly (at least ``size_m / 10`` apart); the edges are a random
    spanning tree of their Delaunay triangulation plus each other Delaunay edge with
    probability ``extra_edge_prob``. An edge of length d metres gets ``k = shape`` and
    ``theta_s = d / speed_m_s / shape`` (mean transit d / speed).
    """
    import networkx as nx
    from scipy.spatial import Delaunay

    if n_cameras < 3:
        raise ValueError(f"n_cameras must be >= 3, got {n_cameras}")
    pts: list[np.ndarray] = []
    while len(pts) < n_cameras:
        p = rng.uniform(0, size_m, 2)
        if all(np.hypot(*(p - q)) >= size_m / 10 for q in pts):
            pts.append(p)
    xy = np.array(pts)
    tri = Delaunay(xy)
    g = nx.Graph()
    for simplex in tri.simplices:
        for a in range(3):
            i, j = sorted((int(simplex[a]), int(simplex[(a + 1) % 3])))
            g.add_edge(i, j, w=float(rng.random()))
    tree = nx.minimum_spanning_tree(g, weight="w")  # random weights: a random spanning tree
    keep = set(tree.edges())
    keep |= {(i, j) for i, j in g.edges() if (i, j) not in keep and (j, i) not in keep
             and rng.random() < extra_edge_prob}
    net = CameraNetwork()
    for i, (x, y) in enumerate(xy):
        net.add_camera(f"c{i:02d}", x, y)
    for i, j in sorted(tuple(sorted(e)) for e in keep):
        d = float(np.hypot(*(xy[i] - xy[j])))
        net.add_edge(f"c{i:02d}", f"c{j:02d}", shape, d / speed_m_s / shape)
    return net


@dataclass
class VirtualDataset:
    """One virtual experiment: the network, every tracklet in time order and the truth.

    Attributes
    ----------
    network : CameraNetwork
    tracklets : list of Tracklet
        Sorted by start time; ``person`` holds the virtual person (0..n_people-1).
    real_camera : dict str -> int
        The CAVIAR camera (0 or 1) each virtual camera shows.
    caviar_person : list of int
        The CAVIAR person of each virtual person.
    """

    network: CameraNetwork
    tracklets: list[Tracklet]
    real_camera: dict[str, int]
    caviar_person: list[int]

    @property
    def truth(self) -> np.ndarray:
        """True person per tracklet, (n,) int."""
        return np.array([t.person for t in self.tracklets], dtype=int)


def make_dataset(rng: np.random.Generator, *, n_cameras: int = 16, n_people: int = 24,
                 min_cameras: int = 7, gap_s: tuple[float, float] = (20.0, 300.0),
                 in_view_s: tuple[float, float] = (5.0, 15.0), images_per_tracklet: int = 3,
                 caviar_folder: str | os.PathLike[str] | None = None,
                 network: CameraNetwork | None = None,
                 image_reuse: bool = False) -> VirtualDataset:
    """A virtual dataset of sec. 4.1 (see the module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
        Everything random is drawn from it: the same seed, the same dataset.
    n_cameras, n_people, min_cameras : int
        16, 24 and 7 in the paper; ``min_cameras`` distinct cameras per person.
    gap_s : (float, float)
        Range of the time between two people entering, seconds.
    in_view_s : (float, float)
        Range of the time a person stays in one camera's view, seconds.
    images_per_tracklet : int
        Images per tracklet (<= 10) at most: fewer where a person has more than
        ``10 // images_per_tracklet`` tracklets through one real camera (module docstring).
    caviar_folder : path, optional
        CAVIAR4REID folder (default under the shared data).
    network : CameraNetwork, optional
        Use this network instead of drawing one (its edges' ``k * theta_s`` are the mean
        transits).
    image_reuse : bool
        The old, flawed protocol: every tracklet draws ``images_per_tracklet`` images of its
        person and real camera independently, so a person's tracklets share images (module
        docstring). Default False: a person's images are partitioned among their tracklets.
    """
    people = load_caviar4reid(caviar_folder)
    if n_people > len(people):
        raise ValueError(f"n_people={n_people}: CAVIAR4REID has {len(people)} two-camera people")
    if not 1 <= images_per_tracklet <= 10:
        raise ValueError(f"images_per_tracklet must be in [1, 10], got {images_per_tracklet}")
    net = network if network is not None else random_network(rng, n_cameras)
    cams = net.cameras
    if min_cameras > len(cams):
        raise ValueError(f"min_cameras={min_cameras} exceeds the {len(cams)} cameras")
    real = rng.integers(0, 2, len(cams))
    real[rng.permutation(len(cams))[:2]] = [0, 1]  # both real cameras appear
    real_camera = {c: int(r) for c, r in zip(cams, real)}
    ids = sorted(people)
    chosen = [ids[i] for i in rng.choice(len(ids), n_people, replace=False)]
    tracklets: list[Tracklet] = []
    picks: list[np.ndarray] = []  # the image_reuse protocol's draw, per tracklet
    t_enter = 0.0
    for p in range(n_people):
        if p:
            t_enter += float(rng.uniform(*gap_s))
        cam = cams[int(rng.integers(len(cams)))]
        prev = None
        seen: set[str] = set()
        t = t_enter
        for _ in range(20 * min_cameras):  # a walk long enough to see min_cameras cameras
            dwell = float(rng.uniform(*in_view_s))
            imgs = people[chosen[p]][real_camera[cam]]
            # drawn in both protocols, so that both walk the same for a seed
            picks.append(np.sort(rng.choice(len(imgs), images_per_tracklet, replace=False)))
            tracklets.append(Tracklet(cam, t, t + dwell, [imgs[i] for i in picks[-1]],
                                      person=p))
            seen.add(cam)
            t += dwell
            if len(seen) >= min_cameras:
                break
            nbs = net.neighbours(cam)
            options = [c for c in nbs if c != prev] or nbs
            nxt = options[int(rng.integers(len(options)))]
            params = net.edge_params(cam, nxt)
            k, theta = params[int(rng.integers(len(params)))]
            t += float(rng.gamma(k, theta))
            prev, cam = cam, nxt
        else:
            raise RuntimeError(f"person {p} did not reach {min_cameras} cameras")
    if not image_reuse:
        tracklets = _partition_images(tracklets, people, chosen, real_camera,
                                      images_per_tracklet, rng)
    tracklets.sort(key=lambda tr: tr.t_start_s)
    return VirtualDataset(net, tracklets, real_camera, chosen)


def _distinct_images(images: tuple[np.ndarray, ...]) -> list[np.ndarray]:
    """``images`` without pixel-identical repeats (first of each kept, in order): CAVIAR4REID
    holds one (person 29, images 002 and 003)."""
    seen: set[tuple[tuple[int, ...], bytes]] = set()
    out = []
    for im in images:
        key = (im.shape, hashlib.sha1(im.tobytes()).digest())
        if key not in seen:
            seen.add(key)
            out.append(im)
    return out


def _partition_images(tracklets: list[Tracklet],
                      people: dict[int, tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]],
                      chosen: list[int], real_camera: dict[str, int], images_per_tracklet: int,
                      rng: np.random.Generator) -> list[Tracklet]:
    """Give each tracklet its own images: per person and real camera, the person's images in
    one seeded random order, cut into equal consecutive shares, one per tracklet in walk order
    (``tracklets`` are in walk order, person by person); a walk is cut before a tracklet for
    which no image is left (module docstring)."""
    out: list[Tracklet] = []
    for p in range(len(chosen)):
        mine = [t for t in tracklets if t.person == p]
        real = np.array([real_camera[t.camera] for t in mine])
        distinct = [_distinct_images(people[chosen[p]][r]) for r in (0, 1)]
        n_images = [len(d) for d in distinct]
        # the walk's first tracklet beyond the images of its real camera ends it
        seen = np.array([np.count_nonzero(real[:i + 1] == r) for i, r in enumerate(real)])
        over = np.flatnonzero(seen > np.take(n_images, real))
        keep = len(mine) if over.size == 0 else int(over[0])
        mine, real = mine[:keep], real[:keep]
        for r in (0, 1):
            idx = np.flatnonzero(real == r)
            if idx.size == 0:
                continue
            share = min(images_per_tracklet, n_images[r] // idx.size)
            order = rng.permutation(n_images[r])
            imgs = distinct[r]
            for j, i in enumerate(idx):
                own = np.sort(order[j * share:(j + 1) * share])
                t = mine[i]
                out.append(Tracklet(t.camera, t.t_start_s, t.t_end_s, [imgs[k] for k in own],
                                    person=p))
    return out
