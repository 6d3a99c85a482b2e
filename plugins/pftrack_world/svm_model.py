"""The linear SVM person detector's model and the windows it scores (for
:class:`pftrack_world.detector.SVMDetector`): :class:`SVMModel` and its ``.npz`` file, the scale
plan (which person heights to look for at which image rows, from a camera or from boxes), the
windows cropped and their features (HOG or grey levels), and the dense scan of a scale band.
Every name is also importable from :mod:`pftrack_world.detector`.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pftrack.contracts.components import (
    Detections,
)
from pftrack.geometry.boxes import foot_points, iou_matrix

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera


__all__ = [
    "SVMModel",
    "ScaleBand",
    "TrainingRecallWarning",
    "crop_windows",
    "detections_on_ground",
    "expected_heights_px",
    "heights_from_boxes",
    "load_model",
    "merge_clusters",
    "n_features_for",
    "save_model",
    "scale_plan",
    "window_features",
]

MODEL_FORMAT = "pftrack-svm-detector"
#: :func:`train_svm_model` warns (:class:`TrainingRecallWarning`) when the trained model finds
#: fewer of its own positives than this at the detector's threshold.
MIN_TRAIN_RECALL = 0.5


class TrainingRecallWarning(UserWarning):
    """A trained detector cannot separate its own training positives."""

MODEL_VERSION = 1
FEATURES = ("hog", "grey")


# --------------------------------------------------------------------------------------------
# Model file
# --------------------------------------------------------------------------------------------


@dataclass
class SVMModel:
    """A trained linear SVM window classifier.

    Attributes
    ----------
    weights : ndarray, shape (F,), float32
        Unit-norm weight vector (so ``weights . x + bias`` is the signed distance c(det)).
    bias : float
        Bias after the same normalisation.
    feature : {"hog", "grey"}
        ``hog``: OpenCV HOG (cells 8 px, blocks 16 px, stride 8 px, 9 bins) of the grey window;
        ``grey``: the grey window's pixel values / 255 (the paper's feature), row-major.
    window_wh : (int, int)
        Window size in pixels (width, height).
    box_in_window : (float, float, float, float)
        The person box inside the window (left, top, width, height), window pixels.
    info : dict
        Training record (frames, counts, training accuracy...). Informative only.
    """

    weights: np.ndarray
    bias: float
    feature: str = "hog"
    window_wh: tuple[int, int] = (32, 64)
    box_in_window: tuple[float, float, float, float] = (6.9, 6.4, 18.2, 51.2)
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def n_features(self) -> int:
        return int(self.weights.size)

    def params(self) -> dict[str, Any]:
        return {
            "format": MODEL_FORMAT,
            "version": MODEL_VERSION,
            "feature": self.feature,
            "window_wh": [int(v) for v in self.window_wh],
            "box_in_window": [float(v) for v in self.box_in_window],
            "bias": float(self.bias),
            "info": self.info,
        }


def detections_on_ground(boxes_xywh_px: np.ndarray, scores: np.ndarray,
                         camera: Camera | None) -> Detections:
    """A detector's boxes and scores as :class:`~pftrack.contracts.components.Detections`, each
    box's foot point (bottom centre) back-projected to the ground (metres) when there is a
    camera."""
    points = None
    if camera is not None:
        feet = foot_points(boxes_xywh_px)
        points = camera.image_to_ground(feet) if len(feet) else np.zeros((0, 3))
    return Detections(boxes_xywh_px, scores, points)


def _hog(window_wh: Sequence[int]):
    import cv2

    return cv2.HOGDescriptor((int(window_wh[0]), int(window_wh[1])), (16, 16), (8, 8), (8, 8), 9)


def n_features_for(feature: str, window_wh: Sequence[int]) -> int:
    """Length of the feature vector of one window."""
    if feature == "hog":
        return int(_hog(window_wh).getDescriptorSize())
    if feature == "grey":
        return int(window_wh[0]) * int(window_wh[1])
    raise ValueError(f"unknown detector feature {feature!r}; known: {', '.join(FEATURES)}")


def save_model(model: SVMModel, path: str | os.PathLike[str]) -> Path:
    """Write ``model`` to ``path`` (``.npz``, no pickle) atomically."""
    from pftrack.io.atomic import atomic_path

    path = Path(path)
    if path.suffix != ".npz":
        raise ValueError(f"detector model {path}: the file name must end in .npz")
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, weights=np.asarray(model.weights, dtype=np.float32),
                 params=np.array(json.dumps(model.params())))
    return path


def load_model(path: str | os.PathLike[str]) -> SVMModel:
    """Read and validate a model written by :func:`save_model`.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ValueError
        The file is not a pftrack detector model, or its weights do not fit its parameters
        (the message names the file and what is wrong).
    """
    import zipfile

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"detector model {path} not found")
    if not zipfile.is_zipfile(path):
        raise ValueError(f"detector model {path}: not an .npz file (expected the zip archive "
                         "`pftrack detector train` writes)")
    try:
        with np.load(path, allow_pickle=False) as z:
            if "weights" not in z.files or "params" not in z.files:
                raise ValueError(f"detector model {path}: expected arrays 'weights' and 'params', "
                                 f"found {sorted(z.files)}")
            weights = np.asarray(z["weights"], dtype=np.float32).ravel()
            params = json.loads(str(z["params"]))
    except ValueError as exc:
        if str(path) in str(exc):
            raise
        raise ValueError(f"detector model {path}: not a readable .npz model ({exc})") from None
    except (OSError, EOFError) as exc:
        raise ValueError(f"detector model {path}: not a readable .npz model ({exc})") from None
    if params.get("format") != MODEL_FORMAT:
        raise ValueError(f"detector model {path}: format {params.get('format')!r}, expected "
                         f"{MODEL_FORMAT!r}")
    if int(params.get("version", -1)) > MODEL_VERSION:
        raise ValueError(f"detector model {path}: version {params.get('version')} is newer than "
                         f"this pftrack reads ({MODEL_VERSION})")
    feature = params.get("feature")
    if feature not in FEATURES:
        raise ValueError(f"detector model {path}: unknown feature {feature!r}")
    window = tuple(int(v) for v in params.get("window_wh", ()))
    if len(window) != 2 or min(window) <= 0 or (feature == "hog" and (
            window[0] % 8 or window[1] % 8 or window[0] < 16 or window[1] < 16)):
        raise ValueError(f"detector model {path}: bad window_wh {params.get('window_wh')}")
    biw = tuple(float(v) for v in params.get("box_in_window", ()))
    if len(biw) != 4 or biw[2] <= 0 or biw[3] <= 0:
        raise ValueError(f"detector model {path}: bad box_in_window {params.get('box_in_window')}")
    expected = n_features_for(feature, window)
    if weights.size != expected or not np.all(np.isfinite(weights)):
        raise ValueError(f"detector model {path}: {weights.size} weights (finite: "
                         f"{bool(np.all(np.isfinite(weights)))}), expected {expected} finite "
                         f"values for {feature} features of a {window[0]}x{window[1]} window")
    bias = float(params.get("bias", np.nan))
    if not np.isfinite(bias):
        raise ValueError(f"detector model {path}: bias is missing or not finite")
    return SVMModel(weights, bias, feature, window, biw, dict(params.get("info", {})))


# --------------------------------------------------------------------------------------------
# Boxes
# --------------------------------------------------------------------------------------------


def merge_clusters(boxes_xywh_px: np.ndarray, scores: np.ndarray, keep: np.ndarray,
                   iou_min: float = 0.5, tau: float = 0.1) -> np.ndarray:
    """Refine each kept box by the score-weighted mean of the windows around it.

    Windows lie on a grid (the HOG stride, 8 px at each scale); averaging each kept box with the
    windows that overlap it by at least ``iou_min``, weighted by ``exp((c - c_best) / tau)``,
    places it between grid positions. Returns the refined boxes (len(keep), 4).
    """
    boxes = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    if len(keep) == 0:
        return np.zeros((0, 4))
    iou = iou_matrix(boxes[keep], boxes)  # (M, K)
    w = np.where(iou >= iou_min, np.exp((scores[None, :] - scores[keep][:, None]) / tau), 0.0)
    w[np.arange(len(keep)), keep] = 1.0
    return (w @ boxes) / w.sum(axis=1, keepdims=True)


# --------------------------------------------------------------------------------------------
# Scale plan
# --------------------------------------------------------------------------------------------


@dataclass
class ScaleBand:
    """One scale of the search: windows of ``f`` original pixels per window pixel whose top row
    lies in ``[top_min, top_max]`` (original pixels)."""

    f: float
    top_min: int
    top_max: int


def expected_heights_px(camera: Camera, height_m: float, image_size_wh: tuple[int, int],
                        step_px: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Expected person height (px) for a foot at each pixel of a grid (world frame z up, ground
    z = 0). Returns (foot pixels (M, 2), heights (M,)); NaN above the horizon."""
    w, h = image_size_wh
    us, vs = np.meshgrid(np.arange(0, w, step_px, dtype=np.float64),
                         np.arange(0, h, step_px, dtype=np.float64))
    px = np.stack([us.ravel(), vs.ravel()], axis=1)
    ground = camera.image_to_ground(px)
    head = ground.copy()
    head[:, 2] = height_m
    hp = camera.project(head)
    heights = np.where(np.isfinite(hp[:, 1]), px[:, 1] - hp[:, 1], np.nan)
    heights[~(heights > 0)] = np.nan
    return px, heights


