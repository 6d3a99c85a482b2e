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

The manager is a :class:`~pftrack.engine.lifecycle.LifecycleTracks`: a fixed list of lifecycle
stages, each with a narrow contract, sharing one :class:`~pftrack_coast.volume_book.VolumeBook`
(the per-track state, keyed by engine target id), which the generic runner calls in its
documented order and whose decisions it applies; no stage receives the engine. Before the
predict step: :class:`~pftrack_coast.volume_groups.VolumeGroups` (initiator: on the first frame
the detection groups, as :class:`~pftrack.contracts.stages.Birth` decisions spread through their
volumes) and :class:`~pftrack_coast.volume_book.VolumeMasker` (masker: where particles may live,
as :class:`~pftrack.contracts.stages.Mask` decisions). After the estimates, the reporters
:class:`~pftrack_coast.volume_stages.VolumeCounts` (the particles above ``v_pi``: which tracks
leave), :class:`~pftrack_coast.volume_stages.VolumeEstimator` (the estimates; the groups and the
leaving tracks are not output) and :class:`~pftrack_coast.volume_stages.VolumeEntries` (the
footprint inside the volume); :class:`~pftrack_coast.volume_stages.VolumeConfirmer` (confirmer,
with ``confirm_frames`` above 1: a new track's records held back until it has been shown that
many frames); :class:`~pftrack_coast.volume_stages.VolumeExits` (terminator);
:class:`~pftrack_coast.volume_stages.VolumeMerger` (merger); the groups' new tracks and spreads
(:class:`~pftrack.contracts.stages.Birth` decisions carrying particles,
:class:`~pftrack.contracts.stages.Particles`), each new track's first record carrying its
estimate; the new targets' masks; and last
:class:`~pftrack_coast.volume_stages.VolumeReidentifier` (reidentifier: the tracks' colours with
``reid.appearance``, and the records' output ids as
:class:`~pftrack.contracts.stages.OutputAs` decisions, :mod:`pftrack_coast.volume_identity`).
The geometry (:mod:`pftrack_coast.volume_geometry`), the colour histograms
(:mod:`pftrack_coast.volume_colour`), the parameter groups (:mod:`pftrack_coast.volume_params`)
and the tracks' footprints (:mod:`pftrack_coast.volume_footprint`) live in modules of their own,
their public names re-exported here.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from pftrack.contracts.components import (
    Group,
    Param,
    RunContext,
    Target,
)
from pftrack.contracts.stages import LifecycleStage
from pftrack.engine.lifecycle import LifecycleTracks

from pftrack_coast.likelihood import InsideBoxesLikelihood
from pftrack_coast.volume_book import VolumeBook, VolumeMasker, _kernel
from pftrack_coast.volume_colour import HSV_BINS, bhattacharyya, hsv_histogram
from pftrack_coast.volume_geometry import (
    cloud_box,
    cuboid_box,
    cuboid_boxes,
    cuboid_corners,
    footprint_size,
    support_plane_estimate,
)
from pftrack_coast.volume_groups import VolumeGroups
from pftrack_coast.volume_params import (
    VolumeEntry,
    VolumeExit,
    VolumeFootprint,
    VolumeMask,
    VolumeMerge,
    VolumeReid,
)
from pftrack_coast.volume_stages import (
    VolumeConfirmer,
    VolumeCounts,
    VolumeEntries,
    VolumeEstimator,
    VolumeExits,
    VolumeMerger,
    VolumeReidentifier,
)

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera
    from pftrack.geometry.volumes import Volume

    from pftrack_coast.volume_footprint import TrackFootprints
    from pftrack_coast.volume_identity import VolumeIdentities

__all__ = ["HSV_BINS", "InsideBoxesLikelihood", "VolumeEntry", "VolumeExit", "VolumeFootprint",
           "VolumeMask", "VolumeMerge", "VolumeReid", "VolumeTracks", "bhattacharyya",
           "cloud_box", "cuboid_box", "cuboid_boxes", "cuboid_corners", "footprint_size",
           "hsv_histogram", "support_plane_estimate"]


def _shared(name: str, doc: str) -> Any:
    """A manager attribute that is the book's ``name`` (read and set through it)."""

    def get(self: VolumeTracks) -> Any:
        self._start()
        return getattr(self.book_, name)

    def set_(self: VolumeTracks, value: Any) -> None:
        self._start()
        setattr(self.book_, name, value)

    return property(get, set_, doc=doc)


