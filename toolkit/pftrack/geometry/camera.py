"""Calibrated cameras: world points (metres) to image pixels and back.

A :class:`Camera` is a pinhole camera with a lens-distortion model:

* world frame: right-handed, metres; for the scenes pftrack ships, z is up and the ground is z = 0;
* camera frame: OpenCV's (x right, y down, z forward along the optical axis), metres;
  ``X_cam = R @ X_world + t_m``;
* normalised image coordinates: ``(X_cam / Z_cam, Y_cam / Z_cam)``; the distortion model maps the
  ideal (undistorted) normalised point to the distorted one that the lens forms;
* pixels: ``u = fx * x_d + skew * y_d + cx``, ``v = fy * y_d + cy`` with OpenCV's convention that
  the centre of the top-left pixel is (0, 0).

Lens models (all vectorised, all acting on normalised coordinates):

* :class:`NoDistortion` -- an ideal pinhole;
* :class:`OpenCVDistortion` -- OpenCV's polynomial model (k1, k2, p1, p2, k3[, k4, k5, k6]),
  which gives the distorted point as a function of the undistorted one (inverse: iterative,
  :func:`cv2.undistortPointsIter`);
* :class:`TsaiDistortion` -- R. Y. Tsai's (1986/87) radial model, which gives the *undistorted*
  point as a function of the distorted one, ``X_u = X_d (1 + kappa1 r_d^2)`` (inverse: a cubic,
  solved by vectorised Newton iterations). Tsai writes it on the sensor plane in millimetres with
  kappa1 in mm^-2; on normalised coordinates the same model has ``kappa1_norm = kappa1 * f_mm^2``
  (see :meth:`Camera.from_tsai`, which also builds R from Tsai's rx, ry, rz).

Points behind the camera project to NaN, and so do pixels whose ray misses a plane, so a caller
never receives a plausible-looking but wrong pixel; use :meth:`Camera.in_front` and
:meth:`Camera.in_image` to select.

The lens models live in :mod:`pftrack.geometry.lens` and the rotations in
:mod:`pftrack.geometry.rotations`; both import from here as well.
"""

from __future__ import annotations

import copy
import os
from collections.abc import Sequence
from typing import Any, TypeAlias

import numpy as np

from pftrack.geometry.lens import (
    LensDistortion,
    NoDistortion,
    OpenCVDistortion,
    TsaiDistortion,
    distortion_from_dict,
)
from pftrack.geometry.rotations import look_at_rotation, tsai_angles, tsai_rotation

__all__ = [
    "Camera",
    "CameraSpec",
    "LensDistortion",
    "NoDistortion",
    "OpenCVDistortion",
    "TsaiDistortion",
    "distortion_from_dict",
    "look_at_rotation",
    "same_bits",
    "tsai_angles",
    "tsai_rotation",
]


def _as_points(points: Any, dim: int, name: str) -> np.ndarray:
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim == 1 and arr.shape[0] == dim:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != dim:
        raise ValueError(f"{name}: expected an array of shape (N, {dim}), got {arr.shape}")
    return arr




# --------------------------------------------------------------------------------------------
# Camera
# --------------------------------------------------------------------------------------------


