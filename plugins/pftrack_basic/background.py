"""Background-subtraction detector: OpenCV's MOG2 foreground mask, cleaned, split into connected
blobs, each blob's bounding box a detection.

A cheap, learning-free detector for a fixed camera (PETS09, the coastal paper's coast). It keeps the
background model of the stream it is watching, so one instance serves one video; call
:meth:`BackgroundSubtractionDetector.reset` (or
:meth:`~pftrack.contracts.components.Component.clone`) before another.

Person boxes (``person_height_m`` set, with the run's camera): a blob's box is not a person's
(people come out in fragments, and two people walking side by side are one blob). Through the
camera, the image height of an upright person of ``person_height_m`` standing at any foot pixel
is known (:func:`pftrack.geometry.people.predicted_box_heights`); the blobs are then

1. merged when stacked: a blob whose column span overlaps a lower blob's, and whose top lies
   within one person's height (at the lower blob's foot, times ``merge_slack``) above that
   foot, is a fragment of the same person (head, torso, legs cut apart by the clean-up);
2. split when wide: a group wider than ``split_ratio`` person widths (``person_aspect`` times
   the height) is cut into ``round(width / person width)`` equal column slices;
3. made person-shaped: each group or slice becomes a box of the person's height and width at
   its foot point (the lowest foreground row of the slice, at the centre column of its
   foreground), scored with the fraction of that box covered by foreground.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pftrack.contracts.components import Detections, Detector, Frame, Param, RunContext

__all__ = ["BackgroundSubtractionDetector"]


class BackgroundSubtractionDetector(Detector):
    """MOG2 background subtraction -> foreground blobs -> boxes.

    Per frame: the MOG2 model (``cv2.createBackgroundSubtractorMOG2``) is updated and gives a
    foreground mask; shadows (mask value 127) are dropped; a morphological opening then closing
    with a ``morph_px`` square removes speckle and fills holes; each 8-connected blob of at least
    ``min_area_px`` pixels becomes a box ``(left, top, width, height)`` in pixels with score = the
    fraction of its box covered by foreground pixels (in (0, 1]).

    The first frames of a stream only teach the background (the model has seen nothing yet, so
    everything moving or not may be foreground); ``warmup_frames`` frames return no detections.

    {params}

    Attributes
    ----------
    subtractor_ : cv2.BackgroundSubtractorMOG2
        The background model of the current stream (created at the first frame).
    frames_seen_ : int
        Frames given to :meth:`detect` since the last reset.
    """

    history: int = Param(500, "Frames of history of the MOG2 model.", unit="frames", low=1)
    var_threshold: float = Param(
        16.0, "MOG2's squared Mahalanobis distance threshold for foreground.",
        unit="1", low=0.0, low_open=True)
    detect_shadows: bool = Param(
        True, "Let MOG2 mark shadows (they are then discarded rather than detected).")
    learning_rate: float = Param(
        -1.0, "MOG2 learning rate; negative: automatic (1 / history).", unit="1/frame", high=1.0)
    min_area_px: int = Param(100, "Smallest blob kept, pixels.", unit="px²", low=0)
    morph_px: int = Param(
        3, "Side of the square structuring element of the clean-up, pixels (0 or 1: no clean-up).",
        unit="px", low=0)
    warmup_frames: int = Param(
        1, "Frames at the start of a stream that only update the background.",
        unit="frames", low=0)
    person_height_m: float | None = Param(
        None,
        "With the run's camera: turn the blobs into boxes of upright people this tall (module "
        "docstring); None (default): each blob's bounding box.", unit="m", low=0.0, low_open=True)
    person_aspect: float = Param(
        0.4, "Width / height of a person box (person boxes only).",
        unit="1", low=0.0, low_open=True)
    merge_slack: float = Param(
        1.2,
        "Stacked blobs merge when their span is within this many person heights (person boxes "
        "only).", unit="1", low=0.0, low_open=True)
    split_ratio: float = Param(
        1.5, "A group wider than this many person widths is split (person boxes only).",
        unit="1", low=0.0, low_open=True)

    def setup(self, context: RunContext) -> None:
        """Person boxes need the run's camera: keep it, or stop naming the parameter."""
        if self.person_height_m is None:
            return
        if context.camera is None:
            raise ValueError(f"detector mog2: person_height_m={self.person_height_m} makes "
                             "person-shaped boxes through the run's camera, and the run has none "
                             "(give --camera, or set person_height_m: null for blob boxes)")
        self.camera_ = context.camera

    def reset(self) -> BackgroundSubtractionDetector:
        """Forget the background model (start of a new stream)."""
        for k in ("subtractor_", "frames_seen_", "image_shape_"):
            self.__dict__.pop(k, None)
        return self

    def __getstate__(self) -> dict[str, Any]:
        # OpenCV's model cannot be pickled: a pickled detector starts a new stream.
        state = dict(self.__dict__)
        for k in ("subtractor_", "frames_seen_", "image_shape_"):
            state.pop(k, None)
        return state

    def foreground_mask(self, frame: Frame) -> np.ndarray:
        """Update the model with ``frame`` and return its cleaned foreground mask (H, W) uint8
        (255 foreground, 0 background)."""
        import cv2

        img = np.asarray(frame.image)
        if img.ndim not in (2, 3) or img.size == 0:
            raise ValueError(f"BackgroundSubtractionDetector: frame {frame.index} image has "
                             f"shape {img.shape}; expected (H, W) or (H, W, 3)")
        if img.dtype != np.uint8:
            raise ValueError(f"BackgroundSubtractionDetector: frame {frame.index} image must be "
                             f"uint8, got {img.dtype}")
        if getattr(self, "image_shape_", img.shape) != img.shape:
            raise ValueError(f"BackgroundSubtractionDetector: frame {frame.index} has shape "
                             f"{img.shape} but the stream started with {self.image_shape_}; "
                             "call reset() before a new stream")
        if getattr(self, "subtractor_", None) is None:
            self.subtractor_ = cv2.createBackgroundSubtractorMOG2(
                history=int(self.history), varThreshold=float(self.var_threshold),
                detectShadows=bool(self.detect_shadows))
            self.frames_seen_ = 0
            self.image_shape_ = img.shape
        raw = self.subtractor_.apply(np.ascontiguousarray(img),
                                     learningRate=float(self.learning_rate))
        self.frames_seen_ += 1
        mask = np.where(raw == 255, np.uint8(255), np.uint8(0))
        k = int(self.morph_px)
        if k > 1:
            kernel = np.ones((k, k), np.uint8)
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
            mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel)
        return mask

    def detect(self, frame: Frame) -> Detections:
        import cv2

        mask = self.foreground_mask(frame)
        if self.frames_seen_ <= int(self.warmup_frames):
            return Detections.empty()
        _, _, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        stats = stats[1:]  # label 0 is the background
        area = stats[:, cv2.CC_STAT_AREA].astype(np.float64)
        keep = area >= float(self.min_area_px)
        stats, area = stats[keep], area[keep]
        boxes = stats[:, [cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH,
                          cv2.CC_STAT_HEIGHT]].astype(np.float64)
        if self.person_height_m is not None:
            camera = getattr(self, "camera_", None)
            if camera is None:
                raise ValueError("detector mog2: person_height_m is set but no camera was given "
                                 "to setup() (the run's camera makes the person boxes)")
            return person_boxes(mask, boxes, camera, float(self.person_height_m),
                                float(self.person_aspect), float(self.merge_slack),
                                float(self.split_ratio))
        scores = area / np.maximum(boxes[:, 2] * boxes[:, 3], 1.0)
        return Detections(boxes, scores)


