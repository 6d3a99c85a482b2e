"""Uncertainty ellipses: the outline of a 2-D Gaussian's ``k``-standard-deviation contour,
for the tracks' ground covariance (top view) and their image-box spread (overlays).

A 2 sd ellipse of a Gaussian holds ``1 - exp(-2)`` (86 %) of its mass; 1 sd holds 39 %.
"""

from __future__ import annotations

import numpy as np

__all__ = ["covariance_ellipses"]


def covariance_ellipses(centres: np.ndarray, covariances: np.ndarray, k: float = 2.0,
                        n_points: int = 48) -> np.ndarray:
    """Closed outlines (M, n_points + 1, 2) of the ``k``-sd ellipses of M Gaussians.

    Parameters
    ----------
    centres : ndarray, shape (M, 2)
    covariances : ndarray, shape (M, 2, 2)
        Symmetric positive semi-definite (a tiny negative eigenvalue from rounding reads as 0).
    k : float
        Standard deviations along each principal axis. Unit: 1.
    n_points : int
        Points per outline (the first repeated at the end).

    Returns
    -------
    ndarray, shape (M, n_points + 1, 2)
        NaN rows for a centre or covariance that is not finite.
    """
    c = np.asarray(centres, dtype=np.float64).reshape(-1, 2)
    cov = np.asarray(covariances, dtype=np.float64).reshape(-1, 2, 2)
    if len(c) != len(cov):
        raise ValueError(f"covariance_ellipses: {len(c)} centres but {len(cov)} covariances")
    ok = np.isfinite(c).all(axis=1) & np.isfinite(cov).all(axis=(1, 2))
    out = np.full((len(c), n_points + 1, 2), np.nan)
    if not ok.any():
        return out
    sym = 0.5 * (cov[ok] + cov[ok].transpose(0, 2, 1))
    vals, vecs = np.linalg.eigh(sym)  # (m, 2), (m, 2, 2): columns are the axes
    radii = k * np.sqrt(np.clip(vals, 0.0, None))
    t = np.linspace(0.0, 2.0 * np.pi, n_points + 1)
    unit = np.stack([np.cos(t), np.sin(t)], axis=1)  # (P, 2)
    # point = centre + V diag(r) u
    out[ok] = c[ok][:, None, :] + np.einsum("mij,mj,pj->mpi", vecs, radii, unit)
    return out
