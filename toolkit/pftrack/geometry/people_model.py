"""The camera that people standing on a ground plane imply, given its parameters: focal length,
tilt, roll, height above the ground and radial lens distortion (:func:`camera_from_parameters`),
the box heights and leans such a camera predicts for people at given foot points
(:func:`predicted_box_heights`), its horizon (:func:`horizon_row`), and what a fit returns
(:class:`PeopleCameraFit`). The fit itself, and the conventions, are in
:mod:`pftrack.geometry.people`, where these names import from as well.
"""


import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from pftrack.geometry.camera import Camera

# base rotation: camera looks along world +y, image down is world -z, image right is world +x
_R0 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def _rotation(tilt: float, roll: float) -> np.ndarray:
    """World-to-camera rotation for a camera tilted down by ``tilt`` and rolled by ``roll``
    (radians; positive roll makes the horizon fall to the right: its row grows with the column)."""
    ct, st = math.cos(tilt), math.sin(tilt)
    cr, sr = math.cos(roll), math.sin(roll)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, ct, -st], [0.0, st, ct]])
    rz = np.array([[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]])
    return rz @ rx @ _R0


@lru_cache(maxsize=64)
def _rotation_cached(tilt: float, roll: float, tilt_sign: float, roll_sign: float
                     ) -> np.ndarray:
    R = _rotation(tilt, roll)
    R.setflags(write=False)
    return R


def _fixed_rotation(tilt: float, roll: float) -> np.ndarray:
    """:func:`_rotation`, read-only, remembered for the last angles asked (a least-squares
    fit asks for the same angles while it varies the focal length or the camera height);
    keyed by the angles' signs too, so that -0.0 gets its own matrix."""
    t, r = float(tilt), float(roll)
    return _rotation_cached(t, r, math.copysign(1.0, t), math.copysign(1.0, r))


def camera_from_parameters(focal_px: float, tilt_deg: float, roll_deg: float,
                           camera_height_m: float, image_size: tuple[int, int],
                           name: str = "people", distortion_k: float = 0.0) -> Camera:
    """The pinhole camera of the parametrisation used here.

    Parameters
    ----------
    focal_px : float
        Focal length in pixels (fx = fy).
    tilt_deg : float
        Angle of the optical axis below the horizontal, degrees.
    roll_deg : float
        Rotation about the optical axis, degrees (positive: the horizon falls to the right).
    camera_height_m : float
        Height of the camera centre above the ground z = 0, metres.
    image_size : (int, int)
        (width, height) in pixels; the principal point is the image centre.
    distortion_k : float
        Radial lens distortion as the relative displacement at the image corner: a distorted
        pixel ``p`` is undistorted to ``c + (p - c) (1 + k |p - c|^2 / R^2)`` (``c`` the image
        centre, ``R`` the half diagonal; ``k > 0``: barrel). Stored as the equivalent
        :class:`~pftrack.geometry.camera.TsaiDistortion` (``kappa1 = k f^2 / R^2``); 0: none.

    Returns
    -------
    Camera
        Centre at ``(0, 0, camera_height_m)``, looking along +y seen from above.
    """
    from pftrack.geometry.camera import TsaiDistortion

    w, h = (int(v) for v in image_size)
    R = _rotation(math.radians(tilt_deg), math.radians(roll_deg))
    C = np.array([0.0, 0.0, float(camera_height_m)])
    dist = None
    if distortion_k:
        r2 = ((w - 1) / 2) ** 2 + ((h - 1) / 2) ** 2
        dist = TsaiDistortion(float(distortion_k) * focal_px ** 2 / r2)
    return Camera.from_pinhole(focal_px, focal_px, (w - 1) / 2, (h - 1) / 2, R, -R @ C,
                               (w, h), distortion=dist, name=name)


def horizon_row(camera: Camera, column: float | None = None) -> float:
    """Row (pixels) of the ground plane's vanishing line at ``column`` (default the principal
    point's column), from the camera's pinhole part (lens distortion ignored)."""
    line = np.linalg.inv(camera.K).T @ (camera.R @ np.array([0.0, 0.0, 1.0]))
    u = camera.cx if column is None else float(column)
    if abs(line[1]) < 1e-12:
        return float("nan")
    return float(-(line[0] * u + line[2]) / line[1])


