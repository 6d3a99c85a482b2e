"""Camera recalibrations survived by the block eigenspace model.

A thermal camera corrects its own flat field from time to time (a flat-field correction, FFC:
the shutter closes, the recording pauses, then every pixel's offset is new): the global level
steps by tens of counts and the fixed per-pixel pattern changes. A background model trained
before it then sees a changed background in almost every block. The same holds for any sudden
global change of another camera (exposure, gain).

:class:`RecalibrationGuard` scores frames with a fitted
:class:`~pftrack_coast.eigenspace.BlockEigenspaceModel` and watches for such an event:

* a gap in the frame times longer than ``gap_s`` seconds (the FFC's pause), when times are given;
* a step of the frame's median grey level from the previous frame larger than ``level_step``;
* a fraction of the trained blocks flagged as intruders larger than ``block_fraction`` (no
  intruder fills a quarter of the picture in one frame; a changed background does);
* a hint from the caller (a camera's own record of its last FFC changing).

Between events the means of the blocks away from any intruder follow each frame slowly
(``adapt_rate``), so the per-pixel drift that goes on after a recalibration (and in any
thermal camera) does not build up into false intruders.

After an event it holds detections (empty results) for ``settle_frames`` frames and
re-baselines the model on them: each trained block's mean moves by the per-pixel median, over
those frames, of the frame minus the model's mean, so both the level step and the new
per-pixel pattern are absorbed while the block's eigenspace (its noise) is kept. Blocks that
held an intruder in the last sound frame before the event (and their 4-neighbours) would learn
the intruder as background that way: in them a pixel keeps its own shift only when it is within
three robust standard deviations of the nearest other trained block's median shift, and takes
that median otherwise (the intruder's pixels moved much further). Every event and recovery is a
message in :attr:`RecalibrationGuard.messages` and a ``RecalibrationWarning``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from pftrack_coast.eigenspace import (
    BlockEigenspaceModel,
    EigenspaceResult,
    blocks_of,
    to_grey,
)

__all__ = ["RecalibrationGuard", "RecalibrationWarning", "RecalibrationEvent"]


class RecalibrationWarning(UserWarning):
    """A recalibration (sudden global change) was detected, or the model recovered from one."""


@dataclass
class RecalibrationEvent:
    """One detected event: the frame (its number given to :meth:`RecalibrationGuard.score`,
    else the count of frames scored before it), its causes, and the frames the model was
    re-baselined on (``rebaselined_on``, empty while holding)."""

    frame: int
    causes: list[str]
    rebaselined_on: list[int]


class RecalibrationGuard:
    """Score frames with a fitted block eigenspace model through camera recalibrations.

    Parameters
    ----------
    model : BlockEigenspaceModel
        Fitted; it is re-baselined in place after an event.
    block_fraction : float
        An event when more than this fraction of the trained blocks are intruders in a frame.
    level_step : float or None
        An event when the frame's median grey level (of every 4th pixel of every 4th row,
        before any ``frame_offset``) moves by more than this many grey levels from the previous
        frame's; None: not watched.
    gap_s : float or None
        An event when a frame's time is more than this many seconds after the previous one's
        (times given to :meth:`score`); None: not watched.
    settle_frames : int
        Frames after an event whose detections are held (empty) and that the model is
        re-baselined on (>= 1); the event's own frame is the first of them.
    adapt_rate : float
        After each sound frame, the means of the blocks away from any intruder (neither
        flagged nor next to a flagged block) move this fraction of the way towards the frame
        (0: never): the slow per-pixel drift after a recalibration, or of any thermal camera,
        is followed between events, over about ``1 / adapt_rate`` frames. The eigenspaces are
        kept.
    warn : bool
        Also emit each message as a :class:`RecalibrationWarning`.
    """

    def __init__(self, model: BlockEigenspaceModel, block_fraction: float = 0.25,
                 level_step: float | None = 15.0, gap_s: float | None = None,
                 settle_frames: int = 3, adapt_rate: float = 0.02, warn: bool = True,
                 ) -> None:
        model._fitted()
        if not 0.0 < float(block_fraction) <= 1.0:
            raise ValueError(f"RecalibrationGuard: block_fraction must be in (0, 1], got "
                             f"{block_fraction!r}")
        if level_step is not None and not float(level_step) > 0:
            raise ValueError(f"RecalibrationGuard: level_step must be > 0 or None, got "
                             f"{level_step!r}")
        if gap_s is not None and not float(gap_s) > 0:
            raise ValueError(f"RecalibrationGuard: gap_s must be > 0 or None, got {gap_s!r}")
        if int(settle_frames) < 1:
            raise ValueError(f"RecalibrationGuard: settle_frames must be >= 1, got "
                             f"{settle_frames!r}")
        self.model = model
        self.block_fraction = float(block_fraction)
        self.level_step = None if level_step is None else float(level_step)
        self.gap_s = None if gap_s is None else float(gap_s)
        self.settle_frames = int(settle_frames)
        if not 0.0 <= float(adapt_rate) < 1.0:
            raise ValueError(f"RecalibrationGuard: adapt_rate must be in [0, 1), got "
                             f"{adapt_rate!r}")
        self.adapt_rate = float(adapt_rate)
        self.warn = bool(warn)
        self.messages: list[str] = []
        self.events: list[RecalibrationEvent] = []
        self._n = 0
        self._prev_level: float | None = None
        self._prev_time: float | None = None
        self._last_mask: np.ndarray | None = None  # intruder blocks of the last sound frame
        self._held: list[np.ndarray] = []  # (B, P) block vectors of the frames held
        self._held_at: list[int] = []

    @property
    def holding(self) -> bool:
        """True while detections are held after an event."""
        return bool(self._held_at)

    def _say(self, text: str) -> None:
        self.messages.append(text)
        if self.warn:
            warnings.warn(text, RecalibrationWarning, stacklevel=3)

    def _empty(self) -> EigenspaceResult:
        shape = self.model.grid_shape_
        return EigenspaceResult(np.zeros(shape), np.full(shape, -np.inf),
                                np.zeros(shape, bool), np.zeros((0, 4)), np.zeros(0))

    def score(self, image: np.ndarray, time_s: float | None = None,
              hint: str | None = None, frame: int | None = None) -> EigenspaceResult:
        """The model's result for one frame, or an empty one while detections are held.

        ``time_s``: the frame's time in seconds (for ``gap_s``); ``hint``: a reason to treat
        this frame as the start of a recalibration whatever the picture shows (e.g. "the
        camera's last FFC time changed"), or None; ``frame``: the frame's number in messages
        and events (default: the count of frames scored before it).
        """
        m = self.model
        k = self._n if frame is None else int(frame)
        self._n += 1
        raw = to_grey(image)
        level = float(np.median(raw[::4, ::4]))
        causes: list[str] = []
        if hint:
            causes.append(str(hint))
        if self.gap_s is not None and time_s is not None and self._prev_time is not None \
                and float(time_s) - self._prev_time > self.gap_s:
            causes.append(f"a {float(time_s) - self._prev_time:.2f} s gap between frames")
        if self.level_step is not None and self._prev_level is not None and \
                abs(level - self._prev_level) > self.level_step:
            causes.append(f"a level step of {level - self._prev_level:+.1f}")
        self._prev_level = level
        if time_s is not None:
            self._prev_time = float(time_s)
        grey = m.grey(image)
        if self.holding:
            return self._hold(k, grey, causes)
        proj = np.zeros(m.offset_.shape) if self.adapt_rate > 0 else None
        res = m.score_grey(grey, proj)
        trained = m.trained_.reshape(m.grid_shape_)
        frac = float(res.intruder_mask[trained].mean()) if trained.any() else 0.0
        if frac > self.block_fraction:
            causes.append(f"{100 * frac:.0f} % of the trained blocks flagged")
        if not causes:
            self._last_mask = res.intruder_mask
            if proj is not None:
                self._adapt(grey, proj, res.intruder_mask)
            return res
        self.events.append(RecalibrationEvent(k, causes, []))
        self._say(f"frame {k}: recalibration or sudden global change ({'; '.join(causes)}); "
                  f"detections held for {self.settle_frames} frame(s) while the background "
                  "model is re-baselined")
        return self._hold(k, grey, [])

    def _adapt(self, grey: np.ndarray, proj: np.ndarray, intruders: np.ndarray) -> None:
        """Move the means of the blocks away from any intruder (not flagged, nor 4-neighbour of
        a flagged block) ``adapt_rate`` of the way towards this frame."""
        busy = intruders
        if intruders.any():
            from scipy import ndimage

            busy = ndimage.binary_dilation(intruders)
        m = self.model
        m.follow(blocks_of(grey, int(m.block_size)), proj, ~busy.ravel(), self.adapt_rate)

    def _hold(self, k: int, grey: np.ndarray, causes: list[str]) -> EigenspaceResult:
        if causes:  # a new event while settling: start settling again from this frame
            self._held, self._held_at = [], []
            self.events.append(RecalibrationEvent(k, causes, []))
            self._say(f"frame {k}: another sudden change while settling ({'; '.join(causes)});"
                      " settling starts again")
        self._held.append(blocks_of(grey, int(self.model.block_size)))
        self._held_at.append(k)
        if len(self._held) < self.settle_frames:
            return self._empty()
        self._rebaseline()
        return self._empty()

    def _rebaseline(self) -> None:
        m = self.model
        rows, cols = m.grid_shape_
        x = np.stack(self._held)  # (F, B, P)
        delta = np.median(x - m.mean_[None], axis=0)  # (B, P): each pixel's shift
        kept = np.zeros((rows, cols), bool)
        if self._last_mask is not None and self._last_mask.any():
            from scipy import ndimage

            kept = ndimage.binary_dilation(self._last_mask)  # 4-neighbourhood
        kept_flat = kept.ravel()
        others = ~kept_flat & m.trained_
        if kept_flat.any() and others.any():
            from scipy import ndimage

            # in such a block a pixel keeps its own shift when it moved like the background
            # did (within 3 robust standard deviations of the nearest other trained block's
            # median shift); a pixel that moved further (the intruder) takes that median
            level = np.median(delta, axis=1)  # (B,)
            _, (ri, ci) = ndimage.distance_transform_edt(~others.reshape(rows, cols),
                                                         return_indices=True)
            src = (ri * cols + ci).ravel()
            spread = delta[others] - level[others][:, None]
            tol = 3.0 * 1.4826 * float(np.median(np.abs(spread - np.median(spread))))
            near = level[src[kept_flat]][:, None]
            own = delta[kept_flat]
            delta[kept_flat] = np.where(np.abs(own - near) <= tol, own, near)
        m.rebaseline(delta)
        ev = self.events[-1]
        ev.rebaselined_on = list(self._held_at)
        self._say(f"frames {self._held_at[0]}-{self._held_at[-1]}: background model "
                  f"re-baselined (median shift {float(np.median(delta)):+.1f}; "
                  f"{int(kept_flat.sum())} block(s) that held an intruder re-baselined "
                  "without its pixels); detections resume with the next frame")
        self._held, self._held_at = [], []

    def describe(self) -> dict[str, Any]:
        """The events so far, JSON-serialisable."""
        return {"events": [{"frame": e.frame, "causes": e.causes,
                            "rebaselined_on": e.rebaselined_on} for e in self.events],
                "messages": list(self.messages)}
