"""Static things are not people: tracks that never move, at a fixed place, with a fixed look.

A person detector run on someone else's video finds, besides people, things shaped like one: a
post, a coat on a hook, a poster, a statue. Tracked, such a "person" stays where it is, frame
after frame, for as long as the video lasts. A person standing and waiting stays put too, so
place alone does not decide: a person sways, turns the head, moves an arm, and the box's
pixels change; a thing's pixels do not (besides the video's noise and slow light changes).

A track is **static** (:func:`static_evidence`, :func:`flag_static_tracks`) when all three hold:

* it lives at least ``min_seconds`` seconds;
* its box centre stays within ``max_shift_heights`` of its track's median box height of the
  track's median centre, and its height within that fraction of the median height, in all
  but the worst ``1 - quantile`` of its frames (a tracker's estimate jitters for a frame or
  two when someone walks past);
* with the video, its look is fixed: the grey pixels of its median box, sampled at
  ``appearance_samples`` frames spread over its life, correlate with their mean at least
  ``min_similarity`` (normalised cross-correlation, each sample against the mean of the
  others).

Everything is computed from a track's records (MOTChallenge rows) and a few frames of the
video; a track-lifecycle stage can call :func:`static_evidence` on a live track's history.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

__all__ = ["StaticRule", "flag_static_tracks", "patch_similarity", "static_evidence"]


@dataclass(frozen=True)
class StaticRule:
    """When a track is a static thing, not a person (see the module docstring).

    Attributes
    ----------
    min_seconds : float
        A track living shorter than this is never static. Unit: s.
    max_shift_heights : float
        How far the box centre (and the box height) may stray from the track's median, as a
        fraction of the median box height. Unit: box heights.
    quantile : float
        The fraction of the track's frames that must keep within ``max_shift_heights``.
        Unit: 1.
    min_similarity : float
        The lowest normalised cross-correlation of a sampled patch with the mean of the
        others for a fixed look (1: identical up to brightness and contrast); not checked
        without the video. Unit: 1.
    appearance_samples : int
        Frames sampled over the track's life for its look. Unit: frames.
    """

    min_seconds: float = 10.0
    max_shift_heights: float = 0.1
    quantile: float = 0.95
    min_similarity: float = 0.9
    appearance_samples: int = 6

    def check(self) -> None:
        """``ValueError`` naming the first attribute out of range."""
        if not float(self.min_seconds) > 0.0:
            raise ValueError(f"static tracks: min_seconds must be > 0 s, got {self.min_seconds}")
        if not float(self.max_shift_heights) > 0.0:
            raise ValueError(f"static tracks: max_shift_heights must be > 0 box heights, got "
                             f"{self.max_shift_heights}")
        if not 0.5 <= float(self.quantile) <= 1.0:
            raise ValueError(f"static tracks: quantile is a fraction in [0.5, 1], got "
                             f"{self.quantile}")
        if not -1.0 <= float(self.min_similarity) <= 1.0:
            raise ValueError(f"static tracks: min_similarity is a correlation in [-1, 1], got "
                             f"{self.min_similarity}")
        if int(self.appearance_samples) < 2:
            raise ValueError(f"static tracks: appearance_samples must be >= 2 frames, got "
                             f"{self.appearance_samples}")


def static_evidence(frames: np.ndarray, boxes_xywh_px: np.ndarray, fps: float,
                    quantile: float = 0.95) -> dict[str, float]:
    """How still one track is.

    Parameters
    ----------
    frames : ndarray, shape (N,)
        The track's frame numbers.
    boxes_xywh_px : ndarray, shape (N, 4)
        Its boxes (left, top, width, height), pixels; rows with a NaN are left out.
    fps : float
        Frames per second of the video.
    quantile : float
        Which quantile of the per-frame shifts is reported.

    Returns
    -------
    dict
        ``seconds`` (first to last frame, s), ``shift_heights`` (the ``quantile`` of the box
        centre's distance from the median centre, in median box heights), ``height_change``
        (the ``quantile`` of ``|height / median height - 1|``), ``median_height_px``.
    """
    f = np.asarray(frames, dtype=np.float64).reshape(-1)
    b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    ok = np.isfinite(b).all(axis=1) & np.isfinite(f)  # a record without a box says nothing
    f, b = f[ok], b[ok]
    if len(f) == 0:
        return {"seconds": 0.0, "shift_heights": float("inf"), "height_change": float("inf"),
                "median_height_px": 0.0}
    centre = b[:, :2] + 0.5 * b[:, 2:]
    h = float(np.median(b[:, 3]))
    h = max(h, 1e-9)
    shift = np.linalg.norm(centre - np.median(centre, axis=0), axis=1) / h
    change = np.abs(b[:, 3] / h - 1.0)
    return {"seconds": float((f.max() - f.min() + 1.0) / float(fps)),
            "shift_heights": float(np.quantile(shift, quantile)),
            "height_change": float(np.quantile(change, quantile)),
            "median_height_px": h}


def patch_similarity(patches: np.ndarray) -> float:
    """The lowest normalised cross-correlation of a patch (K, H, W) with the mean of the
    others (1: the same up to brightness and contrast; a flat patch counts as 1 with a flat
    mean, 0 otherwise)."""
    p = np.asarray(patches, dtype=np.float64).reshape(len(patches), -1)
    if len(p) < 2:
        return 1.0
    others = (p.sum(axis=0, keepdims=True) - p) / (len(p) - 1)

    def z(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a = a - a.mean(axis=1, keepdims=True)
        n = np.linalg.norm(a, axis=1)
        return a / np.where(n > 1e-9, n, 1.0)[:, None], n > 1e-9

    za, oka = z(p)
    zb, okb = z(others)
    ncc = np.where(oka & okb, np.sum(za * zb, axis=1), np.where(oka == okb, 1.0, 0.0))
    return float(ncc.min())


def _patches(video: str | os.PathLike[str], frames: list[int], box_xywh_px: np.ndarray,
             size_wh: tuple[int, int] = (16, 32)) -> np.ndarray:
    """Grey patches of one fixed box at the given frames (MOT numbering, from 1), each
    resized to ``size_wh``; frames that cannot be read are skipped."""
    import cv2

    cap = cv2.VideoCapture(str(video))
    out = []
    try:
        for f in frames:
            cap.set(cv2.CAP_PROP_POS_FRAMES, int(f) - 1)
            ok, img = cap.read()
            if not ok:
                continue
            grey = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
            H, W = grey.shape
            x, y, w, h = box_xywh_px
            x0, y0 = int(np.clip(np.floor(x), 0, W - 1)), int(np.clip(np.floor(y), 0, H - 1))
            x1 = int(np.clip(np.ceil(x + w), x0 + 1, W))
            y1 = int(np.clip(np.ceil(y + h), y0 + 1, H))
            out.append(cv2.resize(grey[y0:y1, x0:x1], size_wh,
                                  interpolation=cv2.INTER_AREA).astype(np.float64))
    finally:
        cap.release()
    return np.asarray(out).reshape(-1, size_wh[1], size_wh[0])


def flag_static_tracks(rows: np.ndarray, fps: float, rule: StaticRule | None = None,
                       video: str | os.PathLike[str] | None = None) -> list[dict[str, Any]]:
    """The static tracks among MOTChallenge rows (frame, id, left, top, width, height, ...).

    Parameters
    ----------
    rows : ndarray, shape (M, >= 6)
    fps : float
        Frames per second of the video (``ValueError`` when not > 0).
    rule : StaticRule, optional
        The thresholds (default :class:`StaticRule`'s).
    video : path, optional
        The video the rows track: with it, a still track is static only with a fixed look;
        without it, place and time alone decide.

    Returns
    -------
    list of dict
        One per static track, by id: ``id``, ``first``, ``last``, the evidence of
        :func:`static_evidence`, ``similarity`` (None without the video) and ``why``.
    """
    rule = rule or StaticRule()
    rule.check()
    if not float(fps) > 0.0:
        raise ValueError(f"static tracks: fps must be > 0 frames per second, got {fps}")
    r = np.asarray(rows, dtype=np.float64).reshape(-1, np.shape(rows)[-1] if len(rows) else 10)
    flagged: list[dict[str, Any]] = []
    for tid in np.unique(r[:, 1]) if len(r) else []:
        mine = r[r[:, 1] == tid]
        mine = mine[np.isfinite(mine[:, :6]).all(axis=1)]
        if not len(mine):
            continue
        ev = static_evidence(mine[:, 0], mine[:, 2:6], fps, rule.quantile)
        if ev["seconds"] < rule.min_seconds or ev["shift_heights"] > rule.max_shift_heights \
                or ev["height_change"] > rule.max_shift_heights:
            continue
        sim = None
        if video is not None:
            k = int(rule.appearance_samples)
            fr = np.unique(np.round(np.linspace(mine[:, 0].min(), mine[:, 0].max(), k)))
            box = np.median(mine[:, 2:6], axis=0)
            patches = _patches(video, [int(x) for x in fr], box)
            if len(patches) >= 2:
                sim = patch_similarity(patches)
                if sim < rule.min_similarity:
                    continue
        why = (f"for {ev['seconds']:.1f} s (>= {rule.min_seconds:g} s) its box stayed within "
               f"{ev['shift_heights']:.3f} box heights of one place (<= "
               f"{rule.max_shift_heights:g}) in {100 * rule.quantile:g}% of its frames")
        if sim is not None:
            why += (f", its look fixed (correlation {sim:.3f} >= {rule.min_similarity:g} over "
                    f"{len(patches)} frames)")
        flagged.append({"id": int(tid), "first": int(mine[:, 0].min()),
                        "last": int(mine[:, 0].max()), **ev, "similarity": sim, "why": why,
                        "rule": asdict(rule)})
    return flagged