def _undistort_pixels(points: np.ndarray, k: float, centre: np.ndarray) -> np.ndarray:
    """Pixels (N, 2) undistorted by the radial model of :func:`camera_from_parameters`
    (``k``: relative displacement at the corner; the half diagonal is ``|centre|``)."""
    d = points - centre
    return centre + d * (1.0 + k * np.sum(d * d, axis=1) / float(centre @ centre))[:, None]


def _distort_slants(points: np.ndarray, slants_u: np.ndarray, k: float, centre: np.ndarray
                    ) -> np.ndarray:
    """Leans ``du/dv`` of the undistorted image as the lens shows them at the distorted pixels
    ``points`` (N, 2): the direction ``(s, 1)`` through the inverse of the undistortion's
    Jacobian ``g I + a d d^T`` (``d = p - c``, ``g = 1 + k |d|^2 / R^2``, ``a = 2 k / R^2``),
    which keeps its direction as ``v - a d (d . v) / (g + a |d|^2)`` (Sherman-Morrison).

    The fit compares the leans in the image as measured (the prediction distorted, not the
    measurement undistorted): undistorting noisy leans would scale their noise with ``k``,
    and least squares would then pick the ``k`` that shrinks the noise (a bias).
    """
    d = points - centre
    r2 = float(centre @ centre)
    a = 2 * k / r2
    dd = np.sum(d * d, axis=1)
    c = a * (d[:, 0] * slants_u + d[:, 1]) / (1.0 + k * dd / r2 + a * dd)
    return (slants_u - c * d[:, 0]) / (1.0 - c * d[:, 1])


