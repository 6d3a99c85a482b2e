"""What the ``volumes`` track manager (:mod:`pftrack_coast.volumes`) decides about its tracks each
frame, one stage per decision, all sharing one :class:`~pftrack_coast.volume_book.VolumeBook`
(in the order the runner, :class:`~pftrack.engine.lifecycle.LifecycleTracks`, calls them):

* :class:`VolumeCounts` (reporter, first): each track's particles with likelihood above
  ``v_pi``; a track leaves its volume when no more than ``exit.particles`` (N_out) of them are
  for ``exit.frames`` frames in a row;
* :class:`VolumeEstimator` (reporter): the coastal paper's estimate (eq. 8-10: the particles'
  weighted mean and 2 sqrt(variance) along the view's axes) and the support-plane correction
  (the footprint, size and image box each record carries) of the tracks that stay, and the
  image boxes and gates the masks read; the other targets (detection groups, tracks leaving)
  are not output;
* :class:`VolumeEntries` (reporter): a track whose footprint lies outside its volume's ground
  footprint has not entered yet: its record is not output;
* :class:`VolumeConfirmer` (confirmer, with ``confirm_frames`` above 1): a new track's records
  are held back until it has been output ``confirm_frames`` frames, then output from its entry
  on, at the end of the frame if it is still live;
* :class:`VolumeExits` (terminator): the tracks leaving their volumes end;
* :class:`VolumeMerger` (merger): two tracks that are one intruder for ``merge.frames`` frames
  (by ``merge``: boxes, footprints, velocities) -- the younger ends (with ``reid.appearance``,
  the older on the younger's person takes up its output id first);
* :class:`VolumeReidentifier` (reidentifier, last): the tracks' colour templates learnt
  (``reid.appearance``), and each output record's id (re-identification, swaps).

The detection groups and the tracks they start are :class:`~pftrack_coast.volume_groups.
VolumeGroups` (initiator); where particles may live,
:class:`~pftrack_coast.volume_book.VolumeMasker` (masker).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pftrack.contracts.stages import (
    Birth,
    Confirm,
    Confirmer,
    End,
    FrameView,
    Hide,
    Merger,
    OutputAs,
    OutputBox,
    Reidentifier,
    Reporter,
    Terminator,
    TrackView,
)

from pftrack_coast.volume_book import VolumeBook
from pftrack_coast.volume_geometry import _axes, _finite_rows, cuboid_boxes
from pftrack_coast.volume_groups import current_pixels

__all__ = ["VolumeConfirmer", "VolumeCounts", "VolumeEntries", "VolumeEstimator", "VolumeExits",
           "VolumeMerger", "VolumeReidentifier"]


class VolumeCounts(Reporter):
    """Counts each track's particles with likelihood above ``v_pi`` into the book
    (``VolumeBook.above``) and says which tracks leave their volumes in this frame
    (``VolumeBook.leaving``): those with no more than ``exit.particles`` (N_out) above for
    ``exit.frames`` frames in a row (with ``exit.established``: a track that never had more
    than N_out counts as low below ``entry.particles``). The first reporter: the estimator
    leaves the leaving tracks out, :class:`VolumeExits` ends them. Returns no decisions."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    def report(self, view: FrameView) -> list[Hide]:
        book = self.book
        log_v = math.log(book.v_pi)
        live = {t.id: t for t in view.tracks}
        book.leaving = set()
        for tid in list(book.tracks):
            t = live.get(tid)
            if t is None:
                continue
            ll = t.log_likelihoods
            n_above = 0 if ll is None else int(np.count_nonzero(ll > log_v))
            book.above[tid] = n_above
            if n_above > int(book.exit.particles):
                book.established.add(tid)
            low = book.exit.low(n_above, tid in book.established, book.entry.particles)
            book.low[tid] = book.low.get(tid, 0) + 1 if low else 0
            if book.low[tid] >= int(book.exit.frames):
                book.leaving.add(tid)
        return []


