"""The eigenspace background model on thermal cameras: training that says what it got (an error
when no block can be trained, untrained blocks named and drawn), recalibrations survived
(:mod:`pftrack_coast.recalibration`), and the thermal part of ``pftrack bench background`` on
the real clip with its reference boxes."""

from __future__ import annotations

import argparse
import warnings

import numpy as np
import pytest
from pftrack.contracts.components import Frame
from pftrack.io.data import data_dir
from pftrack_bench import background as bb
from pftrack_coast.detector import EigenspaceDetector
from pftrack_coast.eigenspace import BlockEigenspaceModel, untrained_picture
from pftrack_coast.recalibration import RecalibrationGuard, RecalibrationWarning

CLIP = data_dir() / "thermal" / "animal_entry.cptv"


def textured(n: int, seed: int = 0, shape=(64, 64), sigma: float = 5.0) -> list[np.ndarray]:
    """Frames of a fixed texture (levels 70-130) plus Gaussian noise of ``sigma``."""
    rng = np.random.default_rng(seed)
    texture = 100.0 + np.random.default_rng(99).uniform(-30, 30, shape)
    return [texture + rng.normal(0.0, sigma, shape) for _ in range(n)]


def fit_quiet(model: BlockEigenspaceModel, frames, masks=None) -> BlockEigenspaceModel:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return model.fit(frames, masks)


def new_pattern(shape, seed: int = 5) -> np.ndarray:
    """A flat-field correction's change: -33 levels, a per-pixel pattern of 6 and a smooth
    shading of 15 (over 6 px)."""
    import cv2

    rng = np.random.default_rng(seed)
    field = cv2.GaussianBlur(rng.normal(0.0, 1.0, shape), (0, 0), 6.0)
    return -33.0 + rng.normal(0.0, 6.0, shape) + 15.0 * field / field.std()


# -- training that says what it got ------------------------------------------------------------


def test_too_few_background_frames_for_any_block_is_an_error_naming_them():
    # nine clean frames and the default min_samples=10: no block could ever be trained
    with pytest.raises(ValueError, match=r"none of the 64 blocks.*9 training frame\(s\) gave at "
                                         r"most 9.*min_samples=10"):
        BlockEigenspaceModel().fit(textured(9))
    # with masks: a block counts only in frames where it is background
    frames = textured(12)
    masks = [np.ones((64, 64), bool)] * 3 + [None] * 9
    with pytest.raises(ValueError, match=r"12 training frame\(s\) gave at most 9"):
        BlockEigenspaceModel().fit(frames, masks)
    assert BlockEigenspaceModel(min_samples=9).fit(frames, masks).trained_.all()


def test_untrained_blocks_are_named_never_intruders_by_default_and_drawn(tmp_path):
    frames = textured(20)
    masks = [np.zeros((64, 64), bool) for _ in frames]
    for k in range(15):  # blocks (2, 3) and (2, 4) are foreground in 15 of 20 frames
        masks[k][16:24, 24:40] = True
    with pytest.warns(UserWarning, match=r"2 of 64 blocks.*20 training frames.*are never "
                                         r"intruders.*\(2, 3\), \(2, 4\)"):
        m = BlockEigenspaceModel().fit(frames, masks)
    assert m.untrained == "ignore" and m.untrained_blocks_.tolist() == [[2, 3], [2, 4]]
    # a bright square there is not invented into an intruder
    test = textured(1, seed=7)[0]
    test[16:24, 24:40] += 200.0
    assert not m.score(test).intruder_mask.any()
    # "nearest" borrows a neighbour's background and flags the blocks
    near = fit_quiet(BlockEigenspaceModel(untrained="nearest"), frames, masks)
    assert near.score(test).intruder_mask[2, 3:5].all()
    # the picture: the untrained blocks red over the frame, the others grey
    import cv2

    p = untrained_picture(m, tmp_path / "untrained.png", image=frames[0], scale=4)
    img = cv2.imread(str(p))
    assert img.shape == (64 * 4 + 18, 64 * 4, 3)
    inside = img[2 * 32 + 2:3 * 32 - 2, 3 * 32 + 2:5 * 32 - 2].reshape(-1, 3).astype(int)
    outside = img[4 * 32:6 * 32, 0:64].reshape(-1, 3).astype(int)
    assert (inside[:, 2] - inside[:, 0]).min() > 60  # red dominates
    assert np.abs(outside[:, 2] - outside[:, 0]).max() == 0  # grey
    with pytest.raises(ValueError, match="must end in .png"):
        untrained_picture(m, tmp_path / "u.jpg")