def _person_heights(camera: Any, feet: np.ndarray, person_height_m: float) -> np.ndarray:
    from pftrack.geometry.people import predicted_box_heights

    if len(feet) == 0:
        return np.zeros(0)
    return predicted_box_heights(camera, feet, person_height_m)


def merge_stacked(boxes_xywh_px: np.ndarray, heights_px: np.ndarray, slack: float
                  ) -> np.ndarray:
    """Group label (B,) of each blob box: blobs stacked within one person's height merge.

    Blobs are visited from the lowest foot up; a blob joins the group of a lower blob whose
    column span overlaps its own when the group's foot minus the blob's top is at most
    ``slack`` times the person height at that foot (``heights_px``, per blob, NaN: none).
    """
    b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    n = len(b)
    label = np.arange(n)
    if n < 2:
        return label
    order = np.argsort(-(b[:, 1] + b[:, 3]), kind="stable")  # lowest foot first
    x0, x1, top = b[:, 0], b[:, 0] + b[:, 2], b[:, 1]
    # columns overlap (B, B); a group is described by its anchor (its lowest blob)
    overlap = (x0[:, None] < x1[None, :]) & (x0[None, :] < x1[:, None])
    foot = b[:, 1] + b[:, 3]
    reach = foot - slack * np.where(np.isfinite(heights_px), heights_px, 0.0)  # highest top
    anchor_of = np.full(n, -1)
    g_x0, g_x1 = x0.copy(), x1.copy()
    for i in order:
        if anchor_of[i] >= 0:
            continue
        anchor_of[i] = i
        for j in order:
            if anchor_of[j] >= 0 or foot[j] > foot[i] or top[j] < reach[i]:
                continue
            if overlap[i, j] or (x0[j] < g_x1[i] and g_x0[i] < x1[j]):
                anchor_of[j] = i
                g_x0[i], g_x1[i] = min(g_x0[i], x0[j]), max(g_x1[i], x1[j])
    label[:] = anchor_of
    return label


