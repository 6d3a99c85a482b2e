"""Camera calibration: from chessboard images, and from world <-> pixel correspondences.

Two entry points:

* :func:`calibrate_chessboard` -- OpenCV's standard recipe (``findChessboardCorners``,
  ``cornerSubPix`` with an 11 x 11 window, ``calibrateCamera``), as OpenCV's own
  ``calibration.cpp`` sample does it; optionally with ``CALIB_FIX_ASPECT_RATIO`` (fx = fy).
* :func:`calibrate_points` -- hand-picked world points (metres) and their pixels in one image,
  as the soccer paper does with soccer-field line intersections (the soccer paper's sec. 3.4 uses
  Tsai's method).

How :func:`calibrate_points` chooses (``method="auto"``):

* intrinsics known (``camera=`` given, or ``method="pnp"``): pose only, ``cv2.solvePnP``
  (SQPnP, then Levenberg-Marquardt refinement) on the undistorted pixels;
* coplanar points (all soccer-field points lie on z = 0): one view of a plane fixes only two
  intrinsic degrees of freedom, so like Tsai's coplanar method we fix the principal point (image
  centre unless given) and the aspect ratio, take the focal length from the plane's homography
  (``cv2.initCameraMatrix2D``) and run ``cv2.calibrateCamera`` with ``CALIB_USE_INTRINSIC_GUESS``
  fitting f, k1 (and k2 with ``radial_terms=2``) and the pose; points not on z = 0 are first moved
  to their plane's own frame;
* non-coplanar points (>= 6): a normalised DLT gives P = K[R|t] (RQ decomposition) as the initial
  guess, then ``cv2.calibrateCamera`` with ``CALIB_USE_INTRINSIC_GUESS`` (OpenCV requires a guess
  for non-planar rigs) refines it with the principal point free unless fixed;
* ``lens="tsai"``: the OpenCV result is refined by nonlinear least squares
  (``scipy.optimize.least_squares``) in Tsai's model (pose, f, kappa1; principal point and
  aspect as fixed above), so a camera in Tsai's terms is recovered in Tsai's terms.

Every result reports the reprojection error per point (pixels).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pftrack.geometry.camera import Camera, NoDistortion, OpenCVDistortion, TsaiDistortion

__all__ = [
    "CalibrationResult",
    "calibrate_chessboard",
    "calibrate_points",
    "check_against_mot",
    "dlt",
    "find_chessboard",
    "is_coplanar",
    "read_correspondences",
    "read_mot_world",
    "reprojection_errors",
    "rotation_angle_deg",
    "soccer_pitch_keypoints",
]


@dataclass
class CalibrationResult:
    """A calibrated camera and how well it fits its data.

    Attributes
    ----------
    camera : Camera
    rms_px : float
        Root mean square reprojection error over all points (pixels), as OpenCV reports it.
    residuals_px : ndarray, shape (N, 2)
        Reprojected minus observed pixel, per point (all views concatenated).
    method : str
        What was run (e.g. ``"coplanar: initCameraMatrix2D + calibrateCamera"``).
    views : list of str
        Chessboard images used (empty for point calibration).
    per_view_rms_px : list of float
    notes : list of str
        Images skipped, parameters held fixed, and the like.
    """

    camera: Camera
    rms_px: float
    residuals_px: np.ndarray
    method: str
    views: list[str] = field(default_factory=list)
    per_view_rms_px: list[float] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def errors_px(self) -> np.ndarray:
        """Reprojection error per point (pixels), shape (N,)."""
        return np.linalg.norm(self.residuals_px, axis=1)

    def summary(self) -> dict[str, Any]:
        """JSON-ready figures."""
        e = self.errors_px
        lens = self.camera.distortion
        dist = lens.coeffs.tolist() if isinstance(lens, OpenCVDistortion) else \
            [v for v in lens.params().values()]
        return {
            "method": self.method, "points": len(e), "rms_px": float(self.rms_px),
            "median_px": float(np.median(e)) if len(e) else math.nan,
            "max_px": float(e.max()) if len(e) else math.nan,
            "fx": self.camera.fx, "fy": self.camera.fy, "cx": self.camera.cx,
            "cy": self.camera.cy, "lens": lens.model, "dist": dist,
            "center_m": self.camera.center_m.tolist(), "notes": list(self.notes),
        }


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


def reprojection_errors(camera: Camera, points_world_m: Any, pixels: Any) -> np.ndarray:
    """Reprojected minus observed pixels, shape (N, 2)."""
    return camera.project(points_world_m) - np.asarray(pixels, dtype=np.float64)


def rotation_angle_deg(R1: np.ndarray, R2: np.ndarray) -> float:
    """Angle of the rotation ``R1 R2^T`` in degrees (0 when the rotations agree)."""
    c = (np.trace(np.asarray(R1) @ np.asarray(R2).T) - 1) / 2
    return math.degrees(math.acos(min(1.0, max(-1.0, c))))


def _check_spread(X: np.ndarray, x: np.ndarray) -> None:
    """Raise ``ValueError`` for correspondences no camera can be solved from: repeated points,
    or world or image points on one line (or one point)."""
    n_world = len(np.unique(X, axis=0))
    n_pixel = len(np.unique(x, axis=0))
    if n_world < len(X) or n_pixel < len(x):
        raise ValueError(f"correspondences repeat points: {len(X)} rows but {n_world} distinct "
                         f"world points and {n_pixel} distinct pixels")
    for name, P in (("world points", X), ("pixels", x)):
        c = P - P.mean(axis=0)
        sv = np.linalg.svd(c, compute_uv=False)
        if len(sv) < 2 or sv[1] <= 1e-9 * max(sv[0], 1e-300):
            raise ValueError(f"the {name} lie on one line: a camera needs points spread over "
                             "a plane or a volume")


def is_coplanar(points_world_m: Any, rel_tol: float = 1e-6) -> bool:
    """True when the points lie on one plane (smallest singular value of the centred points
    below ``rel_tol`` times the largest)."""
    p = np.asarray(points_world_m, dtype=np.float64)
    s = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
    return bool(s[-1] <= rel_tol * s[0])


def _plane_frame(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Q, c) such that ``Q @ (p - c)`` has z = 0 for points on the plane; det Q = +1.

    Points already on z = 0 get Q = I, c = 0 so the result needs no change of frame.
    """
    if np.all(points[:, 2] == 0):
        return np.eye(3), np.zeros(3)
    c = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - c)
    Q = vt.copy()
    if np.linalg.det(Q) < 0:
        Q[2] *= -1
    return Q, c


