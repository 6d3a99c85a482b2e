"""Intruders in 3-D volumes (the coastal paper's sec. 3 and 4.2, and its future work: several at
once).

:class:`VolumeTracks` (track manager ``volumes``) runs the coastal paper's detection scheme inside
the one engine (:class:`pftrack.engine.tracker.MultiTargetTracker`):

* one **detection group** per volume: particles spread uniformly through the cuboid (velocity
  0); a particle outside its volume gets likelihood 0 (``Target.valid_region``); the group is
  filtered like any target (predict, weight, resample) so that it gathers on what changed;
* **entry** when at least ``entry.particles`` (N_m) of the group's particles have likelihood
  above ``v_pi`` in a frame: a **track** starts from the group's particles (those of the largest
  connected patch of the image they cover), and the group is spread uniformly again; also
  after ``entry.idle_frames`` frames without an entry;
* **several intruders**: the group's particles that project into a tracked intruder's image box
  (enlarged by ``mask.exclusion_margin``) get likelihood 0, so what a track explains is taken away
  from the group and the next intruder can be found; two tracks whose boxes overlap by more
  than ``merge.iou`` are one intruder and the younger ends;
* **exit** when no more than ``exit.particles`` (N_out) of a track's particles have likelihood
  above ``v_pi`` for ``exit.frames`` frames in a row (1: the paper): the track ends.

Identities beyond the paper (each off by default): a candidate entry too small for an intruder
keeps its group gathering on it for ``entry.gather_frames`` frames instead of being spread again at
once (an intruder half-seen by the uniform spread looks small); two tracks moving apart faster than
``merge.speed_m`` do not merge (people crossing); a new track starting within ``reid.distance_m``
of where an output track ended at most ``reid.frames`` frames before takes up its id; with
``reid.appearance`` each track keeps an HSV colour histogram of its cuboid's image region (updated
while no other track is within ``VolumeReid.near_m``), two tracks that were together and separate
swap their output ids when the swapped histograms match their templates better, and a re-identified
track takes up the ended id whose template it matches best; with ``mask.colour_share`` two tracks
whose gates overlap share the image by colour: a track's particle on a pixel whose colour the
neighbour's template explains ``VolumeMask.colour_share_ratio`` times better than its own gets
likelihood 0.

Estimates per frame (each output :class:`~pftrack.contracts.components.TrackRecord`):

* the paper's (eq. 8-10): centre = weighted mean of the particles, size l = 2 sqrt(weighted
  variance) -- kept in :attr:`VolumeTracks.estimates_` as ``centre_raw_m`` and ``size_raw_m``,
  the variance taken along the view's axes (width across the view, height, depth along it);
* the **support-plane correction** (``TrackRecord.world_m``, ``size_m``, ``box_xywh_px``): one
  view cannot place a point along its ray, so the particle cloud of an intruder stretches along
  the rays through it (the coastal paper's Table 1: a 2.3 m deep boat estimated 63 m deep).
  Intruders rest on a support plane (sea level, the ground: ``support_z_m``), so the lowest image
  row of the cloud is the front of the footprint on that plane: back-projected, it fixes the
  distance. The cloud's image box then gives the width across the view (its bottom corners on the
  plane) and the height (the top row on the vertical over the back of the footprint). The depth
  along the view cannot be seen from one view at a grazing angle (a 2.3 m deep boat at 300 m
  from 20 m up moves its top edge by a third of a pixel); it comes from a footprint prior: a
  rectangle whose long side (``footprint.aspect`` times the short one) points along the track's
  direction of travel on the plane (across the view when it has not moved
  ``footprint.min_travel_m``).

The image box of the cloud spans its 2 % to 98 % quantiles per image axis, widened to the ends
of a uniform spread with those quantiles.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from pftrack.contracts.components import (
    Detections,
    Frame,
    Group,
    Likelihood,
    Param,
    ParamGroup,
    RunContext,
    Target,
    TrackManager,
    TrackRecord,
)
from pftrack.geometry.boxes import iou_matrix
from pftrack.geometry.volumes import CuboidVolume

from pftrack_coast.likelihood import _blocks_of_pixels

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera
    from pftrack.geometry.volumes import Volume

__all__ = ["InsideBoxesLikelihood", "VolumeTracks", "bhattacharyya", "cloud_box", "cuboid_box",
           "cuboid_boxes", "cuboid_corners", "footprint_size", "hsv_histogram",
           "support_plane_estimate"]

HSV_BINS = (8, 4, 4)


def _kernel(name: str) -> Any:
    """A compiled kernel of :mod:`pftrack_coast._kernels`, or None with ``PFTRACK_NO_JIT``
    (the numpy path then runs: the same numbers)."""
    from pftrack.filter import _jit

    if not _jit.ENABLED:
        return None
    from pftrack_coast import _kernels

    return getattr(_kernels, name)


def hsv_histogram(image: np.ndarray, box_xywh_px: np.ndarray, inner: float = 0.4,
                  bins: tuple[int, int, int] = HSV_BINS) -> np.ndarray | None:
    """Normalised HSV colour histogram of the central part of an image box.

    Parameters
    ----------
    image : ndarray, shape (H, W, 3), uint8
        BGR picture.
    box_xywh_px : ndarray, shape (4,)
        (left, top, width, height), pixels.
    inner : float
        Fraction of the box's width kept about its centre (its height is kept from 5 % to
        95 %): the region is mostly the intruder, not the background beside it.
    bins : tuple of int
        Bins of hue (0-180), saturation and value.

    Returns
    -------
    ndarray, shape (prod(bins),) or None
        The histogram (sums to 1); None when the region holds fewer than 16 pixels of the image.
    """
    import cv2

    b = np.asarray(box_xywh_px, dtype=np.float64)
    if b.shape != (4,) or not np.isfinite(b).all():
        return None
    h_img, w_img = image.shape[:2]
    cx = b[0] + 0.5 * b[2]
    x0, x1 = int(max(cx - 0.5 * inner * b[2], 0)), int(min(cx + 0.5 * inner * b[2], w_img))
    y0, y1 = int(max(b[1] + 0.05 * b[3], 0)), int(min(b[1] + 0.95 * b[3], h_img))
    if (x1 - x0) * (y1 - y0) < 16:
        return None
    hsv = cv2.cvtColor(np.ascontiguousarray(image[y0:y1, x0:x1]), cv2.COLOR_BGR2HSV)
    nh, ns, nv = bins
    lut_h, lut_s, lut_v = _hsv_luts(nh, ns, nv)
    hsv = hsv.reshape(-1, 3)
    # (min(h nh // 180, nh - 1) ns + s ns // 256) nv + v nv // 256, from three tables
    idx = lut_h.take(hsv[:, 0])
    idx += lut_s.take(hsv[:, 1])
    idx += lut_v.take(hsv[:, 2])
    hist = np.bincount(idx, minlength=nh * ns * nv).astype(np.float64)
    return hist / hist.sum()


_HSV_LUTS: dict[tuple[int, int, int], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _hsv_luts(nh: int, ns: int, nv: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each 8-bit hue, saturation and value's share of its histogram bin index (integers, the
    smallest unsigned type that holds every index)."""
    key = (nh, ns, nv)
    if key not in _HSV_LUTS:
        n = nh * ns * nv
        dtype = np.uint8 if n <= 256 else np.uint16 if n <= 65536 else np.intp
        g = np.arange(256, dtype=np.intp)
        _HSV_LUTS[key] = (
            (np.minimum(g * nh // 180, nh - 1) * ns * nv).astype(dtype),
            (g * ns // 256 * nv).astype(dtype),
            (g * nv // 256).astype(dtype))
    return _HSV_LUTS[key]


def bhattacharyya(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Bhattacharyya distance sqrt(1 - sum sqrt(p q)) between histograms (last axis)."""
    bc = np.sqrt(np.asarray(p) * np.asarray(q)).sum(axis=-1)
    return np.sqrt(np.clip(1.0 - bc, 0.0, None))


def footprint_size(across_m: float, aspect: float, heading_deg: float | None) -> tuple[float,
                                                                                       float]:
    """Footprint extents (across the view, along it) of a rectangle whose long side is
    ``aspect`` times its short one and points ``heading_deg`` from the across-view direction,
    given its measured extent across the view.

    A rectangle L x W (L = aspect W) turned by phi spans ``L |cos phi| + W |sin phi|`` across
    the view and ``L |sin phi| + W |cos phi|`` along it. ``heading_deg`` None: phi = 0.
    """
    phi = 0.0 if heading_deg is None else math.radians(float(heading_deg))
    c, s = abs(math.cos(phi)), abs(math.sin(phi))
    a = float(aspect)
    w = float(across_m) / (a * c + s)
    return float(across_m), w * (a * s + c)


def _finite_rows(px: np.ndarray) -> np.ndarray:
    """``np.isfinite(px).all(axis=1)`` of pixels (N, 2), by columns (a reduction over a
    2-wide axis is numpy's slow path)."""
    return np.isfinite(px[:, 0]) & np.isfinite(px[:, 1])


def _axes(camera: Camera, ground_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors (3,) across and along the view on the horizontal plane at ``ground_xy``."""
    c = camera.center_m
    along = np.array([ground_xy[0] - c[0], ground_xy[1] - c[1], 0.0])
    n = float(np.hypot(along[0], along[1]))
    along = np.array([0.0, 1.0, 0.0]) if n == 0 else along / n
    across = np.array([along[1], -along[0], 0.0])
    return across, along


def support_plane_estimate(camera: Camera, pixels: np.ndarray, *, support_z_m: float = 0.0,
                           aspect: float = 1.0, heading_deg: float | None = None,
                           max_height_m: float = 50.0, quantile: float = 0.02,
                           ) -> dict[str, Any] | None:
    """An object's footprint centre, size and image box from the image positions of its
    particles, for an object resting on the plane ``z = support_z_m`` (see the module docstring).

    Parameters
    ----------
    camera : Camera
    pixels : ndarray, shape (N, 2)
        The particles' image positions (NaN rows ignored), equally weighted.
    support_z_m, aspect, heading_deg
        The support plane's height, the footprint's long/short ratio and its heading from the
        across-view direction (degrees, None: 0).
    max_height_m : float
        Heights are searched up to this.
    quantile : float
        The cloud's image box spans its ``quantile`` to ``1 - quantile`` quantiles per axis,
        widened to the ends of a uniform spread with those quantiles (outlying particles do not
        stretch it).

    Returns
    -------
    dict or None
        ``footprint_m`` (3,) the footprint's centre on the plane, ``centre_m`` (3,) the object's
        centre, ``size_m`` (3,) width across the view, height, depth along it, ``box_xywh_px``
        (4,) the cloud's image box, ``across``/``along`` (3,) the view's unit axes; None when
        the cloud's foot row does not meet the plane in front of the camera.
    """
    base = _support_base(camera, pixels, float(support_z_m), quantile)
    if base is None:
        return None
    return _support_finish(camera, base, aspect=aspect, heading_deg=heading_deg,
                           max_height_m=max_height_m)


def _support_base(camera: Camera, pixels: np.ndarray, z: float, quantile: float,
                  finite: bool = False) -> dict[str, Any] | None:
    """:func:`support_plane_estimate`'s part that does not depend on the footprint's shape:
    the cloud's image box, its foot row on the plane, the view's axes there and the width
    across the view (None: no footprint). ``finite``: the pixels are known to be finite."""
    px = np.asarray(pixels, dtype=np.float64)
    if not finite:
        px = px[np.isfinite(px).all(axis=1)]
    if len(px) < 2:
        return None
    (u0, v0), (u1, v1), mid = _cloud_ends(px, quantile)
    g = camera.image_to_ground(np.array([[mid[0], v1], [u0, v1], [u1, v1]]), z_m=z)
    if not np.isfinite(g).all():
        return None
    g[:, 2] = z  # on the plane exactly (the intersection leaves rounding)
    front = g[0]
    across, along = _axes(camera, front[:2])
    width = float(abs(np.dot(g[2] - g[1], across)))
    return {"z": z, "ends": (u0, v0, u1, v1), "front": front, "across": across,
            "along": along, "width": width}


_HEIGHTS = np.linspace(0.0, 50.0, 65)  # the heights searched by default (read only)
_HEIGHTS.flags.writeable = False


def _support_finish(camera: Camera, base: dict[str, Any], *, aspect: float = 1.0,
                    heading_deg: float | None = None, max_height_m: float = 50.0,
                    ) -> dict[str, Any]:
    """:func:`support_plane_estimate` from its :func:`_support_base`, for a footprint shape."""
    z, (u0, v0, u1, v1) = base["z"], base["ends"]
    front, across, along = base["front"], base["across"], base["along"]
    width, depth = footprint_size(base["width"], aspect, heading_deg)
    back = front + depth * along
    # the top row on the vertical over the back of the footprint (the top edge seen last)
    hz = _HEIGHTS if float(max_height_m) == 50.0 else np.linspace(0.0, float(max_height_m), 65)
    col = np.repeat(back[None], len(hz), axis=0)
    col[:, 2] = z + hz
    vv = camera.project(col)[:, 1]
    ok = np.isfinite(vv)
    height = 0.0
    if ok.sum() >= 2:
        vs, hs = vv[ok], hz[ok]
        order = np.argsort(vs)
        height = float(np.interp(v0, vs[order], hs[order]))
    foot = front + 0.5 * depth * along
    centre = foot.copy()
    centre[2] = z + 0.5 * height
    return {"footprint_m": foot, "centre_m": centre,
            "size_m": np.array([width, height, depth]),
            "box_xywh_px": np.array([u0, v0, u1 - u0, v1 - v0]),
            "across": across, "along": along}


def cuboid_box(camera: Camera, centre_m: np.ndarray, size_m: np.ndarray, across: np.ndarray,
               along: np.ndarray) -> np.ndarray:
    """Image bounding box (4,) of a cuboid with ``size_m`` (across, height, along) about
    ``centre_m``, its faces along the view's axes (NaN when a corner is behind the camera)."""
    return cuboid_boxes(camera, np.asarray(centre_m, float)[None],
                        np.asarray(size_m, float)[None], across, along)[0]


def cuboid_corners(centres_m: np.ndarray, sizes_m: np.ndarray, across: np.ndarray,
                   along: np.ndarray) -> np.ndarray:
    """The 8 corners (K, 8, 3) of K cuboids with sizes (K, 3) (across, height, along) about
    centres (K, 3), faces along the view's axes; corner k has + half-size along across / along
    / up where bit 0 / 1 / 2 of k is set (the order of
    :meth:`pftrack.geometry.volumes.CuboidVolume.corners`, so its edge list applies)."""
    bits = (np.arange(8)[:, None] >> np.arange(3)[None, :]) & 1
    s = bits - 0.5  # (8, 3): across, along, up
    c = np.asarray(centres_m, dtype=np.float64)
    z = np.asarray(sizes_m, dtype=np.float64)
    up = np.array([0.0, 0.0, 1.0])
    return (c[:, None, :] + (s[None, :, 0:1] * z[:, None, 0:1]) * across
            + (s[None, :, 2:3] * z[:, None, 1:2]) * up
            + (s[None, :, 1:2] * z[:, None, 2:3]) * along)


def cloud_box(pixels: np.ndarray, quantile: float = 0.02) -> np.ndarray:
    """The image box (4,) of a particle cloud's pixels (N, 2), finite rows: its ``quantile``
    to ``1 - quantile`` quantiles per axis, widened to the ends of a uniform spread with those
    quantiles (outlying particles do not stretch it)."""
    lo, hi, _ = _cloud_ends(pixels, quantile)
    return np.concatenate([lo, hi - lo])


def _cloud_ends(pixels: np.ndarray, quantile: float,
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`cloud_box`'s (left, top), (right, bottom) and middle."""
    q = float(quantile)
    lo, hi = _quantiles(pixels, q, 1.0 - q)
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo) / (1.0 - 2.0 * q)  # a uniform spread's ends
    return mid - half, mid + half, mid


def _quantiles(x: np.ndarray, q0: float, q1: float) -> tuple[np.ndarray, np.ndarray]:
    """``np.quantile(x, [q0, q1], axis=0)`` of finite ``x`` (N, K), N >= 1, as two (K,)
    arrays: the same numbers (numpy's "linear" method: the order statistics at the floor of
    ``(N - 1) q`` and the next, and its interpolation), from one partition and no more."""
    n = len(x)
    idx = []
    for q in (q0, q1):
        v = (n - 1) * q
        prev = int(math.floor(v))
        if v >= n - 1:
            prev = nxt = n - 1
        elif v < 0:
            prev = nxt = 0
        else:
            nxt = prev + 1
        idx.append((v, prev, nxt))
    part = np.partition(x, sorted({i for _, a, b in idx for i in (a, b)}), axis=0)
    out = []
    for v, prev, nxt in idx:
        a, b = part[prev], part[nxt]
        t = v - prev
        d = b - a
        out.append(b - d * (1 - t) if t >= 0.5 else a + d * t)  # numpy's _lerp
    return out[0], out[1]


def cuboid_boxes(camera: Camera, centres_m: np.ndarray, sizes_m: np.ndarray, across: np.ndarray,
                 along: np.ndarray) -> np.ndarray:
    """:func:`cuboid_box` of K cuboids (K, 3) at once: (K, 4), one projection."""
    c = np.asarray(centres_m, dtype=np.float64)
    corners = cuboid_corners(c, sizes_m, across, along).reshape(-1, 3)
    p = camera.project(corners).reshape(len(c), 8, 2)
    behind = ~camera.in_front(corners).reshape(len(c), 8).all(axis=1)
    lo, hi = p.min(axis=1), p.max(axis=1)
    out = np.concatenate([lo, hi - lo], axis=1)
    out[behind] = np.nan
    return out


class _Region:
    """A target's ``valid_region`` (a picklable callable): see
    :meth:`VolumeTracks._in_region`."""

    def __init__(self, manager: VolumeTracks, volume: Any, tid: int, mode: str) -> None:
        self.manager, self.volume, self.tid, self.mode = manager, volume, tid, mode

    def __call__(self, points: np.ndarray) -> np.ndarray:
        return self.manager._in_region(self.tid, self.volume, self.mode, points)


def _clip_into(volume: Any, points: np.ndarray) -> np.ndarray:
    """Points (N, 3) moved into a cuboid along its own axes (the nearest inside point)."""
    local = volume.to_local(points)
    half = 0.5 * np.asarray(volume.size_m, dtype=np.float64)
    return volume.to_world(np.clip(local, -half, half))


class InsideBoxesLikelihood(Likelihood):
    """A particle's likelihood is ``inside`` when its pixel lies in one of the frame's
    detection boxes, ``outside`` elsewhere (0 without detections): a perfect foreground mask
    made of boxes, for tests and the conformance kit's run of :class:`VolumeTracks` (boxes
    of size 0, ``particle_box="point"``, are read as the particles' pixels).

    {params}
    """

    inside: float = Param(0.95, "Likelihood inside a box.")
    outside: float = Param(1e-3, "Likelihood outside every box.")

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        self.boxes_ = detections.boxes_xywh_px if detections is not None else np.zeros((0, 4))

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        px = b[:, :2] + 0.5 * b[:, 2:]
        d = self.boxes_
        with np.errstate(invalid="ignore"):
            hit = ((px[:, None, :] >= d[None, :, :2])
                   & (px[:, None, :] <= d[None, :, :2] + d[None, :, 2:])).all(axis=2).any(axis=1)
        return np.where(hit, math.log(float(self.inside)), math.log(float(self.outside)))


class VolumeEntry(ParamGroup):
    """How a detection group finds an entry (the coastal paper's N_m), group ``entry`` of
    :class:`VolumeTracks`: a track starts when at least ``particles`` of a detection group's
    particles have likelihood above ``v_pi``, from those of the largest connected patch of the
    image they cover.

    {params}
    """

    particles: int = Param(50, "N_m: an entry when at least this many particles of a "
                               "detection group have likelihood above v_pi.", unit="count",
                           low=1)
    idle_frames: int = Param(10, "A detection group without an entry for this many frames is "
                                 "spread uniformly through its volume again.", unit="frames",
                             low=1)
    gather_frames: int = Param(
        0, "With object_size_m: a detection group whose entry candidate is too small "
        "(min_size_fraction of the typical width or height) keeps gathering on it, without "
        "being spread again, for up to this many frames (its few hits are resampled and spread "
        "over the intruder, which then looks its size); 0: it is spread again at once.",
        unit="frames", low=0)

    #: With object_size_m: an entry whose particles span less than this fraction of the
    #: typical width or height (on the support plane) is a fringe or noise: no new track.
    min_size_fraction: ClassVar[float] = 0.5
    #: An entry whose particles' image box lies more than this fraction inside a tracked
    #: intruder's box is that intruder's fringe: no new track.
    spawn_overlap: ClassVar[float] = 0.5
    #: Cell size (pixels) of the image grid on which a new track takes the largest connected
    #: patch of its group's particles (the likelihood's blocks).
    blob_block_px: ClassVar[int] = 8


class VolumeExit(ParamGroup):
    """When a track ends (the coastal paper's N_out), group ``exit`` of :class:`VolumeTracks`.

    {params}
    """

    particles: int = Param(10, "N_out: a track ends when no more than this many of its "
                               "particles have likelihood above v_pi.", unit="count", low=0)
    frames: int = Param(1, "Frames in a row at or below N_out before a track ends (1: the "
                           "paper).", unit="frames", low=1)
    established: bool = Param(
        False, "A track is held to N_out only once it has had more than N_out particles above "
        "v_pi (its particles have gathered on its intruder); before that it ends when fewer "
        "than N_m (entry.particles) are (the evidence that started it is gone). False: N_out "
        "from the first frame (the paper), which ends a new track on an intruder smaller than "
        "its first frame's spread one frame after its entry.")

    def low(self, n_above: int, gathered: bool, entry_particles: int) -> bool:
        """Whether a track with ``n_above`` particles above v_pi is low this frame (an exit
        after ``frames`` low frames in a row). ``gathered``: it has had more than N_out
        particles above v_pi before; ``entry_particles``: N_m."""
        if self.established and not gathered:
            return n_above < int(entry_particles)  # not gathered yet: N_m holds it
        return n_above <= int(self.particles)


class VolumeMask(ParamGroup):
    """Where particles may live, group ``mask`` of :class:`VolumeTracks`: every particle in its
    volume; a detection group's particles off the tracked intruders' image boxes; a track's
    particles in its gate, and off the pixels whose colour a neighbour's template claims.

    {params}
    """

    exclusion_margin: float = Param(0.2, "A tracked intruder's image box, enlarged by this "
                                         "fraction of its size per side, is taken away from "
                                         "the detection groups.", unit="1", low=0.0)
    gate_margin: float | None = Param(
        0.5, "With object_size_m: a track's particles live only where they project into the "
        "image boxes of a cuboid of that size on its last footprint and where its recent "
        "motion takes it next, enlarged by this fraction of the size per side (one "
        "intruder's particles do not spread onto a neighbour). None: no gate.", unit="1",
        low=0.0)
    colour_share: bool = Param(
        False, "With reid.appearance: among tracks whose gates overlap, a track's particle "
        "whose pixel's colour (its bin of the HSV histograms) is more than colour_share_ratio "
        "times as likely under a neighbouring track's template as under its own gets "
        "likelihood 0: a neighbour's blob cannot take a track's particles where the colours "
        "say whose they are. Colour (8-bit BGR) frames only; a grey frame bars nothing.")

    #: colour_share bars a particle whose pixel's colour a neighbour's template explains more
    #: than this many times better than the track's own.
    colour_share_ratio: ClassVar[float] = 1.25
    #: Added to both templates' bin probabilities before colour_share's ratio: a colour
    #: neither template holds decides nothing.
    colour_share_floor: ClassVar[float] = 0.01
    #: colour_share acts only between tracks whose templates lie at least this Bhattacharyya
    #: distance apart (alike templates decide nothing).
    colour_share_distance: ClassVar[float] = 0.35
    #: When colour_share would bar more than this fraction of a track's particles (its
    #: intruder hidden behind a neighbour), it bars none.
    colour_share_max_barred: ClassVar[float] = 0.7


class VolumeMerge(ParamGroup):
    """When two tracks are one intruder (the younger ends), group ``merge`` of
    :class:`VolumeTracks`.

    {params}
    """

    iou: float = Param(0.5, "Two tracks whose image boxes overlap by more than this for "
                            "frames frames in a row are one intruder: the younger ends.",
                       unit="1", low=0.0, high=1.0)
    distance_m: float | None = Param(
        None, "Two tracks whose footprints are closer than this (metres) are one intruder too "
        "(with the same frames), and an entry that close to a track's footprint is that "
        "track's; None: only the image overlap.", unit="m", low=0.0, low_open=True)
    frames: int = Param(5, "Frames in a row of overlap before two tracks merge (two "
                           "intruders crossing overlap for a while and stay two).",
                        unit="frames", low=1)
    speed_m: float | None = Param(
        None, "Two tracks whose footprint velocities (over speed_frames) differ by more than "
        "this (metres per frame) do not merge however close: two intruders crossing, not one "
        "tracked twice (which moves as one). None: no velocity test.", unit="m/frame",
        low=0.0, low_open=True)

    #: Frames over which speed_m's footprint velocities are measured.
    speed_frames: ClassVar[int] = 4

    def same(self, boxes_xywh_px: np.ndarray, ground_xy: np.ndarray | None,
             velocities: np.ndarray | None) -> np.ndarray:
        """Which pairs of K tracks look like one intruder this frame (K, K) bool: image boxes
        (K, 4) overlapping by more than ``iou``, or footprints ``ground_xy`` (K, 2), metres,
        closer than ``distance_m``; but not footprint ``velocities`` (K, 2), metres per frame,
        differing by more than ``speed_m`` (NaN: not known yet, may merge). ``ground_xy`` and
        ``velocities`` are read only when ``distance_m`` and ``speed_m`` are set."""
        same = iou_matrix(boxes_xywh_px, boxes_xywh_px) > float(self.iou)
        if self.distance_m is not None and ground_xy is not None:
            xy = ground_xy
            d = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
            same |= d < float(self.distance_m)
        if self.speed_m is not None and velocities is not None:
            v = velocities  # crossing intruders move apart: not one
            dv = np.hypot(v[:, None, 0] - v[None, :, 0], v[:, None, 1] - v[None, :, 1])
            same &= ~(dv > float(self.speed_m))
        return same


class VolumeReid(ParamGroup):
    """Identities kept across losses and crossings, group ``reid`` of :class:`VolumeTracks`.

    {params}
    """

    frames: int = Param(
        0, "A new track whose first output footprint lies within distance_m of where an output "
        "track ended (exit or merge) at most this many frames before takes up that track's id "
        "(a person lost in an occlusion and found again); 0: every track a new id (the "
        "paper).", unit="frames", low=0)
    distance_m: float = Param(1.5, "Distance on the support plane for frames.", unit="m",
                              low=0.0, low_open=True)
    appearance: bool = Param(
        False, "Per-track appearance: an HSV histogram of each track's cuboid image region "
        "(updated while alone); two tracks that were within near_m and separate swap output "
        "ids when the swapped histograms match the templates better by margin, a merge ends "
        "the older track when its template matches its region worse, and re-identification "
        "takes the best-matching ended id within distance_m (False: positions only).")

    #: Template update rate per frame while a track is alone.
    rate: ClassVar[float] = 0.1
    #: Tracks whose footprints are closer than this (metres) are together; a track is alone
    #: (its template updated) with no other within twice this.
    near_m: ClassVar[float] = 1.0
    #: Two tracks together are apart (a swap is tested) once their footprints are farther
    #: than this times near_m and their image boxes are disjoint.
    apart: ClassVar[float] = 1.5
    #: Fraction of a track's image region's width (about its centre) whose colours its
    #: histogram counts.
    inner: ClassVar[float] = 0.4
    #: Bhattacharyya distance (summed over a pair) by which a swapped match must beat the kept
    #: one.
    margin: ClassVar[float] = 0.05
    #: Frames alone before a track's template is used.
    min_frames: ClassVar[int] = 5


class VolumeFootprint(ParamGroup):
    """The footprint prior of the support-plane correction and what is output of it, part
    ``footprint`` of :class:`VolumeTracks`.

    {params}
    """

    aspect: float = Param(1.0, "Length / width of an intruder's footprint (1: a person; about "
                               "3 for boats and cars).", unit="1", low=0.0, low_open=True)
    min_travel_m: float = Param(2.0, "A track's heading is the direction of its footprint's "
                                     "travel over the last heading_frames once it exceeds "
                                     "this distance (before: across the view).", unit="m",
                                low=0.0)
    heading_frames: int = Param(15, "Frames over which the heading is measured.",
                                unit="frames", low=1)
    heading_from: str = Param(
        "footprint", "What min_travel_m's travel is measured on: 'footprint' (the footprint's "
        "centre) or 'top': the footprint's, but the travel of the particle cloud's top centre "
        "pixel put on the support plane while the footprint is held (held) or has not yet "
        "travelled min_travel_m (a point at a constant height h moves there in the same "
        "direction as the object, scaled by H / (H - h); the top is not held at the volume's "
        "near face as the foot row is while an intruder is seen through the volume from in "
        "front of it).", choices=("footprint", "top"))
    held: bool = Param(
        False, "A track is not output while its foot row may be held by the volume: while the "
        "image row of blob_block_px cells (the likelihood's blocks) below the one holding the "
        "cloud's foot sees the support plane outside the volume, the particles, which live in "
        "the volume, could not follow an intruder's foot that is nearer than the volume's near "
        "face, so the footprint may be that face's, not the intruder's.")

    #: Before the footprint has travelled min_travel_m, the heading is the particles' mean
    #: horizontal velocity once faster than this (metres per time step; state entries 3, 4).
    min_speed: ClassVar[float] = 0.3


class VolumeTracks(TrackManager):
    """The coastal paper's entry / exit detection in cuboid volumes, for several intruders at once.

    Its parameters are grouped by what they decide: ``entry`` (:class:`VolumeEntry`), ``exit``
    (:class:`VolumeExit`), ``mask`` (:class:`VolumeMask`), ``merge`` (:class:`VolumeMerge`),
    ``reid`` (:class:`VolumeReid`) and ``footprint`` (:class:`VolumeFootprint`), each a
    parameter group given as a mapping (keys left out take their defaults), e.g. ``merge:
    {iou: 0.5, frames: 3}``.

    {params}

    Attributes
    ----------
    groups_ : dict[int, str]
        Live detection groups: target id -> volume name.
    tracks_ : dict[int, str]
        Live tracks: target id -> volume name.
    estimates_ : list of dict
        One per output record: ``frame``, ``id``, ``volume``, ``centre_raw_m`` and
        ``size_raw_m`` (eq. 8-10; size across, height, along the view), ``footprint_m``,
        ``size_m`` (the support-plane correction), ``n_above`` (particles above ``v_pi``).
    events_ : list of dict
        ``{"frame", "id", "volume", "event": "entry"|"exit"|"merged"|"reidentified"|"swapped"}``
        (engine target ids; "reidentified" adds ``"as"``, the output id the track takes up;
        "swapped" adds ``"with"``, the track it swapped output ids with).
    """

    volumes: Sequence[str | dict | Volume] | str | dict | Volume = Param(
        ("near", "far"), "Detection volumes: names (built in, or defined in the shipped "
        "``calib/*.yaml``), 'FILE' (every volume of a volumes YAML) / 'FILE:NAME', or volume "
        "mappings as in a volumes file.")
    v_pi: float = Param(0.5, "Likelihood threshold in (0, 1) of the entry and exit counts.",
                        unit="1", low=0.0, low_open=True, high=1.0, high_open=True)
    object_size_m: Sequence[float] | None = Param(
        None, "A typical intruder's size (width across the view, height, depth along it), "
        "metres: a new track's particles are jittered by half of it (so that a track started "
        "on part of an intruder soon covers all of it), each track takes away from the "
        "detection groups at least the image box of a cuboid this size on its footprint, and "
        "mask.gate_margin gates a track's particles about that box. None: none of these.",
        unit="m", low=0.0, low_open=True, length=3)
    support_z_m: float = Param(0.0, "Height of the plane intruders rest on (sea level, the "
                                    "ground), metres.", unit="m")
    confirm_frames: int = Param(3, "A new track is output once it has lived this many frames "
                                   "(its records from the entry on, so confirmation costs no "
                                   "frames); one that ends sooner was noise and is never "
                                   "output (1: every entry is output at once, the paper).",
                                unit="frames", low=1)
    entry: VolumeEntry = Group(VolumeEntry, "When a detection group starts a track (N_m).")
    exit: VolumeExit = Group(VolumeExit, "When a track ends (N_out).")
    mask: VolumeMask = Group(VolumeMask, "Where particles may live.")
    merge: VolumeMerge = Group(VolumeMerge, "When two tracks are one intruder.")
    reid: VolumeReid = Group(VolumeReid, "Identities across losses and crossings.")
    footprint: VolumeFootprint = Group(VolumeFootprint, "The footprint prior of the "
                                       "support-plane correction, and what is output of it.")

    #: A track is output only while its footprint (the support-plane correction) lies inside
    #: its volume's ground footprint: one view sees an intruder through the volume before it
    #: enters and after it leaves; its footprint says where it is.
    footprint_inside: ClassVar[bool] = True

    @classmethod
    def _conformance_example(cls) -> Any:
        """For :mod:`pftrack.testing`: a camera 20 m up over a 60 x 60 x 2 m volume, the kit's
        synthetic scene's boxes as a perfect foreground (:class:`InsideBoxesLikelihood`)."""
        from pftrack.builtin.world_observation import CameraVolumeObservation
        from pftrack.geometry.camera import Camera
        from pftrack.geometry.volumes import CuboidVolume
        from pftrack.testing import ConformanceExample
        from pftrack_basic.motion import ConstantVelocity3DMotion

        cam = Camera.look_at((0.0, -40.0, 20.0), (0.0, 0.0, 0.0), (160, 120), fx=150.0)
        vol = CuboidVolume([0.0, 0.0, 1.0], [60.0, 60.0, 2.0], None, "kit")
        return ConformanceExample(
            cls(volumes=[vol.to_dict()], entry={"particles": 3}, exit={"particles": 2},
                object_size_m=(1, 2, 1)),
            context=RunContext(camera=cam),
            engine={"motion": ConstantVelocity3DMotion(position_noise=0.3),
                    "likelihood": InsideBoxesLikelihood(),
                    "observation": CameraVolumeObservation(particle_box="point"),
                    "associator": None, "detection_driven": False, "n_particles": 400,
                    "max_misses": None, "kill_out_of_view": False})

    def setup(self, context: RunContext) -> None:
        """The run's camera (else the observation model's, at the first frame) and the
        volumes, resolved."""
        if context.camera is not None:
            self.camera_ = context.camera
        self._start()
        if _kernel("region_mask") is not None:
            from pftrack_coast._kernels import warm_up

            warm_up()  # before the first frame

    def _check_relations(self) -> None:
        if self.mask.colour_share and not self.reid.appearance:
            raise ValueError("tracks 'volumes': mask.colour_share needs reid.appearance: true "
                             "(it reads the tracks' colour templates)")

    def _start(self) -> None:
        """The volumes resolved and the per-run state made, once."""
        if "volumes_" in self.__dict__:
            return
        from pftrack.geometry.volumes import CuboidVolume, load_volumes, resolve_volume

        specs = [self.volumes] if isinstance(self.volumes, str) or \
            not isinstance(self.volumes, (list, tuple)) else list(self.volumes)
        vols: dict[str, Any] = {}
        from pftrack.geometry.volumes import Volume, _volume_from_dict

        for spec in specs:
            if isinstance(spec, Volume):
                vols[getattr(spec, "name", f"volume{len(vols)}")] = spec
                continue
            if isinstance(spec, dict):
                v = _volume_from_dict(spec, "tracks 'volumes'")
                vols[v.name] = v
                continue
            s = str(spec)
            if s.endswith((".yaml", ".yml")) and ":" not in s:
                vols.update(load_volumes(s))
            else:
                v = resolve_volume(s)
                vols[getattr(v, "name", s)] = v
        if not vols:
            raise ValueError("tracks 'volumes': no volume given")
        for name, v in vols.items():
            if not isinstance(v, CuboidVolume):
                vols[name] = v.as_cuboid() if hasattr(v, "as_cuboid") else v
        self.volumes_ = vols
        self.groups_: dict[int, str] = {}
        self.tracks_: dict[int, str] = {}
        self.idle_: dict[int, int] = {}
        self.low_: dict[int, int] = {}
        self.boxes_: dict[int, np.ndarray] = {}
        self.paths_: dict[int, deque] = {}
        self.tops_: dict[int, deque] = {}
        self.established_: set[int] = set()
        self.held_: set[int] = set()
        self.overlaps_: dict[tuple[int, int], int] = {}
        self.gates_: dict[int, np.ndarray] = {}
        self.targets_: dict[int, Target] = {}
        self.pending_: dict[int, list[TrackRecord]] = {}
        self.gather_: dict[int, int] = {}
        self.alias_: dict[int, int] = {}
        self.shown_: set[int] = set()
        self.ended_: list[tuple[int, int, np.ndarray]] = []
        self.templates_: dict[int, tuple[np.ndarray, int]] = {}
        self.ended_templates_: dict[int, tuple[np.ndarray, int]] = {}
        self.together_: set[tuple[int, int]] = set()
        self.hists_: dict[int, np.ndarray] = {}
        self.look_: dict[int, np.ndarray] = {}
        self.ahead_: dict[int, np.ndarray] = {}
        self.estimates_: list[dict[str, Any]] = []
        self.events_: list[dict[str, Any]] = []

    # -- helpers ------------------------------------------------------------------------------

    def _camera(self, engine: Any) -> Camera:
        cam = self.__dict__.get("camera_")
        if cam is None:
            get = getattr(engine.observation, "get_camera", None)
            cam = get() if get is not None else None
            if cam is None:
                raise ValueError("tracks 'volumes': needs a camera (the run's, or the "
                                 "observation model's)")
            self.camera_ = cam
        return cam

    def _spread(self, engine: Any, tid: int, volume: Any) -> None:
        """Particles uniform in ``volume``, velocity 0."""
        n, d = engine.n_particles, engine.motion.state_dim
        p = np.zeros((n, d))
        p[:, list(engine.motion.position_dims)] = volume.sample(n, engine.rng)
        engine.set_particles(tid, p)
        self.idle_[tid] = 0
        self.gather_[tid] = 0

    def _pixels(self, tid: int, points: np.ndarray) -> np.ndarray:
        """Image positions (N, 2) of a target's particles: the engine's particle boxes when they
        are points of this frame (``particle_box="point"``), else projected."""
        t = self.targets_.get(tid)
        b = None if t is None else t.particle_boxes_xywh_px
        if b is not None and len(b) == len(points) and not b[:, 2:].any():
            return b[:, :2]
        return self.camera_.project(points)

    def _current_pixels(self, t: Target, points: np.ndarray) -> np.ndarray:
        """Image positions (N, 2) of a target's current (resampled) particles: the weighted
        particles' pixels taken through the engine's ``resample_index`` when this frame
        projected them as points (the same pixels without projecting again), else projected."""
        b, ri = t.particle_boxes_xywh_px, t.resample_index
        if b is not None and ri is not None and len(ri) == len(points) and \
                not b[:, 2:].any():
            return b[:, :2].take(ri, axis=0)  # (b[ri, :2]: the same rows, faster)
        return self.camera_.project(points)

    def _group_region(self, volume: Any, tid: int) -> Any:
        return _Region(self, volume, tid, "exclude")

    def _in_region(self, tid: int, volume: Any, mode: str, points: np.ndarray) -> np.ndarray:
        """Where particles of target ``tid`` may be: in ``volume``, and (``"exclude"``, a
        detection group) outside every tracked intruder's box enlarged by
        ``mask.exclusion_margin`` and outside its gate, or (``"gate"``, a track) inside its gate.
        For a cuboid, one compiled pass (:func:`pftrack_coast._kernels.region_mask`, the same
        comparisons)."""
        kernel = _kernel("region_mask") if isinstance(volume, CuboidVolume) else None
        if kernel is not None:
            lo, hi = self._region_boxes(tid, mode)
            local = volume.to_local(points)  # (CuboidVolume.contains' numbers)
            tol = 1e-9 * max(1.0, float(np.max(np.abs(volume.center_m))))
            lim = np.asarray(volume.size_m / 2.0 + tol, dtype=np.float64)
            out = np.empty(len(local), dtype=np.bool_)
            px = self._pixels(tid, points) if len(lo) else np.zeros((0, 2))
            kernel(np.ascontiguousarray(local), lim, np.ascontiguousarray(px, dtype=np.float64),
                   lo, hi, mode == "gate", out)
            if mode == "gate" and self.mask.colour_share and len(lo):
                out &= self._colour_own(tid, px)
            return out
        inside = volume.contains(points)
        if not inside.any():
            return inside
        lo, hi = self._region_boxes(tid, mode)
        if not len(lo):  # no gate, or no tracked intruder to keep away from
            return inside
        px = self._pixels(tid, points)
        with np.errstate(invalid="ignore"):
            hit = ((px[:, None, :] >= lo[None]) & (px[:, None, :] <= hi[None])).all(axis=2)
        if mode == "gate":
            keep = inside & hit[:, 0]
            if self.mask.colour_share:
                keep &= self._colour_own(tid, px)
            return keep
        return inside & ~hit.any(axis=1)

    def _neighbours(self, tid: int) -> list[int]:
        """The live tracks other than ``tid`` whose gates overlap ``tid``'s gate."""
        gate = self.gates_.get(tid)
        if gate is None:
            return []
        out = []
        for k, g in self.gates_.items():
            if k == tid or g is None or k not in self.tracks_:
                continue
            if g[0] < gate[0] + gate[2] and gate[0] < g[0] + g[2] and \
                    g[1] < gate[1] + gate[3] and gate[1] < g[1] + g[3]:
                out.append(k)
        return out

    def _colour_bins(self, px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The HSV histogram bin (:func:`hsv_histogram`'s) of the frame's pixel under each of
        ``px`` (N, 2), and which of them lie in the image: the frame's bins are computed once
        per frame, over the box that holds every track's gate (a grey or 16-bit frame: none)."""
        if self.__dict__.get("bins_at_") != self.frame_:
            import cv2

            self.bins_at_ = self.frame_
            self.bins_ = None
            img = self.__dict__.get("image_")
            gates = [g for g in self.gates_.values() if g is not None and np.isfinite(g).all()]
            if img is not None and img.ndim == 3 and img.shape[2] == 3 and \
                    img.dtype == np.uint8 and gates:
                g = np.array(gates)
                h, w = img.shape[:2]
                x0, y0 = (int(max(math.floor(v), 0)) for v in g[:, :2].min(axis=0))
                x1 = int(min(math.ceil(float((g[:, 0] + g[:, 2]).max())) + 1, w))
                y1 = int(min(math.ceil(float((g[:, 1] + g[:, 3]).max())) + 1, h))
                if x1 > x0 and y1 > y0:
                    hsv = cv2.cvtColor(np.ascontiguousarray(img[y0:y1, x0:x1]),
                                       cv2.COLOR_BGR2HSV)
                    lut_h, lut_s, lut_v = _hsv_luts(*HSV_BINS)
                    idx = lut_h.take(hsv[:, :, 0])
                    idx += lut_s.take(hsv[:, :, 1])
                    idx += lut_v.take(hsv[:, :, 2])
                    self.bins_ = (idx, x0, y0)
        if self.bins_ is None:
            return np.zeros(0, dtype=np.intp), np.zeros(len(px), dtype=np.bool_)
        idx, x0, y0 = self.bins_
        with np.errstate(invalid="ignore"):
            u = np.floor(px[:, 0]) - x0
            v = np.floor(px[:, 1]) - y0
            ok = (u >= 0) & (u < idx.shape[1]) & (v >= 0) & (v < idx.shape[0])
        return idx[v[ok].astype(np.intp), u[ok].astype(np.intp)], ok

    def _colour_own(self, tid: int, px: np.ndarray) -> np.ndarray:
        """``mask.colour_share``: whether each pixel (N, 2) is not more than
        ``VolumeMask.colour_share_ratio`` times as likely, by its colour, under a neighbouring
        track's template as under track ``tid``'s own (both plus
        ``VolumeMask.colour_share_floor``); only neighbours whose gates overlap ``tid``'s and whose
        templates are ready and lie at least ``VolumeMask.colour_share_distance`` from ``tid``'s
        count. True where nothing decides (no template ready, no such neighbour, off the image,
        NaN)."""
        keep = np.ones(len(px), dtype=np.bool_)
        n = int(self.reid.min_frames)
        own = self.templates_.get(tid)
        if own is None or own[1] < n:
            return keep
        dmin = float(self.mask.colour_share_distance)
        others = [self.templates_[k][0] for k in self._neighbours(tid)
                  if k in self.templates_ and self.templates_[k][1] >= n
                  and float(bhattacharyya(self.templates_[k][0], own[0])) >= dmin]
        if not others:
            return keep
        bins, ok = self._colour_bins(px)
        if not len(bins):
            return keep
        floor = float(self.mask.colour_share_floor)
        limit = float(self.mask.colour_share_ratio) * (own[0].take(bins) + floor)
        barred = np.zeros(len(bins), dtype=np.bool_)
        for tpl in others:
            barred |= tpl.take(bins) + floor > limit
        if np.count_nonzero(barred) > float(self.mask.colour_share_max_barred) * len(px):
            return keep  # hidden behind the neighbour: nothing of its own to keep to
        keep[np.flatnonzero(ok)[barred]] = False
        return keep

    def _region_boxes(self, tid: int, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """The image boxes of :meth:`_in_region` as corners ``lo``, ``hi`` (B, 2): a track's
        gate (``"gate"``; none without one), or the tracked intruders' boxes enlarged by
        ``mask.exclusion_margin`` and widened to their gates (``"exclude"``)."""
        if mode == "gate":
            gate = self.gates_.get(tid)
            if gate is None:
                return np.zeros((0, 2)), np.zeros((0, 2))
            return np.ascontiguousarray(gate[None, :2]), (gate[:2] + gate[2:])[None]
        boxes = list(self.boxes_.values())
        if not boxes:
            return np.zeros((0, 2)), np.zeros((0, 2))
        b = np.array(boxes)
        m = float(self.mask.exclusion_margin)
        lo = b[:, :2] - m * b[:, 2:]
        hi = b[:, :2] + (1.0 + m) * b[:, 2:]
        gates = [self.gates_.get(k) for k in self.boxes_]
        if any(g is not None for g in gates):  # a track's gate is taken away too
            g = np.array([x if x is not None else np.full(4, np.nan) for x in gates])
            has = np.isfinite(g).all(axis=1)
            lo[has] = np.minimum(lo[has], g[has, :2])
            hi[has] = np.maximum(hi[has], g[has, :2] + g[has, 2:])
        return lo, hi

    def _track_region(self, tid: int, volume: Any) -> Any:
        return _Region(self, volume, tid, "gate")

    def _start_groups(self, engine: Any, frame: Frame) -> None:
        for name, vol in self.volumes_.items():
            t = engine.add_target(frame, position=np.asarray(vol.center_m, float))
            self.groups_[t.id] = name
            self.targets_[t.id] = t
            t.valid_region = self._group_region(vol, t.id)
            self._spread(engine, t.id, vol)

    def _blob(self, engine: Any, particles: np.ndarray, frame: Frame,
              px: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The particles of the largest 8-connected patch (in cells of
        ``VolumeEntry.blob_block_px``) of the image they cover, resampled to the engine's count,
        and their pixels (``px``: the particles' pixels when known, else projected)."""
        import cv2

        if px is None:
            px = self.camera_.project(particles[:, list(engine.motion.position_dims)])
        w, h = frame.size_wh
        bs = int(self.entry.blob_block_px)
        gw, gh = -(-w // bs), -(-h // bs)
        ok, cells = _blocks_of_pixels(px, bs, (gh, gw))
        if not ok.any():
            return particles, px
        cell = np.full(len(px), -1, dtype=np.intp)
        cell[ok] = cells
        counts = np.bincount(cell[ok], minlength=gw * gh).reshape(gh, gw)
        n_lab, labels = cv2.connectedComponents((counts > 0).astype(np.uint8), connectivity=8)
        if n_lab <= 2:
            chosen = ok
        else:
            lab = labels.ravel()
            per = np.bincount(lab, weights=counts.ravel(), minlength=n_lab)
            per[0] = -1
            best = int(np.argmax(per))
            chosen = ok.copy()
            chosen[ok] = lab[cell[ok]] == best
        sel, sel_px = particles[chosen], px[chosen]
        n = engine.n_particles
        if len(sel) == n:
            return sel, sel_px
        pick = engine.rng.integers(0, len(sel), size=n)
        return sel[pick], sel_px[pick]

    def _heading(self, tid: int, across: np.ndarray, velocity: np.ndarray | None = None,
                 ) -> float | None:
        """Degrees from the across-view direction to the track's travel: its footprint's
        over the last heading_frames once it exceeds min_travel_m (heading_from 'top': its
        cloud's top centre's on the support plane while the footprint is held or has not
        travelled that far), else its particles' mean horizontal velocity once faster than
        min_speed, else None."""
        paths = [self.paths_.get(tid)]
        if self.footprint.heading_from == "top":
            paths.insert(0 if tid in self.held_ else 1, self.tops_.get(tid))
        d = None
        for path in paths:
            if path and len(path) >= 2:
                d = path[-1] - path[0]
                if float(np.hypot(d[0], d[1])) >= float(self.footprint.min_travel_m):
                    break
                d = None
        if d is None and velocity is not None and \
                float(np.hypot(velocity[0], velocity[1])) >= float(self.footprint.min_speed):
            d = np.asarray(velocity[:2], dtype=np.float64)
        if d is None:
            return None
        along = np.array([-across[1], across[0]])
        return math.degrees(math.atan2(float(np.dot(d, along)), float(np.dot(d, across[:2]))))

    def _top_path(self, tid: int, base: dict[str, Any]) -> None:
        """Append the cloud's top centre pixel, put on the support plane, to track ``tid``'s
        ``tops_`` (heading_from 'top'; nothing when that ray misses the plane)."""
        u0, v0, u1, _ = base["ends"]
        g = self.camera_.image_to_ground(np.array([[0.5 * (u0 + u1), v0]]), z_m=base["z"])[0]
        if np.isfinite(g[:2]).all():
            self.tops_.setdefault(tid, deque(maxlen=int(self.footprint.heading_frames))).append(
                np.asarray(g[:2], dtype=np.float64))

    def _hold(self, tid: int, base: dict[str, Any]) -> None:
        """``footprint.held``: track ``tid`` is in ``held_`` while the support-plane point of the
        first pixel row of the ``VolumeEntry.blob_block_px`` cells below the cell row holding its
        cloud's foot (the cloud's 98 % row), in the cloud's middle column, lies outside its volume
        (the cloud may be cut there by the volume)."""
        u0, v0, u1, v1 = base["ends"]
        bs = float(self.entry.blob_block_px)
        row = (math.floor((v1 - 0.02 * (v1 - v0)) / bs) + 1.0) * bs + 0.5
        vol = self.volumes_[self.tracks_[tid]]
        g = self.camera_.image_to_ground(np.array([[0.5 * (u0 + u1), row]]), z_m=base["z"])[0]
        held = bool(np.isfinite(g).all()) and not bool(
            vol.contains(np.array([[g[0], g[1], float(vol.center_m[2])]]))[0])
        if held:
            self.held_.add(tid)
        else:
            self.held_.discard(tid)

    def _estimate(self, engine: Any, frame: Frame, t: Target, record: TrackRecord,
                  n_above: int) -> TrackRecord:
        cam = self.camera_
        pos_dims = list(engine.motion.position_dims)
        pos = t.particles[:, pos_dims]
        px = self._current_pixels(t, pos)
        fine = _finite_rows(px)
        raw_centre = t.state[pos_dims].copy()
        across, along = _axes(cam, raw_centre[:2])
        est = None
        extra: dict[str, Any] = {}
        n_fine = int(np.count_nonzero(fine))
        if n_fine >= 2:
            # (support_plane_estimate, its shape-free part computed once)
            base = _support_base(cam, px if n_fine == len(px) else px[fine],
                                 float(self.support_z_m), 0.02, finite=True)
            if base is not None:
                across, along = base["across"], base["along"]
                if self.footprint.heading_from == "top":
                    self._top_path(t.id, base)
                if self.footprint.held:
                    self._hold(t.id, base)
                vel = t.state[3:5] if len(t.state) >= 6 else None
                heading = self._heading(t.id, across, vel)
                extra["heading_deg"] = heading
                if float(self.footprint.aspect) != 1.0:  # (a square: the heading is moot)
                    est = _support_finish(cam, base, aspect=float(self.footprint.aspect),
                                          heading_deg=heading)
                else:
                    est = _support_finish(cam, base)
        # eq. 10 along the view's axes: the particles' (biased) variance along each axis
        axes = np.array([across, (0.0, 0.0, 1.0), along])
        var = np.zeros(3)
        if len(pos) > 1:
            proj = axes @ pos.T  # (3, N): rows, for fast reductions
            dev = proj - proj.mean(axis=1, keepdims=True)
            var = np.einsum("ij,ij->i", dev, dev) / len(pos)
        size_raw = 2.0 * np.sqrt(np.maximum(var, 0.0))
        entry = {"frame": frame.index, "id": self.alias_.get(t.id, t.id),
                 "volume": self.tracks_[t.id],
                 "centre_raw_m": raw_centre, "size_raw_m": size_raw, "n_above": int(n_above),
                 **extra}
        if est is None:  # no footprint: the particles' mean, put on the support plane
            record.world_m = np.array([raw_centre[0], raw_centre[1], float(self.support_z_m)])
            self.boxes_[t.id] = record.box_xywh_px.copy()
            self.estimates_.append(entry)
            return record
        record.world_m = est["footprint_m"].copy()
        record.size_m = est["size_m"].copy()
        path = self.paths_.setdefault(t.id, deque(maxlen=int(self.footprint.heading_frames)))
        path.append(est["footprint_m"][:2].copy())
        entry.update(footprint_m=est["footprint_m"], size_m=est["size_m"])
        # the estimate's cuboid, and with a typical size: the one on the footprint and where
        # the footprint goes next (its mean displacement over the last few frames), one call
        centres, sizes = [est["centre_m"]], [est["size_m"]]
        if self.object_size_m is not None:
            size = np.asarray(self.object_size_m, dtype=np.float64)
            c = est["footprint_m"].copy()
            c[2] += 0.5 * size[1]
            nxt = c.copy()
            if len(path) >= 2:
                k = min(len(path), 4)
                nxt[:2] += (path[-1] - path[-k]) / (k - 1)
            centres += [c, nxt]
            sizes += [size, size]
        boxes = cuboid_boxes(cam, np.array(centres), np.array(sizes), est["across"],
                             est["along"])
        if np.isfinite(boxes[0]).all():
            record.box_xywh_px = boxes[0]
        box = record.box_xywh_px.copy()
        if self.object_size_m is not None and np.isfinite(boxes[1]).all():
            prior = boxes[1]
            self.look_[t.id] = prior  # (appearance: a typical intruder on the footprint)
            ahead = boxes[2] if np.isfinite(boxes[2]).all() else prior
            self.ahead_[t.id] = ahead
            if self.mask.gate_margin is not None:
                lo = np.minimum(prior[:2], ahead[:2])
                hi = np.maximum(prior[:2] + prior[2:], ahead[:2] + ahead[2:])
                g = float(self.mask.gate_margin)
                self.gates_[t.id] = np.concatenate([lo - g * prior[2:],
                                                    hi - lo + 2.0 * g * prior[2:]])
            lo = np.minimum(box[:2], prior[:2])
            hi = np.maximum(box[:2] + box[2:], prior[:2] + prior[2:])
            box = np.concatenate([lo, hi - lo])
        self.boxes_[t.id] = box
        self.estimates_.append(entry)
        return record

    # -- the hooks ----------------------------------------------------------------------------

    def before_frame(self, engine: Any, frame: Frame, detections: Detections | None) -> None:
        """Start the detection groups on the first frame."""
        self._start()
        self._camera(engine)
        self.frame_ = frame.index
        self.image_ = frame.image
        if not self.groups_:
            self._start_groups(engine, frame)

    def end_target(self, target: Target) -> None:
        tid = target.id
        path = self.paths_.get(tid)
        if tid in self.tracks_ and tid not in self.pending_ and tid in self.shown_ and path:
            # an output track ends: its id may be taken up again (reid_frames, reid_m)
            self.ended_.append((int(self.__dict__.get("frame_", 0)),
                                self.alias_.get(tid, tid), np.array(path[-1], dtype=float)))
            if tid in self.templates_:
                self.ended_templates_[self.alias_.get(tid, tid)] = self.templates_[tid]
        self.templates_.pop(tid, None)
        self.alias_.pop(tid, None)
        self.shown_.discard(tid)
        self.established_.discard(tid)
        self.held_.discard(tid)
        for d in (self.groups_, self.tracks_, self.idle_, self.low_, self.boxes_, self.paths_,
                  self.tops_,
                  self.pending_, self.gates_, self.targets_, self.gather_, self.look_,
                  self.ahead_):
            d.pop(tid, None)

    def after_frame(self, engine: Any, frame: Frame, detections: Detections | None,
                    records: list[TrackRecord], unmatched_detections: np.ndarray,
                    ) -> list[TrackRecord]:
        log_v = math.log(float(self.v_pi))
        live = {t.id: t for t in engine.targets}
        by_id = {r.id: r for r in records}

        def above(t: Target) -> int:
            ll = t.log_likelihoods
            return 0 if ll is None else int(np.count_nonzero(ll > log_v))

        out: list[TrackRecord] = []
        # exits and estimates of the tracks
        for tid in list(self.tracks_):
            t = live.get(tid)
            if t is None:
                continue
            n_above = above(t)
            if n_above > int(self.exit.particles):
                self.established_.add(tid)
            low = self.exit.low(n_above, tid in self.established_, self.entry.particles)
            self.low_[tid] = self.low_.get(tid, 0) + 1 if low else 0
            if self.low_[tid] >= int(self.exit.frames) or tid not in by_id:
                self.events_.append({"frame": frame.index, "id": tid,
                                     "volume": self.tracks_[tid], "event": "exit"})
                engine.remove_target(tid)
                continue
            out.append(self._estimate(engine, frame, t, by_id[tid], n_above))
        # one intruder tracked twice (overlapping for merge_frames frames): the younger ends
        overlaps: dict[tuple[int, int], int] = {}
        if len(out) > 1:
            merge = self.merge
            xy = v = None
            if merge.distance_m is not None:
                xy = np.array([r.world_m[:2] if r.world_m is not None else (np.nan, np.nan)
                               for r in out])
            if merge.speed_m is not None:
                v = np.array([self._velocity(r.id) for r in out])
            same = merge.same(np.array([r.box_xywh_px for r in out]), xy, v)
            drop: set[int] = set()
            order = sorted(range(len(out)), key=lambda i: out[i].id)  # older first
            for a_i, i in enumerate(order):
                if out[i].id in drop:
                    continue
                for j in order[a_i + 1:]:
                    if out[j].id in drop or not same[i, j]:
                        continue
                    key = (out[i].id, out[j].id)
                    overlaps[key] = self.overlaps_.get(key, 0) + 1
                    if overlaps[key] >= int(self.merge.frames):
                        if self.reid.appearance and out[i].id in self.shown_ and \
                                out[j].id in self.shown_ and \
                                self._mismatch(frame, out[i], out[j]):
                            # the older is on the younger's person: it goes on under the
                            # younger's output id (and template); the older's id ends
                            self._swap(frame, out[i].id, out[j].id)
                        drop.add(out[j].id)
            for tid in drop:
                self.events_.append({"frame": frame.index, "id": tid,
                                     "volume": self.tracks_[tid], "event": "merged"})
                engine.remove_target(tid)
            out = [r for r in out if r.id not in drop]
        self.overlaps_ = overlaps
        # entries: each detection group with enough particles above v_pi starts a track
        for gid, name in list(self.groups_.items()):
            g = live.get(gid)
            vol = self.volumes_[name]
            if g is None:
                continue
            ll = g.log_likelihoods
            if ll is None or not np.isfinite(ll).any():
                self._spread(engine, gid, vol)
                continue
            if above(g) >= int(self.entry.particles):
                pos_dims = list(engine.motion.position_dims)
                parts, parts_px = self._blob(engine, g.particles, frame,
                                             self._current_pixels(g, g.particles[:, pos_dims]))
                why = self._refusal(parts, engine, parts_px)
                if why == "small" and self.gather_.get(gid, 0) < int(self.entry.gather_frames):
                    # too small for an intruder yet: the group keeps gathering on it (the
                    # few particles that hit it are resampled and spread over it)
                    self.gather_[gid] = self.gather_.get(gid, 0) + 1
                    continue
                if why is not None:
                    self._spread(engine, gid, vol)  # a tracked intruder's fringe, not a new one
                    continue
                pos_dims = list(engine.motion.position_dims)
                if self.object_size_m is not None:
                    a = np.asarray(self.object_size_m, dtype=np.float64)
                    jitter = engine.rng.standard_normal((len(parts), 3)) * (0.25 * a[[0, 2, 1]])
                    parts = parts.copy()
                    parts[:, pos_dims] += jitter
                    parts[:, pos_dims] = _clip_into(vol, parts[:, pos_dims])
                pos = parts[:, pos_dims].mean(axis=0)
                t = engine.add_target(frame, position=pos)
                engine.set_particles(t.id, parts)
                t.valid_region = self._track_region(t.id, vol)
                self.targets_[t.id] = t
                self.tracks_[t.id] = name
                self.low_[t.id] = 0
                if int(self.confirm_frames) > 1:
                    self.pending_[t.id] = []
                self.events_.append({"frame": frame.index, "id": t.id, "volume": name,
                                     "event": "entry"})
                out.append(self._estimate(engine, frame, t, engine.record(frame, t),
                                          above(g)))
                self._spread(engine, gid, vol)
                continue
            self.idle_[gid] = self.idle_.get(gid, 0) + 1
            if self.idle_[gid] >= int(self.entry.idle_frames):
                self._spread(engine, gid, vol)
        for tid in list(self.boxes_):
            if tid not in self.tracks_:
                del self.boxes_[tid]
        if self.reid.appearance:
            self._appearance(frame, out)
        self.image_ = None  # (colour_share reads the frame while it is weighted, not after)
        return self._reidentified(self._confirmed([r for r in out if self._shown(r)]))

    def _reidentified(self, out: list[TrackRecord]) -> list[TrackRecord]:
        """The records with their output ids: a track output for the first time whose
        footprint lies within ``reid.distance_m`` of where an output track ended at most
        ``reid.frames`` frames ago takes up that track's id (the nearest; each id once)."""
        n, r_m = int(self.reid.frames), float(self.reid.distance_m)
        if n > 0 and self.ended_:
            now = int(self.__dict__.get("frame_", 0))
            self.ended_ = [e for e in self.ended_ if now - e[0] <= n]
        new = sorted({r.id for r in out if r.id not in self.shown_})
        for tid in new:
            self.shown_.add(tid)
            if n <= 0 or not self.ended_:
                continue
            first = next(r for r in out if r.id == tid)
            if first.world_m is None:
                continue
            # (a track confirmed late outputs from its entry on: only ids ended by then)
            xy = np.array([e[2] for e in self.ended_])
            d = np.hypot(xy[:, 0] - first.world_m[0], xy[:, 1] - first.world_m[1])
            d[np.array([e[0] > first.frame for e in self.ended_])] = np.inf
            k = int(np.argmin(d))
            if self.reid.appearance and d[k] <= r_m:  # of the ids within reid_m: the best match
                k = self._best_match(tid, d, r_m, k)
            if d[k] <= r_m:
                self.alias_[tid] = self.ended_.pop(k)[1]
                self.events_.append({"frame": first.frame, "id": tid, "volume":
                                     self.tracks_.get(tid), "event": "reidentified",
                                     "as": self.alias_[tid]})
                self._rename_estimates(tid, self.alias_[tid], first.frame)
        for r in out:
            if r.id in self.alias_:
                r.id = self.alias_[r.id]
        return out

    def _best_match(self, tid: int, d: np.ndarray, r_m: float, k: int) -> int:
        """Of the ended ids within ``r_m`` (distances ``d`` to ``self.ended_``), the one whose
        template matches track ``tid``'s histogram best (``k``, the nearest, without
        templates)."""
        h = self.hists_.get(tid)
        if h is None:
            return k
        best, cost = k, np.inf
        for i in np.flatnonzero(d <= r_m):
            tpl = self.ended_templates_.get(self.ended_[i][1])
            if tpl is None or tpl[1] < int(self.reid.min_frames):
                continue
            c = float(bhattacharyya(h, tpl[0]))
            if c < cost:
                best, cost = int(i), c
        return best

    def _appearance(self, frame: Frame, out: list[TrackRecord]) -> None:
        """Histograms of this frame's tracks; templates updated for tracks alone; pairs that
        were together and have separated swap output ids when appearance says so."""
        self.hists_ = {}
        for r in out:
            h = self._hist(frame, r)
            if h is not None:
                self.hists_[r.id] = h
        xy = {r.id: r.world_m[:2] for r in out if r.world_m is not None}
        ids = sorted(xy)
        near = float(self.reid.near_m)
        if ids:
            p = np.array([xy[i] for i in ids])
            d = np.hypot(p[:, None, 0] - p[None, :, 0], p[:, None, 1] - p[None, :, 1])
            np.fill_diagonal(d, np.inf)
        else:
            d = np.zeros((0, 0))
        pos = {tid: i for i, tid in enumerate(ids)}
        together = {(ids[i], ids[j]) for i, j in zip(*np.nonzero(d < near)) if i < j}
        # pairs together before and now apart (both still live, beyond apart * near, image
        # boxes disjoint): test a swap
        apart = float(self.reid.apart)
        box = {r.id: r.box_xywh_px for r in out}
        for a, b in sorted(self.together_ - together):
            if a not in pos or b not in pos:
                continue
            ba, bb = box[a], box[b]
            disjoint = bool(np.any(ba[:2] + ba[2:] <= bb[:2])
                            or np.any(bb[:2] + bb[2:] <= ba[:2]))
            if d[pos[a], pos[b]] < apart * near or not disjoint:
                together.add((a, b))  # not apart yet: still together
                continue
            self._maybe_swap(frame, a, b)
        self.together_ = together
        alone = [tid for tid in ids if not np.any(d[pos[tid]] < 2.0 * near)]
        rate = float(self.reid.rate)
        for tid in alone:
            h = self.hists_.get(tid)
            if h is None:
                continue
            tpl = self.templates_.get(tid)
            self.templates_[tid] = (h.copy(), 1) if tpl is None else \
                ((1.0 - rate) * tpl[0] + rate * h, tpl[1] + 1)

    def _hist(self, frame: Frame, record: TrackRecord) -> np.ndarray | None:
        """HSV histogram of a track's region: the image box of a typical intruder
        (``object_size_m``) on its footprint, else its record's box."""
        box = self.look_.get(record.id, record.box_xywh_px)
        return hsv_histogram(frame.image, box, inner=float(self.reid.inner))

    def _mismatch(self, frame: Frame, older: TrackRecord, younger: TrackRecord) -> bool:
        """Two tracks on one intruder merge: whether the older's template matches its region
        worse (by ``VolumeReid.margin``) than the younger's matches its own (the older ends
        then, not the younger). False when either template is not ready."""
        n = int(self.reid.min_frames)
        costs = []
        for r in (older, younger):
            tpl = self.templates_.get(r.id)
            h = self._hist(frame, r)
            if tpl is None or tpl[1] < n or h is None:
                return False
            costs.append(float(bhattacharyya(h, tpl[0])))
        return costs[0] > costs[1] + float(self.reid.margin)

    def _maybe_swap(self, frame: Frame, a: int, b: int) -> None:
        ta, tb = self.templates_.get(a), self.templates_.get(b)
        ha, hb = self.hists_.get(a), self.hists_.get(b)
        n = int(self.reid.min_frames)
        if ta is None or tb is None or ha is None or hb is None or min(ta[1], tb[1]) < n:
            return
        if a not in self.shown_ or b not in self.shown_:
            return
        kept = float(bhattacharyya(ha, ta[0]) + bhattacharyya(hb, tb[0]))
        swapped = float(bhattacharyya(ha, tb[0]) + bhattacharyya(hb, ta[0]))
        if swapped + float(self.reid.margin) >= kept:
            return
        self._swap(frame, a, b)

    def _swap(self, frame: Frame, a: int, b: int) -> None:
        """Tracks ``a`` and ``b`` exchange their output ids and templates."""
        oa, ob = self.alias_.get(a, a), self.alias_.get(b, b)
        self.alias_[a], self.alias_[b] = ob, oa
        ta, tb = self.templates_.pop(a, None), self.templates_.pop(b, None)
        if tb is not None:
            self.templates_[a] = tb
        if ta is not None:
            self.templates_[b] = ta
        for e in reversed(self.estimates_):  # this frame's estimates under the new ids
            if e["frame"] < frame.index:
                break
            if e["id"] in (oa, ob):
                e["id"] = ob if e["id"] == oa else oa
        self.events_.append({"frame": frame.index, "id": a, "volume": self.tracks_.get(a),
                             "event": "swapped", "with": b})

    def _rename_estimates(self, tid: int, new_id: int, since: int) -> None:
        """The estimates of track ``tid`` from frame ``since`` on, under ``new_id`` (the
        estimates of a track waiting for confirmation were kept under its own id)."""
        for e in reversed(self.estimates_):
            if e["frame"] < since:
                break
            if e["id"] == tid:
                e["id"] = new_id

    def _velocity(self, tid: int) -> np.ndarray:
        """A track's footprint velocity (2,), metres per frame, over its last
        ``VolumeMerge.speed_frames`` footprints (NaN before it has that many)."""
        path = self.paths_.get(tid)
        k = int(self.merge.speed_frames)
        if not path or len(path) <= k:
            return np.full(2, np.nan)
        return (path[-1] - path[-1 - k]) / k

    def _shown(self, record: TrackRecord) -> bool:
        """With ``footprint_inside``: whether the record's footprint lies inside its volume's
        ground footprint (a track whose particles see an intruder through the volume while
        the intruder is still outside it is not yet an entry)."""
        if not self.footprint_inside or record.world_m is None:
            return True
        if record.id in self.held_:
            return False
        vol = self.volumes_[self.tracks_[record.id]] if record.id in self.tracks_ else None
        if vol is None:
            return True
        p = np.array([[record.world_m[0], record.world_m[1], float(vol.center_m[2])]])
        return bool(vol.contains(p)[0])

    def _confirmed(self, out: list[TrackRecord]) -> list[TrackRecord]:
        """The records to output: a track's from its entry on once it has lived
        ``confirm_frames`` frames."""
        n = int(self.confirm_frames)
        if n <= 1:
            return out
        shown = []
        for r in out:
            buf = self.pending_.get(r.id)
            if buf is None:
                shown.append(r)
                continue
            buf.append(r)
            if len(buf) >= n:
                shown.extend(buf)
                del self.pending_[r.id]
        return shown

    def _explained(self, particles: np.ndarray, engine: Any) -> bool:
        """Whether ``particles`` are not a new intruder (:meth:`_refusal` gives a reason)."""
        return self._refusal(particles, engine) is not None

    def _refusal(self, particles: np.ndarray, engine: Any,
                 px: np.ndarray | None = None) -> str | None:
        """Why ``particles`` are not a new intruder: ``"small"`` (smaller than
        ``VolumeEntry.min_size_fraction`` of ``object_size_m``), ``"tracked"`` (on a tracked one's
        footprint, ``merge.distance_m``, or mostly -- ``VolumeEntry.spawn_overlap`` -- inside a
        tracked intruder's image box), ``"none"`` (no footprint: nothing projects, or the cloud's
        foot row misses the support plane); None: a new intruder. ``px``: the particles' pixels
        when known."""
        if px is None:
            px = self.camera_.project(particles[:, list(engine.motion.position_dims)])
        fine = _finite_rows(px)
        if not fine.all():
            px = px[fine]
        if not len(px):
            return "none"
        est = None
        if self.object_size_m is not None or self.merge.distance_m is not None:
            # (support_plane_estimate of the finite pixels)
            base = _support_base(self.camera_, px, float(self.support_z_m), 0.02, finite=True)
            if base is None:
                return "none"
            est = _support_finish(self.camera_, base)
            if self.merge.distance_m is not None and self.paths_:
                xy = np.array([p[-1] for p in self.paths_.values() if p])
                if len(xy) and np.hypot(*(xy - est["footprint_m"][:2]).T).min() \
                        < float(self.merge.distance_m):
                    return "tracked"
            if self.object_size_m is not None:
                size = np.asarray(self.object_size_m, dtype=np.float64)
                f = float(self.entry.min_size_fraction)
                if est["size_m"][0] < f * size[0] or est["size_m"][1] < f * size[1]:
                    return "small"
        if not self.boxes_:
            return None
        if est is not None:  # cloud_box(px): the estimate's image box, the same numbers
            box = est["box_xywh_px"]
        else:
            box = cloud_box(px) if len(px) >= 2 else np.concatenate([px[0], np.zeros(2)])
        lo, hi = box[:2], box[:2] + box[2:]
        area = max(float(np.prod(hi - lo)), 1e-9)
        b = np.array(list(self.boxes_.values()))
        ov = np.clip(np.minimum(hi, b[:, :2] + b[:, 2:]) - np.maximum(lo, b[:, :2]), 0, None)
        inside = ov.prod(axis=1) / area > float(self.entry.spawn_overlap)
        return "tracked" if bool(inside.any()) else None
