"""Block eigenspace background model (the coastal paper sec. 2; Mittal's block PCA with a threshold
that depends on the eigenspace dimension).

The image is cut into ``block_size`` x ``block_size`` pixel blocks; each block ``b`` has its own
eigenspace learnt by PCA over its background training vectors ``x`` (the block's P = block_size²
grey levels, row-major):

* eigenvalues ``lambda_1 >= lambda_2 >= ...`` and eigenvectors ``e_i`` of the block's covariance;
* dimension ``D`` = the smallest with cumulative contribution ``q(D) = sum_{i<=D} lambda_i /
  sum_i lambda_i >= threshold_q`` (eq. 1);
* projection ``s = E^T (x - mean)`` with ``E = [e_1 .. e_D]`` (eq. 2, on the mean-subtracted
  block, see :class:`BlockEigenspaceModel`);
* relative variation ``r_D(s) = (1/D) sum_{i<=D} s_i² / lambda_i`` (eq. 3);
* the block is part of an intruder when ``r_D - v_D > 0`` (eq. 4), ``v_D = v_low`` (15) for
  ``D <= d_split`` (20) and ``v_high`` (9) above.

Intruder blocks are grouped 4-connected (the paper's 4-neighbourhood) and each group's bounding
rectangle, in pixels, is a detection.

Everything is vectorised over blocks: training accumulates per-block sums with a validity weight
(blocks whose pixels are foreground in a frame do not count in that frame) and diagonalises all
block covariances in one batched ``numpy.linalg.eigh``; scoring a frame is one batched matrix
product. Grey levels are float64 throughout, so 16-bit thermal counts keep their full range.
Optionally (``frame_offset="median"``, not in the paper) each frame's median grey level is
subtracted first, for cameras whose global level drifts (a thermal camera's automatic gain).

Pixels beyond the last whole block (the right and bottom remainders when the image size is not a
multiple of ``block_size``) are not modelled; detections never cover them.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "MODEL_FORMAT",
    "MODEL_VERSION",
    "BlockEigenspaceModel",
    "EigenspaceResult",
    "block_fractions",
    "blocks_of",
    "components_to_boxes",
    "fit_model",
    "to_grey",
    "untrained_picture",
]

MODEL_FORMAT = "pftrack-block-eigenspace"
MODEL_VERSION = 1
_END = object()
FRAME_OFFSETS = ("none", "median")
UNTRAINED = ("ignore", "nearest")


# --------------------------------------------------------------------------------------------
# Pixels -> blocks
# --------------------------------------------------------------------------------------------


def to_grey(image: np.ndarray) -> np.ndarray:
    """A frame as float64 grey levels, shape (H, W), without loss of range.

    * (H, W) or (H, W, 1) of any integer or float dtype (8-bit grey, 16-bit thermal counts):
      the values unchanged, as float64 (no scaling, no clipping to 8 bits);
    * (H, W, 3) BGR (OpenCV order), uint8 or uint16: OpenCV's ``COLOR_BGR2GRAY`` luma
      ``0.299 R + 0.587 G + 0.114 B`` (rounded to the input's integer type by OpenCV), so a
      grey picture stored as three equal channels gives back exactly its grey levels;
      float colour frames: the same weights in float64.
    """
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.ndim == 2:
        return img.astype(np.float64, copy=False)
    if img.ndim == 3 and img.shape[2] == 3:
        if img.dtype in (np.uint8, np.uint16):
            import cv2

            return cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(np.float64)
        return img.astype(np.float64) @ np.array([0.114, 0.587, 0.299])
    raise ValueError(f"expected a grey (H, W) or BGR (H, W, 3) frame, got shape {img.shape}")


def _gather_kernel(grey: np.ndarray) -> Any:
    """The compiled block gather (:func:`pftrack_coast._kernels.gather_blocks`) for a 2-D
    uint8, uint16 or float64 frame when the kernels are on (``PFTRACK_NO_JIT`` unset), else
    None."""
    if grey.ndim != 2 or grey.dtype not in (np.uint8, np.uint16, np.float64):
        return None
    from pftrack.filter import _jit

    if not _jit.ENABLED:
        return None
    from pftrack_coast._kernels import gather_blocks

    return gather_blocks


def blocks_of(grey: np.ndarray, block_size: int) -> np.ndarray:
    """Cut a (H, W) array into blocks: (rows * cols, block_size²), block (r, c) at row
    ``r * cols + c``, its pixels row-major. The right and bottom remainders are dropped."""
    bs = int(block_size)
    rows, cols = grey.shape[0] // bs, grey.shape[1] // bs
    g = grey[: rows * bs, : cols * bs]
    return g.reshape(rows, bs, cols, bs).transpose(0, 2, 1, 3).reshape(rows * cols, bs * bs)


def block_fractions(mask: np.ndarray, block_size: int) -> np.ndarray:
    """Fraction of the pixels of each block that are set in a (H, W) boolean mask, as a
    (rows, cols) float64 grid (the remainders beyond the last whole block are dropped)."""
    m = np.asarray(mask)
    if m.ndim == 3:
        m = m[:, :, 0]
    bs = int(block_size)
    rows, cols = m.shape[0] // bs, m.shape[1] // bs
    return blocks_of(m.astype(np.float64) != 0, bs).mean(axis=1).reshape(rows, cols)


# --------------------------------------------------------------------------------------------
# Result of one frame
# --------------------------------------------------------------------------------------------


@dataclass
class EigenspaceResult:
    """What the model finds in one frame.

    Attributes
    ----------
    r_map : ndarray, shape (rows, cols), float64
        Relative variation r_D(s) (eq. 3) of every block; 0 for untrained blocks.
    excess_map : ndarray, shape (rows, cols), float64
        ``r_D - v_D`` (eq. 4); ``-inf`` for untrained blocks (never intruders).
    intruder_mask : ndarray, shape (rows, cols), bool
        Blocks with ``r_D - v_D > 0``.
    boxes_xywh_px : ndarray, shape (K, 4), float64
        Bounding rectangles (left, top, width, height) in image pixels of the 4-connected
        groups of intruder blocks, in OpenCV's label order (top-left first).
    scores : ndarray, shape (K,), float64
        Per box, the largest ``r_D - v_D`` of its blocks (> 0).
    """

    r_map: np.ndarray
    excess_map: np.ndarray
    intruder_mask: np.ndarray
    boxes_xywh_px: np.ndarray
    scores: np.ndarray


def components_to_boxes(intruder_mask: np.ndarray, excess_map: np.ndarray,
                        block_size: int) -> tuple[np.ndarray, np.ndarray]:
    """4-connected groups of a (rows, cols) block mask -> (boxes (K, 4) xywh px, scores (K,)),
    score = the group's largest ``excess_map`` value."""
    import cv2

    n, labels, stats, _ = cv2.connectedComponentsWithStats(
        intruder_mask.astype(np.uint8), connectivity=4, ltype=cv2.CV_32S)
    if n <= 1:
        return np.zeros((0, 4)), np.zeros(0)
    boxes = stats[1:, :4].astype(np.float64) * float(block_size)
    scores = np.full(n, -np.inf)
    sel = labels > 0
    np.maximum.at(scores, labels[sel], excess_map[sel])
    return boxes, scores[1:]


# --------------------------------------------------------------------------------------------
# The model
# --------------------------------------------------------------------------------------------


class BlockEigenspaceModel:
    """Per-block PCA background model with the dimension-dependent threshold of the coastal paper.

    Parameters
    ----------
    block_size : int
        Side of a block, pixels (P = block_size² grey levels per block vector).
    threshold_q : float
        Cumulative contribution q(D) that fixes each block's dimension D (eq. 1), in (0, 1].
    v_low, v_high : float
        Threshold v_D of eq. 4 for ``D <= d_split`` and ``D > d_split``.
    d_split : int
        Largest dimension that gets ``v_low`` (the paper: 20).
    min_background_fraction : float
        With masks, a block takes part in a frame's training only when at least this fraction
        of its pixels is background (1.0: only wholly background blocks).
    min_samples : int
        A block needs at least ``max(min_samples, D + 2)`` background samples to be trained
        (a covariance from fewer vectors than its dimension is degenerate). Blocks with fewer
        are *untrained*: listed in ``untrained_blocks_``, a warning names them (row, col) and
        :func:`untrained_picture` draws where they are; what they are judged by is
        ``untrained``. When no block has enough samples :meth:`fit` raises a ``ValueError``
        (a model that could never detect anything).
    untrained : {"ignore", "nearest"}
        ``"ignore"`` (default): an untrained block's r_D is 0 and it is never an intruder, so
        a block the model knows nothing about cannot invent one. ``"nearest"`` (not in the
        paper): an untrained block uses the mean and eigenspace of the nearest trained block
        (grid distance), the water or ground next to it; for an object that stands in the same
        blocks through every training frame (the beach sequence's people) this is the
        difference between finding it and never finding it, but wherever the borrowed mean
        differs from the block's own background the block is flagged in every frame.
    min_eigenvalue : float
        Floor on the eigenvalues used in eq. 3 (squared grey levels): only guards against a
        division by zero for a block that never varied during training.
    frame_offset : {"none", "median"}
        ``"median"`` subtracts each frame's median grey level (of every 4th pixel of every 4th
        row) before training and scoring, so a global level change (a thermal camera's
        automatic gain and drift, the paper's "exposure adjustment ON") is not an intruder
        everywhere; ``"none"`` (default) is the paper's model.

    Notes
    -----
    Eq. 2 of the paper projects the raw block ``x``; here the block's training mean is
    subtracted first, ``s = E^T (x - mean)``. The eigenvalues ``lambda_i`` are variances about
    the mean, so only the centred projection makes ``s_i² / lambda_i`` the squared number of
    standard deviations along ``e_i`` (expected value 1 for a background block): projecting the
    raw block would add the mean's own projection ``(E^T mean)_i``, large for any bright block,
    and flag a background that merely has high grey levels.

    Attributes
    ----------
    grid_shape_ : (int, int)
        Blocks per column and per row, (rows, cols); this and the others are set by :meth:`fit`.
    image_shape_ : (int, int)
        (H, W) of the training frames; frames scored must have it.
    mean_ : ndarray, shape (B, P)
        Block means (B = rows * cols).
    components_ : ndarray, shape (B, P, Dmax)
        Eigenvectors, largest eigenvalue first; columns beyond a block's D are zero.
    eigenvalues_ : ndarray, shape (B, Dmax)
        The matching eigenvalues (0 beyond D).
    dims_ : ndarray, shape (B,), int
        D per block (0 for an untrained block).
    v_ : ndarray, shape (B,)
        v_D per block.
    n_samples_ : ndarray, shape (B,), int
        Background samples each block was trained on.
    trained_ : ndarray, shape (B,), bool
        Blocks with an eigenspace (their own, or with ``untrained="nearest"`` a borrowed one).
    source_ : ndarray, shape (B,), int
        The block whose eigenspace each block uses (itself when it has its own).
    untrained_blocks_ : ndarray, shape (U, 2), int
        (row, col) of the blocks without enough background samples of their own.
    """

    def __init__(self, block_size: int = 8, threshold_q: float = 0.8, v_low: float = 15.0,
                 v_high: float = 9.0, d_split: int = 20, min_background_fraction: float = 1.0,
                 min_samples: int = 10, min_eigenvalue: float = 1e-6,
                 frame_offset: str = "none", untrained: str = "ignore") -> None:
        self.block_size = block_size
        self.threshold_q = threshold_q
        self.v_low = v_low
        self.v_high = v_high
        self.d_split = d_split
        self.min_background_fraction = min_background_fraction
        self.min_samples = min_samples
        self.min_eigenvalue = min_eigenvalue
        self.frame_offset = frame_offset
        self.untrained = untrained

    def params(self) -> dict[str, Any]:
        return {"block_size": int(self.block_size), "threshold_q": float(self.threshold_q),
                "v_low": float(self.v_low), "v_high": float(self.v_high),
                "d_split": int(self.d_split),
                "min_background_fraction": float(self.min_background_fraction),
                "min_samples": int(self.min_samples),
                "min_eigenvalue": float(self.min_eigenvalue),
                "frame_offset": str(self.frame_offset), "untrained": str(self.untrained)}

    def _check_params(self) -> None:
        if int(self.block_size) < 1:
            raise ValueError(f"block_size must be >= 1, got {self.block_size}")
        if not 0.0 < float(self.threshold_q) <= 1.0:
            raise ValueError(f"threshold_q must be in (0, 1], got {self.threshold_q}")
        if not 0.0 <= float(self.min_background_fraction) <= 1.0:
            raise ValueError("min_background_fraction must be in [0, 1], got "
                             f"{self.min_background_fraction}")
        if self.frame_offset not in FRAME_OFFSETS:
            raise ValueError(f"frame_offset must be one of {FRAME_OFFSETS}, got "
                             f"{self.frame_offset!r}")
        if self.untrained not in UNTRAINED:
            raise ValueError(f"untrained must be one of {UNTRAINED}, got {self.untrained!r}")

    def _grey(self, image: np.ndarray) -> np.ndarray:
        grey = to_grey(image)
        if self.frame_offset == "median":
            # a subsample's median: the full one would cost more than scoring the frame
            grey = grey - np.median(grey[::4, ::4])
        return grey

    # -- training -----------------------------------------------------------------------------

    def fit(self, frames: Iterable[np.ndarray],
            masks: Iterable[np.ndarray | None] | None = None) -> BlockEigenspaceModel:
        """Learn every block's eigenspace.

        Parameters
        ----------
        frames : iterable of ndarray
            Training pictures (see :func:`to_grey`: grey, BGR or 16-bit), all the same size.
            Streamed once: only per-block sums are kept, never the frames.
        masks : iterable of ndarray or None, optional
            One (H, W) foreground mask per frame (non-zero = foreground), or None for a frame
            that is all background; without ``masks`` every frame is background only. A block
            counts in a frame when at least ``min_background_fraction`` of its pixels are
            background.

        Returns
        -------
        self
        """
        if masks is None:
            return self.fit_pairs((img, None) for img in frames)
        frames, masks = iter(frames), iter(masks)

        def pairs() -> Iterator[tuple[np.ndarray, np.ndarray | None]]:
            for k, img in enumerate(frames):
                m = next(masks, _END)
                if m is _END:
                    raise ValueError(f"fewer masks than frames ({k})")
                yield img, m

        return self.fit_pairs(pairs())

    def fit_pairs(self, pairs: Iterable[tuple[np.ndarray, np.ndarray | None]],
                  ) -> BlockEigenspaceModel:
        """:meth:`fit` from ``(image, foreground mask or None)`` pairs, streamed once."""
        self._check_params()
        bs = int(self.block_size)
        shape = None
        ref = s1 = s2 = count = None
        n_frames = 0
        for img, m in pairs:
            grey = self._grey(img)
            if shape is None:
                shape = grey.shape
                if shape[0] < bs or shape[1] < bs:
                    raise ValueError(f"frames of {shape[1]}x{shape[0]} px are smaller than one "
                                     f"{bs}x{bs} block")
            elif grey.shape != shape:
                raise ValueError(f"training frame {n_frames} is {grey.shape[1]}x{grey.shape[0]}"
                                 f" px, the first was {shape[1]}x{shape[0]}")
            x = blocks_of(grey, bs)  # (B, P)
            if m is None:
                w = np.ones(len(x))
            else:
                m = np.asarray(m)
                if m.shape[:2] != shape:
                    raise ValueError(f"mask {n_frames} has shape {m.shape[:2]}, frame {shape}")
                bg = 1.0 - block_fractions(m, bs).ravel()
                w = (bg >= float(self.min_background_fraction) - 1e-12).astype(np.float64)
            if ref is None:
                # sums are taken about the first frame's blocks: the covariance from raw sums
                # of squares would lose precision to cancellation with 16-bit grey levels
                ref = x.copy()
                s1 = np.zeros_like(x)
                s2 = np.zeros((x.shape[0], x.shape[1], x.shape[1]))
                count = np.zeros(len(x))
            d = (x - ref) * w[:, None]
            s1 += d
            # validity weights are 0/1, so d (x - ref)^T already carries w once
            s2 += d[:, :, None] * (x - ref)[:, None, :]
            count += w
            n_frames += 1
        if shape is None:
            raise ValueError("BlockEigenspaceModel.fit: no training frames")
        self._finish(shape, ref, s1, s2, count, n_frames)
        return self

    def _finish(self, shape: tuple[int, int], ref: np.ndarray, s1: np.ndarray, s2: np.ndarray,
                count: np.ndarray, n_frames: int) -> None:
        bs = int(self.block_size)
        rows, cols = shape[0] // bs, shape[1] // bs
        n = count
        safe = np.maximum(n, 1.0)
        m1 = s1 / safe[:, None]
        cov = (s2 - safe[:, None, None] * m1[:, :, None] * m1[:, None, :])
        cov /= np.maximum(n - 1.0, 1.0)[:, None, None]
        cov = 0.5 * (cov + cov.transpose(0, 2, 1))
        lam, vec = np.linalg.eigh(cov)  # ascending, batched over blocks
        lam = np.clip(lam[:, ::-1], 0.0, None)
        vec = vec[:, :, ::-1]
        total = lam.sum(axis=1)
        cum = np.cumsum(lam, axis=1) / np.where(total > 0, total, 1.0)[:, None]
        # eq. 1: smallest D with q(D) >= threshold (a tiny tolerance for round-off at q = 1)
        dims = 1 + np.argmax(cum >= float(self.threshold_q) - 1e-12, axis=1)
        dims = np.where(total > 0, dims, 1)
        trained = (n >= int(self.min_samples)) & (n >= dims + 2)
        if not trained.any():
            raise ValueError(
                f"block eigenspace: none of the {len(trained)} blocks ({rows}x{cols} of "
                f"{bs}x{bs} px) has enough background samples: {int(n_frames)} training "
                f"frame(s) gave at most {int(n.max())} per block, and a block needs "
                f"max(min_samples={int(self.min_samples)}, D + 2) (D = its eigenspace "
                f"dimension, up to {int(dims.max())} here); give more background frames or "
                "lower min_samples")
        dims = np.where(trained, dims, 0)
        dmax = max(int(dims.max()), 1)
        keep = np.arange(dmax)[None, :] < dims[:, None]  # (B, Dmax)
        self.mean_ = np.where(trained[:, None], ref + m1, 0.0)
        self.components_ = np.ascontiguousarray(vec[:, :, :dmax] * keep[:, None, :])
        self.eigenvalues_ = np.where(keep, np.maximum(lam[:, :dmax],
                                                      float(self.min_eigenvalue)), 0.0)
        self.dims_ = dims.astype(np.int64)
        self.n_samples_ = n.astype(np.int64)
        self.source_ = np.arange(len(trained))
        if self.untrained == "nearest" and trained.any() and not trained.all():
            from scipy import ndimage

            _, (ri, ci) = ndimage.distance_transform_edt(~trained.reshape(rows, cols),
                                                         return_indices=True)
            src = (ri * cols + ci).ravel()
            self.mean_, self.components_ = self.mean_[src], self.components_[src]
            self.eigenvalues_, self.dims_ = self.eigenvalues_[src], self.dims_[src]
            self.source_ = src
        self.v_ = np.where(self.dims_ <= int(self.d_split), float(self.v_low),
                           float(self.v_high))
        self.trained_ = self.dims_ > 0  # blocks with an eigenspace, their own or borrowed
        self.grid_shape_ = (rows, cols)
        self.image_shape_ = (int(shape[0]), int(shape[1]))
        self.n_frames_ = int(n_frames)
        self._prepare()
        untrained = np.flatnonzero(~trained)
        self.untrained_blocks_ = np.stack(np.divmod(untrained, cols), axis=1).astype(np.int64)
        if len(untrained):
            fate = ("use the nearest trained block's mean and eigenspace"
                    if self.untrained == "nearest" else "are never intruders")
            warnings.warn(
                f"block eigenspace: {len(untrained)} of {len(trained)} blocks have fewer than "
                f"max(min_samples={int(self.min_samples)}, D + 2) background samples in "
                f"{int(n_frames)} training frames and {fate} (untrained={self.untrained!r}); "
                f"(row, col): {_block_list(self.untrained_blocks_)}; untrained_picture() "
                "draws them", stacklevel=3)

    def follow(self, x: np.ndarray, projections: np.ndarray, blocks: np.ndarray,
               rate: float) -> None:
        """Move the means of ``blocks`` (B,) bool ``rate`` of the way towards a frame's block
        vectors ``x`` (B, P), given their whitened projections (``projections`` of
        :meth:`score_grey`): ``W^T mean`` follows linearly, so no product over the pixels is
        needed. The eigenspaces stay."""
        self._fitted()
        b = np.asarray(blocks, bool) & self.trained_
        r = float(rate)
        self.mean_[b] += r * (x[b] - self.mean_[b])
        self.offset_[b] += r * (projections[b] - self.offset_[b])
        self.groups_ = [(idx, w, np.ascontiguousarray(self.offset_[idx, :w.shape[2]]))
                        for idx, w, _ in self.groups_]

    def rebaseline(self, delta: np.ndarray) -> None:
        """Shift every block's mean by ``delta`` (B, P) grey levels (or (B, 1): one level per
        block), keeping its eigenspace: after a camera recalibration the background's noise is
        the same, only its per-pixel offsets moved. The scoring operators follow."""
        self._fitted()
        d = np.asarray(delta, dtype=np.float64)
        if d.ndim != 2 or d.shape[0] != self.mean_.shape[0] or \
                d.shape[1] not in (1, self.mean_.shape[1]):
            raise ValueError(f"rebaseline: delta of shape {d.shape}, expected "
                             f"({self.mean_.shape[0]}, {self.mean_.shape[1]}) or "
                             f"({self.mean_.shape[0]}, 1)")
        self.mean_ = np.where(self.trained_[:, None], self.mean_ + d, self.mean_)
        # the whitened components stay: only W^T mean changes
        self.offset_ = np.einsum("bpd,bp->bd", self.whiten_, self.mean_)
        self.groups_ = [(idx, w, np.ascontiguousarray(self.offset_[idx, :w.shape[2]]))
                        for idx, w, _ in self.groups_]

    def _prepare(self) -> None:
        """Scoring operators: whitened components W = E / sqrt(lambda) / sqrt(D), so that
        r_D = |W^T x - W^T mean|² (eq. 3), as (B, P, Dmax) for one batched product (the
        (B, 1, P) @ (B, P, Dmax) orientation is the faster of the two with NumPy's matmul)."""
        dims = np.maximum(self.dims_, 1).astype(np.float64)
        inv = np.where(self.eigenvalues_ > 0, 1.0 / np.sqrt(np.where(
            self.eigenvalues_ > 0, self.eigenvalues_, 1.0)), 0.0) / np.sqrt(dims)[:, None]
        w = self.components_ * inv[:, None, :]
        self.whiten_ = np.ascontiguousarray(w)  # (B, P, Dmax)
        self.offset_ = np.einsum("bpd,bp->bd", self.whiten_, self.mean_)
        # scoring a whole frame: the blocks grouped by their dimension D, one batched product
        # per group over its first D columns only (a few groups, not a loop over blocks; the
        # columns beyond D are zero): 1.7x faster than one product with Dmax columns on PETS
        self.groups_ = []
        for d in np.unique(self.dims_):
            idx = np.flatnonzero(self.dims_ == d)
            k = max(int(d), 1)
            self.groups_.append((idx, np.ascontiguousarray(self.whiten_[idx, :, :k]),
                                 np.ascontiguousarray(self.offset_[idx, :k])))

    # -- scoring ------------------------------------------------------------------------------

    def _fitted(self) -> None:
        if not hasattr(self, "whiten_"):
            raise ValueError("BlockEigenspaceModel: not fitted; call fit() or load() first")

    def relative_variation(self, image: np.ndarray) -> np.ndarray:
        """r_D(s) (eq. 3) of every block of a frame, as a (rows, cols) float64 grid; 0 for
        untrained blocks."""
        self._fitted()
        grey = self._grey(image)
        if grey.shape != self.image_shape_:
            raise ValueError(f"frame of {grey.shape[1]}x{grey.shape[0]} px, the model was "
                             f"trained on {self.image_shape_[1]}x{self.image_shape_[0]} px")
        return self.relative_variation_of_grey(grey).reshape(self.grid_shape_)

    def relative_variation_of_grey(self, grey: np.ndarray,
                                   projections: np.ndarray | None = None) -> np.ndarray:
        """r_D of every block of a grey frame (:meth:`grey`), flat (rows * cols,): one batched
        product per group of blocks of equal D. ``projections``, a (B, Dmax) array, receives
        each block's whitened projection ``W^T x`` (zero beyond its D) when given."""
        x = blocks_of(grey, int(self.block_size))
        out = np.empty(len(x))
        for idx, w, o in self.groups_:
            p = np.matmul(x[idx][:, None, :], w)[:, 0, :]  # (B_d, D)
            if projections is not None:
                projections[idx, : p.shape[1]] = p
            s = p - o
            out[idx] = np.einsum("bd,bd->b", s, s)
        return out

    def relative_variation_at(self, grey: np.ndarray, blocks: np.ndarray) -> np.ndarray:
        """r_D (eq. 3) of only the blocks ``blocks`` (K,) (indices ``row * cols + col``) of a
        grey frame (:meth:`grey`, or its integer levels before the conversion), as (K,)
        float64; 0 for untrained blocks. One batched product over the K blocks: what a
        particle likelihood needs when particles touch few blocks."""
        self._fitted()
        b = np.asarray(blocks, dtype=np.intp).reshape(-1)
        bs = int(self.block_size)
        cols = self.grid_shape_[1]
        gather = _gather_kernel(grey)
        rows = self.grid_shape_[0]
        if gather is not None and len(b) and 0 <= b.min() and b.max() < rows * cols and \
                grey.shape[0] >= rows * bs and grey.shape[1] >= cols * bs:
            # the same pixels, copied in one compiled pass
            x = np.empty((len(b), bs * bs))
            gather(grey, np.ascontiguousarray(b), bs, cols, x)
        else:
            r, c = np.divmod(b, cols)
            ys = r[:, None] * bs + np.arange(bs)[None, :]  # (K, bs) rows of each block
            xs = c[:, None] * bs + np.arange(bs)[None, :]
            # (an integer grey frame, see EigenspaceLikelihood.begin_frame: its float64 values)
            x = grey[ys[:, :, None], xs[:, None, :]].reshape(len(b), bs * bs).astype(
                np.float64, copy=False)
        s = np.matmul(x[:, None, :], self.whiten_[b])[:, 0, :] - self.offset_[b]
        return np.einsum("bd,bd->b", s, s)

    def grey(self, image: np.ndarray) -> np.ndarray:
        """A frame as the float64 grey levels the model scores (``frame_offset`` applied),
        checked against the training size."""
        self._fitted()
        grey = self._grey(image)
        if grey.shape != self.image_shape_:
            raise ValueError(f"frame of {grey.shape[1]}x{grey.shape[0]} px, the model was "
                             f"trained on {self.image_shape_[1]}x{self.image_shape_[0]} px")
        return grey

    def score(self, image: np.ndarray) -> EigenspaceResult:
        """r_D map, intruder blocks and their boxes in one frame (see :class:`EigenspaceResult`)."""
        return self.score_grey(self.grey(image))

    def score_grey(self, grey: np.ndarray,
                   projections: np.ndarray | None = None) -> EigenspaceResult:
        """:meth:`score` of a grey frame already converted by :meth:`grey`; ``projections``
        as in :meth:`relative_variation_of_grey`."""
        r = self.relative_variation_of_grey(grey, projections).reshape(self.grid_shape_)
        trained = self.trained_.reshape(self.grid_shape_)
        excess = np.where(trained, r - self.v_.reshape(self.grid_shape_), -np.inf)
        mask = excess > 0
        boxes, scores = components_to_boxes(mask, excess, int(self.block_size))
        return EigenspaceResult(r, excess, mask, boxes, scores)

    # -- description and files ----------------------------------------------------------------

    def describe(self) -> dict[str, Any]:
        """Parameters and a summary of what was learnt (JSON-serialisable)."""
        out: dict[str, Any] = {"format": MODEL_FORMAT, "version": MODEL_VERSION,
                               **self.params()}
        if hasattr(self, "dims_"):
            d = self.dims_[self.trained_]
            out.update({
                "image_hw": list(self.image_shape_), "grid_rows_cols": list(self.grid_shape_),
                "n_frames": int(self.n_frames_), "n_blocks": len(self.dims_),
                "n_untrained": len(self.untrained_blocks_),
                "n_borrowed": int((self.source_ != np.arange(len(self.source_))).sum()),
                "dims_min": int(d.min()) if len(d) else 0,
                "dims_median": float(np.median(d)) if len(d) else 0.0,
                "dims_max": int(d.max()) if len(d) else 0})
        return out

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the model to ``path`` (``.npz`` of arrays and a JSON parameter string, no
        pickle), atomically."""
        from pftrack.io.atomic import atomic_path

        self._fitted()
        path = Path(path)
        if path.suffix != ".npz":
            raise ValueError(f"eigenspace model {path}: the file name must end in .npz")
        params = {**self.describe(), "n_frames": int(self.n_frames_)}
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, params=np.array(json.dumps(params)), mean=self.mean_,
                     components=self.components_, eigenvalues=self.eigenvalues_,
                     dims=self.dims_, n_samples=self.n_samples_, source=self.source_)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> BlockEigenspaceModel:
        """Read and validate a model written by :meth:`save`.

        Raises
        ------
        FileNotFoundError
            No such file.
        ValueError
            Not such a model, or arrays inconsistent with its parameters; the message names
            the file.
        """
        import zipfile

        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"eigenspace model {path} not found")
        if not zipfile.is_zipfile(path):
            raise ValueError(f"eigenspace model {path}: not an .npz file")
        names = ("mean", "components", "eigenvalues", "dims", "n_samples")
        try:
            with np.load(path, allow_pickle=False) as z:
                missing = [k for k in ("params", *names) if k not in z.files]
                if missing:
                    raise ValueError(f"eigenspace model {path}: missing arrays {missing}")
                params = json.loads(str(z["params"]))
                arrays = {k: np.asarray(z[k]) for k in names}
                source = np.asarray(z["source"]) if "source" in z.files else None
        except ValueError as exc:
            if str(path) in str(exc):
                raise
            raise ValueError(f"eigenspace model {path}: not a readable model ({exc})") from None
        except (OSError, EOFError, zipfile.BadZipFile, KeyError) as exc:
            raise ValueError(f"eigenspace model {path}: not a readable model ({exc})") from None
        if not isinstance(params, dict) or params.get("format") != MODEL_FORMAT:
            got = params.get("format") if isinstance(params, dict) else params
            raise ValueError(f"eigenspace model {path}: format {got!r}, expected "
                             f"{MODEL_FORMAT!r}")
        if int(params.get("version", -1)) > MODEL_VERSION:
            raise ValueError(f"eigenspace model {path}: version {params.get('version')} is newer "
                             f"than this pftrack reads ({MODEL_VERSION})")
        try:
            model = cls(**{k: params[k] for k in cls().params()})
            model._check_params()
            h, w = (int(v) for v in params["image_hw"])
            rows, cols = (int(v) for v in params["grid_rows_cols"])
            n_frames = int(params["n_frames"])
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"eigenspace model {path}: bad parameters ({exc})") from None
        bs = int(model.block_size)
        B, P = rows * cols, bs * bs
        mean, comp, lam = arrays["mean"], arrays["components"], arrays["eigenvalues"]
        dims, n = arrays["dims"], arrays["n_samples"]
        dmax = comp.shape[2] if comp.ndim == 3 else -1
        ok = (rows == h // bs and cols == w // bs and mean.shape == (B, P)
              and comp.shape[:2] == (B, P) and lam.shape == (B, dmax) and dims.shape == (B,)
              and n.shape == (B,) and all(a.dtype.kind == "f" for a in (mean, comp, lam))
              and dims.dtype.kind in "iu" and n.dtype.kind in "iu"
              and all(np.all(np.isfinite(a)) for a in (mean, comp, lam))
              and bool(np.all((dims >= 0) & (dims <= dmax))))
        if not ok:
            raise ValueError(f"eigenspace model {path}: arrays do not fit a {rows}x{cols} grid of "
                             f"{bs}x{bs} blocks (mean {mean.shape}, components {comp.shape}, "
                             f"eigenvalues {lam.shape}, dims {dims.shape}) or are not finite")
        model.mean_ = mean.astype(np.float64)
        model.components_ = np.ascontiguousarray(comp, dtype=np.float64)
        model.eigenvalues_ = lam.astype(np.float64)
        model.dims_ = dims.astype(np.int64)
        model.n_samples_ = n.astype(np.int64)
        model.trained_ = model.dims_ > 0
        own = np.arange(B)
        if source is None:
            source = own
        if source.shape != (B,) or source.dtype.kind not in "iu" or \
                not bool(np.all((source >= 0) & (source < B))):
            raise ValueError(f"eigenspace model {path}: the source array does not index the "
                             f"{B} blocks")
        model.source_ = source.astype(np.intp)
        model.v_ = np.where(model.dims_ <= int(model.d_split), float(model.v_low),
                            float(model.v_high))
        model.grid_shape_ = (rows, cols)
        model.image_shape_ = (h, w)
        model.n_frames_ = n_frames
        untrained = np.flatnonzero(~model.trained_ | (model.source_ != own))
        model.untrained_blocks_ = np.stack(np.divmod(untrained, cols), axis=1).astype(np.int64)
        model._prepare()
        return model


def _block_list(blocks: np.ndarray, most: int = 12) -> str:
    """'(r, c), (r, c), ...' of up to ``most`` (row, col) pairs, '... and N more' after."""
    pairs = [f"({int(r)}, {int(c)})" for r, c in np.asarray(blocks).reshape(-1, 2)[:most]]
    more = len(blocks) - most
    return ", ".join(pairs) + (f" and {more} more" if more > 0 else "")


def untrained_picture(model: BlockEigenspaceModel, path: str | os.PathLike[str],
                      image: np.ndarray | None = None, scale: int = 4) -> Path:
    """Draw where a fitted model's untrained blocks are, as a PNG written atomically.

    The picture is ``image`` (any frame of the training size; grey levels stretched between
    their 1st and 99th percentiles) or mid-grey, enlarged ``scale`` times; blocks without
    enough background samples of their own are filled red (half transparent) and outlined,
    and a caption gives their count and the rule they are judged by (``untrained``).
    """
    import cv2
    from pftrack.io.atomic import atomic_path

    model._fitted()
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"untrained_picture {path}: the file name must end in .png")
    h, w = model.image_shape_
    if image is None:
        grey = np.full((h, w), 128, np.uint8)
    else:
        g = to_grey(image)
        if g.shape != (h, w):
            raise ValueError(f"untrained_picture: image of {g.shape[1]}x{g.shape[0]} px, the "
                             f"model was trained on {w}x{h} px")
        lo, hi = np.percentile(g, [1, 99])
        grey = np.clip((g - lo) / max(hi - lo, 1e-9) * 255.0, 0, 255).astype(np.uint8)
    k = max(int(scale), 1)
    bs = int(model.block_size) * k
    img = cv2.cvtColor(cv2.resize(grey, (w * k, h * k), interpolation=cv2.INTER_NEAREST),
                       cv2.COLOR_GRAY2BGR)
    over = img.copy()
    for r, c in model.untrained_blocks_:  # drawing a handful of rectangles, not a hot path
        cv2.rectangle(over, (int(c) * bs, int(r) * bs), ((int(c) + 1) * bs - 1,
                      (int(r) + 1) * bs - 1), (0, 0, 255), -1)
    img = cv2.addWeighted(over, 0.45, img, 0.55, 0.0)
    for r, c in model.untrained_blocks_:
        cv2.rectangle(img, (int(c) * bs, int(r) * bs), ((int(c) + 1) * bs - 1,
                      (int(r) + 1) * bs - 1), (0, 0, 255), 1)
    caption = (f"{len(model.untrained_blocks_)} of {len(model.dims_)} blocks untrained "
               f"({model.untrained})")
    bar = np.zeros((18, img.shape[1], 3), np.uint8)
    cv2.putText(bar, caption, (3, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1)
    with atomic_path(path) as tmp:
        ok, buf = cv2.imencode(".png", np.vstack([img, bar]))
        if not ok:
            raise ValueError(f"untrained_picture {path}: PNG encoding failed")
        Path(tmp).write_bytes(buf.tobytes())
    return path


def fit_model(frames: Sequence[np.ndarray], masks: Sequence[np.ndarray | None] | None = None,
              **params: Any) -> BlockEigenspaceModel:
    """``BlockEigenspaceModel(**params).fit(frames, masks)``."""
    return BlockEigenspaceModel(**params).fit(frames, masks)