class VolumeTracks(LifecycleTracks):
    """The coastal paper's entry / exit detection in cuboid volumes, for several intruders at once.

    Its parameters are grouped by what they decide: ``entry`` (:class:`VolumeEntry`), ``exit``
    (:class:`VolumeExit`), ``mask`` (:class:`VolumeMask`), ``merge`` (:class:`VolumeMerge`),
    ``reid`` (:class:`VolumeReid`) and ``footprint`` (:class:`VolumeFootprint`), each a
    parameter group given as a mapping (keys left out take their defaults), e.g. ``merge:
    {iou: 0.5, frames: 3}``.

    {params}

    Attributes
    ----------
    book_ : VolumeBook
        The state the stages share (:mod:`pftrack_coast.volume_book`); the attributes below
        are its entries.
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

    volumes_: dict[str, Any] = _shared("volumes", "The detection volumes by name.")
    camera_: Camera = _shared("camera", "The run's camera.")
    groups_: dict[int, str] = _shared("groups", "Live detection groups: id -> volume.")
    tracks_: dict[int, str] = _shared("tracks", "Live tracks: id -> volume.")
    boxes_: dict[int, np.ndarray] = _shared("boxes", "Each track's image box the groups avoid.")
    gates_: dict[int, np.ndarray] = _shared("gates", "Each track's gate (4,) xywh px.")
    look_: dict[int, np.ndarray] = _shared("look", "A typical intruder's box on a footprint.")
    estimates_: list[dict[str, Any]] = _shared("estimates", "One row per estimate.")
    events_: list[dict[str, Any]] = _shared("events", "Entries, exits, merges, id changes.")
    footprints_: TrackFootprints = _shared("footprints", "The tracks' footprints.")
    identities_: VolumeIdentities = _shared("identities", "The tracks' output ids.")
    frame_: int = _shared("frame", "The frame being tracked.")
    image_: np.ndarray | None = _shared("image", "The frame's image while it is tracked.")

    def setup(self, context: RunContext) -> None:
        """The volumes resolved, the run's camera taken, and the stages built."""
        self._start()
        if context.camera is None:
            raise ValueError("tracks 'volumes': needs the run's camera (--camera PATH, or a "
                             "camera given to the observation model)")
        self.book_.camera = context.camera
        super().setup(context)
        if _kernel("region_mask") is not None:
            from pftrack_coast._kernels import warm_up

            warm_up()  # before the first frame

    def _check_relations(self) -> None:
        if self.mask.colour_share and not self.reid.appearance:
            raise ValueError("tracks 'volumes': mask.colour_share needs reid.appearance: true "
                             "(it reads the tracks' colour templates)")

    def _start(self) -> None:
        """The volumes resolved and the per-run state made, once."""
        if "book_" in self.__dict__:
            return
        from pftrack.geometry.volumes import (
            CuboidVolume,
            Volume,
            _volume_from_dict,
            load_volumes,
            resolve_volume,
        )

        specs = [self.volumes] if isinstance(self.volumes, str) or \
            not isinstance(self.volumes, (list, tuple)) else list(self.volumes)
        vols: dict[str, Any] = {}
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
        self.book_ = VolumeBook(
            vols, v_pi=self.v_pi, object_size_m=self.object_size_m,
            support_z_m=self.support_z_m, footprint_inside=self.footprint_inside,
            entry=self.entry, exit=self.exit, mask=self.mask, merge=self.merge,
            reid=self.reid, footprint=self.footprint)

    def build_stages(self) -> list[LifecycleStage]:
        """The stages, all on one book: the groups, the counts, the estimator, the entries,
        the confirmer (``confirm_frames`` above 1), the exits, the merger, the masker and the
        reidentifier (the reporters run in this order)."""
        self._start()
        b = self.book_
        confirm: list[LifecycleStage] = [] if int(self.confirm_frames) <= 1 else \
            [VolumeConfirmer(b, int(self.confirm_frames))]
        return [VolumeGroups(b), VolumeCounts(b), VolumeEstimator(b), VolumeEntries(b),
                *confirm, VolumeExits(b), VolumeMerger(b), VolumeMasker(b),
                VolumeReidentifier(b)]

    def stage(self, cls: type) -> Any:
        """The stage of class ``cls`` (e.g. ``stage(VolumeGroups)``)."""
        return next(s for s in self._stages() if type(s) is cls)

    def end_target(self, target: Target) -> None:
        """The book forgets the target (an output track's id may be taken up again), then the
        stages are told."""
        self.book_.end(target.id)
        super().end_target(target)
