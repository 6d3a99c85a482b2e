"""Lens distortion models of :class:`pftrack.geometry.camera.Camera`, on normalised image
coordinates (dimensionless, shape (N, 2)): :class:`NoDistortion`, :class:`OpenCVDistortion`
and :class:`TsaiDistortion` (the models are described in :mod:`pftrack.geometry.camera`), and
:func:`distortion_from_dict` that builds one from a camera file's ``distortion`` entry.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np


class LensDistortion(ABC):
    """A lens model acting on normalised image coordinates (dimensionless, shape (N, 2))."""

    model: ClassVar[str] = ""

    @abstractmethod
    def distort(self, xy_u: np.ndarray) -> np.ndarray:
        """Ideal (undistorted) normalised points (N, 2) -> distorted normalised points (N, 2)."""

    @abstractmethod
    def undistort(self, xy_d: np.ndarray) -> np.ndarray:
        """Distorted normalised points (N, 2) -> ideal normalised points (N, 2)."""

    @abstractmethod
    def params(self) -> dict[str, float]:
        """The coefficients by name (dimensionless, on normalised coordinates)."""

    def edge_scale(self, xy_u: np.ndarray) -> np.ndarray | None:
        """The radial scale (distorted radius over undistorted radius) at the edge of the
        field where :meth:`distort` has a value, along the direction of each ideal point
        (N, 2), when the model knows it in closed form; None: it does not (a caller finds the
        edge by bisection)."""
        return None

    @property
    def is_identity(self) -> bool:
        return all(v == 0.0 for v in self.params().values())

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model, **{k: float(v) for k, v in self.params().items()}}

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, LensDistortion) and self.model == other.model
                and self.params() == other.params())

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v:.6g}" for k, v in self.params().items())
        return f"{type(self).__name__}({args})"


class NoDistortion(LensDistortion):
    """An ideal pinhole: no distortion."""

    model = "none"

    def distort(self, xy_u: np.ndarray) -> np.ndarray:
        return np.array(xy_u, dtype=np.float64, copy=True)

    def undistort(self, xy_d: np.ndarray) -> np.ndarray:
        return np.array(xy_d, dtype=np.float64, copy=True)

    def params(self) -> dict[str, float]:
        return {}


class OpenCVDistortion(LensDistortion):
    """OpenCV's lens model: radial k1, k2, k3 (and rational k4, k5, k6), tangential p1, p2.

    ``x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6)
    + 2 p1 x y + p2 (r^2 + 2 x^2)`` and likewise for y, with (x, y) the undistorted normalised
    point. Coefficient order is OpenCV's ``distCoeffs``.
    """

    model = "opencv"
    names = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")

    def __init__(self, k1: float = 0.0, k2: float = 0.0, p1: float = 0.0, p2: float = 0.0,
                 k3: float = 0.0, k4: float = 0.0, k5: float = 0.0, k6: float = 0.0):
        self.k1, self.k2, self.p1, self.p2 = float(k1), float(k2), float(p1), float(p2)
        self.k3, self.k4, self.k5, self.k6 = float(k3), float(k4), float(k5), float(k6)

    @classmethod
    def from_coeffs(cls, coeffs: Sequence[float] | np.ndarray) -> OpenCVDistortion:
        """From OpenCV's ``distCoeffs`` (4, 5 or 8 numbers)."""
        c = np.asarray(coeffs, dtype=np.float64).ravel()
        if c.size not in (4, 5, 8):
            raise ValueError(f"OpenCV distortion: expected 4, 5 or 8 coefficients, got {c.size} "
                             "(thin-prism and tilted models are not supported)")
        return cls(*c.tolist())

    @property
    def coeffs(self) -> np.ndarray:
        """OpenCV ``distCoeffs``: 5 numbers, or 8 when the rational terms are used."""
        full = np.array([getattr(self, n) for n in self.names])
        return full if np.any(full[5:] != 0) else full[:5]

    def params(self) -> dict[str, float]:
        return {n: getattr(self, n) for n in self.names[: self.coeffs.size]}

    def distort(self, xy_u: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy_u, dtype=np.float64)
        x, y = xy[:, 0], xy[:, 1]
        r2 = x * x + y * y
        radial = (1 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))) / (
            1 + r2 * (self.k4 + r2 * (self.k5 + r2 * self.k6)))
        xd = x * radial + 2 * self.p1 * x * y + self.p2 * (r2 + 2 * x * x)
        yd = y * radial + self.p1 * (r2 + 2 * y * y) + 2 * self.p2 * x * y
        out = np.stack([xd, yd], axis=1)
        out[r2 > self.max_radius**2] = np.nan
        return out

    @property
    def max_radius(self) -> float:
        """Undistorted normalised radius up to which the radial map r -> r * radial(r) rises.

        Beyond it a polynomial lens folds back (with k1 < 0, points far outside the field of
        view would land inside the image), so :meth:`distort` returns NaN there. Searched up to
        r = 20 (87 degrees off axis); ``inf`` when the map rises all the way.
        """
        key = tuple(self.params().values())
        cached = getattr(self, "_max_radius_cache", None)
        if cached is not None and cached[0] == key:
            return cached[1]
        r = np.linspace(0.0, 20.0, 20001)
        r2 = r * r
        num = 1 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))
        den = 1 + r2 * (self.k4 + r2 * (self.k5 + r2 * self.k6))
        rd = r * num / den
        bad = (np.diff(rd) <= 0) | (den[1:] <= 0) | (num[1:] <= 0)
        limit = float(r[np.argmax(bad)]) if bad.any() else math.inf
        self._max_radius_cache = (key, limit)
        return limit

    def undistort(self, xy_d: np.ndarray) -> np.ndarray:
        import cv2

        xy = np.asarray(xy_d, dtype=np.float64)
        if xy.shape[0] == 0 or self.is_identity:
            return xy.copy()
        out = np.full_like(xy, np.nan)
        ok = np.all(np.isfinite(xy), axis=1)
        if ok.any():
            crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15)
            und = cv2.undistortPointsIter(xy[ok].reshape(-1, 1, 2), np.eye(3), self.coeffs,  # type: ignore[call-overload]
                                          None, None, crit)
            out[ok] = und.reshape(-1, 2)
        return out


