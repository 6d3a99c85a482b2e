"""The pitch the ``soccer`` scene films: its default camera and volume, and its static picture.

The empty pitch (grass with mowing stripes, markings, goals, stands) is rendered once per scene
through the camera's lens model, so straight lines bend as the players do;
:class:`pftrack_world.soccer.SoccerScene` draws the players over it and
:class:`pftrack_world.soccer_detector.PitchBlobDetector` finds them against it.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera


#: Candidate file names of the project's soccer camera, searched in ``calib/``.
_CAMERA_FILE = "soccer_camera.yaml"
#: Default pitch volume (in the camera's world frame), looked up with
#: :func:`pftrack.geometry.volumes.resolve_volume` (``pftrack_world/data/volumes.yaml``).
_DEFAULT_VOLUME = "pitch_corner"


def default_soccer_camera_path() -> Path:
    """The plugin's soccer camera, package data ``pftrack_world/data/soccer_camera.yaml``
    (the soccer paper's Table 1 camera; ``calib/soccer_camera.yaml`` in a checkout points to it).

    Raises
    ------
    FileNotFoundError
        When the package data is missing (a broken install), naming the path.
    """
    from importlib import resources

    path = Path(str(resources.files("pftrack_world") / "data" / _CAMERA_FILE))
    if not path.is_file():
        raise FileNotFoundError(f"soccer scene: the plugin's camera {path} is missing (package "
                                "data of pftrack_world); pass camera=PATH")
    return path


def _noise_bank(rng: np.random.Generator, shape: tuple[int, int], std: float,
                n: int = 4) -> list[tuple[np.ndarray, np.ndarray]] | None:
    """A few frames of sensor noise split into positive and negative uint8 parts."""
    if std <= 0:
        return None
    bank = []
    for _ in range(n):
        z = np.rint(rng.normal(0.0, std, shape + (3,))).clip(-255, 255)
        bank.append((np.maximum(z, 0).astype(np.uint8), np.maximum(-z, 0).astype(np.uint8)))
    return bank


def _scaled_camera(camera: Camera, factor: int) -> Camera:
    """The same camera rendering at ``factor`` times the resolution (pixel centres kept)."""
    if factor == 1:
        return camera
    w, h = camera.image_size
    return camera.resized((w * factor, h * factor))


def marking_quads(pitch: Any, line_width_m: float = 0.12, step_m: float = 0.25) -> np.ndarray:
    """The pitch markings as thin ground quads, world metres.

    Parameters
    ----------
    pitch : SoccerPitchVolume
    line_width_m : float
        Painted line width (FIFA: at most 0.12 m).
    step_m : float
        Polyline sampling step; each short segment becomes one quad, so curves and the lens's
        bending of straight lines are followed.

    Returns
    -------
    ndarray, shape (Q, 4, 3)
        Quad corners on z = 0.
    """
    quads = []
    for poly in pitch.markings(step_m=step_m).values():
        p = poly[:, :2]
        d = np.diff(p, axis=0)
        ln = np.linalg.norm(d, axis=1)
        keep = ln > 1e-9
        if not keep.any():
            continue
        a, b, d, ln = p[:-1][keep], p[1:][keep], d[keep], ln[keep]
        u = d / ln[:, None]
        nrm = np.stack([-u[:, 1], u[:, 0]], axis=1) * (line_width_m / 2)
        ext = u * (line_width_m / 2)  # overlap the joints
        q = np.stack([a - ext + nrm, b + ext + nrm, b + ext - nrm, a - ext - nrm], axis=1)
        quads.append(np.concatenate([q, np.zeros(q.shape[:2] + (1,))], axis=2))
    return np.concatenate(quads) if quads else np.zeros((0, 4, 3))


def _goal_boxes(pitch: Any) -> np.ndarray:
    """Posts and crossbars of both goals as thin boxes, (B, 8, 3) world metres."""
    from pftrack.geometry.volumes import GOAL_WIDTH_M

    hl = pitch.length_m / 2
    gw = GOAL_WIDTH_M / 2
    r = 0.06
    gh = 2.44
    boxes = []
    off = pitch.origin_offset_m
    for sgn in (-1.0, 1.0):
        x = sgn * (hl + r)
        for lo, hi in (([x - r, -gw - 2 * r, 0], [x + r, -gw, gh + r]),
                       ([x - r, gw, 0], [x + r, gw + 2 * r, gh + r]),
                       ([x - r, -gw - 2 * r, gh], [x + r, gw + 2 * r, gh + 2 * r])):
            lo, hi = np.array(lo), np.array(hi)
            c = np.array([[lo[0] if i & 1 == 0 else hi[0], lo[1] if i & 2 == 0 else hi[1],
                           lo[2] if i & 4 == 0 else hi[2]] for i in range(8)])
            boxes.append(c + off)
    return np.array(boxes)


def render_pitch_background(camera: Camera, pitch: Any, rng: np.random.Generator,
                            centre_m: Any = None, supersample: int = 2,
                            n_stripes: int = 18) -> np.ndarray:
    """The empty pitch seen by ``camera``: grass with mowing stripes, markings, goals, stands.

    Every pixel is cast onto the ground (z = 0) through the camera's lens model; the stripes
    and the grass texture are functions of the ground point, the markings are ground quads
    projected and filled, so all of it bends with the lens exactly as the players do.

    Parameters
    ----------
    camera : Camera
        Output size is ``camera.image_size``.
    pitch : SoccerPitchVolume
        Size and markings; its ``margin_m`` is the grass run-off around the lines.
    rng : numpy.random.Generator
        Grass texture and crowd speckle.
    centre_m : array_like, shape (3,), optional
        World position of the centre spot in the camera's frame; default the pitch's own
        ``origin_offset_m`` (0 for a centre-frame pitch).
    supersample : int
        Render at this factor and average down (anti-aliasing).
    n_stripes : int
        Mowing stripes across the length of the pitch.

    Returns
    -------
    ndarray, shape (H, W, 3), uint8, BGR
    """
    import cv2

    W, H = camera.image_size
    cam = _scaled_camera(camera, supersample)
    Ws, Hs = cam.image_size
    u, v = np.meshgrid(np.arange(Ws, dtype=np.float64), np.arange(Hs, dtype=np.float64))
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        g = cam.image_to_ground(np.column_stack([u.ravel(), v.ravel()]))
    c = np.asarray(pitch.origin_offset_m if centre_m is None else centre_m, dtype=np.float64)
    shift = c - np.asarray(pitch.origin_offset_m, dtype=np.float64)  # pitch frame -> world
    gx = (g[:, 0] - c[0]).reshape(Hs, Ws)
    gy = (g[:, 1] - c[1]).reshape(Hs, Ws)
    hl, hw, m = pitch.length_m / 2, pitch.width_m / 2, pitch.margin_m
    on_ground = np.isfinite(gx)
    # far away the ground is seen at grazing angles: everything beyond the run-off is stands
    grass = on_ground & (np.abs(gx) <= hl + m) & (np.abs(gy) <= hw + m)
    # grass: two shades in stripes along x, low-frequency texture, fine noise
    stripe = np.floor((np.nan_to_num(gx) + hl) / (pitch.length_m / n_stripes)).astype(np.int64)
    shade = np.where(stripe % 2 == 0, 1.0, 0.86)
    tex_small = rng.normal(0.0, 1.0, (48, 80)).astype(np.float32)
    tex = cv2.resize(cv2.GaussianBlur(tex_small, (0, 0), 1.5), (Ws, Hs),
                     interpolation=cv2.INTER_CUBIC)
    tex = 1.0 + 0.06 * tex / max(float(np.std(tex)), 1e-6)
    base = np.array([60.0, 140.0, 70.0])  # BGR grass green
    img = np.empty((Hs, Ws, 3), np.float32)
    img[:] = (shade * tex)[..., None] * base
    # outside the run-off: advertising boards, a running track 8 m wide, then (and above the
    # horizon) the stands with a blurred crowd texture
    track = on_ground & ~grass & (np.abs(gx) <= hl + m + 8.0) & (np.abs(gy) <= hw + m + 8.0)
    stands = ~grass & ~track
    if stands.any():
        palette = np.array([[70, 60, 55], [95, 90, 100], [55, 50, 65], [110, 105, 100],
                            [60, 70, 95]], np.float32)
        crowd = palette[rng.integers(0, len(palette), (Hs // 4 + 1, Ws // 4 + 1))]
        crowd = cv2.GaussianBlur(crowd, (0, 0), 0.8)
        cimg = cv2.resize(crowd, (Ws, Hs), interpolation=cv2.INTER_LINEAR)
        rows = np.linspace(0.8, 1.0, Hs, dtype=np.float32)[:, None, None]
        img[stands] = (cimg * rows)[stands]
    img[track] = (70, 85, 110)  # a dull brown-grey track
    board = on_ground & ~grass & (np.abs(gx) <= hl + m + 0.8) & (np.abs(gy) <= hw + m + 0.8)
    img[board] = (40, 40, 150)
    img = np.clip(img, 0, 255).astype(np.uint8)
    # markings: thin ground quads projected through the lens, filled one by one (fillPoly with
    # several overlapping polygons would cancel their overlaps), anti-aliased by downsampling
    quads = marking_quads(pitch, 0.12, 0.25) + shift
    qpx = cam.project(quads.reshape(-1, 3)).reshape(-1, 4, 2)
    good = np.isfinite(qpx).all(axis=(1, 2))
    qpx = qpx[good]
    inside = ((qpx[..., 0].max(1) >= -2) & (qpx[..., 0].min(1) <= Ws + 2)
              & (qpx[..., 1].max(1) >= -2) & (qpx[..., 1].min(1) <= Hs + 2))
    for q in np.round(qpx[inside] * 16).astype(np.int32):
        cv2.fillConvexPoly(img, q, (235, 238, 235), lineType=cv2.LINE_8, shift=4)
    # goals: posts and crossbar as projected thin boxes
    gb = _goal_boxes(pitch) + shift
    gpx = cam.project(gb.reshape(-1, 3)).reshape(-1, 8, 2)
    for q in gpx:
        if np.isfinite(q).all():
            hull = cv2.convexHull(np.round(q * 16).astype(np.int32))
            cv2.fillConvexPoly(img, hull, (245, 245, 245), lineType=cv2.LINE_AA, shift=4)
    if supersample > 1:
        img = cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA)
    return np.ascontiguousarray(img)
