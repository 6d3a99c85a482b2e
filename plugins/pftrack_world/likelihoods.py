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

NCC and EMD, the appearance likelihoods, are in :mod:`pftrack_world.appearance`; detection and
composite here; all four import from here.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pftrack.contracts.components import Detections, Frame, Likelihood, Param, RunContext, Target
from pftrack.engine.tracker import ComponentOutputError, component_label
from pftrack.geometry.boxes import foot_points

from pftrack_world.appearance import EMDLikelihood, NCCLikelihood, emd_1d

__all__ = [
    "CompositeLikelihood",
    "DetectionLikelihood",
    "EMDLikelihood",
    "NCCLikelihood",
    "emd_1d",
]


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
