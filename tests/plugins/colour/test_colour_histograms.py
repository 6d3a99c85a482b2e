"""Colour binning, box geometry and the region machinery of the colour likelihoods, against
brute-force per-box loops."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.geometry.boxes import sub_boxes
from pftrack_colour.histograms import (
    ColourBins,
    ParticleRegion,
    integer_boxes,
    normalise_histogram,
    subsample,
)


def _image(seed: int = 0, shape=(48, 64)) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (*shape, 3), dtype=np.uint8)


def _brute_rect(box):
    x0 = int(np.floor(box[0] + 0.5))
    y0 = int(np.floor(box[1] + 0.5))
    return x0, y0, x0 + max(1, int(np.floor(box[2] + 0.5))), y0 + max(1, int(np.floor(box[3]
                                                                                       + 0.5)))


def _brute_part(rect, part):
    x0, y0, x1, y1 = rect
    if part is None:
        return rect
    k, p = part
    h = y1 - y0
    return x0, y0 + (k * h) // p, x1, y0 + ((k + 1) * h) // p


def _clip(rect, w, h):
    x0, y0, x1, y1 = rect
    return max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)


def test_rgb_bins_match_the_formula():
    img = _image()
    b = ColourBins(8, "rgb")(img)
    r, g, bl = img[..., 2] // 32, img[..., 1] // 32, img[..., 0] // 32
    assert b.shape == img.shape[:2]
    np.testing.assert_array_equal(b, r.astype(int) * 64 + g * 8 + bl)
    assert ColourBins(8).n_bins == 512
    assert ColourBins((4, 2, 3)).n_bins == 24


def test_uneven_bins_and_hsv():
    img = _image(1)
    cb = ColourBins((4, 2, 3), "bgr")
    b = cb(img)
    expected = (img[..., 0] // 64).astype(int) * 6 + (img[..., 1] // 128) * 3 \
        + np.minimum(img[..., 2].astype(int) * 3 // 256, 2)
    np.testing.assert_array_equal(b, expected)
    import cv2

    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    bh = ColourBins(6, "hsv")(img)
    np.testing.assert_array_equal(
        bh, (hsv[..., 0].astype(int) * 6 // 180) * 36 + (hsv[..., 1].astype(int) * 6 // 256) * 6
        + hsv[..., 2].astype(int) * 6 // 256)
    assert bh.max() < 216


@pytest.mark.parametrize("space", ["rgb", "bgr", "hsv"])
def test_bins_of_views_equal_bins_of_copies(space):
    """A crop of a frame is binned in place (row-strided view); other layouts are copied."""
    img = _image(4, (40, 50))
    cb = ColourBins((4, 8, 2), space)
    full = cb(img)
    for view, rows, cols in ((img[5:30, 7:44], slice(5, 30), slice(7, 44)),
                             (img[::2, ::3], slice(None, None, 2), slice(None, None, 3)),
                             (img[:, ::-1], slice(None), slice(None, None, -1))):
        got = cb(view)
        assert got.dtype == full.dtype
        np.testing.assert_array_equal(got, full[rows, cols])


@pytest.mark.parametrize("kwargs, word", [({"bins": 0}, "bins"), ({"bins": (8, 8)}, "bins"),
                                          ({"colour_space": "xyz"}, "colour_space")])
def test_bad_binning_parameters_are_named(kwargs, word):
    with pytest.raises(ValueError, match=word):
        ColourBins(**kwargs)


def test_histogram_counts_every_pixel():
    img = _image(2)
    h = ColourBins(8).histogram(img)
    assert h.shape == (512,)
    assert h.sum() == img.shape[0] * img.shape[1]


@pytest.mark.parametrize("space", ["rgb", "bgr", "hsv", "lab", "ycrcb"])
@pytest.mark.parametrize("bins", [8, (4, 6, 5), (256, 3, 1)])
def test_masked_histogram_counts_the_masked_bins(space, bins):
    """One calcHist call where it bins exactly (ranges of 256), the bin image elsewhere (hue):
    either way the counts of the bins of the pixels the mask keeps."""
    img = _image(5, (31, 45))
    cb = ColourBins(bins, space)
    mask = np.random.default_rng(6).random(img.shape[:2]) < 0.4
    expected = np.bincount(cb(img)[mask], minlength=cb.n_bins).astype(float)
    for m in (mask, mask.astype(np.uint8) * 255):
        got = cb.histogram(img, m)
        assert got.dtype == np.float64
        np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(cb.histogram(img[::2, ::3]),
                                  np.bincount(cb(img[::2, ::3]).ravel(), minlength=cb.n_bins))
    with pytest.raises(ValueError, match="mask shape"):
        cb.histogram(img, mask[1:])


@pytest.mark.parametrize("shape", [(240, 360), (241, 361), (7, 5)])
@pytest.mark.parametrize("stride", [1, 2, 3])
def test_subsample_is_the_strided_slice(shape, stride):
    img = _image(3, shape)
    np.testing.assert_array_equal(subsample(img, stride), img[::stride, ::stride])


def test_normalise_histogram_floor():
    h = normalise_histogram(np.array([3.0, 1.0, 0.0, 0.0]), eps=0.01)
    np.testing.assert_allclose(h, (np.array([0.75, 0.25, 0, 0]) + 0.01) / 1.04)
    assert h.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(normalise_histogram(np.zeros(4), 0.01), 0.25)


def test_integer_boxes_round_half_up_and_sub_boxes():
    r = integer_boxes(np.array([[1.5, 2.49, 10.0, 0.2], [-3.5, 0.0, 4.6, 7.5]]))
    np.testing.assert_array_equal(r, [[2, 2, 12, 3], [-3, 0, 2, 8]])
    sb = sub_boxes(np.array([[10.0, 20.0, 40.0, 100.0]]), (0.25, 0.1, 0.75, 0.5))
    np.testing.assert_allclose(sb, [[20.0, 30.0, 20.0, 40.0]])


def _random_boxes(rng, n, w, h, fixed):
    centres = np.column_stack([rng.uniform(-15, w + 15, n), rng.uniform(-15, h + 15, n)])
    if fixed:
        sizes = np.tile([12.0, 17.0], (n, 1))
    else:
        sizes = np.column_stack([rng.uniform(1, 20, n), rng.uniform(1, 25, n)])
    boxes = np.column_stack([centres - sizes / 2, sizes])
    # some boxes wholly outside, one larger than the image
    boxes[0] = [w + 5, 3, 12, 17] if fixed else [w + 5, 3, 6, 9]
    boxes[1] = [-30, -40, 12, 17] if fixed else [-5, -5, w + 10, h + 10]
    return boxes


@pytest.mark.parametrize("fixed", [True, False])
@pytest.mark.parametrize("part", [None, (0, 3), (2, 3), (1, 2)])
def test_box_sums_match_brute_force(fixed, part):
    rng = np.random.default_rng(4)
    img = _image(4)
    h, w = img.shape[:2]
    boxes = _random_boxes(rng, 60, w, h, fixed)
    region = ParticleRegion(img, boxes)
    assert (region.fixed_size is not None) == fixed
    values = rng.normal(size=region.shape).astype(np.float32)
    full = np.zeros((h, w))
    full[region.y0:region.y1, region.x0:region.x1] = values
    got = region.box_sums(values, part)
    for i, b in enumerate(boxes):
        x0, y0, x1, y1 = _clip(_brute_part(_brute_rect(b), part), w, h)
        expected = full[y0:max(y1, y0), x0:max(x1, x0)].sum()
        assert got[i] == pytest.approx(expected, abs=1e-3), i
    # pixel counts
    for i, b in enumerate(boxes):
        x0, y0, x1, y1 = _clip(_brute_rect(b), w, h)
        assert region.n_pixels[i] == max(x1 - x0, 0) * max(y1 - y0, 0)
    assert region.inside.tolist() == (region.n_pixels > 0).tolist()


@pytest.mark.parametrize("fixed", [True, False])
@pytest.mark.parametrize("part", [None, (1, 3)])
def test_box_histograms_match_brute_force(fixed, part):
    rng = np.random.default_rng(5)
    img = _image(5)
    h, w = img.shape[:2]
    boxes = _random_boxes(rng, 40, w, h, fixed)
    region = ParticleRegion(img, boxes)
    cb = ColourBins(4)
    bins = cb(region.pixels())
    got = region.box_histograms(bins, cb.n_bins, part)
    full = cb(img)
    for i, b in enumerate(boxes):
        x0, y0, x1, y1 = _clip(_brute_part(_brute_rect(b), part), w, h)
        patch = full[y0:max(y1, y0), x0:max(x1, x0)]
        np.testing.assert_array_equal(got[i], np.bincount(patch.ravel(), minlength=64))


def test_far_away_and_nan_boxes():
    img = _image(6)
    region = ParticleRegion(img, np.array([[1e12, 5.0, 10, 10], [3.0, 4.0, 10, 10]]))
    sums = region.box_sums(np.ones(region.shape, np.float32))
    np.testing.assert_allclose(sums, [0.0, 100.0])
    with pytest.raises(ValueError, match="NaN"):
        ParticleRegion(img, np.array([[np.nan, 1.0, 10, 10]]))
