"""The soccer paper's likelihoods (eq. 5-9): detection, histogram distance (EMD), normalised
cross-correlation, and their combination.

======================  =======================  ===========================================
registered name         class                    what it computes, per particle box
======================  =======================  ===========================================
``detection``           DetectionLikelihood      eq. 6: I(tr*) (phi c(p) + psi p_N(p - det*))
``emd``                 EMDLikelihood            eq. 7: p_N(EMD(template, window histogram))
``ncc``                 NCCLikelihood            eq. 8: normalised cross-correlation
``composite``           CompositeLikelihood      eq. 5, 9: sum_i w_i p_i, w_i a number, beta
                                                 or 1 - beta (beta from the nearest target)
======================  =======================  ===========================================

How each is computed (all vectorised over particles):

* **NCC** (eq. 8): each window is reduced to a ``gw x gh`` grid of cell means read from one
  integral image of the grey frame (the exact area average of each cell, so large windows do not
  alias); the template is the same grid over the target's box at birth. NCC is computed between
  the two grids (masked where a window leaves the image). ``p_C`` is the raw NCC clipped to
  ``[eps, 1]`` as in the paper (``sigma=None``), or ``exp(-(1 - NCC)^2 / (2 sigma^2))`` to make
  the weight sharper (the preset does this; the raw value is nearly flat across nearby windows).
* **EMD** (eq. 7): per colour channel, the 1-D histogram (``bins`` bins) of the window's pixels
  sampled on a ``gw x gh`` grid (nearest pixel at each cell centre). For 1-D histograms with
  ground distance ``|i - j|`` (in bins), the Earth Mover's Distance is *exactly* the L1 distance
  between the two cumulative histograms; we divide it by ``bins - 1`` (so it lies in [0, 1]) and
  average over the three channels. This is the exact EMD between the per-channel marginal
  histograms -- not the 3-D joint-histogram EMD (cv2.EMD on 512 bins costs hundreds of ms per
  call) -- and of the grid-sampled histogram rather than of every pixel. ``p_H = exp(-d^2 /
  (2 sigma^2))``.
* **Detection** (eq. 6): ``I(tr*)`` is 1 when the associator matched a detection ``det*`` to the
  target (the associators of this plugin only match pairs whose score s(tr, det) exceeds their
  ``min_score``, i.e. the paper's threshold). ``p_N(p - det*)`` is a Gaussian of the distance
  between the particle's and the detection's foot points (bottom centres) in units of the
  detection's height. ``c(p)``, the SVM score of the particle's own window, is approximated from
  the frame's detections: ``max_k max(c(det_k), 0) * IoU(p, det_k)`` (the detector's response is
  only known at the windows it reported; computing HOG at every particle would cost more than the
  detector itself).
* **Composite** (eq. 5, 9): terms and weights come from configuration; in ``mix="sum"`` the
  weighted probabilities are added in probability space with a log-sum-exp, in ``mix="product"``
  the log-likelihoods are added with the weights as exponents. ``beta = exp(-d^2 / (2
  beta_sigma^2))`` with ``d`` the distance from the target's position (state dims 0, 1; metres for
  ground-plane state) to the nearest other live target (beta = 0 when alone).
* **Exclusion** (composite option ``exclusion_m``, not in the soccer paper): two people cannot stand
  on the same spot. A target with no matched detection this frame is followed by its appearance
  terms alone, and those can pull its particles onto a similar-looking neighbour, which then
  ends up tracked twice while the hidden person is lost (the identity switches of PETS 2009).
  Such a target's weights are multiplied by ``prod_j (1 - exp(-d_j^2 / (2 r^2)))``, ``d_j`` the
  particle's distance (state dims 0, 1) to the predicted position (particle mean) of each other
  target that *did* match a detection, ``r = exclusion_m``: the pairwise interaction prior of
  Khan, Balch and Dellaert (MCMC-based particle filtering for tracking a variable number of
  interacting targets, PAMI 2005), applied where the evidence is weakest. Targets with a
  detection are left alone, so a coasting track never pushes a detected person away.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pftrack.contracts.components import Detections, Frame, Likelihood, Param, RunContext, Target
from pftrack.engine.tracker import ComponentOutputError, component_label
from pftrack.geometry.boxes import foot_points, sub_boxes

from pftrack_world.regions import (
    cell_means,
    check_region,
    grid_samples,
    integral_image,
)

__all__ = [
    "CompositeLikelihood",
    "DetectionLikelihood",
    "EMDLikelihood",
    "NCCLikelihood",
    "emd_1d",
]


def _frame_key(frame: Frame) -> tuple[int, int]:
    return (int(frame.index), id(frame.image))


class _TemplateLikelihood(Likelihood):
    """Per-target templates (``templates_``, by target id): taken in the target's first frame
    (:meth:`init_target`), blended ``T <- (1 - a) T + a T(estimate)`` with ``a = update_rate``
    each frame the target had support, measured at its last estimate in the previous frame
    (:meth:`begin_frame`). A subclass says what a frame is reduced to (:meth:`_prepare`, kept
    with the previous frame's), how a template is measured in it (:meth:`_measure`) and what a
    new target starts from (:meth:`_first_template`)."""

    update_rate: float

    def _prepare(self, frame: Frame) -> Any:
        """The current frame's reduced form (cached per frame; the previous one kept)."""
        raise NotImplementedError

    def _previous(self) -> Any:
        """The previous frame's reduced form, or None."""
        raise NotImplementedError

    def _measure(self, source: Any, box: np.ndarray) -> np.ndarray | None:
        """A template at ``box`` in a reduced frame; None where it cannot be measured whole."""
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
        a = float(self.update_rate)
        prev = self._previous()
        if a > 0 and prev is not None:
            # targets' boxes are still last frame's estimates: read them in last frame's image
            for t in targets:
                if t.id in self.templates_ and t.frames_tracked > 0:
                    m = self._measure(prev, t.box_xywh_px)
                    if m is not None:
                        self.templates_[t.id] = (1 - a) * self.templates_[t.id] + a * m


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
    update_rate: float = Param(
        0.0,
        "Template update ``T <- (1 - a) T + a T(estimate)`` each frame the target had support "
        "(0, the paper: never).", unit="1/frame", low=0.0, high=1.0)
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
            self.prev_integral_ = getattr(self, "integral_", None)
            self.integral_ = integral_image(grey)
            self.frame_key_ = key
        return self.integral_

    def _cells(self, integral: np.ndarray, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        means, valid = cell_means(integral, sub_boxes(boxes, self.region), self.grid_wh)
        k = means.shape[1] * means.shape[2]
        return means.reshape(len(means), k), valid.reshape(len(valid), k)

    def _previous(self) -> np.ndarray | None:
        return getattr(self, "prev_integral_", None)

    def _measure(self, source: np.ndarray, box: np.ndarray) -> np.ndarray | None:
        vals, valid = self._cells(source, box[None])
        return vals[0] if valid[0].all() else None

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
    update_rate: float = Param(
        0.0, "Template update each frame the target had support (0: never, as the paper).",
        unit="1/frame", low=0.0, high=1.0)

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
            self.prev_quantised_ = getattr(self, "quantised_", None)
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

    def _previous(self) -> np.ndarray | None:
        return getattr(self, "prev_quantised_", None)

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


# --------------------------------------------------------------------------------------------
# Detection (eq. 6)
# --------------------------------------------------------------------------------------------


class DetectionLikelihood(Likelihood):
    """Detection likelihood (the soccer paper's eq. 6): ``p_D = I(tr*) (phi c(p) + psi p_N(p -
    det*))``.

    {params}

    Attributes
    ----------
    detections_ : Detections or None
        The frame's detections (for ``c(p)``).
    """

    phi: float = Param(
        0.5,
        "Weight of the SVM score term ``c(p)`` (see the module docstring for how it is read).",
        unit="1", low=0.0)
    psi: float = Param(
        1.0, "Weight of the Gaussian of the distance to the matched detection.", unit="1", low=0.0)
    sigma: float = Param(
        0.15, "Standard deviation of ``p_N(p - det*)``: foot-point distance in units of the "
        "detection's height.", unit="detection heights", low=0.0, low_open=True)
    floor: float = Param(
        0.0,
        "Added to ``p_D`` before the log, so a target without a matched detection (``I = 0``) "
        "gets ``log(floor)`` everywhere (``-inf`` when 0: in a composite, the term then simply "
        "contributes nothing).", unit="1", low=0.0)

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        self.detections_ = detections

    def svm_score(self, boxes_xywh_px: np.ndarray) -> np.ndarray:
        """c(p) (N,): ``max_k max(c_k, 0) * IoU(p, det_k)`` over this frame's detections."""
        from pftrack.geometry.boxes import iou_matrix

        det = getattr(self, "detections_", None)
        if det is None or len(det) == 0:
            return np.zeros(len(boxes_xywh_px))
        iou = iou_matrix(boxes_xywh_px, det.boxes_xywh_px)
        return (iou * np.maximum(det.scores, 0.0)[None, :]).max(axis=1)

    def probability(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        """p_D (N,) without the floor."""
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        match = target.detection
        if match is None:
            return np.zeros(len(b))
        d = np.asarray(match.box_xywh_px, dtype=np.float64)
        dist = np.linalg.norm(foot_points(b) - foot_points(d), axis=1) / max(float(d[3]), 1e-6)
        pn = np.exp(-0.5 * (dist / float(self.sigma)) ** 2)
        p = float(self.psi) * pn
        if float(self.phi) > 0:
            p = p + float(self.phi) * self.svm_score(b)
        return np.where(np.isfinite(p), p, 0.0)

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        p = self.probability(boxes_xywh_px, target) + float(self.floor)
        with np.errstate(divide="ignore"):
            return np.log(p)

    def probability_rows(self, boxes_xywh_px: np.ndarray,
                         targets: Sequence[Target]) -> np.ndarray:
        """p_D (T, N) of every target's particle boxes (T, N, 4) without the floor, row ``i``
        equal to ``probability(boxes_xywh_px[i], targets[i])`` bit for bit: the matched
        targets' rows in one pass, zeros for the others."""
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        out = np.zeros(b.shape[:2])
        matched = [i for i, t in enumerate(targets) if t.detection is not None]
        if not matched:
            return out
        rows = slice(None) if len(matched) == len(targets) else np.array(matched)
        bm = b[rows]  # (M, N, 4)
        d = np.array([np.asarray(targets[i].detection.box_xywh_px,  # type: ignore[union-attr]
                                 dtype=np.float64) for i in matched])  # (M, 4)
        heights = np.maximum(d[:, 3], 1e-6)
        dist = np.linalg.norm(foot_points(bm) - foot_points(d)[:, None, :], axis=2)
        dist /= heights[:, None]
        pn = np.exp(-0.5 * (dist / float(self.sigma)) ** 2)
        p = float(self.psi) * pn
        if float(self.phi) > 0:
            p = p + float(self.phi) * self.svm_score(bm.reshape(-1, 4)).reshape(pn.shape)
        out[rows] = np.where(np.isfinite(p), p, 0.0)
        return out

    def log_likelihood_rows(self, boxes_xywh_px: np.ndarray,
                            targets: Sequence[Target]) -> np.ndarray:
        """Every target's log-likelihoods (T, N) in one pass (:meth:`probability_rows`)."""
        p = self.probability_rows(boxes_xywh_px, targets) + float(self.floor)
        with np.errstate(divide="ignore"):
            return np.log(p)


# --------------------------------------------------------------------------------------------
# Composite (eq. 5, 9)
# --------------------------------------------------------------------------------------------


def _checked_term(term: Likelihood, logl: Any, n: int) -> np.ndarray:
    """A term's log-likelihoods as float64 (n,), held to the contract the engine holds a
    likelihood to (floating point, one per box, no NaN or +inf): the mix would otherwise turn
    a term's NaN into an impossible particle and hide the term at fault."""
    arr = np.asarray(logl)
    if arr.dtype.kind != "f":
        raise ComponentOutputError(f"composite term {component_label(term)} returned "
                                   f"log-likelihoods of dtype {arr.dtype}, expected floating "
                                   "point")
    if arr.shape != (n,):
        raise ComponentOutputError(f"composite term {component_label(term)} returned "
                                   f"log-likelihoods of shape {arr.shape}, expected ({n},) (one "
                                   "per box)")
    arr = arr.astype(np.float64, copy=False)
    if not (arr < np.inf).all():
        bad = int(np.count_nonzero(~(arr < np.inf)))
        raise ComponentOutputError(f"composite term {component_label(term)} returned {bad} NaN "
                                   f"or +inf log-likelihood(s) of {n}")
    return arr


def _checked_term_rows(term: Likelihood, logl: Any, targets: Sequence[Target],
                       n: int) -> np.ndarray:
    """:func:`_checked_term` of a term's rows (T, N), the message naming the first target at
    fault."""
    arr = np.asarray(logl)
    if arr.dtype.kind != "f":
        raise ComponentOutputError(f"composite term {component_label(term)} returned "
                                   f"log-likelihoods of dtype {arr.dtype}, expected floating "
                                   "point")
    if arr.shape != (len(targets), n):
        raise ComponentOutputError(f"composite term {component_label(term)} returned "
                                   f"log-likelihoods of shape {arr.shape} from "
                                   f"log_likelihood_rows, expected ({len(targets)}, {n})")
    arr = arr.astype(np.float64, copy=False)
    if not (arr < np.inf).all():
        i = int(np.flatnonzero(~(arr < np.inf).all(axis=1))[0])
        bad = int(np.count_nonzero(~(arr[i] < np.inf)))
        raise ComponentOutputError(f"composite term {component_label(term)} returned {bad} NaN "
                                   f"or +inf log-likelihood(s) of {n} (target {targets[i].id})")
    return arr

def _term_rows(term: Likelihood, boxes_xywh_px: np.ndarray, targets: Sequence[Target],
               n: int) -> np.ndarray:
    """A term's log-likelihoods of the targets' boxes (T, N, 4) -> (T, N), checked: one rows
    call when the term offers it, else its per-target calls, each checked as
    :meth:`CompositeLikelihood._mixed` checks them."""
    if term.offers_rows():
        return _checked_term_rows(term, term.log_likelihood_rows(boxes_xywh_px, targets),
                                  targets, n)
    out = np.empty((len(targets), n))
    for i, (b, t) in enumerate(zip(boxes_xywh_px, targets)):
        out[i] = _checked_term(term, term.log_likelihood(b, t), n)
    return out


_MIXES = ("sum", "product")
_SYMBOLIC = ("beta", "1-beta")


def _no_box_no_weight(boxes_xywh_px: np.ndarray, logl: np.ndarray) -> np.ndarray:
    """``logl`` (...) with -inf where the box (..., 4) has a NaN (no box: a state the camera
    cannot see, behind it); ``logl`` itself when every box is finite."""
    if np.isfinite(boxes_xywh_px.sum()):  # (one reduction: the common case)
        return logl
    return np.where(np.isnan(boxes_xywh_px).any(axis=-1), -np.inf, logl)


class CompositeLikelihood(Likelihood):
    """Weighted combination of likelihood plugins (the soccer paper's eq. 5 with eq. 9).

    {params}

    Attributes
    ----------
    terms_ : list of Likelihood
        The built terms.
    beta_ : dict[int, float]
        This frame's beta per target id (empty when no term is weighted by beta).
    anchors_ : dict[int, ndarray (2,)]
        This frame's predicted positions of the targets that matched a detection (exclusion).
    """

    terms: Sequence[dict[str, Any]] = Param(
        (), 'Each ``{"likelihood": spec, "weight": w}``: ``spec`` anything '
        ':meth:`pftrack.host.Host.build` takes (a registered name or ``{"type", "params"}``), '
        '``w`` a number >= 0, ``"beta"`` or ``"1-beta"``.')
    mix: str = Param(
        "sum",
        "``sum``: ``p = sum_i w_i p_i`` (eq. 5), computed as a log-sum-exp of ``log w_i + log "
        "p_i``. ``product``: ``log p = sum_i w_i log p_i``.", choices=_MIXES)
    beta_sigma: float = Param(
        1.0,
        "``beta = exp(-d^2 / (2 beta_sigma^2))`` (eq. 9), ``d`` the distance from the target "
        "to the nearest other live target in state units (metres for ground-plane state).",
        unit="state units (m or px)", low=0.0, low_open=True)
    exclusion_m: float | None = Param(
        None, "Radius ``r`` of the exclusion prior (module docstring) in state units (metres for "
        "ground-plane state: about a person's radius, 0.3 m); None: none (the soccer paper).",
        unit="state units (m or px)", low=0.0, low_open=True)

    @classmethod
    def _conformance_example(cls):
        """For :mod:`pftrack.testing`: eq. 5 without the detector, p = beta p_H + (1 - beta) p_C."""
        return cls(terms=[{"likelihood": "emd", "weight": "beta"},
                          {"likelihood": "ncc", "weight": "1-beta"},
                          {"likelihood": {"type": "detection", "params": {"floor": 1e-3}},
                           "weight": 0.5}],
                   beta_sigma=30.0)

    def setup(self, context: RunContext) -> None:
        """Build the terms with the run's host and hand each the context."""
        self.terms_ = None
        for t in self._build(context):
            t.setup(context)

    def _build(self, context: RunContext | None = None) -> list[Likelihood]:
        """The terms, built once through ``context``'s host (without :meth:`setup`, e.g. a
        composite used directly from Python: the process-wide host)."""
        if getattr(self, "terms_", None) is not None:
            return self.terms_
        host = (context or RunContext()).get_host()

        if not self.terms:
            raise ValueError("CompositeLikelihood: terms is empty")
        built = []
        for i, term in enumerate(self.terms):
            if not isinstance(term, dict) or "likelihood" not in term:
                raise ValueError(f"CompositeLikelihood: terms[{i}] must be a dict with a "
                                 f"'likelihood' key, got {term!r}")
            w = term.get("weight", 1.0)
            if isinstance(w, str):
                if w not in _SYMBOLIC:
                    raise ValueError(f"CompositeLikelihood: terms[{i}] weight {w!r} must be a "
                                     f"number, 'beta' or '1-beta'")
            elif not (isinstance(w, (int, float)) and np.isfinite(w) and w >= 0):
                raise ValueError(f"CompositeLikelihood: terms[{i}] weight must be >= 0, got {w!r}")
            built.append(host.build("likelihood", term["likelihood"]))
        self.terms_ = built
        return built

    def _weights(self, target: Target) -> list[float]:
        beta = getattr(self, "beta_", {}).get(target.id, 0.0)
        out = []
        for term in self.terms:
            w = term.get("weight", 1.0)
            out.append(beta if w == "beta" else (1.0 - beta) if w == "1-beta" else float(w))
        return out

    def prepare(self) -> None:
        for t in self._build():
            t.prepare()

    def init_target(self, frame: Frame, target: Target) -> None:
        for t in self._build():
            t.init_target(frame, target)

    def end_target(self, target: Target) -> None:
        for t in self._build():
            t.end_target(target)
        getattr(self, "beta_", {}).pop(target.id, None)

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        terms = self._build()
        self.beta_ = {}
        symbolic = any(isinstance(t.get("weight", 1.0), str) for t in self.terms)
        if targets and symbolic:  # beta weighs only the terms weighted 'beta' or '1-beta'
            pos = np.array([np.asarray(t.state, dtype=np.float64)[:2] for t in targets])
            d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
            np.fill_diagonal(d, np.inf)
            dmin = d.min(axis=1) if len(targets) > 1 else np.full(1, np.inf)
            beta = np.exp(-0.5 * (dmin / float(self.beta_sigma)) ** 2)
            self.beta_ = {t.id: float(b) for t, b in zip(targets, beta)}
        self.anchors_ = {}
        if self.exclusion_m is not None:
            # where the detected targets are predicted to be (their particles are predicted
            # and matched before the weights are computed)
            self.anchors_ = {t.id: np.asarray(t.particles, dtype=np.float64)[:, :2].mean(axis=0)
                             for t in targets
                             if t.detection is not None and t.particles is not None
                             and len(t.particles)}
        for t in terms:
            t.begin_frame(frame, targets, detections)

    def _exclusion(self, target: Target) -> np.ndarray | None:
        """log of the exclusion prior (N,) for ``target``'s particles, or None when it does not
        apply (no ``exclusion_m``, the target matched a detection, nobody else did)."""
        if self.exclusion_m is None or target.detection is not None or target.particles is None:
            return None
        others = [p for tid, p in getattr(self, "anchors_", {}).items() if tid != target.id]
        if not others:
            return None
        xy = np.asarray(target.particles, dtype=np.float64)[:, :2]
        d2 = ((xy[:, None, :] - np.array(others)[None, :, :]) ** 2).sum(axis=2)
        r2 = float(self.exclusion_m) ** 2
        return np.log(np.maximum(1.0 - np.exp(-0.5 * d2 / r2), 1e-6)).sum(axis=1)

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        """log-likelihoods (N,) of the boxes (N, 4); -inf (zero likelihood) for a particle
        with no box (a NaN row: the observation model has none for a state behind the
        camera), whatever its terms make of it."""
        out = self._mixed(boxes_xywh_px, target)
        ex = self._exclusion(target)
        if ex is not None and len(ex) == len(out):  # boxes are the target's own particles
            out = out + ex
        return _no_box_no_weight(np.asarray(boxes_xywh_px, dtype=np.float64), out)

    def offers_rows(self) -> bool:
        """True: the mix runs over every target at once; a term without its own rows method
        is called once per target (the base class's rows)."""
        return True

    def log_likelihood_rows(self, boxes_xywh_px: np.ndarray,
                            targets: Sequence[Target]) -> np.ndarray:
        """Every target's log-likelihoods (T, N): each term's rows in one call, mixed for all
        targets at once; row ``i`` equals ``log_likelihood(boxes_xywh_px[i], targets[i])``
        bit for bit."""
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        out = self._mixed_rows(b, targets)
        if self.exclusion_m is not None:
            for i, t in enumerate(targets):
                ex = self._exclusion(t)
                if ex is not None and len(ex) == out.shape[1]:
                    out[i] = out[i] + ex
        return _no_box_no_weight(b, out)

    def _mixed_rows(self, boxes_xywh_px: np.ndarray,
                    targets: Sequence[Target]) -> np.ndarray:
        """:meth:`_mixed` of every target (T, N): a term is computed for the targets that
        weigh it (one rows call), and targets weighing the same terms are mixed together, with
        the arithmetic of one target's mix."""
        terms = self._build()
        n_rows, n = boxes_xywh_px.shape[:2]
        weights = [self._weights(t) for t in targets]
        out = np.zeros((n_rows, n))
        groups: dict[tuple[bool, ...], list[int]] = {}
        for i, w in enumerate(weights):
            groups.setdefault(tuple(v > 0 for v in w), []).append(i)
        logls: list[np.ndarray | None] = []
        for k, term in enumerate(terms):
            rows = [i for i, w in enumerate(weights) if w[k] > 0]
            if not rows:
                logls.append(None)  # a zero weight never needs its likelihood computed
            elif len(rows) == n_rows:
                logls.append(_term_rows(term, boxes_xywh_px, targets, n))
            else:
                full = np.empty((n_rows, n))
                full[rows] = _term_rows(term, boxes_xywh_px[rows], [targets[i] for i in rows], n)
                logls.append(full)
        for on, rows in groups.items():
            ks = [k for k, used in enumerate(on) if used]
            if not ks:
                continue  # no term: zeros
            idx: slice | list[int] = slice(None) if len(rows) == n_rows else rows
            L = np.stack([logls[k][idx] for k in ks])  # type: ignore[index]  # (K, R, N)
            logw = np.log(np.array([[weights[i][k] for i in rows] for k in ks]))  # (K, R)
            if self.mix == "product":
                w = np.exp(logw)[:, :, None]
                with np.errstate(invalid="ignore"):
                    mixed = (w * L).sum(axis=0)
                out[idx] = np.where(np.isnan(mixed), -np.inf, mixed)
                continue
            A = L + logw[:, :, None]
            if len(ks) == 1:  # log(exp(a - a)) is 0 exactly: the one term's weighted values
                out[idx] = A[0]
                continue
            m = A.max(axis=0)
            finite = np.isfinite(m)
            ms = np.where(finite, m, 0.0)
            with np.errstate(divide="ignore"):
                mixed = ms + np.log(np.exp(A - ms[None]).sum(axis=0))
            out[idx] = np.where(finite, mixed, -np.inf)
        return out

    def _mixed(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        """The terms' log-likelihoods (N,) combined by ``mix`` (eq. 5)."""
        terms = self._build()
        n = len(boxes_xywh_px)
        parts, logw = [], []
        for term, w in zip(terms, self._weights(target)):
            if w <= 0:
                continue  # a zero weight never needs its likelihood computed
            parts.append(_checked_term(term, term.log_likelihood(boxes_xywh_px, target), n))
            logw.append(np.log(w))
        if not parts:
            return np.zeros(n)
        L = np.stack(parts)
        if self.mix == "product":
            w = np.exp(np.array(logw))[:, None]
            with np.errstate(invalid="ignore"):
                out = (w * L).sum(axis=0)
            return np.where(np.isnan(out), -np.inf, out)
        A = L + np.array(logw)[:, None]
        m = A.max(axis=0)
        finite = np.isfinite(m)
        ms = np.where(finite, m, 0.0)
        with np.errstate(divide="ignore"):
            out = ms + np.log(np.exp(A - ms[None, :]).sum(axis=0))
        return np.where(finite, out, -np.inf)