def heights_from_boxes(boxes_xywh_px: np.ndarray, image_size_wh: tuple[int, int],
                       step_px: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Expected person height (px) for a foot at each pixel of a grid, learnt from boxes.

    Without a camera, the ground-truth boxes of the training frames say the same thing a
    calibrated camera does: on a flat ground seen by a pinhole camera, a person's image height
    is an affine function of the foot point ``(u, v)`` (it grows linearly with the distance of
    the foot row below the horizon). The least-squares plane ``h = a u + b v + c`` through the
    boxes' (foot, height) samples is evaluated on the grid of :func:`expected_heights_px`.

    Parameters
    ----------
    boxes_xywh_px : ndarray, shape (K, 4)
        Person boxes (left, top, width, height) in pixels; at least 3.
    image_size_wh : (int, int)
    step_px : int
        Grid step (pixels).

    Returns
    -------
    feet : ndarray, shape (M, 2)
        Foot pixels of the grid.
    heights : ndarray, shape (M,)
        Expected heights (px); NaN where the fit is not positive (above the horizon).
    """
    b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    b = b[np.all(np.isfinite(b), axis=1) & (b[:, 3] > 0)]
    if len(b) < 3:
        raise ValueError(f"heights_from_boxes: need at least 3 boxes, got {len(b)}")
    A = np.column_stack([foot_points(b), np.ones(len(b))])
    coef, *_ = np.linalg.lstsq(A, b[:, 3], rcond=None)
    w, h = image_size_wh
    us, vs = np.meshgrid(np.arange(0, w, step_px, dtype=np.float64),
                         np.arange(0, h, step_px, dtype=np.float64))
    px = np.stack([us.ravel(), vs.ravel()], axis=1)
    heights = px @ coef[:2] + coef[2]
    heights[~(heights > 0)] = np.nan
    return px, heights


def _camera_words(camera: Camera) -> str:
    """``camera FILE (for WxH images)`` (or ``the camera NAME``) for a message."""
    src = camera.metadata.get("source") if isinstance(camera.metadata, dict) else None
    path = src.get("path") if isinstance(src, dict) else None
    label = getattr(camera, "name", "") or ""
    name = f"camera {path}" if path else (f"the camera {label!r}" if label else "the camera")
    cw, ch = camera.image_size
    return f"{name} (calibrated for {cw}x{ch} images)"


def scale_plan(box_height_win: float, window_h: int, foot_offset_win: float,
               image_size_wh: tuple[int, int], *, scale_step: float = 1.15,
               min_height_px: float = 40.0, max_height_px: float = 400.0,
               camera: Camera | None = None, height_m: float = 1.75, tolerance: float = 1.25,
               expected: tuple[np.ndarray, np.ndarray] | None = None,
               ) -> list[ScaleBand]:
    """The scales to search and, with a camera, the band of window tops at each scale.

    Parameters
    ----------
    box_height_win : float
        Height of the person box inside the window (window pixels).
    window_h : int
        Window height (window pixels).
    foot_offset_win : float
        Row of the person's foot inside the window (window pixels from its top).
    image_size_wh : (int, int)
    scale_step : float
        Ratio between consecutive scales.
    min_height_px, max_height_px : float
        Person heights (image pixels) searched without a camera; with one, the camera's range
        is clipped to them.
    camera : pftrack.geometry.camera.Camera, optional
        Gives the expected person height at each foot row, so that each scale only scans the
        rows where a person of that size can stand (a strong speed-up).
    height_m : float
        Person height for the camera's expectation, metres.
    tolerance : float
        A foot row is searched at scale f when the expected height is within a factor
        ``tolerance * sqrt(scale_step)`` of the scale's box height.
    expected : (feet (M, 2), heights (M,)), optional
        Used like the camera's expectation when there is no camera (e.g.
        :func:`heights_from_boxes` of the training boxes).
    """
    if scale_step <= 1.0:
        raise ValueError(f"scale_step must be > 1, got {scale_step}")
    h = image_size_wh[1]
    lo, hi = float(min_height_px), float(max_height_px)
    feet = heights = None
    where = f"{image_size_wh[0]}x{image_size_wh[1]} frames"
    if camera is not None or expected is not None:
        if camera is not None:
            feet, heights = expected_heights_px(camera, height_m, image_size_wh)
            where = f"{_camera_words(camera)} on {where}"
        else:
            feet, heights = (np.asarray(a, dtype=np.float64) for a in expected)
            where = f"the person heights expected from the training boxes on {where}"
        ok = np.isfinite(heights)
        if not np.any(ok):
            raise ValueError(f"scale_plan: {where}: no image row sees the ground (check that "
                             "the camera belongs to this video)")
        lo = max(lo, float(np.nanmin(heights)) / tolerance)
        hi = min(hi, float(np.nanmax(heights)) * tolerance)
        if hi < lo:
            raise ValueError(
                f"scale_plan: {where}: people {height_m:g} m tall would be "
                f"{np.nanmin(heights):.0f}-{np.nanmax(heights):.0f} px tall, outside the "
                f"searched {min_height_px:g}-{max_height_px:g} px (min_height_px, "
                f"max_height_px; tolerance {tolerance:g}): empty height range [{lo:.0f}, "
                f"{hi:.0f}] px (check that the camera belongs to this video)")
    if hi < lo:
        raise ValueError(f"scale_plan on {where}: empty height range [{lo:.0f}, {hi:.0f}] px "
                         "(min_height_px > max_height_px)")
    n = int(np.floor(np.log(hi / lo) / np.log(scale_step))) + 1
    bands = []
    slack = tolerance * np.sqrt(scale_step)
    for k in range(n):
        box_h = lo * scale_step ** k
        f = box_h / box_height_win
        if feet is None:
            bands.append(ScaleBand(f, 0, int(h - window_h * f)))
            continue
        sel = (heights >= box_h / slack) & (heights <= box_h * slack)
        if not np.any(sel):
            continue
        vmin, vmax = float(feet[sel, 1].min()) - 16, float(feet[sel, 1].max()) + 16
        top_min = int(np.floor(vmin - foot_offset_win * f))
        top_max = int(np.ceil(vmax - foot_offset_win * f))
        top_min, top_max = max(top_min, int(-0.3 * window_h * f)), min(top_max, h - 1)
        if top_max < top_min:
            continue
        bands.append(ScaleBand(f, top_min, top_max))
    return bands


# --------------------------------------------------------------------------------------------
# Features of single windows (training)
# --------------------------------------------------------------------------------------------


def _window_rect(person_boxes: np.ndarray, box_in_window: Sequence[float],
                 window_wh: Sequence[int]) -> np.ndarray:
    """Window rectangles (x, y, w, h) in image px whose person box is ``person_boxes``."""
    b = np.asarray(person_boxes, dtype=np.float64).reshape(-1, 4)
    bl, bt, bw, bh = box_in_window
    f = b[:, 3] / bh
    x = b[:, 0] + 0.5 * b[:, 2] - f * (bl + 0.5 * bw)
    y = b[:, 1] - f * bt
    return np.stack([x, y, f * window_wh[0], f * window_wh[1]], axis=1)


def crop_windows(grey: np.ndarray, windows_xywh: np.ndarray,
                 window_wh: Sequence[int]) -> np.ndarray:
    """Crops of ``grey`` at the given rectangles resized to ``window_wh`` (area averaging),
    borders replicated. Returns (K, H, W) uint8. A loop over windows: training only."""
    import cv2

    W, H = int(window_wh[0]), int(window_wh[1])
    out = np.empty((len(windows_xywh), H, W), dtype=np.uint8)
    ih, iw = grey.shape[:2]
    for i, (x, y, w, h) in enumerate(np.asarray(windows_xywh, dtype=np.float64)):
        x0, y0 = round(x), round(y)
        x1, y1 = round(x + w), round(y + h)
        x1, y1 = max(x1, x0 + 1), max(y1, y0 + 1)
        pad = (max(0, -y0), max(0, y1 - ih), max(0, -x0), max(0, x1 - iw))
        crop = grey[max(y0, 0):min(y1, ih), max(x0, 0):min(x1, iw)]
        if crop.size == 0:
            crop = np.zeros((1, 1), np.uint8)
            pad = (0, y1 - y0 - 1, 0, x1 - x0 - 1)
        if any(pad):
            crop = cv2.copyMakeBorder(crop, *pad, cv2.BORDER_REPLICATE)
        interp = cv2.INTER_AREA if crop.shape[0] > H else cv2.INTER_LINEAR
        out[i] = cv2.resize(crop, (W, H), interpolation=interp)
    return out


def window_features(crops: np.ndarray, feature: str) -> np.ndarray:
    """Features (K, F) float32 of window crops (K, H, W) uint8."""
    crops = np.asarray(crops, dtype=np.uint8)
    if feature == "grey":
        return crops.reshape(len(crops), -1).astype(np.float32) / 255.0
    if feature == "hog":
        hog = _hog((crops.shape[2], crops.shape[1]))
        if len(crops) == 0:
            return np.zeros((0, hog.getDescriptorSize()), np.float32)
        return np.stack([hog.compute(c).ravel() for c in crops]).astype(np.float32)
    raise ValueError(f"unknown detector feature {feature!r}; known: {', '.join(FEATURES)}")


# --------------------------------------------------------------------------------------------
# Dense scoring
# --------------------------------------------------------------------------------------------


def _band_strip(band: ScaleBand, ih: int, window_h: int) -> tuple[int, int] | None:
    """Rows ``[y0, y1)`` of the image a band scans, or None when too few for one window."""
    f = band.f
    y0 = max(band.top_min, 0)
    y1 = min(int(np.ceil(band.top_max + window_h * f)) + 1, ih)
    if y1 - y0 < window_h * f * 0.999:
        return None
    return y0, y1


def _small_windows(model: SVMModel, small: np.ndarray, threshold: float, hog: Any,
                   kernel: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Window tops (K, 2) of the resized strip ``small`` scoring at least ``threshold``, and
    their scores; stride 8 from the strip's corner (HOG), local maxima (grey)."""
    import cv2

    W, H = model.window_wh
    sh, sw = small.shape[:2]
    if model.feature == "hog":
        loc, wt = hog.detect(small, hitThreshold=float(threshold), winStride=(8, 8),
                             padding=(0, 0))
        return (np.asarray(loc, dtype=np.float64).reshape(-1, 2),
                np.asarray(wt, dtype=np.float64).reshape(-1))
    resp = cv2.filter2D(small.astype(np.float32), cv2.CV_32F, kernel, anchor=(0, 0),
                        borderType=cv2.BORDER_CONSTANT)
    resp = resp[: sh - H + 1, : sw - W + 1] + np.float32(model.bias)
    # keep 3x3 local maxima only: dense windows one pixel apart add nothing after NMS
    peak = resp >= cv2.dilate(resp, np.ones((3, 3), np.uint8))
    yy, xx = np.nonzero(peak & (resp >= threshold))
    return np.stack([xx, yy], axis=1).astype(np.float64), resp[yy, xx].astype(np.float64)


