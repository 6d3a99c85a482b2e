"""The multi-target tracker loop: tracking, seeding, recovery, birth and death, streaming."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SampleWalk
from pftrack.builtin.image_box import ImageBoxObservation
from pftrack.contracts.components import Detections, Detector, Frame, Likelihood, Target
from pftrack.engine.tracker import MultiTargetTracker, records_to_mot
from pftrack_basic.motion import RandomWalkMotion
from pftrack_basic.tracks import DetectionBirthTracks


class _TruthLikelihood(Likelihood):
    """Gaussian around a per-target truth the test sets each frame (``truth_`` by id)."""

    def __init__(self, sigma_px: float = 4.0) -> None:
        self.sigma_px = sigma_px

    def begin_frame(self, frame, targets, detections=None):
        self.frame_ = frame.index

    def log_likelihood(self, boxes, target):
        c = boxes[:, :2] + boxes[:, 2:] / 2
        truth = self.truth_[target.id](self.frame_)
        if truth is None:
            return np.full(len(boxes), -np.inf)
        d2 = np.sum((c - truth) ** 2, axis=1)
        return -d2 / (2 * self.sigma_px**2)


def _frames(n, size=(200, 100)):
    img = np.zeros((size[1], size[0], 3), np.uint8)
    for k in range(1, n + 1):
        yield Frame(k, img, k / 25.0)


def _track(seed, n_frames=60, truth=None):
    lik = _TruthLikelihood()
    truth = truth or {1: lambda k: np.array([20.0 + 2 * k, 50.0])}
    lik.truth_ = truth
    tr = MultiTargetTracker(SampleWalk(3.0), lik, ImageBoxObservation(10, 10), n_particles=300,
                            rng=np.random.default_rng(seed), kill_out_of_view=False)
    frames = list(_frames(n_frames))
    tr.add_target(frames[0], np.array([20.0, 50.0]), target_id=1)
    recs = [r for f in frames[1:] for r in tr.step(f)]
    return tr, records_to_mot(recs)


def test_follows_a_moving_target_within_a_few_pixels():
    _, mot = _track(0)
    centres = mot[:, 2:4] + mot[:, 4:6] / 2
    truth = np.stack([20.0 + 2 * mot[:, 0], np.full(len(mot), 50.0)], axis=1)
    err = np.linalg.norm(centres - truth, axis=1)
    assert len(mot) == 59
    assert np.median(err[10:]) < 3.0, err


def test_same_seed_bit_identical_other_seed_differs():
    _, a = _track(7)
    _, b = _track(7)
    _, c = _track(8)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_recovers_when_every_weight_vanishes_and_never_returns_nan():
    # truth disappears for frames 20..24 (likelihood -inf everywhere), then comes back
    truth = {1: lambda k: None if 20 <= k < 25 else np.array([100.0, 50.0])}
    tr, mot = _track(1, truth=truth)
    assert np.all(np.isfinite(mot[:, 2:7]))
    assert tr.recoveries == 5
    centre = mot[-1, 2:4] + 5
    assert np.linalg.norm(centre - [100, 50]) < 3.0


class _ListDetector(Detector):
    def __init__(self, boxes_by_frame: dict | None = None) -> None:
        self.boxes_by_frame = boxes_by_frame

    def detect(self, frame):
        b = self.boxes_by_frame.get(frame.index, np.zeros((0, 4)))
        return Detections(b, np.ones(len(b)))


class _NearestAssociator:
    kind = "associator"

    def associate(self, targets, detections):
        from pftrack.contracts.components import Assignment

        m = []
        used = set()
        for ti, t in enumerate(targets):
            c = t.box_xywh_px[:2] + t.box_xywh_px[2:] / 2
            d = np.linalg.norm(detections.boxes_xywh_px[:, :2] + 5 - c, axis=1)
            for di in np.argsort(d):
                if d[di] < 15 and di not in used:
                    m.append((ti, di))
                    used.add(di)
                    break
        return Assignment.from_matches(m, len(targets), len(detections))


def test_birth_from_detections_and_death_after_misses():
    # one object detected in frames 5..30 at a fixed place
    boxes = {k: np.array([[45.0, 45.0, 10.0, 10.0]]) for k in range(5, 31)}
    lik = _TruthLikelihood()
    lik.truth_ = {}
    lik.truth_ = type("T", (), {"__getitem__": lambda s, i: (lambda k: np.array([50.0, 50.0]))})()
    tr = MultiTargetTracker(SampleWalk(1.0), lik, ImageBoxObservation(10, 10), n_particles=100,
                            detector=_ListDetector(boxes), associator=_NearestAssociator(),
                            tracks=DetectionBirthTracks(min_score=0.5), max_misses=3,
                            rng=np.random.default_rng(0))
    out = {f.index: tr.step(f) for f in _frames(50)}
    alive = [k for k, recs in out.items() if recs]
    assert alive[0] == 5                      # born on its first detection
    assert alive[-1] == 33                    # 30 + 3 misses tolerated, dead at the 4th
    assert {r.id for recs in out.values() for r in recs} == {1}
    assert tr.targets == []


def test_valid_region_zeroes_particles_outside_and_kills_target_leaving_it():
    lik = _TruthLikelihood()
    lik.truth_ = {1: lambda k: np.array([20.0 + 4 * k, 50.0])}
    region = lambda p: p[:, 0] < 120.0  # noqa: E731
    tr = MultiTargetTracker(SampleWalk(3.0), lik, ImageBoxObservation(10, 10), n_particles=200,
                            valid_region=region, min_log_likelihood=-8.0, max_misses=2,
                            rng=np.random.default_rng(0))
    frames = list(_frames(60))
    tr.add_target(frames[0], np.array([24.0, 50.0]), target_id=1)
    last = 0
    for f in frames[1:]:
        recs = tr.step(f)
        for r in recs:
            assert r.position[0] < 120.0
            last = f.index
    # the truth crosses x = 120 at frame 25; particles are held inside the region, so the best
    # one falls 16 px (log-lik -8) behind at frame 28.75, and 3 misses later the target dies
    assert 28 <= last <= 31
    assert tr.targets == []


def test_rejects_missing_rng_and_bad_scheme():
    with pytest.raises(ValueError, match="rng"):
        MultiTargetTracker(SampleWalk(3.0), _TruthLikelihood(), ImageBoxObservation())
    with pytest.raises(ValueError, match="resampling scheme"):
        MultiTargetTracker(SampleWalk(3.0), _TruthLikelihood(), ImageBoxObservation(),
                           resampling="bogus", rng=np.random.default_rng(0))


def test_size_from_box_keeps_each_targets_initial_size():
    lik = _TruthLikelihood()
    lik.truth_ = {1: lambda k: np.array([50.0, 50.0]), 2: lambda k: np.array([150.0, 50.0])}
    tr = MultiTargetTracker(SampleWalk(3.0), lik, ImageBoxObservation(size_from_box=True),
                            n_particles=50, rng=np.random.default_rng(0))
    f = Frame(1, np.zeros((100, 200, 3), np.uint8))
    tr.add_target(f, box_xywh_px=np.array([40.0, 30.0, 20.0, 40.0]), target_id=1)
    tr.add_target(f, box_xywh_px=np.array([145.0, 45.0, 10.0, 10.0]), target_id=2)
    recs = {r.id: r for r in tr.step(Frame(2, f.image))}
    assert tuple(recs[1].box_xywh_px[2:]) == (20.0, 40.0)
    assert tuple(recs[2].box_xywh_px[2:]) == (10.0, 10.0)


@pytest.mark.parametrize("motion", ["test", "random-walk"])
def test_targets_vectorised_equal_one_at_a_time_bit_for_bit(motion):
    """The rows backend normalises, estimates and resamples all targets' filters as rows of
    one array; the reference, one target at a time, gives the same tracks (with recoveries:
    frames whose ends run target by target)."""
    scheme, ess = "systematic", 1.0
    truth = {1: lambda k: np.array([20.0 + 2 * k, 50.0]),
             2: lambda k: None if 30 <= k < 33 else np.array([150.0 - k, 40.0]),  # recoveries
             3: lambda k: np.array([100.0, 20.0 + 0.5 * k])}

    def run(vectorise):
        lik = _TruthLikelihood()
        lik.truth_ = truth
        walk = SampleWalk(3.0) if motion == "test" else RandomWalkMotion(sigma_px=1.0)
        tr = MultiTargetTracker(walk, lik, ImageBoxObservation(10, 10), n_particles=200,
                                resampling=scheme, ess_threshold=ess,
                                rng=np.random.default_rng(5), kill_out_of_view=False)
        tr.backend = "rows" if vectorise else "reference"
        frames = list(_frames(60))
        for tid, path in truth.items():
            tr.add_target(frames[0], path(0), target_id=tid)
        recs = [r for f in frames[1:] for r in tr.step(f)]
        return records_to_mot(recs), tr.recoveries

    (a, rec_a), (b, rec_b) = run(True), run(False)
    assert rec_a == rec_b == 3
    assert len(a) == 3 * 59
    assert np.array_equal(a, b)


@pytest.mark.skipif(not __import__("pftrack.filter._jit").filter._jit.ENABLED,
                    reason="PFTRACK_NO_JIT is set")
@pytest.mark.parametrize("scheme", ["systematic", "stratified"])
def test_small_count_kernels_give_the_numpy_paths_tracks_bit_for_bit(monkeypatch, scheme):
    """Once a likelihood has imported numba, the engine's small per-frame calls (random-walk
    noise of (T, N, 2), systematic resampling of (T, N) weights) run compiled: the tracks,
    recoveries and the Generator's final state are those of the numpy path."""
    import numba  # noqa: F401  (what a compiled likelihood does first)
    from pftrack.filter import _jit

    truth = {1: lambda k: np.array([20.0 + 2 * k, 50.0]),
             2: lambda k: None if 30 <= k < 33 else np.array([150.0 - k, 40.0]),
             3: lambda k: np.array([100.0, 20.0 + 0.5 * k])}

    def run(small):
        with monkeypatch.context() as m:
            m.setattr(_jit, "_small_warm", False)
            if not small:
                m.setattr(_jit, "warm_up_small", lambda: False)
            lik = _TruthLikelihood()
            lik.truth_ = truth
            rng = np.random.default_rng(11)
            tr = MultiTargetTracker(RandomWalkMotion(sigma_px=1.5), lik,
                                    ImageBoxObservation(10, 10), n_particles=300,
                                    resampling=scheme, rng=rng, kill_out_of_view=False)
            assert _jit.small_ready() is small
            frames = list(_frames(60))
            for tid, path in truth.items():
                tr.add_target(frames[0], path(0), target_id=tid)
            recs = [r for f in frames[1:] for r in tr.step(f)]
            return records_to_mot(recs), tr.recoveries, rng.random()

    (a, rec_a, next_a), (b, rec_b, next_b) = run(True), run(False)
    assert rec_a == rec_b == 3
    assert len(a) == 3 * 59
    assert a.tobytes() == b.tobytes()
    assert next_a == next_b  # the Generator ends in the same state