class Camera:
    """A calibrated camera: intrinsics K, extrinsics (R, t) in metres, a lens model.

    Parameters
    ----------
    K : array_like, shape (3, 3)
        Intrinsic matrix in pixels: ``[[fx, skew, cx], [0, fy, cy], [0, 0, 1]]``.
    R : array_like, shape (3, 3)
        Rotation from world to camera frame (OpenCV camera frame: x right, y down, z forward).
    t_m : array_like, shape (3,)
        Translation in metres: ``X_cam = R @ X_world + t_m``.
    image_size : (int, int)
        Image (width, height) in pixels.
    distortion : LensDistortion, optional
        Lens model on normalised coordinates; default none.
    name : str
        A label (file stem, scene name).
    metadata : dict, optional
        Extra facts a file format holds that do not change the projection (Tsai's sensor
        geometry ``tsai_sensor``: dpx, dpy, dx, dy in mm, ncx, nfx; where it came from).
    """

    def __init__(self, K: Any, R: Any, t_m: Any, image_size: Sequence[int],
                 distortion: LensDistortion | None = None, name: str = "",
                 metadata: dict[str, Any] | None = None):
        K = np.array(K, dtype=np.float64)
        R = np.array(R, dtype=np.float64)
        t = np.array(t_m, dtype=np.float64).reshape(-1)
        if K.shape != (3, 3) or K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
            raise ValueError(f"Camera {name!r}: K must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]], "
                             f"got {K.tolist()}")
        if K.shape == (3, 3) and not np.all(np.isfinite(K)):
            raise ValueError(f"Camera {name!r}: K must be finite (fx, fy, skew, cx, cy), got "
                             f"{K.tolist()}")
        if not (K[0, 0] > 0 and K[1, 1] > 0):
            raise ValueError(f"Camera {name!r}: focal lengths must be positive, got "
                             f"fx={K[0, 0]}, fy={K[1, 1]}")
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) \
                or np.linalg.det(R) < 0:
            raise ValueError(f"Camera {name!r}: R must be a rotation matrix, got {R.tolist()}")
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise ValueError(f"Camera {name!r}: t_m must be 3 finite numbers, got {t_m!r}")
        try:
            w, h = (int(v) for v in image_size)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"Camera {name!r}: image_size must be two integers (width, "
                             f"height), got {image_size!r}") from None
        if w <= 0 or h <= 0:
            raise ValueError(f"Camera {name!r}: image_size must be (width, height) > 0, "
                             f"got {image_size!r}")
        self.K = K
        self.R = R
        self.t_m = t
        self.image_size = (w, h)
        self.distortion = distortion if distortion is not None else NoDistortion()
        self.name = name
        self.metadata = dict(metadata or {})

    # ---- constructors -------------------------------------------------------------------

    @classmethod
    def from_pinhole(cls, fx: float, fy: float, cx: float, cy: float, R: Any, t_m: Any,
                     image_size: Sequence[int], distortion: LensDistortion | None = None,
                     skew: float = 0.0, **kw: Any) -> Camera:
        """From focal lengths and principal point in pixels."""
        K = np.array([[fx, skew, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        return cls(K, R, t_m, image_size, distortion, **kw)

    @classmethod
    def look_at(cls, eye_m: Sequence[float], target_m: Sequence[float], image_size: Sequence[int],
                fx: float, fy: float | None = None, cx: float | None = None,
                cy: float | None = None, up: Sequence[float] = (0.0, 0.0, 1.0),
                distortion: LensDistortion | None = None, **kw: Any) -> Camera:
        """A camera at ``eye_m`` (metres) whose optical axis passes through ``target_m``.

        The principal point defaults to the image centre ``((w - 1) / 2, (h - 1) / 2)``.
        """
        w, h = image_size
        R = look_at_rotation(eye_m, target_m, up)
        t = -R @ np.asarray(eye_m, dtype=np.float64)
        return cls.from_pinhole(fx, fx if fy is None else fy,
                                (w - 1) / 2 if cx is None else cx,
                                (h - 1) / 2 if cy is None else cy, R, t, image_size,
                                distortion, **kw)

    @classmethod
    def from_tsai(cls, *, focal_mm: float, kappa1_per_mm2: float, sx: float, dpx_mm: float,
                  dpy_mm: float, cx_px: float, cy_px: float, rx: float, ry: float, rz: float,
                  t_mm: Sequence[float], image_size: Sequence[int], name: str = "",
                  sensor: dict[str, float] | None = None) -> Camera:
        """From Tsai's parameters (lengths in millimetres, angles in radians).

        Tsai's model: ``X_cam = R(rx, ry, rz) X_world + T``; ``X_u = f X_cam / Z_cam`` on the
        sensor (mm); ``X_u = X_d (1 + kappa1 r_d^2)``; pixel ``x = sx X_d / dpx + cx``,
        ``y = Y_d / dpy + cy``. Hence ``fx = sx f / dpx``, ``fy = f / dpy`` and, on normalised
        coordinates, ``kappa1_norm = kappa1 f^2``. ``sensor`` (dpx, dpy, dx, dy, ncx, nfx) is kept
        in ``metadata["tsai_sensor"]`` so the file can be written back as it was.
        """
        fx = sx * focal_mm / dpx_mm
        fy = focal_mm / dpy_mm
        R = tsai_rotation(rx, ry, rz)
        t = np.asarray(t_mm, dtype=np.float64) / 1000.0
        meta = {"tsai_sensor": {"dpx": float(dpx_mm), "dpy": float(dpy_mm), **(sensor or {})}}
        return cls.from_pinhole(fx, fy, cx_px, cy_px, R, t, image_size,
                                TsaiDistortion(kappa1_per_mm2 * focal_mm**2), name=name,
                                metadata=meta)

    def tsai_parameters(self) -> dict[str, Any]:
        """Tsai's parameters of this camera (mm, radians), the inverse of :meth:`from_tsai`.

        The sensor pitch (dpx, dpy) does not change the projection; it is taken from
        ``metadata["tsai_sensor"]`` or, when absent, set to 0.01 mm with ncx = nfx = width.

        Raises
        ------
        ValueError
            If the lens is not Tsai's or none, or K has a skew (Tsai's model holds neither).
        """
        if not isinstance(self.distortion, (TsaiDistortion, NoDistortion)):
            # ValueError, not TypeError: the CLI reports ValueErrors as one-line user errors
            raise ValueError(  # noqa: TRY004
                f"camera {self.name!r}: Tsai's model cannot hold a {self.distortion.model} lens;"
                " convert it first (pftrack.geometry.formats.convert_camera)")
        if self.K[0, 1] != 0:
            raise ValueError(f"camera {self.name!r}: Tsai's model cannot hold a skew "
                             f"({self.K[0, 1]})")
        sensor = dict(self.metadata.get("tsai_sensor") or {})
        dpy = float(sensor.get("dpy", 0.01))
        dpx = float(sensor.get("dpx", dpy))
        focal = self.fy * dpy
        sx = self.fx * dpx / focal
        kappa = getattr(self.distortion, "kappa1", 0.0) / focal**2
        rx, ry, rz = tsai_angles(self.R)
        w, _ = self.image_size
        return {
            "focal_mm": focal, "kappa1_per_mm2": kappa, "sx": sx, "cx_px": self.cx,
            "cy_px": self.cy, "rx": rx, "ry": ry, "rz": rz, "t_mm": (self.t_m * 1000.0).tolist(),
            "dpx_mm": dpx, "dpy_mm": dpy, "dx_mm": float(sensor.get("dx", dpx)),
            "dy_mm": float(sensor.get("dy", dpy)), "ncx": float(sensor.get("ncx", w)),
            "nfx": float(sensor.get("nfx", w)),
        }

    # ---- plain properties ---------------------------------------------------------------

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def cx(self) -> float:
        return float(self.K[0, 2])

    @property
    def cy(self) -> float:
        return float(self.K[1, 2])

    @property
    def width(self) -> int:
        return self.image_size[0]

    @property
    def height(self) -> int:
        return self.image_size[1]

    @property
    def center_m(self) -> np.ndarray:
        """Camera (projection centre) position in the world, metres, shape (3,)."""
        return -self.R.T @ self.t_m

    @property
    def optical_axis(self) -> np.ndarray:
        """Unit viewing direction in the world frame, shape (3,)."""
        return self.R[2].copy()

    @property
    def rvec(self) -> np.ndarray:
        """Rodrigues rotation vector of R (OpenCV's rvec), shape (3,)."""
        import cv2

        return cv2.Rodrigues(self.R)[0].ravel()

    def copy(self) -> Camera:
        return copy.deepcopy(self)

    def resized(self, image_size: Sequence[int]) -> Camera:
        """The same camera (same field of view, pose and lens) imaging at another resolution.

        K is scaled per axis about the image's outer edge, so that a point seen at pixel
        ``(u, v)`` is seen at ``((u + 0.5) * sx - 0.5, (v + 0.5) * sy - 0.5)`` with
        ``sx = new_w / w``, ``sy = new_h / h`` (OpenCV's pixel-centre convention).
        """
        w, h = self.image_size
        nw, nh = (int(v) for v in image_size)
        sx, sy = nw / w, nh / h
        K = self.K.copy()
        K[0, :2] *= sx
        K[1, 1] *= sy
        K[0, 2] = (self.K[0, 2] + 0.5) * sx - 0.5
        K[1, 2] = (self.K[1, 2] + 0.5) * sy - 0.5
        return Camera(K, self.R, self.t_m, (nw, nh), copy.deepcopy(self.distortion),
                      name=self.name, metadata=copy.deepcopy(self.metadata))

    def with_distortion(self, distortion: LensDistortion, K: Any = None) -> Camera:
        """A copy with another lens model (and optionally another K)."""
        return Camera(self.K if K is None else K, self.R, self.t_m, self.image_size,
                      distortion, name=self.name, metadata=copy.deepcopy(self.metadata))

    def __repr__(self) -> str:
        c = self.center_m
        return (f"Camera({self.name!r}, {self.width}x{self.height}, fx={self.fx:.2f}, "
                f"fy={self.fy:.2f}, c=({self.cx:.1f}, {self.cy:.1f}), {self.distortion!r}, "
                f"centre_m=({c[0]:.2f}, {c[1]:.2f}, {c[2]:.2f}))")

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Camera) and np.array_equal(self.K, other.K)
                and np.array_equal(self.R, other.R) and np.array_equal(self.t_m, other.t_m)
                and self.image_size == other.image_size and self.distortion == other.distortion)

    # ---- forward: world -> pixels -------------------------------------------------------

    def world_to_camera(self, points_world_m: Any) -> np.ndarray:
        """World points (N, 3) m -> camera-frame points (N, 3) m."""
        p = _as_points(points_world_m, 3, "points_world_m")
        return p @ self.R.T + self.t_m

    def depth(self, points_world_m: Any) -> np.ndarray:
        """Depth along the optical axis (camera z), metres, shape (N,); negative = behind."""
        p = _as_points(points_world_m, 3, "points_world_m")
        return p @ self.R[2] + self.t_m[2]

    def in_front(self, points_world_m: Any, min_depth_m: float = 1e-6) -> np.ndarray:
        """Boolean (N,): the point lies in front of the camera (depth > ``min_depth_m``)."""
        return self.depth(points_world_m) > min_depth_m

    def normalized_to_pixels(self, xy_u: np.ndarray) -> np.ndarray:
        """Ideal normalised coordinates (N, 2) -> pixels (N, 2), applying the lens."""
        xd = self.distortion.distort(xy_u)
        u = self.K[0, 0] * xd[:, 0] + self.K[0, 1] * xd[:, 1] + self.K[0, 2]
        v = self.K[1, 1] * xd[:, 1] + self.K[1, 2]
        return np.stack([u, v], axis=1)

    def pixels_to_normalized(self, pixels: Any) -> np.ndarray:
        """Pixels (N, 2) -> ideal (undistorted) normalised coordinates (N, 2)."""
        px = _as_points(pixels, 2, "pixels")
        yd = (px[:, 1] - self.K[1, 2]) / self.K[1, 1]
        xd = (px[:, 0] - self.K[0, 2] - self.K[0, 1] * yd) / self.K[0, 0]
        return self.distortion.undistort(np.stack([xd, yd], axis=1))

    def project(self, points_world_m: Any) -> np.ndarray:
        """World points (N, 3) in metres -> pixel coordinates (N, 2).

        Rows for points at or behind the camera's centre plane are NaN. Once
        :meth:`project_rows` has loaded its compiled pass (and checked it), the same numbers
        come from it.
        """
        pc = self.world_to_camera(points_world_m)
        d = self.distortion
        if _ROWS_KERNEL and _ROWS_KERNEL[0] is not None:
            # once project_rows has loaded the kernel (never here: a process that only
            # projects does not pay numba's import), the numbers below in one compiled pass
            lens = _kernel_lens(d)
            if lens is not None:
                return _run_rows_kernel(_ROWS_KERNEL[0], np.ascontiguousarray(pc)[None],
                                        lens, self.K)[0]
        return self._project_numpy(pc)

    def _project_numpy(self, pc: np.ndarray) -> np.ndarray:
        """:meth:`project`'s numpy path from camera-frame points (N, 3)."""
        z = pc[:, 2]
        front = z > 1e-9
        zs = np.where(front, z, 1.0)
        xy = pc[:, :2] / zs[:, None]
        px = self.normalized_to_pixels(xy)
        px[~front] = np.nan
        return px

    def project_beyond_lens(self, points_world_m: Any) -> np.ndarray:
        """:meth:`project`, with a pixel also for the points in front of the camera that lie
        beyond the field where the lens model has a value (where :meth:`project` gives NaN
        though the point is in front: Tsai's ``kappa1 < 0`` or a polynomial lens folding back).

        Such a point keeps its pinhole direction from the principal point and its pinhole
        radius, times the lens's radial scale at the edge of the lens model's field along that
        direction (the model's own :meth:`~pftrack.geometry.lens.LensDistortion.edge_scale`,
        3/2 for Tsai's, or found by a vectorised bisection): continuous where the model ends
        and rising outward beyond it, so the point lands outside the image, further out the
        further out it is. A lens model fitted to an image covers the image, so these pixels
        only ever describe things outside the picture: the head of a tall person cut by the
        frame's top, a particle beside the image. Points at or behind the camera's centre plane
        stay NaN.

        Parameters
        ----------
        points_world_m : array_like, shape (N, 3)
            World points, metres.

        Returns
        -------
        ndarray, shape (N, 2)
            Pixels; NaN only for points at or behind the camera's centre plane.
        """
        px = self.project(points_world_m)
        if np.isfinite(px.sum()):  # (one reduction: the common case, every pixel finite)
            return px
        bad = ~np.isfinite(px).all(axis=1)
        if not bad.any():
            return px
        pc = self.world_to_camera(points_world_m)[bad]
        front = pc[:, 2] > 1e-9
        if not front.any():
            return px
        xy = pc[front, :2] / pc[front, 2:3]
        d = self.distortion
        known = d.edge_scale(xy)
        scale = self._bisected_edge_scale(xy) if known is None else known
        xd = xy * scale[:, None]
        u = self.K[0, 0] * xd[:, 0] + self.K[0, 1] * xd[:, 1] + self.K[0, 2]
        v = self.K[1, 1] * xd[:, 1] + self.K[1, 2]
        rows = np.flatnonzero(bad)[front]
        px[rows, 0] = u
        px[rows, 1] = v
        return px

    def _bisected_edge_scale(self, xy: np.ndarray) -> np.ndarray:
        """The lens's radial scale at the edge of its field along each ideal point's direction
        (N, 2), found by bisection on the fraction of the point's radius it maps."""
        d = self.distortion
        lo = np.zeros(len(xy))
        hi = np.ones(len(xy))
        for _ in range(40):  # the largest fraction of the ray's radius the lens model maps
            mid = 0.5 * (lo + hi)
            ok = np.isfinite(d.distort(xy * mid[:, None])).all(axis=1)
            lo = np.where(ok, mid, lo)
            hi = np.where(ok, hi, mid)
        edge = xy * lo[:, None]
        xd_edge = d.distort(edge)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.hypot(xd_edge[:, 0], xd_edge[:, 1]) / np.hypot(edge[:, 0], edge[:, 1])
        return np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)

    def project_rows(self, points_world_m: Any) -> np.ndarray:
        """:meth:`project` of T sets of points at once: (T, N, 3) metres -> (T, N, 2) pixels,
        row ``t`` equal bit for bit to ``project(points_world_m[t])`` (Tsai's Newton
        iterations stop per row, as they do per call).

        With no lens, Tsai's or OpenCV's, one compiled pass (:mod:`pftrack.geometry._kernels`)
        after numpy's batched rotation (the same products per row as the (N, 3) call); with another
        lens, or ``PFTRACK_NO_JIT=1``, or where the compiled pass was found to differ from the
        numpy path when first loaded, row by row through :meth:`project`'s numpy path.

        Parameters
        ----------
        points_world_m : array_like, shape (T, N, 3)
            T sets of N world points, metres.

        Returns
        -------
        ndarray, shape (T, N, 2)
            Pixels; NaN for points at or behind the camera's centre plane (and where a lens
            has no value).

        Raises
        ------
        ValueError
            If the points are not (T, N, 3).
        """
        p = np.asarray(points_world_m, dtype=np.float64)
        if p.ndim != 3 or p.shape[2] != 3:
            raise ValueError(f"project_rows: expected an array of shape (T, N, 3), got "
                             f"{p.shape}")
        lens = _kernel_lens(self.distortion)
        kernel = _rows_kernel() if lens is not None else None
        if kernel is None or lens is None:
            out = np.empty(p.shape[:2] + (2,))
            for i, row in enumerate(p):
                out[i] = self._project_numpy(self.world_to_camera(row))
            return out
        # matmul of a (T, N, 3) stack runs one (N, 3) product per row: the rows' own numbers
        pc = np.ascontiguousarray(p @ self.R.T + self.t_m)
        return _run_rows_kernel(kernel, pc, lens, self.K)

    def in_image(self, pixels: Any, margin_px: float = 0.0) -> np.ndarray:
        """Boolean (N,): pixel lies inside the image (pixel centres 0..w-1, 0..h-1), with a margin
        (positive: that far inside; negative: allows that much outside). NaN -> False."""
        px = _as_points(pixels, 2, "pixels")
        w, h = self.image_size
        lo = -0.5 + margin_px
        return ((px[:, 0] >= lo) & (px[:, 0] <= w - 0.5 - margin_px)
                & (px[:, 1] >= lo) & (px[:, 1] <= h - 0.5 - margin_px))

    def visible(self, points_world_m: Any, margin_px: float = 0.0) -> np.ndarray:
        """Boolean (N,): in front of the camera and projecting inside the image."""
        return self.in_image(self.project(points_world_m), margin_px)

    # ---- inverse: pixels -> rays / planes -----------------------------------------------

    def rays(self, pixels: Any) -> tuple[np.ndarray, np.ndarray]:
        """Viewing rays of pixels.

        Returns
        -------
        origins : ndarray, shape (N, 3)
            The camera centre in world metres (the same row repeated).
        directions : ndarray, shape (N, 3)
            Unit directions in the world frame, pointing away from the camera into the scene.
        """
        xy = self.pixels_to_normalized(pixels)
        dc = np.concatenate([xy, np.ones((xy.shape[0], 1))], axis=1)
        dw = dc @ self.R  # R.T @ d for each row
        dw /= np.linalg.norm(dw, axis=1, keepdims=True)
        origins = np.broadcast_to(self.center_m, dw.shape).copy()
        return origins, dw

    def image_to_plane(self, pixels: Any,
                       plane: tuple[Sequence[float], float] = ((0.0, 0.0, 1.0), 0.0)) -> np.ndarray:
        """Back-project pixels onto the world plane ``{X : n . X = d}``.

        Parameters
        ----------
        pixels : array_like, shape (N, 2)
        plane : (normal (3,), d)
            Plane normal (any length) and offset in metres; default the ground z = 0.

        Returns
        -------
        ndarray, shape (N, 3)
            World points in metres; NaN where the ray is parallel to the plane or meets it
            behind the camera.
        """
        n = np.asarray(plane[0], dtype=np.float64).reshape(3)
        norm = np.linalg.norm(n)
        if norm == 0:
            raise ValueError("image_to_plane: plane normal is zero")
        n, d = n / norm, float(plane[1]) / norm
        o, dirs = self.rays(pixels)
        denom = dirs @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (d - o @ n) / denom
        s[~(np.abs(denom) > 1e-12) | ~(s > 0)] = np.nan
        return o + s[:, None] * dirs

    def image_to_ground(self, pixels: Any, z_m: float = 0.0) -> np.ndarray:
        """Back-project pixels onto the horizontal plane z = ``z_m`` (metres), shape (N, 3)."""
        return self.image_to_plane(pixels, ((0.0, 0.0, 1.0), z_m))


