"""Off-screen pyvista set-up shared by the renderers: EGL, a fixed theme, plotters closed.

Importing this module sets ``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow`` and
``PYVISTA_OFF_SCREEN=true`` (unless already set) *before* pyvista is imported, so no display is
ever needed. Every plotter gets its own copy of the fixed theme (no global theme is touched, so
no render state leaks between calls or tests) and is closed in ``finally``.
"""

from __future__ import annotations

import os

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")

from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pyvista as pv

__all__ = ["plotter", "polyline_cells", "pv", "screenshot", "segment_cells", "theme"]

BACKGROUND = "white"
FOREGROUND = "black"
FONT_FAMILY = "arial"


def theme() -> pv.themes.Theme:
    """A fresh copy of the fixed report theme (white background, black text, no anti-aliasing
    so the pixels do not depend on the GPU's multisampling)."""
    t = pv.themes.DocumentTheme()
    t.background = BACKGROUND
    t.font.color = FOREGROUND
    t.font.family = FONT_FAMILY
    t.font.size = 12
    t.font.label_size = 10
    t.font.title_size = 12
    t.anti_aliasing = None
    t.lighting = True
    t.show_scalar_bar = False
    t.allow_empty_mesh = True
    return t


@contextmanager
def plotter(size_wh: tuple[int, int]) -> Iterator[pv.Plotter]:
    """An off-screen ``pv.Plotter`` of ``size_wh`` pixels with the report theme, closed after."""
    w, h = int(size_wh[0]), int(size_wh[1])
    if w < 16 or h < 16:
        raise ValueError(f"render size must be at least 16x16 px, got {w}x{h}")
    p = pv.Plotter(off_screen=True, window_size=(w, h), theme=theme())  # type: ignore[arg-type]
    try:
        yield p
    finally:
        p.close()
        p.deep_clean()


def screenshot(p: pv.Plotter) -> np.ndarray:
    """Render and return the picture as (H, W, 3) uint8 RGB."""
    img = p.screenshot(return_img=True, transparent_background=False)
    return np.ascontiguousarray(np.asarray(img)[:, :, :3], dtype=np.uint8)


def polyline_cells(polylines: list[np.ndarray]) -> pv.PolyData:
    """One PolyData holding each (K_i, 3) polyline as a line cell (cell i = polyline i)."""
    polylines = [np.asarray(p, dtype=np.float64) for p in polylines if len(p) >= 2]
    if not polylines:
        return pv.PolyData()
    pts = np.vstack(polylines)
    sizes = np.array([len(p) for p in polylines])
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    idx = np.arange(len(pts))
    # VTK's legacy cell array: [n, i0, i1, ..., n, j0, ...]
    cells = np.insert(idx, starts, sizes)
    return pv.PolyData(pts, lines=cells)


def segment_cells(segments: np.ndarray) -> pv.PolyData:
    """One PolyData with one 2-point line cell per segment: (E, 2, 3) -> E cells."""
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 3)
    if len(seg) == 0:
        return pv.PolyData()
    pts = seg.reshape(-1, 3)
    e = len(seg)
    cells = np.column_stack([np.full(e, 2), 2 * np.arange(e), 2 * np.arange(e) + 1]).ravel()
    return pv.PolyData(pts, lines=cells)
