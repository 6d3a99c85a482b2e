"""Sliding-window linear-SVM person detector (the soccer paper's sec. 2), multi-scale, scored by
c(det).

Pipeline per frame (grey image)::

    scale plan (from the camera: expected person height at each image row, or a plain pyramid)
    -> per scale: crop the band of rows where people of that size can stand, resize by 1/f
    -> dense linear SVM over every window (HOG: cv2.HOGDescriptor.detect with our own weights;
       grey levels: one cv2.filter2D correlation with the weight template)
    -> boxes in image pixels, score c(det) = (w . x + b) / ||w|| (signed distance to the
       decision boundary in feature space) -> non-maximum suppression.

Window geometry: the detector window is ``window_wh`` pixels (default 32 x 64); a person's box
occupies ``box_in_window`` = (left, top, width, height) of it (learned from the training boxes:
the height is ``occupancy`` of the window height, the width the median aspect ratio). A window
found at scale ``f`` (original pixels per window pixel) at (x, y) reports the person box
``(x + f * left, y + f * top, f * width, f * height)``.

Models are stored as ``.npz`` (``allow_pickle=False``) holding the weight vector, the bias and a
JSON string of parameters; :func:`load_model` validates them and names the file on error.

Training (:func:`train_svm_model`): positives are the ground-truth boxes (visibility flag 1)
mapped into the window and their horizontal mirror images; negatives are random windows whose
person box has IoU < ``neg_iou`` with every ground-truth box (any flag), drawn with a seeded
``numpy.random.Generator``; one optional round of hard-negative mining adds the detector's own
false positives on the training frames, searched where the detector looks at run time: the
camera's band of rows per scale when the detector has a camera, else the band the training boxes
themselves show (:func:`heights_from_boxes`), so a model trained without a camera mines the same
kind of windows as one trained with it (a plain pyramid would spend the hard negatives on scales
no person can have at that row).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pftrack.contracts.components import (
    Detections,
    Detector,
    Frame,
    Group,
    Param,
    ParamGroup,
    RunContext,
)
from pftrack.geometry.boxes import foot_points, iou_matrix, nms

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera, CameraSpec

__all__ = [
    "SVMDetector",
    "SVMModel",
    "ScaleBand",
    "SvmTraining",
    "TrainingRecallWarning",
    "heights_from_boxes",
    "load_model",
    "save_model",
    "scale_plan",
    "train_svm_model",
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


# --------------------------------------------------------------------------------------------
# The detector component
# --------------------------------------------------------------------------------------------


class SvmTraining(ParamGroup):
    """How :meth:`SVMDetector.fit` trains a model (:func:`train_svm_model`): the window, the
    feature, the regularisation and the negatives.

    {params}
    """

    feature: str = Param("hog", "Window feature: OpenCV HOG, or the grey levels (the soccer "
                         "paper's feature).", choices=FEATURES)
    window_wh: Sequence[int] = Param(
        (32, 64), "Window size (width, height).", unit="px", low=1, length=2)
    C: float = Param(0.01, "LinearSVC regularisation.", unit="1", low=0.0, low_open=True)
    n_negatives: int = Param(8000, "Random negative windows drawn.", unit="count", low=0)
    hard_negative_rounds: int = Param(
        1, "Rounds of hard-negative mining (the detector's own false positives on the training "
        "frames added as negatives; 0 or 1 in practice).", unit="count", low=0)


class SVMDetector(Detector):
    """Linear SVM sliding-window person detector (the soccer paper's sec. 2), multi-scale, with NMS.

    {params}

    Attributes
    ----------
    model_ : SVMModel
        The trained (or loaded) classifier.
    camera_ : Camera or None
    """

    model: str | os.PathLike[str] | None = Param(
        None,
        "Path of a ``.npz`` model written by ``pftrack detector train`` (:func:`save_model`). "
        "Not needed when the detector is fitted in the same process (:meth:`fit`).")
    camera: CameraSpec | None = Param(
        None,
        "A calibrated camera (path or object). With it, each scale only scans the image rows "
        "where a person of that size can stand, and detections carry their ground point "
        "(``points_world_m``, the foot point back-projected to z = 0).")
    height_m: float = Param(
        1.75, "Person height used with the camera, metres.", unit="m", low=0.0, low_open=True)
    threshold: float = Param(
        0.0, "Minimum score c(det) (signed distance to the SVM boundary) of a reported window.",
        unit="1")
    nms_iou: float = Param(
        0.3, "Windows overlapping a better one by more than this IoU are suppressed.",
        unit="1", low=0.0, high=1.0)
    merge_tau: float | None = Param(
        0.1,
        "Each kept window is refined to the score-weighted mean of the windows overlapping it "
        "(IoU >= 0.5), weights ``exp((c - c_best) / merge_tau)`` (:func:`merge_clusters`), "
        "which places detections between the 8 px grid positions; None keeps the grid window. "
        "Needs windows below ``threshold`` too, so the windows are scored down to ``threshold "
        "- 3 merge_tau``.", unit="1", low=0.0, low_open=True)
    scale_step: float = Param(
        1.15, "Ratio between consecutive search scales.", unit="1", low=1.0, low_open=True)
    min_height_px: float = Param(
        40.0,
        "Smallest person height searched; with a camera it clips its expected range.",
        unit="px", low=0.0, low_open=True)
    max_height_px: float = Param(
        400.0,
        "Largest person height searched; with a camera it clips its expected range.",
        unit="px", low=0.0, low_open=True)
    train: SvmTraining = Group(
        SvmTraining,
        "How :meth:`fit` (``pftrack detector train``) trains a model; a loaded model carries "
        "its own window and feature. A configuration gives these keys under "
        "``detector.train.params``.")

    # -- set-up -------------------------------------------------------------------------------

    def setup(self, context: RunContext) -> None:
        """The run's camera when ``camera`` is not set; the run's detector model
        (``--detector-model``) when it names one."""
        if self.camera is None and context.camera is not None:
            self.camera_ = context.camera
        if context.detector_model is not None:
            self.load(context.detector_model)

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the fitted model (``.npz``, no pickle) atomically: :func:`save_model`."""
        if not hasattr(self, "model_"):
            raise ValueError("SVMDetector.save: no model yet; call fit() first")
        return save_model(self.model_, path)

    def load(self, path: str | os.PathLike[str]) -> SVMDetector:
        """Use the model in ``path`` (:func:`load_model`)."""
        self.set_model(load_model(path))
        return self

    def describe(self) -> dict[str, Any]:
        """The model's parameters and training record (``pftrack detector info``)."""
        m = self._model()
        return {**m.params(), "n_features": m.n_features}

    def _camera(self) -> Camera | None:
        if not hasattr(self, "camera_"):
            cam = self.camera
            if isinstance(cam, (str, os.PathLike)):
                from pftrack.geometry.formats import load_camera

                cam = load_camera(cam)
            self.camera_ = cam
        return self.camera_

    def _model(self) -> SVMModel:
        if not hasattr(self, "model_"):
            if self.model is None:
                raise ValueError("SVMDetector: no model; pass model=PATH (from `pftrack detector "
                                 "train`) or call fit() first")
            self.model_ = load_model(self.model)
        return self.model_

    def set_model(self, model: SVMModel) -> SVMDetector:
        """Use an in-memory model (what :meth:`fit` does)."""
        self.model_ = model
        for attr in ("hog_", "plan_", "plan_size_"):
            self.__dict__.pop(attr, None)
        return self

    def _plan_options(self) -> dict[str, Any]:
        """Further :func:`scale_plan` options of a subclass (none here)."""
        return {}

    def _new_hog(self, m: SVMModel) -> Any:
        """The OpenCV HOG descriptor with the model's weights (None: not a HOG model)."""
        if m.feature != "hog":
            return None
        hog = _hog(m.window_wh)
        hog.setSVMDetector(np.r_[m.weights, np.float32(m.bias)].astype(np.float32))
        return hog

    def _prepare(self, image_size_wh: tuple[int, int]) -> None:
        m = self._model()
        if getattr(self, "plan_size_", None) != image_size_wh:
            _, bt, _, bh = m.box_in_window
            self.plan_ = scale_plan(bh, m.window_wh[1], bt + bh, image_size_wh,
                                    scale_step=self.scale_step, min_height_px=self.min_height_px,
                                    max_height_px=self.max_height_px, camera=self._camera(),
                                    height_m=self.height_m,
                                    expected=getattr(self, "expected_heights_", None),
                                    **self._plan_options())
            self.plan_size_ = image_size_wh
        if not hasattr(self, "hog_"):
            hog = self._new_hog(m)
            if hog is not None:
                self.hog_ = hog

    def __getstate__(self) -> dict[str, Any]:
        # cv2.HOGDescriptor does not pickle; it is rebuilt from the model on first use
        d = dict(self.__dict__)
        d.pop("hog_", None)
        return d

    @classmethod
    def _conformance_example(cls):
        """For :mod:`pftrack.testing`: a small model trained once on the kit's synthetic scene
        (cached under the temporary folder), scales for its 20-45 px objects, no camera."""
        import tempfile

        from pftrack.testing import ConformanceExample, synthetic_scene

        path = Path(tempfile.gettempdir()) / f"pftrack-conformance-svm-v{MODEL_VERSION}.npz"
        if not path.is_file():
            sc = synthetic_scene(seed=1, n_frames=8)
            model = train_svm_model(sc.frames, sc.boxes_by_frame, np.random.default_rng(0),
                                    window_wh=(16, 32), n_negatives=400, C=0.01,
                                    hard_negative_rounds=0)
            save_model(model, path)
        det = cls(model=str(path), threshold=-0.5, min_height_px=20.0, max_height_px=60.0)
        sc = synthetic_scene(seed=0, n_frames=4)
        return ConformanceExample(det, frames=sc.frames, fit_boxes={})

    # -- detection ----------------------------------------------------------------------------

    def score_windows(self, grey: np.ndarray, threshold: float | None = None,
                      rois: np.ndarray | None = None, roi_margin: float = 0.3,
                      ) -> tuple[np.ndarray, np.ndarray]:
        """Every window above ``threshold`` (default: the detector's) before NMS.

        Parameters
        ----------
        grey : ndarray, shape (H, W), uint8
        rois : ndarray (K, 4), optional
            Person boxes (xywh px): only windows whose person box lies within ``roi_margin``
            box heights of one of them, at scales within a factor 1.5 of its height, are
            scored (at the whole search's window positions). Default: the whole search.
        roi_margin : float
            See ``rois``. Unit: box heights.

        Returns
        -------
        boxes_xywh_px : ndarray, shape (K, 4)
        scores : ndarray, shape (K,)
        """
        self._prepare((grey.shape[1], grey.shape[0]))
        thr = self.threshold if threshold is None else threshold
        return _dense_windows(self._model(), grey, self.plan_, thr, getattr(self, "hog_", None),
                              rois=rois, roi_margin=roi_margin)

    def detect(self, frame: Frame) -> Detections:
        """Detections in ``frame``: person boxes (xywh px), scores c(det), ground points (m)."""
        import cv2

        img = frame.image
        grey = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        tau = self.merge_tau
        low = self.threshold - (3.0 * float(tau) if tau is not None else 0.0)
        boxes, scores = self.score_windows(grey, threshold=low)
        keep = nms(boxes, scores, self.nms_iou)
        keep = keep[scores[keep] >= self.threshold]
        if self.merge_tau is not None and len(keep):
            boxes = merge_clusters(boxes, scores, keep, tau=float(self.merge_tau))
        else:
            boxes = boxes[keep]
        scores = scores[keep]
        return detections_on_ground(boxes, scores, self._camera())

    # -- training -----------------------------------------------------------------------------

    def fit(self, frames: Iterable[Frame] | Iterator[Frame], boxes_by_frame: dict[int, np.ndarray],
            rng: np.random.Generator | None = None,
            ignore_by_frame: dict[int, np.ndarray] | None = None) -> SVMDetector:
        """Train on ``frames`` with their ground-truth person boxes.

        Parameters
        ----------
        frames : iterable of Frame
            Streamed once; every 4th frame with boxes is kept (grey) for hard-negative mining.
        boxes_by_frame : dict {frame index: (K, 4) xywh px}
            Fully visible people (positives). With no box at all, a detector that already has
            a model (``model`` path or a previous fit) keeps it; otherwise ValueError.
        rng : numpy.random.Generator
            Draws the negative windows. Required.
        ignore_by_frame : dict {frame index: (K, 4)}, optional
            Partly hidden people: neither positives nor negatives.
        """
        if not any(len(np.asarray(b).reshape(-1, 4)) for b in boxes_by_frame.values()):
            if self.model is not None or hasattr(self, "model_"):
                return self  # nothing to learn from: the loaded model stays
            raise ValueError("SVMDetector.fit: no ground-truth boxes to learn from")
        if rng is None:
            raise ValueError("SVMDetector.fit needs rng=np.random.default_rng(seed)")
        t = self.train
        model = train_svm_model(frames, boxes_by_frame, rng, ignore_by_frame=ignore_by_frame,
                                feature=t.feature, window_wh=tuple(t.window_wh), C=t.C,
                                n_negatives=t.n_negatives,
                                hard_negative_rounds=t.hard_negative_rounds, detector=self)
        self.set_model(model)
        return self


def _grey(image: np.ndarray) -> np.ndarray:
    import cv2

    return image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)


