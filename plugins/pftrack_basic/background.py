"""Background-subtraction detector: OpenCV's MOG2 foreground mask, cleaned, split into connected
blobs, each blob's bounding box a detection.

A cheap, learning-free detector for a fixed camera (PETS09, the seed 003 coast). It keeps the
background model of the stream it is watching, so one instance serves one video; call
:meth:`BackgroundSubtractionDetector.reset` (or :meth:`~pftrack.components.Component.clone`)
before another.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pftrack.components import Detections, Detector, Frame

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

    Parameters
    ----------
    history : int
        Frames of history of the MOG2 model. Unit: frames.
    var_threshold : float
        MOG2's squared Mahalanobis distance threshold for foreground. Unit: 1.
    detect_shadows : bool
        Let MOG2 mark shadows (they are then discarded rather than detected).
    learning_rate : float
        MOG2 learning rate; negative: automatic (1 / history). Unit: 1/frame.
    min_area_px : int
        Smallest blob kept, pixels. Unit: px².
    morph_px : int
        Side of the square structuring element of the clean-up, pixels (0 or 1: no clean-up).
        Unit: px.
    warmup_frames : int
        Frames at the start of a stream that only update the background. Unit: frames.

    Attributes
    ----------
    subtractor_ : cv2.BackgroundSubtractorMOG2
        The background model of the current stream (created at the first frame).
    frames_seen_ : int
        Frames given to :meth:`detect` since the last reset.
    """

    def __init__(self, history: int = 500, var_threshold: float = 16.0,
                 detect_shadows: bool = True, learning_rate: float = -1.0,
                 min_area_px: int = 100, morph_px: int = 3, warmup_frames: int = 1) -> None:
        self.history = history
        self.var_threshold = var_threshold
        self.detect_shadows = detect_shadows
        self.learning_rate = learning_rate
        self.min_area_px = min_area_px
        self.morph_px = morph_px
        self.warmup_frames = warmup_frames

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
        scores = area / np.maximum(boxes[:, 2] * boxes[:, 3], 1.0)
        return Detections(boxes, scores)
