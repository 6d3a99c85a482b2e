"""``mog2`` with ``person_height_m`` and a camera: blobs merged when stacked, split when wide,
made person-shaped through the camera; and on real PETS frames, more people found at IoU 0.5
than with the blob boxes."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Frame, RunContext
from pftrack.geometry.boxes import iou_matrix
from pftrack.geometry.people import camera_from_parameters, predicted_box_heights
from pftrack.io.data import data_dir
from pftrack.workflows.pipeline import iter_frames, read_ground_truth
from pftrack_basic.background import BackgroundSubtractionDetector, merge_stacked, person_boxes

PETS = data_dir() / "pets09"
needs_pets = pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")

SIZE = (640, 480)


@pytest.fixture(scope="module")
def camera():
    return camera_from_parameters(800.0, 20.0, 0.0, 6.0, SIZE)


def _person(camera, foot_x: float, foot_y: float) -> tuple[float, float, float, float]:
    h = float(predicted_box_heights(camera, [[foot_x, foot_y]])[0])
    w = 0.4 * h
    return foot_x - w / 2, foot_y - h, w, h


def _blobs(mask: np.ndarray) -> np.ndarray:
    import cv2

    _, _, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    return stats[1:, :4].astype(np.float64)


def test_stacked_fragments_of_one_person_make_one_person_box(camera):
    x, y, w, h = _person(camera, 300.0, 400.0)
    mask = np.zeros(SIZE[::-1], np.uint8)
    # legs and torso cut apart by a 6-px gap, the head apart by another
    mask[int(y + 0.55 * h):int(y + h), int(x + 0.2 * w):int(x + 0.8 * w)] = 255
    mask[int(y + 0.18 * h):int(y + 0.55 * h) - 6, int(x + 0.1 * w):int(x + 0.9 * w)] = 255
    mask[int(y):int(y + 0.18 * h) - 4, int(x + 0.35 * w):int(x + 0.65 * w)] = 255
    blobs = _blobs(mask)
    assert len(blobs) == 3
    assert len(set(merge_stacked(blobs, np.full(3, h), 1.2).tolist())) == 1
    det = person_boxes(mask, blobs, camera, 1.7, 0.4)
    assert len(det) == 1
    assert iou_matrix(np.array([[x, y, w, h]]), det.boxes_xywh_px)[0, 0] > 0.85
    # the box's height is the camera's person height at its foot
    b = det.boxes_xywh_px[0]
    foot = [[b[0] + b[2] / 2, b[1] + b[3]]]
    assert b[3] == pytest.approx(predicted_box_heights(camera, foot)[0], rel=1e-9)
    assert 0.5 < det.scores[0] <= 1.0


def test_two_people_side_by_side_are_split_and_far_blobs_stay_apart(camera):
    a = _person(camera, 250.0, 420.0)
    b = _person(camera, 250.0 + a[2], 420.0)  # shoulder to shoulder: one wide blob
    c = _person(camera, 500.0, 300.0)  # someone else, farther away
    mask = np.zeros(SIZE[::-1], np.uint8)
    for x, y, w, h in (a, b, c):
        mask[int(y):int(y + h), int(x):int(x + w) + 1] = 255
    blobs = _blobs(mask)
    assert len(blobs) == 2
    det = person_boxes(mask, blobs, camera, 1.7, 0.4)
    assert len(det) == 3
    iou = iou_matrix(np.array([a, b, c]), det.boxes_xywh_px)
    assert np.all(iou.max(axis=1) > 0.7), iou
    # without the split the wide blob is one box that matches neither person at IoU 0.5
    wide = blobs[np.argmax(blobs[:, 2])]
    assert iou_matrix(np.array([a, b]), wide[None]).max() < 0.6


def test_person_boxes_need_the_runs_camera_and_valid_parameters(camera):
    det = BackgroundSubtractionDetector(person_height_m=1.7)
    with pytest.raises(ValueError, match=r"mog2: person_height_m=1.7 .*--camera"):
        det.setup(RunContext())
    with pytest.raises(ValueError, match=r"'person_aspect' must be a number > 0"):
        BackgroundSubtractionDetector(person_height_m=1.7, person_aspect=0).setup(
            RunContext(camera=camera))
    BackgroundSubtractionDetector().setup(RunContext())  # blob boxes: no camera needed
    det.setup(RunContext(camera=camera))
    assert det.camera_ is camera
    assert len(det.detect(Frame(1, np.zeros((480, 640, 3), np.uint8)))) == 0  # warm-up


@needs_pets
def test_person_boxes_find_more_pets_people_than_blob_boxes():
    """PETS 2009 S2.L1 frames 51-150 (after 50 of learning), the real camera View_001.xml:
    recall and precision at IoU 0.5 (flag-0 people count neither way) of the blob boxes and the
    person boxes of the same foreground masks."""
    from pftrack.geometry.formats import load_camera
    from pftrack_bench.fresh_video import detector_recall_precision

    cam = load_camera(PETS / "View_001.xml")
    blob = BackgroundSubtractionDetector()
    person = BackgroundSubtractionDetector(person_height_m=1.7)
    person.setup(RunContext(camera=cam))
    out_blob, out_person = {}, {}
    for frame in iter_frames(PETS / "vtest.avi", 1, 150):
        d_blob, d_person = blob.detect(frame), person.detect(frame)
        if frame.index > 50:
            out_blob[frame.index], out_person[frame.index] = d_blob, d_person
    gt = read_ground_truth(PETS / "gt.txt", 51, 150)
    rb = detector_recall_precision(gt, out_blob, 0.0)
    rp = detector_recall_precision(gt, out_person, 0.0)
    assert rb["detector_recall"] < 0.55, rb  # measured 0.469
    assert rp["detector_recall"] > 0.68, rp  # measured 0.734
    assert rp["detector_precision"] > 0.7, rp  # measured 0.765 (blob boxes: 0.507)
