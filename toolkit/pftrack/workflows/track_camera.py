"""The camera behind ``pftrack track``: estimated from the people it detects, checked before
it is used, and the detections placed on the ground through it.

- :func:`estimate_camera`: :func:`pftrack.geometry.people.estimate_camera_from_people` on the
  confident detections of the first frames, with each person's lean for the focal length
  (their silhouettes measured from the video, or while the detector decodes it:
  :class:`CalibrationSilhouettes`);
- :func:`camera_trust`: whether the estimate can be believed (the people's feet below its
  horizon, their heights following it, and the two halves of the frames agreeing on the camera's
  height);
- :func:`with_ground_points`: the detections' foot points on the ground.

Every name is also importable from :mod:`pftrack.workflows.track`.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np

from pftrack.contracts.components import Detections
from pftrack.geometry.boxes import foot_points

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera

__all__ = [
    "CalibrationSilhouettes",
    "camera_trust",
    "estimate_camera",
    "with_ground_points",
]


def estimate_camera(detections: dict[int, Detections], image_size: tuple[int, int], *,
                    person_height_m: float = 1.7, min_score: float = 0.5, min_boxes: int = 20,
                    seed: int = 0, video: str | os.PathLike[str] | None = None,
                    max_frames: int | None = 600, every: int = 2,
                    silhouette_scale: float = 0.5,
                    silhouettes: CalibrationSilhouettes | None = None) -> tuple[Any, str]:
    """A ground-plane camera from the detected people, or ``(None, why)``.

    Uses the detections scoring at least ``min_score`` (at least ``min_boxes`` of them). With
    ``video`` (the one the detections come from), each person's silhouette is measured in the
    moving pixels (:func:`pftrack.workflows.calibrate.measure_silhouettes`, one more pass over the
    frames with a background subtractor): the camera is fitted from the silhouettes' top and
    bottom rows (the detector's box heights are coarse) and the focal length from the people's
    lean (the vertical vanishing point) instead of the prior, with the lens's radial
    distortion (:func:`~pftrack.geometry.people.estimate_camera_from_people`'s
    ``fit_distortion``). Only every ``every``-th of the
    first ``max_frames`` frames' detections are used (``max_frames`` None: all), and the
    background model sees only those frames, at ``silhouette_scale`` of their size: the pass
    costs a bounded time however long the video is, and spreading it over more frames sees
    more people. ``silhouettes``: the same silhouettes measured during the detection pass
    (:class:`CalibrationSilhouettes`, used when it measured the boxes chosen here with the
    same settings; else the pass is made). How well the estimate places people on PETS 2009
    S2.L1 is measured by
    ``pftrack bench fresh-video`` (its ``camera_median_error_m``); why the distortion is fitted:
    docs/decisions/camera-from-people.md.
    Returns ``(PeopleCameraFit, description)`` or ``(None, reason)``; the fit's ``trust`` is
    :func:`camera_trust`'s verdict on the same boxes (whether to track on its ground plane).
    """
    from pftrack.geometry.people import estimate_camera_from_people
    from pftrack.workflows.calibrate import estimate_camera_from_video

    boxes, frames = [], []
    use = sorted(detections)
    if max_frames is not None:
        use = use[: int(max_frames)]
    for f in use:
        d = detections[f]
        keep = d.scores >= min_score
        boxes.append(d.boxes_xywh_px[keep])
        frames.append(np.full(int(keep.sum()), f))
    b = np.concatenate(boxes) if boxes else np.zeros((0, 4))
    fr = np.concatenate(frames) if frames else np.zeros(0)
    if len(b) < min_boxes:
        return None, (f"only {len(b)} person boxes scored >= {min_score} (need {min_boxes}) to "
                      "estimate a camera")
    thin = (fr - use[0]) % int(every) == 0
    if every > 1 and thin.sum() >= min_boxes:
        b, fr = b[thin], fr[thin]
    else:
        every = 1
    measured = None
    if silhouettes is not None and video is not None:
        measured = silhouettes.measured(use[0], len(b), min_score, max_frames, every,
                                        silhouette_scale)
    try:
        if video is not None:  # what `pftrack calib people` does with these boxes
            fit, _, _ = estimate_camera_from_video(
                video, np.column_stack([b, fr]), first=int(use[0]), silhouettes=True,
                silhouette_every=int(every), silhouette_scale=silhouette_scale,
                person_height_m=person_height_m, rng=np.random.default_rng(seed),
                silhouettes_measured=measured)
        else:
            fit = estimate_camera_from_people(b, image_size=image_size,
                                              person_height_m=person_height_m,
                                              rng=np.random.default_rng(seed))
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        return None, f"the camera could not be estimated from {len(b)} person boxes: {exc}"
    if not (np.isfinite(fit.camera_height_m) and fit.camera_height_m > 0):
        return None, f"the estimated camera height {fit.camera_height_m} is not usable"
    try:
        fitted = getattr(fit, "boxes_xywh", None)  # with silhouettes: their rows
        fit.trust = camera_trust(fit, fitted if fitted is not None and len(fitted) == len(b)
                                 else b, fr, image_size, seed=seed)
    except (ValueError, np.linalg.LinAlgError) as exc:  # not checkable: not trusted
        fit.trust = {"trusted": False, "reasons": [f"the camera could not be checked: {exc}"]}
    lean = ""
    if getattr(fit, "slants_used", 0):
        lean = (", focal length from their lean" if fit.focal_identified else
                ", focal length fitted to their lean but not identified (see camera_fit)")
    return fit, (f"estimated from {int(np.sum(fit.inliers))} of {len(b)} person boxes in "
                 f"frames {use[0]}-{use[-1]}{f' every {every}' if every > 1 else ''} (mean "
                 f"height {person_height_m} m{lean})")


class CalibrationSilhouettes:
    """The silhouettes :func:`estimate_camera` measures
    (:func:`pftrack.workflows.calibrate.measure_silhouettes`), measured while the detection
    pass decodes the frames (:func:`detect_video`'s ``silhouettes``) instead of in a pass of
    their own: fed each frame with its detections, it measures the boxes
    :func:`estimate_camera` will choose at these settings (scoring at least ``min_score``, in
    every ``every``-th of the first ``max_frames`` frames) with the same background model fed
    the same frames. The model's inputs of the ``warmup`` frames it learns before the first
    box are kept until that box comes (a few small images). When the camera estimate
    chooses other boxes (too few for ``every``), or the warm-up reaches before the frames
    decoded, :meth:`measured` gives None and the pass is made.
    """

    def __init__(self, min_score: float = 0.5, max_frames: int | None = 600, every: int = 2,
                 scale: float = 0.5, warmup: int = 20) -> None:
        from collections import deque

        self.min_score, self.max_frames, self.every = float(min_score), max_frames, int(every)
        self.scale, self.warmup = float(scale), int(warmup)
        self.use0: int | None = None  # the first frame decoded
        self.n = 0  # frames fed
        self.meter: Any = None
        self.possible = True
        self.pending: Any = deque(maxlen=self.warmup)  # (index, model input) before the 1st box
        self.rows: dict[int, np.ndarray] = {}  # frame: (K, 3) of its chosen boxes

    def feed(self, index: int, image: np.ndarray, detections: Detections) -> None:
        """The next frame of the detection pass (in order) and its detections."""
        from pftrack.workflows.calibrate import SilhouetteMeter

        self.n += 1
        if not self.possible or (self.max_frames is not None and self.n > self.max_frames):
            return
        if self.use0 is None:
            self.use0 = int(index)
        if (index - self.use0) % self.every:
            return
        keep = detections.scores >= self.min_score
        if self.meter is None:
            if not keep.any():
                self.pending.append((int(index),
                                     SilhouetteMeter.model_input(image, self.scale)))
                return
            self.meter = SilhouetteMeter(int(index), warmup=self.warmup, every=self.every,
                                         scale=self.scale)
            if self.meter.start < self.use0:  # its warm-up needs frames not decoded
                self.possible = False
                self.pending.clear()
                return
            for i, small in self.pending:
                if i >= self.meter.start:
                    self.meter.learn(i, None, small)
            self.pending.clear()
        fg = self.meter.learn(int(index), image)
        if fg is not None and keep.any():
            self.rows[int(index)] = self.meter.measure(fg, detections.boxes_xywh_px[keep])

    def measured(self, use0: int, n_boxes: int, min_score: float, max_frames: int | None,
                 every: int, scale: float) -> np.ndarray | None:
        """The silhouettes (N, 3) of :func:`estimate_camera`'s boxes when it chose them as
        this pass did (from frame ``use0``, these settings, ``n_boxes`` boxes); else None."""
        if not (self.possible and self.use0 == use0 and float(min_score) == self.min_score
                and max_frames == self.max_frames and int(every) == self.every
                and float(scale) == self.scale):
            return None
        out = (np.concatenate([self.rows[f] for f in sorted(self.rows)]) if self.rows
               else np.zeros((0, 3)))
        return out if len(out) == n_boxes else None


#: The camera-trust test (:func:`camera_trust`). A box's key for telling repeats apart: its
#: foot point and height on a grid of this fraction of its height, so that a static thing
#: seen in hundreds of frames counts once. Unit: box heights.
TRUST_DISTINCT_CELL = 0.05
#: Most distinct person boxes that may have their feet on or above the estimated horizon
#: (no ground point: the camera puts them in the sky), as a fraction. A right camera places
#: every standing person's feet below its horizon; a box above it is a false detection or a
#: wrong horizon, and past one in twenty it is the horizon. Unit: 1.
TRUST_MAX_ABOVE_HORIZON = 0.05
#: The people of the first and of the second half of the frames are two samples of the same
#: scene; each half's own height-row line (``h = a v + c``, RANSAC then least squares on its
#: distinct boxes) gives a camera height ``person_height / a`` and a horizon row ``-c / a``.
#: Most ratio of the largest to the smallest of three camera heights: the estimate's and the
#: two halves'. Every ground distance scales with the camera height, so estimates that
#: disagree by more than this factor leave the ground distances uncertain by as much. (The
#: straight line ignores the camera's tilt and lens, which alone moves its camera height some
#: tens of per cent from the full fit's on a camera looking down: the factor leaves room for
#: that. Measured: docs/decisions/camera-trust.md.) Unit: 1.
TRUST_MAX_HEIGHT_RATIO = 1.5
#: Most robust spread (1.4826 MAD) of ``log(box height / predicted height)`` over the distinct
#: usable boxes: people's heights spread by about 4 % and box errors add a few more; a spread
#: past 0.2 (heights off by 20 % typically) says the boxes do not follow the camera's
#: height-row relation. Unit: log ratio.
TRUST_MAX_SPREAD = 0.2
#: Fewest distinct usable boxes in each half of the frames for the split-half check. Unit:
#: boxes.
TRUST_MIN_HALF = 10


def _distinct(boxes_xywh: np.ndarray) -> np.ndarray:
    """Indices of the boxes (N, 4) that are not repeats of an earlier box on the
    :data:`TRUST_DISTINCT_CELL` grid (foot point and log height)."""
    if len(boxes_xywh) == 0:
        return np.zeros(0, dtype=np.intp)
    feet = foot_points(boxes_xywh)
    h = np.maximum(boxes_xywh[:, 3], 1e-9)
    cell = TRUST_DISTINCT_CELL
    key = np.column_stack([np.round(feet[:, 0] / (cell * h)), np.round(feet[:, 1] / (cell * h)),
                           np.round(np.log(h) / cell)])
    _, idx = np.unique(key, axis=0, return_index=True)
    return np.sort(idx)


def _height_row_line(feet: np.ndarray, heights: np.ndarray, rng: np.random.Generator
                     ) -> tuple[float, float] | None:
    """``(a, c)`` of the robust line ``h = a v + c`` through boxes' foot rows and heights
    (RANSAC as the camera fit's, then least squares on its inliers); None when it is not
    rising (no horizon below which people grow)."""
    from pftrack.geometry.people import _ransac_linear

    inl = _ransac_linear(feet, heights, rng, 0.3, 500, False)
    if inl.sum() < 3:
        return None
    A = np.column_stack([feet[inl, 1], np.ones(int(inl.sum()))])
    a, c = np.linalg.lstsq(A, heights[inl], rcond=None)[0]
    if not (np.isfinite(a) and a > 0):
        return None
    return float(a), float(c)


def camera_trust(fit: Any, boxes_xywh: np.ndarray, frames: np.ndarray,
                 image_size: tuple[int, int], seed: int = 0) -> dict[str, Any]:
    """Whether a camera estimated from people can be trusted, measured on the boxes it came
    from, and the figures behind the decision.

    The boxes used are the confident detections not cut by the frame's top or bottom (a
    cut box has a wrong foot row or height), each counted once however many frames it
    repeats in (:data:`TRUST_DISTINCT_CELL`: a static false positive seen for minutes would
    otherwise outvote the people). The camera is trusted when all of these hold:

    * ``above_horizon`` <= :data:`TRUST_MAX_ABOVE_HORIZON`: the share of those boxes whose
      foot point the camera cannot put on the ground (on or above its horizon);
    * ``spread`` <= :data:`TRUST_MAX_SPREAD`: the boxes' heights follow the camera's
      height-row relation;
    * split-half agreement: the people of the first and of the second half of the frames,
      each fitted on its own by the straight height-row line, give camera heights within a
      factor :data:`TRUST_MAX_HEIGHT_RATIO` of each other and of the estimate's
      (``height_ratio``: the largest of the three over the smallest). When the people do not
      determine the camera (all of them at one distance, their feet cut by the frame, a few
      static things) the halves disagree with each other or the estimate wandered off where
      both halves agree; where they do determine it -- including a camera at head or waist
      height whose horizon passes through the people -- all three agree. Each half needs
      :data:`TRUST_MIN_HALF` distinct boxes. The halves' horizons are compared too, as the
      angle between them at the camera (``horizon_diff_deg``), but reported only: that angle
      leans on the focal length, which people often leave unidentified.

    Parameters
    ----------
    fit : PeopleCameraFit
    boxes_xywh : ndarray (N, 4)
        The person boxes the camera was estimated from, pixels.
    frames : ndarray (N,)
        Their frame numbers.
    image_size : (int, int)
        (width, height), pixels.
    seed : int
        Seed of the halves' RANSAC.

    Returns
    -------
    dict
        ``trusted`` (bool), ``reasons`` (list of str, empty when trusted) and the figures:
        ``boxes`` (distinct usable), ``above_horizon``, ``spread``, ``halves`` (each half's
        ``boxes``, ``camera_height_m``, ``horizon_row``), ``height_ratio``,
        ``horizon_diff_deg``, and ``horizon_through_people``: the share of the boxes that the
        horizon row (at the image's centre column) crosses, near 1 for a camera at head or
        waist height (not a reason to distrust it: such a camera is checked as any other).
    """
    from pftrack.geometry.people import _clean_boxes, predicted_box_heights

    w, h = (int(v) for v in image_size)
    b = np.asarray(boxes_xywh, dtype=np.float64).reshape(-1, 4)
    fr = np.asarray(frames, dtype=np.float64).reshape(-1)
    _, ok = _clean_boxes(b, (w, h), 2.0)
    b, fr = b[ok], fr[ok]
    keep = _distinct(b)
    b, fr = b[keep], fr[keep]
    out: dict[str, Any] = {"boxes": len(b)}
    reasons: list[str] = []
    if len(b) == 0:
        return {**out, "trusted": False,
                "reasons": ["no person box clear of the frame's top and bottom"]}
    feet = foot_points(b)
    ground = fit.camera.image_to_ground(feet)
    above = float(np.mean(~np.isfinite(ground).all(axis=1)))
    pred = predicted_box_heights(fit, feet, fit.person_height_m)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.log(b[:, 3] / pred)
    r = r[np.isfinite(r)]
    spread = (float(1.4826 * np.median(np.abs(r - np.median(r)))) if len(r) >= 3
              else float("inf"))
    hz = float(fit.horizon_row)
    through = float(np.mean((b[:, 1] < hz) & (feet[:, 1] > hz)))
    out.update(above_horizon=above, spread=spread, horizon_through_people=through)
    if above > TRUST_MAX_ABOVE_HORIZON:
        reasons.append(f"{above:.0%} of the people's feet are on or above its horizon (at "
                       f"most {TRUST_MAX_ABOVE_HORIZON:.0%})")
    if not spread <= TRUST_MAX_SPREAD:
        reasons.append(f"the box heights spread by {spread:.2f} (log ratio) about its "
                       f"height-row relation (at most {TRUST_MAX_SPREAD:g})")
    rng = np.random.default_rng(seed)
    mid = float(np.median(fr))
    halves: list[dict[str, Any]] = []
    heights: list[float] = []
    horizons: list[float] = []
    for part in (fr <= mid, fr > mid):
        line = (_height_row_line(feet[part], b[part, 3], rng)
                if part.sum() >= TRUST_MIN_HALF else None)
        if line is not None:
            heights.append(float(fit.person_height_m) / line[0])
            horizons.append(-line[1] / line[0])
        halves.append({"boxes": int(part.sum()),
                       "camera_height_m": None if line is None else heights[-1],
                       "horizon_row": None if line is None else horizons[-1]})
    out["halves"] = halves
    if len(heights) < 2:
        n = min(hf["boxes"] for hf in halves)
        out.update(height_ratio=None, horizon_diff_deg=None)
        reasons.append(f"the two halves of the frames could not be checked against each other "
                       f"(a half has {n} distinct boxes, at least {TRUST_MIN_HALF} needed, or "
                       "its people do not grow below a horizon)")
    else:
        h1, h2 = heights
        h0 = float(fit.camera_height_m)
        ratio = max(h0, h1, h2) / min(h0, h1, h2)
        dv = abs(horizons[0] - horizons[1])
        deg = float(np.degrees(np.arctan2(dv, fit.focal_px)))
        out.update(height_ratio=float(ratio), horizon_diff_deg=deg)
        if ratio > TRUST_MAX_HEIGHT_RATIO:
            reasons.append(f"it puts the camera {h0:.2f} m up, the people of the first and "
                           f"second half of the frames {h1:.2f} m and {h2:.2f} m (a factor "
                           f"{ratio:.2f}, at most {TRUST_MAX_HEIGHT_RATIO:g})")
    out["trusted"] = not reasons
    out["reasons"] = reasons
    return out


def with_ground_points(detections: dict[int, Detections], camera: Camera
                       ) -> dict[int, Detections]:
    """The same detections with their foot points back-projected to the ground (z = 0); NaN
    for a foot point on or above the camera's horizon, which cannot be placed on the ground:
    such a detection starts no track and proposes no particles, but a track matched to it in
    the image still takes it in its likelihood
    (:meth:`~pftrack.builtin.world_observation.CameraBoxObservation.position_from_box`)."""
    out = {}
    for f, d in detections.items():
        b = d.boxes_xywh_px
        feet = foot_points(b)
        pts = camera.image_to_ground(feet) if len(b) else np.zeros((0, 3))
        out[f] = Detections(b, d.scores, pts)
    return out