def test_the_likelihood_is_prepared_once_when_the_tracker_is_built_before_any_frame():
    class Counting(_TruthLikelihood):
        def prepare(self):
            self.prepared_ = getattr(self, "prepared_", 0) + 1

        def begin_frame(self, frame, targets, detections=None):
            assert self.prepared_ == 1  # prepared before the first frame
            super().begin_frame(frame, targets, detections)

    lik = Counting()
    lik.truth_ = {1: lambda k: np.array([20.0, 50.0])}
    tr = MultiTargetTracker(SampleWalk(3.0), lik, ImageBoxObservation(10, 10), n_particles=50,
                            rng=np.random.default_rng(0))
    assert lik.prepared_ == 1
    frames = list(_frames(3))
    tr.add_target(frames[0], np.array([20.0, 50.0]), target_id=1)
    for f in frames[1:]:
        tr.step(f)
    assert lik.prepared_ == 1


def test_a_composite_likelihood_prepares_its_terms(monkeypatch):
    from pftrack.host import get_host
    from pftrack_colour import _jit

    loaded = []
    monkeypatch.setattr(_jit, "warm_up", lambda: loaded.append(1))
    lik = get_host().build("likelihood", {"type": "composite", "params": {"terms": [
        {"likelihood": {"type": "cross-entropy-bg"}, "weight": 1.0},
        {"likelihood": {"type": "cross-entropy", "params": {"method": "histogram"}},
         "weight": 1.0}]}})
    MultiTargetTracker(SampleWalk(3.0), lik, ImageBoxObservation(10, 10), n_particles=10,
                       rng=np.random.default_rng(0))
    assert loaded == [1]  # the integral term loads the kernels; the histogram one needs none


