"""Identities of the ``volumes`` track manager's tracks (:mod:`pftrack_coast.volumes`): the
output id of each track, its colour template, and the rules that change output ids.

* **re-identification** (``reid.frames``, ``reid.distance_m``): a track output for the first time
  whose footprint lies near where an output track ended a few frames before takes up that
  track's id (with ``reid.appearance``: of the ended ids near enough, the one whose template
  matches best);
* **appearance** (``reid.appearance``): each track's HSV colour histogram of its image region,
  its template updated while no other track is within ``VolumeReid.near_m``; two tracks that
  were together and have separated swap output ids when the swapped histograms match their
  templates better; two tracks on one intruder merge with the older ending when its template
  matches its region worse;
* **colour share** (``mask.colour_share``): which of a track's pixels a neighbouring track's
  template claims by their colour.

:class:`VolumeIdentities` holds this state for one run, keyed by engine target id; the
manager's :class:`~pftrack_coast.volume_book.VolumeBook` holds one: the merger stage asks it
which of two tracks on one intruder goes on, and the reidentifier stage
(:class:`~pftrack_coast.volume_stages.VolumeReidentifier`) learns the templates and gives the
output records their ids through it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from pftrack.contracts.components import Frame

from pftrack_coast.volume_colour import bhattacharyya, hsv_histogram

if TYPE_CHECKING:
    from pftrack_coast.volume_params import VolumeMask, VolumeReid

__all__ = ["VolumeIdentities"]


class VolumeIdentities:
    """Output ids and colour templates of one run's tracks (engine target ids), for the ``volumes``
    track manager.

    Parameters
    ----------
    reid : VolumeReid
        The manager's ``reid`` group.
    estimates : list of dict
        The manager's ``estimates_``: a track's estimates are renamed in it when its output id
        changes.
    events : list of dict
        The manager's ``events_``: "reidentified" and "swapped" events are appended to it.

    Attributes
    ----------
    alias_ : dict[int, int]
        Track id -> output id, for the tracks whose output id is not their own.
    shown_ : set[int]
        Tracks output at least once.
    ended_ : list of tuple
        ``(frame, output id, footprint (2,))`` of the output tracks that ended, whose ids may be
        taken up again.
    templates_ : dict[int, tuple[ndarray, int]]
        Track id -> (colour template, frames alone it was updated on).
    ended_templates_ : dict[int, tuple[ndarray, int]]
        Output id -> the template of an ended track.
    together_ : set[tuple[int, int]]
        Pairs of tracks (ascending ids) whose footprints were together.
    hists_ : dict[int, ndarray]
        Output id -> this frame's histogram of the track's region.
    """

    def __init__(self, reid: VolumeReid, estimates: list[dict[str, Any]],
                 events: list[dict[str, Any]]) -> None:
        self.reid = reid
        self.estimates = estimates
        self.events = events
        self.alias_: dict[int, int] = {}
        self.shown_: set[int] = set()
        self.ended_: list[tuple[int, int, np.ndarray]] = []
        self.templates_: dict[int, tuple[np.ndarray, int]] = {}
        self.ended_templates_: dict[int, tuple[np.ndarray, int]] = {}
        self.together_: set[tuple[int, int]] = set()
        self.hists_: dict[int, np.ndarray] = {}

    def output_id(self, tid: int) -> int:
        """The id track ``tid`` is output under."""
        return self.alias_.get(tid, tid)

    def end(self, tid: int, now: int, footprint_xy: np.ndarray | None) -> None:
        """Track ``tid`` ends at frame ``now``; ``footprint_xy``: its last footprint when it was
        a confirmed track (None: a detection group, or a track never confirmed or without a
        footprint). An output track's id (and template) may then be taken up again."""
        if footprint_xy is not None and tid in self.shown_:
            self.ended_.append((now, self.alias_.get(tid, tid),
                                np.array(footprint_xy, dtype=float)))
            if tid in self.templates_:
                self.ended_templates_[self.alias_.get(tid, tid)] = self.templates_[tid]
        self.templates_.pop(tid, None)
        self.alias_.pop(tid, None)
        self.shown_.discard(tid)

    def reidentify(self, first: Mapping[int, tuple[int, np.ndarray | None]], now: int,
                   volumes: Mapping[int, str]) -> None:
        """Frame ``now``'s tracks output for the first time (``first``: track id -> the frame
        and ground position (3,), metres, of its first output record): one whose footprint lies
        within ``reid.distance_m`` of where an output track ended at most ``reid.frames``
        frames before frame ``now`` takes up that track's id (the nearest; each id once; its
        output id is then :meth:`output_id`). ``volumes``: track id -> volume name, for the
        events."""
        n, r_m = int(self.reid.frames), float(self.reid.distance_m)
        if n > 0 and self.ended_:
            self.ended_ = [e for e in self.ended_ if now - e[0] <= n]
        new = sorted(tid for tid in first if tid not in self.shown_)
        for tid in new:
            self.shown_.add(tid)
            if n <= 0 or not self.ended_:
                continue
            frame, world_m = first[tid]
            if world_m is None:
                continue
            # (a track confirmed late outputs from its entry on: only ids ended by then)
            xy = np.array([e[2] for e in self.ended_])
            d = np.hypot(xy[:, 0] - world_m[0], xy[:, 1] - world_m[1])
            d[np.array([e[0] > frame for e in self.ended_])] = np.inf
            k = int(np.argmin(d))
            if self.reid.appearance and d[k] <= r_m:  # of the ids within reid_m: the best match
                k = self._best_match(tid, d, r_m, k)
            if d[k] <= r_m:
                self.alias_[tid] = self.ended_.pop(k)[1]
                self.events.append({"frame": frame, "id": tid, "volume":
                                    volumes.get(tid), "event": "reidentified",
                                    "as": self.alias_[tid]})
                self._rename_estimates(tid, self.alias_[tid], frame)

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

    def appearance_of(self, frame: Frame, boxes: Mapping[int, np.ndarray],
                      world: Mapping[int, np.ndarray | None], look: Mapping[int, np.ndarray],
                      volumes: Mapping[int, str]) -> None:
        """Histograms of this frame's tracks (``boxes``: track id -> its estimate's image box
        (4,) xywh px; ``world``: its ground position (3,), metres, or None; ``look``: track
        id -> the image box of a typical intruder on its footprint, read instead of its box
        when given); templates updated for tracks alone; pairs that were together and have
        separated swap output ids when appearance says so (``volumes``: track id -> volume
        name, for the events)."""
        self.hists_ = {}
        for tid, b in boxes.items():
            h = self._hist(frame, tid, b, look)
            if h is not None:
                self.hists_[tid] = h
        xy = {tid: w[:2] for tid, w in world.items() if w is not None}
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
        box = boxes
        for a, b in sorted(self.together_ - together):
            if a not in pos or b not in pos:
                continue
            ba, bb = box[a], box[b]
            disjoint = bool(np.any(ba[:2] + ba[2:] <= bb[:2])
                            or np.any(bb[:2] + bb[2:] <= ba[:2]))
            if d[pos[a], pos[b]] < apart * near or not disjoint:
                together.add((a, b))  # not apart yet: still together
                continue
            self._maybe_swap(frame, a, b, volumes)
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

    def _hist(self, frame: Frame, tid: int, box_xywh_px: np.ndarray,
              look: Mapping[int, np.ndarray]) -> np.ndarray | None:
        """HSV histogram of track ``tid``'s region: its box in ``look`` (the image box of a
        typical intruder, ``object_size_m``, on its footprint), else ``box_xywh_px`` (its
        record's box)."""
        box = look.get(tid, box_xywh_px)
        return hsv_histogram(frame.image, box, inner=float(self.reid.inner))

    def mismatch(self, frame: Frame, older: int, younger: int,
                 boxes: Mapping[int, np.ndarray], look: Mapping[int, np.ndarray]) -> bool:
        """Two tracks on one intruder merge: whether the older's template matches its region
        worse (by ``VolumeReid.margin``) than the younger's matches its own (the older ends
        then, not the younger). ``boxes``: track id -> its output box of this frame (4,) xywh
        px. False when either template is not ready."""
        n = int(self.reid.min_frames)
        costs = []
        for tid in (older, younger):
            tpl = self.templates_.get(tid)
            h = self._hist(frame, tid, boxes[tid], look)
            if tpl is None or tpl[1] < n or h is None:
                return False
            costs.append(float(bhattacharyya(h, tpl[0])))
        return costs[0] > costs[1] + float(self.reid.margin)

    def _maybe_swap(self, frame: Frame, a: int, b: int, volumes: Mapping[int, str]) -> None:
        """Tracks ``a`` and ``b`` swap (:meth:`swap`) when both were output, their templates are
        ready, and the swapped histograms match the templates better by ``VolumeReid.margin``."""
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
        self.swap(frame, a, b, volumes)

    def swap(self, frame: Frame, a: int, b: int, volumes: Mapping[int, str]) -> None:
        """Tracks ``a`` and ``b`` exchange their output ids and templates (``volumes``: track
        id -> volume name, for the event)."""
        oa, ob = self.alias_.get(a, a), self.alias_.get(b, b)
        self.alias_[a], self.alias_[b] = ob, oa
        ta, tb = self.templates_.pop(a, None), self.templates_.pop(b, None)
        if tb is not None:
            self.templates_[a] = tb
        if ta is not None:
            self.templates_[b] = ta
        for e in reversed(self.estimates):  # this frame's estimates under the new ids
            if e["frame"] < frame.index:
                break
            if e["id"] in (oa, ob):
                e["id"] = ob if e["id"] == oa else oa
        self.events.append({"frame": frame.index, "id": a, "volume": volumes.get(a),
                            "event": "swapped", "with": b})

    def _rename_estimates(self, tid: int, new_id: int, since: int) -> None:
        """The estimates of track ``tid`` from frame ``since`` on, under ``new_id`` (the
        estimates of a track waiting for confirmation were kept under its own id)."""
        for e in reversed(self.estimates):
            if e["frame"] < since:
                break
            if e["id"] == tid:
                e["id"] = new_id

    def colour_own(self, tid: int, neighbours: list[int], px: np.ndarray,
                   bins_of: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
                   mask: VolumeMask) -> np.ndarray:
        """``mask.colour_share``: whether each pixel (N, 2) is not more than
        ``VolumeMask.colour_share_ratio`` times as likely, by its colour, under a neighbouring
        track's template as under track ``tid``'s own (both plus
        ``VolumeMask.colour_share_floor``); only ``neighbours`` (the tracks whose gates overlap
        ``tid``'s) whose templates are ready and lie at least
        ``VolumeMask.colour_share_distance`` from ``tid``'s count. ``bins_of``: the histogram
        bins under pixels and which pixels have one
        (:func:`pftrack_coast.volume_colour.pixel_bins`). True where nothing decides (no
        template ready, no such neighbour, off the image, NaN)."""
        keep = np.ones(len(px), dtype=np.bool_)
        n = int(self.reid.min_frames)
        own = self.templates_.get(tid)
        if own is None or own[1] < n:
            return keep
        dmin = float(mask.colour_share_distance)
        others = [self.templates_[k][0] for k in neighbours
                  if k in self.templates_ and self.templates_[k][1] >= n
                  and float(bhattacharyya(self.templates_[k][0], own[0])) >= dmin]
        if not others:
            return keep
        bins, ok = bins_of(px)
        if not len(bins):
            return keep
        floor = float(mask.colour_share_floor)
        limit = float(mask.colour_share_ratio) * (own[0].take(bins) + floor)
        barred = np.zeros(len(bins), dtype=np.bool_)
        for tpl in others:
            barred |= tpl.take(bins) + floor > limit
        if np.count_nonzero(barred) > float(mask.colour_share_max_barred) * len(px):
            return keep  # hidden behind the neighbour: nothing of its own to keep to
        keep[np.flatnonzero(ok)[barred]] = False
        return keep