def _roi_crops(model: SVMModel, rois: np.ndarray, f: float, y0: int, fx: float, fy: float,
               small_wh: tuple[int, int], margin: float, ratio: float) -> list[tuple[int, ...]]:
    """Crops ``(x0, y0, x1, y1)`` of a band's resized strip (corners on its stride-8 grid, so
    that their windows are the whole strip's; one stride of apron on every side) holding every
    window whose person box lies
    within ``margin`` box heights of one of ``rois`` (person boxes xywh, original pixels) of a
    height within a factor ``ratio`` of the band's; overlapping crops merged."""
    W, H = model.window_wh
    bl, bt, bw, bh = model.box_in_window
    sw, sh = small_wh
    hb = bh * f
    r = rois[(rois[:, 3] <= hb * ratio) & (rois[:, 3] >= hb / ratio)]
    if not len(r):
        return []
    m = margin * r[:, 3]
    # window corners (small pixels) of person boxes at the ROI moved by up to the margin
    x0 = (r[:, 0] - m) / fx - bl
    x1 = (r[:, 0] + r[:, 2] + m) / fx - bl - bw + W
    ya = (r[:, 1] - m - y0) / fy - bt
    yb = (r[:, 1] + r[:, 3] + m - y0) / fy - bt - bh + H
    # an apron of one stride on every side (gradients at a crop's outer pixels differ from
    # the whole strip's; windows reaching into the apron are dropped by the caller)
    c = np.stack([np.maximum(np.floor(x0 / 8) * 8 - 8, 0), np.maximum(np.floor(ya / 8) * 8 - 8, 0),
                  np.minimum(np.ceil(x1) + 8, sw), np.minimum(np.ceil(yb) + 8, sh)], axis=1)
    c = c[(c[:, 2] - c[:, 0] >= W) & (c[:, 3] - c[:, 1] >= H)].astype(int)
    # merge overlapping crops into their bounding box (windows then counted once)
    crops = [tuple(v) for v in c[np.argsort(c[:, 0])]]
    merged = True
    while merged and len(crops) > 1:
        merged = False
        out: list[tuple[int, ...]] = []
        for a in crops:
            for i, b in enumerate(out):
                if a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]:
                    out[i] = (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]),
                              max(a[3], b[3]))
                    merged = True
                    break
            else:
                out.append(a)
        crops = out
    return crops


