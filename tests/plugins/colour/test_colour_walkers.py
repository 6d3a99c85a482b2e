"""The synthetic ``walkers`` scene (the colour paper's test video): size, ground truth, determinism,
torso colours, crossings without long full occlusions."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from pftrack.testing import check_component
from pftrack_colour.walkers import TORSO_COLOURS_BGR, WalkersScene, torso_visibility


@pytest.fixture(scope="module")
def scene():
    s = WalkersScene(seed=0)
    return s, list(s.frames()), s.ground_truth()


def test_size_frames_and_ground_truth(scene):
    s, frames, gt = scene
    assert len(frames) == 180
    assert [f.index for f in frames[:3]] == [1, 2, 3]
    assert frames[0].image.shape == (240, 360, 3) and frames[0].image.dtype == np.uint8
    assert gt.shape == (540, 10)
    assert sorted(np.unique(gt[:, 1]).astype(int)) == [1, 2, 3]
    np.testing.assert_array_equal(gt[:, 4:6], 30.0)
    # every torso box lies inside the image
    assert gt[:, 2].min() >= 0 and (gt[:, 2] + 30).max() <= 360
    assert gt[:, 3].min() >= 0 and (gt[:, 3] + 30).max() <= 240
    assert s.target_names == {1: "blue", 2: "red", 3: "purple"}
    # the walkers walk: each covers at least 150 px
    for tid in (1, 2, 3):
        c = gt[gt[:, 1] == tid][:, 2:4]
        assert np.linalg.norm(c[-1] - c[0]) > 150


def test_torso_colour_at_the_ground_truth(scene):
    s, frames, gt = scene
    vis = torso_visibility(s.layout["centres"])
    checked = 0
    for k in range(0, 180, 10):
        for tid, name in s.target_names.items():
            if vis[k, tid - 1] < 0.999:
                continue
            x, y = gt[(gt[:, 0] == k + 1) & (gt[:, 1] == tid)][0, 2:4] + 15
            patch = frames[k].image[int(y) - 3:int(y) + 3, int(x) - 3:int(x) + 3].reshape(-1, 3)
            assert np.abs(patch.mean(axis=0) - TORSO_COLOURS_BGR[name]).max() < 20, (k, name)
            checked += 1
    assert checked > 30


def test_people_cross_but_never_vanish(scene):
    s, _, _ = scene
    vis = torso_visibility(s.layout["centres"])
    assert vis.min() >= 0.3
    assert (vis < 0.8).sum() >= 10  # some real occlusions


def test_seeded_and_deterministic(scene):
    s, frames, gt = scene
    again = WalkersScene(seed=0)
    f2 = list(itertools.islice(again.frames(), 3))
    np.testing.assert_array_equal(f2[2].image, frames[2].image)
    np.testing.assert_array_equal(again.ground_truth(), gt)
    # streaming twice gives the same frames (noise included)
    f3 = list(itertools.islice(s.frames(), 3))
    np.testing.assert_array_equal(f3[2].image, frames[2].image)
    other = WalkersScene(seed=1)
    assert not np.allclose(other.ground_truth()[:, 2:4], gt[:, 2:4])
    # the noise comes from the seed too
    quiet = next(iter(WalkersScene(seed=0, noise_sigma=0.0).frames()))
    diff = frames[0].image.astype(int) - quiet.image.astype(int)
    assert 2.0 < diff.std() < 4.0


def test_short_scene_and_bad_parameters():
    s = WalkersScene(seed=3, n_frames=12)
    assert len(list(s.frames())) == 12 and len(s.ground_truth()) == 36
    with pytest.raises(ValueError, match="n_frames"):
        WalkersScene(n_frames=0).ground_truth()


def test_registered_and_conforms():
    import pftrack_colour
    from pftrack.host import Host

    host = Host(load_entry_points=False, plugins=[("colour", pftrack_colour)])
    assert host.get("scene", "walkers") is WalkersScene
    assert [str(r) for r in check_component(WalkersScene) if not r.passed] == []
