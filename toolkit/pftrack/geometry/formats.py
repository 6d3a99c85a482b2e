"""Camera files: load, save and convert between formats and lens models.

Formats (``format=`` names):

``pftrack``
    pftrack's own YAML (``*.yaml``, ``*.yml``; the format of the project's ``calib/`` folder).
    Holds everything exactly: K, R, t (metres), image size, any lens model, metadata. It also
    accepts, on reading, a ``tsai:`` block with Tsai's parameters (mm, degrees or radians), so a
    camera published in Tsai's terms can be written down as published. See ``calib/README.md``.
``tsai``
    The PETS 2009 Tsai XML (``*.xml`` whose root is ``<Camera>``): Geometry (dpx, dpy, dx, dy in
    mm/pixel, ncx, nfx), Intrinsic (focal mm, kappa1 mm^-2, cx, cy, sx), Extrinsic (tx, ty, tz mm,
    rx, ry, rz rad). Holds a Tsai or distortion-free lens, no skew; an OpenCV lens is refitted.
``opencv``
    OpenCV FileStorage (YAML or XML, ``*.opencv.yml`` / ``*.opencv.yaml`` / ``*.opencv.xml`` on
    saving; any file starting ``%YAML:1.0`` or with an ``<opencv_storage>`` root on loading) as
    OpenCV's calibration sample writes it: ``image_width``, ``image_height``, ``camera_matrix``,
    ``distortion_coefficients``, and the pose as a one-row ``extrinsic_parameters`` (rvec, tvec in
    metres). A file with several views' extrinsics (a chessboard calibration) loads with the
    camera at the world origin (R = I, t = 0). Holds an OpenCV or no lens exactly; a Tsai lens is
    refitted as (k1, k2, p1, p2, k3).
``open3d``
    Open3D's ``PinholeCameraParameters`` JSON (``*.json``; written and read by
    ``open3d.io.write/read_pinhole_camera_parameters``). It cannot hold lens distortion: a
    distorted camera is replaced by the pinhole (fx, fy, cx, cy) that best fits it.

Whenever a target cannot hold a camera exactly, :func:`convert_camera` refits the lens over a
grid of image points and reports the residual: the largest (and RMS) pixel distance, over a
denser grid covering the whole image, between where the original and the converted camera
project the same world point. :func:`save_camera` refuses a lossy save unless
``approximate=True``. All writes are atomic.
"""

from __future__ import annotations

import json
import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pftrack.geometry.camera import (
    Camera,
    NoDistortion,
    OpenCVDistortion,
    TsaiDistortion,
    distortion_from_dict,
)

__all__ = [
    "FORMATS",
    "ConversionReport",
    "camera_from_dict",
    "camera_to_dict",
    "convert_camera",
    "guess_format",
    "load_camera",
    "pixel_grid",
    "save_camera",
]

FORMATS = ("pftrack", "tsai", "opencv", "open3d")
#: which lens models each format holds exactly
_HOLDS = {
    "pftrack": ("none", "opencv", "tsai"),
    "tsai": ("none", "tsai"),
    "opencv": ("none", "opencv"),
    "open3d": ("none",),
}
_NATIVE_TAG = "pftrack-camera"


@dataclass
class ConversionReport:
    """What a conversion kept and lost.

    Attributes
    ----------
    target : str
        Format or lens model converted to.
    exact : bool
        True when the converted camera projects exactly as the original (to rounding).
    lost : list of str
        Human-readable notes on what the target cannot hold.
    residual_max_px, residual_rms_px : float
        Largest and RMS pixel distance between original and converted projections of the same
        world points, over a grid covering the image (0 when exact).
    fitted : dict
        The refitted lens coefficients / intrinsics, when a fit was made.
    """

    target: str
    exact: bool = True
    lost: list[str] = field(default_factory=list)
    residual_max_px: float = 0.0
    residual_rms_px: float = 0.0
    fitted: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"target": self.target, "exact": self.exact, "lost": list(self.lost),
                "residual_max_px": self.residual_max_px,
                "residual_rms_px": self.residual_rms_px, "fitted": dict(self.fitted)}


