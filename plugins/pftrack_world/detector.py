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

Where each part lives: the component here; the model, its file, the scale plan and the windows
in :mod:`pftrack_world.svm_model`; training in :mod:`pftrack_world.svm_training` (their names
import from here too).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator, Sequence
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
from pftrack.geometry.boxes import nms

from pftrack_world.svm_model import (  # noqa: F401 (public here as well)
    FEATURES,
    MIN_TRAIN_RECALL,
    MODEL_FORMAT,
    MODEL_VERSION,
    ScaleBand,
    SVMModel,
    TrainingRecallWarning,
    _dense_windows,
    _hog,
    _roi_crops,
    crop_windows,
    detections_on_ground,
    expected_heights_px,
    heights_from_boxes,
    load_model,
    merge_clusters,
    n_features_for,
    save_model,
    scale_plan,
    window_features,
)
from pftrack_world.svm_training import train_svm_model

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera, CameraSpec

__all__ = ["SVMDetector", "SvmTraining"]

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
