"""The parameter groups of the ``volumes`` track manager
(:class:`pftrack_coast.volumes.VolumeTracks`): ``entry``, ``exit``, ``mask``, ``merge``, ``reid``
and ``footprint``, each with the rules it decides on its own numbers.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pftrack.contracts.components import Param, ParamGroup
from pftrack.geometry.boxes import iou_matrix

__all__ = ["VolumeEntry", "VolumeExit", "VolumeFootprint", "VolumeMask", "VolumeMerge",
           "VolumeReid"]


class VolumeEntry(ParamGroup):
    """How a detection group finds an entry (the coastal paper's N_m), group ``entry`` of
    :class:`~pftrack_coast.volumes.VolumeTracks`: a track starts when at least ``particles`` of a
    detection group's particles have likelihood above ``v_pi``, from those of the largest
    connected patch of the image they cover.

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
    """When a track ends (the coastal paper's N_out), group ``exit`` of
    :class:`~pftrack_coast.volumes.VolumeTracks`.

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
    """Where particles may live, group ``mask`` of :class:`~pftrack_coast.volumes.VolumeTracks`:
    every particle in its volume; a detection group's particles off the tracked intruders' image
    boxes; a track's particles in its gate, and off the pixels whose colour a neighbour's
    template claims.

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
    :class:`~pftrack_coast.volumes.VolumeTracks`.

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
    """Identities kept across losses and crossings, group ``reid`` of
    :class:`~pftrack_coast.volumes.VolumeTracks`.

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
    ``footprint`` of :class:`~pftrack_coast.volumes.VolumeTracks`.

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
