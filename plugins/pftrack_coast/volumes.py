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
  Intruders rest on a support plane (sea level, the ground: ``support_z_m``): the cloud's foot
  row on it fixes the distance, the cloud's image box the width across the view and the
  height, and a footprint prior the depth along the view, a rectangle whose long side
  (``footprint.aspect`` times the short one) points along the track's direction of travel on
  the plane (across the view when it has not moved ``footprint.min_travel_m``); see
  :mod:`pftrack_coast.volume_geometry`.

The manager's parts live in modules of their own, each re-exported here: the geometry
(:mod:`pftrack_coast.volume_geometry`), the colour histograms (:mod:`pftrack_coast.volume_colour`),
the parameter groups (:mod:`pftrack_coast.volume_params`), the tracks' footprints and headings
(:class:`~pftrack_coast.volume_footprint.TrackFootprints`) and their identities
(:class:`~pftrack_coast.volume_identity.VolumeIdentities`), the last two owned by the manager.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from pftrack.contracts.components import (
    Detections,
    Frame,
    Group,
    Param,
    RunContext,
    Target,
    TrackManager,
    TrackRecord,
)
from pftrack.geometry.volumes import CuboidVolume

from pftrack_coast.likelihood import InsideBoxesLikelihood, _blocks_of_pixels
from pftrack_coast.volume_colour import (
    HSV_BINS,
    bhattacharyya,
    hsv_bin_image,
    hsv_histogram,
    pixel_bins,
)
from pftrack_coast.volume_footprint import TrackFootprints
from pftrack_coast.volume_geometry import (
    _axes,
    _clip_into,
    _finite_rows,
    _support_base,
    _support_finish,
    cloud_box,
    cuboid_box,
    cuboid_boxes,
    cuboid_corners,
    footprint_size,
    support_plane_estimate,
)
from pftrack_coast.volume_identity import VolumeIdentities
from pftrack_coast.volume_params import (
    VolumeEntry,
    VolumeExit,
    VolumeFootprint,
    VolumeMask,
    VolumeMerge,
    VolumeReid,
)

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera
    from pftrack.geometry.volumes import Volume

__all__ = ["HSV_BINS", "InsideBoxesLikelihood", "VolumeEntry", "VolumeExit", "VolumeFootprint",
           "VolumeMask", "VolumeMerge", "VolumeReid", "VolumeTracks", "bhattacharyya",
           "cloud_box", "cuboid_box", "cuboid_boxes", "cuboid_corners", "footprint_size",
           "hsv_histogram", "support_plane_estimate"]


def _kernel(name: str) -> Any:
    """A compiled kernel of :mod:`pftrack_coast._kernels`, or None with ``PFTRACK_NO_JIT``
    (the numpy path then runs: the same numbers)."""
    from pftrack.filter import _jit

    if not _jit.ENABLED:
        return None
    from pftrack_coast import _kernels

    return getattr(_kernels, name)


