"""Footprints of the ``volumes`` track manager's tracks (:mod:`pftrack_coast.volumes`): each
track's support-plane estimate (:func:`pftrack_coast.volume_geometry.support_plane_estimate`)
with the footprint prior's long side laid along the track's heading, and what the heading is
measured on.

A track's heading is the direction of its footprint's travel on the support plane over the last
``footprint.heading_frames`` frames once it exceeds ``footprint.min_travel_m``; with
``footprint.heading_from: top`` the travel of the particle cloud's top centre pixel put on the
plane is read while the footprint is held or has not travelled that far (a point at a constant
height moves there in the direction of the object); before either, the particles' mean
horizontal velocity once faster than ``VolumeFootprint.min_speed``. With ``footprint.held`` a
track's foot row may be held by its volume's near face (:meth:`TrackFootprints.hold`).

:class:`TrackFootprints` holds these paths for one run, keyed by engine target id; the
manager's :class:`~pftrack_coast.volume_book.VolumeBook` holds one, which the estimator stage
fills.
"""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING, Any

import numpy as np

from pftrack_coast.volume_geometry import _support_base, _support_finish

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera

    from pftrack_coast.volume_params import VolumeFootprint

__all__ = ["TrackFootprints"]


class TrackFootprints:
    """The footprint estimates of one run's tracks (engine target ids) and the paths their
    headings are measured on, for the ``volumes`` track manager.

    Parameters
    ----------
    footprint : VolumeFootprint
        The manager's ``footprint`` group.

    Attributes
    ----------
    paths_ : dict[int, deque]
        Track id -> its last ``footprint.heading_frames`` footprints (2,) on the support plane.
    tops_ : dict[int, deque]
        Track id -> its cloud's last top centre pixels put on the support plane (2,)
        (``heading_from: top``).
    held_ : set[int]
        Tracks whose foot row may be held by their volume (``footprint.held``).
    """

    def __init__(self, footprint: VolumeFootprint) -> None:
        self.footprint = footprint
        self.paths_: dict[int, deque] = {}
        self.tops_: dict[int, deque] = {}
        self.held_: set[int] = set()

    def end(self, tid: int) -> None:
        """Track ``tid`` ends: its paths are dropped."""
        self.held_.discard(tid)
        self.paths_.pop(tid, None)
        self.tops_.pop(tid, None)

    def estimate(self, tid: int, camera: Camera, px: np.ndarray, support_z_m: float,
                 velocity: np.ndarray | None, volume: Any, block_px: float,
                 ) -> tuple[dict[str, Any], float | None] | None:
        """Track ``tid``'s support-plane estimate from its particles' finite pixels ``px`` (N, 2)
        (:func:`~pftrack_coast.volume_geometry.support_plane_estimate`'s dict), the footprint's
        long side along the track's heading, and that heading (degrees from the across-view
        direction, None: not known); the footprint is appended to the track's path. None when
        the cloud's foot row misses the support plane. ``velocity``: the particles' mean
        horizontal velocity (2,), metres per time step (None: not in the state); ``volume`` and
        ``block_px``: the track's volume and the likelihood's block size, for
        ``footprint.held``."""
        base = _support_base(camera, px, float(support_z_m), 0.02, finite=True)
        if base is None:
            return None
        if self.footprint.heading_from == "top":
            self.add_top(tid, camera, base)
        if self.footprint.held:
            self.hold(tid, camera, base, volume, block_px)
        heading = self.heading(tid, base["across"], velocity)
        if float(self.footprint.aspect) != 1.0:  # (a square: the heading is moot)
            est = _support_finish(camera, base, aspect=float(self.footprint.aspect),
                                  heading_deg=heading)
        else:
            est = _support_finish(camera, base)
        path = self.paths_.setdefault(tid, deque(maxlen=int(self.footprint.heading_frames)))
        path.append(est["footprint_m"][:2].copy())
        return est, heading

    def heading(self, tid: int, across: np.ndarray, velocity: np.ndarray | None = None,
                ) -> float | None:
        """Degrees from the across-view direction ``across`` (3,) to the track's travel: its
        footprint's over the last heading_frames once it exceeds min_travel_m (heading_from
        'top': its cloud's top centre's on the support plane while the footprint is held or has
        not travelled that far), else its particles' mean horizontal ``velocity`` once faster
        than min_speed, else None."""
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

    def add_top(self, tid: int, camera: Camera, base: dict[str, Any]) -> None:
        """Append the cloud's top centre pixel, put on the support plane, to track ``tid``'s
        ``tops_`` (heading_from 'top'; nothing when that ray misses the plane). ``base``: the
        cloud's :func:`~pftrack_coast.volume_geometry._support_base`."""
        u0, v0, u1, _ = base["ends"]
        g = camera.image_to_ground(np.array([[0.5 * (u0 + u1), v0]]), z_m=base["z"])[0]
        if np.isfinite(g[:2]).all():
            self.tops_.setdefault(tid, deque(maxlen=int(self.footprint.heading_frames))).append(
                np.asarray(g[:2], dtype=np.float64))

    def hold(self, tid: int, camera: Camera, base: dict[str, Any], volume: Any,
             block_px: float) -> None:
        """``footprint.held``: track ``tid`` is in ``held_`` while the support-plane point of the
        first pixel row of the ``block_px`` cells (``VolumeEntry.blob_block_px``) below the cell
        row holding its cloud's foot (the cloud's 98 % row), in the cloud's middle column, lies
        outside its ``volume`` (the cloud may be cut there by the volume)."""
        u0, v0, u1, v1 = base["ends"]
        bs = float(block_px)
        row = (math.floor((v1 - 0.02 * (v1 - v0)) / bs) + 1.0) * bs + 0.5
        g = camera.image_to_ground(np.array([[0.5 * (u0 + u1), row]]), z_m=base["z"])[0]
        held = bool(np.isfinite(g).all()) and not bool(
            volume.contains(np.array([[g[0], g[1], float(volume.center_m[2])]]))[0])
        if held:
            self.held_.add(tid)
        else:
            self.held_.discard(tid)

    def velocity(self, tid: int, frames: int) -> np.ndarray:
        """Track ``tid``'s footprint velocity (2,), metres per frame, over its last ``frames``
        footprints (NaN before it has that many)."""
        path = self.paths_.get(tid)
        k = int(frames)
        if not path or len(path) <= k:
            return np.full(2, np.nan)
        return (path[-1] - path[-1 - k]) / k