def test_image_boxes_of_every_target_in_one_call_equal_one_target_at_a_time():
    from pftrack.contracts.components import ObservationModel

    obs = ImageBoxObservation(30.0, 20.0, size_from_box=True)
    targets = [Target(id=i, state=np.zeros(2), box_xywh_px=np.zeros(4)) for i in (1, 2, 3)]
    obs.init_target(targets[1], np.array([0.0, 0.0, 12.0, 7.0]))  # its own size
    states = np.random.default_rng(0).normal(size=(3, 40, 2)) * 100
    rows = obs.to_boxes_rows(states, targets)
    assert rows.shape == (3, 40, 4)
    for i, t in enumerate(targets):
        assert np.array_equal(rows[i], obs.to_boxes(states[i], t))
    assert np.array_equal(rows, ObservationModel.to_boxes_rows(obs, states, targets))
    assert np.all(rows[1, :, 2:] == [12.0, 7.0]) and np.all(rows[0, :, 2:] == [30.0, 20.0])


@pytest.mark.parametrize("vectorise, ess", [(True, 1.0), (False, 1.0), (False, 0.0)])
def test_resample_index_says_which_weighted_particle_each_particle_copies(vectorise, ess):
    """After a step, ``particle_boxes_xywh_px[resample_index]`` are the boxes of the current
    particles (vectorised rows and one target at a time); None when the frame kept its
    weights (ess 0: no resampling), after a recovery's re-spread and after set_particles."""
    truth = {1: lambda k: np.array([20.0 + 2 * k, 50.0]),
             2: lambda k: None if k == 3 else np.array([150.0 - k, 40.0])}
    lik = _TruthLikelihood()
    lik.truth_ = truth
    obs = ImageBoxObservation(10, 10)
    tr = MultiTargetTracker(SampleWalk(3.0), lik, obs, n_particles=200, ess_threshold=ess,
                            rng=np.random.default_rng(2), kill_out_of_view=False)
    tr.backend = "rows" if vectorise else "reference"
    frames = list(_frames(6))
    for tid, path in truth.items():
        tr.add_target(frames[0], path(0), target_id=tid)
    for f in frames[1:5]:
        tr.step(f)
        for t in tr.targets:
            ri = t.resample_index
            if ess == 0.0 or (t.id == 2 and f.index == 3):  # kept weights / re-spread
                assert ri is None
                continue
            assert ri is not None and ri.shape == (200,) and len(np.unique(ri)) < 200
            assert np.array_equal(t.particle_boxes_xywh_px[ri], obs.to_boxes(t.particles, t))
    if ess == 1.0:
        t = tr.set_particles(1, np.zeros((200, tr.motion.state_dim)))
        assert t.resample_index is None