class _Region:
    """A target's ``valid_region`` (a picklable callable): see
    :meth:`VolumeTracks._in_region`."""

    def __init__(self, manager: VolumeTracks, volume: Any, tid: int, mode: str) -> None:
        self.manager, self.volume, self.tid, self.mode = manager, volume, tid, mode

    def __call__(self, points: np.ndarray) -> np.ndarray:
        return self.manager._in_region(self.tid, self.volume, self.mode, points)


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
    footprints_ : TrackFootprints
        The tracks' footprint paths and headings (:mod:`pftrack_coast.volume_footprint`).
    identities_ : VolumeIdentities
        The tracks' output ids and colour templates (:mod:`pftrack_coast.volume_identity`).
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
        self.established_: set[int] = set()
        self.overlaps_: dict[tuple[int, int], int] = {}
        self.gates_: dict[int, np.ndarray] = {}
        self.targets_: dict[int, Target] = {}
        self.pending_: dict[int, list[TrackRecord]] = {}
        self.gather_: dict[int, int] = {}
        self.look_: dict[int, np.ndarray] = {}
        self.ahead_: dict[int, np.ndarray] = {}
        self.estimates_: list[dict[str, Any]] = []
        self.events_: list[dict[str, Any]] = []
        self.footprints_ = TrackFootprints(self.footprint)
        self.identities_ = VolumeIdentities(self.reid, self.estimates_, self.events_)

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
            self.bins_at_ = self.frame_
            self.bins_ = hsv_bin_image(self.__dict__.get("image_"), [
                g for g in self.gates_.values() if g is not None and np.isfinite(g).all()])
        return pixel_bins(self.bins_, px)

    def _colour_own(self, tid: int, px: np.ndarray) -> np.ndarray:
        """``mask.colour_share``: whether each pixel (N, 2) of track ``tid`` is its own by its
        colour against the templates of the tracks whose gates overlap its gate
        (:meth:`pftrack_coast.volume_identity.VolumeIdentities.colour_own`)."""
        return self.identities_.colour_own(tid, self._neighbours(tid), px, self._colour_bins,
                                           self.mask)

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

    def _estimate(self, engine: Any, frame: Frame, t: Target, record: TrackRecord,
                  n_above: int) -> TrackRecord:
        cam = self.camera_
        pos_dims = list(engine.motion.position_dims)
        pos = t.particles[:, pos_dims]
        px = self._current_pixels(t, pos)
        fine = _finite_rows(px)
        raw_centre = t.state[pos_dims].copy()
        est = None
        extra: dict[str, Any] = {}
        n_fine = int(np.count_nonzero(fine))
        if n_fine >= 2:  # (support_plane_estimate, the footprint along the track's heading)
            found = self.footprints_.estimate(
                t.id, cam, px if n_fine == len(px) else px[fine], float(self.support_z_m),
                t.state[3:5] if len(t.state) >= 6 else None,
                self.volumes_[self.tracks_[t.id]], float(self.entry.blob_block_px))
            if found is not None:
                est, extra["heading_deg"] = found
        across, along = _axes(cam, raw_centre[:2]) if est is None else \
            (est["across"], est["along"])
        # eq. 10 along the view's axes: the particles' (biased) variance along each axis
        axes = np.array([across, (0.0, 0.0, 1.0), along])
        var = np.zeros(3)
        if len(pos) > 1:
            proj = axes @ pos.T  # (3, N): rows, for fast reductions
            dev = proj - proj.mean(axis=1, keepdims=True)
            var = np.einsum("ij,ij->i", dev, dev) / len(pos)
        size_raw = 2.0 * np.sqrt(np.maximum(var, 0.0))
        entry = {"frame": frame.index, "id": self.identities_.output_id(t.id),
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
        path = self.footprints_.paths_[t.id]
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
        path = self.footprints_.paths_.get(tid)
        # an output track ends: its id may be taken up again (reid.frames, reid.distance_m)
        self.identities_.end(tid, int(self.__dict__.get("frame_", 0)),
                             path[-1] if tid in self.tracks_ and tid not in self.pending_
                             and path else None)
        self.footprints_.end(tid)
        self.established_.discard(tid)
        for d in (self.groups_, self.tracks_, self.idle_, self.low_, self.boxes_,
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
                        ids = self.identities_
                        if self.reid.appearance and out[i].id in ids.shown_ and \
                                out[j].id in ids.shown_ and \
                                ids.mismatch(frame, out[i], out[j], self.look_):
                            # the older is on the younger's person: it goes on under the
                            # younger's output id (and template); the older's id ends
                            ids.swap(frame, out[i].id, out[j].id, self.tracks_)
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
            self.identities_.appearance(frame, out, self.look_, self.tracks_)
        self.image_ = None  # (colour_share reads the frame while it is weighted, not after)
        return self.identities_.reidentified(
            self._confirmed([r for r in out if self._shown(r)]),
            int(self.__dict__.get("frame_", 0)), self.tracks_)

    def _velocity(self, tid: int) -> np.ndarray:
        """A track's footprint velocity (2,), metres per frame, over its last
        ``VolumeMerge.speed_frames`` footprints (NaN before it has that many)."""
        return self.footprints_.velocity(tid, int(self.merge.speed_frames))

    def _shown(self, record: TrackRecord) -> bool:
        """With ``footprint_inside``: whether the record's footprint lies inside its volume's
        ground footprint (a track whose particles see an intruder through the volume while
        the intruder is still outside it is not yet an entry)."""
        if not self.footprint_inside or record.world_m is None:
            return True
        if record.id in self.footprints_.held_:
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
            paths = self.footprints_.paths_
            if self.merge.distance_m is not None and paths:
                xy = np.array([p[-1] for p in paths.values() if p])
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
