"""Image overlays drawn with OpenCV on a video frame: boxes with ids, projected particles,
projected volume edges and pitch/field lines, projected ground positions.

All functions take and return (H, W, 3) uint8 images in OpenCV's BGR order and never modify
their input (they draw on a copy). Pixel coordinates are (u, v) = (column, row), pixel centres
at integers. World points are metres in the camera's world frame; they go through
:meth:`pftrack.geometry.camera.Camera.project`, so lens distortion is applied. World lines are
sampled densely (``step_m``) before projection so that distortion bends them as it should;
points behind the camera (NaN) or far outside the image are dropped and the polyline is broken
there. Drawing is vectorised: polylines go to ``cv2.polylines`` as arrays, points are stamped
with array indexing (no Python loop over particles).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pftrack.geometry.camera import Camera
from pftrack.geometry.clouds import ParticleCloud
from pftrack.geometry.volumes import Volume, sample_polyline
from pftrack.render.colours import track_colours_rgb

__all__ = [
    "draw_uncertainty",
    "GROUND_DOT_BGR",
    "MARKING_BGR",
    "VOLUME_BGR",
    "draw_boxes",
    "draw_ground_points",
    "draw_particles",
    "draw_points",
    "draw_polylines",
    "draw_volume",
    "draw_world_polylines",
    "project_polylines",
    "read_video_frame",
    "render_overlay",
]

#: Colour of projected ground positions (BGR): pure magenta, rare in natural video.
GROUND_DOT_BGR = (255, 0, 255)
#: Pitch / field lines (BGR): white.
MARKING_BGR = (255, 255, 255)
#: Volume edges (BGR): yellow.
VOLUME_BGR = (0, 220, 255)

_SHIFT = 4  # cv2 sub-pixel bits for polylines


def _check_image(image: np.ndarray, name: str = "image") -> np.ndarray:
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise ValueError(f"{name}: expected an (H, W, 3) uint8 BGR image, got {img.shape} "
                         f"{img.dtype}")
    return np.ascontiguousarray(img).copy()


def draw_boxes(image_bgr: np.ndarray, boxes_xywh_px: np.ndarray, ids: np.ndarray,
               thickness: int = 2, labels: bool = True, font_scale: float = 0.5) -> np.ndarray:
    """Draw boxes with their ids, each in its id's stable colour.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8
    boxes_xywh_px : ndarray, shape (N, 4)
        left, top, width, height in pixels.
    ids : ndarray, shape (N,), int
        Track ids (colour = :func:`pftrack.render.colours.track_colours_rgb`).
    thickness : int
    labels : bool
        Write the id above each box's top-left corner.

    Returns
    -------
    ndarray, shape (H, W, 3), uint8
    """
    import cv2

    img = _check_image(image_bgr)
    boxes = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    ids = np.asarray(ids).astype(np.int64).reshape(-1)
    if len(ids) != len(boxes):
        raise ValueError(f"draw_boxes: {len(boxes)} boxes but {len(ids)} ids")
    ok = np.all(np.isfinite(boxes), axis=1)
    boxes, ids = boxes[ok], ids[ok]
    colours = track_colours_rgb(ids)[:, ::-1]
    x0, y0 = boxes[:, 0], boxes[:, 1]
    x1, y1 = x0 + boxes[:, 2], y0 + boxes[:, 3]
    rects = np.stack([np.column_stack([x0, y0]), np.column_stack([x1, y0]),
                      np.column_stack([x1, y1]), np.column_stack([x0, y1])], axis=1)
    rects = np.round(rects * (1 << _SHIFT)).astype(np.int32)
    # one polylines call per colour (a handful of targets)
    for c in np.unique(colours, axis=0):
        sel = np.all(colours == c, axis=1)
        cv2.polylines(img, list(rects[sel]), True, tuple(int(v) for v in c), thickness,
                      cv2.LINE_AA, _SHIFT)
    if labels:
        for (bx, by), i, c in zip(boxes[:, :2], ids, colours):
            org = (round(bx), round(max(by - 4, 12)))
            cv2.putText(img, str(int(i)), org, cv2.FONT_HERSHEY_SIMPLEX, font_scale,
                        (0, 0, 0), thickness + 2, cv2.LINE_AA)
            cv2.putText(img, str(int(i)), org, cv2.FONT_HERSHEY_SIMPLEX, font_scale,
                        tuple(int(v) for v in c), max(1, thickness - 1), cv2.LINE_AA)
    return img


def _disc_offsets(radius: int) -> np.ndarray:
    r = int(max(0, radius))
    dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
    keep = dx**2 + dy**2 <= r * r + r  # a round-ish disc; radius 0 -> one pixel
    return np.column_stack([dx[keep], dy[keep]])


def draw_points(image_bgr: np.ndarray, points_px: np.ndarray, colours_bgr: np.ndarray |
                Sequence[int], radius: int = 1) -> np.ndarray:
    """Stamp small discs at pixel positions by array indexing (vectorised over points).

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8
    points_px : ndarray, shape (N, 2)
        (u, v) pixels; NaN rows and discs outside the image are skipped.
    colours_bgr : (3,) or ndarray, shape (N, 3), uint8
        One colour for all, or one per point. Later points are drawn over earlier ones.
    radius : int
        Disc radius in pixels (0 = single pixel).

    Returns
    -------
    ndarray, shape (H, W, 3), uint8
    """
    img = _check_image(image_bgr)
    pts = np.asarray(points_px, dtype=np.float64).reshape(-1, 2)
    col = np.asarray(colours_bgr, dtype=np.uint8)
    col = np.broadcast_to(col.reshape(-1, 3) if col.ndim == 2 else col.reshape(1, 3),
                          (len(pts), 3))
    ok = np.all(np.isfinite(pts), axis=1)
    h, w = img.shape[:2]
    centres = np.round(pts[ok]).astype(np.int64)
    col = col[ok]
    off = _disc_offsets(radius)
    uv = (centres[:, None, :] + off[None, :, :]).reshape(-1, 2)
    c = np.repeat(col, len(off), axis=0)
    inside = (uv[:, 0] >= 0) & (uv[:, 0] < w) & (uv[:, 1] >= 0) & (uv[:, 1] < h)
    # fancy assignment: for repeated pixels the last point wins (numpy assigns in order)
    img[uv[inside, 1], uv[inside, 0]] = c[inside]
    return img


def project_polylines(camera: Camera, polylines_m: Sequence[np.ndarray], step_m: float = 0.25,
                      margin: float = 0.5) -> list[np.ndarray]:
    """Project world polylines into pixel polylines, bending with the lens.

    Parameters
    ----------
    camera : Camera
    polylines_m : sequence of ndarray, shape (K_i, 3)
        World polylines, metres.
    step_m : float
        Largest spacing of samples along each line before projection (metres).
    margin : float
        Points projecting farther than ``margin`` times the image size outside the image are
        dropped (far outside, a distortion model is no longer valid and may fold back).

    Returns
    -------
    list of ndarray, shape (k_j, 2)
        Pixel polylines (u, v); each input line is broken wherever a sample is behind the
        camera, NaN, or far outside. Pieces with fewer than 2 points are dropped.
    """
    lines = [sample_polyline(np.asarray(p, dtype=np.float64).reshape(-1, 3), step_m)
             for p in polylines_m if len(p) >= 2]
    if not lines:
        return []
    sizes = np.array([len(p) for p in lines])
    pts = np.vstack(lines)
    line_of = np.repeat(np.arange(len(lines)), sizes)
    px = camera.project(pts)
    w, h = camera.image_size
    ok = np.all(np.isfinite(px), axis=1)
    ok &= (px[:, 0] >= -margin * w) & (px[:, 0] <= (1 + margin) * w)
    ok &= (px[:, 1] >= -margin * h) & (px[:, 1] <= (1 + margin) * h)
    # a new piece starts at every valid sample whose predecessor is invalid or on another line
    prev_ok = np.concatenate([[False], ok[:-1]])
    same_line = np.concatenate([[False], line_of[1:] == line_of[:-1]])
    start = ok & ~(prev_ok & same_line)
    piece = np.cumsum(start) - 1
    idx = np.flatnonzero(ok)
    if not len(idx):
        return []
    pieces = np.split(px[idx], np.flatnonzero(np.diff(piece[idx])) + 1)
    return [p for p in pieces if len(p) >= 2]


def draw_polylines(image_bgr: np.ndarray, polylines_px: Sequence[np.ndarray],
                   colour_bgr: Sequence[int], thickness: int = 1) -> np.ndarray:
    """Draw pixel polylines (open) in one ``cv2.polylines`` call, sub-pixel, anti-aliased."""
    import cv2

    img = _check_image(image_bgr)
    arrs = [np.round(np.asarray(p, dtype=np.float64) * (1 << _SHIFT)).astype(np.int32)
            for p in polylines_px if len(p) >= 2]
    if arrs:
        cv2.polylines(img, arrs, False, tuple(int(c) for c in colour_bgr), int(thickness),
                      cv2.LINE_AA, _SHIFT)
    return img


def draw_world_polylines(image_bgr: np.ndarray, camera: Camera,
                         polylines_m: Sequence[np.ndarray], colour_bgr: Sequence[int],
                         thickness: int = 1, step_m: float = 0.25) -> np.ndarray:
    """Project world polylines (see :func:`project_polylines`) and draw them."""
    return draw_polylines(image_bgr, project_polylines(camera, polylines_m, step_m), colour_bgr,
                          thickness)


def draw_volume(image_bgr: np.ndarray, camera: Camera, volume: Volume, *,
                edges: bool = True, ground_lines: bool = True,
                edge_bgr: Sequence[int] = VOLUME_BGR, marking_bgr: Sequence[int] = MARKING_BGR,
                thickness: int = 2, step_m: float | None = None) -> np.ndarray:
    """Draw a volume's ground lines (pitch markings or footprint) and its 3D edges.

    ``step_m`` defaults to 1/200 of the volume's largest extent.
    """
    b = volume.bounds()
    if step_m is None:
        step_m = max(float(np.max(b[1] - b[0])) / 200.0, 1e-3)
    img = image_bgr
    if ground_lines:
        img = draw_world_polylines(img, camera, list(volume.ground_lines().values()),
                                   marking_bgr, thickness, step_m)
    if edges:
        img = draw_world_polylines(img, camera, list(np.asarray(volume.edges())), edge_bgr,
                                   thickness, step_m)
    return _check_image(img)


def draw_particles(image_bgr: np.ndarray, camera: Camera, clouds: Sequence[ParticleCloud],
                   radius: int = 1) -> np.ndarray:
    """Project particles and stamp them coloured by weight (viridis; heavy ones on top)."""
    clouds = [c for c in clouds if len(c)]
    if not clouds:
        return _check_image(image_bgr)
    vmax = max(float(c.weights.max()) for c in clouds)  # type: ignore[union-attr]
    pts = np.vstack([c.points_world_m for c in clouds])
    rgb = np.vstack([c.colours(vmax) for c in clouds])
    order = np.argsort(np.concatenate([c.weights for c in clouds]), kind="stable")
    px = camera.project(pts[order])
    return draw_points(image_bgr, px, rgb[order][:, ::-1], radius)


def draw_ground_points(image_bgr: np.ndarray, camera: Camera, points_world_m: np.ndarray,
                       radius: int = 3, colour_bgr: Sequence[int] = GROUND_DOT_BGR
                       ) -> np.ndarray:
    """Project world points (N, 3) (e.g. ground positions (x, y, 0)) and draw dots."""
    px = camera.project(np.asarray(points_world_m, dtype=np.float64).reshape(-1, 3))
    return draw_points(image_bgr, px, colour_bgr, radius)


def render_overlay(frame_bgr: np.ndarray, *, camera: Camera | None = None,
                   boxes_xywh_px: np.ndarray | None = None, ids: np.ndarray | None = None,
                   ground_points_m: np.ndarray | None = None, volume: Volume | None = None,
                   clouds: Sequence[ParticleCloud] = (), thickness: int = 2) -> np.ndarray:
    """Everything on one frame: volume/markings, particles, boxes with ids, ground dots.

    Layers needing a camera (volume, particles, ground points) raise ValueError without one.

    Returns
    -------
    ndarray, shape (H, W, 3), uint8, BGR
    """
    img = _check_image(frame_bgr, "frame")
    if camera is None and (volume is not None or len(clouds) or ground_points_m is not None):
        raise ValueError("render_overlay: volume, clouds and ground points need a camera")
    if volume is not None:
        img = draw_volume(img, camera, volume, thickness=max(1, thickness - 1))  # type: ignore[arg-type]
    if len(clouds):
        img = draw_particles(img, camera, clouds)  # type: ignore[arg-type]
    if boxes_xywh_px is not None:
        ids_ = np.arange(len(boxes_xywh_px)) if ids is None else ids
        img = draw_boxes(img, boxes_xywh_px, ids_, thickness)
    if ground_points_m is not None:
        img = draw_ground_points(img, camera, ground_points_m, radius=max(2, thickness + 1))  # type: ignore[arg-type]
    return img


def read_video_frame(path: str | os.PathLike[str], index: int) -> np.ndarray:
    """Frame ``index`` (0-based) of a video file as (H, W, 3) uint8 BGR.

    Raises FileNotFoundError / ValueError naming the file when it is missing, unreadable or
    shorter than ``index + 1`` frames.
    """
    import cv2

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"video {path} not found")
    if index < 0:
        raise ValueError(f"{path}: frame index must be >= 0, got {index}")
    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise ValueError(f"{path}: OpenCV cannot open this video")
        n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        if n > 0 and index >= n:
            raise ValueError(f"{path}: has {n} frames, frame index {index} is past the end")
        cap.set(cv2.CAP_PROP_POS_FRAMES, index)
        ok, frame = cap.read()
    finally:
        cap.release()
    if not ok or frame is None:
        raise ValueError(f"{path}: could not read frame index {index}")
    return np.ascontiguousarray(frame)


def draw_uncertainty(image_bgr: np.ndarray, xyxy: np.ndarray, xyxy_sd: np.ndarray,
                     ids: np.ndarray, k: float = 2.0, thickness: int = 1) -> np.ndarray:
    """Each track's box centre with its ``k``-sd ellipse, in its id's colour.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8
    xyxy : ndarray, shape (N, 4)
        Boxes x1, y1, x2, y2 in pixels (:attr:`pftrack.Tracks.xyxy`).
    xyxy_sd : ndarray, shape (N, 4)
        Standard deviations of x1, y1, x2, y2 in pixels (:attr:`pftrack.Tracks.xyxy_sd`).
        The ellipse's half-axes are ``k`` times the means of the two x and the two y sds: the
        centre's sd when a box's edges move together (a box of fixed size), more than it
        otherwise.
    ids : ndarray, shape (N,), int
        Track ids (colours as :func:`draw_boxes`).
    k : float
        Standard deviations drawn (2: 86 % of a Gaussian's mass). Unit: 1.

    Returns
    -------
    ndarray, shape (H, W, 3), uint8
    """
    import cv2

    from pftrack.render.ellipses import covariance_ellipses

    img = _check_image(image_bgr)
    b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    sd = np.asarray(xyxy_sd, dtype=np.float64).reshape(-1, 4)
    ids = np.asarray(ids).astype(np.int64).reshape(-1)
    if not len(b) == len(sd) == len(ids):
        raise ValueError(f"draw_uncertainty: {len(b)} boxes, {len(sd)} sds and {len(ids)} ids")
    centres = 0.5 * (b[:, :2] + b[:, 2:])
    s = 0.5 * (sd[:, :2] + sd[:, 2:])
    cov = np.zeros((len(b), 2, 2))
    cov[:, 0, 0], cov[:, 1, 1] = s[:, 0] ** 2, s[:, 1] ** 2
    outlines = covariance_ellipses(centres, cov, k=k)
    colours = track_colours_rgb(ids)[:, ::-1]
    ok = np.isfinite(outlines).all(axis=(1, 2))  # a record without a spread draws nothing
    pts = np.zeros(outlines.shape, dtype=np.int32)
    pts[ok] = np.round(outlines[ok] * (1 << _SHIFT)).astype(np.int32)
    for c in np.unique(colours[ok], axis=0):
        sel = ok & np.all(colours == c, axis=1)
        col = tuple(int(v) for v in c)
        cv2.polylines(img, list(pts[sel]), True, col, thickness, cv2.LINE_AA, _SHIFT)
        for u, v in centres[sel]:
            cv2.circle(img, (round(u), round(v)), 2, col, -1, cv2.LINE_AA)
    return img
