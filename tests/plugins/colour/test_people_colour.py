"""The colour tracker for a user's own boxes: the ``image-box-sized`` observation (box size
following the matched detections), the ``people-colour`` preset through the one engine (births
from confirmed detections, the colour x detection likelihood keeping a person through frames
without detections, deaths), and ``pftrack run people-colour`` on a PETS slice."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from pftrack.contracts.components import Detections, Frame, RunContext, Target
from pftrack.geometry.boxes import box_iou
from pftrack.io.data import data_dir
from pftrack.workflows.pipeline import build_engine, load_config
from pftrack_colour.observation import SizedImageBoxObservation

PETS = data_dir() / "pets09"
needs_pets = pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")


def _target(tid: int = 1) -> Target:
    return Target(id=tid, state=np.zeros(6), box_xywh_px=np.zeros(4))


def test_sized_box_follows_matched_detections_within_limits():
    obs = SizedImageBoxObservation(size_rate=0.25, size_limits=(0.5, 2.0))
    obs.setup(RunContext())
    t = _target()
    obs.init_target(t, np.array([10.0, 20.0, 20.0, 50.0]))
    assert t.box_wh_px == (20.0, 50.0)
    obs.update_target(t, np.array([0.0, 0.0, 28.0, 70.0]))
    assert t.box_wh_px == pytest.approx((22.0, 55.0))  # 0.75 * old + 0.25 * detection
    for _ in range(100):  # a huge detection: bounded at twice the starting size
        obs.update_target(t, np.array([0.0, 0.0, 400.0, 900.0]))
    assert t.box_wh_px == pytest.approx((40.0, 100.0))
    obs.update_target(t, np.array([0.0, 0.0, np.nan, 5.0]))  # ignored
    assert t.box_wh_px == pytest.approx((40.0, 100.0))
    boxes = obs.to_boxes(np.array([[100.0, 200.0, 0, 0, 0, 0]]), t)
    np.testing.assert_allclose(boxes, [[80.0, 150.0, 40.0, 100.0]])
    obs.end_target(t)
    assert obs.start_wh_ == {}
    still = SizedImageBoxObservation(size_rate=0.0)
    t2 = _target(2)
    still.init_target(t2, np.array([0.0, 0.0, 20.0, 50.0]))
    still.update_target(t2, np.array([0.0, 0.0, 30.0, 60.0]))
    assert t2.box_wh_px == (20.0, 50.0)


@pytest.mark.parametrize("kw, message", [
    ({"size_rate": 1.5}, r"'image-box-sized'\): parameter 'size_rate' must be a number in \[0, 1"),
    ({"size_limits": (1.2, 2.0)}, "image-box-sized: size_limits must be"),
])
def test_sized_box_rejects_bad_parameters(kw, message):
    with pytest.raises(ValueError, match=message):
        SizedImageBoxObservation(**kw).setup(RunContext())


def _walker_video(n: int = 40, gap: tuple[int, int] = (21, 30)):
    """A 320x240 noisy grey street; a person-like box (red top, blue trousers, 20 x 50 px)
    walks right at 3 px/frame until frame 20 and then stands still; detections (the true box)
    in every frame except ``gap``; plus a grey-clad walker detected throughout."""
    rng = np.random.default_rng(7)
    frames, truth, dets = [], [], {}
    for k in range(1, n + 1):
        img = rng.integers(100, 140, size=(240, 320, 3), dtype=np.uint8)
        x = 60.0 + 3.0 * min(k, 20)
        box = np.array([x, 120.0, 20.0, 50.0])
        xi = int(x)
        img[120:145, xi:xi + 20] = (30, 30, 200)  # BGR red top
        img[145:170, xi:xi + 20] = (160, 60, 20)  # blue trousers
        other = np.array([250.0 - 2.0 * k, 40.0, 16.0, 40.0])
        oi = int(other[0])
        img[40:80, oi:oi + 16] = (90, 90, 90)
        frames.append(Frame(k, img))
        truth.append(box)
        rows = [other] if gap[0] <= k <= gap[1] else [box, other]
        dets[k] = Detections(np.array(rows), np.full(len(rows), 0.9))
    return frames, np.array(truth), dets


def _run(cfg, frames, dets):
    engine = build_engine(cfg, seed=0)
    out = []
    boxes_in_gap = {}
    for f in frames:
        out.extend(engine.step(f, dets[f.index]))
        for t in engine.targets:
            if 21 <= f.index <= 30:
                boxes_in_gap.setdefault(t.id, []).append(t.box_xywh_px.copy())
    return engine, out, boxes_in_gap


def test_people_colour_keeps_a_person_through_missed_detections_where_detections_alone_drift():
    frames, truth, dets = _walker_video()
    cfg = load_config("people-colour")
    cfg["detector"] = None
    engine, out, gap = _run(cfg, frames, dets)
    ids = {r.id for r in out if box_iou(r.box_xywh_px[None], truth[r.frame - 1][None])[0] > 0.5}
    assert len(ids) == 1  # one identity for the walker, from birth to the end
    tid = ids.pop()
    # through the 10 frames without its detection the colour holds the box on the person
    ious = [box_iou(b[None], truth[20 + i][None])[0] for i, b in enumerate(gap[tid])]
    assert min(ious) > 0.7, ious
    walker = [r for r in out if r.id == tid]
    assert walker[0].frame <= 3  # confirmation costs no frames: output from birth on
    assert {r.frame for r in walker} >= set(range(31, 41))  # re-matched after the gap
    # the same run with the colour term weighted 0: the box coasts away on its velocity
    nocol = copy.deepcopy(cfg)
    nocol["likelihood"]["params"]["terms"][1]["weight"] = 0.0
    _, _, gap0 = _run(nocol, frames, dets)
    drift = [box_iou(gap0[tid][i][None], truth[20 + i][None])[0] for i in range(len(gap0[tid]))]
    assert drift[-1] < 0.5, drift


def test_people_colour_tracks_die_when_lost():
    frames, truth, dets = _walker_video(n=70, gap=(21, 70))
    cfg = load_config("people-colour")
    cfg["detector"] = None
    cfg["tracker"]["max_misses"] = 25
    engine, out, _ = _run(cfg, frames, dets)
    walker_ids = {r.id for r in out if r.frame <= 20
                  and box_iou(r.box_xywh_px[None], truth[r.frame - 1][None])[0] > 0.5}
    assert len(walker_ids) == 1
    tid = walker_ids.pop()
    assert tid not in {t.id for t in engine.targets}  # 50 frames unmatched: gone
    hidden = cfg["tracks"]["params"]["hide_after_misses"]
    assert max(r.frame for r in out if r.id == tid) == 20 + hidden


@needs_pets
@pytest.mark.slow
def test_pftrack_run_people_colour_on_a_pets_slice(tmp_path):
    """``pftrack run people-colour`` with the registered hog-people detector on PETS 2009 S2.L1
    frames 1-120 (tuning frames): tracks.txt, metrics.json and report images, MOTA and IDF1 above
    measured floors (measured at seed 0: MOTA 0.745, IDF1 0.753; people-image with its birth
    size kept, on the same frames and detector: 0.569, 0.709). About 15 s of CPU time (the
    detector's pass is most of it)."""
    from pftrack.cli import main

    out = tmp_path / "run"
    assert main(["run", "people-colour", "--video", str(PETS / "vtest.avi"), "--gt",
                 str(PETS / "gt.txt"), "--frames", "1:120", "--out", str(out), "--quiet"]) == 0
    rows = np.loadtxt(out / "tracks.txt", delimiter=",")
    assert rows.shape[1] == 10 and rows[:, 0].min() >= 1 and rows[:, 0].max() <= 120
    m = json.loads((out / "metrics.json").read_text())
    assert m["MOTA"] > 0.68, m
    assert m["IDF1"] > 0.68, m
    assert sorted(p.name for p in (out / "report").glob("*.png"))