def person_boxes(mask: np.ndarray, blob_boxes_xywh_px: np.ndarray, camera: Any,
                 person_height_m: float, aspect: float, merge_slack: float = 1.2,
                 split_ratio: float = 1.5) -> Detections:
    """Person-shaped boxes from foreground blobs through a camera (the module docstring's
    steps 1-3).

    Parameters
    ----------
    mask : ndarray (H, W) uint8
        The foreground mask (non-zero: foreground).
    blob_boxes_xywh_px : ndarray (B, 4)
        The blobs' bounding boxes. Unit: px.
    camera : Camera
        Ground-plane camera (world metres, z up).
    person_height_m : float
        Height of an upright person. Unit: m.
    aspect : float
        Width / height of a person box. Unit: 1.
    merge_slack, split_ratio : float
        See :class:`BackgroundSubtractionDetector`. Unit: 1.

    Returns
    -------
    Detections
        One box per person found, score = the foreground fraction of its box.
    """
    b = np.asarray(blob_boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    if len(b) == 0:
        return Detections.empty()
    fg = np.asarray(mask) > 0
    img_h, img_w = fg.shape
    feet = np.column_stack([b[:, 0] + 0.5 * b[:, 2], b[:, 1] + b[:, 3]])
    label = merge_stacked(b, _person_heights(camera, feet, person_height_m), merge_slack)
    groups = np.unique(label)
    gx0 = np.array([b[label == g, 0].min() for g in groups])
    gy0 = np.array([b[label == g, 1].min() for g in groups])
    gx1 = np.array([(b[label == g, 0] + b[label == g, 2]).max() for g in groups])
    gy1 = np.array([(b[label == g, 1] + b[label == g, 3]).max() for g in groups])
    gh = _person_heights(camera, np.column_stack([0.5 * (gx0 + gx1), gy1]), person_height_m)
    slices = []  # (x0, x1, y0, y1) integer column slices of the groups
    for x0, x1, y0, y1, h in zip(gx0, gx1, gy0, gy1, gh):
        pw = aspect * h if np.isfinite(h) and h > 0 else x1 - x0
        k = int(round((x1 - x0) / pw)) if (x1 - x0) > split_ratio * pw else 1
        edges = np.linspace(x0, x1, max(k, 1) + 1).round().astype(int)
        for a, c in zip(edges[:-1], edges[1:]):
            if c > a:
                slices.append((a, c, int(y0), int(y1)))
    boxes = []
    for x0, x1, y0, y1 in slices:
        sub = fg[y0:y1, x0:x1]
        rows = np.flatnonzero(sub.any(axis=1))
        cols = sub.sum(axis=0)
        if len(rows) == 0 or cols.sum() == 0:
            continue
        foot_y = y0 + rows[-1] + 1.0
        cx = x0 + float((np.arange(x1 - x0) + 0.5) @ cols) / float(cols.sum())
        boxes.append((cx, foot_y))
    if not boxes:
        return Detections.empty()
    feet = np.array(boxes)
    h = _person_heights(camera, feet, person_height_m)
    ok = np.isfinite(h) & (h > 1.0)
    feet, h = feet[ok], h[ok]
    w = aspect * h
    out = np.column_stack([feet[:, 0] - 0.5 * w, feet[:, 1] - h, w, h])
    # score: the foreground fraction of each box, through one integral image
    ii = np.zeros((img_h + 1, img_w + 1), dtype=np.int64)
    ii[1:, 1:] = fg.cumsum(axis=0, dtype=np.int64).cumsum(axis=1)
    xa = np.clip(np.floor(out[:, 0]), 0, img_w).astype(int)
    xb = np.clip(np.ceil(out[:, 0] + out[:, 2]), 0, img_w).astype(int)
    ya = np.clip(np.floor(out[:, 1]), 0, img_h).astype(int)
    yb = np.clip(np.ceil(out[:, 1] + out[:, 3]), 0, img_h).astype(int)
    area = np.maximum((xb - xa) * (yb - ya), 1)
    count = ii[yb, xb] - ii[ya, xb] - ii[yb, xa] + ii[ya, xa]
    keep = count > 0
    return Detections(out[keep], (count / area)[keep].astype(np.float64))
