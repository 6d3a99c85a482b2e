"""A detector for a fixed camera over a pitch: players as foreground blobs, sized by the camera.

Registered as the ``pitch-blob`` detector; :class:`pftrack_world.soccer.SoccerScene` renders the
frames it is tested and benchmarked on.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path
from typing import Any

import numpy as np
from pftrack.contracts.components import Detections, Detector, Frame, Param, RunContext

from pftrack_world.soccer_pitch import _DEFAULT_VOLUME, default_soccer_camera_path


class PitchBlobDetector(Detector):
    """Players as foreground blobs inside the pitch's image region, sized by the camera.

    A fixed, calibrated camera over a pitch knows where players can be and how tall they look
    there. Per frame: OpenCV's MOG2 background model is updated on the pitch's bounding band of
    rows only (the run-off included); its foreground (shadows dropped) outside the projected
    pitch is cleared, closed vertically (limbs and torso join), and split into 8-connected blobs.
    For each blob the expected box of a ``height_m`` x ``width_m`` player standing at its bottom
    centre is computed through the camera (the same cuboid as the soccer scene's ground truth);
    blobs much smaller than that are dropped, blobs much wider are split into side-by-side
    players and blobs much taller into a near (bottom) and a far (top) player.

    {params}

    Attributes
    ----------
    camera_ : Camera
    band_ : tuple of int
        Rows ``(top, bottom)`` and columns ``(left, right)`` processed, ``(y0, y1, x0, x1)``.
    region_ : ndarray, shape (y1 - y0, x1 - x0), uint8
        255 where the pitch (with margin) is seen.
    subtractor_ : cv2.BackgroundSubtractorMOG2
    frames_seen_ : int

    Notes
    -----
    Detections carry ``points_world_m``: the ground point under each box's bottom centre. Each
    box is that of a ``height_m`` player standing there (:meth:`model_boxes`), not the blob's.
    Scores are the blob's foreground fill of its box times its height agreement (times
    ``split_score`` for the parts of a split blob), in (0, 1].
    """

    camera: str | os.PathLike[str] | None = Param(
        None, "Camera file; default the project's soccer camera "
        "(:func:`default_soccer_camera_path`).")
    volume: str = Param(
        _DEFAULT_VOLUME,
        "Pitch volume (camera's world frame) whose run-off bounds the search region.")
    margin_m: float = Param(
        2.0, "Extra ground margin around the volume, metres.", unit="m", low=0.0)
    history: int = Param(
        500, "MOG2's history (frames its background model remembers).", unit="frames", low=1)
    var_threshold: float = Param(
        16.0, "MOG2's varThreshold (squared Mahalanobis distance of a foreground pixel).",
        unit="1", low=0.0, low_open=True)
    learning_rate: float | None = Param(
        None,
        "MOG2's learning rate. None: automatic -- OpenCV's ``1 / min(frames, history)`` while "
        "the detector learns the background from the stream itself, and 0 (a frozen "
        "background) once :meth:`fit` has learned it from frames of the empty pitch, so "
        "players who stand still are never absorbed into the background.",
        unit="1/frame", high=1.0)
    height_m: float = Param(
        1.8, "Player height (its cuboid gives the expected box at each foot point).",
        unit="m", low=0.0, low_open=True)
    width_m: float = Param(
        0.6, "Player width (its cuboid gives the expected box at each foot point).",
        unit="m", low=0.0, low_open=True)
    min_height_frac: float = Param(
        0.4, "Blobs shorter than this fraction of the expected height are dropped.",
        unit="1", low=0.0)
    split_factor: float = Param(
        1.6, "A blob wider (taller) than ``split_factor`` times the expected width (height) is "
        "split.", unit="1", low=0.0, low_open=True)
    split_score: float = Param(
        0.4, "Factor on the score of the parts of a split blob (their positions are guesses), so "
        "that births (``min_score``) can ignore them while the tracker still uses them.",
        unit="1", low=0.0)
    foot_depth_m: float = Param(
        0.7,
        "Ground distance from a blob's lowest point (the nearest foot, plus the anti-aliased "
        "fringe) to the player's centre, away from the camera, added to ``points_world_m``. "
        "0.7 m removes the mean depth bias on the soccer scene with the soccer paper's camera "
        "(measured: mean error along the viewing direction -0.57 m at 0.3, ~0 at 0.7).", unit="m")
    warmup_frames: int = Param(
        1, "Frames at the start of a stream that only teach the background (unless fitted).",
        unit="frames", low=0)

    _STATE = ("camera_", "band_", "region_", "subtractor_", "frames_seen_", "image_shape_")

    def setup(self, context: RunContext) -> None:
        """The run's camera (``--camera``) when ``camera`` is not set."""
        if context.camera is not None:
            self.run_camera_ = context.camera

    def fit(self, frames: Any, boxes_by_frame: dict[int, np.ndarray] | None = None,
            rng: np.random.Generator | None = None,
            ignore_by_frame: dict[int, np.ndarray] | None = None) -> PitchBlobDetector:
        """Learn the background from frames of the pitch before play (a fixed camera can film
        the empty pitch; :meth:`SoccerScene.empty_frames` renders such frames).

        Frames with moving players work too (MOG2 averages them away), but players standing
        still would become background. ``boxes_by_frame`` and ``rng`` are not used. The learned
        band of each frame is kept (``fit_crops_``) so that :meth:`reset`, copies and unpickled
        detectors start from the same background. Returns ``self``.
        """
        crops = []
        shape = None
        self.__dict__.pop("fit_crops_", None)
        self.reset()
        for frame in frames:
            img = np.asarray(frame.image)
            if img.ndim != 3 or img.dtype != np.uint8:
                raise ValueError(f"PitchBlobDetector.fit: frame {frame.index} must be an "
                                 f"(H, W, 3) uint8 image, got {img.shape} {img.dtype}")
            if shape is None:
                shape = img.shape
                self._setup(shape)
            elif img.shape != shape:
                raise ValueError(f"PitchBlobDetector.fit: frame {frame.index} has shape "
                                 f"{img.shape}, the first had {shape}")
            y0, y1, x0, x1 = self.band_
            crops.append(np.ascontiguousarray(img[y0:y1, x0:x1]))
        self.fit_crops_ = crops
        self.fit_shape_ = shape
        self.reset()
        return self

    @classmethod
    def _conformance_example(cls) -> tuple[PitchBlobDetector, dict[str, Any]]:
        """A detector and 6 frames of the soccer scene at 640 x 360 for :mod:`pftrack.testing`."""
        return cls(), {"frames": [Frame(f.index, f.image.copy(), f.time_s)
                                  for f in _example_frames()]}

    def reset(self) -> PitchBlobDetector:
        """Start a new stream: forget what the stream taught (what :meth:`fit` learned stays)."""
        for k in self._STATE:
            self.__dict__.pop(k, None)
        return self

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        for k in self._STATE:  # OpenCV's model cannot be pickled: a new stream starts over
            state.pop(k, None)
        return state

    def _setup(self, shape: tuple[int, ...]) -> None:
        import cv2
        from pftrack.geometry.formats import load_camera
        from pftrack.geometry.volumes import resolve_volume

        given = self.camera if self.camera is not None else getattr(self, "run_camera_", None)
        if given is not None and not isinstance(given, (str, os.PathLike)):
            cam, path = given, "(the run's camera)"
        else:
            path = Path(given) if given is not None else default_soccer_camera_path()
            if not path.is_file():
                raise FileNotFoundError(f"PitchBlobDetector: camera file not found: {path}")
            cam = load_camera(path)
        h, w = shape[:2]
        if tuple(cam.image_size) != (w, h):
            cam = cam.resized((w, h))
        lo, hi = np.asarray(resolve_volume(self.volume).bounds(), dtype=np.float64)[:, :2]
        m = float(self.margin_m)
        lo, hi = lo - m, hi + m
        # the ground rectangle's outline, densely sampled so the lens bends it
        from pftrack.geometry.volumes import sample_polyline

        ring = sample_polyline(np.array([[lo[0], lo[1], 0], [hi[0], lo[1], 0],
                                         [hi[0], hi[1], 0], [lo[0], hi[1], 0],
                                         [lo[0], lo[1], 0]]), 0.5)
        px = cam.project(ring)
        px = px[np.isfinite(px).all(axis=1)]
        if len(px) < 3:
            raise ValueError(f"PitchBlobDetector: volume {self.volume!r} is not in view of "
                             f"camera {path}")
        full = np.zeros((h, w), np.uint8)
        cv2.fillPoly(full, [np.round(px).astype(np.int32)], 255)
        # head room above the far edge: players stand up to height_m above the ground
        pad = int(np.ceil(cam.fy * self.height_m / max(float(np.min(
            cam.depth(ring[::10]))), 1.0))) + 2
        ys, xs = np.nonzero(full)
        if len(ys) == 0:
            raise ValueError(f"PitchBlobDetector: volume {self.volume!r} projects outside the "
                             f"{w}x{h} image of camera {path}")
        y0, y1 = max(int(ys.min()) - pad, 0), min(int(ys.max()) + 2, h)
        x0, x1 = max(int(xs.min()) - 2, 0), min(int(xs.max()) + 2, w)
        region = cv2.dilate(full, np.ones((2 * pad + 1, 1), np.uint8), anchor=(0, 2 * pad))
        self.camera_ = cam
        self.band_ = (y0, y1, x0, x1)
        self.region_ = np.ascontiguousarray(region[y0:y1, x0:x1])
        self.subtractor_ = cv2.createBackgroundSubtractorMOG2(
            history=int(self.history), varThreshold=float(self.var_threshold),
            detectShadows=True)  # shadows marked, then counted as background
        self.frames_seen_ = 0
        self.image_shape_ = tuple(shape)
        if self._fitted():
            if tuple(self.fit_shape_) != tuple(shape):
                raise ValueError(f"PitchBlobDetector: frames of shape {tuple(shape)} but the "
                                 f"background was fitted on {tuple(self.fit_shape_)}")
            for crop in self.fit_crops_:
                self.subtractor_.apply(crop, learningRate=-1.0)

    def _fitted(self) -> bool:
        return bool(getattr(self, "fit_crops_", None))

    def _rate(self) -> float:
        if self.learning_rate is not None:
            return float(self.learning_rate)
        return 0.0 if self._fitted() else -1.0

    def expected_boxes(self, foot_px: np.ndarray) -> np.ndarray:
        """Boxes (K, 4) xywh px of a player cuboid standing at each foot pixel (K, 2)."""
        cam = self.camera_
        g = cam.image_to_ground(np.asarray(foot_px, dtype=np.float64).reshape(-1, 2))
        k = len(g)
        hw = self.width_m / 2
        off = np.array([[sx * hw, sy * hw, sz * self.height_m]
                        for sz in (0, 1) for sy in (-1, 1) for sx in (-1, 1)])
        pts = (g[:, None, :] + off[None]).reshape(-1, 3)
        px = cam.project(pts).reshape(k, 8, 2)
        lo, hi = px.min(axis=1), px.max(axis=1)
        return np.column_stack([lo, hi - lo])

    def foreground_mask(self, frame: Frame) -> np.ndarray:
        """Update the model; the cleaned foreground of the processed band, (y1-y0, x1-x0)."""
        import cv2

        img = np.asarray(frame.image)
        if img.ndim != 3 or img.dtype != np.uint8:
            raise ValueError(f"PitchBlobDetector: frame {frame.index} must be an (H, W, 3) "
                             f"uint8 image, got {img.shape} {img.dtype}")
        if getattr(self, "image_shape_", None) is None:
            self._setup(img.shape)
        elif self.image_shape_ != img.shape:
            raise ValueError(f"PitchBlobDetector: frame {frame.index} has shape {img.shape} "
                             f"but the stream started with {self.image_shape_}; call reset()")
        y0, y1, x0, x1 = self.band_
        raw = self.subtractor_.apply(np.ascontiguousarray(img[y0:y1, x0:x1]),
                                     learningRate=self._rate())
        self.frames_seen_ += 1
        mask = np.where((raw == 255) & (self.region_ > 0), np.uint8(255), np.uint8(0))
        return cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((3, 1), np.uint8))

    def detect(self, frame: Frame) -> Detections:
        import cv2

        mask = self.foreground_mask(frame)
        if not self._fitted() and self.frames_seen_ <= int(self.warmup_frames):
            return Detections.empty()
        _, _, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        stats = stats[1:]
        stats = stats[stats[:, cv2.CC_STAT_AREA] >= 3]
        if len(stats) == 0:
            return Detections.empty()
        y0, _, x0, _ = self.band_
        bx = stats[:, [cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH,
                       cv2.CC_STAT_HEIGHT]].astype(np.float64)
        bx[:, 0] += x0
        bx[:, 1] += y0
        # a blob covers pixel centres left..left+w-1; its outermost pixels are mostly the
        # half-covered anti-aliased fringe, so the figure's edges lie at those centres
        bx[:, 2:] = np.maximum(bx[:, 2:] - 1.0, 1.0)
        area = stats[:, cv2.CC_STAT_AREA].astype(np.float64)
        foot = np.column_stack([bx[:, 0] + bx[:, 2] / 2, bx[:, 1] + bx[:, 3]])
        exp = self.expected_boxes(foot)
        ok = np.isfinite(exp).all(axis=1) & (bx[:, 3] >= self.min_height_frac * exp[:, 3])
        boxes, scores = [], []
        for b, a, e in zip(bx[ok], area[ok], exp[ok]):  # loop over blobs (a few dozen)
            fill = a / max(b[2] * b[3], 1.0)
            n_wide = round(b[2] / e[2]) if b[2] > self.split_factor * e[2] else 1
            tall = b[3] > self.split_factor * e[3]
            parts = []
            for i in range(max(n_wide, 1)):
                wi = b[2] / n_wide
                left = b[0] + i * wi
                parts.append([left, b[1] + (b[3] - e[3] if tall else 0.0), wi,
                              e[3] if tall else b[3]])
                if tall:  # a far player whose feet are hidden behind the near one
                    parts.append([left, b[1], wi, e[3]])
            agree = min(1.0, b[3] / e[3]) if not tall else 1.0
            # a split guesses where the players of a merged blob stand: less confident
            conf = fill * agree * (float(self.split_score) if len(parts) > 1 else 1.0)
            for p in parts:
                boxes.append(p)
                scores.append(float(np.clip(conf, 1e-3, 1.0)))
        if not boxes:
            return Detections.empty()
        boxes_a = np.asarray(boxes, dtype=np.float64)
        foot = np.column_stack([boxes_a[:, 0] + boxes_a[:, 2] / 2, boxes_a[:, 1] + boxes_a[:, 3]])
        world = self.camera_.image_to_ground(foot)
        # the lowest pixel is the nearest foot: the player's centre lies a little further away
        away = world[:, :2] - self.camera_.center_m[None, :2]
        away /= np.maximum(np.linalg.norm(away, axis=1, keepdims=True), 1e-9)
        world[:, :2] += float(self.foot_depth_m) * away
        # each box that of a height_m player standing at the ground point (the tracker's
        # CameraBoxObservation convention): foot points compare without the bias of the blob's
        # lowest pixel
        boxes_a = self.model_boxes(world)
        ok = np.isfinite(boxes_a).all(axis=1)
        boxes_a, world = boxes_a[ok], world[ok]
        scores = list(np.asarray(scores)[ok])
        return Detections(boxes_a, np.asarray(scores, dtype=np.float64), world)

    def model_boxes(self, points_world_m: np.ndarray) -> np.ndarray:
        """Boxes (K, 4) of ``height_m`` players standing at ground points (K, 3): bottom centre
        at the projected point, top at the projected head, width ``width_m / height_m`` of the
        height (the convention of
        :class:`pftrack.builtin.world_observation.CameraBoxObservation`)."""
        g = np.asarray(points_world_m, dtype=np.float64).reshape(-1, 3).copy()
        g[:, 2] = 0.0
        head = g.copy()
        head[:, 2] = float(self.height_m)
        px = self.camera_.project(np.concatenate([g, head]))
        foot, top = px[: len(g)], px[len(g):]
        h = np.hypot(*(foot - top).T)
        w = h * float(self.width_m) / float(self.height_m)
        return np.column_stack([foot[:, 0] - w / 2, foot[:, 1] - h, w, h])


@functools.lru_cache(maxsize=1)
def _example_frames() -> tuple[Frame, ...]:
    """Six small frames of the soccer scene (cached; the conformance kit asks repeatedly)."""
    from pftrack_world.soccer import SoccerScene  # the scene's module imports this one

    scene = SoccerScene(duration_s=0.24, image_size=(640, 360), supersample=1)
    return tuple(scene.frames())