def dlt(points_world_m: Any, pixels: Any) -> np.ndarray:
    """Normalised direct linear transform: the 3x4 projection matrix P (pixels, metres).

    Needs >= 6 points not all on one plane. P is scaled so that the points have positive depth.
    """
    X = np.asarray(points_world_m, dtype=np.float64)
    x = np.asarray(pixels, dtype=np.float64)
    if len(X) < 6:
        raise ValueError(f"DLT needs at least 6 correspondences, got {len(X)}")
    if is_coplanar(X):
        raise ValueError("DLT needs points that are not all on one plane")

    def norm_t(p: np.ndarray) -> np.ndarray:
        c = p.mean(axis=0)
        s = math.sqrt(p.shape[1]) / np.mean(np.linalg.norm(p - c, axis=1))
        T = np.eye(p.shape[1] + 1)
        T[:-1, :-1] *= s
        T[:-1, -1] = -s * c
        return T

    T2, T3 = norm_t(x), norm_t(X)
    xn = (np.c_[x, np.ones(len(x))] @ T2.T)[:, :2]
    Xn = np.c_[X, np.ones(len(X))] @ T3.T
    n = len(X)
    A = np.zeros((2 * n, 12))
    A[0::2, 0:4] = Xn
    A[0::2, 8:12] = -xn[:, :1] * Xn
    A[1::2, 4:8] = Xn
    A[1::2, 8:12] = -xn[:, 1:2] * Xn
    _, _, vt = np.linalg.svd(A)
    Pn = vt[-1].reshape(3, 4)
    P = np.linalg.inv(T2) @ Pn @ T3
    depth = np.c_[X, np.ones(n)] @ P[2]
    if np.median(depth) < 0:
        P = -P
    return P