# -- recalibrations ----------------------------------------------------------------------------


def test_guard_detects_a_flat_field_correction_holds_and_rebaselines():
    train = textured(40)
    model = fit_quiet(BlockEigenspaceModel(block_size=8, min_samples=10), train)
    plain = fit_quiet(BlockEigenspaceModel(block_size=8, min_samples=10), train)
    guard = RecalibrationGuard(model, warn=False)
    stream = textured(40, seed=1)
    pattern = new_pattern((64, 64))
    for k in range(10, 40):  # an object of +120 in block (1, 1) from frame 10 on
        stream[k][8:16, 8:16] += 120.0
    for k in range(20, 40):  # the correction at frame 20
        stream[k] = stream[k] + pattern
    got = [guard.score(f, time_s=0.1 * k, frame=k) for k, f in enumerate(stream)]
    flagged = np.array([r.intruder_mask.sum() for r in got])
    plain_flagged = np.array([plain.score(f).intruder_mask.sum() for f in stream])
    # before: only the object; the plain model after the event: most of the picture
    assert flagged[:10].max() == 0 and all(got[k].intruder_mask[1, 1] for k in range(10, 20))
    assert plain_flagged[20:].min() > 16
    # the event at frame 20, three frames held, then the object again and nothing else
    assert [e.frame for e in guard.events] == [20]
    # the step of the frame median: -33 plus the new pattern's own median
    step = np.median(stream[20][::4, ::4]) - np.median(stream[19][::4, ::4])
    causes = guard.events[0].causes
    assert causes[0] == f"a level step of {step:+.1f}" and step < -15
    assert causes[1].endswith("% of the trained blocks flagged") and len(causes) == 2
    assert guard.events[0].rebaselined_on == [20, 21, 22] and flagged[20:23].max() == 0
    assert all(got[k].intruder_mask[1, 1] and flagged[k] <= 2 for k in range(23, 40))
    assert "re-baselined" in guard.messages[1]
    # the object's block was an intruder before the event: its shift left the object out
    assert not guard.holding


def test_guard_time_gap_alone_and_the_detector_param():
    train = textured(30)
    guard = RecalibrationGuard(fit_quiet(BlockEigenspaceModel(), train), gap_s=1.0,
                               settle_frames=2, warn=False)
    stream = textured(6, seed=2)
    times = [0.0, 0.1, 0.2, 2.0, 2.1, 2.2]
    held = [not guard.score(f, time_s=t).r_map.any() for f, t in zip(stream, times)]
    assert held == [False, False, False, True, True, False]
    assert "1.80 s gap" in guard.events[0].causes[0]
    # the detector: recalibration mode "rebaseline" warns and gives no boxes while settling
    det = EigenspaceDetector(recalibration={"mode": "rebaseline", "gap_s": 1.0,
                                            "settle_frames": 2})
    det.fit_masks(train, [None] * len(train))
    out = []
    with pytest.warns(RecalibrationWarning, match="frame 3: recalibration"):
        for k, (f, t) in enumerate(zip(stream, times)):
            f = f.copy()
            f[8:16, 8:16] += 120.0
            out.append(len(det.detect(Frame(k, f, t)).boxes_xywh_px))
    assert out == [1, 1, 1, 0, 0, 1]
    with pytest.raises(ValueError, match="'recalibration.mode' must be one of 'rebaseline', "
                                         "'off'"):
        EigenspaceDetector(recalibration={"mode": "yes"})


# -- the thermal benchmark ---------------------------------------------------------------------


def bench_args(*argv: str) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    bb.add_arguments(p)
    return p.parse_args(["--sequences", "thermal", "--quiet", *argv])


