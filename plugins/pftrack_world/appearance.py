"""The soccer paper's appearance likelihoods: ``ncc`` (:class:`NCCLikelihood`, eq. 8, normalised
cross-correlation of a grid of cell means) and ``emd`` (:class:`EMDLikelihood`, eq. 7, the Earth
Mover's Distance between per-channel colour histograms), each against a template taken from the
target's box at birth. How each is computed is described in :mod:`pftrack_world.likelihoods`,
where they import from as well.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pftrack.contracts.components import Detections, Frame, Likelihood, Param, Target
from pftrack.geometry.boxes import sub_boxes

from pftrack_world.regions import (
    cell_means,
    check_region,
    grid_samples,
    integral_image,
)


def _frame_key(frame: Frame) -> tuple[int, int]:
    return (int(frame.index), id(frame.image))


class _TemplateLikelihood(Likelihood):
    """Per-target templates (``templates_``, by target id), taken in the target's first frame
    (:meth:`init_target`) and kept, as the soccer paper does: a template that followed the
    estimates would drift onto whoever the track wrongly follows. A subclass says what a frame
    is reduced to (:meth:`_prepare`) and what a new target's template is
    (:meth:`_first_template`)."""

    def _prepare(self, frame: Frame) -> Any:
        """The current frame's reduced form (cached per frame)."""
        raise NotImplementedError

    def _first_template(self, source: Any, box: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def init_target(self, frame: Frame, target: Target) -> None:
        if not hasattr(self, "templates_"):
            self.templates_: dict[int, np.ndarray] = {}
        self.templates_[target.id] = self._first_template(self._prepare(frame),
                                                          target.box_xywh_px)

    def end_target(self, target: Target) -> None:
        getattr(self, "templates_", {}).pop(target.id, None)

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        if not hasattr(self, "templates_"):
            self.templates_ = {}
        self._prepare(frame)


# --------------------------------------------------------------------------------------------
# NCC (eq. 8)
# --------------------------------------------------------------------------------------------


class NCCLikelihood(_TemplateLikelihood):
    """Normalised cross-correlation with the target's grey template (the soccer paper's eq. 8).

    {params}

    Attributes
    ----------
    templates_ : dict[int, ndarray (gh * gw,)]
    integral_ : ndarray (H+1, W+1)
        Integral image of the current grey frame.
    """

    grid_wh: Sequence[int] = Param(
        (8, 16),
        "Template size in cells (across, down); each window is reduced to this grid of cell "
        "means.", unit="count", low=1, length=2)
    sigma: float | None = Param(
        0.25,
        "None: ``p_C = clip(NCC, eps, 1)`` (the paper's value). A number: ``p_C = exp(-(1 - "
        "NCC)^2 / (2 sigma^2))``.", unit="1", low=0.0, low_open=True)
    eps: float = Param(
        1e-3, "Floor of ``p_C`` (log-likelihoods stay finite).", unit="1", low=0.0, low_open=True)
    region: Sequence[float] | None = Param(
        None, "Part of each box compared, fractions of its width and height.",
        unit="1", low=0.0, high=1.0, length=4)
    min_valid: float = Param(
        0.5, "Windows with less than this fraction of their cells inside the image get ``p_C = "
        "eps``.", unit="1", low=0.0, high=1.0)

    def _check_relations(self) -> None:
        check_region(self.region, type(self).__name__)

    def _prepare(self, frame: Frame) -> np.ndarray:
        import cv2

        key = _frame_key(frame)
        if getattr(self, "frame_key_", None) != key:
            img = frame.image
            grey = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
            self.integral_ = integral_image(grey)
            self.frame_key_ = key
        return self.integral_

    def _cells(self, integral: np.ndarray, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        means, valid = cell_means(integral, sub_boxes(boxes, self.region), self.grid_wh)
        k = means.shape[1] * means.shape[2]
        return means.reshape(len(means), k), valid.reshape(len(valid), k)

    def _first_template(self, source: np.ndarray, box: np.ndarray) -> np.ndarray:
        vals, valid = self._cells(source, box[None])
        t = vals[0]
        if not valid[0].all():
            t = np.where(valid[0], t, t[valid[0]].mean() if valid[0].any() else 0.0)
        return t

    def ncc(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        """NCC (N,) in [-1, 1] of each window with the target's template (NaN: too little of
        the window inside the image)."""
        kern = _kernels()
        gw, gh = (int(v) for v in self.grid_wh)
        if kern is not None:
            out = np.empty(len(boxes_xywh_px))
            kern.ncc_values(self.integral_, sub_boxes(boxes_xywh_px, self.region), gw, gh,
                            np.ascontiguousarray(self.templates_[target.id], dtype=np.float64),
                            float(self.min_valid), out)
            return out
        vals, valid = self._cells(self.integral_, boxes_xywh_px)
        tmpl = self.templates_[target.id][None, :]
        m = valid.astype(np.float64)
        n = m.sum(axis=1)
        nn = np.maximum(n, 1.0)
        di = (vals - (vals * m).sum(axis=1, keepdims=True) / nn[:, None]) * m
        dt = (tmpl - (tmpl * m).sum(axis=1, keepdims=True) / nn[:, None]) * m
        num = (di * dt).sum(axis=1)
        den = np.sqrt((di * di).sum(axis=1) * (dt * dt).sum(axis=1))
        with np.errstate(invalid="ignore", divide="ignore"):
            r = np.where(den > 1e-12, num / np.where(den > 1e-12, den, 1.0), 0.0)
        r[n < float(self.min_valid) * vals.shape[1]] = np.nan
        return np.clip(r, -1.0, 1.0)

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        r = self.ncc(boxes_xywh_px, target)
        eps = float(self.eps)
        if self.sigma is None:
            out = np.log(np.clip(r, eps, 1.0))
        else:
            out = np.maximum(-0.5 * ((1.0 - r) / float(self.sigma)) ** 2, np.log(eps))
        return np.where(np.isfinite(r), out, np.log(eps))


# --------------------------------------------------------------------------------------------
# EMD (eq. 7)
# --------------------------------------------------------------------------------------------


_KERNELS: Any = None


def _kernels() -> Any:
    """:mod:`pftrack_world._kernels`, loaded (numba imported, the kernels warmed up) on first
    use; None with ``PFTRACK_NO_JIT`` set or without numba: the numpy paths."""
    global _KERNELS
    if _KERNELS is None:
        from pftrack.filter._jit import ENABLED

        _KERNELS = False
        if ENABLED:
            try:
                from pftrack_world import _kernels as kern
            except ImportError:  # pragma: no cover - numba is a dependency
                pass
            else:
                kern.warm_up()
                _KERNELS = kern
    return _KERNELS or None


def emd_1d(hist_a: np.ndarray, hist_b: np.ndarray) -> np.ndarray:
    """Exact Earth Mover's Distance between 1-D histograms with ground distance ``|i - j|`` bins.

    Parameters
    ----------
    hist_a, hist_b : ndarray, shape (..., B)
        Normalised histograms (each sums to 1), broadcastable.

    Returns
    -------
    ndarray, shape (...)
        ``sum_b |CDF_a(b) - CDF_b(b)|`` in bins (0 .. B - 1).
    """
    return np.abs(np.cumsum(hist_a, axis=-1) - np.cumsum(hist_b, axis=-1)).sum(axis=-1)


_COLOUR_SPACES = ("bgr", "hsv", "lab")


class EMDLikelihood(_TemplateLikelihood):
    """Histogram likelihood by the Earth Mover's Distance (the soccer paper's eq. 7).

    ``p_H = exp(-d^2 / (2 sigma^2))`` with ``d`` the exact 1-D EMD between the template's and the
    window's per-channel histograms, divided by ``bins - 1`` and averaged over channels (module
    docstring).

    {params}

    Attributes
    ----------
    templates_ : dict[int, ndarray (3, bins)]
    quantised_ : ndarray (H, W, 3) uint8
        Bin index of each pixel and channel in the current frame.
    """

    bins: int = Param(16, "Bins per channel.", unit="count", low=2, high=256)
    colour_space: str = Param(
        "bgr",
        "Colour space the 8-bit channels are converted to before they are binned (OpenCV's "
        'full-range HSV, or Lab); "bgr": the frame\'s own channels, as the paper.',
        choices=_COLOUR_SPACES)
    sigma: float = Param(
        0.1, "Scale of the distance (in [0, 1] units).", unit="1", low=0.0, low_open=True)
    grid_wh: Sequence[int] = Param(
        (8, 16), "Sample grid over each window (across, down).", unit="count", low=1, length=2)
    region: Sequence[float] | None = Param(
        (0.15, 0.1, 0.85, 0.9),
        "Part of each box histogrammed, fractions of its width and height (default: the "
        "middle, less background beside the legs and above the head).",
        unit="1", low=0.0, high=1.0, length=4)

    def _check_relations(self) -> None:
        check_region(self.region, type(self).__name__)

    def _prepare(self, frame: Frame) -> np.ndarray:
        import cv2

        key = _frame_key(frame)
        if getattr(self, "frame_key_", None) != key:
            img = frame.image
            if img.ndim == 2:
                img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
            if self.colour_space == "hsv":
                img = cv2.cvtColor(img, cv2.COLOR_BGR2HSV_FULL)
            elif self.colour_space == "lab":
                img = cv2.cvtColor(img, cv2.COLOR_BGR2LAB)
            self.quantised_ = ((img.astype(np.uint16) * int(self.bins)) >> 8).astype(np.uint8)
            self.frame_key_ = key
        return self.quantised_

    def histograms(self, quantised: np.ndarray, boxes_xywh_px: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Normalised per-channel histograms (N, 3, bins) of the windows' grid samples, and the
        number of valid samples (N,)."""
        B = int(self.bins)
        vals, valid = grid_samples(quantised, sub_boxes(boxes_xywh_px, self.region),
                                   self.grid_wh)
        n = len(vals)
        idx = (np.arange(n)[:, None, None] * 3 + np.arange(3)[None, None, :]) * B + vals
        w = np.broadcast_to(valid[:, :, None], idx.shape).astype(np.float64)
        counts = np.bincount(idx.ravel(), weights=w.ravel(), minlength=n * 3 * B)
        counts = counts.reshape(n, 3, B)
        k = valid.sum(axis=1).astype(np.float64)
        return counts / np.maximum(k, 1.0)[:, None, None], k

    def _measure(self, quantised: np.ndarray, box: np.ndarray) -> np.ndarray | None:
        """Exact histogram (3, bins) of every pixel of the box's region (None if outside)."""
        H, W = quantised.shape[:2]
        b = sub_boxes(box[None], self.region)[0]
        if not np.all(np.isfinite(b)):
            return None
        x0, y0 = int(max(np.floor(b[0]), 0)), int(max(np.floor(b[1]), 0))
        x1, y1 = int(min(np.ceil(b[0] + b[2]), W)), int(min(np.ceil(b[1] + b[3]), H))
        if x1 <= x0 or y1 <= y0:
            return None
        patch = quantised[y0:y1, x0:x1].reshape(-1, 3)
        B = int(self.bins)
        h = np.stack([np.bincount(patch[:, c], minlength=B) for c in range(3)]).astype(float)
        return h / h.sum(axis=1, keepdims=True)

    def _first_template(self, quantised: np.ndarray, box: np.ndarray) -> np.ndarray:
        t = self._measure(quantised, box)
        return t if t is not None else np.full((3, int(self.bins)), 1.0 / int(self.bins))

    def distance(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        """EMD / (bins - 1) averaged over channels, (N,) in [0, 1]; NaN for windows with no
        sample inside the image."""
        kern = _kernels()
        if kern is not None:
            gw, gh = (int(v) for v in self.grid_wh)
            out = np.empty(len(boxes_xywh_px))
            kern.emd_distances(self.quantised_, sub_boxes(boxes_xywh_px, self.region), gw, gh,
                               int(self.bins), np.ascontiguousarray(self.templates_[target.id],
                                                                    dtype=np.float64), out)
            return out
        hist, k = self.histograms(self.quantised_, boxes_xywh_px)
        d = emd_1d(hist, self.templates_[target.id][None]).mean(axis=1) / (int(self.bins) - 1)
        return np.where(k > 0, d, np.nan)

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        d = self.distance(boxes_xywh_px, target)
        d = np.where(np.isfinite(d), d, 1.0)
        return -0.5 * (d / float(self.sigma)) ** 2