def _random_negatives(grey: np.ndarray, avoid: np.ndarray, n: int, heights: np.ndarray,
                      aspect: float, neg_iou: float, rng: np.random.Generator) -> np.ndarray:
    """Up to ``n`` random person-shaped boxes with IoU < neg_iou against ``avoid``."""
    ih, iw = grey.shape[:2]
    m = 4 * n + 8
    h = rng.choice(heights, size=m) * rng.uniform(0.7, 1.4, size=m)
    w = h * aspect
    x = rng.uniform(-0.1, 1.0, size=m) * (iw - w * 0.9)
    y = rng.uniform(-0.1, 1.0, size=m) * (ih - h * 0.9)
    cand = np.stack([x, y, w, h], axis=1)
    if len(avoid):
        cand = cand[iou_matrix(cand, avoid).max(axis=1) < neg_iou]
    return cand[:n]


def train_svm_model(frames: Iterable[Frame], boxes_by_frame: dict[int, np.ndarray],
                    rng: np.random.Generator, *,
                    ignore_by_frame: dict[int, np.ndarray] | None = None,
                    feature: str = "hog", window_wh: tuple[int, int] = (32, 64),
                    occupancy: float = 0.8, C: float = 0.01, n_negatives: int = 8000,
                    hard_negative_rounds: int = 1, neg_iou: float = 0.3, max_hard: int = 20000,
                    detector: SVMDetector | None = None, progress: bool = False) -> SVMModel:
    """Train a linear SVM window classifier from frames and ground-truth boxes.

    See the module docstring for the sampling; the returned weights are scaled to unit norm so
    the detector's scores are distances to the decision boundary. ``detector`` (its scale and
    NMS settings) is used for hard-negative mining; a default :class:`SVMDetector` otherwise.
    """
    from sklearn.svm import LinearSVC

    if feature not in FEATURES:
        raise ValueError(f"unknown detector feature {feature!r}; known: {', '.join(FEATURES)}")
    if not 0 < occupancy <= 1:
        raise ValueError(f"occupancy must be in (0, 1], got {occupancy}")
    ignore_by_frame = ignore_by_frame or {}
    W, H = int(window_wh[0]), int(window_wh[1])
    all_boxes = [np.asarray(b, float).reshape(-1, 4) for b in boxes_by_frame.values()]
    all_boxes = [b for b in all_boxes if len(b)]
    if not all_boxes:
        raise ValueError("train_svm_model: no ground-truth boxes to learn from")
    stacked = np.concatenate(all_boxes)
    aspect = float(np.median(stacked[:, 2] / stacked[:, 3]))
    bh = occupancy * H
    bw = aspect * bh
    box_in_window = ((W - bw) / 2.0, (H - bh) / 2.0, bw, bh)
    heights = stacked[:, 3]
    n_frames_with_boxes = sum(1 for b in all_boxes)
    per_frame_neg = max(1, int(np.ceil(n_negatives / max(n_frames_with_boxes, 1))))

    pos_crops, neg_crops, kept = [], [], []
    n_seen = 0
    it = frames
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(frames, desc="detector: sampling", unit="frame")
    for frame in it:
        boxes = np.asarray(boxes_by_frame.get(frame.index, np.zeros((0, 4))), float).reshape(-1, 4)
        if len(boxes) == 0:
            continue
        grey = _grey(frame.image)
        ign = np.asarray(ignore_by_frame.get(frame.index, np.zeros((0, 4))), float).reshape(-1, 4)
        pos_crops.append(crop_windows(grey, _window_rect(boxes, box_in_window, (W, H)), (W, H)))
        negs = _random_negatives(grey, np.concatenate([boxes, ign]), per_frame_neg, heights,
                                 aspect, neg_iou, rng)
        neg_crops.append(crop_windows(grey, _window_rect(negs, box_in_window, (W, H)), (W, H)))
        if n_seen % 4 == 0:
            kept.append((grey, np.concatenate([boxes, ign])))
        n_seen += 1
    if not pos_crops:
        raise ValueError("train_svm_model: none of the frames has ground-truth boxes")
    pos = np.concatenate(pos_crops)
    pos = np.concatenate([pos, pos[:, :, ::-1]])  # mirror images
    neg = np.concatenate(neg_crops)
    Xp, Xn = window_features(pos, feature), window_features(neg, feature)

    def train(xp: np.ndarray, xn: np.ndarray) -> tuple[np.ndarray, float, float]:
        X = np.concatenate([xp, xn])
        y = np.r_[np.ones(len(xp)), -np.ones(len(xn))]
        clf = LinearSVC(C=C, loss="hinge", dual=True, max_iter=20000, random_state=0)
        clf.fit(X, y)
        w = clf.coef_.ravel().astype(np.float64)
        b = float(clf.intercept_[0])
        norm = float(np.linalg.norm(w))
        if not (np.isfinite(norm) and norm > 0):
            raise ValueError("train_svm_model: the training windows carry no signal (blank "
                             "frames? positives and negatives have the same features): nothing "
                             "to learn")
        acc = float(np.mean(np.sign(X @ w + b) == y))
        return (w / norm).astype(np.float32), b / norm, acc

    w, b, acc = train(Xp, Xn)
    info: dict[str, Any] = {"n_positive": len(Xp), "n_random_negative": len(Xn),
                            "n_frames": int(n_seen), "C": C, "aspect": aspect,
                            "occupancy": occupancy, "train_accuracy": acc}
    model = SVMModel(w, b, feature, (W, H), box_in_window, info)
    hard_total = 0
    # hard negatives are mined where the detector will look at run time: the camera's scale
    # band at each row when the detector has one, else the band the training boxes themselves
    # give (heights_from_boxes), so training without --camera mines the same kind of windows
    # instead of every scale at every row
    expected = None
    rounds = int(hard_negative_rounds)
    if rounds > 0 and kept and (detector is None or detector._camera() is None):
        ih, iw = kept[0][0].shape[:2]
        expected = heights_from_boxes(stacked, (iw, ih))
        if not np.any(np.isfinite(expected[1])):
            expected = None  # degenerate boxes: fall back to the plain pyramid
    if rounds > 0:
        info["mining_scales"] = ("camera" if detector is not None and detector._camera()
                                 is not None else "training boxes" if expected is not None
                                 else "pyramid")
    for _ in range(rounds):
        det = (detector.clone() if detector is not None else SVMDetector())
        det.set_model(model)
        if expected is not None:
            det.expected_heights_ = expected
        hard = []
        for grey, avoid in kept:
            boxes, scores = det.score_windows(grey, threshold=-0.1)
            if len(boxes) == 0:
                continue
            keep = nms(boxes, scores, 0.5)
            boxes = boxes[keep]
            if len(avoid):
                boxes = boxes[iou_matrix(boxes, avoid).max(axis=1) < neg_iou]
            if len(boxes):
                hard.append(crop_windows(grey, _window_rect(boxes, box_in_window, (W, H)),
                                         (W, H)))
        if not hard:
            break
        hard_crops = np.concatenate(hard)
        if len(hard_crops) > max_hard:
            hard_crops = hard_crops[rng.choice(len(hard_crops), max_hard, replace=False)]
        hard_total += len(hard_crops)
        Xn = np.concatenate([Xn, window_features(hard_crops, feature)])
        w, b, acc = train(Xp, Xn)
        model = SVMModel(w, b, feature, (W, H), box_in_window, info)
    info["n_hard_negative"] = int(hard_total)
    info["train_accuracy"] = acc
    # accuracy is dominated by the many negatives: a model that rejects everything scores
    # 99 %; what matters is whether it finds its own positives at the detection threshold
    thr = float(detector.threshold) if detector is not None else 0.0
    recall = float(np.mean(Xp @ model.weights.astype(np.float64) + model.bias >= thr))
    info["train_recall_positives"] = recall
    if recall < MIN_TRAIN_RECALL:
        import warnings

        warnings.warn(
            f"svm detector: the trained model finds only {100 * recall:.1f} % of its own "
            f"{len(Xp)} training positives at threshold {thr:g} (training accuracy "
            f"{100 * acc:.2f} % is dominated by the {len(Xn)} negatives): it cannot separate "
            "people from background here. Train on more frames/boxes (--frames), raise C, "
            "or use the training-free hog-people detector", TrainingRecallWarning,
            stacklevel=2)
    return model
