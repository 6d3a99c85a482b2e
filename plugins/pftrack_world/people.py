"""``hog-people``: a person detector that needs no training (OpenCV's HOG people detector).

OpenCV ships a linear SVM on HOG features trained on the INRIA person set
(``cv2.HOGDescriptor_getDefaultPeopleDetector``, a 64 x 128 window). This module wraps it as a
pftrack detector with three additions:

* **Boxes tightened to the person.** An INRIA window holds the person with a margin. The
  margin was measured on PETS 2009 S2.L1's ground truth, frames 1-200 only (every 10th frame,
  111 fully visible people): the window was run over the frame scaled by 1.5, each ground-truth
  box was paired with the highest-scoring window whose centre lies within 0.15 of the box height
  of the box's centre, and the box was expressed in window units; the medians are
  :data:`HOG_PEOPLE_BOX` = left 0.25, top 0.12, width 0.51, height 0.74 of the window (the
  interquartile ranges: 0.19-0.32, 0.09-0.14, 0.47-0.56, 0.71-0.77). The height agrees with
  the INRIA protocol (a 96 px person in a 128 px window, 0.75); the width is wider than a
  PETS ground-truth box's median aspect (0.36) because the ground truth's boxes include the arms
  only when spread. Reproduce with ``python -m pftrack_world.people --measure-margin GT VIDEO``.
* **Scale search limited by the camera.** With a camera (the run's, or ``camera=``), a person
  of ``height_m`` standing at a foot row has a known image height, so each search scale only
  scans the band of rows where such a person can stand (:func:`pftrack_world.detector.
  scale_plan`). Without a camera the first ``learn_scales`` frames are searched over the whole
  pyramid; then the (foot row, height) relation is fitted to their confident detections
  (:func:`~pftrack_world.detector.heights_from_boxes`, a plane valid for a flat ground) and the
  search is limited by it as by a camera.
* **Calibrated scores.** The SVM margin ``m`` (raw ``w . x + b`` of OpenCV's model) is mapped to
  ``score = 1 / (1 + exp(-(m - score_offset) / score_scale))``, a logistic (Platt) map whose
  two constants (0.46, 0.32) were fitted once by logistic regression (frames 1-200 of PETS with
  the real camera's scale bands, the detections after suppression, label = IoU >= 0.5 with a
  ground-truth box) and are fixed for every video: a score is the probability
  that a detection is a person's box, so a threshold of 0.5 means "more likely right than wrong"
  whatever the video. The map is monotone: ranking and suppression are those of the margin.

Speed: one grey conversion, one resize and one ``HOGDescriptor.detect`` per scale band, the
windows' boxes and scores as arrays; non-maximum suppression in OpenCV. The search is limited
by ``min_height_px`` / ``max_height_px``, ``scale_step`` and ``tolerance``. On PETS (768 x 576,
people 50-150 px, so the smallest scales enlarge their band of rows about twice): 0.08 s of CPU
per frame on one core with a camera or with the learnt bands (measured on the shared
development machine under load), against 0.2-0.4 s for OpenCV's own pyramid over the frame
enlarged 1.5-2 times. With ``full_every`` 2 (the ``people-*`` presets) the frames between whole
searches score only crops near the people found before and where the frame changed, each window
exactly as the whole search would: on PETS 201-795, 34-37 s of detection against 52-54 s.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, ClassVar

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
from pftrack.geometry.boxes import foot_points, nms

if TYPE_CHECKING:
    from pftrack.geometry.camera import CameraSpec

from .detector import SVMDetector, SVMModel, heights_from_boxes, merge_clusters

__all__ = [
    "HOG_PEOPLE_BOX",
    "HOGPeopleDetector",
    "PartialSearch",
    "default_people_model",
    "measure_margin",
]

#: Person box inside OpenCV's 64 x 128 default people window, as fractions of the window
#: (left, top, width, height); measured as the module docstring says.
HOG_PEOPLE_BOX = (0.26, 0.12, 0.50, 0.73)
WINDOW_WH = (64, 128)


def default_people_model(box_fraction: Sequence[float] = HOG_PEOPLE_BOX) -> SVMModel:
    """OpenCV's default HOG people detector as an :class:`SVMModel` (raw weights, not
    normalised: its scores are OpenCV's margins)."""
    import cv2

    coef = np.asarray(cv2.HOGDescriptor_getDefaultPeopleDetector(), dtype=np.float32).ravel()
    W, H = WINDOW_WH
    fl, ft, fw, fh = (float(v) for v in box_fraction)
    return SVMModel(coef[:-1].copy(), float(coef[-1]), "hog", WINDOW_WH,
                    (fl * W, ft * H, fw * W, fh * H), {"source": "cv2 default people detector"})


