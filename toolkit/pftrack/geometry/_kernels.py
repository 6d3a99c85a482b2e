"""numba kernels of :mod:`pftrack.geometry.camera` (this module imports numba; the camera
imports it on first use of :meth:`~pftrack.geometry.camera.Camera.project_rows`).

:func:`camera_to_pixels_rows` is :meth:`Camera.project`'s arithmetic after the rotation (the
perspective division, Tsai's lens by Newton's method or OpenCV's polynomial one, the pixel
mapping) for T independent calls
at once, one pass per call: each row gives the numbers ``project`` gives for it alone, bit for
bit. The same operations in the same order (no fast-math: no fused multiply-add; the cube
``rd * rd * rd`` as two products in both, not ``pow``, whose libm and numpy SIMD loops may
differ and which cost most of the kernel's time; checked at first use, see
:func:`pftrack.geometry.camera._rows_kernel`), and Newton's stopping rule per row: a row
iterates until no finite step of any of its points exceeds its tolerance (numpy's vectorised
loop over the whole call). A point whose step is exactly 0 (or NaN) is at a fixed point: it
would be recomputed to the same value, so it is skipped, which is where the time goes.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_JIT = {"cache": True, "nogil": True}


@njit(**_JIT)  # type: ignore[call-overload]
def camera_to_pixels_rows(pc, kappa, opencv, k00, k01, k02, k11, k12, out, rd, ru, fr,
                          live):  # pragma: no cover - compiled
    """Camera-frame points ``pc`` (T, N, 3) -> pixels ``out`` (T, N, 2), NaN at or behind the
    centre plane; ``kappa`` Tsai's kappa1 on normalised coordinates (0: no lens), or
    ``opencv`` (None: not) OpenCV's k1, k2, p1, p2, k3, k4, k5, k6 and the squared radius
    beyond which the lens folds back (NaN there). ``rd``,
    ``ru``, ``fr`` (N,) float64 and ``live`` (N,) bool are work arrays."""
    n_rows, n = pc.shape[0], pc.shape[1]
    k = kappa
    k3 = 3 * k
    for t in range(n_rows):
        # perspective division: xy = pc[:, :2] / where(z > 1e-9, z, 1.0)
        for i in range(n):
            z = pc[t, i, 2]
            zs = z if z > 1e-9 else 1.0
            out[t, i, 0] = pc[t, i, 0] / zs
            out[t, i, 1] = pc[t, i, 1] / zs
        if k != 0.0 and n > 0:
            for i in range(n):
                r = math.hypot(out[t, i, 0], out[t, i, 1])
                ru[i] = r
                rd[i] = r
                live[i] = True
            for _ in range(60):
                active = False
                for i in range(n):
                    if not live[i]:
                        continue
                    r = rd[i]
                    f = k * (r * r * r) + r - ru[i]
                    step = f / (k3 * r * r + 1)
                    r = r - step
                    rd[i] = r
                    a = abs(step)
                    if a > 1e-15 * (1 + ru[i]) and a < np.inf:
                        active = True
                    if step == 0.0 or r != r:  # a fixed point (or NaN): stays as it is
                        live[i] = False
                        fr[i] = f  # the residual at it (the final check's, same numbers)
                if not active:
                    break
            for i in range(n):
                r, u = rd[i], ru[i]
                res = k * (r * r * r) + r - u if live[i] else fr[i]
                bad = not np.isfinite(r) or abs(res) > 1e-9 * (1 + u)
                if k < 0:
                    bad = bad or k3 * r * r + 1 <= 0
                scale = r / u if u > 0 else 1.0
                if bad:
                    scale = np.nan
                out[t, i, 0] = out[t, i, 0] * scale
                out[t, i, 1] = out[t, i, 1] * scale
        if opencv is not None:  # OpenCVDistortion.distort's closed form, its order of operations
            k1, k2, p1, p2, k3, k4, k5, k6, max_r2 = (opencv[0], opencv[1], opencv[2], opencv[3],
                                                      opencv[4], opencv[5], opencv[6], opencv[7],
                                                      opencv[8])
            p1x2, p2x2 = 2 * p1, 2 * p2
            for i in range(n):
                x, y = out[t, i, 0], out[t, i, 1]
                r2 = x * x + y * y
                radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (
                    1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
                xd = x * radial + p1x2 * x * y + p2 * (r2 + 2 * x * x)
                yd = y * radial + p1 * (r2 + 2 * y * y) + p2x2 * x * y
                if r2 > max_r2:
                    xd = yd = np.nan
                out[t, i, 0] = xd
                out[t, i, 1] = yd
        for i in range(n):
            xd, yd = out[t, i, 0], out[t, i, 1]
            if pc[t, i, 2] > 1e-9:
                out[t, i, 0] = k00 * xd + k01 * yd + k02
                out[t, i, 1] = k11 * yd + k12
            else:
                out[t, i, 0] = np.nan
                out[t, i, 1] = np.nan
