"""The track lifecycle as stages (:mod:`pftrack.engine.lifecycle`): the named track managers equal
their explicit stage lists and the rows they gave as single track managers; stages see tracks
read-only and run in the documented order."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import pytest
from pftrack.builtin.image_box import ImageBoxObservation
from pftrack.contracts.components import RunContext
from pftrack.contracts.stages import (
    ROLES,
    Birth,
    Confirm,
    Confirmer,
    End,
    FrameView,
    Hide,
    Initiator,
    Mask,
    Masker,
    Merger,
    OutputAs,
    OutputBox,
    Particles,
    Reidentifier,
    Reporter,
    Sizer,
    Terminator,
)
from pftrack.engine.lifecycle import StagedTracks
from pftrack.engine.tracker import MultiTargetTracker
from pftrack.testing.checks import _KitAssociator, _KitNearest, _KitWalk
from pftrack.testing.synthetic import synthetic_scene
from pftrack_basic.tracks import ConfirmedTracks, DetectionBirthTracks

#: every option of ``confirmed`` that acts on this small scene (merging, output boxes,
#: confirmation, the birth overlap test), and the colour model and border test beside them
CONFIRMED = dict(min_score=0.0, max_iou=0.2, confirm_hits=2, confirm_window=3, merge_iou=0.3,
                 hide_after_misses=1, end_at_border=True,
                 appearance={"bins": 8, "sigma": 0.2}, box_from_detection=0.5, box_min_iou=0.1)
#: the same as an explicit list of stages
STAGES = [
    {"type": "colour-reid", "params": {"bins": 8, "sigma": 0.2}},
    {"type": "output-boxes", "params": {"hide_after_misses": 1, "box_from_detection": 0.5,
                                        "box_min_iou": 0.1}},
    {"type": "hit-confirmation", "params": {"confirm_hits": 2, "confirm_window": 3}},
    "border-exit",
    {"type": "duplicate-merge", "params": {"merge_iou": 0.3}},
    {"type": "detection-births", "params": {"min_score": 0.0, "max_iou": 0.2}},
]
#: sha256 of the rows (frame, id, box rounded to 1e-9 px) that ``confirmed`` gave with these
#: parameters when it was one track manager driving the engine itself (117 rows, 6 ids)
CONFIRMED_ROWS_SHA = "834e3e91ba8e8904b54a270e2fb938acdf16b3e5f2ed3e956ef005dddeca81dc"


def _rows(tracks, seed: int = 3) -> np.ndarray:
    sc = synthetic_scene(seed=seed, n_frames=30)
    tracks.setup(RunContext())
    eng = MultiTargetTracker(_KitWalk(), _KitNearest(), ImageBoxObservation(20, 40),
                             tracks=tracks, associator=_KitAssociator(), detection_driven=True,
                             n_particles=64, init_spread=2.0, max_misses=3,
                             rng=np.random.default_rng(seed))
    out = [[r.frame, r.id, *r.box_xywh_px] for f in sc.frames
           for r in eng.step(f, sc.detections(f.index))]
    return np.array(out).reshape(-1, 6)


def test_confirmed_equals_its_stages_and_its_rows_as_one_manager():
    named = _rows(ConfirmedTracks(**CONFIRMED))
    explicit = _rows(StagedTracks(stages=STAGES))
    assert named.shape == (117, 6) and len(np.unique(named[:, 1])) == 6
    np.testing.assert_array_equal(named, explicit)
    assert hashlib.sha256(np.round(named, 9).tobytes()).hexdigest() == CONFIRMED_ROWS_SHA
    # the options act on this scene: without merging or output boxes the rows differ
    for key, value in [("merge_iou", 1.0), ("box_from_detection", 0.0), ("confirm_hits", 1)]:
        other = _rows(ConfirmedTracks(**{**CONFIRMED, key: value}))
        assert other.shape != named.shape or not np.array_equal(other, named), key


def test_births_is_the_unmatched_births_stage():
    named = _rows(DetectionBirthTracks(min_score=0.0))
    explicit = _rows(StagedTracks(stages=[{"type": "unmatched-births",
                                           "params": {"min_score": 0.0}}]))
    assert len(named) > 0
    np.testing.assert_array_equal(named, explicit)


def test_no_stage_outputs_every_estimate_and_starts_nothing():
    assert len(_rows(StagedTracks(stages=[]))) == 0


def test_unknown_stage_is_named():
    with pytest.raises(ValueError, match=r"tracks.stages\[1\].*no stage named 'nope'"):
        StagedTracks(stages=["border-exit", "nope"]).setup(RunContext())


class _Log:
    calls: list[str] = []


def _logged(role_cls, method, result=()):
    def run(self, view):
        _Log.calls.append(f"{self.role}.{method}")
        return result(self, view) if callable(result) else result

    return type(f"Logged{role_cls.__name__}", (role_cls,), {method: run})


def _births(self, view: FrameView):
    d = view.detections
    return [Birth(box_xywh_px=d.boxes_xywh_px[i], detection_index=int(i))
            for i in view.unmatched]


def test_roles_run_in_the_documented_order_and_see_tracks_read_only():
    writes = []

    def confirm(self, view: FrameView):
        arrays = [view.frame.image, view.detections.boxes_xywh_px, view.detections.scores,
                  view.unmatched]
        for t in view.tracks:
            arrays += [t.state, t.box_xywh_px]
            if t.detection is not None:
                arrays.append(t.detection.box_xywh_px)
        for a in arrays:
            try:
                a[...] = 0
            except ValueError:
                writes.append("refused")
            else:
                writes.append("written")
        return [Confirm(t.id) for t in view.tracks if t.tentative]

    stages = [_logged(Merger, "merge")(), _logged(Initiator, "initiate", _births)(),
              _logged(Initiator, "scheduled")(), _logged(Terminator, "terminate")(),
              _logged(Confirmer, "confirm", confirm)(), _logged(Reporter, "report")(),
              _logged(Sizer, "resize")(), _logged(Reidentifier, "observe")(),
              _logged(Masker, "mask")()]
    _Log.calls = []
    rows = _rows(StagedTracks(stages=stages))
    assert len(rows) and writes and set(writes) == {"refused"}
    # one frame with live tracks: before the predict, then after the estimates in ROLES order
    frame = ["initiator.scheduled", "sizer.resize", "reporter.report", "confirmer.confirm",
             "terminator.terminate", "merger.merge", "initiator.initiate", "masker.mask",
             "reidentifier.observe"]
    assert [c.split(".")[0] for c in frame[1:]] == list(ROLES)
    assert _Log.calls[:len(frame)] == frame
    assert _Log.calls[len(frame):2 * len(frame)] == frame


def test_an_end_keeps_or_withdraws_the_frame_record():
    class EndAll(Terminator):
        def __init__(self, output: bool = False) -> None:
            self.output = output

        def terminate(self, view: FrameView):
            return [End(t.id, "test", output=self.output) for t in view.tracks]

    births = {"type": "unmatched-births", "params": {"min_score": 0.0}}
    kept = _rows(StagedTracks(stages=[births, EndAll(output=True)]))
    gone = _rows(StagedTracks(stages=[births, EndAll(output=False)]))
    # a track born from a detection is output in its birth frame, then ends in its first
    # frame after that: with output=True that frame's record is kept
    assert len(kept) > len(gone) > 0


_DATA = Path(os.environ.get("PFTRACK_DATA", "")) / "pets09"


def _explicit_stages(cfg: dict) -> dict:
    """``cfg`` with its ``confirmed`` tracks written as the explicit list of their stages."""
    from pftrack.host import get_host

    tracks = get_host().build("tracks", cfg["tracks"])
    stages = [st.to_config() for st in tracks.build_stages()]
    return {**cfg, "tracks": {"type": "stages", "params": {"stages": stages}}}


@pytest.mark.slow
@pytest.mark.skipif(not (_DATA / "vtest.avi").is_file(), reason="PETS 2009 data not found")
@pytest.mark.parametrize(("preset", "n_rows", "ids_sha", "sums"), [
    ("people-image", 160, "fbbab729e72df8d4fa179d1ef047a31d0012165e1fa18da92bc3e3f6b3855aaa",
     [77087.990072, 34116.386982, 5095.500431, 13694.61732, 107.286819, -1407.221702,
      -1445.905112, 0.0, 39755835.512384, 7462106.24907, 164416.51171, 1189216.329708,
      96.659855, 12929.927482, 14646.594753, 0.0]),
    ("people-ground", 150, "d3195face9b21e982f1e71047b6aff0c5810e40425ff681d1c401da34fbe6fdb",
     [72309.151561, 32165.951869, 4415.82024, 12670.517681, 112.333828, -1319.372201,
      -1353.908452, 0.0, 37190766.591814, 7087300.92882, 131251.741536, 1084754.0177,
      94.716443, 12186.980721, 13670.988913, 0.0]),
])
def test_presets_track_pets_as_their_explicit_stages(preset, n_rows, ids_sha, sums, tmp_path):
    """PETS frames 1-40 with the bench's simulated noisy detections (seed 0), seed 0: the
    presets' ``confirmed`` tracks and the same written as their explicit stages give the same
    rows, and those rows are the ones measured when this was written (the image-plane preset's
    with their ground positions through the camera, its boxes' feet): the frames and ids
    exactly, the boxes, scores and ground positions by the sum and the sum of squares of each
    column to 1e-6. Not by a hash of rounded values: the last bits of the floats depend on the
    vector instructions numpy uses on the machine (about 1e-13 here), and a value that lies on a
    rounding boundary then rounds either way."""
    from pftrack.io.detections import read_detections
    from pftrack.workflows.pipeline import load_config, run_pipeline
    from pftrack_bench.own_detections import simulate_detections

    gt = np.loadtxt(_DATA / "gt.txt", delimiter=",")
    det = simulate_detections(gt[gt[:, 0] <= 40], "noisy", 0, (768, 576))
    np.savetxt(tmp_path / "det.txt", det, delimiter=",")
    rows = []
    for cfg in (load_config(preset), _explicit_stages(load_config(preset))):
        r = run_pipeline(cfg, video=_DATA / "vtest.avi", camera=_DATA / "View_001.xml",
                         frames=(1, 40), detections=read_detections(tmp_path / "det.txt"),
                         seed=0, progress=False, report=False)
        rows.append(r.rows)
    assert np.array_equal(rows[0], rows[1])
    assert rows[0].shape == (n_rows, 10)
    r = rows[0]
    assert hashlib.sha256(r[:, :2].astype(np.int64).tobytes()).hexdigest() == ids_sha
    fingerprint = np.concatenate([r[:, 2:].sum(axis=0), (r[:, 2:] ** 2).sum(axis=0)])
    np.testing.assert_allclose(fingerprint, sums, rtol=1e-12, atol=1e-6)
    if preset == "people-image":  # image-plane rows on the ground: their boxes' feet
        from pftrack.geometry.boxes import foot_points
        from pftrack.geometry.formats import load_camera

        feet = load_camera(_DATA / "View_001.xml").image_to_ground(foot_points(rows[0][:, 2:6]))
        np.testing.assert_allclose(rows[0][:, 7:10], feet)


def test_a_stage_list_reads_pixels_only_through_its_stages():
    from types import SimpleNamespace

    from pftrack.host import get_host
    from pftrack.workflows.stream import image_readers

    lik = get_host().build("likelihood", "gaussian")

    def readers(stages):
        tracks = StagedTracks(stages=stages)
        tracks.setup(RunContext())
        return image_readers(SimpleNamespace(likelihood=lik, tracks=tracks))

    assert readers(["detection-births", "hit-confirmation", "duplicate-merge"]) == []
    assert readers(["colour-reid", "detection-births"]) == ["stage 'colour-reid'"]


class _LeftHalf:
    """A picklable region: x below ``x_max`` (pixels)."""

    def __init__(self, x_max: float) -> None:
        self.x_max = x_max

    def __call__(self, positions: np.ndarray) -> np.ndarray:
        return positions[:, 0] < self.x_max


def test_a_maskers_regions_reach_the_weighting_and_can_be_lifted():
    """A masker's :class:`Mask` sets where a track's particles may live: from the next frame
    on, its particles beyond the region get likelihood 0 (-inf); a mask of None lifts it; the
    tracks end only by the filter's rules (the rows are those without masks until then)."""
    seen: list[tuple[int, float]] = []

    class Halves(Masker):
        def mask(self, view: FrameView):
            # every track kept left of its own estimate's x, until frame 10: lifted
            lift = view.frame.index >= 10
            return [Mask(t.id, None if lift else _LeftHalf(float(t.state[0])))
                    for t in view.tracks]

    class Spy(Reidentifier):
        def observe(self, view: FrameView):
            seen.append((view.frame.index, len(view.tracks)))

    births = {"type": "unmatched-births", "params": {"min_score": 0.0}}
    tracks = StagedTracks(stages=[births, Halves(), Spy()])
    sc = synthetic_scene(seed=3, n_frames=14)
    tracks.setup(RunContext())
    eng = MultiTargetTracker(_KitWalk(), _KitNearest(), ImageBoxObservation(20, 40),
                             tracks=tracks, associator=_KitAssociator(), detection_driven=True,
                             n_particles=64, init_spread=2.0, max_misses=3,
                             rng=np.random.default_rng(3))
    barred = {}
    for f in sc.frames:
        eng.step(f, sc.detections(f.index))
        barred[f.index] = sum(int(np.isneginf(t.log_likelihoods).sum()) for t in eng.targets
                              if t.log_likelihoods is not None)
        if f.index >= 10:
            assert all(t.valid_region is None for t in eng.targets)
        elif eng.targets:
            assert all(isinstance(t.valid_region, _LeftHalf) for t in eng.targets)
    assert seen and max(n for _, n in seen) >= 2
    # particles right of the last estimate were barred while the masks held, none after
    assert sum(v for k, v in barred.items() if k <= 10) > 0
    assert sum(v for k, v in barred.items() if k > 10) == 0


class _BoxedHalf:
    """A picklable region that reads the particles' boxes: the box's left edge below
    ``x_max`` (pixels); records each call's boxes."""

    def __init__(self, x_max: float, calls: list) -> None:
        self.x_max, self.calls = x_max, calls

    def __call__(self, positions: np.ndarray, boxes: np.ndarray | None) -> np.ndarray:
        self.calls.append((len(positions), None if boxes is None else boxes.shape,
                           None if boxes is None else boxes.flags.writeable))
        return boxes[:, 0] < self.x_max


def test_births_with_particles_and_particles_decisions_apply_in_the_order_returned():
    """An initiator's generator: a :class:`Birth` carrying particles starts a track with
    exactly them (after the engine's own draws), every stage hears of it before the generator
    goes on, and a :class:`Particles` decision then replaces them; the stage draws from the
    run's generator (``FrameView.rng`` is the engine's); tracks show their particles,
    log-likelihoods, particle boxes and resample index read-only; a :class:`Mask` with
    ``boxes`` gets the weighted particles' boxes; an :class:`OutputBox` sets the record's
    ground position and size."""
    seen: dict = {"rng": [], "started": [], "views": [], "calls": []}

    class Seeded(Initiator):
        def initiate(self, view: FrameView):
            seen["rng"].append(view.rng)
            m = view.models
            if view.frame.index != 2:
                return
            first = np.zeros((m.n_particles, m.state_dim))
            first[:, :2] = 40.0
            b = Birth(position=np.array([40.0, 40.0]), particles=first, supported=False)
            yield b
            tid = seen["started"][-1]
            yield Particles(tid, view.rng.normal(80.0, 1.0, (m.n_particles, m.state_dim)))

        def track_started(self, track, birth):
            seen["started"].append(track.id)
            seen["born"] = track.particles.copy()

    class Spy(Reporter):
        def report(self, view: FrameView):
            seen["views"].append(view.tracks)
            return [OutputBox(t.id, t.box_xywh_px, world_m=np.array([1.0, 2.0, 0.0]),
                              size_m=np.array([0.5, 1.7, 0.5])) for t in view.tracks]

    class Boxed(Masker):
        def mask(self, view: FrameView):
            return [Mask(t.id, _BoxedHalf(70.0, seen["calls"]), boxes=True)
                    for t in view.tracks]

    tracks = StagedTracks(stages=[Seeded(), Spy(), Boxed()])
    tracks.setup(RunContext())
    rng = np.random.default_rng(3)
    eng = MultiTargetTracker(_KitWalk(), _KitNearest(), ImageBoxObservation(20, 40),
                             tracks=tracks, n_particles=16, rng=rng)
    sc = synthetic_scene(seed=3, n_frames=4)
    records = {f.index: eng.step(f, sc.detections(f.index)) for f in sc.frames}
    assert seen["rng"] and all(r is rng for r in seen["rng"])
    assert len(seen["started"]) == 1
    np.testing.assert_array_equal(seen["born"][:, :2], np.full((16, 2), 40.0))
    # the birth's record is of its given particles' mean; then the Particles decision moved it
    (born,) = records[2]
    np.testing.assert_array_equal(born.state[:2], [40.0, 40.0])
    t = eng.targets[0]
    assert np.abs(t.state[:2] - 80.0).max() < 20.0  # the particles set after the birth
    # later frames: the views hold the particles read-only, the records the reported fields
    (v,) = seen["views"][-1]
    for a in (v.particles, v.log_likelihoods, v.particle_boxes_xywh_px, v.resample_index):
        assert a is not None and not a.flags.writeable
    (r,) = records[4]
    np.testing.assert_array_equal(r.world_m, [1.0, 2.0, 0.0])
    np.testing.assert_array_equal(r.size_m, [0.5, 1.7, 0.5])
    # the mask read the boxes of the 16 particles being weighted, read-only
    assert seen["calls"] and all(c == (16, (16, 4), False) for c in seen["calls"])
    barred = np.isneginf(t.log_likelihoods)
    assert 0 < barred.sum() < 16  # the particles whose box's left edge is right of x = 70
    np.testing.assert_array_equal(barred, t.particle_boxes_xywh_px[:, 0] >= 70.0)


_BIRTHS = {"type": "unmatched-births", "params": {"min_score": 0.0}}


def _ids_by_frame(rows: np.ndarray) -> dict[int, set[int]]:
    out: dict[int, set[int]] = {}
    for f, i in rows[:, :2].astype(int):
        out.setdefault(int(f), set()).add(int(i))
    return out


def test_output_as_gives_this_frames_records_another_id():
    """A reidentifier's :class:`OutputAs` relabels the track's records output in that frame
    only, after every other stage (the reidentifier is called last)."""

    class Renamer(Reidentifier):
        def observe(self, view: FrameView):
            if view.frame.index % 2:
                return None
            return [OutputAs(t.id, 100 + t.id) for t in view.tracks]

    plain = _rows(StagedTracks(stages=[_BIRTHS]))
    renamed = _rows(StagedTracks(stages=[_BIRTHS, Renamer()]))
    even = renamed[:, 0] % 2 == 0
    assert even.any() and (~even).any()
    np.testing.assert_array_equal(renamed[even, 1], plain[even, 1] + 100)
    np.testing.assert_array_equal(renamed[~even, 1], plain[~even, 1])
    np.testing.assert_array_equal(renamed[:, [0, 2, 3, 4, 5]], plain[:, [0, 2, 3, 4, 5]])


class _ConfirmSecond(Confirmer):
    """Confirms a tentative track in its second frame (its ``frames``-th; ``at_end`` as
    given)."""

    def __init__(self, at_end: bool = False, frames: int = 2) -> None:
        self.at_end = at_end
        self.frames = frames
        self.age: dict[int, int] = {}

    def track_started(self, track, birth):
        self.age[track.id] = 1

    def confirm(self, view: FrameView):
        out = []
        for t in view.tracks:
            if t.tentative and t.id in self.age:
                self.age[t.id] += 1
                if self.age[t.id] >= self.frames:
                    out.append(Confirm(t.id, at_end=self.at_end))
        return out


class _EndNewlyConfirmed(Merger):
    """Ends every track the first time it sees it confirmed (its first frame after its birth
    frame, when :class:`_ConfirmSecond` confirmed it)."""

    def __init__(self) -> None:
        self.seen: set[int] = set()

    def merge(self, view: FrameView):
        new = [t.id for t in view.tracks if not t.tentative and t.id not in self.seen]
        self.seen.update(t.id for t in view.tracks)
        return [End(tid, "test") for tid in new]


def test_confirm_at_end_outputs_the_held_records_only_if_the_track_is_still_live():
    """:class:`Confirm` outputs the held records now (a merger of the same frame withdraws
    only that frame's record); with ``at_end`` at the end of the frame, and none of a track
    a later stage ended in it."""

    now = _rows(StagedTracks(stages=[_BIRTHS, _ConfirmSecond(), _EndNewlyConfirmed()]))
    late = _rows(StagedTracks(stages=[_BIRTHS, _ConfirmSecond(at_end=True),
                                      _EndNewlyConfirmed()]))
    kept = _rows(StagedTracks(stages=[_BIRTHS, _ConfirmSecond(at_end=True)]))
    plain = _rows(StagedTracks(stages=[_BIRTHS]))
    # confirmed at once, then merged: the birth frame's record is output, the second not
    assert len(now) > 0 and len(late) == 0
    ids, counts = np.unique(now[:, 1], return_counts=True)
    assert len(ids) > 1 and (counts == 1).all()
    # nothing ends them: the same records as without a confirmer
    np.testing.assert_array_equal(kept[np.lexsort((kept[:, 1], kept[:, 0]))],
                                  plain[np.lexsort((plain[:, 1], plain[:, 0]))])


def test_a_confirmer_may_drop_the_records_hidden_while_tentative_and_births_are_reported():
    """``Confirmer.holds_hidden`` False: a tentative track's records a reporter hides are not
    output on confirmation (True: they are); :meth:`Reporter.report_started` gives a new
    track's first record its box, or hides it."""

    class HideOdd(Reporter):
        def report(self, view: FrameView):
            return [Hide(t.id) for t in view.tracks if view.frame.index % 2]

        def report_started(self, track, birth):
            if birth.box_xywh_px is None:
                return ()
            box = np.asarray(birth.box_xywh_px, dtype=np.float64) + 1000.0
            return [Hide(track.id)] if track.id % 2 else [OutputBox(track.id, box)]

    class Dropping(_ConfirmSecond):
        holds_hidden = False

    held = _rows(StagedTracks(stages=[_BIRTHS, HideOdd(), _ConfirmSecond(frames=3)]))
    dropped = _rows(StagedTracks(stages=[_BIRTHS, HideOdd(), Dropping(frames=3)]))
    births = {}
    for f, i, *box in held.tolist():
        births.setdefault(int(i), (int(f), box))
    # held: every track's birth record is output (its box moved by report_started when even)
    even = [i for i in births if i % 2 == 0]
    assert even and all(births[i][1][0] > 900.0 for i in even)
    # dropped: no record of an odd frame while tentative, no hidden birth record
    drop_ids = _ids_by_frame(dropped)
    for i, (f0, _) in births.items():
        hidden = {f0: bool(i % 2), f0 + 1: bool((f0 + 1) % 2)}  # (birth: report_started)
        for f, hid in hidden.items():
            assert (i in drop_ids.get(f, ())) == (not hid), (i, f)
    assert len(dropped) < len(held)
