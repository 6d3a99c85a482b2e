"""Association by each track's predicted likelihood of each detection, solved globally.

A particle filter carries, for every track, a cloud of hypotheses about where its object is in
this frame. The ``cloud`` associator scores a detection against a track by how likely the
cloud makes it: the mean over the track's predicted particles of a Gaussian of the distance
between the detection's box centre and the particle's box centre (in units of the detection's
height), times a Gaussian of the log ratio of the detection's height to the track's. A track
whose cloud has spread (it went unseen for a while) claims detections over a wider area, and
two tracks side by side each claim the detection their own particles predict, which a distance
between two box estimates cannot tell apart. The cost is the negative log of that likelihood
(plus an appearance term when the track management supplies ``Target.appearance_scores``), and
all tracks and detections are matched at once by the Hungarian method, not greedily.

Detections are matched in two passes by score, after ByteTrack (Zhang et al., ECCV 2022):
confident detections first, against every track; then the less confident ones, only against
the tracks left unmatched that were seen in the last frames. A weak detection continues a
track that is being followed through an occlusion, but does not re-find a track lost long ago,
nor start one (track management starts tracks from unmatched confident detections only).

A third pass re-finds lost tracks. A track unseen for a while keeps predicting, and its cloud
spreads with every frame (the motion model's noise is what lets a followed person turn and
speed up); after a second or two hidden behind someone, the cloud covers so much of the image
that no detection is likely under it, and the person who steps out again would start a new
track. So the confident detections left unmatched are also offered to the tracks left
unmatched that have gone ``recent_misses`` frames or more without one and were hidden behind
another track when last seen (at least ``covered`` of their box under another track's box),
through a gate on what a person can do while hidden (``refind``): the detection's box centre
within ``margin`` plus
``speed`` times the seconds lost of the track's last matched box (both in that box's heights),
its height within a factor ``exp(size)`` of that box's, and its colour similarity, when the
track management supplies one, at least ``min_appearance``. The pairs that pass are matched
at once by the Hungarian method on the distance and height ratio as fractions of the gate,
plus the appearance cost.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pftrack.contracts.components import (
    Assignment,
    Associator,
    Detections,
    Group,
    Param,
    ParamGroup,
    Target,
)
from pftrack.geometry.boxes import covered_fraction

__all__ = ["CloudAssociator", "Refind", "cloud_cost"]

_INFEASIBLE = 1e9
# the assumed scatter counts as this many measured pairs; the measurement keeps the last
# _WINDOW pairs (the scatter of a run's detections may change as its people come nearer)
_PRIOR_PAIRS = 50
_WINDOW = 1000
# the measured scatter is kept within these multiples of the assumed one
_SCATTER_RANGE = (0.25, 2.0)
# frames per second when the run does not say (RunContext's own default)
_DEFAULT_FPS = 25.0


def _particle_boxes(t: Target) -> np.ndarray:
    pb = t.particle_boxes_xywh_px
    if pb is None or len(pb) == 0:
        pb = np.asarray(t.box_xywh_px, dtype=np.float64)[None]
    return np.asarray(pb, dtype=np.float64)


def cloud_cost(targets: Sequence[Target], detections: Detections, *,
               sigma: float | tuple[float, float] = 0.1, sigma_size: float = 0.2) -> np.ndarray:
    """Negative log predicted likelihood of each detection under each track's particles.

    Parameters
    ----------
    targets : sequence of Target
        Each with ``particle_boxes_xywh_px`` (N, 4), the predicted particles as image boxes
        (falls back to ``box_xywh_px``).
    detections : Detections
    sigma : float or (float, float)
        Standard deviation of a detection's box centre about a particle's box centre, in
        detection heights; a pair gives the horizontal and the vertical one.
    sigma_size : float
        Standard deviation of the log ratio of the detection's height to the track's mean
        particle box height.

    Returns
    -------
    ndarray, shape (T, K)
        ``-log(mean_i N(d_i; sigma) * N(log(h_det / h_track); sigma_size))`` (Gaussians
        without their normalising constants: 0 for a detection exactly where every particle
        is); ``inf`` for a track with no finite particle box.
    """
    return _cloud_cost(targets, detections, sigma, sigma_size)[0]


def _cloud_mean(b: np.ndarray) -> tuple[np.ndarray, float]:
    """Mean box centre (2,) and height of one cloud's finite particle boxes (N, 4)."""
    b = b[np.isfinite(b).all(axis=1)]
    if not len(b):
        return np.full(2, np.nan), np.nan
    return (b[:, :2] + 0.5 * b[:, 2:]).mean(axis=0), float(b[:, 3].mean())


