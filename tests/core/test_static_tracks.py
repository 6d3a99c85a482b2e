"""Static things are not people (pftrack.workflows.static_tracks): still tracks with a fixed look
are flagged; moving ones, short ones and still ones whose pixels change (a person waiting) are
not."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.workflows.static_tracks import (
    StaticRule,
    flag_static_tracks,
    patch_similarity,
    static_evidence,
)

FPS = 10.0


def _track(tid, n, x0=100.0, vx=0.0, jitter=0.0, h=80.0, first=1, seed=0):
    rng = np.random.default_rng(seed)
    f = np.arange(first, first + n, dtype=float)
    x = x0 + vx * (f - first) + jitter * rng.standard_normal(n)
    y = 50.0 + jitter * rng.standard_normal(n)
    return np.c_[f, np.full(n, tid), x, y, np.full(n, h / 2), np.full(n, h), np.ones(n),
                 -np.ones((n, 3))]


def test_evidence_measures_time_shift_and_height_in_box_heights():
    rows = _track(1, 101, vx=0.4, h=80.0)  # 40 px over 101 frames at 10 fps
    ev = static_evidence(rows[:, 0], rows[:, 2:6], FPS, quantile=1.0)
    assert ev["seconds"] == pytest.approx(10.1)
    assert ev["shift_heights"] == pytest.approx(20.0 / 80.0)  # half the path from the median
    assert ev["height_change"] == 0.0 and ev["median_height_px"] == 80.0


def test_place_and_time_decide_without_the_video():
    rows = np.vstack([
        _track(1, 150, jitter=2.0),            # 15 s, jitter 2 px of 80: still
        _track(2, 150, vx=3.0),                # walking 30 px/s: moves
        _track(3, 60, jitter=2.0),             # still but only 6 s
        _track(4, 150, jitter=2.0, h=20.0),    # the same jitter is 10% of a 20 px box
    ])
    flagged = flag_static_tracks(rows, FPS)
    assert [t["id"] for t in flagged] == [1]
    assert flagged[0]["first"] == 1 and flagged[0]["last"] == 150
    assert flagged[0]["similarity"] is None and "15.0 s" in flagged[0]["why"]
    # a shorter minimum time takes the 6 s track too
    assert [t["id"] for t in flag_static_tracks(rows, FPS, StaticRule(min_seconds=5.0))] == [1, 3]
    assert flag_static_tracks(np.zeros((0, 10)), FPS) == []
    # a record whose box is not a number (a tracker's estimate off the image) is left out
    with_nan = rows.copy()
    with_nan[5, 2:6] = np.nan
    assert [t["id"] for t in flag_static_tracks(with_nan, FPS)] == [1]
    assert static_evidence([1, 2], [[np.nan] * 4] * 2, FPS)["seconds"] == 0.0


def test_patch_similarity_is_one_for_a_fixed_look_and_low_for_a_changing_one():
    rng = np.random.default_rng(1)
    base = rng.uniform(0, 255, (32, 16))
    fixed = np.stack([base * a + b for a, b in ((1.0, 0), (0.9, 10), (1.1, -5))])
    assert patch_similarity(fixed) == pytest.approx(1.0)
    changing = rng.uniform(0, 255, (4, 32, 16))
    assert patch_similarity(changing) < 0.5
    assert patch_similarity(np.zeros((3, 8, 8))) == 1.0


def test_a_still_track_whose_pixels_change_is_not_static(tmp_path):
    import cv2

    rng = np.random.default_rng(2)
    path = tmp_path / "v.avi"
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (320, 240))
    thing = rng.uniform(0, 255, (80, 40)).astype(np.uint8)
    for _ in range(150):
        img = np.full((240, 320, 3), 90, np.uint8)
        img[50:130, 60:100] = thing[..., None]                  # a thing: same pixels
        person = rng.uniform(0, 255, (80, 40)).astype(np.uint8)  # always different pixels
        img[50:130, 200:240] = person[..., None]
        w.write(img)
    w.release()
    rows = np.vstack([_track(1, 150, x0=60.0), _track(2, 150, x0=200.0)])
    rows[:, 3] = 50.0
    flagged = flag_static_tracks(rows, FPS, video=path)
    assert [t["id"] for t in flagged] == [1]
    assert flagged[0]["similarity"] > 0.9 and "look fixed" in flagged[0]["why"]


def test_bad_rules_and_fps_are_named():
    with pytest.raises(ValueError, match="min_seconds"):
        flag_static_tracks(_track(1, 5), FPS, StaticRule(min_seconds=0.0))
    with pytest.raises(ValueError, match="quantile"):
        flag_static_tracks(_track(1, 5), FPS, StaticRule(quantile=0.2))
    with pytest.raises(ValueError, match="fps"):
        flag_static_tracks(_track(1, 5), 0.0)
