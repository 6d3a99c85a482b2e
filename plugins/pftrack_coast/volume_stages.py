"""What the ``volumes`` track manager (:mod:`pftrack_coast.volumes`) decides about its tracks each
frame, one stage per decision, all sharing one :class:`~pftrack_coast.volume_book.VolumeBook`:

* :class:`VolumeExits` (terminator): a track ends when no more than ``exit.particles`` (N_out) of
  its particles have likelihood above ``v_pi`` for ``exit.frames`` frames in a row;
* :class:`VolumeEstimator` (reporter): the coastal paper's estimate (eq. 8-10: the particles'
  weighted mean and 2 sqrt(variance) along the view's axes) and the support-plane correction
  (the footprint, size and image box each record carries), and the image boxes and gates the
  masks read;
* :class:`VolumeMerger` (merger): two tracks that are one intruder for ``merge.frames`` frames
  (by ``merge``: boxes, footprints, velocities) -- the younger ends (with ``reid.appearance``,
  the older on the younger's person takes up its output id first);
* :class:`VolumeEntries` (reporter): a track whose footprint lies outside its volume's ground
  footprint has not entered yet: its record is not output.

The detection groups and the tracks they start are :class:`~pftrack_coast.volume_groups.
VolumeGroups`; where particles may live, :class:`~pftrack_coast.volume_book.VolumeMasker`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pftrack.contracts.stages import (
    Birth,
    End,
    FrameView,
    Hide,
    Merger,
    OutputBox,
    Reporter,
    Terminator,
    TrackView,
)

from pftrack_coast.volume_book import VolumeBook
from pftrack_coast.volume_geometry import _axes, _finite_rows, cuboid_boxes
from pftrack_coast.volume_groups import current_pixels

__all__ = ["VolumeEntries", "VolumeEstimator", "VolumeExits", "VolumeMerger"]


class VolumeExits(Terminator):
    """Ends a track when no more than ``exit.particles`` (N_out) of its particles have
    likelihood above ``v_pi`` for ``exit.frames`` frames in a row (with ``exit.established``: a
    track that never had more than N_out counts as low below ``entry.particles``). Counts each
    track's particles above ``v_pi`` into the book (``VolumeBook.above``)."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    def terminate(self, view: FrameView) -> list[End]:
        book = self.book
        log_v = math.log(book.v_pi)
        live = {t.id: t for t in view.tracks}
        out = []
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
                book.events.append({"frame": int(book.frame), "id": tid,
                                    "volume": book.tracks[tid], "event": "exit"})
                out.append(End(tid, "left its volume"))
        return out


class VolumeEstimator(Reporter):
    """Each track's estimate of this frame (the module docstring): an :class:`OutputBox` per
    track (its box, footprint as ``world_m`` and size as ``size_m``), kept in the book's
    ``outputs``; one row per estimate in the book's ``estimates``; the track's image box,
    gate and typical-intruder boxes (``boxes``, ``gates``, ``look``, ``ahead``). A track that
    starts is estimated at once, from the particles it starts with."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    def report(self, view: FrameView) -> list[OutputBox]:
        """The estimates of the live tracks, in the order they started."""
        book = self.book
        book.outputs = {}
        live = {t.id: t for t in view.tracks}
        pos_dims = list(view.models.position_dims)
        for tid in list(book.tracks):
            t = live.get(tid)
            if t is not None:
                book.outputs[tid] = self.estimate(t, pos_dims, book.above.get(tid, 0))
        return list(book.outputs.values())

    def track_started(self, track: TrackView, birth: Birth) -> None:
        book = self.book
        if track.id in book.tracks and track.particles is not None:
            book.outputs[track.id] = self.estimate(track, list(book.position_dims),
                                                   book.above.get(track.id, 0))

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
    it is. Returns :class:`Hide` for the others, from the book's ``outputs``."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    def report(self, view: FrameView) -> list[Hide]:
        return [Hide(tid) for tid, o in self.book.outputs.items() if not self.inside(tid, o)]

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
