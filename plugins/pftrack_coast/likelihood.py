"""Eigenspace likelihood (the coastal paper's eq. 12-13, sec. 4.1 steps 1-5): a particle is likely
where the block it projects into leaves its background eigenspace.

For each particle: project its position through the run's camera (world metres, the state's
``position_dims``; or take the pixel the observation model projected, when its boxes are points
of size 0), find the block it falls into, and return ``log f`` with
``f = 1 / (1 + exp(-alpha (r_D - v_D)))`` (eq. 12), ``r_D`` that block's relative variation
(eq. 3) and ``v_D`` its threshold (eq. 4). Only the blocks that some particle touches are scored
(one batched product per frame over the blocks not yet scored). A particle behind the camera,
outside the image or in an untrained block gets likelihood 0 (``log f = -inf``), never NaN.

Without a camera (image-plane tracking), each particle's box centre pixel is used instead.

Also here: the OpenCV MOG2 foreground fraction for comparison
(:class:`ForegroundFractionLikelihood`), and a perfect foreground made of the frame's detection
boxes for tests (:class:`InsideBoxesLikelihood`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import Any

import numpy as np
from pftrack.contracts.components import Detections, Frame, Likelihood, Param, RunContext, Target

from pftrack_coast.eigenspace import BlockEigenspaceModel

__all__ = ["EigenspaceLikelihood", "ForegroundFractionLikelihood",
           "InsideBoxesLikelihood"]


def _blocks_of_pixels(px: np.ndarray, block_size: int, grid_shape: tuple[int, int],
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (N, 2) -> which fall in the block grid (bool (N,)) and their block indices
    ``row * cols + col`` (for those that do); NaN pixels fall outside."""
    rows, cols = grid_shape
    if len(px) > 64 and px.dtype == np.float64 and px.ndim == 2 and px.shape[1] == 2:
        from pftrack.filter import _jit

        if _jit.ENABLED:
            from pftrack_coast._kernels import blocks_of_pixels

            ok = np.empty(len(px), dtype=np.bool_)
            idx = np.empty(len(px), dtype=np.intp)
            count = blocks_of_pixels(px, float(block_size), rows, cols, ok, idx)
            return ok, idx[:count]
    with np.errstate(invalid="ignore"):
        c = np.floor(px[:, 0] / block_size)
        r = np.floor(px[:, 1] / block_size)
    ok = np.isfinite(c) & np.isfinite(r) & (c >= 0) & (c < cols) & (r >= 0) & (r < rows)
    return ok, (r[ok] * cols + c[ok]).astype(np.intp)


def _engine_points(boxes_xywh_px: np.ndarray, target: Target | None) -> bool:
    """Whether ``boxes_xywh_px`` are the engine's particle boxes of this frame and points (an
    observation with ``particle_box="point"`` projected the particles already)."""
    return (target is not None and target.particle_boxes_xywh_px is boxes_xywh_px
            and len(boxes_xywh_px) > 0 and not np.asarray(boxes_xywh_px)[:, 2:].any())


def _same_rows(a: np.ndarray | None, b: np.ndarray) -> bool:
    """Whether ``a`` is the array ``b`` views (the same memory, shape and strides): a
    target's particle boxes of this frame, as the engine stacked them."""
    return (type(a) is np.ndarray and a.shape == b.shape and a.strides == b.strides
            and a.dtype == b.dtype and a.ctypes.data == b.ctypes.data)


