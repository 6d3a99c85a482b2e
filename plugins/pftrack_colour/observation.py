"""Image-plane boxes whose size follows the matched detections (``image-box-sized``).

The colour tracker of a user's own boxes (preset ``people-colour``) keeps each target's box
size as a per-target parameter, as :class:`pftrack.tracker.ImageBoxObservation` with
``size_from_box=True`` does, but lets it follow the detections: after every frame in which the
target matched a detection, ``(w, h) <- (1 - a) (w, h) + a (w_det, h_det)`` with ``a`` =
``size_rate``, the new size bounded to ``size_limits`` times the starting size. Without it the
box keeps its birth size, and a person walking towards or away from a low camera soon has a box
that holds much background (the colour likelihood then prefers background-coloured places) or a
part of the person only (IoU below 0.5 although the person is tracked).
"""

from __future__ import annotations

import numpy as np
from pftrack.components import Target
from pftrack.tracker import ImageBoxObservation

__all__ = ["SizedImageBoxObservation"]


class SizedImageBoxObservation(ImageBoxObservation):
    """Image-plane state (dims 0, 1: the box centre, px); each target starts with the size of
    the box it was started from and its size follows its matched detections.

    Parameters
    ----------
    width_px, height_px : float
        Box size of a target started without a box. Unit: px.
    size_rate : float
        Weight ``a`` of a matched detection's size in the running mean of the target's box
        size, per matched frame (0: the birth size is kept, 1: the last matched detection's
        size). Unit: 1/frame.
    size_limits : (float, float)
        The size stays within these factors of the target's starting size. Unit: 1.

    Attributes
    ----------
    start_wh_ : dict[int, (float, float)]
        Each live target's starting size, by id.
    """

    #: always: each target starts with the size of the box it was started from
    size_from_box = True

    def __init__(self, width_px: float = 30.0, height_px: float = 30.0, size_rate: float = 0.2,
                 size_limits: tuple[float, float] = (0.5, 2.0)) -> None:
        self.width_px = width_px
        self.height_px = height_px
        self.size_rate = size_rate
        self.size_limits = size_limits

    def _check(self) -> None:
        super()._check()
        if not 0.0 <= float(self.size_rate) <= 1.0:
            raise ValueError(f"image-box-sized: size_rate must be in [0, 1], got "
                             f"{self.size_rate!r}")
        lo, hi = (float(v) for v in self.size_limits)
        if not 0.0 < lo <= 1.0 <= hi:
            raise ValueError(f"image-box-sized: size_limits must be (lo, hi) with "
                             f"0 < lo <= 1 <= hi, got {self.size_limits!r}")

    @property
    def start_wh_(self) -> dict[int, tuple[float, float]]:
        return self.__dict__.setdefault("_start_wh", {})

    def init_target(self, target: Target, box_xywh_px: np.ndarray | None) -> None:
        super().init_target(target, box_xywh_px)
        if target.box_wh_px is not None:
            self.start_wh_[target.id] = (float(target.box_wh_px[0]), float(target.box_wh_px[1]))

    def end_target(self, target: Target) -> None:
        self.start_wh_.pop(target.id, None)

    def update_target(self, target: Target, box_xywh_px: np.ndarray) -> None:
        """Blend the matched detection's size into the target's (see the class docstring)."""
        a = float(self.size_rate)
        start = self.start_wh_.get(target.id)
        if a <= 0.0 or target.box_wh_px is None or start is None:
            return
        det = np.asarray(box_xywh_px, dtype=np.float64)
        if not (np.isfinite(det[2:4]).all() and det[2] > 0 and det[3] > 0):
            return
        lo, hi = (float(v) for v in self.size_limits)
        w0, h0 = start
        w = (1.0 - a) * float(target.box_wh_px[0]) + a * float(det[2])
        h = (1.0 - a) * float(target.box_wh_px[1]) + a * float(det[3])
        target.box_wh_px = (min(max(w, lo * w0), hi * w0), min(max(h, lo * h0), hi * h0))