def test_frame_spec():
    assert bb.frame_spec("1:5", 10, "--x") == [1, 2, 3, 4, 5]
    assert bb.frame_spec("2:9:3,0", 10, "--x") == [0, 2, 5, 8]
    with pytest.raises(ValueError, match=r"--thermal-train: '1:20' gives \[10, 11"):
        bb.frame_spec("1:20", 10, "--thermal-train")
    with pytest.raises(ValueError, match="--x: 'a:b' is not"):
        bb.frame_spec("a:b", 10, "--x")
    assert bb._ranges([2, 4, 6, 8]) == "2-8 step 2" and bb._ranges([1, 2, 3, 7]) == "1-3, 7"


needs_clip = pytest.mark.skipif(not CLIP.is_file(), reason=f"{CLIP} not found (shared data)")


@needs_clip
def test_reference_boxes_reproduce_the_shipped_annotation():
    pytest.importorskip("cptv")
    from pftrack.io.mot import read_mot
    from pftrack_coast.thermal import DEFAULT_ANNOTATION, read_thermal, reference_boxes

    clip = read_thermal(CLIP)
    assert len(clip.frames) == 171 and clip.background.tolist() == [True] + [False] * 170
    boxes = reference_boxes(clip.frames)
    rows = read_mot(DEFAULT_ANNOTATION)
    assert sorted(boxes) == rows[:, 0].astype(int).tolist() == list(range(1, 171))
    np.testing.assert_array_equal(np.stack([boxes[k] for k in range(1, 171)]), rows[:, 2:6])


@needs_clip
def test_thermal_bench_goals_with_and_without_a_recalibration():
    pytest.importorskip("cptv")
    t = bb.run(bench_args("--methods", "eigenspace"))["thermal"]
    runs = {r["clip"]: r for r in t["runs"]}
    assert set(runs) == {"recorded", "simulated"} and t["recalibration_at"] == 85
    assert t["train_frames"] == "2-170 step 2" and t["entry_frame"] == 1
    for r in runs.values():
        # measured: first detection at frame 1 (the entry), the empty frame 0 clear, recall
        # 0.988 as recorded (frame 43: the animal dim) and 0.953 with the recalibration (85,
        # 87, 89 held); block precision 1.000 both
        assert all(r["goals"].values()), r
        assert r["first_detection_frame"] == 1 and r["empty_frames"] == 1
    assert runs["simulated"]["recall"] < runs["recorded"]["recall"]
    assert "re-baselined" in runs["simulated"]["messages"][1]
    assert runs["recorded"]["messages"] == []
    # without the guard the simulated correction ruins precision (measured 0.103)
    off = bb.run(bench_args("--methods", "eigenspace", "--thermal-guard", "off",
                            "--thermal-recalibration", "simulated"))["thermal"]["runs"][0]
    assert off["block_precision"] < 0.2 and not off["goals"]["precision_0.9"]


@needs_clip
def test_thermal_bench_can_fail_and_refuses_what_it_cannot_measure(tmp_path):
    pytest.importorskip("cptv")
    # trained on frames 1-35, where the animal rests at the left: its 9 blocks untrained; with
    # "nearest" they borrow a neighbour's background and flag the empty frame 0
    base = ("--methods", "eigenspace", "--thermal-train", "1:35",
            "--thermal-recalibration", "none")
    near = bb.run(bench_args(*base, "--untrained", "nearest"))["thermal"]
    ign = bb.run(bench_args(*base, "--pictures", str(tmp_path)))["thermal"]
    assert len(near["untrained_blocks"]) == len(ign["untrained_blocks"]) == 9
    assert near["runs"][0]["false_alarm_frames"] == 1 and near["runs"][0]["goals"][
        "no_false_alarm"] is False
    assert ign["runs"][0]["false_alarm_frames"] == 0
    # the animal rests in the untrained blocks until frame 43: found late (measured 43)
    assert ign["runs"][0]["first_detection_frame"] > 39
    assert (tmp_path / "thermal_untrained_blocks.png").is_file()
    with pytest.raises(ValueError, match="has the animal in training frames 1-35"):
        bb.run(bench_args(*base, "--thermal-boxes-in-training", "refuse"))
    # an annotation made for another clip
    from pftrack_coast.thermal import DEFAULT_ANNOTATION

    other = tmp_path / "other.txt"
    other.write_text(DEFAULT_ANNOTATION.read_text().replace("sha256: df66", "sha256: 0000"))
    with pytest.raises(ValueError, match="was made for another clip"):
        bb.run(bench_args(*base, "--thermal-annotation", str(other)))
    # --methods is honoured: MOG2 alone, no eigenspace row or model
    mog = bb.run(bench_args("--methods", "mog2", "--thermal-recalibration", "none"))["thermal"]
    assert [r["method"] for r in mog["runs"]] == ["mog2"] and "untrained_blocks" not in mog
    # the animal rests through the training frames: MOG2 learns it (measured recall 0.353)
    assert mog["runs"][0]["recall"] < 0.5
    txt = bb.format_table({"rows": [], "thermal": mog})
    assert "mog2" in txt and "goals met" in txt


