"""Eigenspace intruder detector (the coastal paper sec. 2): the block eigenspace background model of
:mod:`pftrack_coast.eigenspace` as a pftrack :class:`~pftrack.contracts.components.Detector`.

Per frame: every block's relative variation r_D (eq. 3) against its background eigenspace,
intruder blocks where ``r_D - v_D > 0`` (eq. 4), 4-connected groups of intruder blocks -> their
bounding boxes (xywh px), each scored by its largest ``r_D - v_D``.

Training (:meth:`EigenspaceDetector.fit`) takes ordinary frames: the pixels inside the given
ground-truth boxes are foreground, and a block joins a frame's training only where it is
background (see ``min_background_fraction``); frames without boxes are background only.
:meth:`EigenspaceDetector.fit_masks` takes per-pixel foreground masks instead (the water
data's ground truth).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

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

from pftrack_coast.eigenspace import (
    FRAME_OFFSETS,
    UNTRAINED,
    BlockEigenspaceModel,
    EigenspaceResult,
)

__all__ = ["EigenspaceDetector", "RecalibrationWatch", "boxes_to_mask"]


def boxes_to_mask(boxes_xywh_px: np.ndarray, image_hw: tuple[int, int]) -> np.ndarray:
    """(H, W) bool mask, True inside any of the (K, 4) boxes (left, top, width, height) px;
    a box covers the pixels it overlaps (edges rounded outwards), clipped to the image."""
    h, w = int(image_hw[0]), int(image_hw[1])
    mask = np.zeros((h, w), dtype=bool)
    b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    b = b[np.all(np.isfinite(b), axis=1)]
    x0 = np.clip(np.floor(b[:, 0]), 0, w).astype(int)
    y0 = np.clip(np.floor(b[:, 1]), 0, h).astype(int)
    x1 = np.clip(np.ceil(b[:, 0] + b[:, 2]), 0, w).astype(int)
    y1 = np.clip(np.ceil(b[:, 1] + b[:, 3]), 0, h).astype(int)
    for a0, a1, c0, c1 in zip(y0, y1, x0, x1):  # a handful of boxes per frame
        mask[a0:a1, c0:c1] = True
    return mask


class RecalibrationWatch(ParamGroup):
    """How :class:`EigenspaceDetector` watches for a camera recalibration or a sudden global
    change (a time gap, a level step, too many intruder blocks) and re-baselines the model on
    the frames after it (:class:`~pftrack_coast.recalibration.RecalibrationGuard`).

    {params}
    """

    mode: str = Param(
        "rebaseline", "'rebaseline' (default): on an event, hold detections for settle_frames "
        "frames and re-baseline the model's per-pixel means on them, with a "
        "RecalibrationWarning for each; 'off': the model as trained, every frame.",
        choices=("rebaseline", "off"))
    block_fraction: float = Param(
        0.25, "An event when more than this fraction of the trained blocks are intruders in "
        "one frame.", unit="1", low=0.0, low_open=True, high=1.0)
    level_step: float | None = Param(
        15.0, "An event when the frame's median grey level moves by more than this from the "
        "previous frame's (grey levels: counts for a thermal camera); null: not watched.",
        unit="grey levels", low=0.0, low_open=True)
    gap_s: float | None = Param(
        None, "An event when a frame comes more than this long after the previous one (a "
        "thermal camera's flat-field correction pauses the recording for about 1-2 s); null: "
        "not watched.", unit="s", low=0.0, low_open=True)
    adapt_rate: float = Param(
        0.02, "After each sound frame the means of the blocks away from any intruder move "
        "this fraction of the way towards it (the drift after a recalibration); 0: never.",
        unit="1", low=0.0, high=1.0, high_open=True)
    settle_frames: int = Param(
        3, "Frames held after an event and re-baselined on.", unit="frames", low=1)


class EigenspaceDetector(Detector):
    """Block eigenspace background subtraction (the coastal paper): intruder blocks -> boxes.

    {params}

    Attributes
    ----------
    model_ : BlockEigenspaceModel
        The learned (or loaded) background model.
    last_ : EigenspaceResult
        The r_D map, intruder mask, boxes and scores of the last frame given to
        :meth:`detect` (for likelihoods and pictures).
    guard_ : RecalibrationGuard
        With ``recalibration.mode`` "rebaseline", after the first :meth:`detect`: the guard, its
        events and messages; ``guard_.model`` is the copy of ``model_`` that it re-baselines.
    """

    block_size: int = Param(8, "Side of a block, pixels.", unit="px", low=1)
    threshold_q: float = Param(0.8, "Cumulative contribution q(D) fixing each block's "
                                    "eigenspace dimension D (eq. 1).", unit="1",
                                    low=0.0, low_open=True, high=1.0)
    v_low: float = Param(15.0, "Threshold v_D on r_D (eq. 4) for D <= d_split.", unit="1", low=0.0)
    v_high: float = Param(9.0, "Threshold v_D on r_D (eq. 4) for D > d_split.", unit="1", low=0.0)
    d_split: int = Param(20, "Largest dimension D that gets v_low.", unit="count", low=0)
    min_background_fraction: float = Param(
        1.0, "Training with boxes or masks: a block counts in a frame when at least this "
             "fraction of its pixels is background.", unit="1", low=0.0, high=1.0)
    min_samples: int = Param(
        10, "A block needs max(min_samples, D + 2) background samples; blocks with fewer are "
            "untrained (see untrained) and named in a warning; training where no block has "
            "enough is an error.", unit="count", low=0)
    frame_offset: str = Param(
        "none", "'median' subtracts each frame's median grey level first (a thermal camera's "
                "automatic gain or drift); 'none' is the paper's model.", choices=FRAME_OFFSETS)
    untrained: str = Param(
        "ignore", "A block without enough background samples: 'ignore' (default) is never an "
                  "intruder; 'nearest' (not in the paper) uses the nearest trained block's "
                  "mean and eigenspace, which finds objects that stood in the block through "
                  "training but flags it in every frame where its background differs from "
                  "the borrowed one.", choices=UNTRAINED)
    recalibration: RecalibrationWatch = Group(
        RecalibrationWatch, "Watching for a camera recalibration or sudden global change "
        "(:mod:`pftrack_coast.recalibration`).")
    box_margin_px: int = Param(0, "Training with boxes: each box is grown by this many pixels "
                                  "per side (people's outlines are not background).", unit="px",
                                  low=0)
    model: str | os.PathLike[str] | None = Param(
        None, "A model file written by save() (.npz), loaded on first use when the detector is "
        "not fitted.")

    def _model_params(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in (
            "block_size", "threshold_q", "v_low", "v_high", "d_split",
            "min_background_fraction", "min_samples", "frame_offset", "untrained")}

    # -- set-up and files ---------------------------------------------------------------------

    def setup(self, context: RunContext) -> None:
        """Load the run's detector model (``context.detector_model``) when it names one."""
        if context.detector_model is not None:
            self.load(context.detector_model)

    def _model(self) -> BlockEigenspaceModel:
        if not hasattr(self, "model_"):
            if self.model is None:
                raise ValueError("EigenspaceDetector: no model; pass model=PATH (written by "
                                 "save()) or call fit() / fit_masks() first")
            self.model_ = BlockEigenspaceModel.load(self.model)
        return self.model_

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the model (``.npz`` arrays + JSON parameters, no pickle) atomically."""
        if not hasattr(self, "model_") and self.model is None:
            raise ValueError("EigenspaceDetector.save: no model yet; call fit() first")
        return self._model().save(path)

    def load(self, path: str | os.PathLike[str]) -> EigenspaceDetector:
        """Use the model in ``path`` (ValueError naming the file when it is not one). The
        file's own block size, q and thresholds apply."""
        self.model_ = BlockEigenspaceModel.load(path)
        return self

    def describe(self) -> dict[str, Any]:
        """The model's parameters and a summary of what it learned (``pftrack detector info``);
        the detector's parameters when it has no model yet."""
        if not hasattr(self, "model_") and self.model is None:
            return super().describe()
        return self._model().describe()

    # -- training -----------------------------------------------------------------------------

    def fit(self, frames: Iterable[Frame] | Iterator[Frame], boxes_by_frame: dict[int, np.ndarray],
            rng: np.random.Generator | None = None,
            ignore_by_frame: dict[int, np.ndarray] | None = None) -> EigenspaceDetector:
        """Learn the background from ``frames``; pixels inside the boxes of
        ``boxes_by_frame`` (and ``ignore_by_frame``) of a frame are foreground there.

        Parameters
        ----------
        frames : iterable of Frame
            Streamed once (grey, BGR or 16-bit images, one size).
        boxes_by_frame : dict {frame index: (K, 4) xywh px}
            Objects per frame; a frame without an entry is background only.
        rng : numpy.random.Generator, optional
            Unused: training is deterministic.
        ignore_by_frame : dict {frame index: (K, 4)}, optional
            More foreground boxes (neither kind of sample).
        """
        ignore_by_frame = ignore_by_frame or {}
        empty = np.zeros((0, 4))
        m = float(self.box_margin_px)

        def pairs() -> Iterator[tuple[np.ndarray, np.ndarray | None]]:
            for f in frames:
                b = np.concatenate([np.asarray(d.get(f.index, empty), float).reshape(-1, 4)
                                    for d in (boxes_by_frame, ignore_by_frame)])
                if m and len(b):
                    b = b + np.array([-m, -m, 2 * m, 2 * m])
                yield f.image, (boxes_to_mask(b, f.image.shape[:2]) if len(b) else None)

        self.model_ = BlockEigenspaceModel(**self._model_params()).fit_pairs(pairs())
        return self

    def fit_masks(self, frames: Iterable[Frame | np.ndarray],
                  masks: Iterable[np.ndarray | None]) -> EigenspaceDetector:
        """Learn the background from frames (Frame or image arrays) with one (H, W) foreground
        mask per frame (non-zero = foreground; None = all background)."""
        imgs = (f.image if isinstance(f, Frame) else f for f in frames)
        self.model_ = BlockEigenspaceModel(**self._model_params()).fit(imgs, masks)
        return self

    # -- detection ----------------------------------------------------------------------------

    def score(self, frame: Frame | np.ndarray) -> EigenspaceResult:
        """r_D map, intruder blocks and boxes of one frame (see
        :class:`~pftrack_coast.eigenspace.EigenspaceResult`)."""
        img = frame.image if isinstance(frame, Frame) else frame
        return self._model().score(img)

    def _guard(self) -> Any:
        """The recalibration guard (``recalibration.mode`` "rebaseline") around a copy of the
        model: its re-baselines and drift-following change ``guard_.model``, never ``model_``
        (what :meth:`score` and :meth:`save` use)."""
        model = self._model()
        guard = self.__dict__.get("guard_")
        if guard is None or self.__dict__.get("guard_source_") is not model:
            import copy

            from pftrack_coast.recalibration import RecalibrationGuard

            self.guard_source_ = model
            w = self.recalibration
            guard = RecalibrationGuard(
                copy.deepcopy(model), block_fraction=float(w.block_fraction),
                level_step=None if w.level_step is None else float(w.level_step),
                gap_s=None if w.gap_s is None else float(w.gap_s),
                settle_frames=int(w.settle_frames), adapt_rate=float(w.adapt_rate))
            self.guard_ = guard
        return guard

    def detect(self, frame: Frame) -> Detections:
        """Boxes (xywh px) of the 4-connected groups of intruder blocks, scored by their
        largest ``r_D - v_D``. With ``recalibration.mode`` "rebaseline" no boxes while the
        model settles after a recalibration (each event is a ``RecalibrationWarning``)."""
        if self.recalibration.mode == "rebaseline":
            res = self._guard().score(frame.image, time_s=frame.time_s, frame=frame.index)
        else:
            res = self.score(frame)
        self.last_ = res
        return Detections(res.boxes_xywh_px, res.scores)

    @classmethod
    def _conformance_example(cls) -> Any:
        """For :mod:`pftrack.testing`: trained by the kit on its synthetic scene (four frames,
        the objects' boxes as foreground), so ``min_samples`` is lowered to 3."""
        return cls(min_samples=3)

