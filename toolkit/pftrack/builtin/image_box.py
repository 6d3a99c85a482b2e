"""The image-plane observation model (``image-box``, registered by the built-in plugin
``basic``): a particle's state axes 0 and 1 are its box centre in pixels, the box has a fixed
size or each target's own from the box it was born from."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pftrack.contracts.components import ObservationModel, Param, Target
from pftrack.filter import _jit

__all__ = ["ImageBoxObservation"]


class ImageBoxObservation(ObservationModel):
    """Image-plane state: dims 0 and 1 are the box centre in pixels; the box has a fixed size
    (the colour paper uses 30 x 30 px).

    With ``size_from_box=True`` each target keeps the size of the box it was started from
    (``target.box_wh_px``), e.g. each person's ground-truth size at initialisation.

    {params}
    """

    width_px: float = Param(30.0, "The box width.", unit="px", low=0.0, low_open=True)
    height_px: float = Param(30.0, "The box height.", unit="px", low=0.0, low_open=True)
    size_from_box: bool = Param(
        False, "Each target keeps the size of the box it was started from.")

    def init_target(self, target: Target, box_xywh_px: np.ndarray | None) -> None:
        if self.size_from_box and box_xywh_px is not None:
            target.box_wh_px = (float(box_xywh_px[2]), float(box_xywh_px[3]))

    def to_boxes(self, states: np.ndarray, target: Target | None = None) -> np.ndarray:
        s = np.asarray(states, dtype=np.float64)
        w, h = float(self.width_px), float(self.height_px)
        if target is not None and target.box_wh_px is not None:
            w, h = target.box_wh_px
        if len(s) == 1:  # an estimate: Python floats are the same IEEE doubles, and faster
            x, y = s[0, :2].tolist()
            return np.array([[x - 0.5 * w, y - 0.5 * h, w, h]])
        if _jit.use(len(s)) and s.ndim == 2 and s.shape[1] >= 2:
            return _jit.centre_boxes(s, w, h)  # one compiled pass: the same numbers as below
        out = np.empty((len(s), 4))
        out[:, 0] = s[:, 0] - 0.5 * w
        out[:, 1] = s[:, 1] - 0.5 * h
        out[:, 2] = w
        out[:, 3] = h
        return out

    def to_boxes_rows(self, states: np.ndarray, targets: Sequence[Target]) -> np.ndarray:
        """(T, N, D) -> (T, N, 4) in one pass, each row's size its target's."""
        s = np.asarray(states, dtype=np.float64)
        wh, half = self._row_sizes(targets)
        if (_jit.small_ready() and s.ndim == 3 and s.shape[2] >= 2 and s.flags.c_contiguous
                and wh.shape == (len(s), 2)):
            return _jit.centre_boxes_rows(s, half, wh)  # one compiled pass, same numbers
        out = np.empty(s.shape[:2] + (4,))
        # column by column: inner loops run over the N particles, not over the 2 axes
        for k in range(2):
            np.subtract(s[:, :, k], half[:, k:k + 1], out=out[:, :, k])
            out[:, :, 2 + k] = wh[:, k:k + 1]
        return out

    def _row_sizes(self, targets: Sequence[Target]) -> tuple[np.ndarray, np.ndarray]:
        """Each target's box size (T, 2) and half of it, kept while the sizes do not change
        (the engine asks twice a frame: particles and estimates); read, never written."""
        size = (float(self.width_px), float(self.height_px))
        sizes = [size if t.box_wh_px is None else t.box_wh_px for t in targets]
        hit = self.__dict__.get("_sizes_rows")
        if hit is not None and len(hit[0]) == len(sizes) and all(
                type(a) is tuple and a == b for a, b in zip(sizes, hit[0])):
            return hit[1], hit[2]
        wh = np.array(sizes, dtype=np.float64)
        half = 0.5 * wh
        self._sizes_rows = ([tuple(v) for v in sizes], wh, half)
        return wh, half

    def position_from_box(self, box_xywh_px: np.ndarray) -> np.ndarray:
        b = np.asarray(box_xywh_px, dtype=np.float64)
        return np.array([b[0] + 0.5 * b[2], b[1] + 0.5 * b[3]])

    def box_height_in_state(self, box_xywh_px: np.ndarray) -> float | None:
        """The box's height in pixels: the state is in pixels."""
        return float(np.asarray(box_xywh_px, dtype=np.float64)[3])
