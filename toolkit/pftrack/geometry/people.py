"""A ground-plane camera from the people in a video ("single view metrology from people").

People stand on the ground and are about the same height, so their image height grows with how
far below the horizon their feet are. For a level camera (zero tilt) at height ``H_c`` and a
person of height ``H_p`` the relation is exactly linear (Criminisi et al. 2000; Hoiem, Efros and
Hebert 2006)::

    h_img = (v_foot - v_horizon) * H_p / H_c

With a tilted (and rolled) camera :func:`estimate_camera_from_people` uses the exact pinhole
relation instead: a foot pixel is back-projected onto the ground z = 0, a vertical segment of
height ``H_p`` is erected there and its top is projected; the predicted image height is the
difference of the two rows. The parameters fitted are

* the tilt of the optical axis below the horizontal (which, with the focal length, fixes the
  horizon row),
* the roll about the optical axis (identified when people are seen across the image width: the
  horizon is then a sloping line), with a weak zero-mean prior (:data:`PRIOR_ROLL_SD_DEG`),
* the camera height above the ground, in units of the assumed mean person height (1.7 m by
  default): a wrong mean height scales the camera height and every ground distance by the same
  factor,
* the focal length only where it can be identified. Boxes carry it only through a second-order
  (tilt) effect of a few per cent across the image, which real boxes do not follow well enough:
  on PETS 2009 S2.L1's ground-truth boxes (lens distortion removed or not) the fit runs away to
  f > 5000 px against the true 1185 px, while boxes drawn from the true camera give it back
  within 2 %. What does carry it is the people's **lean**: upright people lean towards the
  vertical vanishing point, a few pixels over their height at the image's sides, and that point
  with the horizon fixes the focal length (``f^2 = d(p, horizon) d(p, vanishing point)`` for the
  principal point p). Given ``slants`` (each box's ``du/dv`` from
  :func:`~pftrack.workflows.calibrate.measure_slants`, which fits a line to the moving pixels' row
  centroids in the box) the focal length is fitted from the leans and the heights together. Without
  them it is a documented **prior**: a horizontal field of view of :data:`PRIOR_HFOV_DEG` degrees
  (a 6 mm lens on a 1/3" sensor, the middle of common surveillance lenses), 1-sigma
  :data:`PRIOR_LOG_FOCAL_SD` in log focal length (a factor 1.5), whose spread is propagated into
  the other figures' uncertainties; ``fit_focal=True`` fits it from the heights alone with that
  prior as a regulariser (for undistorted images and tight boxes), and ``focal_px=`` fixes a known
  one. ``fit.focal_identified``, ``fit.slants_used`` and ``fit.notes`` say which. On PETS 2009
  S2.L1 the leans with a pinhole gave 1237-1429 px against the true 1185 px: 4-21 % high, a bias
  the bootstrap 1-sigma (20-110 px) does not include,
* with the leans, a one-coefficient **radial lens distortion** ``k`` (the relative displacement
  at the image corner, :func:`camera_from_parameters`), zero-mean prior
  :data:`PRIOR_DISTORTION_SD` (``fit_distortion``). Barrel distortion pulls the image's sides
  towards the centre, which straightens the leans there: a pinhole fit then puts the vertical
  vanishing point too far and the focal length comes out long. On synthetic people seen
  through a lens with 4.6 % barrel distortion at the corner (boxes and leans noisy as the
  silhouettes give them) the pinhole fit's focal length is 5-7 % long and its median ground
  error 0.62-0.69 m; with ``k`` fitted, within 0.5 % and 0.09-0.15 m; through a distortion-free
  lens ``k`` stays within 0.003 of 0 (the test of the module). The leans are compared in the
  image as measured (the prediction distorted), not undistorted: undistorting noisy leans
  scales their noise with ``k``, which least squares would exploit.

The principal point is the image centre and the pixels are square (an offset of the principal
point along the rows is absorbed by the roll: checked on synthetic people, 60 px on a 768 px
image moves the focal length fitted from the leans by under 2 %).

Robustness: detector false positives (boxes whose height does not follow the row) are removed by
a RANSAC over the linear relation above (generalised to a sloping horizon,
``h = a v + b u + c``, minimal samples of 3 boxes, all hypotheses scored at once by MSAC's
truncated squares), then the exact model is refined on the inliers by
:func:`scipy.optimize.least_squares` with a soft-L1 (Huber like) loss on the log height ratio,
which also absorbs the spread of people's heights. The 1-sigma
uncertainties come from a bootstrap over the inlier boxes (``n_bootstrap`` refits, seeded
:class:`numpy.random.Generator`), or from the Jacobian when ``n_bootstrap=0``.

World frame of the result: metres, z up, the ground is z = 0, the camera centre is at
``(0, 0, camera_height_m)`` and its optical axis points along +y (seen from above). Any other
frame differs from it by a rigid motion in the ground plane: compare ground positions after a 2-D
rigid alignment (:func:`~pftrack.geometry.alignment.rigid_align_2d`,
:func:`~pftrack.geometry.alignment.compare_with_reference`).

Silhouettes: a detector's box heights are coarse (a scale pyramid's steps) and biased with the
person's size, which bends the height-row relation:
:func:`~pftrack.workflows.calibrate.measure_silhouettes` finds each person's top and bottom rows
and lean in the moving pixels (MOG2), and
:func:`~pftrack.geometry.people_boxes.refine_boxes_by_silhouettes` puts those rows into the boxes
(on PETS 2009 S2.L1's ``hog-people`` boxes the horizon error falls from 60-70 px to 1-25 px and the
camera height from 8.3-8.5 m to 6.6-7.2 m, real 7.07 m).
:func:`~pftrack.geometry.people_boxes.link_boxes` links boxes into people for a bootstrap over
people (``groups``), whose 1-sigma is the honest one (a person's boxes share errors).

Where the boxes come from: :func:`~pftrack.io.box_files.read_boxes_csv` (a user's clicked boxes),
:func:`~pftrack.io.box_files.read_detection_boxes` (a MOTChallenge ``det.txt``),
:func:`~pftrack.workflows.calibrate.detect_people` (a registered ``hog-people`` detector, else
OpenCV's HOG people detector); :func:`~pftrack.workflows.calibrate.estimate_camera_from_video` does
detection, leans and fit in one call (``pftrack calib people``).

The camera model given its parameters (:func:`camera_from_parameters`,
:func:`predicted_box_heights`, :func:`horizon_row`) and :class:`PeopleCameraFit` are in
:mod:`pftrack.geometry.people_model`; they import from here as well.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pftrack.geometry.boxes import foot_points
from pftrack.geometry.people_model import (
    PeopleCameraFit,
    _distort_slants,
    _fixed_rotation,
    _predict_heights,
    _rotation,  # noqa: F401 - re-exported
    _undistort_boxes,
    camera_from_parameters,
    horizon_row,
    predicted_box_heights,
)

__all__ = [
    "PRIOR_DISTORTION_SD",
    "PRIOR_HFOV_DEG",
    "PRIOR_LOG_FOCAL_SD",
    "PRIOR_ROLL_SD_DEG",
    "PeopleCameraFit",
    "camera_from_parameters",
    "estimate_camera_from_people",
    "horizon_row",
    "predicted_box_heights",
]

#: Horizontal field of view (degrees) of the focal-length prior: a typical surveillance lens.
PRIOR_HFOV_DEG = 45.0
#: 1-sigma of the focal-length prior in natural-log units (exp(0.4) = a factor 1.49).
PRIOR_LOG_FOCAL_SD = 0.4

#: 1-sigma (degrees) of the zero-mean prior on the roll: cameras are mounted nearly level, and a
#: few boxes near one row cannot pin a horizon's slope down.
PRIOR_ROLL_SD_DEG = 5.0

#: 1-sigma of the zero-mean prior on the radial lens distortion ``k`` fitted with the leans
#: (:func:`estimate_camera_from_people`): the relative radial displacement at the image corner
#: (0.1: a point at the corner is imaged 10 % nearer to, or further from, the centre than a
#: pinhole would put it). Chosen a priori, not fitted to any video: wide surveillance lenses
#: show barrel distortion of a few per cent at the corner.
PRIOR_DISTORTION_SD = 0.1

#: Fraction of a box, from its top, whose rows
#: :func:`~pftrack.workflows.calibrate.measure_slants` uses (the legs swing).
SLANT_TOP_FRACTION = 0.7


def _clean_boxes(boxes_xywh: Any, image_size: tuple[int, int], border_px: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    b = np.asarray(boxes_xywh, dtype=np.float64)
    if b.ndim != 2 or b.shape[1] < 4:
        raise ValueError(f"estimate_camera_from_people: boxes_xywh must have shape (N, 4) "
                         f"(x, y, w, h in pixels), got {b.shape}")
    b = b[:, :4]
    h = image_size[1]
    ok = np.all(np.isfinite(b), axis=1) & (b[:, 2] > 0) & (b[:, 3] > 0)
    # people cut by the top or bottom border have a wrong height or foot row
    ok &= (b[:, 1] > border_px) & (b[:, 1] + b[:, 3] < h - 1 - border_px)
    return b, ok


def _ransac_linear(feet: np.ndarray, hgt: np.ndarray, rng: np.random.Generator,
                   threshold: float, n_hypotheses: int, with_roll: bool) -> np.ndarray:
    """Inlier mask of the best ``h = a v + b u + c`` (or ``a v + c``) by relative error."""
    n = len(hgt)
    cols = [feet[:, 1], feet[:, 0], np.ones(n)] if with_roll else [feet[:, 1], np.ones(n)]
    A = np.column_stack(cols)
    k = A.shape[1]
    if n <= k:
        return np.ones(n, dtype=bool)
    # k distinct indices per hypothesis: argsort of uniform keys over at most 2000 candidates
    idx = np.argsort(rng.random((n_hypotheses, n)), axis=1)[:, :k] if n <= 2000 else \
        rng.integers(0, n, size=(n_hypotheses, k))
    As = A[idx]                        # (M, k, k)
    ys = hgt[idx]                      # (M, k)
    det = np.linalg.det(As)
    good = np.abs(det) > 1e-9 * np.abs(As).max(axis=(1, 2)) ** k
    if not good.any():
        return np.ones(n, dtype=bool)
    coef = np.linalg.solve(As[good], ys[good][..., None])[..., 0]  # (M', k)
    pred = coef @ A.T                                              # (M', N)
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.abs(np.log(hgt[None, :] / pred))
    err[~(pred > 0)] = np.inf
    # plausibility: heights grow downwards
    err[coef[:, 0] <= 0] = np.inf
    score = np.sum(np.minimum(err, threshold) ** 2, axis=1)  # MSAC: truncated squares
    best = int(np.argmin(score))
    return err[best] < threshold


def _init_from_linear(feet: np.ndarray, hgt: np.ndarray, centre: np.ndarray, f0: float,
                      person_height_m: float) -> np.ndarray:
    A = np.column_stack([feet[:, 1] - centre[1], feet[:, 0] - centre[0], np.ones(len(hgt))])
    wts = 1.0 / hgt  # relative errors
    coef, *_ = np.linalg.lstsq(A * wts[:, None], hgt * wts, rcond=None)
    a, b, c = coef
    a = max(a, 1e-3)
    v0 = -c / a                        # horizon row offset from the centre row at the centre col
    hc = person_height_m / a
    tilt = math.atan2(-v0, f0)
    roll = math.atan(-b / a)           # horizon slope dv/du = -b/a
    return np.array([math.log(f0), tilt, roll, math.log(max(hc, 0.1))])


def _predict_slants(params: np.ndarray, feet: np.ndarray, hgt: np.ndarray,
                    centre: np.ndarray, top_fraction: float = SLANT_TOP_FRACTION) -> np.ndarray:
    """``du/dv`` of upright people's axes under ``params`` (towards the vertical vanishing
    point ``K R e_z``), at the middle of the rows
    :func:`~pftrack.workflows.calibrate.measure_slants` uses."""
    f = math.exp(params[0])
    R = _fixed_rotation(params[1], params[2])
    rz = R[:, 2]
    v_mid = feet[:, 1] - (1 - top_fraction / 2) * hgt
    return ((feet[:, 0] - centre[0]) * rz[2] - f * rz[0]) / (
        (v_mid - centre[1]) * rz[2] - f * rz[1])


def _solve(p0: np.ndarray, feet: np.ndarray, hgt: np.ndarray, centre: np.ndarray,
           person_height_m: float, sigma: float, log_f0: float, fit_roll: bool,
           fit_focal: bool, slants: np.ndarray | None = None,
           sigma_s: float = 1.0, slant_scale: np.ndarray | None = None,
           top_fraction: float = SLANT_TOP_FRACTION, fit_dist: bool = False
           ) -> tuple[np.ndarray, Any]:
    """Least squares over the free ones of ``p = (log f, tilt, roll, log H_c, k)``; ``feet``,
    ``hgt`` and ``slants`` as observed (distorted when ``k`` is not 0)."""
    from scipy.optimize import least_squares

    free = np.array([fit_focal, True, fit_roll, True, fit_dist])
    fixed = np.zeros(5)
    fixed[:len(p0)] = p0
    use_dist = fit_dist or fixed[4] != 0.0  # (0: the observations are the pinhole's)
    log_h = np.log(hgt)
    if slants is not None:
        has = np.isfinite(slants)
        s_obs, s_feet, s_hgt = slants[has], feet[has], hgt[has]
        s_sd = sigma_s * (1.0 if slant_scale is None else slant_scale[has])
        # where each lean was measured: the box's centre column, the middle of its rows
        s_at = np.column_stack([s_feet[:, 0], s_feet[:, 1] - (1 - top_fraction / 2) * s_hgt])
        # _distort_slants' constants of the fit (its offsets and squared radii), inlined
        ds = s_at - centre
        r2s = float(centre @ centre)
        dds = np.sum(ds * ds, axis=1)
    if use_dist:
        # the undistortion is a function of the observed (distorted) pixels: their offsets from
        # the centre and squared radii are constants of the fit (_undistort_boxes, inlined)
        r2c = float(centre @ centre)
        d_f = feet - centre
        rad_f = np.sum(d_f * d_f, axis=1) / r2c
        d_t = feet[:, 1] - hgt - centre[1]
        rad_t = (d_f[:, 0] ** 2 + d_t ** 2) / r2c

    def fun(q: np.ndarray) -> np.ndarray:
        p = fixed.copy()
        p[free] = q
        if use_dist:
            k = float(p[4])
            fu = centre + d_f * (1.0 + k * rad_f)[:, None]
            hu = fu[:, 1] - centre[1] - d_t * (1.0 + k * rad_t)
            with np.errstate(invalid="ignore", divide="ignore"):
                r = (np.log(hu) - np.log(_predict_heights(p, fu, centre, person_height_m))
                     ) / sigma
        else:
            pred = _predict_heights(p, feet, centre, person_height_m)
            with np.errstate(invalid="ignore", divide="ignore"):
                r = (log_h - np.log(pred)) / sigma
        r[~np.isfinite(r)] = 10.0 / sigma  # foot above the horizon: a large, bounded residual
        if slants is not None:
            if use_dist:
                su = _predict_slants(p, fu[has], hu[has], centre, top_fraction)
                a = 2 * k / r2s
                c = a * (ds[:, 0] * su + ds[:, 1]) / (1.0 + k * dds / r2s + a * dds)
                pred_s = (su - c * ds[:, 0]) / (1.0 - c * ds[:, 1])
                rs = (s_obs - pred_s) / s_sd
            else:
                rs = (s_obs - _predict_slants(p, s_feet, s_hgt, centre, top_fraction)) / s_sd
            r = np.concatenate([r, np.where(np.isfinite(rs), rs, 10.0)])
        priors = []
        if fit_focal:
            priors.append((p[0] - log_f0) / PRIOR_LOG_FOCAL_SD)
        if fit_roll:
            priors.append(p[2] / math.radians(PRIOR_ROLL_SD_DEG))
        if fit_dist:
            priors.append(p[4] / PRIOR_DISTORTION_SD)
        return np.concatenate([r, priors]) if priors else r

    lo = np.array([math.log(20.0), -math.radians(89), -math.radians(45), math.log(0.05), -0.5])
    hi = np.array([math.log(1e5), math.radians(89), math.radians(45), math.log(1e4), 0.5])
    q0 = np.clip(fixed[free], lo[free] + 1e-9, hi[free] - 1e-9)
    res = least_squares(fun, q0, bounds=(lo[free], hi[free]), loss="soft_l1", f_scale=2.0,
                        x_scale="jac", max_nfev=200)
    p = fixed.copy()
    p[free] = res.x
    return p, res


def _figures(p: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """(horizon_row, camera_height_m, tilt_deg, roll_deg, focal_px, distortion_k) of p."""
    cam = camera_from_parameters(math.exp(p[0]), math.degrees(p[1]), math.degrees(p[2]),
                                 math.exp(p[3]), image_size)
    return np.array([horizon_row(cam), math.exp(p[3]), math.degrees(p[1]), math.degrees(p[2]),
                     math.exp(p[0]), float(p[4]) if len(p) > 4 else 0.0])


_FIGURE_NAMES = ("horizon_row", "camera_height_m", "tilt_deg", "roll_deg", "focal_px",
                 "distortion_k")


def estimate_camera_from_people(boxes_xywh: Any, image_size: tuple[int, int],
                                person_height_m: float = 1.7,
                                rng: np.random.Generator | int | None = None, *,
                                fit_roll: bool | None = None, focal_px: float | None = None,
                                fit_focal: bool = False,
                                inlier_threshold: float = 0.15, n_hypotheses: int = 512,
                                n_bootstrap: int = 100, border_px: float = 2.0,
                                slants: Any = None, min_slants: int = 30,
                                groups: Any = None,
                                slant_top_fraction: float = SLANT_TOP_FRACTION,
                                fit_distortion: bool | None = None
                                ) -> PeopleCameraFit:
    """Estimate a pinhole ground-plane camera from boxes around standing people.

    Parameters
    ----------
    boxes_xywh : array_like, shape (N, >=4)
        Person boxes ``x, y, w, h`` in pixels (left, top, width, height), from any number of
        frames; extra columns are ignored. The foot point is the bottom centre, the head the top
        centre. Boxes touching the top or bottom border (within ``border_px``) are not used.
        Boxes should hug the person (a detector's margins scale the camera height).
    image_size : (int, int)
        (width, height) of the image in pixels.
    person_height_m : float
        Mean height of the people, metres (default 1.7). The camera height and all ground
        distances scale with it.
    rng : numpy.random.Generator or int or None
        Randomness of the RANSAC and the bootstrap; an int seeds a new Generator; None means
        ``numpy.random.default_rng(0)`` (so the result is reproducible).
    fit_roll : bool, optional
        Fit the roll; default: when the boxes' foot points span at least a third of the width.
    focal_px : float, optional
        A known focal length (pixels): fixed, no prior.
    fit_focal : bool
        Fit the focal length from the boxes, regularised by the prior (default False: the prior's
        value is used and its spread propagated; see the module docstring for why).
    inlier_threshold : float
        RANSAC inlier bound on ``|log(h_observed / h_predicted)|`` (0.15: about +-16 %, three
        times the 5 % spread of ground-truth boxes around the fitted relation on PETS 2009).
    n_hypotheses : int
        RANSAC minimal samples (scored together, vectorised).
    n_bootstrap : int
        Bootstrap refits for the uncertainty; 0 uses the Jacobian (faster, assumes the
        residuals are independent and the model is locally linear).
    border_px : float
        Boxes this close to the top or bottom border are dropped.
    slants : array_like, shape (N,), optional
        Each box's lean ``du/dv`` (:func:`~pftrack.workflows.calibrate.measure_slants`; NaN: not
        measured). Upright people lean towards the vertical vanishing point, which with the horizon
        fixes the focal length: when at least ``min_slants`` of the inlier boxes have one (and
        ``focal_px`` is not given) the focal length is fitted from them and the box heights
        together, the prior kept as a weak regulariser.
    min_slants : int
        Fewest measured slants for that.
    groups : array_like of int, shape (N,), optional
        Which person each box is (e.g. :func:`~pftrack.geometry.people_boxes.link_boxes`; boxes of
        one person in consecutive frames share a number). A person's boxes over many frames are not
        independent measurements (a height, a posture, a bag, a direction of walking): with
        ``groups`` the bootstrap resamples people, with all their boxes, rather than boxes, and its
        1-sigma values are the wider, honest ones. (Weighing each person's leans as one lean was
        tried on PETS 2009 S2.L1 and made the focal length less stable across stretches: short
        fragments of people weigh as much as long tracks.)
    slant_top_fraction : float
        The part of the person, from the top, whose rows gave each lean (as measured:
        :func:`~pftrack.workflows.calibrate.measure_slants` 0.7,
        :func:`~pftrack.workflows.calibrate.measure_silhouettes` its ``top_fraction``). Unit: 1.
    fit_distortion : bool, optional
        Fit a one-coefficient radial lens distortion ``k`` (see :func:`camera_from_parameters`)
        with the focal length, from the leans and the heights, with a zero-mean prior of 1-sigma
        :data:`PRIOR_DISTORTION_SD`. Default (None): whenever the leans are used. Unmodelled
        barrel distortion straightens the leans at the image's sides and lengthens the focal
        length fitted from them (module docstring). False: a pinhole. Without leans it is not
        fitted (the heights alone do not pin it down).

    Returns
    -------
    PeopleCameraFit

    Raises
    ------
    ValueError
        Bad shapes or sizes, fewer than 3 usable boxes, boxes all on one row, or no consistent
        set of boxes (the message names the parameter and what to change).
    """
    w, h = (int(v) for v in image_size)
    if w <= 0 or h <= 0:
        raise ValueError(f"estimate_camera_from_people: image_size must be (width, height) > 0, "
                         f"got {image_size!r}")
    if not person_height_m > 0:
        raise ValueError(f"estimate_camera_from_people: person_height_m must be > 0, got "
                         f"{person_height_m!r}")
    if focal_px is not None and not focal_px > 0:
        raise ValueError(f"estimate_camera_from_people: focal_px must be > 0, got {focal_px!r}")
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(
        0 if rng is None else rng)
    boxes, usable = _clean_boxes(boxes_xywh, (w, h), border_px)
    n_all = len(boxes)
    if usable.sum() < 3:
        raise ValueError(f"estimate_camera_from_people: {int(usable.sum())} usable boxes of "
                         f"{n_all} (positive size, not cut by the top or bottom border); "
                         "at least 3 are needed, at several distances from the camera")
    ids = np.flatnonzero(usable)
    sl_all = None
    if slants is not None:
        sl = np.asarray(slants, dtype=np.float64).reshape(-1)
        if len(sl) != n_all:
            raise ValueError(f"estimate_camera_from_people: slants has {len(sl)} values for "
                             f"{n_all} boxes")
        sl_all = sl[ids]
    grp_all = None
    if groups is not None:
        gr = np.asarray(groups).reshape(-1)
        if len(gr) != n_all:
            raise ValueError(f"estimate_camera_from_people: groups has {len(gr)} values for "
                             f"{n_all} boxes")
        grp_all = np.unique(gr[ids], return_inverse=True)[1].reshape(-1)
    b = boxes[ids]
    feet = foot_points(b)
    hgt = b[:, 3]
    centre = np.array([(w - 1) / 2, (h - 1) / 2])
    notes: list[str] = []
    if np.ptp(feet[:, 1]) < 0.05 * h:
        raise ValueError(f"estimate_camera_from_people: the usable boxes' feet span only "
                         f"{np.ptp(feet[:, 1]):.1f} px of rows; boxes_xywh needs people at "
                         "several distances (feet spread over at least 5 % of the height)")
    if fit_roll is None:
        fit_roll = bool(np.ptp(feet[:, 0]) >= w / 3 and len(hgt) >= 4)
    if not fit_roll:
        notes.append("roll not fitted (fixed at 0): the boxes do not span the width")

    inl = _ransac_linear(feet, hgt, gen, inlier_threshold, n_hypotheses, fit_roll)
    if inl.sum() < 3:
        raise ValueError("estimate_camera_from_people: no 3 boxes agree on a horizon and a "
                         "camera height; check the boxes or raise inlier_threshold")
    f0 = focal_px if focal_px is not None else (w / 2) / math.tan(math.radians(PRIOR_HFOV_DEG) / 2)
    log_f0 = math.log(f0)
    p0 = _init_from_linear(feet[inl], hgt[inl], centre, f0, person_height_m)
    if not fit_roll:
        p0[2] = 0.0
    fit_focal = bool(fit_focal) and focal_px is None
    # robust scale of the initial relative residuals
    r0 = np.log(hgt[inl] / _predict_heights(p0, feet[inl], centre, person_height_m))
    r0 = r0[np.isfinite(r0)]
    sigma = max(1.4826 * float(np.median(np.abs(r0 - np.median(r0)))) if r0.size else 0.1, 0.02)
    p, _ = _solve(p0, feet[inl], hgt[inl], centre, person_height_m, sigma, log_f0, fit_roll,
                  fit_focal)
    # final inliers against the exact model (all usable boxes), then refit
    for _ in range(2):
        r = np.log(hgt / _predict_heights(p, feet, centre, person_height_m))
        finite = np.isfinite(r)
        med = np.median(r[finite & inl]) if np.any(finite & inl) else 0.0
        mad = 1.4826 * float(np.median(np.abs(r[finite & inl] - med))) if np.any(
            finite & inl) else sigma
        sigma = max(mad, 0.02)
        new_inl = finite & (np.abs(r) < max(3.0 * sigma, 0.05)) & (np.abs(r) < inlier_threshold)
        if new_inl.sum() < 3:
            break
        inl = new_inl
        p, res = _solve(p, feet[inl], hgt[inl], centre, person_height_m, sigma, log_f0,
                        fit_roll, fit_focal)
    # the people's lean: the vertical vanishing point, hence the focal length
    sl_in, sigma_s, n_slants, sl_scale = None, 1.0, 0, None
    fit_dist = False
    tf = float(slant_top_fraction)
    if sl_all is not None and focal_px is None:
        n_slants = int(np.isfinite(sl_all[inl]).sum())
        if n_slants >= min_slants:
            sl_in = sl_all[inl]
            fit_focal = True
            fit_dist = fit_distortion is not False
            people = ""
            if grp_all is not None:
                g_in = grp_all[inl]
                people = f" of {len(np.unique(g_in[np.isfinite(sl_in)]))} people"
            for _ in range(2):
                fu, hu = _undistort_boxes(p, feet[inl], hgt[inl], centre)
                pred_s = _predict_slants(p, fu, hu, centre, tf)
                if p[4] != 0.0:
                    pred_s = _distort_slants(np.column_stack(
                        [feet[inl, 0], feet[inl, 1] - (1 - tf / 2) * hgt[inl]]), pred_s,
                        float(p[4]), centre)
                rs = sl_in - pred_s
                rs = rs[np.isfinite(rs)]
                sigma_s = max(1.4826 * float(np.median(np.abs(rs - np.median(rs)))), 1e-3)
                p, _ = _solve(p, feet[inl], hgt[inl], centre, person_height_m, sigma, log_f0,
                              fit_roll, True, sl_in, sigma_s, sl_scale, tf, fit_dist)
            notes.append(f"focal length from {n_slants} leans{people} (the vertical "
                         f"vanishing point) and the heights, 1-sigma of a lean {sigma_s:.3f}")
            if fit_dist:
                notes.append(f"radial lens distortion fitted with it: k = {p[4]:.4f} (relative "
                             f"displacement at the image corner, prior 1-sigma "
                             f"{PRIOR_DISTORTION_SD:g})")
        else:
            notes.append(f"only {n_slants} slants measured on inlier boxes (< min_slants = "
                         f"{min_slants}): not used")
    figs = _figures(p, (w, h))

    # uncertainty
    free = np.array([fit_focal, True, fit_roll, True, fit_dist])
    fi, hi_ = feet[inl], hgt[inl]
    if n_bootstrap > 0 and len(hi_) >= 4:
        method = "bootstrap"
        samples = np.empty((n_bootstrap, len(_FIGURE_NAMES)))
        g_in = None if grp_all is None else grp_all[inl]
        if g_in is None:
            reps = gen.integers(0, len(hi_), size=(n_bootstrap, len(hi_)))
        else:
            members = np.unique(g_in)
            by_person = np.argsort(g_in, kind="stable")
            bounds = np.searchsorted(g_in[by_person], np.arange(int(g_in.max()) + 2))
        for k in range(n_bootstrap):
            if g_in is None:
                rep_k = reps[k]
            else:  # resample people, with all their boxes
                pick = gen.choice(members, size=len(members))
                rep_k = np.concatenate([by_person[bounds[m]:bounds[m + 1]] for m in pick])
            pk, _ = _solve(p, fi[rep_k], hi_[rep_k], centre, person_height_m, sigma, log_f0,
                           fit_roll, fit_focal, None if sl_in is None else sl_in[rep_k],
                           sigma_s, None if sl_scale is None else sl_scale[rep_k], tf,
                           fit_dist)
            samples[k] = _figures(pk, (w, h))
        sd = np.std(samples, axis=0, ddof=1)
    else:
        method = "jacobian"
        _, res = _solve(p, fi, hi_, centre, person_height_m, sigma, log_f0, fit_roll, fit_focal,
                        sl_in, sigma_s, sl_scale, tf, fit_dist)
        J = res.jac
        cov_q = np.linalg.pinv(J.T @ J)
        # figures' Jacobian w.r.t. the free parameters by central differences
        qf = p[free]
        G = np.empty((len(_FIGURE_NAMES), qf.size))
        for j in range(qf.size):
            e = np.zeros(len(p))
            e[np.flatnonzero(free)[j]] = 1e-6
            G[:, j] = (_figures(p + e, (w, h)) - _figures(p - e, (w, h))) / 2e-6
        sd = np.sqrt(np.maximum(np.diag(G @ cov_q @ G.T), 0.0))
    if not fit_focal and focal_px is None:
        # the prior's spread, propagated by refitting at f0 exp(+-sd)
        ends = []
        for sgn in (-1.0, 1.0):
            pk = p.copy()
            pk[0] = log_f0 + sgn * PRIOR_LOG_FOCAL_SD
            pk, _ = _solve(pk, fi, hi_, centre, person_height_m, sigma, log_f0, fit_roll, False)
            ends.append(_figures(pk, (w, h)))
        prior_sd = np.abs(ends[1] - ends[0]) / 2
        prior_sd[4] = f0 * PRIOR_LOG_FOCAL_SD
        sd = np.sqrt(sd ** 2 + prior_sd ** 2)
    unc = {k: float(v) for k, v in zip(_FIGURE_NAMES, sd)}
    if not fit_roll:
        unc["roll_deg"] = 0.0
    if not fit_dist:
        unc["distortion_k"] = 0.0
    if focal_px is not None:
        unc["focal_px"] = 0.0
        notes.append(f"focal length given ({focal_px:g} px), not fitted")
        focal_identified = True
    elif not fit_focal:
        focal_identified = False
        notes.append(f"focal length not identified from boxes: the prior's {f0:.1f} px "
                     f"(horizontal field of view {PRIOR_HFOV_DEG:g} deg, log-sd "
                     f"{PRIOR_LOG_FOCAL_SD:g}, propagated into the uncertainties); the horizon "
                     "row and camera height are fitted")
    else:
        post_log_sd = unc["focal_px"] / figs[4]
        focal_identified = bool(post_log_sd < 0.5 * PRIOR_LOG_FOCAL_SD)
        if not focal_identified:
            fitted_from = (f"the {n_slants} leans and the heights" if sl_in is not None
                           else "the boxes")
            notes.append(f"focal length not identified: fitted from {fitted_from} to "
                         f"{figs[4]:.0f} +- {unc['focal_px']:.0f} px (log-sd {post_log_sd:.2f}, "
                         f"not under half the prior's {PRIOR_LOG_FOCAL_SD:g}; the prior: "
                         f"{f0:.0f} px, a horizontal field of view of {PRIOR_HFOV_DEG:g} deg); "
                         "the horizon row and camera height are still fitted")
    cam = camera_from_parameters(figs[4], figs[2], figs[3], figs[1], (w, h),
                                 distortion_k=float(figs[5]))
    cam.metadata["source"] = (f"pftrack.geometry.people: {int(inl.sum())} of {n_all} boxes, "
                              f"person height {person_height_m:g} m")
    mask = np.zeros(n_all, dtype=bool)
    mask[ids[inl]] = True
    fi, hi_ = _undistort_boxes(p, feet[inl], hgt[inl], centre)
    rr = np.log(hi_ / _predict_heights(p, fi, centre, person_height_m))
    rsd = float(1.4826 * np.median(np.abs(rr - np.median(rr))))
    fit = PeopleCameraFit(camera=cam, horizon_row=float(figs[0]), camera_height_m=float(figs[1]),
                           tilt_deg=float(figs[2]), roll_deg=float(figs[3]),
                           focal_px=float(figs[4]), focal_identified=focal_identified,
                           uncertainty=unc, inliers=mask, person_height_m=float(person_height_m),
                           residual_sd=rsd, uncertainty_method=method, notes=notes,
                           slants_used=n_slants if sl_in is not None else 0,
                           distortion_k=float(figs[5]), boxes_xywh=boxes.copy())
    # the file written from this camera records how it was made
    cam.metadata["people_fit"] = {k: v for k, v in fit.summary().items()}
    return fit