class VolumeExits(Terminator):
    """Ends the tracks that leave their volumes in this frame (:class:`VolumeCounts` says
    which), their records of this frame withdrawn."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    def terminate(self, view: FrameView) -> list[End]:
        book = self.book
        out = []
        for tid in list(book.tracks):
            if tid in book.leaving:
                book.events.append({"frame": int(book.frame), "id": tid,
                                    "volume": book.tracks[tid], "event": "exit"})
                out.append(End(tid, "left its volume"))
        return out


class VolumeEstimator(Reporter):
    """Each track's estimate of this frame (the module docstring): an :class:`OutputBox` per
    track that stays in its volume (its box, footprint as ``world_m`` and size as ``size_m``),
    kept in the book's ``outputs``; one row per estimate in the book's ``estimates``; the
    track's image box, gate and typical-intruder boxes (``boxes``, ``gates``, ``look``,
    ``ahead``). The other live targets, detection groups and the tracks leaving
    (``VolumeBook.leaving``), have no estimate and are not output (:class:`Hide`). A track that
    starts is estimated at once, from the particles it starts with, and its first record
    carries that estimate."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    def report(self, view: FrameView) -> list[OutputBox | Hide]:
        """The estimates of the live tracks that stay, in the order they started, then the
        other live targets hidden."""
        book = self.book
        book.outputs = {}
        live = {t.id: t for t in view.tracks}
        pos_dims = list(view.models.position_dims)
        for tid in list(book.tracks):
            t = live.get(tid)
            if t is not None and tid not in book.leaving:
                book.outputs[tid] = self.estimate(t, pos_dims, book.above.get(tid, 0))
        out: list[OutputBox | Hide] = list(book.outputs.values())
        out += [Hide(tid) for tid in live if tid not in book.outputs]
        return out

    def track_started(self, track: TrackView, birth: Birth) -> None:
        book = self.book
        if track.id in book.tracks and track.particles is not None:
            book.outputs[track.id] = self.estimate(track, list(book.position_dims),
                                                   book.above.get(track.id, 0))

    def report_started(self, track: TrackView, birth: Birth) -> list[OutputBox]:
        o = self.book.outputs.get(track.id)
        return [] if o is None else [o]

    def estimate(self, t: TrackView, pos_dims: list[int], n_above: int) -> OutputBox:
        """Track ``t``'s estimate (see the class docstring); ``n_above``: its particles above
        ``v_pi``, for the estimates' row."""
        book = self.book
        cam = book.camera
        assert cam is not None and t.particles is not None
        pos = t.particles[:, pos_dims]
        px = current_pixels(book, t, pos)
        fine = _finite_rows(px)
        raw_centre = t.state[pos_dims].copy()
        est = None
        extra: dict[str, Any] = {}
        n_fine = int(np.count_nonzero(fine))
        if n_fine >= 2:  # (support_plane_estimate, the footprint along the track's heading)
            found = book.footprints.estimate(
                t.id, cam, px if n_fine == len(px) else px[fine], book.support_z_m,
                t.state[3:5] if len(t.state) >= 6 else None,
                book.volumes[book.tracks[t.id]], float(book.entry.blob_block_px))
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
        entry = {"frame": int(book.frame), "id": book.identities.output_id(t.id),
                 "volume": book.tracks[t.id],
                 "centre_raw_m": raw_centre, "size_raw_m": size_raw, "n_above": int(n_above),
                 **extra}
        if est is None:  # no footprint: the particles' mean, put on the support plane
            book.boxes[t.id] = t.box_xywh_px.copy()
            book.estimates.append(entry)
            return OutputBox(t.id, t.box_xywh_px.copy(),
                             world_m=np.array([raw_centre[0], raw_centre[1], book.support_z_m]))
        path = book.footprints.paths_[t.id]
        entry.update(footprint_m=est["footprint_m"], size_m=est["size_m"])
        # the estimate's cuboid, and with a typical size: the one on the footprint and where
        # the footprint goes next (its mean displacement over the last few frames), one call
        centres, sizes = [est["centre_m"]], [est["size_m"]]
        if book.object_size_m is not None:
            size = np.asarray(book.object_size_m, dtype=np.float64)
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
        shown = boxes[0] if np.isfinite(boxes[0]).all() else t.box_xywh_px.copy()
        box = shown.copy()
        if book.object_size_m is not None and np.isfinite(boxes[1]).all():
            prior = boxes[1]
            book.look[t.id] = prior  # (appearance: a typical intruder on the footprint)
            ahead = boxes[2] if np.isfinite(boxes[2]).all() else prior
            book.ahead[t.id] = ahead
            if book.mask.gate_margin is not None:
                lo = np.minimum(prior[:2], ahead[:2])
                hi = np.maximum(prior[:2] + prior[2:], ahead[:2] + ahead[2:])
                g = float(book.mask.gate_margin)
                book.gates[t.id] = np.concatenate([lo - g * prior[2:],
                                                   hi - lo + 2.0 * g * prior[2:]])
            lo = np.minimum(box[:2], prior[:2])
            hi = np.maximum(box[:2] + box[2:], prior[:2] + prior[2:])
            box = np.concatenate([lo, hi - lo])
        book.boxes[t.id] = box
        book.estimates.append(entry)
        return OutputBox(t.id, shown, world_m=est["footprint_m"].copy(),
                         size_m=est["size_m"].copy())