def _undistort_boxes(params: np.ndarray, feet: np.ndarray, hgt: np.ndarray,
                     centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Foot points and heights of the boxes as the undistorted image shows them under
    ``params[4]`` (the box's bottom and top centres undistorted); unchanged when it is 0."""
    k = float(params[4]) if len(params) > 4 else 0.0
    if k == 0.0:
        return feet, hgt
    fu = _undistort_pixels(feet, k, centre)
    tu = _undistort_pixels(np.column_stack([feet[:, 0], feet[:, 1] - hgt]), k, centre)
    return fu, fu[:, 1] - tu[:, 1]


def _predict_heights(params: np.ndarray, feet: np.ndarray, centre: np.ndarray,
                     person_height_m: float) -> np.ndarray:
    """Image heights (pixels) of people of ``person_height_m`` whose feet are at ``feet``
    (N, 2) under ``params = (log f, tilt, roll, log H_c[, k])`` (k, the distortion, is not
    used here: ``feet`` are undistorted pixels); NaN where the foot is not on the
    ground in front of the camera or the head is behind it."""
    f = math.exp(params[0])
    hc = math.exp(params[3])
    R = _fixed_rotation(params[1], params[2])
    xn = (feet - centre) / f
    d = np.column_stack([xn, np.ones(len(feet))]) @ R  # world directions (R.T @ d per row)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = hc / -d[:, 2]
    s[~(s > 0)] = np.nan
    # head relative to the camera centre: foot (s d) raised by the person height
    head = s[:, None] * d
    head[:, 2] += person_height_m
    hcam = head @ R.T
    with np.errstate(divide="ignore", invalid="ignore"):
        v_head = centre[1] + f * hcam[:, 1] / hcam[:, 2]
    v_head[~(hcam[:, 2] > 0)] = np.nan
    return feet[:, 1] - v_head


def predicted_box_heights(camera_or_fit: Any, feet_px: Any, person_height_m: float = 1.7
                          ) -> np.ndarray:
    """Image heights (pixels) of upright people of ``person_height_m`` standing at the foot
    pixels ``feet_px`` (N, 2), through any :class:`Camera` (or a :class:`PeopleCameraFit`).

    NaN where the foot ray misses the ground or the head is behind the camera.
    """
    cam = getattr(camera_or_fit, "camera", camera_or_fit)
    feet = np.asarray(feet_px, dtype=np.float64).reshape(-1, 2)
    ground = cam.image_to_ground(feet)
    head = ground.copy()
    head[:, 2] += person_height_m
    ok = np.all(np.isfinite(ground), axis=1)
    out = np.full(len(feet), np.nan)
    if ok.any():
        ph = cam.project(head[ok])
        out[ok] = cam.project(ground[ok])[:, 1] - ph[:, 1]
    return out


@dataclass
class PeopleCameraFit:
    """The result of :func:`estimate_camera_from_people`.

    Attributes
    ----------
    camera : Camera
        Pinhole camera, ground plane z = 0, metres (frame: see the module docstring).
    horizon_row : float
        Row (pixels) of the horizon at the image's centre column (negative: above the image).
    camera_height_m : float
        Camera centre above the ground, metres (proportional to ``person_height_m``).
    tilt_deg, roll_deg : float
        Optical axis below the horizontal; rotation about the axis (positive: the horizon falls
        to the right).
    focal_px : float
        Focal length in pixels (fx = fy); see ``focal_identified``.
    focal_identified : bool
        True when the focal length was given, or fitted (``fit_focal=True``) and the boxes
        narrowed the prior to under half its width; False means it is the prior's
        (``PRIOR_HFOV_DEG``).
    uncertainty : dict of str to float
        1-sigma of ``horizon_row``, ``camera_height_m``, ``tilt_deg``, ``roll_deg``,
        ``focal_px`` (bootstrap or Jacobian, see ``uncertainty_method``, plus the focal-length
        prior's spread when the focal length is the prior's); the spread of the assumed *mean*
        person height is not included (it scales ``camera_height_m``).
    inliers : ndarray of bool, shape (N,)
        Over the input boxes: the ones used in the final fit.
    person_height_m : float
        The mean person height assumed.
    residual_sd : float
        Robust (MAD) 1-sigma of ``log(h_observed / h_predicted)`` over the inliers: the spread
        of people's heights plus the detector's box error, relative.
    notes : list of str
        What was assumed or could not be identified.
    slants_used : int
        Boxes whose measured lean entered the fit (0: the focal length is not from leans).
    distortion_k : float
        Radial lens distortion fitted with the leans (:func:`camera_from_parameters`; 0: a
        pinhole, as without leans or with ``fit_distortion=False``).
    trust : dict or None
        Whether the camera can be trusted to track on, with the figures behind the verdict,
        when a caller checked it (:func:`pftrack.workflows.track_camera.camera_trust`); None:
        not checked.
    boxes_xywh : ndarray (N, 4) or None
        The boxes as fitted (``x, y, w, h`` pixels, one row per input box, in their order):
        with silhouettes (:func:`~pftrack.workflows.calibrate.estimate_camera_from_video`),
        their top and bottom rows from the silhouettes.
    """

    camera: Camera
    horizon_row: float
    camera_height_m: float
    tilt_deg: float
    roll_deg: float
    focal_px: float
    focal_identified: bool
    uncertainty: dict[str, float]
    inliers: np.ndarray
    person_height_m: float
    residual_sd: float
    uncertainty_method: str = "bootstrap"
    notes: list[str] = field(default_factory=list)
    slants_used: int = 0
    distortion_k: float = 0.0
    trust: dict[str, Any] | None = None
    boxes_xywh: np.ndarray | None = field(default=None, repr=False)

    def summary(self) -> dict[str, Any]:
        """The figures as a JSON-ready dict."""
        return {
            "horizon_row": self.horizon_row, "camera_height_m": self.camera_height_m,
            "tilt_deg": self.tilt_deg, "roll_deg": self.roll_deg, "focal_px": self.focal_px,
            "focal_identified": self.focal_identified,
            "uncertainty": dict(self.uncertainty), "uncertainty_method": self.uncertainty_method,
            "boxes": int(self.inliers.size), "inliers": int(self.inliers.sum()),
            "person_height_m": self.person_height_m, "residual_sd": self.residual_sd,
            "slants_used": self.slants_used, "distortion_k": self.distortion_k,
            "notes": list(self.notes),
        }