class TsaiDistortion(LensDistortion):
    """Tsai's one-coefficient radial model on normalised coordinates.

    ``x_u = x_d (1 + kappa1 r_d^2)``, ``r_d^2 = x_d^2 + y_d^2``: the undistorted point is a
    closed-form function of the distorted one; the forward direction solves
    ``kappa1 r_d^3 + r_d - r_u = 0`` (smallest positive root) by Newton's method, vectorised.
    Tsai's kappa1 on the sensor in mm^-2 equals ``kappa1 / f_mm**2`` of this one.
    """

    model = "tsai"

    def __init__(self, kappa1: float = 0.0):
        self.kappa1 = float(kappa1)

    def params(self) -> dict[str, float]:
        return {"kappa1": self.kappa1}

    def undistort(self, xy_d: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy_d, dtype=np.float64)
        r2 = np.sum(xy * xy, axis=1, keepdims=True)
        return xy * (1.0 + self.kappa1 * r2)

    def edge_scale(self, xy_u: np.ndarray) -> np.ndarray | None:
        """With ``kappa1 < 0`` the field ends where ``r_u = r_d (1 + kappa1 r_d^2)`` stops
        growing, at ``r_d = 1 / sqrt(-3 kappa1)`` and ``r_u = 2/3`` of that, in every
        direction: the scale there is exactly 3/2. With ``kappa1 >= 0`` the field has no edge
        (None)."""
        if self.kappa1 >= 0:
            return None
        return np.full(len(np.asarray(xy_u)), 1.5)

    def distort(self, xy_u: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy_u, dtype=np.float64)
        k = self.kappa1
        if k == 0.0 or xy.shape[0] == 0:
            return xy.copy()
        ru = np.hypot(xy[:, 0], xy[:, 1])
        rd = ru.copy()
        tol = 1e-15 * (1 + ru)
        # Newton on f(r) = k r^3 + r - ru from r = ru: monotone convergence for k > 0; for k < 0
        # it climbs to the smaller root, which exists only if ru <= 2 / (3 sqrt(-3k)). Stops
        # when every finite step is within tol (NaN / inf steps are ignored): one pass over the
        # steps instead of masked copies (the same iterations, the same numbers)
        for _ in range(60):
            f = k * (rd * rd * rd) + rd - ru
            step = f / (3 * k * rd * rd + 1)
            rd = rd - step
            a = np.abs(step)
            with np.errstate(invalid="ignore"):
                if not ((a > tol) & (a < np.inf)).any():
                    break
        bad = ~np.isfinite(rd) | (np.abs(k * (rd * rd * rd) + rd - ru) > 1e-9 * (1 + ru))
        if k < 0:
            bad |= 3 * k * rd * rd + 1 <= 0  # beyond the fold: not the physical root
        scale = np.where(ru > 0, rd / np.where(ru > 0, ru, 1.0), 1.0)
        scale[bad] = np.nan
        return xy * scale[:, None]


def distortion_from_dict(d: dict[str, Any] | None) -> LensDistortion:
    """Build a lens model from ``{"model": "opencv"|"tsai"|"none", <coefficients>}``."""
    if not d:
        return NoDistortion()
    d = dict(d)
    model = str(d.pop("model", "none")).lower()
    try:
        if model in ("none", "pinhole"):
            return NoDistortion()
        if model == "opencv":
            return OpenCVDistortion(**{k: float(v) for k, v in d.items()})
        if model == "tsai":
            return TsaiDistortion(**{k: float(v) for k, v in d.items()})
    except TypeError as exc:
        raise ValueError(f"distortion model {model!r}: bad coefficients {sorted(d)}: "
                         f"{exc}") from exc
    raise ValueError(f"unknown distortion model {model!r} (known: none, opencv, tsai)")