def _decompose_projection(P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """P = K [R | t] with K upper triangular, positive diagonal, K[2, 2] = 1; det R = +1."""
    from scipy.linalg import rq

    M = P[:, :3]
    K, R = rq(M)
    S = np.diag(np.sign(np.diag(K)))
    K, R = K @ S, S @ R
    scale = K[2, 2]
    K = K / scale
    t = np.linalg.solve(K, P[:, 3] / scale)
    if np.linalg.det(R) < 0:  # P was determined up to sign; flip both
        R, t = -R, -t
    return K, R, t


# --------------------------------------------------------------------------------------------
# Chessboard
# --------------------------------------------------------------------------------------------


def find_chessboard(image: np.ndarray, board: tuple[int, int],
                    subpix_window: int = 11) -> np.ndarray | None:
    """Inner-corner pixels (board[0] * board[1], 2) of a chessboard, sub-pixel refined; None if
    the board is not found."""
    import cv2

    grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    found, corners = cv2.findChessboardCorners(grey, tuple(board), flags=flags)
    if not found:
        return None
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 1e-4)
    corners = cv2.cornerSubPix(grey, corners, (subpix_window, subpix_window), (-1, -1), crit)
    return corners.reshape(-1, 2).astype(np.float64)


def calibrate_chessboard(images: Sequence[str | os.PathLike[str] | np.ndarray],
                         board: tuple[int, int] = (9, 6), square_m: float = 0.025,
                         fix_aspect: bool = False, radial_terms: int = 3,
                         subpix_window: int = 11, name: str = "chessboard") -> CalibrationResult:
    """Calibrate from views of a chessboard.

    Parameters
    ----------
    images : sequence of paths or BGR/grey arrays
    board : (columns, rows)
        Inner corners per row and per column (OpenCV's ``patternSize``), e.g. (9, 6).
    square_m : float
        Side of a square in metres; the views' poses come out in metres.
    fix_aspect : bool
        ``CALIB_FIX_ASPECT_RATIO`` with fx / fy = 1.
    radial_terms : int
        3 (k1, k2, k3, OpenCV's default), 2 (k3 fixed at 0) or 1.

    Returns
    -------
    CalibrationResult
        Its camera sits at the world origin (R = I, t = 0): a chessboard calibration gives
        intrinsics; each view's board pose is in ``notes``-free form through ``per_view_rms_px``.

    Raises
    ------
    FileNotFoundError, ValueError
        A missing/unreadable image, mixed image sizes, or fewer than 3 views with the board.
    """
    import cv2

    if square_m <= 0:
        raise ValueError(f"square_m must be > 0, got {square_m}")
    cols, rows = (int(b) for b in board)
    if cols < 2 or rows < 2:
        raise ValueError(f"board must be inner corners (columns, rows) >= 2, got {board}")
    obj = np.zeros((cols * rows, 3), np.float32)
    obj[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square_m
    obj_pts, img_pts, views, notes = [], [], [], []
    size: tuple[int, int] | None = None
    for i, im in enumerate(images):
        label = str(im) if not isinstance(im, np.ndarray) else f"image[{i}]"
        if not isinstance(im, np.ndarray):
            if not Path(im).is_file():
                raise FileNotFoundError(f"chessboard image {im} not found")
            arr = cv2.imread(str(im), cv2.IMREAD_GRAYSCALE)
            if arr is None:
                raise ValueError(f"{im}: OpenCV cannot read this image")
        else:
            arr = im
        wh = (arr.shape[1], arr.shape[0])
        if size is None:
            size = wh
        elif wh != size:
            raise ValueError(f"{label}: image size {wh} differs from the first image's {size}")
        corners = find_chessboard(arr, (cols, rows), subpix_window)
        if corners is None:
            notes.append(f"{label}: board {cols}x{rows} not found, skipped")
            continue
        obj_pts.append(obj)
        img_pts.append(corners.astype(np.float32).reshape(-1, 1, 2))
        views.append(label)
    if len(views) < 3:
        raise ValueError(f"only {len(views)} image(s) show a {cols}x{rows} board; need >= 3")
    assert size is not None
    flags = 0
    K0 = np.eye(3)
    if fix_aspect:
        flags |= cv2.CALIB_FIX_ASPECT_RATIO
    if radial_terms < 3:
        flags |= cv2.CALIB_FIX_K3
    if radial_terms < 2:
        flags |= cv2.CALIB_FIX_K2
    rms, K, dist, rvecs, tvecs = cv2.calibrateCamera(obj_pts, img_pts, size, K0, None,
                                                     flags=flags)
    lens = OpenCVDistortion.from_coeffs(dist.ravel())
    cam = Camera(K, np.eye(3), np.zeros(3), size, lens, name=name,
                 metadata={"calibration": {"board": [cols, rows], "square_m": square_m,
                                           "views": len(views), "rms_px": float(rms)}})
    res, per_view = [], []
    for o, p, rv, tv in zip(obj_pts, img_pts, rvecs, tvecs):
        proj, _ = cv2.projectPoints(o, rv, tv, K, dist)
        r = proj.reshape(-1, 2) - p.reshape(-1, 2)
        res.append(r)
        per_view.append(float(np.sqrt(np.mean(np.sum(r**2, axis=1)))))
    return CalibrationResult(cam, float(rms), np.concatenate(res).astype(np.float64),
                             "chessboard: findChessboardCorners + cornerSubPix + calibrateCamera",
                             views, per_view, notes)


# --------------------------------------------------------------------------------------------
# Correspondences
# --------------------------------------------------------------------------------------------


def read_correspondences(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read a CSV with a header naming columns X, Y, Z (metres) and u, v (pixels).

    Other columns (a point name, say) are ignored. Returns (points_world_m (N, 3),
    pixels (N, 2)).
    """
    import csv

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"correspondence file {p} not found")
    with p.open(newline="") as fh:
        reader = csv.DictReader(fh)
        if reader.fieldnames is None:
            raise ValueError(f"{p}: empty file")
        cols = {c.strip().lower(): c for c in reader.fieldnames}
        need = ["x", "y", "z", "u", "v"]
        missing = [c for c in need if c not in cols]
        if missing:
            raise ValueError(f"{p}: header must name columns X,Y,Z,u,v; missing {missing} "
                             f"(have {reader.fieldnames})")
        rows = []
        for i, row in enumerate(reader, start=2):
            try:
                rows.append([float(row[cols[c]]) for c in need])
            except (TypeError, ValueError):
                raise ValueError(f"{p}:{i}: not numbers: {row}") from None
    if not rows:
        raise ValueError(f"{p}: no correspondences")
    a = np.array(rows)
    return a[:, :3], a[:, 3:]


def _lens_flags(lens: str, radial_terms: int, tangential: bool) -> int:
    import cv2

    flags = 0
    if lens == "none":
        return cv2.CALIB_FIX_K1 | cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST
    if not tangential:
        flags |= cv2.CALIB_ZERO_TANGENT_DIST
    if radial_terms < 3:
        flags |= cv2.CALIB_FIX_K3
    if radial_terms < 2:
        flags |= cv2.CALIB_FIX_K2
    if radial_terms < 1:
        flags |= cv2.CALIB_FIX_K1
    return flags


def _refine_tsai(camera: Camera, X: np.ndarray, x: np.ndarray, fix_principal_point: bool,
                 fix_aspect: bool) -> Camera:
    """Nonlinear least squares in Tsai's model: pose, f, kappa1 (+ principal point, aspect)."""
    import cv2
    from scipy.optimize import least_squares

    w, h = camera.image_size
    fy0, asp0 = camera.fy, camera.fx / camera.fy
    k0 = camera.distortion.kappa1 if isinstance(camera.distortion, TsaiDistortion) else 0.0

    def build(p: np.ndarray) -> Camera:
        R = cv2.Rodrigues(p[0:3])[0]
        fy = fy0 * math.exp(p[6])
        i = 8
        cx, cy, asp = camera.cx, camera.cy, asp0
        if not fix_principal_point:
            cx, cy = p[i], p[i + 1]
            i += 2
        if not fix_aspect:
            asp = p[i]
        return Camera.from_pinhole(asp * fy, fy, cx, cy, R, p[3:6], (w, h),
                                   TsaiDistortion(p[7]), name=camera.name)

    p0 = [*camera.rvec, *camera.t_m, 0.0, k0]
    if not fix_principal_point:
        p0 += [camera.cx, camera.cy]
    if not fix_aspect:
        p0 += [asp0]

    def fun(p: np.ndarray) -> np.ndarray:
        r = build(p).project(X) - x
        return np.nan_to_num(r, nan=1e6).ravel()

    sol = least_squares(fun, np.asarray(p0, dtype=np.float64), method="lm", xtol=1e-14,
                        ftol=1e-14, gtol=1e-14, max_nfev=20000)
    return build(sol.x)


def calibrate_points(points_world_m: Any, pixels: Any, image_size: Sequence[int], *,
                     lens: str = "opencv", camera: Camera | None = None, method: str = "auto",
                     fix_principal_point: bool | None = None,
                     principal_point: Sequence[float] | None = None, fix_aspect: bool = True,
                     radial_terms: int = 1, tangential: bool = False,
                     name: str = "points") -> CalibrationResult:
    """Calibrate one camera from world <-> pixel correspondences.

    Parameters
    ----------
    points_world_m : array_like, shape (N, 3)
        World points in metres.
    pixels : array_like, shape (N, 2)
        Where they appear in the image (pixels, distorted as observed).
    image_size : (width, height)
    lens : {"opencv", "tsai", "none"}
        Lens model to fit. ``"tsai"`` fits Tsai's kappa1 (the soccer paper's choice).
    camera : Camera, optional
        Known intrinsics (and lens); with it, ``method="auto"`` solves the pose only.
    method : {"auto", "pnp", "calibrate", "dlt"}
        ``pnp``: pose only (needs ``camera``); ``calibrate``: intrinsics + pose; ``dlt``: the
        linear DLT alone (non-coplanar points, no lens). See the module docstring.
    fix_principal_point : bool, optional
        Default: True for coplanar points (one plane cannot determine it), False otherwise.
    principal_point : (cx, cy), optional
        Where to fix it; default the image centre (w/2, h/2) as in Tsai's method.
    fix_aspect : bool
        Square pixels (fx = fy, or the guess's ratio).
    radial_terms : int
        Radial coefficients for the OpenCV lens (1: k1; 2: k1, k2; 3: k1, k2, k3).
    tangential : bool
        Fit OpenCV's p1, p2.

    Returns
    -------
    CalibrationResult

    Raises
    ------
    ValueError
        Shapes differ, too few points (4 for pnp, 6 otherwise), unknown lens/method.
    """
    import cv2

    X = np.asarray(points_world_m, dtype=np.float64)
    x = np.asarray(pixels, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != 3 or x.ndim != 2 or x.shape[1] != 2 or len(X) != len(x):
        raise ValueError(f"points_world_m must be (N, 3) and pixels (N, 2) with the same N; got "
                         f"{X.shape} and {x.shape}")
    if lens not in ("opencv", "tsai", "none"):
        raise ValueError(f"lens must be 'opencv', 'tsai' or 'none', got {lens!r}")
    if method not in ("auto", "pnp", "calibrate", "dlt"):
        raise ValueError(f"method must be auto, pnp, calibrate or dlt, got {method!r}")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(x))):
        raise ValueError("correspondences contain NaN or infinite values")
    _check_spread(X, x)
    w, h = (int(v) for v in image_size)
    coplanar = is_coplanar(X)
    if method == "auto":
        method = "pnp" if camera is not None else "calibrate"
    notes: list[str] = []

    if method == "pnp":
        if camera is None:
            raise ValueError("method 'pnp' needs known intrinsics: pass camera=")
        if len(X) < 4:
            raise ValueError(f"pose from points needs >= 4 correspondences, got {len(X)}")
        und = camera.pixels_to_normalized(x)
        ok, rvec, tvec = cv2.solvePnP(X, und.reshape(-1, 1, 2), np.eye(3), None,
                                      flags=cv2.SOLVEPNP_SQPNP)
        if not ok:
            raise ValueError("cv2.solvePnP failed on these correspondences")
        rvec, tvec = cv2.solvePnPRefineLM(X, und.reshape(-1, 1, 2), np.eye(3), None, rvec, tvec)
        cam = Camera(camera.K, cv2.Rodrigues(rvec)[0], tvec.ravel(), (w, h), camera.distortion,
                     name=name)
        desc = "pnp: solvePnP (SQPnP + LM) with given intrinsics"
    elif method == "dlt":
        K, R, t = _decompose_projection(dlt(X, x))
        cam = Camera(K, R, t, (w, h), NoDistortion(), name=name)
        desc = "dlt: normalised DLT + RQ decomposition"
        if lens != "none":
            notes.append("dlt fits no lens distortion")
    else:
        if len(X) < 6:
            raise ValueError(f"calibration needs >= 6 correspondences, got {len(X)}")
        if fix_principal_point is None:
            fix_principal_point = coplanar
        pp = (w / 2.0, h / 2.0) if principal_point is None else tuple(principal_point)
        flags = cv2.CALIB_USE_INTRINSIC_GUESS | _lens_flags(
            "none" if lens == "none" else "opencv", max(radial_terms, 1) if lens == "tsai"
            else radial_terms, tangential and lens == "opencv")
        if fix_aspect:
            flags |= cv2.CALIB_FIX_ASPECT_RATIO
        if fix_principal_point:
            flags |= cv2.CALIB_FIX_PRINCIPAL_POINT
        if camera is not None:
            K0 = camera.K.copy()
            Q, c = _plane_frame(X) if coplanar else (np.eye(3), np.zeros(3))
            desc = "calibrate: calibrateCamera from the given camera as guess"
        elif coplanar:
            Q, c = _plane_frame(X)
            Xp = ((X - c) @ Q.T).astype(np.float32)
            Xp[:, 2] = 0
            K0 = cv2.initCameraMatrix2D([Xp], [x.astype(np.float32)], (w, h), 1.0)
            if fix_aspect:
                f = math.sqrt(K0[0, 0] * K0[1, 1])
                K0[0, 0] = K0[1, 1] = f
            desc = "coplanar: initCameraMatrix2D + calibrateCamera (principal point " + \
                ("fixed" if fix_principal_point else "free") + ")"
        else:
            Q, c = np.eye(3), np.zeros(3)
            K0, _, _ = _decompose_projection(dlt(X, x))
            K0[0, 1] = 0.0
            if fix_aspect:
                f = math.sqrt(K0[0, 0] * K0[1, 1])
                K0[0, 0] = K0[1, 1] = f
            desc = "non-coplanar: DLT guess + calibrateCamera"
        if fix_principal_point:
            K0[0, 2], K0[1, 2] = pp
        Xp = ((X - c) @ Q.T)  # type: ignore[assignment]
        if coplanar:
            Xp[:, 2] = 0.0
        rms, K, dist, rvecs, tvecs = cv2.calibrateCamera(
            [Xp.astype(np.float32)], [x.astype(np.float32).reshape(-1, 1, 2)], (w, h), K0,
            np.zeros(5), flags=flags,
            criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12))
        Rp = cv2.Rodrigues(rvecs[0])[0]
        R = Rp @ Q
        t = tvecs[0].ravel() - R @ c
        lens_obj = OpenCVDistortion.from_coeffs(dist.ravel()) if lens == "opencv" else \
            NoDistortion()
        cam = Camera(K, R, t, (w, h), lens_obj, name=name)
        if lens == "tsai":
            from pftrack.geometry.formats import convert_camera

            start, _ = convert_camera(Camera(K, R, t, (w, h),
                                             OpenCVDistortion.from_coeffs(dist.ravel())), "tsai")
            cam = _refine_tsai(start, X, x, bool(fix_principal_point), fix_aspect)
            cam.name = name
            desc += " + Tsai least-squares refinement"
        fixed = (["principal point"] if fix_principal_point else []) + \
            (["aspect ratio"] if fix_aspect else [])
        if fixed:
            notes.append("held fixed: " + ", ".join(fixed))
    res = reprojection_errors(cam, X, x)
    rms = float(np.sqrt(np.mean(np.sum(res**2, axis=1))))
    cam.metadata["calibration"] = {"method": desc, "points": len(X), "rms_px": rms}
    return CalibrationResult(cam, rms, res, desc, notes=notes)