class _NaNForOne(_TruthLikelihood):
    """``_TruthLikelihood`` whose target ``bad_id`` gets one NaN at frame ``bad_frame``."""

    bad_id, bad_frame = 2, 4

    def log_likelihood(self, boxes, target):
        out = super().log_likelihood(boxes, target)
        if target.id == self.bad_id and self.frame_ == self.bad_frame:
            out[7] = np.nan
        return out


@pytest.mark.parametrize("vectorise", [True, False])
@pytest.mark.parametrize("region", [None, "engine", "target"])
def test_a_nan_from_one_of_several_targets_stops_the_run_naming_that_target(vectorise, region):
    """All targets' log-likelihoods are checked once as the stacked (T, N) array; the error
    still names the likelihood, the frame and the target at fault, as the per-target check
    does (which runs where a valid region masks a row)."""
    from pftrack.engine.tracker import ComponentOutputError

    lik = _NaNForOne()
    lik.truth_ = {i: (lambda k, i=i: np.array([30.0 * i, 50.0])) for i in (1, 2, 3)}

    def inside(xy):
        return np.ones(len(xy), dtype=bool)

    tr = MultiTargetTracker(SampleWalk(3.0), lik, ImageBoxObservation(10, 10), n_particles=50,
                            rng=np.random.default_rng(1), kill_out_of_view=False,
                            valid_region=inside if region == "engine" else None)
    tr.backend = "rows" if vectorise else "reference"
    frames = list(_frames(6))
    for i in (1, 2, 3):
        t = tr.add_target(frames[0], np.array([30.0 * i, 50.0]), target_id=i)
        if region == "target":
            t.valid_region = inside
    for f in frames[1:3]:
        assert len(tr.step(f)) == 3
    with pytest.raises(ComponentOutputError,
                       match=r"_NaNForOne.*returned 1 NaN or \+inf log-likelihood\(s\) of 50 "
                             r"at frame 4 \(target 2\)"):
        tr.step(frames[3])


