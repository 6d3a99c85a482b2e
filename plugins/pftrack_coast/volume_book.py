"""The state the ``volumes`` track manager's stages share (:mod:`pftrack_coast.volumes`), and
where their particles may live.

:class:`VolumeBook` holds one run's per-track state keyed by engine target id -- which targets
are detection groups and which are tracks, in which volume, their counts, image boxes, gates,
footprints and identities -- and the parameters the stages read. Every stage of the manager
holds the same book; none holds the engine or a target.

:class:`VolumeRegion` is a target's ``valid_region`` (a detection group kept in its volume and
off the tracked intruders, a track kept in its volume and its gate), read from the book when the
particles are weighted; :class:`VolumeMasker` hands one to each new target as a
:class:`~pftrack.contracts.stages.Mask` decision.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from pftrack.contracts.stages import FrameView, Mask, Masker
from pftrack.geometry.volumes import CuboidVolume

from pftrack_coast.volume_colour import hsv_bin_image, pixel_bins
from pftrack_coast.volume_footprint import TrackFootprints
from pftrack_coast.volume_identity import VolumeIdentities

if TYPE_CHECKING:
    from pftrack.contracts.stages import OutputBox
    from pftrack.geometry.camera import Camera

    from pftrack_coast.volume_params import (
        VolumeEntry,
        VolumeExit,
        VolumeFootprint,
        VolumeMask,
        VolumeMerge,
        VolumeReid,
    )

__all__ = ["VolumeBook", "VolumeMasker", "VolumeRegion"]


def _kernel(name: str) -> Any:
    """A compiled kernel of :mod:`pftrack_coast._kernels`, or None with ``PFTRACK_NO_JIT``
    (the numpy path then runs: the same numbers)."""
    from pftrack.filter import _jit

    if not _jit.ENABLED:
        return None
    from pftrack_coast import _kernels

    return getattr(_kernels, name)


class VolumeBook:
    """One run's shared state of the ``volumes`` stages, keyed by engine target id.

    Parameters
    ----------
    volumes : dict[str, Volume]
        The detection volumes by name.
    v_pi, object_size_m, support_z_m, footprint_inside
        The manager's parameters of those names (``object_size_m`` as given, metres, or None).
    entry, exit, mask, merge, reid, footprint
        The manager's parameter groups (the same objects: a change to one is seen here).

    Attributes
    ----------
    camera : Camera or None
        The run's camera (set by the manager before the first frame).
    position_dims : tuple of int
        The entries of a state that are its position (the run's motion model's).
    frame, image
        This frame's index and image (the image only while the frame is weighted and its
        stages run: the colour share reads it).
    groups, tracks : dict[int, str]
        Live detection groups and tracks: target id -> volume name (in birth order).
    idle, gather : dict[int, int]
        A group's frames without an entry, and frames spent gathering on a candidate too small
        for an intruder.
    low : dict[int, int]
        A track's consecutive frames with at most ``exit.particles`` above ``v_pi``.
    above : dict[int, int]
        This frame's count of a target's particles with likelihood above ``v_pi``.
    leaving : set[int]
        The tracks that leave their volumes in this frame (``exit``): not estimated, ended.
    established : set[int]
        Tracks that have had more than ``exit.particles`` particles above ``v_pi``.
    boxes : dict[int, ndarray]
        A track's image box (4,) xywh px that the detection groups keep away from.
    gates, look, ahead : dict[int, ndarray]
        A track's gate (4,) xywh px, the image box of a typical intruder on its footprint, and
        where that box goes next.
    overlaps : dict[tuple[int, int], int]
        Consecutive frames two tracks (older, younger) were one intruder by ``merge``.
    outputs : dict[int, OutputBox]
        This frame's estimate of each estimated track (box, ground position, size).
    hidden : set[int]
        This frame's estimated tracks whose records are not output (not inside their volumes).
    shown : dict[int, int]
        Frames in which a track's record was output or held back to be (not hidden).
    first_shown : dict[int, tuple[int, ndarray]]
        A track's first such frame and its ground position (3,) there, metres.
    pending : set[int]
        Tracks not yet confirmed (``confirm_frames``): their records are held back.
    births : dict[int, tuple]
        What each birth being applied starts: ``("group", volume)`` or ``("track", volume,
        n_above)``, by ``id`` of its :class:`~pftrack.contracts.stages.Birth` (until the stages
        hear of it).
    estimates, events : list of dict
        The manager's ``estimates_`` and ``events_``.
    footprints : TrackFootprints
    identities : VolumeIdentities
    """

    def __init__(self, volumes: dict[str, Any], *, v_pi: float,
                 object_size_m: Sequence[float] | None, support_z_m: float,
                 footprint_inside: bool, entry: VolumeEntry, exit: VolumeExit,
                 mask: VolumeMask, merge: VolumeMerge, reid: VolumeReid,
                 footprint: VolumeFootprint) -> None:
        self.volumes = volumes
        self.v_pi = float(v_pi)
        self.object_size_m = object_size_m
        self.support_z_m = float(support_z_m)
        self.footprint_inside = bool(footprint_inside)
        self.entry, self.exit, self.mask = entry, exit, mask
        self.merge, self.reid, self.footprint = merge, reid, footprint
        self.camera: Camera | None = None
        self.position_dims: tuple[int, ...] = (0, 1, 2)
        self.frame = 0
        self.image: np.ndarray | None = None
        self.groups: dict[int, str] = {}
        self.tracks: dict[int, str] = {}
        self.idle: dict[int, int] = {}
        self.gather: dict[int, int] = {}
        self.low: dict[int, int] = {}
        self.above: dict[int, int] = {}
        self.leaving: set[int] = set()
        self.established: set[int] = set()
        self.boxes: dict[int, np.ndarray] = {}
        self.gates: dict[int, np.ndarray] = {}
        self.look: dict[int, np.ndarray] = {}
        self.ahead: dict[int, np.ndarray] = {}
        self.overlaps: dict[tuple[int, int], int] = {}
        self.outputs: dict[int, OutputBox] = {}
        self.hidden: set[int] = set()
        self.shown: dict[int, int] = {}
        self.first_shown: dict[int, tuple[int, np.ndarray]] = {}
        self.pending: set[int] = set()
        self.births: dict[int, tuple] = {}
        self.masked: set[int] = set()
        self.estimates: list[dict[str, Any]] = []
        self.events: list[dict[str, Any]] = []
        self.footprints = TrackFootprints(footprint)
        self.identities = VolumeIdentities(reid, self.estimates, self.events)
        self.bins_at: int | None = None
        self.bins: Any = None

    def end(self, tid: int) -> None:
        """Target ``tid`` ended: an output track's id may be taken up again (``reid``), and its
        state is dropped."""
        path = self.footprints.paths_.get(tid)
        self.identities.end(tid, int(self.frame),
                            path[-1] if tid in self.tracks and tid not in self.pending
                            and path else None)
        self.footprints.end(tid)
        for s in (self.established, self.masked, self.pending, self.leaving, self.hidden):
            s.discard(tid)
        for d in (self.groups, self.tracks, self.idle, self.low, self.above, self.boxes,
                  self.gates, self.gather, self.look, self.ahead, self.outputs, self.shown,
                  self.first_shown):
            d.pop(tid, None)

    # -- where particles may live -----------------------------------------------------------

    def pixels(self, points: np.ndarray, boxes: np.ndarray | None) -> np.ndarray:
        """Image positions (N, 2) of particles at ``points`` (N, 3): the boxes the engine gave
        them at this weighting when they are points of the same particles (``particle_box=
        "point"``), else projected."""
        b = boxes
        if b is not None and len(b) == len(points) and not b[:, 2:].any():
            return b[:, :2]
        return self.camera.project(points)  # type: ignore[union-attr]

    def region_boxes(self, tid: int, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """The image boxes of :meth:`in_region` as corners ``lo``, ``hi`` (B, 2): a track's
        gate (``"gate"``; none without one), or the tracked intruders' boxes enlarged by
        ``mask.exclusion_margin`` and widened to their gates (``"exclude"``)."""
        if mode == "gate":
            gate = self.gates.get(tid)
            if gate is None:
                return np.zeros((0, 2)), np.zeros((0, 2))
            return np.ascontiguousarray(gate[None, :2]), (gate[:2] + gate[2:])[None]
        boxes = list(self.boxes.values())
        if not boxes:
            return np.zeros((0, 2)), np.zeros((0, 2))
        b = np.array(boxes)
        m = float(self.mask.exclusion_margin)
        lo = b[:, :2] - m * b[:, 2:]
        hi = b[:, :2] + (1.0 + m) * b[:, 2:]
        gates = [self.gates.get(k) for k in self.boxes]
        if any(g is not None for g in gates):  # a track's gate is taken away too
            g = np.array([x if x is not None else np.full(4, np.nan) for x in gates])
            has = np.isfinite(g).all(axis=1)
            lo[has] = np.minimum(lo[has], g[has, :2])
            hi[has] = np.maximum(hi[has], g[has, :2] + g[has, 2:])
        return lo, hi

    def in_region(self, tid: int, volume: Any, mode: str, points: np.ndarray,
                  boxes: np.ndarray | None = None) -> np.ndarray:
        """Where particles of target ``tid`` may be: in ``volume``, and (``"exclude"``, a
        detection group) outside every tracked intruder's box enlarged by
        ``mask.exclusion_margin`` and outside its gate, or (``"gate"``, a track) inside its gate.
        ``boxes``: the particles' image boxes of this weighting (see :meth:`pixels`). For a
        cuboid, one compiled pass (:func:`pftrack_coast._kernels.region_mask`, the same
        comparisons)."""
        kernel = _kernel("region_mask") if isinstance(volume, CuboidVolume) else None
        if kernel is not None:
            lo, hi = self.region_boxes(tid, mode)
            local = volume.to_local(points)  # (CuboidVolume.contains' numbers)
            tol = 1e-9 * max(1.0, float(np.max(np.abs(volume.center_m))))
            lim = np.asarray(volume.size_m / 2.0 + tol, dtype=np.float64)
            out = np.empty(len(local), dtype=np.bool_)
            px = self.pixels(points, boxes) if len(lo) else np.zeros((0, 2))
            kernel(np.ascontiguousarray(local), lim, np.ascontiguousarray(px, dtype=np.float64),
                   lo, hi, mode == "gate", out)
            if mode == "gate" and self.mask.colour_share and len(lo):
                out &= self.colour_own(tid, px)
            return out
        inside = volume.contains(points)
        if not inside.any():
            return inside
        lo, hi = self.region_boxes(tid, mode)
        if not len(lo):  # no gate, or no tracked intruder to keep away from
            return inside
        px = self.pixels(points, boxes)
        with np.errstate(invalid="ignore"):
            hit = ((px[:, None, :] >= lo[None]) & (px[:, None, :] <= hi[None])).all(axis=2)
        if mode == "gate":
            keep = inside & hit[:, 0]
            if self.mask.colour_share:
                keep &= self.colour_own(tid, px)
            return keep
        return inside & ~hit.any(axis=1)

    def neighbours(self, tid: int) -> list[int]:
        """The live tracks other than ``tid`` whose gates overlap ``tid``'s gate."""
        gate = self.gates.get(tid)
        if gate is None:
            return []
        out = []
        for k, g in self.gates.items():
            if k == tid or g is None or k not in self.tracks:
                continue
            if g[0] < gate[0] + gate[2] and gate[0] < g[0] + g[2] and \
                    g[1] < gate[1] + gate[3] and gate[1] < g[1] + g[3]:
                out.append(k)
        return out

    def colour_bins(self, px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The HSV histogram bin (:func:`~pftrack_coast.volume_colour.hsv_histogram`'s) of the
        frame's pixel under each of ``px`` (N, 2), and which of them lie in the image: the
        frame's bins are computed once per frame, over the box that holds every track's gate
        (a grey or 16-bit frame: none)."""
        if self.bins_at != self.frame:
            self.bins_at = self.frame
            self.bins = hsv_bin_image(self.image, [
                g for g in self.gates.values() if g is not None and np.isfinite(g).all()])
        return pixel_bins(self.bins, px)

    def colour_own(self, tid: int, px: np.ndarray) -> np.ndarray:
        """``mask.colour_share``: whether each pixel (N, 2) of track ``tid`` is its own by its
        colour against the templates of the tracks whose gates overlap its gate
        (:meth:`pftrack_coast.volume_identity.VolumeIdentities.colour_own`)."""
        return self.identities.colour_own(tid, self.neighbours(tid), px, self.colour_bins,
                                          self.mask)


class VolumeRegion:
    """A target's ``valid_region`` (picklable): :meth:`VolumeBook.in_region` of target ``tid``
    in ``volume``, ``mode`` ``"exclude"`` (a detection group) or ``"gate"`` (a track), called
    with the particles' positions and image boxes (``Mask.boxes``)."""

    def __init__(self, book: VolumeBook, volume: Any, tid: int, mode: str) -> None:
        self.book, self.volume, self.tid, self.mode = book, volume, tid, mode

    def __call__(self, points: np.ndarray, boxes: np.ndarray | None = None) -> np.ndarray:
        return self.book.in_region(self.tid, self.volume, self.mode, points, boxes)


class VolumeMasker(Masker):
    """Where the particles of each new target may live: a detection group in its volume and
    off the tracked intruders' image boxes (enlarged by ``mask.exclusion_margin``) and gates, a
    track in its volume and its gate (with ``mask.colour_share``: on the pixels its colour
    template claims). One :class:`VolumeRegion` per target, given once: it reads the book's
    boxes and gates as they are when the particles are weighted."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    def mask(self, view: FrameView) -> list[Mask]:
        book = self.book
        out = []
        for t in view.tracks:
            if t.id in book.masked:
                continue
            if t.id in book.groups:
                mode, name = "exclude", book.groups[t.id]
            elif t.id in book.tracks:
                mode, name = "gate", book.tracks[t.id]
            else:
                continue
            book.masked.add(t.id)
            out.append(Mask(t.id, VolumeRegion(book, book.volumes[name], t.id, mode),
                            boxes=True))
        for tid in list(book.boxes):  # (the groups keep off live tracks only)
            if tid not in book.tracks:
                del book.boxes[tid]
        return out