# --------------------------------------------------------------------------------------------
# Lens conversion
# --------------------------------------------------------------------------------------------


def pixel_grid(image_size: tuple[int, int], step_px: float) -> np.ndarray:
    """Grid of pixel positions covering the image including its borders, shape (N, 2)."""
    w, h = image_size
    xs = np.unique(np.append(np.arange(0.0, w - 1, step_px), w - 1.0))
    ys = np.unique(np.append(np.arange(0.0, h - 1, step_px), h - 1.0))
    gx, gy = np.meshgrid(xs, ys)
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def projection_residual(source: Camera, target: Camera, step_px: float = 4.0
                        ) -> tuple[float, float]:
    """Max and RMS pixel distance between the two cameras' projections of the world points
    that ``source`` sees on a pixel grid (rays through grid pixels). Same pose assumed."""
    grid = pixel_grid(source.image_size, step_px)
    xy = source.pixels_to_normalized(grid)
    moved = target.normalized_to_pixels(xy)
    err = np.linalg.norm(moved - grid, axis=1)
    if not np.all(np.isfinite(err)):
        return math.inf, math.inf
    return float(err.max()), float(np.sqrt(np.mean(err**2)))


def _normalized_pairs(camera: Camera, step_px: float) -> tuple[np.ndarray, np.ndarray]:
    """(distorted, undistorted) normalised coordinates of a pixel grid of ``camera``."""
    grid = pixel_grid(camera.image_size, step_px)
    yd = (grid[:, 1] - camera.cy) / camera.fy
    xd = (grid[:, 0] - camera.cx - camera.K[0, 1] * yd) / camera.fx
    d = np.stack([xd, yd], axis=1)
    return d, camera.distortion.undistort(d)


def _fit_opencv(camera: Camera, step_px: float, rational: bool = False) -> OpenCVDistortion:
    """Least-squares OpenCV lens with the same K.

    Standard model: (k1, k2, p1, p2, k3), linear in the coefficients, solved in pixel units.
    Rational model (``rational=True``): (k1, k2, k3) / (k4, k5, k6), no tangential terms, solved
    linearly on the cross-multiplied (algebraic) form ``d (1 + k4 r^2 + ...) = u (1 + k1 r^2 +
    ...)``, scaled to pixels.
    """
    d, u = _normalized_pairs(camera, step_px)
    x, y = u[:, 0], u[:, 1]
    r2 = x * x + y * y
    if rational:
        cols = []
        for c in (0, 1):
            uc, dc = u[:, c], d[:, c]
            cols.append(np.stack([uc * r2, uc * r2**2, uc * r2**3,
                                  -dc * r2, -dc * r2**2, -dc * r2**3], axis=1))
        A = np.concatenate([cols[0] * camera.fx, cols[1] * camera.fy])
        b = np.concatenate([(d[:, 0] - x) * camera.fx, (d[:, 1] - y) * camera.fy])
        k, *_ = np.linalg.lstsq(A, b, rcond=None)
        return OpenCVDistortion(k[0], k[1], 0.0, 0.0, k[2], k[3], k[4], k[5])
    ax = np.stack([x * r2, x * r2**2, 2 * x * y, r2 + 2 * x * x, x * r2**3], axis=1)
    ay = np.stack([y * r2, y * r2**2, r2 + 2 * y * y, 2 * x * y, y * r2**3], axis=1)
    A = np.concatenate([ax * camera.fx, ay * camera.fy])
    b = np.concatenate([(d[:, 0] - x) * camera.fx, (d[:, 1] - y) * camera.fy])
    coef, *_ = np.linalg.lstsq(A, b, rcond=None)
    return OpenCVDistortion.from_coeffs(coef)