class PartialSearch(ParamGroup):
    """Where :class:`HOGPeopleDetector` searches on the frames between whole searches
    (``full_every`` > 1): near the people it found in the last ``memory`` frames, and where the
    frame changed since the previous one.

    {params}
    """

    margin: float = Param(
        0.3, "How far from a person found before a window is still scored.",
        unit="box heights", low=0.0, low_open=True)
    memory: int = Param(
        10, "The people found in this many frames before are searched near.", unit="frames",
        low=1)
    motion_threshold: float | None = Param(
        15.0,
        "Also search where the frame changed since the previous one (someone entering, or "
        "coming out from behind something): the grey levels, averaged over 4 x 4 pixels, moved "
        "by more than this; each changed region is searched as a person of the expected height "
        "standing at its bottom. None: only near the people found before.", unit="grey levels",
        low=0.0)


class HOGPeopleDetector(SVMDetector):
    """OpenCV's INRIA HOG people detector with tightened boxes, camera-limited scales and a
    calibrated score (see the module docstring). Needs no training.

    {params}
    """

    camera: CameraSpec | None = Param(
        None,
        "A ground-plane camera (path or object); default: the run's camera. Limits each scale "
        "to the rows where a ``height_m`` person has that size, and gives detections their "
        "ground point (foot back-projected to z = 0).")
    height_m: float = Param(
        1.7, "Mean person height with the camera, metres.", unit="m", low=0.0, low_open=True)
    threshold: float = Param(
        0.5,
        "Minimum calibrated score (0-1, a probability of being a person's box) of a detection.",
        unit="1", low=0.0, low_open=True, high=1.0, high_open=True)
    nms_iou: float = Param(
        0.3, "Detections overlapping a better one by more than this IoU are suppressed.",
        unit="1", low=0.0, high=1.0)
    merge_tau: float | None = Param(
        0.3,
        "Each kept window is refined to the mean of the windows overlapping it by IoU >= 0.5, "
        "weighted ``exp((m - m_best) / merge_tau)`` with ``m`` the raw margin; None: no "
        "refinement.", unit="1", low=0.0, low_open=True)
    scale_step: float = Param(
        1.2, "Ratio between consecutive search scales.", unit="1", low=1.0, low_open=True)
    min_height_px: float = Param(
        48.0,
        "Person heights (image pixels) searched; with a camera they clip its expected range.",
        unit="px", low=0.0, low_open=True)
    max_height_px: float = Param(
        480.0,
        "Person heights (image pixels) searched; with a camera they clip its expected range.",
        unit="px", low=0.0, low_open=True)
    learn_scales: int = Param(
        10,
        "Without a camera: frames searched over the whole pyramid before the search is limited "
        "by the height-row relation of their detections (0: never limit).", unit="frames", low=0)
    tolerance: float = Param(
        1.1, "A scale is searched at a row when the expected person height there is within this "
        "factor (times sqrt(scale_step)) of the scale's height.", unit="1", low=0.0,
        low_open=True)
    full_every: int = Param(
        1, "Search the whole frame (every scale band) on every ``full_every``-th frame only, "
        "counted from the first frame (again after a seek); on the frames between, only near "
        "the people found before and where the frame changed (``partial``), at the whole "
        "search's window positions, each window scoring exactly as in the whole search. A "
        "person who appears without moving away from everyone found before is first found at "
        "the next whole search. 1: every frame is searched whole.", unit="frames", low=1)
    partial: PartialSearch = Group(
        PartialSearch, "Where the frames between whole searches (``full_every`` > 1) are "
        "searched.")

    #: The person box inside the 64 x 128 window as fractions (left, top, width, height),
    #: measured as the module docstring says.
    box_fraction: ClassVar[tuple[float, ...]] = HOG_PEOPLE_BOX
    #: The logistic map of the margin ``m``: ``1 / (1 + exp(-(m - score_offset) /
    #: score_scale))``, fitted once as the module docstring says.
    score_offset: ClassVar[float] = 0.46
    score_scale: ClassVar[float] = 0.32

    # the SVM detector's model and training parameters do not apply: no parameters here
    model = None
    train = None

    def setup(self, context: RunContext) -> None:
        """The run's camera when ``camera`` is not set. A ``--detector-model`` is refused:
        this detector has no model to load."""
        if self.camera is None and context.camera is not None:
            self.camera_ = context.camera
        if context.detector_model is not None:
            raise ValueError(f"detector hog-people needs no model; --detector-model "
                             f"{context.detector_model} is not used by it (drop the option, or "
                             "use the svm detector)")

    @property
    def learns(self) -> bool:
        """False: nothing to train, save or load."""
        return False

    def save(self, path: str | os.PathLike[str]):
        raise NotImplementedError("detector 'hog-people' learns nothing to save")

    def load(self, path: str | os.PathLike[str]):
        raise NotImplementedError("detector 'hog-people' has no model to load")

    def fit(self, frames, boxes_by_frame, rng=None, ignore_by_frame=None):
        """Nothing to learn: returns ``self``."""
        return self

    def describe(self) -> dict[str, Any]:
        """The parameters and the window geometry."""
        m = self._model()
        # the parameters as plain values (Detector's), not the SVM model's record
        return {**Detector.describe(self), "window_wh": list(m.window_wh),
                "box_in_window": [float(v) for v in m.box_in_window]}

    def _model(self) -> SVMModel:
        if not hasattr(self, "model_"):
            self.model_ = default_people_model(self.box_fraction)
        return self.model_

    def _plan_options(self) -> dict[str, Any]:
        return {"tolerance": self.tolerance}

    def _new_hog(self, m: SVMModel) -> Any:
        """OpenCV's own people detector (its INRIA-trained weights), not a trained model's."""
        import cv2

        hog = cv2.HOGDescriptor()
        hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())
        return hog

    # -- scores ---------------------------------------------------------------------------

    def calibrate(self, margins: np.ndarray) -> np.ndarray:
        """Calibrated scores (0-1) of raw SVM margins (the logistic map)."""
        z = (np.asarray(margins, dtype=np.float64) - float(self.score_offset))
        return 1.0 / (1.0 + np.exp(-z / float(self.score_scale)))

    def margin_of(self, score: float) -> float:
        """The raw margin whose calibrated score is ``score`` (inverse of :meth:`calibrate`)."""
        s = float(np.clip(score, 1e-9, 1 - 1e-9))
        return float(self.score_offset) + float(self.score_scale) * float(np.log(s / (1 - s)))

    # -- detection ------------------------------------------------------------------------

    def detect_margins(self, grey: np.ndarray, rois: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
        """Person boxes (K, 4) and raw margins (K,) after suppression and refinement, down to
        the margin of ``threshold``; only near ``rois`` (person boxes) when given."""
        thr = self.margin_of(self.threshold)
        tau = self.merge_tau
        low = thr - (3.0 * float(tau) if tau is not None else 0.0)
        boxes, m = self.score_windows(grey, threshold=low, rois=rois,
                                      roi_margin=float(self.partial.margin))
        keep = nms(boxes, m, self.nms_iou)
        keep = keep[m[keep] >= thr]
        if tau is not None and len(keep):
            boxes = merge_clusters(boxes, m, keep, tau=float(tau))
        else:
            boxes = boxes[keep]
        return boxes, m[keep]

    def detect(self, frame: Frame) -> Detections:
        """Detections in ``frame``: person boxes (xywh px), calibrated scores, ground points
        (m) with a camera."""
        import cv2

        img = frame.image
        grey = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        cam = self._camera()
        learning = cam is None and int(self.learn_scales) > 0 and \
            not hasattr(self, "expected_heights_")
        if int(self.full_every) > 1 and \
                int(frame.index) != self.__dict__.get("last_index_", -2) + 1:
            # the first frame, or a seek: the cycle of whole searches starts here
            self.__dict__["start_index_"] = int(frame.index)
            self.__dict__["recent_"] = []
        rois = None if learning else self._rois(int(frame.index))
        if int(self.full_every) > 1 and self.partial.motion_threshold is not None:
            small = cv2.resize(grey, (grey.shape[1] // 4, grey.shape[0] // 4),
                               interpolation=cv2.INTER_AREA)
            prev = self.__dict__.get("prev_small_")
            if rois is not None and prev is not None and prev.shape == small.shape:
                rois = np.concatenate([rois, self._motion_rois(small, prev,
                                                               (grey.shape[1], grey.shape[0]))])
            self.__dict__["prev_small_"] = small
        boxes, margins = self.detect_margins(grey, rois)
        scores = self.calibrate(margins)
        if learning:
            self._learn_scales(boxes, scores, (grey.shape[1], grey.shape[0]))
        if int(self.full_every) > 1:
            idx = int(frame.index)
            recent = self.__dict__.get("recent_", [])
            recent = [(i, b) for i, b in recent if i > idx - int(self.partial.memory)]
            recent.append((idx, boxes))
            if rois is None:
                self.__dict__["full_index_"] = idx
            self.__dict__["recent_"] = recent
            self.__dict__["last_index_"] = idx
        points = None
        if cam is not None:
            feet = foot_points(boxes)
            points = cam.image_to_ground(feet) if len(feet) else np.zeros((0, 3))
        return Detections(boxes, scores, points)

    def _rois(self, index: int) -> np.ndarray | None:
        """The boxes to search near on frame ``index``, or None for a whole search (the frames
        while the scales are learnt, then every ``full_every``-th frame from the first, counted
        again from any frame not following the previous one)."""
        k = int(self.full_every)
        if k <= 1 or "start_index_" not in self.__dict__ or (index - self.start_index_) % k == 0:
            return None
        return np.concatenate([b for _, b in self.recent_])

    def _motion_rois(self, small: np.ndarray, prev: np.ndarray, size_wh: tuple[int, int]
                     ) -> np.ndarray:
        """Person boxes (K, 4) over the regions that changed between two quarter-size frames
        (changed pixels grouped within 2 quarter-size pixels; at least 2 % of a person's
        height squared of them): each region's bottom row holds a person of the expected
        height there (the camera's, or the learnt height-row relation), as wide as the region
        or 0.4 of that height."""
        import cv2

        grid = self._height_grid(size_wh)
        if grid is None:
            return np.zeros((0, 4))
        changed = (cv2.absdiff(small, prev) > float(self.partial.motion_threshold)).astype(np.uint8)
        mask = cv2.dilate(changed, np.ones((3, 3), np.uint8), iterations=2)
        n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        if n <= 1:
            return np.zeros((0, 4))
        st = stats[1:, :4].astype(np.float64) * 4.0
        x0, y0, w, h = st.T
        # the changed pixels themselves (not the dilation's) measure the region's size
        area = 16.0 * np.bincount(labels[changed > 0], minlength=n)[1:]
        u, v = x0 + w / 2, y0 + h
        step, cols, rows, heights = grid
        c = np.clip(np.round(u / step), 0, cols - 1).astype(int)
        r = np.clip(np.round(v / step), 0, rows - 1).astype(int)
        H = heights[r * cols + c]
        ok = np.isfinite(H) & (area >= 0.02 * np.where(np.isfinite(H), H, 0.0) ** 2)
        H, u, v, x0, w = H[ok], u[ok], v[ok], x0[ok], w[ok]
        bw = np.maximum(w, 0.4 * H)
        return np.stack([np.minimum(x0, u - 0.2 * H), v - H, bw, H], axis=1)

    def _height_grid(self, size_wh: tuple[int, int]) -> tuple[int, int, int, np.ndarray] | None:
        """(grid step, columns, rows, expected heights (rows * cols,)) of the expected person
        height at each foot pixel of a 16-px grid, or None when there is no relation."""
        cached = self.__dict__.get("height_grid_")
        if cached is not None and cached[0] == size_wh:
            return cached[1]
        from .detector import expected_heights_px

        cam = self._camera()
        if cam is not None:
            _, heights = expected_heights_px(cam, self.height_m, size_wh, step_px=16)
        elif getattr(self, "expected_heights_", None) is not None:
            heights = self.expected_heights_[1]
        else:
            return None
        w, h = size_wh
        cols, rows = len(range(0, w, 16)), len(range(0, h, 16))
        heights = np.asarray(heights, dtype=np.float64)
        if heights.shape != (rows * cols,):  # a relation learnt on frames of another size
            return None
        grid = (16, cols, rows, heights)
        self.__dict__["height_grid_"] = (size_wh, grid)
        return grid

    def _learn_scales(self, boxes: np.ndarray, scores: np.ndarray,
                      size_wh: tuple[int, int]) -> None:
        """Collect confident boxes over the first ``learn_scales`` frames, then limit the
        search to the fitted height-row plane (rows with a positive height only)."""
        seen = self.__dict__.setdefault("learn_boxes_", [])
        seen.append(boxes[scores >= max(0.5, float(self.threshold))])
        self.__dict__["learn_frames_"] = self.__dict__.get("learn_frames_", 0) + 1
        if self.learn_frames_ < int(self.learn_scales):
            return
        b = np.concatenate(seen) if seen else np.zeros((0, 4))
        if len(b) >= 8:
            feet, heights = heights_from_boxes(b, size_wh)
            # the plane is only trusted within the heights seen (with the tolerance's slack)
            lo, hi = np.percentile(b[:, 3], [2, 98])
            heights = np.clip(heights, lo / 1.5, hi * 1.5)
            if np.any(np.isfinite(heights)):
                self.expected_heights_ = (feet, heights)
                self.__dict__.pop("plan_size_", None)
                return
        self.expected_heights_ = None  # too few people: keep the whole pyramid

    def __getstate__(self) -> dict[str, Any]:
        d = dict(self.__dict__)
        d.pop("hog_", None)
        return d

    @classmethod
    def _conformance_example(cls):
        """For :mod:`pftrack.testing`: the kit's synthetic frames, all scales of 48-120 px."""
        from pftrack.testing import ConformanceExample, synthetic_scene

        sc = synthetic_scene(seed=0, n_frames=4)
        det = cls(threshold=0.05, min_height_px=48.0, max_height_px=120.0, learn_scales=0)
        return ConformanceExample(det, frames=sc.frames, fit_boxes={})


# --------------------------------------------------------------------------------------------
# Measuring the window margin (documentation and reproduction)
# --------------------------------------------------------------------------------------------


def measure_margin(video: str, gt: str, frames: tuple[int, int] = (1, 200), every: int = 10,
                   upscale: float = 1.5) -> dict[str, Any]:
    """Measure where a ground-truth person lies inside OpenCV's people window.

    Every ``every``-th frame of ``frames`` (MOT numbering) is scaled by ``upscale`` and
    searched over OpenCV's own pyramid (scale 1.05, stride 8, no grouping); each fully visible
    ground-truth box is paired with the best-scoring window whose centre lies within 0.15 box
    heights of the box's centre, and expressed as fractions of that window.

    Returns
    -------
    dict
        ``median`` (left, top, width, height fractions), ``q25``, ``q75``, ``n_pairs``,
        ``n_boxes``.
    """
    import cv2
    from pftrack.workflows.pipeline import iter_frames, read_ground_truth

    a, b = frames
    g = read_ground_truth(gt, a, b)
    hog = cv2.HOGDescriptor()
    hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())
    rel, n_boxes = [], 0
    for frame in iter_frames(video, a, b):
        if (frame.index - a) % every:
            continue
        grey = cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY)
        big = cv2.resize(grey, None, fx=upscale, fy=upscale)
        r, w = hog.detectMultiScale(big, hitThreshold=-0.5, winStride=(8, 8), scale=1.05,
                                    groupThreshold=0)
        r = np.asarray(r, np.float64).reshape(-1, 4) / upscale
        w = np.asarray(w, np.float64).reshape(-1)
        gb = g[(g[:, 0] == frame.index) & (g[:, 6] == 1)][:, 2:6]
        n_boxes += len(gb)
        if not len(r) or not len(gb):
            continue
        c = r[:, :2] + r[:, 2:] / 2
        gc = gb[:, :2] + gb[:, 2:] / 2
        d = np.linalg.norm(c[None] - gc[:, None], axis=2) / gb[:, 3:4]
        score = np.where(d < 0.15, w[None], -np.inf)
        j = np.argmax(score, axis=1)
        ok = np.isfinite(score[np.arange(len(gb)), j])
        win = r[j[ok]]
        bb = gb[ok]
        rel.append(np.stack([(bb[:, 0] - win[:, 0]) / win[:, 2], (bb[:, 1] - win[:, 1]) / win[:, 3],
                             bb[:, 2] / win[:, 2], bb[:, 3] / win[:, 3]], axis=1))
    rel = np.concatenate(rel) if rel else np.zeros((0, 4))
    return {"median": np.median(rel, 0).tolist(), "q25": np.percentile(rel, 25, 0).tolist(),
            "q75": np.percentile(rel, 75, 0).tolist(), "n_pairs": len(rel), "n_boxes": n_boxes}


if __name__ == "__main__":  # pragma: no cover
    import argparse
    import json

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--measure-margin", nargs=2, metavar=("GT", "VIDEO"), required=True)
    ap.add_argument("--frames", default="1:200")
    ns = ap.parse_args()
    fa, fb = (int(v) for v in ns.frames.split(":"))
    print(json.dumps(measure_margin(ns.measure_margin[1], ns.measure_margin[0], (fa, fb)),
                     indent=2))
