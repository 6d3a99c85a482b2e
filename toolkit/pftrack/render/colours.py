"""Stable colours for track ids, shared by the pyvista renders and the OpenCV overlays.

A track id always gets the same colour, in every picture and every run: colour =
``TRACK_PALETTE_RGB[id % 20]``, a fixed table of 20 colours that stay distinct from each other
and readable on both a white background (top views) and a video frame (overlays). Ids 20 apart
share a colour; the id is always printed beside the track as well.
"""

from __future__ import annotations

import numpy as np

__all__ = ["TRACK_PALETTE_RGB", "track_colour_bgr", "track_colour_rgb", "track_colours_rgb"]

#: 20 distinct colours (RGB, uint8): matplotlib's tab10 followed by ten darker/saturated others.
TRACK_PALETTE_RGB = np.array(
    [
        [31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189],
        [140, 86, 75], [227, 119, 194], [127, 127, 127], [188, 189, 34], [23, 190, 207],
        [0, 0, 180], [180, 0, 90], [0, 120, 90], [230, 180, 0], [90, 40, 0],
        [0, 200, 120], [120, 0, 200], [250, 80, 160], [60, 60, 0], [0, 90, 160],
    ],
    dtype=np.uint8,
)


def track_colours_rgb(ids: np.ndarray) -> np.ndarray:
    """Colours of track ids: (N,) int -> (N, 3) uint8 RGB."""
    ids = np.asarray(ids).astype(np.int64).reshape(-1)
    return TRACK_PALETTE_RGB[np.mod(ids, len(TRACK_PALETTE_RGB))]


def track_colour_rgb(track_id: int) -> tuple[int, int, int]:
    """Colour of one track id as an (r, g, b) tuple of ints 0-255."""
    r, g, b = track_colours_rgb(np.array([track_id]))[0]
    return int(r), int(g), int(b)


def track_colour_bgr(track_id: int) -> tuple[int, int, int]:
    """Colour of one track id in OpenCV's (b, g, r) order."""
    r, g, b = track_colour_rgb(track_id)
    return b, g, r
