"""Trajectories for drawing: MOT rows -> world tracks per id, dashes as separate segments."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.render.tracks import dashed_segments, polyline_length, tracks_from_mot


def test_dashes_have_the_right_lengths_and_follow_corners():
    line = np.array([[0.0, 0, 0], [10, 0, 0], [10, 10, 0]])
    seg = dashed_segments(line, 1.5, 1.0)
    lengths = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
    # 20 m at a period of 2.5 m: 8 dashes of 1.5 m; the dash over the corner is split in two
    assert lengths.sum() == pytest.approx(8 * 1.5)
    assert seg.shape[1:] == (2, 3)
    # every dash point lies on the polyline (x = 10 or y = 0)
    pts = seg.reshape(-1, 3)
    assert np.all(np.isclose(pts[:, 1], 0) | np.isclose(pts[:, 0], 10))
    # a dash spanning the corner at s = 10 (dash 8.0..11.0 with period 4) bends with it
    seg2 = dashed_segments(line, 3.0, 1.0)
    assert any(np.allclose(s[1], [10, 0, 0]) for s in seg2)
    assert np.linalg.norm(seg2[:, 1] - seg2[:, 0], axis=1).sum() == pytest.approx(15.0)
    # gaps have no ink: the midpoint of the first gap is not covered
    assert not np.any(np.all(np.isclose(seg[:, 0], [1.5, 0, 0]), axis=1)
                      & (seg[:, 1, 0] > 2.0))


def test_dashes_degenerate_inputs():
    assert dashed_segments(np.zeros((1, 3)), 1.0).shape == (0, 2, 3)
    assert dashed_segments(np.zeros((3, 3)), 1.0).shape == (0, 2, 3)
    with pytest.raises(ValueError, match="dash"):
        dashed_segments(np.zeros((2, 3)), 0.0)
    assert polyline_length(np.array([[0, 0, 0], [3, 4, 0]])) == 5.0


def test_tracks_from_mot_sorts_by_frame_and_skips_missing():
    rows = np.array([
        [2, 7, 0, 0, 1, 1, 1, 2.0, 2.0, 0],
        [1, 7, 0, 0, 1, 1, 1, 1.0, 1.0, 0],
        [1, 3, 0, 0, 1, 1, 1, 5.0, 5.0, 0],
        [3, 7, 0, 0, 1, 1, 1, np.nan, 3.0, 0],
    ])
    tr = tracks_from_mot(rows)
    assert list(tr) == [3, 7]
    assert np.array_equal(tr[7], [[1, 1, 0], [2, 2, 0]])
    assert tr[3].shape == (1, 3)
    with pytest.raises(ValueError, match="world columns 8-9"):
        tracks_from_mot(rows[:, :6], source="x.txt")