# --------------------------------------------------------------------------------------------
# Checking a camera against ground truth with world positions
# --------------------------------------------------------------------------------------------


def read_mot_world(path: str | os.PathLike[str], flagged_only: bool = False
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Foot points and world positions from a MOTChallenge file with world columns.

    Rows: ``frame, id, left, top, width, height, flag, x, y, z`` (pixels, metres), read by
    :func:`pftrack.io.mot.read_mot`. Rows whose world columns are all -1 (MOTChallenge's
    "unknown", also what a file without them reads as) are skipped.

    Returns
    -------
    foot_px : ndarray, shape (N, 2)
        Bottom centre of each box, ``(left + width / 2, top + height)``.
    world_m : ndarray, shape (N, 3)
    """
    from pftrack.geometry.boxes import foot_points
    from pftrack.io.mot import read_mot

    a = read_mot(path, check_unique=False)
    keep = ~np.all(a[:, 7:10] == -1, axis=1)
    if flagged_only:
        keep &= a[:, 6] != 0
    a = a[keep]
    if len(a) == 0:
        raise ValueError(f"{path}: no rows with world positions: needs 10 columns (frame,id,left,"
                         "top,width,height,flag,x,y,z) with x, y, z known")
    return foot_points(a[:, 2:6]), a[:, 7:10].copy()


def check_against_mot(camera: Camera, gt_path: str | os.PathLike[str],
                      flagged_only: bool = False) -> dict[str, Any]:
    """Compare a camera with a ground truth's world positions (metres, on z = 0).

    Projects the world positions and measures the pixel distance to the boxes' foot points;
    back-projects the foot points onto z = 0 and measures the ground distance (metres) to the
    world positions. Returns the JSON-ready figures (``points``, ``median_px``, ``p90_px``,
    ``max_px``, ``backprojection_median_m``, ``backprojection_p90_m``, ...).
    """
    foot, world = read_mot_world(gt_path, flagged_only)
    e_px = np.linalg.norm(camera.project(world) - foot, axis=1)
    back = camera.image_to_ground(foot, 0.0)
    e_m = np.linalg.norm(back[:, :2] - world[:, :2], axis=1)
    n_bad = int(np.sum(~np.isfinite(e_px)) + np.sum(~np.isfinite(e_m)))
    e_px, e_m = e_px[np.isfinite(e_px)], e_m[np.isfinite(e_m)]
    if len(e_px) == 0:
        raise ValueError(f"{gt_path}: no world position projects in front of camera "
                         f"{camera.name!r}")
    return {
        "points": len(foot),
        "median_px": float(np.median(e_px)), "p90_px": float(np.percentile(e_px, 90)),
        "max_px": float(e_px.max()), "mean_px": float(e_px.mean()),
        "backprojection_median_m": float(np.median(e_m)) if len(e_m) else math.nan,
        "backprojection_p90_m": float(np.percentile(e_m, 90)) if len(e_m) else math.nan,
        "backprojection_max_m": float(e_m.max()) if len(e_m) else math.nan,
        "not_projectable": n_bad,
    }


# --------------------------------------------------------------------------------------------
# Soccer pitch keypoints (line intersections), for soccer-paper-style calibration
# --------------------------------------------------------------------------------------------


def soccer_pitch_keypoints(length_m: float = 105.0, width_m: float = 68.0,
                           frame: str = "corner") -> dict[str, np.ndarray]:
    """Named pitch points with known world coordinates (z = 0): line intersections and spots.

    Corners, halfway-line ends, centre spot, centre circle on the halfway line, the corners of
    the penalty and goal areas, penalty spots, the penalty arcs' ends on the area line and the
    goal posts (FIFA dimensions: areas 16.5 / 5.5 m deep, goal 7.32 m, circle 9.15 m, spot 11 m).

    Parameters
    ----------
    frame : {"corner", "centre"}
        Origin at a corner (x in [0, L], y in [0, W]) or at the centre spot; x along the length,
        y across, z up.

    Returns
    -------
    dict of str to ndarray (3,)
    """
    if frame not in ("corner", "centre"):
        raise ValueError(f"frame must be 'corner' or 'centre', got {frame!r}")
    L, W = float(length_m), float(width_m)
    hw = W / 2
    pts: dict[str, tuple[float, float]] = {
        "corner_0_0": (0, 0), "corner_L_0": (L, 0), "corner_L_W": (L, W), "corner_0_W": (0, W),
        "halfway_0": (L / 2, 0), "halfway_W": (L / 2, W), "centre_spot": (L / 2, hw),
        "circle_halfway_near": (L / 2, hw - 9.15), "circle_halfway_far": (L / 2, hw + 9.15),
    }
    dy_arc = math.sqrt(9.15**2 - (16.5 - 11.0) ** 2)
    for side, gx, s in (("left", 0.0, 1.0), ("right", L, -1.0)):
        pa, ga = gx + s * 16.5, gx + s * 5.5
        for tag, dy in (("near", -1.0), ("far", 1.0)):
            pts[f"penalty_area_goalline_{side}_{tag}"] = (gx, hw + dy * (3.66 + 16.5))
            pts[f"penalty_area_corner_{side}_{tag}"] = (pa, hw + dy * (3.66 + 16.5))
            pts[f"goal_area_goalline_{side}_{tag}"] = (gx, hw + dy * (3.66 + 5.5))
            pts[f"goal_area_corner_{side}_{tag}"] = (ga, hw + dy * (3.66 + 5.5))
            pts[f"goal_post_{side}_{tag}"] = (gx, hw + dy * 3.66)
            pts[f"penalty_arc_{side}_{tag}"] = (pa, hw + dy * dy_arc)
        pts[f"penalty_spot_{side}"] = (gx + s * 11.0, hw)
    off = np.array([L / 2, hw, 0.0]) if frame == "centre" else np.zeros(3)
    return {k: np.array([x, y, 0.0]) - off for k, (x, y) in pts.items()}