def test_guard_follows_slow_drift_away_from_intruders_only():
    """A smooth per-pixel drift builds up to 60 levels over 60 frames: the model as trained
    flags blocks all over the picture by the end; with adapt_rate the means away from the
    object follow it, and a warm object resting in block (1, 1) from frame 5 on is not learnt
    as background."""
    import cv2

    train = textured(40)
    rng = np.random.default_rng(4)
    field = cv2.GaussianBlur(rng.normal(0.0, 1.0, (64, 64)), (0, 0), 6.0)
    field = 60.0 * field / np.abs(field).max()
    stream = textured(60, seed=3)
    for k in range(60):
        stream[k] = stream[k] + field * k / 59
        if k >= 5:
            stream[k][8:16, 8:16] += 120.0
    # a mean lags a steady drift by (drift per frame) / adapt_rate: up to 1 level a frame here,
    # so 0.1 (10 levels behind); the default 0.02 is for a camera drifting far more slowly
    follow = RecalibrationGuard(fit_quiet(BlockEigenspaceModel(), train), adapt_rate=0.1,
                                warn=False)
    still = RecalibrationGuard(fit_quiet(BlockEigenspaceModel(), train), adapt_rate=0.0,
                               warn=False)
    a = [follow.score(f).intruder_mask for f in stream]
    b = [still.score(f).intruder_mask for f in stream]
    assert follow.events == [] and all(m[1, 1] for m in a[5:])
    # measured: only the object's block, in every frame from 5 (its 4-neighbours, kept from
    # following because they might hold part of it, stay below the threshold here)
    assert all(int(m.sum()) == 1 for m in a[5:])
    assert int(b[-1].sum()) > 8  # as trained: the drifted blocks flagged (measured 13)
    with pytest.raises(ValueError, match="adapt_rate must be in"):
        RecalibrationGuard(fit_quiet(BlockEigenspaceModel(), train), adapt_rate=1.0)


def test_follow_moves_means_and_offsets_as_a_rebaseline_does():
    train = textured(30)
    a = fit_quiet(BlockEigenspaceModel(), train)
    b = fit_quiet(BlockEigenspaceModel(), train)
    frame = textured(1, seed=8)[0] + 7.0
    proj = np.zeros(a.offset_.shape)
    r_a = a.score_grey(a.grey(frame), proj).r_map
    np.testing.assert_array_equal(r_a, b.score(frame).r_map)
    quiet = np.zeros(64, bool)
    quiet[::3] = True
    from pftrack_coast.eigenspace import blocks_of

    x = blocks_of(b.grey(frame), 8)
    a.follow(x, proj, quiet, 0.25)
    b.rebaseline(np.where(quiet[:, None], 0.25 * (x - b.mean_), 0.0))
    np.testing.assert_allclose(a.mean_, b.mean_, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.offset_, b.offset_, rtol=0, atol=1e-9)
    later = textured(1, seed=9)[0]
    np.testing.assert_allclose(a.score(later).r_map, b.score(later).r_map, rtol=1e-9, atol=1e-9)
