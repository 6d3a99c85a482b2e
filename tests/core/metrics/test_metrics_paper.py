"""The source papers' accuracy measures (pftrack.metrics.paper)."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.io.data import data_path
from pftrack.io.mot import CONF, ID, LEFT, TOP, read_mot
from pftrack.metrics import (
    accuracy_within,
    adjusted_rand_index,
    cumulative_pixel_error,
    match_ids,
    points_by_target,
    size_error,
)


@pytest.fixture(scope="module")
def pets_gt() -> np.ndarray:
    return read_mot(data_path("pets09", "gt.txt"))


def test_cumulative_pixel_error_sums_distances_and_skips_missing():
    truth = np.zeros((4, 2, 2))
    est = truth.copy()
    est[:, 0] = [3.0, 4.0]           # target 0: 5 px off in every frame
    est[1, 1] = [0.0, 2.0]           # target 1: 2 px off once ...
    est[2, 1] = np.nan               # ... and missing once (not summed)
    np.testing.assert_allclose(cumulative_pixel_error(est, truth), [20.0, 2.0])
    assert cumulative_pixel_error(est[:, 0], truth[:, 0]) == pytest.approx(20.0)
    with pytest.raises(ValueError, match="shape"):
        cumulative_pixel_error(est, truth[:, :1])


def test_accuracy_within_counts_visible_frames_only():
    truth = np.zeros((5, 3, 2))
    truth[3:, 1] = np.nan            # person 1 visible in 3 frames
    truth[:, 2] = np.nan             # person 2 never visible
    est = truth.copy()
    est[:, 0, 0] = [0, 4, 5, 6, 10]  # person 0: 3 of 5 within 5 px (5 counts)
    est[:, 1, 1] = [1, 1, 1, 1, 1]
    est[0, 1] = np.nan               # a lost estimate in a visible frame is a miss
    mean, per = accuracy_within(est, truth, radius_px=5)
    np.testing.assert_allclose(per[:2], [3 / 5, 2 / 3])
    assert np.isnan(per[2]) and mean == pytest.approx((3 / 5 + 2 / 3) / 2)


def test_pets_points_by_target_and_paper_measures(pets_gt):
    gt = pets_gt[pets_gt[:, CONF] != 0]
    shifted = gt.copy()
    shifted[:, LEFT] += 3.0
    shifted[:, TOP] += 4.0           # 5 px off, every box
    pts = points_by_target(gt, shifted)
    assert pts["truth_px"].shape == (795, 19, 2) and pts["gt_ids"].tolist() == list(range(1, 20))
    frames_per_id = np.bincount(gt[:, ID].astype(int), minlength=20)[1:]
    np.testing.assert_allclose(cumulative_pixel_error(pts["estimated_px"], pts["truth_px"]),
                               5.0 * frames_per_id)
    mean, per = accuracy_within(pts["estimated_px"], pts["truth_px"], radius_px=5.01)
    assert mean == 1.0 and (per == 1.0).all()
    assert accuracy_within(pts["estimated_px"], pts["truth_px"], radius_px=4.99)[0] == 0.0

    # same tracks under other ids: matched through the IDF1-optimal map
    relabelled = shifted.copy()
    relabelled[:, ID] += 100
    assert match_ids(gt, relabelled) == {i: i + 100 for i in range(1, 20)}
    pts2 = points_by_target(gt, relabelled, id_map="match", point="foot")
    assert accuracy_within(pts2["estimated_px"], pts2["truth_px"], 5.01)[0] == 1.0
    # without the map nothing estimates the gt ids: every visible frame is a miss
    pts3 = points_by_target(gt, relabelled)
    assert accuracy_within(pts3["estimated_px"], pts3["truth_px"], 5.0)[0] == 0.0
    assert cumulative_pixel_error(pts3["estimated_px"], pts3["truth_px"]).sum() == 0.0


def test_size_error_on_seed_003_table_1():
    est = np.array([[6.7, 3.0, 63.0], [1.7, 2.3, 21.7]])   # boat, car (m)
    true = np.array([[7.5, 1.8, 2.3], [1.7, 1.5, 4.7]])
    e = size_error(est, true)
    np.testing.assert_allclose(e["abs"], [[0.8, 1.2, 60.7], [0.0, 0.8, 17.0]], atol=1e-12)
    np.testing.assert_allclose(e["rel"][0], [0.8 / 7.5, 1.2 / 1.8, 60.7 / 2.3])
    assert e["ratio"][1, 2] == pytest.approx(21.7 / 4.7)
    with pytest.raises(ValueError, match="broadcast"):
        size_error(est, true[:, :2])


def test_adjusted_rand_index_with_na():
    assert adjusted_rand_index([0, 0, 1, 1], ["b", "b", "a", "a"]) == pytest.approx(1.0)
    # contingency by hand: index 1, expected 2 * 1 / 6, max 1.5 -> (1 - 1/3) / (1.5 - 1/3)
    assert adjusted_rand_index([0, 0, 1, 1], [0, 0, 1, 2]) == pytest.approx(4 / 7)
    # an unassigned tracklet is its own cluster by default, or left out
    assert adjusted_rand_index([0, 0, 1, 1], [0, 0, 1, None]) == pytest.approx(4 / 7)
    assert adjusted_rand_index([0, 0, 1, 1], [0, 0, 1, "NA"], na="drop") == pytest.approx(1.0)
    assert adjusted_rand_index([0, 0, 1, 1], [5, 5, 5, float("nan")], na="drop") == 0.0
    with pytest.raises(ValueError, match="length"):
        adjusted_rand_index([0, 1], [0])
    with pytest.raises(ValueError, match="true_labels contain NA"):
        adjusted_rand_index([0, None], [0, 1])
    with pytest.raises(ValueError, match="na must be"):
        adjusted_rand_index([0, 1], [0, 1], na="zero")