class VolumeMerger(Merger):
    """One intruder tracked twice: two tracks that ``merge`` says are one (boxes overlapping by
    more than ``merge.iou``, footprints closer than ``merge.distance_m``, unless moving apart
    faster than ``merge.speed_m``) for ``merge.frames`` frames in a row -- the younger ends.
    With ``reid.appearance``, when the older's colour template matches its region worse than
    the younger's, the older is on the younger's person: it takes up the younger's output id
    (and template) first. Reads this frame's estimates from the book (``outputs``)."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    def merge(self, view: FrameView) -> list[End]:
        book = self.book
        out = [o for tid, o in book.outputs.items() if tid in book.tracks]
        overlaps: dict[tuple[int, int], int] = {}
        ends = []
        if len(out) > 1:
            merge = book.merge
            xy = v = None
            if merge.distance_m is not None:
                xy = np.array([o.world_m[:2] if o.world_m is not None else (np.nan, np.nan)
                               for o in out])
            if merge.speed_m is not None:
                v = np.array([book.footprints.velocity(o.track_id, int(merge.speed_frames))
                              for o in out])
            same = merge.same(np.array([o.box_xywh_px for o in out]), xy, v)
            drop: set[int] = set()
            ids_of = [o.track_id for o in out]
            order = sorted(range(len(out)), key=lambda i: ids_of[i])  # older first
            boxes = {o.track_id: o.box_xywh_px for o in out}
            for a_i, i in enumerate(order):
                if ids_of[i] in drop:
                    continue
                for j in order[a_i + 1:]:
                    if ids_of[j] in drop or not same[i, j]:
                        continue
                    key = (ids_of[i], ids_of[j])
                    overlaps[key] = book.overlaps.get(key, 0) + 1
                    if overlaps[key] >= int(merge.frames):
                        ids = book.identities
                        if book.reid.appearance and ids_of[i] in ids.shown_ and \
                                ids_of[j] in ids.shown_ and \
                                ids.mismatch(view.frame, ids_of[i], ids_of[j], boxes, book.look):
                            # the older is on the younger's person: it goes on under the
                            # younger's output id (and template); the older's id ends
                            ids.swap(view.frame, ids_of[i], ids_of[j], book.tracks)
                        drop.add(ids_of[j])
            for tid in drop:
                book.events.append({"frame": int(book.frame), "id": tid,
                                    "volume": book.tracks[tid], "event": "merged"})
                ends.append(End(tid, "duplicate"))
        book.overlaps = overlaps
        return ends


class VolumeEntries(Reporter):
    """With ``footprint_inside``: a track's record is output only while its footprint (the
    support-plane correction) lies inside its volume's ground footprint, and not while the
    footprint is held by the volume's near face (``footprint.held``) -- one view sees an
    intruder through the volume before it enters and after it leaves; its footprint says where
    it is. Returns :class:`Hide` for the others, from the book's ``outputs`` (after
    :class:`VolumeEstimator`), and keeps in the book which tracks are hidden in this frame
    (``hidden``), in how many frames each was not (``shown``) and its first such frame
    (``first_shown``)."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    def report(self, view: FrameView) -> list[Hide]:
        book = self.book
        book.hidden = {tid for tid, o in book.outputs.items() if not self.inside(tid, o)}
        for tid, o in book.outputs.items():
            if tid not in book.hidden:
                self._shown(tid, o)
        return [Hide(tid) for tid in book.hidden]

    def report_started(self, track: TrackView, birth: Birth) -> list[Hide]:
        o = self.book.outputs.get(track.id)
        if o is None:
            return []
        if not self.inside(track.id, o):
            self.book.hidden.add(track.id)
            return [Hide(track.id)]
        self._shown(track.id, o)
        return []

    def _shown(self, tid: int, output: OutputBox) -> None:
        """Track ``tid``'s record of this frame (estimate ``output``) is not hidden."""
        book = self.book
        book.shown[tid] = book.shown.get(tid, 0) + 1
        if tid not in book.first_shown:
            w = output.world_m
            book.first_shown[tid] = (int(book.frame), None if w is None else w.copy())

    def inside(self, tid: int, output: OutputBox) -> bool:
        """Whether track ``tid``'s estimate ``output`` has entered its volume."""
        book = self.book
        if not book.footprint_inside or output.world_m is None:
            return True
        if tid in book.footprints.held_:
            return False
        vol = book.volumes[book.tracks[tid]] if tid in book.tracks else None
        if vol is None:
            return True
        p = np.array([[output.world_m[0], output.world_m[1], float(vol.center_m[2])]])
        return bool(vol.contains(p)[0])


