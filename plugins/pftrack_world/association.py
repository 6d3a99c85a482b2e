"""Detection-to-track association by the soccer paper's matching score (eq. 3-4, after Breitenstein
et al., ICCV 2009), solved greedily (the paper) or optimally (Hungarian method).

For a track ``tr`` (its particles, as image boxes) and a detection ``det`` (box, score c(det))::

    s(tr, det) = g(tr, det) * (c(det) + alpha * mean_{p in tr} p_N(det - p))          (eq. 3)
    g(tr, det) = p_N((size_tr - size_det) / size_tr)                                 (eq. 4)

* ``p_N(det - p) = exp(-d^2 / (2 sigma_det^2))`` with ``d`` the distance between the detection's
  and the particle's foot points (bottom centres) in units of the track's height; the paper
  sums over particles, we average (the sum is the mean times N, absorbed into ``alpha``) so that
  ``alpha`` does not depend on the number of particles;
* ``size`` is the box height: ``size_tr`` the mean height of the track's particle boxes (the
  window size the particles' positions give), ``size_det`` the detection's;
  ``p_N(x) = exp(-x^2 / (2 sigma_size^2))``;
* a distance gate (``max_distance``, in track heights, as in Breitenstein et al.) sets the score
  of a pair whose foot points are farther apart to zero: eq. 3 alone would let a confident
  detection anywhere in the image match a track of similar size.

Only pairs with ``s > min_score`` (the paper's ``threshold`` of ``I(tr*)``, eq. 6) are matched,
so a matched detection is exactly ``I(tr*) = 1``.

Appearance (optional, ``appearance_weight > 0``): Breitenstein et al.'s original score uses a
track-specific classifier ``c_tr(det)`` where the soccer paper uses the generic SVM score
``c(det)``. With ``appearance_weight = gamma`` the score becomes
``g * (c(det) + gamma * a(tr, det) + alpha * mean p_N)``, where ``a(tr, det)`` in [0, 1] is an
appearance similarity the caller puts in ``target.appearance_scores`` (one value per
detection; the pipeline's session uses ``exp(-d^2 / (2 sigma^2))`` of the per-channel colour
EMD between the track's and the detection's histograms). Targets without it get ``a = 0``. A
NaN in ``appearance_scores`` bars that pair (score 0, never matched), whatever
``appearance_weight``: a lifecycle stage that rules a pair out says so this way.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pftrack.contracts.components import Assignment, Associator, Detections, Param, Target
from pftrack.geometry.boxes import foot_points

__all__ = ["GreedyScoreAssociator", "HungarianScoreAssociator", "greedy_max", "score_matrix"]


def score_matrix(targets: Sequence[Target], detections: Detections, *, alpha: float = 1.0,
                 sigma_det: float = 0.25, sigma_size: float = 0.25,
                 max_distance: float | None = 1.0,
                 appearance_weight: float = 0.0) -> np.ndarray:
    """Matching scores s(tr, det) (eq. 3-4).

    Parameters
    ----------
    targets : sequence of Target
        Each with ``particle_boxes_xywh_px`` (N, 4) (falls back to ``box_xywh_px``).
    detections : Detections
    alpha, sigma_det, sigma_size, max_distance, appearance_weight : float
        See the module docstring (distances in track heights).

    Returns
    -------
    ndarray, shape (K detections, T tracks)
        Rows are detections and columns tracks, as in the paper's matrix S; 0 where gated.
    """
    K, T = len(detections), len(targets)
    S = np.zeros((K, T))
    if K == 0 or T == 0:
        return S
    db = detections.boxes_xywh_px
    dfoot = foot_points(db)  # (K, 2)
    c = detections.scores
    for j, t in enumerate(targets):
        pb = t.particle_boxes_xywh_px
        if pb is None or len(pb) == 0:
            pb = np.asarray(t.box_xywh_px, dtype=np.float64)[None]
        pb = pb[np.all(np.isfinite(pb), axis=1)]
        if len(pb) == 0:
            continue
        size_tr = float(np.mean(pb[:, 3]))
        if not size_tr > 0:
            continue
        pf = foot_points(pb)  # (N, 2)
        d = np.linalg.norm(dfoot[:, None, :] - pf[None, :, :], axis=2) / size_tr  # (K, N)
        prox = np.exp(-0.5 * (d / sigma_det) ** 2).mean(axis=1)
        g = np.exp(-0.5 * (((size_tr - db[:, 3]) / size_tr) / sigma_size) ** 2)
        app: float | np.ndarray = 0.0
        a = t.appearance_scores
        barred = None
        if a is not None and len(a) == K:
            a = np.asarray(a, dtype=np.float64)
            barred = np.isnan(a)  # the track management bars these pairs
            if appearance_weight > 0:
                app = appearance_weight * np.where(barred, 0.0, a)
        s = g * (c + app + alpha * prox)
        if barred is not None and barred.any():
            s = np.where(barred, 0.0, s)
        if max_distance is not None:
            tfoot = foot_points(np.asarray(t.box_xywh_px, float))
            dc = np.linalg.norm(dfoot - tfoot, axis=1) / size_tr
            s = np.where(dc <= max_distance, s, 0.0)
        S[:, j] = s
    return S


def greedy_max(S: np.ndarray, min_score: float) -> list[tuple[int, int]]:
    """The paper's greedy matching: take the largest entry above ``min_score``, delete its row
    and column, repeat. Returns (row, column) pairs in the order taken."""
    S = np.array(S, dtype=np.float64, copy=True)
    pairs = []
    for _ in range(min(S.shape)):
        if S.size == 0:
            break
        i, j = np.unravel_index(int(np.argmax(S)), S.shape)
        if not S[i, j] > min_score:
            break
        pairs.append((int(i), int(j)))
        S[i, :] = -np.inf
        S[:, j] = -np.inf
    return pairs


class _ScoreAssociator(Associator):
    """Shared parameters and the score matrix; subclasses choose the solver."""

    alpha: float = Param(1.0, "Weight of the particles' proximity to the detection (eq. 3).",
                         unit="1", low=0.0)
    sigma_det: float = Param(0.25, "Std of p_N(det - p), in track heights.",
                             unit="track heights", low=0.0, low_open=True)
    sigma_size: float = Param(0.25, "Std of the size gate g (eq. 4), relative size difference.",
                              unit="1", low=0.0, low_open=True)
    max_distance: float | None = Param(1.0, "Distance gate in track heights (None: none).",
                                       unit="track heights", low=0.0, low_open=True)
    min_score: float = Param(0.2, "Pairs must score above this (the paper's threshold of eq. 6).",
                             unit="1")
    appearance_weight: float = Param(
        0.0, "Weight of the track-specific appearance term (module docstring); 0: the paper's "
        "score.", unit="1", low=0.0)

    def _scores(self, targets: Sequence[Target], detections: Detections) -> np.ndarray:
        S = score_matrix(targets, detections, alpha=float(self.alpha),
                         sigma_det=float(self.sigma_det), sigma_size=float(self.sigma_size),
                         max_distance=self.max_distance,
                         appearance_weight=float(self.appearance_weight))
        self.scores_ = S
        return S

    def _solve(self, S: np.ndarray) -> list[tuple[int, int]]:
        raise NotImplementedError

    def associate(self, targets: Sequence[Target], detections: Detections) -> Assignment:
        """Match targets to detections by s(tr, det); ``Assignment.matches`` rows are
        (target index, detection index). ``scores_`` keeps the matrix S (detections x targets)
        and ``match_scores_`` the score of each match."""
        S = self._scores(targets, detections)
        pairs = self._solve(S)
        self.match_scores_ = np.array([S[i, j] for i, j in pairs])
        return Assignment.from_matches([(j, i) for i, j in pairs], len(targets), len(detections))


class GreedyScoreAssociator(_ScoreAssociator):
    """The soccer paper's association (sec. 3.2): greedy on s(tr, det) of eq. 3-4.

    {params}

    Attributes
    ----------
    scores_ : ndarray (K, T)
        The last score matrix S.
    match_scores_ : ndarray (M,)
        Scores of the last matches.
    """

    def _solve(self, S: np.ndarray) -> list[tuple[int, int]]:
        return greedy_max(S, float(self.min_score))


class HungarianScoreAssociator(_ScoreAssociator):
    """The same score matrix solved by the Hungarian method (maximum total score,
    scipy.optimize.linear_sum_assignment); pairs at or below ``min_score`` are dropped.

    {params}
    """

    def _solve(self, S: np.ndarray) -> list[tuple[int, int]]:
        from scipy.optimize import linear_sum_assignment

        if S.size == 0:
            return []
        thr = float(self.min_score)
        # entries that may not match cost nothing to leave unmatched
        gain = np.where(S > thr, S, 0.0)
        rows, cols = linear_sum_assignment(gain, maximize=True)
        return [(int(i), int(j)) for i, j in zip(rows, cols) if S[i, j] > thr]
