"""Image-plane boxes whose size follows the matched detections (``image-box-sized``).

The colour tracker of a user's own boxes (preset ``people-colour``) keeps each target's box
size as a per-target parameter, as :class:`pftrack.builtin.image_box.ImageBoxObservation` with
``size_from_box=True`` does, but lets it follow the detections: after every frame in which the
target matched a detection, ``(w, h) <- (1 - a) (w, h) + a (w_det, h_det)`` with ``a`` =
``size_rate``, the new size bounded to ``size_limits`` times the starting size. Without it the
box keeps its birth size, and a person walking towards or away from a low camera soon has a box
that holds much background (the colour likelihood then prefers background-coloured places) or a
part of the person only (IoU below 0.5 although the person is tracked).
"""

from __future__ import annotations

import numpy as np
from pftrack.builtin.image_box import ImageBoxObservation
from pftrack.contracts.components import Param, Target

__all__ = ["SizedImageBoxObservation"]


class SizedImageBoxObservation(ImageBoxObservation):
    """Image-plane state (dims 0, 1: the box centre, px); each target starts with the size of
    the box it was started from and its size follows its matched detections.

    {params}

    Attributes
    ----------
    start_wh_ : dict[int, (float, float)]
        Each live target's starting size, by id.
    """

    #: always: each target starts with the size of the box it was started from
    size_from_box = True

    width_px: float = Param(
        30.0, "Box width of a target started without a box.", unit="px", low=0.0, low_open=True)
    height_px: float = Param(
        30.0, "Box height of a target started without a box.", unit="px", low=0.0, low_open=True)
    size_rate: float = Param(
        0.2, "Weight ``a`` of a matched detection's size in the running mean of the target's box "
        "size, per matched frame (0: the birth size is kept, 1: the last matched detection's "
        "size).", unit="1/frame", low=0.0, high=1.0)
    size_limits: tuple[float, float] = Param(
        (0.5, 2.0), "The size stays within these factors of the target's starting size.",
        unit="1", low=0.0, low_open=True, length=2)

    def _check_relations(self) -> None:
        lo, hi = (float(v) for v in self.size_limits)
        if not lo <= 1.0 <= hi:
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