def _dense_windows(model: SVMModel, grey: np.ndarray, bands: Sequence[ScaleBand],
                   threshold: float, hog: Any = None, rois: np.ndarray | None = None,
                   roi_margin: float = 0.3, roi_ratio: float = 1.5
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Every window scoring at least ``threshold`` over the scale bands.

    With ``rois`` (person boxes xywh, original pixels), only the windows near them are scored
    (:func:`_roi_crops`): at the whole search's window positions, clear of the crops' outer
    pixels, so that each scores exactly as in the whole search.

    Returns (person boxes (K, 4) xywh px, scores (K,))."""
    import cv2

    W, H = model.window_wh
    bl, bt, bw, bh = model.box_in_window
    ih, iw = grey.shape[:2]
    boxes, scores = [], []
    kernel = None
    if model.feature == "grey":
        kernel = (model.weights.reshape(H, W) / 255.0).astype(np.float32)
    if rois is not None:
        rois = np.asarray(rois, dtype=np.float64).reshape(-1, 4)
    for band in bands:
        f = band.f
        rows = _band_strip(band, ih, H)
        if rows is None:
            continue
        y0, y1 = rows
        sw, sh = round(iw / f), round((y1 - y0) / f)
        if sw < W or sh < H:
            continue
        fx, fy = iw / sw, (y1 - y0) / sh  # exact scale of this resize
        interp = cv2.INTER_AREA if f > 1 else cv2.INTER_LINEAR
        if rois is None:
            small = cv2.resize(grey[y0:y1], (sw, sh), interpolation=interp)
            loc, wt = _small_windows(model, small, threshold, hog, kernel)
        else:
            crops = _roi_crops(model, rois, f, y0, fx, fy, (sw, sh), roi_margin, roi_ratio)
            if not crops:
                continue
            small = cv2.resize(grey[y0:y1], (sw, sh), interpolation=interp)
            locs, wts = [], []
            for cx0, cy0, cx1, cy1 in crops:
                lc, wc = _small_windows(model, small[cy0:cy1, cx0:cx1], threshold, hog, kernel)
                # only windows clear of the crop's outer pixels (unless that is the strip's
                # border too): they score exactly as in the whole search
                ok = (((lc[:, 0] > 0) | (cx0 == 0)) & ((lc[:, 1] > 0) | (cy0 == 0))
                      & ((lc[:, 0] + W < cx1 - cx0) | (cx1 == sw))
                      & ((lc[:, 1] + H < cy1 - cy0) | (cy1 == sh)))
                locs.append(lc[ok] + (cx0, cy0))
                wts.append(wc[ok])
            loc, wt = np.concatenate(locs), np.concatenate(wts)
        if len(wt) == 0:
            continue
        b = np.empty((len(wt), 4))
        b[:, 0] = (loc[:, 0] + bl) * fx
        b[:, 1] = y0 + (loc[:, 1] + bt) * fy
        b[:, 2] = bw * fx
        b[:, 3] = bh * fy
        boxes.append(b)
        scores.append(wt)
    if not boxes:
        return np.zeros((0, 4)), np.zeros(0)
    return np.concatenate(boxes), np.concatenate(scores)
