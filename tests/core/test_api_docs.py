"""The task page "Track with your own detector" (docs/tasks/own-detector.md): its code blocks
run as written, in order, on 15 frames of PETS 2009 S2.L1 (the page's ``my_video.mp4``) with
the ground truth's boxes standing for the reader's detector."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from pftrack.io.data import data_dir

PAGE = Path(__file__).resolve().parents[2] / "docs" / "tasks" / "own-detector.md"
PETS = data_dir() / "pets09"
N_FRAMES = 15


def _blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", PAGE.read_text(), flags=re.S)


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    if not (PETS / "vtest.avi").is_file():
        pytest.skip("PETS 2009 data not found (PFTRACK_DATA)")
    import cv2
    from pftrack.workflows.pipeline import iter_frames

    path = tmp_path_factory.mktemp("clip") / "clip.avi"
    writer = None
    for fr in iter_frames(PETS / "vtest.avi", 1, N_FRAMES):
        if writer is None:
            h, w = fr.image.shape[:2]
            writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 7.0, (w, h))
        writer.write(fr.image)
    writer.release()
    return path


def _detector(as_supervision: bool):
    """Ground-truth boxes of successive frames (x1, y1, x2, y2, score 0.9)."""
    from pftrack.io.mot import read_mot

    gt = read_mot(PETS / "gt.txt")
    gt = gt[gt[:, 6] != 0]
    count = [0]

    def detect(image):
        count[0] += 1
        g = gt[gt[:, 0] == count[0]]
        boxes = np.c_[g[:, 2:4], g[:, 2:4] + g[:, 4:6], np.full(len(g), 0.9)]
        if not as_supervision:
            return boxes
        import supervision as sv

        return sv.Detections(xyxy=boxes[:, :4], confidence=boxes[:, 4],
                             class_id=np.zeros(len(boxes), dtype=int))

    return detect, count


def _run(code: str, clip: Path, **names):
    ns = dict(names)
    exec(compile(code.replace("my_video.mp4", str(clip)), str(PAGE), "exec"), ns)
    return ns


def test_the_page_has_its_three_examples():
    blocks = _blocks()
    assert len(blocks) == 3
    # ten lines or so each for numpy and supervision
    assert [len(b.strip().splitlines()) for b in blocks[:2]] == [9, 11]


def test_numpy_example_runs_as_written(clip, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    detect, count = _detector(False)
    ns = _run(_blocks()[0], clip, my_detector=detect)
    assert count[0] == N_FRAMES
    out, df = ns["out"], ns["tracks"]
    assert len(out) >= 3 and np.all(out.frame == N_FRAMES)
    assert np.all(np.isfinite(out.xyxy_sd)) and np.all(out.xyxy_sd > 0)
    assert (tmp_path / "last_frame.png").is_file()
    assert len(df) > 3 * (N_FRAMES - 3) and (df.published_frame > df.frame).any()


def test_supervision_example_runs_as_written(clip, tmp_path, monkeypatch):
    sv = pytest.importorskip("supervision")
    monkeypatch.chdir(tmp_path)
    detect, count = _detector(True)
    ns = _run(_blocks()[1], clip, my_sv_detector=detect)
    assert count[0] == N_FRAMES
    det = ns["detections"]
    assert isinstance(det, sv.Detections) and len(det) >= 3
    assert det.tracker_id is not None and len(set(det.tracker_id.tolist())) == len(det)
    assert len(ns["text"]) == len(det) and ns["annotated"].shape == (576, 768, 3)
    # the same tracks as the numpy example
    detect2, _ = _detector(False)
    ns2 = _run(_blocks()[0], clip, my_detector=detect2)
    np.testing.assert_array_equal(ns["tracker"].to_mot(), ns2["tracker"].to_mot())


def test_own_component_example_runs_as_written(clip):
    ns = _run(_blocks()[2], clip)
    tracker = ns["tracker"]
    assert type(tracker._first.likelihood).__name__ == "CentreDistance"
    assert tracker._first.likelihood.sigma_px == 5.0
    # it reads no pixels, but the preset's colour model does: frames still needed
    assert tracker._readers == ["tracks 'confirmed' (its colour model, tracks.appearance)"]
