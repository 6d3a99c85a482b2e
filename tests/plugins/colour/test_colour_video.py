"""The generic ``video`` scene: streaming, ground-truth numbering, slices, errors; PETS 2009."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.io.data import data_dir
from pftrack.scenes.video import VideoScene, write_test_clip
from pftrack.testing import check_component


@pytest.fixture()
def clip(tmp_path):
    video, gt = tmp_path / "clip.avi", tmp_path / "gt.txt"
    write_test_clip(video, gt, n_frames=6)
    return video, gt


def test_frames_follow_the_ground_truth_numbering(clip):
    video, gt = clip
    s = VideoScene(str(video), str(gt))
    frames = list(s.frames())
    assert [f.index for f in frames] == [1, 2, 3, 4, 5, 6]
    assert frames[0].image.shape == (48, 64, 3)
    rows = s.ground_truth()
    assert rows.shape == (6, 10)
    # the white square is where the ground truth says, in every frame
    for f, r in zip(frames, rows):
        x, y, w, h = r[2:6].astype(int)
        assert f.image[y + 2:y + h - 2, x + 2:x + w - 2].mean() > 200
        assert f.image[y:y + h, max(x - 6, 0):x].mean() < 140 or x < 6
    assert s.fps == pytest.approx(10.0)
    assert s.frame_count == 6 and s.size_wh == (64, 48)


def test_slices_stream_the_same_frames(clip):
    video, gt = clip
    full = list(VideoScene(str(video), str(gt)).frames())
    part = VideoScene(str(video), str(gt), first=3, last=4)
    sl = list(part.frames())
    assert [f.index for f in sl] == [3, 4]
    np.testing.assert_array_equal(sl[0].image, full[2].image)
    assert part.ground_truth()[:, 0].tolist() == [3.0, 4.0]
    assert VideoScene(str(video)).ground_truth() is None


def test_missing_files_are_named(tmp_path, clip):
    with pytest.raises(FileNotFoundError, match="nope.avi"):
        list(VideoScene(str(tmp_path / "nope.avi")).frames())
    video, _ = clip
    with pytest.raises(FileNotFoundError, match="gt_missing"):
        VideoScene(str(video), str(tmp_path / "gt_missing.txt")).ground_truth()
    with pytest.raises(ValueError, match="last"):
        list(VideoScene(str(video), first=5, last=2).frames())


def test_registered_and_conforms():
    from pftrack.host import get_host

    assert get_host().get("scene", "video").__name__ == "VideoScene"
    assert [str(r) for r in check_component(VideoScene) if not r.passed] == []


def test_pets09_video_and_ground_truth():
    folder = data_dir() / "pets09"
    if not (folder / "vtest.avi").is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    s = VideoScene(str(folder / "vtest.avi"), str(folder / "gt.txt"), first=790)
    frames = list(s.frames())
    assert [f.index for f in frames] == [790, 791, 792, 793, 794, 795]
    assert frames[0].image.shape == (576, 768, 3)
    gt = s.ground_truth()
    assert gt[:, 0].min() == 790 and gt[:, 0].max() == 795