class _RowsTruth(_TruthLikelihood):
    """``_TruthLikelihood`` that also scores every target in one call (counting both)."""

    def log_likelihood(self, boxes, target):
        self.per_target_calls_ = getattr(self, "per_target_calls_", 0) + 1
        return super().log_likelihood(boxes, target)

    def log_likelihood_rows(self, boxes, targets):
        self.rows_calls_ = getattr(self, "rows_calls_", 0) + 1
        assert boxes.shape == (len(targets), boxes.shape[1], 4)
        return np.array([_TruthLikelihood.log_likelihood(self, b, t)
                         for b, t in zip(boxes, targets)])


def _three_targets(lik, vectorise=True, seed=5, n_frames=40):
    truth = {1: lambda k: np.array([20.0 + 2 * k, 50.0]),
             2: lambda k: None if 20 <= k < 23 else np.array([150.0 - k, 40.0]),  # recoveries
             3: lambda k: np.array([100.0, 20.0 + 0.5 * k])}
    lik.truth_ = truth
    tr = MultiTargetTracker(RandomWalkMotion(sigma_px=1.0), lik, ImageBoxObservation(10, 10),
                            n_particles=200, rng=np.random.default_rng(seed),
                            kill_out_of_view=False)
    tr.backend = "rows" if vectorise else "reference"
    frames = list(_frames(n_frames))
    for tid, path in truth.items():
        tr.add_target(frames[0], path(0), target_id=tid)
    recs = [r for f in frames[1:] for r in tr.step(f)]
    return tr, records_to_mot(recs)