def _cloud_cost(targets: Sequence[Target], detections: Detections,
                sigma: float | tuple[float, float], sigma_size: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`cloud_cost`, plus each cloud's mean particle box centre (T, 2) and height (T,)
    in pixels (NaN for a cloud without a finite box), which the scatter estimate reads."""
    T, K = len(targets), len(detections)
    cost = np.full((T, K), np.inf)
    centre, height = np.full((T, 2), np.nan), np.full(T, np.nan)
    if T == 0 or K == 0:
        return cost, centre, height
    boxes = [_particle_boxes(t) for t in targets]
    db = detections.boxes_xywh_px
    dc = db[:, :2] + 0.5 * db[:, 2:]  # (K, 2)
    dh = np.maximum(db[:, 3], 1e-6)  # (K,)
    if len({len(b) for b in boxes}) == 1:
        groups = [(list(range(T)), np.stack(boxes))]
    else:
        groups = [([j], b[None]) for j, b in enumerate(boxes)]
    sx, sy = (float(sigma), float(sigma)) if np.ndim(sigma) == 0 else map(float, sigma)
    ix, iy = 0.5 / sx ** 2, 0.5 / sy ** 2
    for rows, pb in groups:  # pb (R, N, 4)
        ok = np.isfinite(pb).all(axis=2)  # (R, N)
        pc = pb[..., :2] + 0.5 * pb[..., 2:]  # (R, N, 2)
        # squared centre distance in detection heights (R, K, N)
        dx = (dc[None, :, None, 0] - pc[:, None, :, 0]) / dh[None, :, None]
        dy = (dc[None, :, None, 1] - pc[:, None, :, 1]) / dh[None, :, None]
        e = -(dx * dx * ix + dy * dy * iy)
        e = np.where(ok[:, None, :], e, -np.inf)
        m = e.max(axis=2, keepdims=True)
        finite = np.isfinite(m)
        m = np.where(finite, m, 0.0)
        n_ok = ok.sum(axis=1)  # (R,)
        with np.errstate(divide="ignore"):
            lse = (m[..., 0] + np.log(np.exp(e - m).sum(axis=2))
                   - np.log(np.maximum(n_ok, 1))[:, None])  # (R, K)
        h = np.where(ok, pb[..., 3], np.nan)
        with np.errstate(invalid="ignore"):
            th = np.nanmean(h, axis=1) if ok.any() else np.full(len(pb), np.nan)  # (R,)
        r = np.log(dh[None, :] / np.maximum(th[:, None], 1e-6)) / float(sigma_size)
        c = -(lse - 0.5 * r * r)
        c = np.where(finite[..., 0] & (n_ok[:, None] > 0) & np.isfinite(c), c, np.inf)
        cost[rows] = c
        if ok.all():
            centre[rows] = pc.mean(axis=1)
            height[rows] = pb[..., 3].mean(axis=1)
        else:
            for row, b in zip(rows, pb):
                centre[row], height[row] = _cloud_mean(b)
    return cost, centre, height


def _solve(cost: np.ndarray, max_cost: float) -> list[tuple[int, int]]:
    """Minimum-total-cost matching of the rows and columns of ``cost``; pairs over
    ``max_cost`` are never matched (and cost nothing to leave unmatched)."""
    from scipy.optimize import linear_sum_assignment

    if cost.size == 0:
        return []
    feasible = cost <= max_cost
    if not feasible.any():
        return []
    c = np.where(feasible, cost - max_cost, 0.0)  # a pair below the gate gains; others nothing
    rows, cols = linear_sum_assignment(c)
    return [(int(i), int(j)) for i, j in zip(rows, cols) if feasible[i, j]]


class Refind(ParamGroup):
    """How a lost track is re-found (group ``refind`` of :class:`CloudAssociator`): a
    confident detection left unmatched may continue a track unmatched for ``recent_misses``
    frames or more that was hidden behind another track when last seen, when it lies where the
    person could have walked to while hidden, has about their height and, when colour is
    known, their colours.

    {params}
    """

    speed: float = Param(0.5, "How far a hidden person may have walked, per second lost, in "
                         "heights of the track's last matched box (0.5: about 0.85 m/s for "
                         "a person 1.7 m tall).", unit="heights/s", low=0.0)
    margin: float = Param(0.3, "Distance allowed at once, whatever the time lost, in heights "
                          "of the track's last matched box (the box's own scatter and a "
                          "step).", unit="heights", low=0.0)
    size: float = Param(0.2, "Largest absolute log of the ratio of the detection's height to the "
                        "last matched box's (0.2: within 18 % smaller to 22 % larger).",
                        unit="1", low=0.0, low_open=True)
    covered: float = Param(0.5, "Only a track this much of whose box (a fraction of its "
                           "area) another track's box covered when it was last matched is "
                           "re-found: a person lost behind someone, not a detector's passing "
                           "miss of a thing that stands still.", unit="1", low=0.0,
                           high=1.0)
    min_appearance: float = Param(0.5, "Least colour similarity (Target.appearance_scores, "
                                  "0-1) of the detection to the track, when the track "
                                  "management supplies one.", unit="1", low=0.0, high=1.0)


class CloudAssociator(Associator):
    """Global association on each track's predicted likelihood of each detection, confident
    detections first (see the module docstring).

    The detector's scatter is measured during the run: the residuals of the pairs matched to
    tracks that were matched in the previous frame (detection centre minus the cloud's mean
    centre, in detection heights, per axis; the log height ratio), their robust standard
    deviation (1.4826 times the median absolute residual) over the last 1000 pairs. It is
    blended with the assumed ``sigma`` and ``sigma_size`` as if those had been measured on 50
    pairs, and kept between a quarter and twice them. A detector whose boxes scatter by a few
    pixels around people 500 pixels tall is then held to that, and one whose boxes scatter by
    a tenth of a small person's height to that, with no setting per video or detector.

    Attributes
    ----------
    cost_ : ndarray (T, K)
        The last frame's cost matrix (tracks x detections), appearance included.
    scatter_ : (float, float, float)
        The scatter the last frame's costs used: horizontal and vertical centre (detection
        heights) and log height ratio.
    """

    sigma: float = Param(0.1, "Standard deviation of a detection's box centre about a "
                         "predicted particle's box centre, in detection heights: the "
                         "detector's own scatter (the cloud's spread adds to it), as assumed "
                         "before the run has measured it (see the class docstring).",
                         unit="1", low=0.0, low_open=True)
    sigma_size: float = Param(0.2, "Standard deviation of the log ratio of a detection's "
                              "height to the track's mean particle box height, as assumed "
                              "before the run has measured it.", unit="1",
                              low=0.0, low_open=True)
    max_cost: float = Param(8.0, "Gate: a pair whose cost (negative log predicted "
                            "likelihood, appearance included) exceeds this is never matched. "
                            "8 admits a detection about 4 sigma from a tight cloud.",
                            unit="1", low=0.0, low_open=True)
    high_score: float = Param(0.6, "Detections at least this confident are matched first, "
                              "against every track; the others only in a second pass, to "
                              "tracks seen recently (recent_misses). On the detector's score "
                              "scale (a probability for calibrated detectors).",
                              unit="1", low=0.0)
    recent_misses: int = Param(2, "A track may take a less confident detection in the second "
                               "pass only if it went at most this many frames without a "
                               "match.", unit="frames", low=0)
    appearance_weight: float = Param(1.0, "Weight of the appearance cost "
                                     "-log(Target.appearance_scores), when the track "
                                     "management sets them (0: motion only). NaN scores bar "
                                     "the pair.", unit="1", low=0.0)
    refind: Refind = Group(Refind, "How a lost track is re-found by a confident detection "
                           "its cloud no longer explains.")

    def setup(self, context: object) -> None:
        """Start a run: the scatter is the assumed one until this run's pairs measure it; the
        run's frame rate converts the frames a track was lost into seconds."""
        self._fps = float(getattr(context, "fps", 0.0) or _DEFAULT_FPS)
        self._reset()

    def _ready(self) -> None:
        """Used without :meth:`setup`: set up as a run at the default frame rate."""
        if not hasattr(self, "_fps"):
            self.setup(None)

    def _reset(self) -> None:
        """Forget the measured scatter and the tracks' last matched boxes: a new run starts
        from the assumed values."""
        self._residuals = np.zeros((0, 3))
        self._last_box: dict[int, np.ndarray] = {}
        self._hidden: dict[int, bool] = {}
        self.scatter_ = (float(self.sigma), float(self.sigma), float(self.sigma_size))
        self._scatter_now = self.scatter_

    def _scatter(self) -> tuple[float, float, float]:
        """The (horizontal, vertical, size) scatter in use: the assumed values, or their
        blend with the measured ones."""
        prior = np.array([self.sigma, self.sigma, self.sigma_size], dtype=np.float64)
        r = getattr(self, "_residuals", None)
        if r is None or not len(r):
            return (float(prior[0]), float(prior[1]), float(prior[2]))
        n = len(r)
        a = np.abs(r)
        k = n // 2
        if n % 2:
            med = np.partition(a, k, axis=0)[k]
        else:
            part = np.partition(a, (k - 1, k), axis=0)
            med = (part[k - 1] + part[k]) / 2
        measured = 1.4826 * med  # robust standard deviations
        var = (_PRIOR_PAIRS * prior ** 2 + n * measured ** 2) / (_PRIOR_PAIRS + n)
        s = np.clip(np.sqrt(var), prior * _SCATTER_RANGE[0], prior * _SCATTER_RANGE[1])
        return (float(s[0]), float(s[1]), float(s[2]))

    def _learn(self, detections: Detections, matches: list[tuple[int, int]],
               misses: np.ndarray, centre: np.ndarray, height: np.ndarray) -> None:
        """Keep the residuals of this frame's pairs whose track was matched in the previous
        frame (``misses`` 0: its cloud is tight): detection centre minus the cloud's mean
        centre (``centre``, px), in detection heights, and the log ratio of the detection's
        height to the cloud's mean height (``height``, px)."""
        pairs = [(i, j) for i, j in matches if misses[i] == 0]
        if not pairs:
            return
        ti = np.array([i for i, _ in pairs], dtype=np.intp)
        d = detections.boxes_xywh_px[[j for _, j in pairs]]
        c, h = centre[ti], height[ti]
        ok = np.isfinite(h) & (d[:, 3] > 0)
        if not ok.any():
            return
        d, c, h = d[ok], c[ok], h[ok]
        rows = np.column_stack([(d[:, 0] + 0.5 * d[:, 2] - c[:, 0]) / d[:, 3],
                                (d[:, 1] + 0.5 * d[:, 3] - c[:, 1]) / d[:, 3],
                                np.log(d[:, 3] / np.maximum(h, 1e-6))])
        self._residuals = np.concatenate([self._residuals, rows])[-_WINDOW:]
        self._scatter_now = self._scatter()

    def costs(self, targets: Sequence[Target], detections: Detections) -> np.ndarray:
        """The (T, K) cost matrix: :func:`cloud_cost` plus the appearance cost."""
        return self._costs(targets, detections)[0]

    def _costs(self, targets: Sequence[Target], detections: Detections
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`costs`, and the clouds' mean centres and heights (see :func:`_cloud_cost`)."""
        self._ready()
        sx, sy, ss = self._scatter_now
        self.scatter_ = (sx, sy, ss)
        cost, centre, height = _cloud_cost(targets, detections, (sx, sy), ss)
        w = float(self.appearance_weight)
        K = len(detections)
        for j, t in enumerate(targets):
            a = t.appearance_scores
            if a is None or len(a) != K:
                continue
            a = np.asarray(a, dtype=np.float64)
            barred = np.isnan(a)
            if w > 0:
                with np.errstate(divide="ignore"):
                    cost[j] += w * -np.log(np.where(barred, 1.0, np.clip(a, 0.0, 1.0)))
            cost[j, barred] = np.inf
        return cost, centre, height

    def associate(self, targets: Sequence[Target], detections: Detections) -> Assignment:
        """Match targets to detections; ``Assignment.matches`` rows are (target, detection)."""
        T, K = len(targets), len(detections)
        self._ready()
        self._note_hidden(targets)
        cost, centre, height = self._costs(targets, detections)
        self.cost_ = cost
        gate = float(self.max_cost)
        high = np.flatnonzero(detections.scores >= float(self.high_score))
        low = np.flatnonzero(detections.scores < float(self.high_score))
        matches = [(i, int(high[j])) for i, j in _solve(cost[:, high], gate)]
        if len(low):
            taken = {i for i, _ in matches}
            recent = np.array([i for i in range(T) if i not in taken
                               and targets[i].misses <= int(self.recent_misses)], dtype=np.intp)
            if len(recent):
                sub = cost[np.ix_(recent, low)]
                matches += [(int(recent[i]), int(low[j])) for i, j in _solve(sub, gate)]
        misses = np.array([t.misses for t in targets], dtype=np.intp)
        self._learn(detections, matches, misses, centre, height)
        matches += self._refind(targets, detections, matches, high)
        self._remember(targets, detections, matches)
        return Assignment.from_matches(matches, T, K)

    def _refind(self, targets: Sequence[Target], detections: Detections,
                matches: list[tuple[int, int]], high: np.ndarray) -> list[tuple[int, int]]:
        """The third pass: lost tracks against the confident detections left unmatched,
        through the ``refind`` gate (see the module docstring)."""
        taken_t = {i for i, _ in matches}
        taken_d = {j for _, j in matches}
        lost = [i for i, t in enumerate(targets) if i not in taken_t and t.id in self._last_box
                and t.misses >= int(self.recent_misses) and self._hidden.get(t.id, False)]
        free = [int(j) for j in high if int(j) not in taken_d]
        if not lost or not free:
            return []
        g = self.refind
        last = np.array([self._last_box[targets[i].id] for i in lost])  # (L, 4)
        db = detections.boxes_xywh_px[free]  # (F, 4)
        h = np.maximum(last[:, 3], 1e-6)
        seconds = np.array([targets[i].misses + 1 for i in lost]) / self._fps
        reach = float(g.margin) + float(g.speed) * seconds  # (L,) heights
        dist = np.hypot(*((db[None, :, :2] + 0.5 * db[None, :, 2:])
                          - (last[:, None, :2] + 0.5 * last[:, None, 2:])).transpose(2, 0, 1))
        with np.errstate(divide="ignore", invalid="ignore"):  # no reach: nothing passes
            dist = dist / h[:, None] / reach[:, None]  # fraction of the reach
        ratio = np.abs(np.log(np.maximum(db[None, :, 3], 1e-6) / h[:, None])) / float(g.size)
        cost = np.where((dist <= 1.0) & (ratio <= 1.0), dist + ratio, np.inf)
        K = len(detections)
        for r, i in enumerate(lost):
            a = targets[i].appearance_scores
            if a is None or len(a) != K:
                continue
            a = np.asarray(a, dtype=np.float64)[free]
            ok = np.isfinite(a) & (a >= float(g.min_appearance))
            with np.errstate(divide="ignore"):
                cost[r] = np.where(ok, cost[r] - np.log(np.where(ok, a, 1.0)), np.inf)
        feasible = np.isfinite(cost)
        if not feasible.any():
            return []
        from scipy.optimize import linear_sum_assignment

        rows, cols = linear_sum_assignment(np.where(feasible, cost, _INFEASIBLE))
        return [(lost[r], free[c]) for r, c in zip(rows, cols) if feasible[r, c]]

    def _note_hidden(self, targets: Sequence[Target]) -> None:
        """For each track matched in the previous frame, whether at least ``refind.covered``
        of its box lies under another track's box (both as estimated then): kept until it is
        matched again, it says whether a track that goes unseen was lost behind someone."""
        seen = [i for i, t in enumerate(targets) if t.misses == 0]
        if not seen:
            return
        b = np.array([np.asarray(t.box_xywh_px, dtype=np.float64) for t in targets])  # (T, 4)
        cover = covered_fraction(b[seen][:, None], b[None])  # (S, T)
        cover[np.arange(len(seen)), seen] = 0.0  # not covered by itself
        frac = cover.max(axis=1)
        for k, i in enumerate(seen):
            self._hidden[targets[i].id] = bool(frac[k] >= float(self.refind.covered))

    def _remember(self, targets: Sequence[Target], detections: Detections,
                  matches: list[tuple[int, int]]) -> None:
        """Each live track's last matched detection box (the re-find gate's origin)."""
        for i, j in matches:
            self._last_box[targets[i].id] = np.array(detections.boxes_xywh_px[j],
                                                     dtype=np.float64)
        live = {t.id for t in targets}
        for k in [k for k in self._last_box if k not in live]:
            del self._last_box[k]
        for k in [k for k in self._hidden if k not in live]:
            del self._hidden[k]
