"""The colour paper's experiment helpers: start boxes, errors, tracking the walkers, and the paper's
claim that cross entropy + background is more accurate than Bhattacharyya + background."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack_bench.colour_tables import walkers_tables
from pftrack_colour.experiment import (
    centre_errors,
    cumulative_errors,
    first_boxes,
    last_frames,
    track,
)


def _rows(data):
    out = np.full((len(data), 10), -1.0)
    out[:, :6] = data
    return out


def test_first_and_last_boxes():
    gt = _rows([[3, 7, 10, 10, 4, 4], [1, 2, 0, 0, 2, 2], [2, 2, 1, 1, 2, 2], [5, 7, 0, 0, 4, 4]])
    starts = first_boxes(gt)
    assert sorted(starts) == [1, 3]
    assert starts[1][0][0] == 2 and starts[3][0][0] == 7
    np.testing.assert_array_equal(starts[3][0][1], [10, 10, 4, 4])
    assert first_boxes(gt, ids=[7]).keys() == {3}
    assert last_frames(gt) == {7: 5, 2: 2}


def test_errors_hold_the_last_box():
    gt = _rows([[1, 1, 0, 0, 2, 2], [2, 1, 10, 0, 2, 2], [3, 1, 20, 0, 2, 2]])
    tr = _rows([[1, 1, 0, 0, 2, 2], [2, 1, 13, 4, 2, 2]])
    e = centre_errors(tr, gt)[1]
    np.testing.assert_allclose(e[:2], [0.0, 5.0])
    assert np.isnan(e[2])
    held = centre_errors(tr, gt, hold_last=True)[1]
    np.testing.assert_allclose(held, [0.0, 5.0, np.hypot(7, 4)])
    assert cumulative_errors(tr, gt, {1: "blue"}) == {"blue": pytest.approx(5 + np.hypot(7, 4))}
    assert cumulative_errors(tr, gt, {1: "blue"}, frames=[1, 2]) == {"blue": pytest.approx(5)}


def test_track_walkers_with_cross_entropy_background():
    from pftrack.host import get_host

    scene = get_host().build("scene", {"type": "walkers", "params": {"n_frames": 40}})
    frames = list(scene.frames())
    gt = scene.ground_truth()
    run = track(frames, "cross-entropy-bg", first_boxes(gt), n_particles=200,
                snapshot_frames=[10])
    assert run.n_frames == 40 and run.n_updates == 120 and run.seconds > 0
    assert set(run.snapshots[10]) == {1, 2, 3} and run.snapshots[10][1].shape == (200, 2)
    errs = centre_errors(run.rows, gt)
    for tid, e in errs.items():
        assert not np.isnan(e).any()
        assert np.mean(e) < 2.5, tid  # the walkers are tracked to a couple of pixels
    # same seed, same tracks
    again = track(frames, "cross-entropy-bg", first_boxes(gt), n_particles=200)
    np.testing.assert_array_equal(again.rows, run.rows)


@pytest.mark.slow
def test_cross_entropy_beats_bhattacharyya_for_every_walker():
    """The paper's Tables 2 and 4: lower cumulative error with cross entropy for every target
    (both with background), on 180 frames at N = 100, three targets."""
    res = walkers_tables(("bhattacharyya-bg", "cross-entropy-bg"), samples=(100,), targets=(3,))
    rows = {r["likelihood"]: r for r in res["rows"]}
    bh = rows["bhattacharyya-bg"]["cumulative_error_px"]
    ce = rows["cross-entropy-bg"]["cumulative_error_px"]
    assert set(bh) == set(ce) == {"blue", "red", "purple"}
    for name in bh:
        assert ce[name] < bh[name], name
        assert ce[name] < 180 * 2.5  # under 2.5 px a frame on average
    assert res["ratios"][0]["ratio"] > 1.0