def test_the_engine_scores_all_targets_in_one_call_when_the_likelihood_offers_it():
    """A likelihood overriding log_likelihood_rows gets one call per frame with every
    target's (T, N, 4) boxes and no per-target call; the tracks are those of the per-target
    calls bit for bit (rows kept in ``target.log_likelihoods``)."""
    assert not _TruthLikelihood().offers_rows() and _RowsTruth().offers_rows()
    rows_lik = _RowsTruth()
    tr, a = _three_targets(rows_lik)
    assert rows_lik.rows_calls_ == 39
    assert getattr(rows_lik, "per_target_calls_", 0) == 0
    assert tr.targets[0].log_likelihoods.shape == (200,)
    plain = _TruthLikelihood()
    _, b = _three_targets(plain)
    assert len(a) == 3 * 39 and tr.recoveries == 3
    assert a.tobytes() == b.tobytes()
    # the reference backend, one target at a time: the per-target method
    one = _RowsTruth()
    _, c = _three_targets(one, vectorise=False)
    assert getattr(one, "rows_calls_", 0) == 0 and one.per_target_calls_ == 3 * 39
    assert c.tobytes() == a.tobytes()


def test_the_default_rows_method_stacks_the_per_target_calls():
    lik = _TruthLikelihood()
    lik.truth_ = {1: lambda k: np.array([5.0, 5.0]), 2: lambda k: None}
    lik.frame_ = 1
    ts = [Target(id=i, state=np.zeros(2), box_xywh_px=np.zeros(4)) for i in (1, 2)]
    boxes = np.random.default_rng(0).uniform(0, 10, (2, 7, 4))
    got = Likelihood.log_likelihood_rows(lik, boxes, ts)
    assert got.shape == (2, 7)
    assert np.array_equal(got[0], lik.log_likelihood(boxes[0], ts[0]))
    assert np.all(got[1] == -np.inf)


class _RowsNaN(_RowsTruth):
    def log_likelihood_rows(self, boxes, targets):
        out = super().log_likelihood_rows(boxes, targets)
        if self.frame_ == 4:
            out[1, 3] = np.nan
        return out


class _RowsWrongShape(_RowsTruth):
    def log_likelihood_rows(self, boxes, targets):
        return super().log_likelihood_rows(boxes, targets)[:, :-1]


def test_errors_from_the_rows_method_name_the_likelihood_and_the_target():
    from pftrack.engine.tracker import ComponentOutputError

    with pytest.raises(ComponentOutputError,
                       match=r"_RowsNaN.*returned 1 NaN or \+inf log-likelihood\(s\) of 200 "
                             r"at frame 4 \(target 2\)"):
        _three_targets(_RowsNaN())
    with pytest.raises(ComponentOutputError,
                       match=r"_RowsWrongShape.*shape \(3, 199\) from log_likelihood_rows, "
                             r"expected \(3, 200\)"):
        _three_targets(_RowsWrongShape())


def _record_bytes(recs):
    """Every field of every record, as bytes (arrays) and values, for exact comparison."""
    out = []
    for r in recs:
        out.append((r.frame, r.id, r.box_xywh_px.tobytes(), r.state.tobytes(),
                    r.position.tobytes(), r.extent.tobytes(), r.confidence,
                    None if r.world_m is None else r.world_m.tobytes(), r.size_m))
    return out


@pytest.mark.skipif(not __import__("pftrack.filter._jit").filter._jit.ENABLED,
                    reason="PFTRACK_NO_JIT is set")