class VolumeConfirmer(Confirmer):
    """A new track is output once it has been shown (not hidden, :class:`VolumeEntries`) in
    ``frames`` frames: its records from its entry on, at the end of that frame and only if it
    is still live then (:class:`~pftrack.contracts.stages.Confirm` ``at_end``: one that exits or
    merges in that frame was noise and is never output). Its records hidden while it waits are
    dropped (``holds_hidden`` False). Detection groups are not tentative. The tracks waiting
    are the book's ``pending``."""

    holds_hidden = False

    def __init__(self, book: VolumeBook, frames: int) -> None:
        self.book = book
        self.frames = int(frames)

    def tentative(self, birth: Birth) -> bool:
        return self.book.births.get(id(birth), ("",))[0] == "track"

    def track_started(self, track: TrackView, birth: Birth) -> None:
        if track.tentative and track.id in self.book.tracks:
            self.book.pending.add(track.id)

    def confirm(self, view: FrameView) -> list[Confirm]:
        book = self.book
        out = []
        for tid in sorted(book.pending):
            if book.shown.get(tid, 0) >= self.frames:
                book.pending.discard(tid)
                out.append(Confirm(tid, at_end=True))
        return out


class VolumeReidentifier(Reidentifier):
    """Last each frame: with ``reid.appearance`` the tracks' colour histograms of this frame's
    estimates, their templates and the swaps of two tracks that were together
    (:meth:`~pftrack_coast.volume_identity.VolumeIdentities.appearance_of`); then the tracks
    output for the first time take up the ids of tracks that ended near them
    (:meth:`~pftrack_coast.volume_identity.VolumeIdentities.reidentify`), and every track
    output under an id not its own is told so (:class:`~pftrack.contracts.stages.OutputAs`)."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    def observe(self, view: FrameView) -> list[OutputAs]:
        book = self.book
        ids = book.identities
        if book.reid.appearance:
            est = {tid: o for tid, o in book.outputs.items() if tid in book.tracks}
            ids.appearance_of(view.frame, {tid: o.box_xywh_px for tid, o in est.items()},
                              {tid: o.world_m for tid, o in est.items()}, book.look,
                              book.tracks)
        book.image = None  # (colour_share reads the frame while it is weighted, not after)
        shown = [t.id for t in view.tracks if not t.tentative and t.id in book.tracks
                 and t.id not in book.hidden and t.id in book.first_shown]
        ids.reidentify({tid: book.first_shown[tid] for tid in shown if tid not in ids.shown_},
                       int(book.frame), book.tracks)
        return [OutputAs(tid, oid) for tid, oid in ids.alias_.items()]
