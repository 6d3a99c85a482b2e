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

The manager is a :class:`~pftrack.engine.lifecycle.LifecycleTracks` whose work is done by
lifecycle stages, each with a narrow contract, sharing one
:class:`~pftrack_coast.volume_book.VolumeBook` (the per-track state, keyed by engine target id):
:class:`~pftrack_coast.volume_groups.VolumeGroups` (initiator: the detection groups and the
tracks they start, as :class:`~pftrack.contracts.stages.Birth` decisions carrying particles),
:class:`~pftrack_coast.volume_stages.VolumeExits` (terminator),
:class:`~pftrack_coast.volume_stages.VolumeEstimator` (reporter: the estimates),
:class:`~pftrack_coast.volume_stages.VolumeMerger` (merger),
:class:`~pftrack_coast.volume_stages.VolumeEntries` (reporter: the footprint inside the volume)
and :class:`~pftrack_coast.volume_book.VolumeMasker` (masker: where particles may live, as
:class:`~pftrack.contracts.stages.Mask` decisions). No stage receives the engine. The manager
calls them in its own order and applies their decisions: before the predict step the groups
(started and spread on the first frame) and their masks; after the estimates the exits, the
estimates, the merges, the groups' new tracks and spreads, the new targets' masks, and the
entries test. It then learns the tracks' colours (``reid.appearance``), holds each new track's
records back until ``confirm_frames`` and gives the records their output ids
(:mod:`pftrack_coast.volume_identity`).
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
    Detections,
    Frame,
    Group,
    Param,
    RunContext,
    Target,
    TrackRecord,
)
from pftrack.contracts.stages import LifecycleStage, _frozen
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
    VolumeEntries,
    VolumeEstimator,
    VolumeExits,
    VolumeMerger,
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
        """The volumes resolved, the run's camera (else the observation model's, at the first
        frame), and the stages built."""
        self._start()
        if context.camera is not None:
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
        """The stages, all on one book: groups, exits, the estimator, the merger, entries and
        the masker."""
        self._start()
        b = self.book_
        return [VolumeGroups(b), VolumeExits(b), VolumeEstimator(b), VolumeMerger(b),
                VolumeEntries(b), VolumeMasker(b)]

    def stage(self, cls: type) -> Any:
        """The stage of class ``cls`` (e.g. ``stage(VolumeGroups)``)."""
        return next(s for s in self._stages() if type(s) is cls)

    def _camera(self, engine: Any) -> Camera:
        """The run's camera, else the observation model's (kept in the book)."""
        cam = self.book_.camera
        if cam is None:
            get = getattr(engine.observation, "get_camera", None)
            cam = get() if get is not None else None
            if cam is None:
                raise ValueError("tracks 'volumes': needs a camera (the run's, or the "
                                 "observation model's)")
            self.book_.camera = cam
        return cam

    # -- the hooks ----------------------------------------------------------------------------

    def before_frame(self, engine: Any, frame: Frame, detections: Detections | None) -> None:
        """The camera, then the stages (the groups start on the first frame)."""
        self._start()
        self._camera(engine)
        super().before_frame(engine, frame, detections)

    def end_target(self, target: Target) -> None:
        """The book forgets the target (an output track's id may be taken up again), then the
        stages are told."""
        self.book_.end(target.id)
        super().end_target(target)

    def after_frame(self, engine: Any, frame: Frame, detections: Detections | None,
                    records: list[TrackRecord], unmatched_detections: np.ndarray,
                    ) -> list[TrackRecord]:
        """Exits, estimates, merges, the groups' new tracks and spreads, the new targets' masks
        and the entries test (the stages, in that order), then the tracks' colours, the records
        held back until confirmed, and their output ids."""
        self._stages()
        book = self.book_
        models = self._models(engine)
        seen, seen_detections = self._read_only(frame, detections)
        unmatched = _frozen(np.asarray(unmatched_detections))

        def view() -> Any:
            return self._view(engine, seen, seen_detections, unmatched,  # type: ignore[arg-type]
                              frozenset(), models)

        by_id = {r.id: r for r in records}
        ended: set[int] = set()
        self._end(engine, self.stage(VolumeExits).terminate(view()), ended)
        v = view()
        estimates = self.stage(VolumeEstimator).report(v)
        hidden: set[int] = set()
        self._apply_outputs(estimates, by_id, hidden)
        out = [by_id[d.track_id] for d in estimates if d.track_id in by_id]
        merged: set[int] = set()
        self._end(engine, self.stage(VolumeMerger).merge(v), merged)
        out = [r for r in out if r.id not in merged]
        n = len(out)
        self._apply_births(engine, frame, self.stage(VolumeGroups).initiate(view()), out)
        born = {r.id: r for r in out[n:]}
        self._apply_outputs([book.outputs[i] for i in born], born, hidden)
        if int(self.confirm_frames) > 1:
            for tid in born:
                book.pending[tid] = []
        self._apply_masks(engine, view())
        for tid in list(book.boxes):
            if tid not in book.tracks:
                del book.boxes[tid]
        if self.reid.appearance:
            book.identities.appearance(frame, out, book.look, book.tracks)
        book.image = None  # (colour_share reads the frame while it is weighted, not after)
        hidden.update(h.track_id for h in self.stage(VolumeEntries).report(v))
        return book.identities.reidentified(
            self._confirmed([r for r in out if r.id not in hidden]), int(book.frame),
            book.tracks)

    def _confirmed(self, out: list[TrackRecord]) -> list[TrackRecord]:
        """The records to output: a track's from its entry on once it has lived
        ``confirm_frames`` frames."""
        n = int(self.confirm_frames)
        if n <= 1:
            return out
        pending = self.book_.pending
        shown = []
        for r in out:
            buf = pending.get(r.id)
            if buf is None:
                shown.append(r)
                continue
            buf.append(r)
            if len(buf) >= n:
                shown.extend(buf)
                del pending[r.id]
        return shown