def _fit_tsai(camera: Camera, step_px: float) -> TsaiDistortion:
    """Least-squares kappa1 of ``u = d (1 + kappa1 |d|^2)``, same K, scaled to pixels."""
    d, u = _normalized_pairs(camera, step_px)
    r2 = np.sum(d * d, axis=1)
    a = np.concatenate([d[:, 0] * r2 * camera.fx, d[:, 1] * r2 * camera.fy])
    b = np.concatenate([(u[:, 0] - d[:, 0]) * camera.fx, (u[:, 1] - d[:, 1]) * camera.fy])
    return TsaiDistortion(float(a @ b / (a @ a)))


def _fit_pinhole(camera: Camera, step_px: float) -> np.ndarray:
    """The K of the distortion-free camera closest (least squares, pixels) to ``camera``."""
    grid = pixel_grid(camera.image_size, step_px)
    u = camera.pixels_to_normalized(grid)
    one = np.ones(len(u))
    (fx, s, cx), *_ = np.linalg.lstsq(np.stack([u[:, 0], u[:, 1], one], 1), grid[:, 0], rcond=None)
    if camera.K[0, 1] == 0:
        (fx, cx), *_ = np.linalg.lstsq(np.stack([u[:, 0], one], 1), grid[:, 0], rcond=None)
        s = 0.0
    (fy, cy), *_ = np.linalg.lstsq(np.stack([u[:, 1], one], 1), grid[:, 1], rcond=None)
    return np.array([[fx, s, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def convert_camera(camera: Camera, target: str, fit_step_px: float = 16.0,
                   check_step_px: float = 4.0, opencv_model: str = "auto",
                   rational_above_px: float = 0.05) -> tuple[Camera, ConversionReport]:
    """The camera as ``target`` (a format name, or a lens model ``none``/``opencv``/``tsai``)
    can hold it, and a report of what changed.

    Lenses the target cannot hold are refitted by linear least squares over a pixel grid
    (``fit_step_px``): Tsai -> OpenCV fits (k1, k2, p1, p2, k3) with K unchanged; OpenCV -> Tsai
    fits kappa1; any -> pinhole (Open3D, model ``none``) fits fx, fy, cx, cy (and skew if any).
    The residual is measured on a finer grid (``check_step_px``), see :class:`ConversionReport`.

    ``opencv_model``: ``"standard"`` (5 coefficients), ``"rational"`` (8, OpenCV's
    ``CALIB_RATIONAL_MODEL``) or ``"auto"``: the standard fit unless its residual exceeds
    ``rational_above_px`` and the rational one does better (a strong Tsai lens, such as the soccer
    paper's kappa1 = 0.36, leaves ~16 px with 5 coefficients and ~0.001 px with 8).

    Raises
    ------
    ValueError
        For an unknown target.
    """
    if target in _HOLDS:
        holds = _HOLDS[target]
    elif target in ("none", "opencv", "tsai"):
        holds = (target,)
    else:
        raise ValueError(f"unknown camera format or lens model {target!r} "
                         f"(formats: {', '.join(FORMATS)}; lens models: none, opencv, tsai)")
    report = ConversionReport(target=target)
    model = camera.distortion.model
    out = camera.copy()
    if model not in holds:
        if camera.distortion.is_identity:
            out = camera.with_distortion(NoDistortion() if "none" in holds else
                                         (OpenCVDistortion() if "opencv" in holds
                                          else TsaiDistortion()))
        elif "opencv" in holds:
            if opencv_model not in ("auto", "standard", "rational"):
                raise ValueError(f"opencv_model must be auto, standard or rational, got "
                                 f"{opencv_model!r}")
            lens = _fit_opencv(camera, fit_step_px, rational=opencv_model == "rational")
            out = camera.with_distortion(lens)
            if opencv_model == "auto":
                res_std = projection_residual(camera, out, check_step_px)[0]
                if res_std > rational_above_px:
                    lens_r = _fit_opencv(camera, fit_step_px, rational=True)
                    out_r = camera.with_distortion(lens_r)
                    res_r = projection_residual(camera, out_r, check_step_px)[0]
                    if res_r < res_std:
                        report.lost.append(f"the 5-coefficient OpenCV fit leaves {res_std:.3f} px;"
                                           " using OpenCV's rational model (8 coefficients)")
                        lens, out = lens_r, out_r
            names = "(k1, k2, p1, p2, k3" + (", k4, k5, k6)" if lens.coeffs.size == 8 else ")")
            report.lost.append(f"{target} cannot hold Tsai's radial model: refitted as OpenCV "
                               f"{names} = {lens.coeffs.round(8).tolist()}")
            report.fitted = lens.to_dict()
        elif "tsai" in holds:
            lens = _fit_tsai(camera, fit_step_px)  # type: ignore[assignment]
            out = camera.with_distortion(lens)
            report.lost.append(f"{target} holds only Tsai's one-coefficient radial lens: "
                               f"{model} lens {camera.distortion.params()} refitted as "
                               f"kappa1 = {lens.kappa1:.8g} (normalised)")  # type: ignore[attr-defined]
            report.fitted = lens.to_dict()
        else:
            K = _fit_pinhole(camera, fit_step_px)
            out = camera.with_distortion(NoDistortion(), K=K)
            report.lost.append(f"{target} cannot hold lens distortion: {model} lens "
                               f"{camera.distortion.params()} dropped and replaced by the "
                               f"closest pinhole fx={K[0, 0]:.4f} fy={K[1, 1]:.4f} "
                               f"cx={K[0, 2]:.4f} cy={K[1, 2]:.4f}")
            report.fitted = {"fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2],
                             "skew": K[0, 1]}
    if target == "tsai" and out.K[0, 1] != 0:
        K = out.K.copy()
        K[0, 1] = 0.0
        out = out.with_distortion(out.distortion, K=K)
        report.lost.append(f"tsai cannot hold a skew ({camera.K[0, 1]:.6g}): set to 0")
    if report.lost:
        report.exact = False
        report.residual_max_px, report.residual_rms_px = projection_residual(
            camera, out, check_step_px)
        report.lost.append(f"residual over the image: max {report.residual_max_px:.4f} px, "
                           f"rms {report.residual_rms_px:.4f} px")
    if target == "opencv" and camera.metadata.get("tsai_sensor"):
        report.lost.append("Tsai's sensor geometry (dpx, dpy, ncx, nfx) is not stored; it does "
                           "not change the projection")
    return out, report


# --------------------------------------------------------------------------------------------
# pftrack native YAML
# --------------------------------------------------------------------------------------------


def _floats(a: Any) -> Any:
    return np.asarray(a, dtype=np.float64).tolist()


def camera_to_dict(camera: Camera) -> dict[str, Any]:
    """The pftrack-native mapping of a camera (exact: floats written with repr)."""
    d: dict[str, Any] = {
        "format": _NATIVE_TAG,
        "version": 1,
        "name": camera.name,
        "image_size": [int(camera.width), int(camera.height)],
        "K": _floats(camera.K),
        "R": _floats(camera.R),
        "t_m": _floats(camera.t_m),
        "distortion": camera.distortion.to_dict(),
    }
    meta = {k: v for k, v in camera.metadata.items() if k not in ("source", "notes")}
    if camera.metadata.get("notes"):
        d["notes"] = str(camera.metadata["notes"])
    if meta:
        d["metadata"] = json.loads(json.dumps(meta, default=float))
    return d


def _tsai_block(block: dict[str, Any], image_size: Any, name: str, where: str) -> Camera:
    b = dict(block)
    try:
        def angle(key: str) -> float:
            if f"{key}_deg" in b:
                return math.radians(float(b.pop(f"{key}_deg")))
            return float(b.pop(key))

        rx, ry, rz = angle("rx"), angle("ry"), angle("rz")
        if "t_m" in b:
            t_mm = np.asarray(b.pop("t_m"), dtype=np.float64) * 1000.0
        else:
            t_mm = np.asarray(b.pop("t_mm"), dtype=np.float64)
        dpx = float(b.pop("dpx_mm"))
        dpy = float(b.pop("dpy_mm", dpx))
        sensor = {k.removesuffix("_mm"): float(b.pop(k))
                  for k in ("dx_mm", "dy_mm", "ncx", "nfx") if k in b}
        cam = Camera.from_tsai(
            focal_mm=float(b.pop("focal_mm")), kappa1_per_mm2=float(b.pop("kappa1_per_mm2", 0)),
            sx=float(b.pop("sx", 1.0)), dpx_mm=dpx, dpy_mm=dpy, cx_px=float(b.pop("cx_px")),
            cy_px=float(b.pop("cy_px")), rx=rx, ry=ry, rz=rz, t_mm=t_mm, image_size=image_size,  # type: ignore[arg-type]
            name=name, sensor=sensor)
    except KeyError as exc:
        raise ValueError(f"{where}: 'tsai' block lacks {exc.args[0]!r}") from None
    if b:
        raise ValueError(f"{where}: unknown keys in 'tsai' block: {sorted(b)}")
    return cam


def camera_from_dict(d: dict[str, Any], where: str = "camera") -> Camera:
    """Inverse of :func:`camera_to_dict`; also accepts a ``tsai:`` block instead of K/R/t."""
    if not isinstance(d, dict):
        raise ValueError(f"{where}: expected a mapping, got {type(d).__name__}")  # noqa: TRY004  # noqa: TRY004
    if d.get("format", _NATIVE_TAG) != _NATIVE_TAG:
        raise ValueError(f"{where}: format is {d.get('format')!r}, expected {_NATIVE_TAG!r}")
    known = {"format", "version", "name", "image_size", "K", "R", "t_m", "distortion",
             "metadata", "tsai", "notes"}
    if set(d) - known:
        raise ValueError(f"{where}: unknown keys {sorted(set(d) - known)}")
    if "image_size" not in d:
        raise ValueError(f"{where}: no 'image_size' [width, height]")
    name = str(d.get("name") or Path(where).stem)
    meta = dict(d.get("metadata") or {})
    if d.get("notes"):
        meta["notes"] = str(d["notes"])
    if "tsai" in d:
        if any(k in d for k in ("K", "R", "t_m", "distortion")):
            raise ValueError(f"{where}: give either a 'tsai' block or K/R/t_m/distortion")
        cam = _tsai_block(d["tsai"], d["image_size"], name, where)
        cam.metadata.update(meta)
        return cam
    missing = [k for k in ("K", "R", "t_m") if k not in d]
    if missing:
        raise ValueError(f"{where}: missing {missing}")
    try:
        return Camera(d["K"], d["R"], d["t_m"], d["image_size"],
                      distortion_from_dict(d.get("distortion")), name=name, metadata=meta)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def _save_pftrack(camera: Camera, path: Path) -> None:
    import yaml

    from pftrack.io.atomic import atomic_write_text

    header = ("# pftrack camera. World frame: metres; X_cam = R @ X_world + t_m (OpenCV camera\n"
              "# frame: x right, y down, z forward); K in pixels; distortion on normalised\n"
              "# image coordinates. Format: calib/README.md\n")
    atomic_write_text(path, header + yaml.safe_dump(camera_to_dict(camera), sort_keys=False,
                                                    default_flow_style=None, width=100))


def _load_pftrack(path: Path) -> Camera:
    import yaml

    try:
        d = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{path}: not valid YAML: {exc}") from None
    return camera_from_dict(d, str(path))


# --------------------------------------------------------------------------------------------
# Tsai XML (PETS 2009)
# --------------------------------------------------------------------------------------------


def _load_tsai(path: Path) -> Camera:
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ValueError(f"{path}: not valid XML: {exc}") from None
    nodes = {n: root.find(n) for n in ("Geometry", "Intrinsic", "Extrinsic")}
    if root.tag != "Camera" or any(v is None for v in nodes.values()):
        raise ValueError(f"{path}: not a Tsai camera XML (<Camera> with Geometry, Intrinsic, "
                         "Extrinsic)")

    def num(node: str, key: str) -> float:
        val = nodes[node].get(key)  # type: ignore[union-attr]
        if val is None:
            raise ValueError(f"{path}: <{node}> lacks attribute {key!r}")
        try:
            return float(val)
        except ValueError:
            raise ValueError(f"{path}: <{node} {key}={val!r}> is not a number") from None

    size = (int(num("Geometry", "width")), int(num("Geometry", "height")))
    sensor = {k: num("Geometry", k) for k in ("dx", "dy", "ncx", "nfx")
              if nodes["Geometry"].get(k) is not None}  # type: ignore[union-attr]
    return Camera.from_tsai(
        focal_mm=num("Intrinsic", "focal"), kappa1_per_mm2=num("Intrinsic", "kappa1"),
        sx=num("Intrinsic", "sx"), dpx_mm=num("Geometry", "dpx"), dpy_mm=num("Geometry", "dpy"),
        cx_px=num("Intrinsic", "cx"), cy_px=num("Intrinsic", "cy"), rx=num("Extrinsic", "rx"),
        ry=num("Extrinsic", "ry"), rz=num("Extrinsic", "rz"),
        t_mm=[num("Extrinsic", k) for k in ("tx", "ty", "tz")], image_size=size,
        name=root.get("name") or path.stem, sensor=sensor)


def _save_tsai(camera: Camera, path: Path) -> None:
    from pftrack.io.atomic import atomic_write_text

    p = camera.tsai_parameters()
    def f(x: float) -> str:
        return repr(float(x))

    w, h = camera.image_size
    text = (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<Camera name="{camera.name or path.stem}">\n'
        f'\t<Geometry width="{w}" height="{h}" ncx="{f(p["ncx"])}" nfx="{f(p["nfx"])}" '
        f'dx="{f(p["dx_mm"])}" dy="{f(p["dy_mm"])}" dpx="{f(p["dpx_mm"])}" '
        f'dpy="{f(p["dpy_mm"])}"/>\n'
        f'\t<Intrinsic focal="{f(p["focal_mm"])}" kappa1="{f(p["kappa1_per_mm2"])}" '
        f'cx="{f(p["cx_px"])}" cy="{f(p["cy_px"])}" sx="{f(p["sx"])}"/>\n'
        f'\t<Extrinsic tx="{f(p["t_mm"][0])}" ty="{f(p["t_mm"][1])}" tz="{f(p["t_mm"][2])}" '
        f'rx="{f(p["rx"])}" ry="{f(p["ry"])}" rz="{f(p["rz"])}"/>\n'
        "</Camera>\n"
    )
    atomic_write_text(path, text)


# --------------------------------------------------------------------------------------------
# OpenCV FileStorage
# --------------------------------------------------------------------------------------------


def _load_opencv(path: Path) -> Camera:
    import cv2

    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except cv2.error as exc:
        raise ValueError(f"{path}: OpenCV cannot read it: {exc}") from None
    try:
        if not fs.isOpened():
            raise ValueError(f"{path}: OpenCV cannot open it as FileStorage")

        def node(*names: str) -> Any:
            for n in names:
                nd = fs.getNode(n)
                if not nd.empty():
                    return nd
            return None

        K = node("camera_matrix", "cameraMatrix", "K")
        if K is None:
            raise ValueError(f"{path}: no camera_matrix")
        K = K.mat()
        dist = node("distortion_coefficients", "dist_coeffs", "distCoeffs", "D")
        dist_v = np.zeros(5) if dist is None else np.asarray(dist.mat(), dtype=np.float64).ravel()
        w, h = node("image_width"), node("image_height")
        if w is None or h is None:
            raise ValueError(f"{path}: no image_width/image_height")
        width, height = int(w.real()), int(h.real())
        ext = node("extrinsic_parameters")
        meta: dict[str, Any] = {}
        R, t = np.eye(3), np.zeros(3)
        if ext is not None:
            e = np.asarray(ext.mat(), dtype=np.float64).reshape(-1, 6)
            if len(e) == 1:
                R = cv2.Rodrigues(e[0, :3])[0]  # type: ignore[assignment]
                t = e[0, 3:]
            else:
                meta["note"] = (f"{len(e)} views' extrinsics in the file; camera placed at the "
                                "world origin (R = I, t = 0)")
        rms = node("avg_reprojection_error")
        if rms is not None:
            meta["avg_reprojection_error_px"] = float(rms.real())
    finally:
        fs.release()
    dist_v = np.trim_zeros(dist_v, "b") if dist_v.size > 8 else dist_v
    if dist_v.size < 4:
        dist_v = np.pad(dist_v, (0, 4 - dist_v.size))
    lens = OpenCVDistortion.from_coeffs(dist_v)
    return Camera(K, R, t, (width, height), lens if not lens.is_identity else NoDistortion(),
                  name=path.name.split(".")[0], metadata=meta)


def _save_opencv(camera: Camera, path: Path) -> None:
    import cv2

    from pftrack.io.atomic import atomic_path

    lens = camera.distortion
    coeffs = lens.coeffs if isinstance(lens, OpenCVDistortion) else np.zeros(5)
    with atomic_path(path) as tmp:
        fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
        try:
            fs.write("image_width", int(camera.width))
            fs.write("image_height", int(camera.height))
            fs.write("camera_matrix", camera.K)
            fs.write("distortion_coefficients", coeffs.reshape(-1, 1))
            fs.write("extrinsic_parameters",
                     np.concatenate([camera.rvec, camera.t_m]).reshape(1, 6))
            fs.writeComment("extrinsic_parameters: rvec (Rodrigues) and tvec in metres, "
                            "X_cam = R X_world + t (written by pftrack)")
        finally:
            fs.release()


# --------------------------------------------------------------------------------------------
# Open3D PinholeCameraParameters JSON
# --------------------------------------------------------------------------------------------


def _load_open3d(path: Path) -> Camera:
    try:
        doc = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON: {exc}") from None
    if not isinstance(doc, dict) or "intrinsic" not in doc or "extrinsic" not in doc:
        raise ValueError(f"{path}: not an Open3D PinholeCameraParameters JSON "
                         "(needs 'intrinsic' and 'extrinsic')")
    import open3d as o3d

    p = o3d.io.read_pinhole_camera_parameters(str(path))  # type: ignore[arg-type]
    K = np.asarray(p.intrinsic.intrinsic_matrix, dtype=np.float64)
    E = np.asarray(p.extrinsic, dtype=np.float64)
    size = (int(p.intrinsic.width), int(p.intrinsic.height))
    if size[0] <= 0 or size[1] <= 0:
        raise ValueError(f"{path}: Open3D read no usable intrinsic (width/height {size})")
    return Camera(K, E[:3, :3], E[:3, 3], size, NoDistortion(), name=path.name.split(".")[0])


def _save_open3d(camera: Camera, path: Path) -> None:
    import open3d as o3d

    from pftrack.io.atomic import atomic_write_with

    if not camera.distortion.is_identity:
        raise ValueError("open3d cannot hold lens distortion")
    p = o3d.camera.PinholeCameraParameters()
    p.intrinsic = o3d.camera.PinholeCameraIntrinsic(int(camera.width), int(camera.height),
                                                    camera.K)
    E = np.eye(4)
    E[:3, :3], E[:3, 3] = camera.R, camera.t_m

    p.extrinsic = E

    def write(tmp: Path) -> None:
        if not o3d.io.write_pinhole_camera_parameters(str(tmp), p):  # type: ignore[arg-type]
            raise OSError(f"Open3D could not write {path}")

    atomic_write_with(path, write)


# --------------------------------------------------------------------------------------------
# Dispatch
# --------------------------------------------------------------------------------------------

_LOADERS = {"pftrack": _load_pftrack, "tsai": _load_tsai, "opencv": _load_opencv,
            "open3d": _load_open3d}
_SAVERS = {"pftrack": _save_pftrack, "tsai": _save_tsai, "opencv": _save_opencv,
           "open3d": _save_open3d}


def guess_format(path: str | os.PathLike[str], for_writing: bool = False) -> str:
    """The format of ``path``: by content when reading an existing file, else by name.

    Names: ``*.opencv.yml|yaml|xml`` -> opencv, ``*.xml`` -> tsai, ``*.json`` -> open3d,
    ``*.yaml|yml`` -> pftrack.
    """
    p = Path(path)
    name = p.name.lower()
    if not for_writing and p.is_file():
        head = p.read_bytes()[:4096].decode("utf-8", errors="replace").lstrip()
        if head.startswith("%YAML:1.") or "!!opencv-matrix" in head or "<opencv_storage>" in head:
            return "opencv"
        if head.startswith(("<?xml", "<Camera")):
            return "tsai"
        if head.startswith("{"):
            return "open3d"
        if _NATIVE_TAG in head or "tsai:" in head:
            return "pftrack"
    if any(name.endswith(s) for s in (".opencv.yml", ".opencv.yaml", ".opencv.xml")):
        return "opencv"
    suffix = p.suffix.lower()
    if suffix == ".xml":
        return "tsai"
    if suffix == ".json":
        return "open3d"
    if suffix in (".yaml", ".yml"):
        return "pftrack"
    raise ValueError(f"{path}: cannot tell the camera format from the name; pass format= one of "
                     f"{', '.join(FORMATS)}")


def _check_format(fmt: str) -> str:
    f = fmt.lower()
    if f not in FORMATS:
        raise ValueError(f"unknown camera format {fmt!r}; known: {', '.join(FORMATS)}")
    return f


def load_camera(path: str | os.PathLike[str], format: str | None = None) -> Camera:
    """Read a camera file (any of :data:`FORMATS`; guessed from content/name when not given)."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"camera file {p} not found")
    fmt = _check_format(format) if format else guess_format(p)
    try:
        cam = _LOADERS[fmt](p)
    except ValueError as exc:
        if str(p) in str(exc):
            raise
        raise ValueError(f"camera file {p}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - OpenCV's parser raises cv2.error / SystemError
        raise ValueError(f"camera file {p}: cannot be read as format {fmt!r} "
                         f"({type(exc).__name__}: {' '.join(str(exc).split())[:200]})") from None
    cam.metadata["source"] = {"path": str(p), "format": fmt}
    return cam


def save_camera(camera: Camera, path: str | os.PathLike[str], format: str | None = None,
                approximate: bool = False) -> ConversionReport:
    """Write ``camera`` to ``path`` atomically in ``format`` (guessed from the name if None).

    Parameters
    ----------
    approximate : bool
        Allow a format that cannot hold the camera exactly; the lens is refitted by
        :func:`convert_camera` and the report says what was lost and the residual.

    Returns
    -------
    ConversionReport

    Raises
    ------
    ValueError
        If the format cannot hold the camera and ``approximate`` is False (the message names
        what is lost and the residual).
    """
    p = Path(path)
    fmt = _check_format(format) if format else guess_format(p, for_writing=True)
    out, report = convert_camera(camera, fmt)
    if not report.exact and not approximate:
        raise ValueError(f"{p}: format {fmt!r} cannot hold camera {camera.name!r} exactly: "
                         + "; ".join(report.lost) + " (pass approximate=True / use "
                         "'pftrack calib convert' to accept)")
    _SAVERS[fmt](out, p)
    return report