def test_rows_backend_compiled_and_numpy_give_the_references_records(monkeypatch):
    """The rows backend (compiled step 4, or numpy's rows functions) ends a frame for all
    targets at once (``_finish_rows``) and the next prediction reads the resampled rows as
    they are: every field of every record, the recoveries, the deaths and the generator's
    final state are the reference's; and the rows' end really runs (a spy counts it)."""
    import numba  # noqa: F401  (what a compiled likelihood does first)
    from pftrack.filter import _jit

    truth = {1: lambda k: np.array([20.0 + 4 * k, 50.0]),  # leaves the 200 px image: dies
             2: lambda k: None if 30 <= k < 33 else np.array([150.0 - k, 40.0]),  # recoveries
             3: lambda k: np.array([100.0, 20.0 + 0.5 * k])}
    calls = {"finish": 0, "reused": 0}

    def run(backend, compiled):
        calls.update(finish=0, reused=0)
        with monkeypatch.context() as m:
            m.setattr(_jit, "_small_warm", False)
            if not compiled:
                m.setattr(_jit, "warm_up_small", lambda: False)
            lik = _TruthLikelihood()
            lik.truth_ = truth
            rng = np.random.default_rng(3)
            motion = RandomWalkMotion(sigma_px=1.5)
            tr = MultiTargetTracker(motion, lik, ImageBoxObservation(10, 10), n_particles=300,
                                    rng=rng, min_log_likelihood=-20.0, max_misses=2,
                                    backend=backend)
            assert _jit.small_ready() is compiled
            real_finish, real_predict = tr._finish_rows, motion.predict_rows

            def finish(*a, **k):
                calls["finish"] += 1
                return real_finish(*a, **k)

            def predict_rows(states, *a, **k):
                last = tr.__dict__.get("_last_stack")
                calls["reused"] += last is not None and states is last[0]
                return real_predict(states, *a, **k)

            m.setattr(tr, "_finish_rows", finish)
            m.setattr(motion, "predict_rows", predict_rows)
            frames = list(_frames(60))
            for tid, path in truth.items():
                tr.add_target(frames[0], path(0), target_id=tid)
            recs = [r for f in frames[1:] for r in tr.step(f)]
            left = {t.id: (t.state.tobytes(), t.particles.tobytes(), t.misses)
                    for t in tr.targets}
            return _record_bytes(recs), tr.recoveries, left, rng.random()

    reference = run("reference", True)
    assert calls == {"finish": 0, "reused": 0}
    numpy_rows = run("rows", False)
    assert numpy_rows == reference
    compiled = run("rows", True)
    assert compiled == reference
    assert reference[1] == 3  # the recovery frames ended target by target
    assert 1 not in reference[2] and 3 in reference[2]  # target 1 left the image and died
    # frames 1-59 ended in _finish_rows but for the three whose ends ran target by target
    # (30-31 re-spread target 2, 32 its death by misses); the prediction after each of them
    # read its rows without a new stack, but at 1 (after add_target), at 31-33 (each after a
    # frame ended target by target) and at the frame after target 1's death
    assert calls["finish"] == 59 - 3
    assert calls["reused"] == 59 - 1 - 3 - 1


def test_box_sizes_kept_between_calls_follow_a_changed_size():
    """``ImageBoxObservation.to_boxes_rows`` keeps the targets' sizes between calls: a target
    whose ``box_wh_px`` changes (scale adaptation) gets boxes of its new size at once."""
    obs = ImageBoxObservation(10, 10)
    targets = [Target(id=i, state=np.zeros(2), box_xywh_px=np.zeros(4)) for i in (1, 2)]
    states = np.arange(2 * 3 * 2, dtype=float).reshape(2, 3, 2)
    first = obs.to_boxes_rows(states, targets)
    assert np.all(first[:, :, 2:] == 10.0)
    targets[1].box_wh_px = (20.0, 30.0)
    second = obs.to_boxes_rows(states, targets)
    assert np.all(second[0, :, 2:] == 10.0) and np.all(second[1, :, 2:] == [20.0, 30.0])
    assert np.array_equal(second[1, :, :2], states[1] - [10.0, 15.0])
    targets[1].box_wh_px = (20.0, 30.0)  # an equal new tuple: the same boxes
    assert np.array_equal(obs.to_boxes_rows(states, targets), second)
    obs.width_px = 12.0  # the default size changed
    assert np.all(obs.to_boxes_rows(states, targets)[0, :, 2] == 12.0)