_ROWS_KERNEL: list[Any] = []  # [kernel or None] once decided


def _kernel_lens(d: LensDistortion) -> tuple[float, np.ndarray | None] | None:
    """The compiled projection's lens arguments: Tsai's kappa1 (0: none) and OpenCV's
    coefficients with the squared fold-back radius (None: not OpenCV's); None for a lens it
    does not know."""
    if type(d) is NoDistortion:  # (exact types: a subclass may change the arithmetic)
        return 0.0, None
    if type(d) is TsaiDistortion:
        return d.kappa1, None
    if type(d) is OpenCVDistortion:
        return 0.0, np.array([d.k1, d.k2, d.p1, d.p2, d.k3, d.k4, d.k5, d.k6,
                              d.max_radius ** 2])
    return None


def _run_rows_kernel(kernel: Any, pc: np.ndarray, lens: tuple[float, np.ndarray | None],
                     K: np.ndarray) -> np.ndarray:
    """Pixels (T, N, 2) of camera-frame points ``pc`` (T, N, 3, C-contiguous)."""
    n = pc.shape[1]
    out = np.empty(pc.shape[:2] + (2,))
    kernel(pc, lens[0], lens[1], K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2], out, np.empty(n),
           np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_))
    return out


def _rows_kernel() -> Any:
    """The compiled :meth:`Camera.project_rows` kernel, or None (``PFTRACK_NO_JIT``, numba
    missing, or its numbers differ from :meth:`Camera.project`'s on a check set).

    Decided once per process: both paths do the same float64 operations in the same order
    (the cube as two products), but a build of numba or numpy could contract or vectorise
    them differently, so on first use both project a fixed set of points (both signs of
    kappa, points behind the camera, far outside the image, on the optical axis) and the
    kernel is used only if every bit agrees."""
    if _ROWS_KERNEL:
        return _ROWS_KERNEL[0]
    kernel = None
    from pftrack.filter import _jit

    if _jit.ENABLED:
        try:
            from pftrack.geometry import _kernels

            kernel = _kernels.camera_to_pixels_rows
        except ImportError:  # pragma: no cover - numba is a dependency
            kernel = None
    if kernel is not None and not _rows_kernel_agrees(kernel):
        kernel = None  # pragma: no cover - depends on the machine's numpy
    _ROWS_KERNEL.append(kernel)
    return kernel


