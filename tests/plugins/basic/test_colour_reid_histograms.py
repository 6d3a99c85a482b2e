"""The ``colour-reid`` stage's per-channel histograms: exact counts of ``floor(v * bins / 256)``
for every pixel of each box's region, whichever way they are computed."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack_basic.tracks import ColourReidentifier


def _reference(image: np.ndarray, boxes: np.ndarray, bins: int,
               region: tuple[float, float, float, float]) -> np.ndarray:
    """Pixel by pixel: each box's region, each channel's value binned as v * bins // 256."""
    fx0, fy0, fx1, fy1 = region
    H, W = image.shape[:2]
    out = np.full((len(boxes), 3, bins), 1.0 / bins)
    for k, (x, y, w, h) in enumerate(boxes):
        x0, x1 = int(max(x + fx0 * w, 0)), int(min(x + fx1 * w, W))
        y0, y1 = int(max(y + fy0 * h, 0)), int(min(y + fy1 * h, H))
        if x1 <= x0 or y1 <= y0:
            continue
        px = image[y0:y1, x0:x1].reshape(-1, 3).astype(np.int64)
        for c in range(3):
            counts = np.zeros(bins)
            for v in px[:, c]:
                counts[v * bins // 256] += 1
            out[k, c] = counts / len(px)
    return out


BOXES = np.array([[10.0, 12.0, 30.0, 50.0],     # inside
                  [-8.0, 40.0, 25.0, 40.0],     # cut by the left edge
                  [70.0, 55.0, 40.0, 30.0],     # cut by the right and bottom edges
                  [200.0, 10.0, 20.0, 20.0]])   # outside: the uniform histogram


@pytest.mark.parametrize("bins", [16, 10, 7, 32])
def test_histograms_are_exact_counts_of_each_region(bins):
    rng = np.random.default_rng(bins)
    image = rng.integers(0, 256, (64, 96, 3), dtype=np.uint8)
    stage = ColourReidentifier(bins=bins)
    got = stage._histograms(image, BOXES)
    np.testing.assert_array_equal(got, _reference(image, BOXES, bins, stage.region))
    np.testing.assert_allclose(got.sum(axis=2), 1.0)


def test_an_image_that_is_not_8_bit_colour_takes_the_integer_path():
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (64, 96, 3), dtype=np.uint8)
    stage = ColourReidentifier(bins=16)
    wide = image.astype(np.int32)  # same values, not 8-bit
    np.testing.assert_array_equal(stage._histograms(wide, BOXES),
                                  stage._histograms(image, BOXES))
