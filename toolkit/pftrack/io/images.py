"""Pictures to PNG, the one home of it: encoded in memory (for a notebook's ``Image``) or written
atomically to a file.

OpenCV encodes arrays (BGR channel order, as OpenCV reads and draws them); a picture in RGB
order (pyvista's screenshots) is written as ``write_png(path, image_rgb[:, :, ::-1])``.
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Any

import numpy as np

from pftrack.io.atomic import atomic_write_bytes

__all__ = ["figure_png", "png_bytes", "write_png"]


def png_bytes(image_bgr: np.ndarray) -> bytes:
    """PNG encoding of an image.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3) or (H, W), uint8 (or uint16)
        BGR (OpenCV's order) or single-channel.

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        When OpenCV cannot encode the array (its shape and dtype are named).
    """
    import cv2

    img = np.ascontiguousarray(image_bgr)
    try:
        ok, buf = cv2.imencode(".png", img)
    except cv2.error:
        ok = False
    if not ok:
        raise ValueError(f"png_bytes: OpenCV could not encode an array of shape {img.shape}, "
                         f"dtype {img.dtype} as PNG")
    return buf.tobytes()


def write_png(path: str | os.PathLike[str], image_bgr: np.ndarray) -> Path:
    """Write an image (see :func:`png_bytes`) as a PNG file, atomically.

    Raises
    ------
    ValueError
        When ``path`` does not end in ``.png`` or the image cannot be encoded (naming ``path``).
    """
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"{path}: the output must be a .png file")
    try:
        data = png_bytes(image_bgr)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    return atomic_write_bytes(path, data)


def figure_png(fig: Any, dpi: int = 90, *, tight: bool = False) -> bytes:
    """A matplotlib figure as PNG bytes (``bbox_inches="tight"`` when ``tight``); the figure is
    closed afterwards."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", dpi=dpi, **({"bbox_inches": "tight"} if tight else {}))
    finally:
        plt.close(fig)
    return buf.getvalue()