def _rows_kernel_agrees(kernel: Any) -> bool:
    """Whether ``kernel`` gives :meth:`Camera.project`'s numbers on a check set."""
    rng = np.random.default_rng(20261124)
    pts = rng.normal(0.0, 1.0, (2, 4000, 3)) * np.array([8.0, 8.0, 3.0])
    pts[:, :, 2] += 6.0  # mostly in front, some behind
    pts[0, :4] = [[0.0, 0.0, 5.0], [0.0, 0.0, 0.0], [50.0, -40.0, 1.0], [np.nan, 0.0, 5.0]]
    lenses: list[LensDistortion] = [TsaiDistortion(0.15772011860650012), TsaiDistortion(-0.3),
                                    TsaiDistortion(0.0), NoDistortion(), OpenCVDistortion(-0.05),
                                    OpenCVDistortion(-0.2, 0.05, 1e-3, -2e-3, 0.01, 0.1, 0.02,
                                                     0.003)]
    for lens in lenses:
        cam = Camera.look_at((0.3, -0.2, 0.1), (0.0, 0.0, 5.0), (768, 576), fx=700.0,
                             distortion=lens)
        pc = np.ascontiguousarray(pts @ cam.R.T + cam.t_m)
        args = _kernel_lens(lens)
        assert args is not None
        out = _run_rows_kernel(kernel, pc, args, cam.K)
        ref = np.array([cam._project_numpy(cam.world_to_camera(row)) for row in pts])
        if not same_bits(out, ref):
            return False
    return True


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two arrays hold the same float64 numbers bit for bit.

    Parameters
    ----------
    a, b : array_like
        Compared as float64.

    Returns
    -------
    bool
        Same shape and the same bits everywhere, any NaN equal to any NaN (0.0 and -0.0
        differ).
    """
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        return False
    na, nb = np.isnan(a), np.isnan(b)
    return bool(np.array_equal(na, nb) and np.array_equal(np.where(na, 0.0, a).view(np.int64),
                                                          np.where(nb, 0.0, b).view(np.int64)))


#: What a component's ``camera`` parameter takes: a :class:`Camera` or a camera file path
#: (anything :func:`pftrack.geometry.formats.load_camera` reads).
CameraSpec: TypeAlias = "Camera | str | os.PathLike[str]"
