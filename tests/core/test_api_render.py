"""Uncertainty ellipses: their geometry, the overlay's and the top view's."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.render.ellipses import covariance_ellipses
from pftrack.render.overlay import draw_uncertainty


def test_ellipse_axes_are_k_standard_deviations():
    # sd 3 along the diagonal (1, 1)/sqrt2, sd 1 across it
    v = np.array([[1.0, -1.0], [1.0, 1.0]]) / np.sqrt(2)
    cov = v @ np.diag([9.0, 1.0]) @ v.T
    ring = covariance_ellipses(np.array([[10.0, 20.0]]), cov[None], k=2.0, n_points=360)[0]
    d = ring - [10.0, 20.0]
    r = np.linalg.norm(d, axis=1)
    assert r.max() == pytest.approx(6.0, rel=1e-4) and r.min() == pytest.approx(2.0, rel=1e-3)
    far = d[np.argmax(r)]
    assert abs(abs(far @ v[:, 0]) - 6.0) < 1e-3  # the long axis along the first eigenvector
    np.testing.assert_allclose(ring[0], ring[-1])
    # every point of the outline at Mahalanobis distance k
    m = np.einsum("pi,ij,pj->p", d, np.linalg.inv(cov), d)
    np.testing.assert_allclose(np.sqrt(m), 2.0, rtol=1e-9)
    bad = covariance_ellipses(np.array([[0.0, 0.0], [np.nan, 0.0]]), np.stack([cov, cov]))
    assert np.isfinite(bad[0]).all() and np.isnan(bad[1]).all()


def test_overlay_ellipse_is_drawn_where_and_as_large_as_the_sd():
    img = np.zeros((200, 300, 3), np.uint8)
    xyxy = np.array([[100.0, 50.0, 140.0, 150.0]])  # centre (120, 100)
    sd = np.array([[5.0, 10.0, 5.0, 10.0]])
    out = draw_uncertainty(img, xyxy, sd, np.array([1]), k=2.0)
    assert not img.any()  # the input is not drawn on
    ys, xs = np.nonzero(out.any(axis=2))
    # the 2 sd ellipse: half-axes 10 px across, 20 px up and down (plus the line's width)
    assert 108 <= xs.min() <= 111 and 129 <= xs.max() <= 132
    assert 78 <= ys.min() <= 81 and 119 <= ys.max() <= 122


def test_a_record_without_a_spread_draws_nothing_and_warns_nothing():
    import warnings

    img = np.zeros((200, 300, 3), np.uint8)
    xyxy = np.array([[100.0, 50.0, 140.0, 150.0], [10.0, 10.0, 30.0, 60.0]])
    sd = np.array([[5.0, 10.0, 5.0, 10.0], [np.nan] * 4])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = draw_uncertainty(img, xyxy, sd, np.array([1, 2]), k=2.0)
    alone = draw_uncertainty(img, xyxy[:1], sd[:1], np.array([1]), k=2.0)
    np.testing.assert_array_equal(out, alone)


def test_topview_draws_the_ellipses(tmp_path):
    from pftrack.render.topview import render_topview

    tracks = {1: np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]])}
    base = render_topview(tracks=tracks, size_wh=(400, 300), legend=False,
                          bounds_m=np.array([[-2.0, -2.0], [3.0, 3.0]]))
    cov = np.diag([0.25, 0.04])  # sd 0.5 m along x, 0.2 m along y
    img = render_topview(tmp_path / "t.png", tracks=tracks, size_wh=(400, 300), legend=False,
                         bounds_m=np.array([[-2.0, -2.0], [3.0, 3.0]]),
                         ellipses={1: (np.array([1.0, 1.0]), cov)})
    assert (tmp_path / "t.png").is_file()
    changed = np.any(img != base, axis=2)
    ys, xs = np.nonzero(changed)
    # wider (2 x 2 x 0.5 m) than tall (2 x 2 x 0.2 m), in the same pixels per metre
    assert 2.0 < (xs.max() - xs.min()) / (ys.max() - ys.min()) < 3.2


def test_report_overlay_draws_the_side_files_ellipses():
    from pftrack.render.report import draw_overlay

    img = np.zeros((200, 300, 3), np.uint8)
    rows = np.array([[5, 1, 100, 50, 40, 100, 0.9, -1, -1, -1],
                     [4, 1, 90, 50, 40, 100, 0.9, -1, -1, -1]], dtype=np.float64)
    unc = np.array([[5, 1, 6, 12, 6, 12, np.nan, np.nan, np.nan],
                    [4, 1, 6, 12, 6, 12, np.nan, np.nan, np.nan]])
    plain = draw_overlay(img, rows, 5)
    with_sd = draw_overlay(img, rows, 5, uncertainty=unc)
    ys, xs = np.nonzero(np.any(plain != with_sd, axis=2))
    # frame 5's box centre (120, 100), half-axes 12 and 24 px
    assert 106 <= xs.min() <= 110 and 130 <= xs.max() <= 134
    assert 74 <= ys.min() <= 78 and 122 <= ys.max() <= 126
