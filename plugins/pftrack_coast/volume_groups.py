"""The detection groups of the ``volumes`` track manager (:mod:`pftrack_coast.volumes`): one per
volume, and the tracks they start (the coastal paper's sec. 3).

:class:`VolumeGroups` is the manager's initiator. At the first frame it starts one detection
group per volume, a target whose particles are spread uniformly through the cuboid (velocity 0)
and filtered like any other so that they gather on what changed. After each frame's estimates
it looks at every group: when at least ``entry.particles`` (N_m) of its particles have
likelihood above ``v_pi``, a track starts from them (a :class:`~pftrack.contracts.stages.Birth`
carrying the particles of the largest connected patch of the image they cover) and the group is
spread again (a :class:`~pftrack.contracts.stages.Particles` decision); a candidate too small
for an intruder keeps the group gathering on it for ``entry.gather_frames`` frames; a group
with no entry for ``entry.idle_frames`` frames is spread again too.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
from pftrack.contracts.stages import Birth, FrameView, Initiator, Particles, TrackView
from pftrack.geometry.boxes import covered_fraction

from pftrack_coast.likelihood import _blocks_of_pixels
from pftrack_coast.volume_book import VolumeBook
from pftrack_coast.volume_geometry import (
    _clip_into,
    _finite_rows,
    _support_base,
    _support_finish,
    cloud_box,
)

__all__ = ["VolumeGroups", "current_pixels"]


def current_pixels(book: VolumeBook, t: TrackView, points: np.ndarray) -> np.ndarray:
    """Image positions (N, 2) of a target's current (resampled) particles: the weighted
    particles' pixels taken through the engine's ``resample_index`` when this frame projected
    them as points (the same pixels without projecting again), else projected."""
    b, ri = t.particle_boxes_xywh_px, t.resample_index
    if b is not None and ri is not None and len(ri) == len(points) and \
            not b[:, 2:].any():
        return b[:, :2].take(ri, axis=0)  # (b[ri, :2]: the same rows, faster)
    return book.camera.project(points)  # type: ignore[union-attr]


class VolumeGroups(Initiator):
    """The detection groups (one per volume) and the tracks they start; see the module
    docstring. Draws from the run's generator (``FrameView.rng``): the groups' spreads, the
    particles a track starts from and their jitter."""

    def __init__(self, book: VolumeBook) -> None:
        self.book = book

    # -- decisions ------------------------------------------------------------------------------

    def _spread(self, view: FrameView, tid: int, volume: Any) -> Particles:
        """Particles uniform in ``volume``, velocity 0, for target ``tid``."""
        m = view.models
        n, d = m.n_particles, m.state_dim
        p = np.zeros((n, d))
        p[:, list(m.position_dims)] = volume.sample(n, view.rng)
        self.book.idle[tid] = 0
        self.book.gather[tid] = 0
        return Particles(tid, p)

    def scheduled(self, view: FrameView) -> Iterator[Birth | Particles]:
        """The frame's index and image to the book; at the first frame (and whenever no group
        is live) one group per volume, each spread through its volume."""
        book = self.book
        book.frame = view.frame.index
        book.image = view.frame.image
        book.position_dims = tuple(view.models.position_dims)
        if book.groups:
            return
        for name, vol in book.volumes.items():
            b = Birth(position=np.asarray(vol.center_m, float), supported=False)
            self.book.births[id(b)] = ("group", name)
            yield b  # (track_started hears of it before this goes on)
            yield self._spread(view, self.started_, vol)

    def track_started(self, track: TrackView, birth: Birth) -> None:
        what = self.book.births.pop(id(birth), None)
        if what is None:
            return
        self.started_ = track.id
        book = self.book
        if what[0] == "group":
            book.groups[track.id] = what[1]
            return
        book.tracks[track.id] = what[1]
        book.above[track.id] = what[2]
        book.low[track.id] = 0
        book.events.append({"frame": int(book.frame), "id": track.id, "volume": what[1],
                            "event": "entry"})

    def initiate(self, view: FrameView) -> Iterator[Birth | Particles]:
        """Each group in turn: an entry (a track's birth, then the group spread again), a
        gathering frame, a spread, or an idle frame."""
        book = self.book
        log_v = math.log(book.v_pi)
        live = {t.id: t for t in view.tracks}
        pos_dims = list(view.models.position_dims)
        for gid, name in list(book.groups.items()):
            g = live.get(gid)
            vol = book.volumes[name]
            if g is None:
                continue
            ll = g.log_likelihoods
            if ll is None or not np.isfinite(ll).any():
                yield self._spread(view, gid, vol)
                continue
            n_above = int(np.count_nonzero(ll > log_v))
            if n_above >= int(book.entry.particles):
                assert g.particles is not None
                parts, parts_px = self._blob(view, g.particles,
                                             current_pixels(book, g, g.particles[:, pos_dims]))
                why = self.refusal(parts, pos_dims, parts_px)
                if why == "small" and book.gather.get(gid, 0) < int(book.entry.gather_frames):
                    # too small for an intruder yet: the group keeps gathering on it (the
                    # few particles that hit it are resampled and spread over it)
                    book.gather[gid] = book.gather.get(gid, 0) + 1
                    continue
                if why is not None:
                    yield self._spread(view, gid, vol)  # a tracked intruder's fringe
                    continue
                if book.object_size_m is not None:
                    a = np.asarray(book.object_size_m, dtype=np.float64)
                    jitter = view.rng.standard_normal(  # type: ignore[union-attr]
                        (len(parts), 3)) * (0.25 * a[[0, 2, 1]])
                    parts = parts.copy()
                    parts[:, pos_dims] += jitter
                    parts[:, pos_dims] = _clip_into(vol, parts[:, pos_dims])
                pos = parts[:, pos_dims].mean(axis=0)
                b = Birth(position=pos, particles=parts, supported=False)
                self.book.births[id(b)] = ("track", name, n_above)
                yield b
                yield self._spread(view, gid, vol)
                continue
            book.idle[gid] = book.idle.get(gid, 0) + 1
            if book.idle[gid] >= int(book.entry.idle_frames):
                yield self._spread(view, gid, vol)

    # -- what a group gathered ------------------------------------------------------------------

    def _blob(self, view: FrameView, particles: np.ndarray,
              px: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The particles of the largest 8-connected patch (in cells of
        ``VolumeEntry.blob_block_px``) of the image they cover, resampled to the engine's count,
        and their pixels (``px``: the particles' pixels when known, else projected)."""
        import cv2

        book = self.book
        if px is None:
            px = book.camera.project(  # type: ignore[union-attr]
                particles[:, list(view.models.position_dims)])
        w, h = view.frame.size_wh
        bs = int(book.entry.blob_block_px)
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
        n = view.models.n_particles
        if len(sel) == n:
            return sel, sel_px
        pick = view.rng.integers(0, len(sel), size=n)  # type: ignore[union-attr]
        return sel[pick], sel_px[pick]

    def refusal(self, particles: np.ndarray, pos_dims: list[int],
                px: np.ndarray | None = None) -> str | None:
        """Why ``particles`` are not a new intruder: ``"small"`` (smaller than
        ``VolumeEntry.min_size_fraction`` of ``object_size_m``), ``"tracked"`` (on a tracked
        one's footprint, ``merge.distance_m``, or mostly -- ``VolumeEntry.spawn_overlap`` --
        inside a tracked intruder's image box), ``"none"`` (no footprint: nothing projects, or
        the cloud's foot row misses the support plane); None: a new intruder. ``pos_dims``: the
        state's position entries; ``px``: the particles' pixels when known."""
        book = self.book
        cam = book.camera
        assert cam is not None
        if px is None:
            px = cam.project(particles[:, pos_dims])
        fine = _finite_rows(px)
        if not fine.all():
            px = px[fine]
        if not len(px):
            return "none"
        est = None
        if book.object_size_m is not None or book.merge.distance_m is not None:
            # (support_plane_estimate of the finite pixels)
            base = _support_base(cam, px, book.support_z_m, 0.02, finite=True)
            if base is None:
                return "none"
            est = _support_finish(cam, base)
            paths = book.footprints.paths_
            if book.merge.distance_m is not None and paths:
                xy = np.array([p[-1] for p in paths.values() if p])
                if len(xy) and np.hypot(*(xy - est["footprint_m"][:2]).T).min() \
                        < float(book.merge.distance_m):
                    return "tracked"
            if book.object_size_m is not None:
                size = np.asarray(book.object_size_m, dtype=np.float64)
                f = float(book.entry.min_size_fraction)
                if est["size_m"][0] < f * size[0] or est["size_m"][1] < f * size[1]:
                    return "small"
        if not book.boxes:
            return None
        if est is not None:  # cloud_box(px): the estimate's image box, the same numbers
            box = est["box_xywh_px"]
        else:
            box = cloud_box(px) if len(px) >= 2 else np.concatenate([px[0], np.zeros(2)])
        b = np.array(list(book.boxes.values()))
        inside = covered_fraction(box, b) > float(book.entry.spawn_overlap)
        return "tracked" if bool(inside.any()) else None