class EigenspaceLikelihood(Likelihood):
    """Sigmoid of the block eigenspace's relative variation (the coastal paper's eq. 12-13).

    {params}

    Attributes
    ----------
    model_ : BlockEigenspaceModel
        The background model (loaded from ``model`` or the run's detector model, or given with
        :meth:`set_model`).
    camera_ : Camera or None
        The run's camera (None: box centres are used).
    """

    model: str | os.PathLike[str] | None = Param(
        None, "A model file (.npz) written by the eigenspace detector's save(); None: the run's "
        "detector model (pftrack run --detector-model).")
    alpha: float = Param(1.0, "Slope of the sigmoid (eq. 12), per unit of r_D - v_D.", unit="1",
                         low=0.0, low_open=True)
    position_dims: tuple[int, int, int] = Param(
        (0, 1, 2), "State entries holding a particle's (x, y, z) in world metres.", unit="none",
        low=0, length=3)

    def setup(self, context: RunContext) -> None:
        """The run's camera, and the run's detector model when ``model`` is not set."""
        self.camera_ = context.camera
        if self.model is None and context.detector_model is not None and \
                "model_" not in self.__dict__:
            self.set_model(BlockEigenspaceModel.load(context.detector_model))

    def set_model(self, model: BlockEigenspaceModel) -> EigenspaceLikelihood:
        """Use an in-memory model (a detector's ``model_``)."""
        self.model_ = model
        return self

    def _get_model(self) -> BlockEigenspaceModel:
        if "model_" not in self.__dict__:
            if self.model is None:
                raise ValueError("EigenspaceLikelihood: no model; give model=PATH (a file the "
                                 "eigenspace detector saved) or run with --detector-model")
            self.model_ = BlockEigenspaceModel.load(self.model)
        return self.model_

    def prepare(self) -> None:
        """The model loaded and checked; the compiled block lookup loaded."""
        self._get_model()
        from pftrack.filter import _jit

        if _jit.ENABLED:
            from pftrack_coast._kernels import warm_up

            warm_up()

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        """The frame's grey levels; no block scored yet."""
        m = self._get_model()
        self.excess_ = np.full(m.grid_shape_[0] * m.grid_shape_[1], np.nan)  # r_D - v_D
        self.log_sigmoid_ = np.full(len(self.excess_), np.nan)  # each scored block's log-lik.
        img = frame.image
        if m.frame_offset != "median" and img.ndim == 3 and img.shape[2] == 3 and \
                img.dtype in (np.uint8, np.uint16):
            # the grey levels as OpenCV gives them: the particles' blocks are gathered and
            # converted to float64 (the model's grey(), exactly) without converting the frame
            import cv2

            raw = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
            if raw.shape == m.image_shape_:
                self.grey_raw_ = raw
                self.__dict__.pop("grey_", None)
                return
        self.grey_raw_ = None
        self.grey_ = m.grey(img)

    def _grey(self) -> np.ndarray:
        """This frame's float64 grey levels (:meth:`BlockEigenspaceModel.grey`)."""
        if "grey_" not in self.__dict__:
            self.grey_ = self.grey_raw_.astype(np.float64)
        return self.grey_

    def _pixels(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        if _engine_points(boxes_xywh_px, target):
            return b[:, :2]
        cam = self.__dict__.get("camera_")
        if cam is not None and target is not None and target.particles is not None \
                and len(target.particles) == len(boxes_xywh_px):
            pts = np.asarray(target.particles, dtype=np.float64)[:, list(self.position_dims)]
            return cam.project(pts)  # NaN behind the camera
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        return b[:, :2] + 0.5 * b[:, 2:]

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        m = self._get_model()
        px = self._pixels(boxes_xywh_px, target)
        n = len(px)
        out = np.full(n, -np.inf)
        if n == 0:
            return out
        ok, blocks = _blocks_of_pixels(px, int(m.block_size), m.grid_shape_)
        if not len(blocks):
            return out
        # the blocks touched and not yet scored, in order (np.unique's, by a mask of the grid)
        self._score_blocks(m, blocks)
        out[ok] = self.log_sigmoid_[blocks]
        return out

    def _log_sigmoid(self, excess: np.ndarray) -> np.ndarray:
        """Eq. 12's log-likelihood of blocks from their r_D - v_D: log sigmoid(alpha z),
        stable; -inf for untrained blocks (computed once per block and frame, then looked up
        per particle: the same numbers)."""
        z = excess
        if float(self.alpha) != 1.0:  # (x * 1.0 is x, bit for bit: no pass for it)
            z = float(self.alpha) * z
        return -np.logaddexp(0.0, -z)

    def _score_blocks(self, m: BlockEigenspaceModel, blocks: np.ndarray) -> None:
        """Score the blocks of ``blocks`` (indices, one particle each) not yet scored this
        frame: the whole frame at once when they are more than a fifth of the grid."""
        touched = np.zeros(len(self.excess_), dtype=np.bool_)
        touched[blocks] = True
        need = np.flatnonzero(touched & np.isnan(self.excess_))
        if len(need) > 0.2 * len(self.excess_):
            # most of the frame: every block at once (grouped by D) is cheaper than gathering
            rd = m.relative_variation_of_grey(self._grey())
            self.excess_ = np.where(m.trained_, rd - m.v_, -np.inf)
            self.log_sigmoid_ = self._log_sigmoid(self.excess_)
        elif len(need):
            raw = self.__dict__.get("grey_raw_")
            rd = m.relative_variation_at(self._grey() if raw is None else raw, need)
            self.excess_[need] = np.where(m.trained_[need], rd - m.v_[need], -np.inf)
            self.log_sigmoid_[need] = self._log_sigmoid(self.excess_[need])

    def log_likelihood_rows(self, boxes_xywh_px: np.ndarray,
                            targets: Sequence[Target]) -> np.ndarray:
        """Every target's log-likelihoods at once (the engine's stacked path): one block
        lookup over all (T, N) pixels and one sigmoid, with the blocks scored target by target
        in the rows' order exactly as :meth:`log_likelihood` would (so each row equals its
        per-target call bit for bit). Rows whose boxes are not the engine's projected points
        of this frame go through :meth:`log_likelihood`.

        Parameters
        ----------
        boxes_xywh_px : ndarray, shape (T, N, 4), float64
            Each target's particles as image boxes (points when projected by the engine).
        targets : sequence of Target
            The T targets, in the rows' order.

        Returns
        -------
        ndarray, shape (T, N), float64
        """
        b = boxes_xywh_px
        if (type(b) is not np.ndarray or b.ndim != 3 or b.shape[0] != len(targets)
                or b.shape[1] == 0 or b.shape[2] != 4 or b.dtype != np.float64
                or b[:, :, 2:].any()
                or not all(_same_rows(t.particle_boxes_xywh_px, b[i])
                           for i, t in enumerate(targets))):
            return super().log_likelihood_rows(boxes_xywh_px, targets)
        m = self._get_model()
        n_t, n = b.shape[:2]
        px = np.ascontiguousarray(b[:, :, :2]).reshape(n_t * n, 2)  # the engine's pixels
        ok, blocks = _blocks_of_pixels(px, int(m.block_size), m.grid_shape_)
        out = np.full(n_t * n, -np.inf)
        if not len(blocks):
            return out.reshape(n_t, n)
        ends = np.cumsum(ok.reshape(n_t, n).sum(axis=1))  # each row's share of ``blocks``
        ll = np.empty(len(blocks))
        start = 0
        for end in ends.tolist():
            if end > start:
                # this row's blocks scored and looked up before the next row's (a later row
                # may rescore the whole frame, as successive calls would)
                self._score_blocks(m, blocks[start:end])
                np.take(self.log_sigmoid_, blocks[start:end], out=ll[start:end])
            start = end
        out[ok] = ll
        return out.reshape(n_t, n)

    @classmethod
    def _conformance_example(cls) -> Any:
        """For :mod:`pftrack.testing`: a 4-pixel-block model of 24 noisy empty frames the size
        of the kit's synthetic scene, saved to a temporary file (no camera: box centres)."""
        rng = np.random.default_rng(3)
        base = np.linspace(60.0, 120.0, 160)[None, :] + np.linspace(0.0, 40.0, 120)[:, None]
        frames = [np.clip(base + rng.normal(0.0, 6.0, base.shape), 0, 255).astype(np.uint8)
                  for _ in range(24)]
        import tempfile
        from pathlib import Path

        path = Path(tempfile.mkdtemp(prefix="pftrack-eigenspace-")) / "model.npz"
        BlockEigenspaceModel(block_size=4).fit(frames).save(path)
        return cls(model=str(path))


class ForegroundFractionLikelihood(Likelihood):
    """The fraction of foreground pixels (OpenCV's MOG2 background subtractor) in the block each
    particle projects into: ``f = eps + (1 - eps) * fraction`` (the coastal paper's comparison: the
    block eigenspace model against a per-pixel mixture model, through the same particles).

    The subtractor learns online from every frame it weights (OpenCV's default learning rate);
    :meth:`fit` shows it background frames first. Shadows (MOG2's grey 127) count as
    background. A particle outside the image gets likelihood 0.

    {params}
    """

    block_size: int = Param(8, "Block size in pixels (as the eigenspace model's).", unit="px",
                            low=1)
    history: int = Param(500, "MOG2's history (frames).", unit="frames", low=1)
    var_threshold: float = Param(16.0, "MOG2's varThreshold (squared Mahalanobis distance).",
                                 unit="1", low=0.0, low_open=True)
    detect_shadows: bool = Param(True, "MOG2 marks shadows (then counted as background).")
    eps: float = Param(1e-6, "Likelihood of a block without foreground (> 0: a frame without "
                             "foreground still weights).", unit="1",
                             low=0.0, low_open=True, high=1.0, high_open=True)
    position_dims: tuple[int, int, int] = Param(
        (0, 1, 2), "State entries holding a particle's (x, y, z) in world metres.", unit="none",
        low=0, length=3)

    def setup(self, context: RunContext) -> None:
        """The run's camera."""
        self.camera_ = context.camera

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without OpenCV's subtractor (it cannot be): an unpickled copy starts with
        an empty background, as a fresh one."""
        return {k: v for k, v in self.__dict__.items() if k != "subtractor_"}

    def _subtractor(self) -> Any:
        if "subtractor_" not in self.__dict__:
            import cv2

            self.subtractor_ = cv2.createBackgroundSubtractorMOG2(
                history=int(self.history), varThreshold=float(self.var_threshold),
                detectShadows=bool(self.detect_shadows))
        return self.subtractor_

    def prepare(self) -> None:
        self._subtractor()

    def fit(self, frames: Any) -> ForegroundFractionLikelihood:
        """Show the subtractor these frames (images) first, learning as it goes."""
        sub = self._subtractor()
        for img in frames:
            sub.apply(np.asarray(getattr(img, "image", img)))
        return self

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        """Apply the subtractor to the frame; the foreground fraction per block."""
        fg = self._subtractor().apply(frame.image) > 200
        bs = int(self.block_size)
        h, w = fg.shape
        rows, cols = h // bs, w // bs
        blocks = fg[:rows * bs, :cols * bs].reshape(rows, bs, cols, bs)
        frac = blocks.mean(axis=(1, 3))
        e = float(self.eps)
        self.log_f_ = np.log(e + (1.0 - e) * frac).ravel()
        self.grid_ = (rows, cols)

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        if _engine_points(boxes_xywh_px, target):
            px = b[:, :2]
        else:
            cam = self.__dict__.get("camera_")
            if cam is not None and target is not None and target.particles is not None \
                    and len(target.particles) == len(b):
                px = cam.project(np.asarray(target.particles)[:, list(self.position_dims)])
            else:
                px = b[:, :2] + 0.5 * b[:, 2:]
        out = np.full(len(px), -np.inf)
        ok, blocks = _blocks_of_pixels(px, int(self.block_size), self.grid_)
        out[ok] = self.log_f_[blocks]
        return out


class InsideBoxesLikelihood(Likelihood):
    """A particle's likelihood is ``inside`` when its pixel lies in one of the frame's
    detection boxes, ``outside`` elsewhere (0 without detections): a perfect foreground mask
    made of boxes, for tests and the conformance kit's run of
    :class:`~pftrack_coast.volumes.VolumeTracks` (boxes of size 0, ``particle_box="point"``, are
    read as the particles' pixels).

    {params}
    """

    inside: float = Param(0.95, "Likelihood inside a box.")
    outside: float = Param(1e-3, "Likelihood outside every box.")

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        self.boxes_ = detections.boxes_xywh_px if detections is not None else np.zeros((0, 4))

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        px = b[:, :2] + 0.5 * b[:, 2:]
        d = self.boxes_
        with np.errstate(invalid="ignore"):
            hit = ((px[:, None, :] >= d[None, :, :2])
                   & (px[:, None, :] <= d[None, :, :2] + d[None, :, 2:])).all(axis=2).any(axis=1)
        return np.where(hit, math.log(float(self.inside)), math.log(float(self.outside)))
