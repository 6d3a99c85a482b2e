"""The ``cloud`` associator: each track's predicted likelihood of each detection, matched
globally, confident detections first."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Detections, Target
from pftrack.host import get_host
from pftrack_basic.cloud_association import CloudAssociator, cloud_cost


def _target(tid: int, centre: tuple[float, float], spread_px: float, *, h: float = 100.0,
            n: int = 400, seed: int = 0, misses: int = 0) -> Target:
    rng = np.random.default_rng(seed)
    c = np.asarray(centre, dtype=np.float64) + rng.normal(0.0, spread_px, (n, 2))
    w = 0.4 * h
    boxes = np.c_[c[:, 0] - w / 2, c[:, 1] - h / 2, np.full(n, w), np.full(n, h)]
    est = np.array([centre[0] - w / 2, centre[1] - h / 2, w, h])
    return Target(id=tid, state=np.r_[centre, 0.0, 0.0], box_xywh_px=est,
                  particle_boxes_xywh_px=boxes, misses=misses)


def _dets(centres, scores, h: float = 100.0) -> Detections:
    c = np.asarray(centres, dtype=np.float64).reshape(-1, 2)
    w = 0.4 * h
    boxes = np.c_[c[:, 0] - w / 2, c[:, 1] - h / 2, np.full(len(c), w), np.full(len(c), h)]
    return Detections(boxes, np.asarray(scores, dtype=np.float64))


def _assoc(**kw) -> CloudAssociator:
    a = CloudAssociator(**kw)
    a.setup(None)
    return a


def test_cost_is_the_negative_log_of_the_clouds_predicted_likelihood():
    # every particle exactly at the detection, same height: likelihood 1, cost 0
    t = _target(1, (200.0, 300.0), 0.0)
    d = _dets([(200.0, 300.0), (210.0, 300.0)], [0.9, 0.9])
    c = cloud_cost([t], d, sigma=0.1, sigma_size=0.2)
    assert c[0, 0] == pytest.approx(0.0, abs=1e-12)
    # 10 px = 0.1 heights = one sigma away: 0.5
    assert c[0, 1] == pytest.approx(0.5, abs=1e-12)
    # a detection twice the track's height: (log 2 / 0.2)^2 / 2 added
    d2 = _dets([(200.0, 300.0)], [0.9], h=200.0)
    assert cloud_cost([t], d2, sigma=0.1, sigma_size=0.2)[0, 0] == pytest.approx(
        0.5 * (np.log(2.0) / 0.2) ** 2, rel=1e-9)


def test_a_spread_cloud_claims_a_detection_a_tight_one_does_not():
    # a track unseen for a while (its cloud spread 40 px) still claims a detection 50 px from
    # its mean; the same detection is outside a freshly matched track's gate
    d = _dets([(250.0, 300.0)], [0.9])
    tight = _target(1, (200.0, 300.0), 2.0)
    wide = _target(2, (200.0, 300.0), 40.0, misses=5)
    a = _assoc()
    assert len(a.associate([tight], d).matches) == 0
    m = a.associate([wide], d).matches
    assert m.tolist() == [[0, 0]]
    assert a.cost_[0, 0] < a.max_cost


def test_global_assignment_keeps_side_by_side_tracks_apart():
    # two people 30 px apart walking right, both detections 16 px ahead of their tracks: the
    # cheapest single pair is track 1 with the left person's detection (14 px), so a greedy
    # matching takes it and leaves track 0 nothing in its gate; the global matching gives
    # each track its own person's detection
    t0 = _target(1, (200.0, 300.0), 3.0, seed=1)
    t1 = _target(2, (230.0, 300.0), 3.0, seed=2)
    d = _dets([(216.0, 300.0), (246.0, 300.0)], [0.9, 0.9])
    a = _assoc(appearance_weight=0.0)
    m = {int(ti): int(di) for ti, di in a.associate([t0, t1], d).matches}
    assert m == {0: 0, 1: 1}
    c = a.cost_
    assert np.unravel_index(np.argmin(c), c.shape) == (1, 0)  # greedy's first pick
    assert c[0, 1] > a.max_cost  # ... after which track 0 has nothing left in its gate


def test_weak_detections_only_continue_recently_seen_tracks():
    d = _dets([(200.0, 300.0)], [0.4])  # below high_score 0.6
    recent = _target(1, (200.0, 300.0), 3.0, misses=1)
    lost = _target(2, (200.0, 300.0), 3.0, misses=3)
    a = _assoc(recent_misses=2)
    assert a.associate([recent], d).matches.tolist() == [[0, 0]]
    assert len(a.associate([lost], d).matches) == 0
    # confident: the lost track takes it
    d_hi = _dets([(200.0, 300.0)], [0.9])
    assert a.associate([lost], d_hi).matches.tolist() == [[0, 0]]


def test_confident_detections_are_matched_before_weak_ones():
    # one track, a weak detection on its mean and a confident one 5 px away: the confident
    # one wins, though the weak one is cheaper
    t = _target(1, (200.0, 300.0), 3.0)
    d = _dets([(200.0, 300.0), (205.0, 300.0)], [0.3, 0.9])
    a = _assoc()
    assert a.associate([t], d).matches.tolist() == [[0, 1]]


def test_appearance_adds_its_cost_and_nan_bars_the_pair():
    t0 = _target(1, (200.0, 300.0), 3.0, seed=1)
    d = _dets([(200.0, 300.0)], [0.9])
    a = _assoc(appearance_weight=1.0)
    base = a.costs([t0], d)[0, 0]
    t0.appearance_scores = np.array([0.5])
    assert a.costs([t0], d)[0, 0] == pytest.approx(base - np.log(0.5), rel=1e-12)
    t0.appearance_scores = np.array([np.nan])
    assert len(a.associate([t0], d).matches) == 0


def test_tracks_with_different_particle_counts_and_no_particles():
    t0 = _target(1, (200.0, 300.0), 3.0, n=50)
    t1 = _target(2, (400.0, 300.0), 3.0, n=80)
    t2 = Target(id=3, state=np.zeros(4), box_xywh_px=np.array([580.0, 250.0, 40.0, 100.0]))
    d = _dets([(400.0, 300.0), (200.0, 300.0), (600.0, 300.0)], [0.9, 0.9, 0.9])
    m = _assoc().associate([t0, t1, t2], d).matches.tolist()
    assert sorted(m) == [[0, 1], [1, 0], [2, 2]]


def test_non_finite_particle_boxes_are_ignored_and_all_nan_is_never_matched():
    t = _target(1, (200.0, 300.0), 3.0)
    t.particle_boxes_xywh_px[:100] = np.nan
    d = _dets([(200.0, 300.0)], [0.9])
    c = cloud_cost([t], d)
    assert np.isfinite(c).all()
    t.particle_boxes_xywh_px[:] = np.nan
    assert np.isinf(cloud_cost([t], d)).all()
    assert len(_assoc().associate([t], d).matches) == 0


@pytest.mark.parametrize("name,value", [("sigma", 0.0), ("sigma_size", -1.0), ("max_cost", 0),
                                        ("high_score", -0.1), ("appearance_weight", "x"),
                                        ("recent_misses", -1), ("recent_misses", 1.5)])
def test_bad_parameters_name_the_parameter(name, value):
    with pytest.raises(ValueError, match=name):
        CloudAssociator(**{name: value}).setup(None)


def test_registered_as_cloud():
    a = get_host().build("associator", {"type": "cloud", "params": {"sigma": 0.2}})
    assert isinstance(a, CloudAssociator) and a.sigma == 0.2


def _feed(a: CloudAssociator, offsets_h: np.ndarray, h: float = 100.0) -> None:
    """One frame per offset: a freshly matched track (tight cloud at 200, 300) and one
    detection ``offset`` detection heights to its right (the same height)."""
    for k, off in enumerate(offsets_h):
        t = _target(1, (200.0, 300.0), 0.0, h=h, n=20, seed=k)
        a.associate([t], _dets([(200.0 + off * h, 300.0)], [0.9], h=h))


def test_the_detections_scatter_is_measured_and_blended_with_the_assumed_one():
    a = _assoc(sigma=0.1, sigma_size=0.2, appearance_weight=0.0)
    assert a.scatter_ == (0.1, 0.1, 0.2)
    offs = np.random.default_rng(5).normal(0.0, 0.05, 300)
    _feed(a, offs)
    a.costs([], _dets([], []))  # the scatter is taken when costs are computed
    n, prior = 300, 50
    robust_x = 1.4826 * np.median(np.abs(offs))
    want_x = np.sqrt((prior * 0.1 ** 2 + n * robust_x ** 2) / (prior + n))
    sx, sy, ss = a.scatter_
    assert sx == pytest.approx(want_x, rel=1e-9)
    assert 0.04 < sx < 0.06
    # exact vertical centres and heights: measured zero, blended with the assumed values
    assert sy == pytest.approx(0.1 * np.sqrt(prior / (prior + n)), rel=1e-9)
    assert ss == pytest.approx(0.2 * np.sqrt(prior / (prior + n)), rel=1e-9)
    # setup starts a new run from the assumed values
    a.setup(None)
    assert a.scatter_ == (0.1, 0.1, 0.2)


def test_a_tight_detector_narrows_the_gate_a_loose_one_widens_it():
    # a detection 0.35 heights to the right of a fresh track: inside the gate while the
    # scatter is the assumed 0.1 (cost 6.1 < 8), outside it once the detector has shown it
    # scatters by 0.02
    far = _dets([(235.0, 300.0)], [0.9])
    a = _assoc(sigma=0.1, appearance_weight=0.0)
    t = _target(1, (200.0, 300.0), 0.0, n=20)
    assert a.associate([t], far).matches.tolist() == [[0, 0]]
    a.setup(None)
    _feed(a, np.random.default_rng(1).normal(0.0, 0.02, 400))
    assert len(a.associate([t], far).matches) == 0
    # a detector whose boxes scatter by 0.3 heights: the same pair is matched, a pair 0.6
    # heights away too (the assumed scatter puts it at cost 18); at most twice the assumed
    b = _assoc(sigma=0.1, appearance_weight=0.0)
    _feed(b, np.random.default_rng(2).normal(0.0, 0.3, 400))
    assert b.associate([t], _dets([(260.0, 300.0)], [0.9])).matches.tolist() == [[0, 0]]
    assert b.scatter_[0] == pytest.approx(0.2, rel=1e-9)


def test_only_pairs_of_tracks_seen_in_the_previous_frame_are_measured():
    a = _assoc(sigma=0.1, appearance_weight=0.0)
    for k in range(100):
        t = _target(1, (200.0, 300.0), 0.0, n=20, seed=k, misses=3)
        a.associate([t], _dets([(230.0, 300.0)], [0.9]))
    a.costs([], _dets([], []))
    assert a.scatter_ == (0.1, 0.1, 0.2)


@pytest.mark.parametrize(("name", "value"), [("sigma", 0.0), ("sigma_size", -1.0),
                                             ("max_cost", 0.0), ("high_score", -0.1),
                                             ("recent_misses", -1), ("appearance_weight", -1.0)])
def test_a_bad_parameter_is_named(name, value):
    with pytest.raises(ValueError, match=name):
        CloudAssociator(**{name: value})


def _seen_then_lost(a: CloudAssociator, misses: int, *, behind: bool = True, **kw) -> Target:
    """Track 1 matched at (200, 300), 100 px tall (40 wide), with track 2 10 px to its right
    (three quarters of its box under track 2's: hidden behind it) or 100 px away (``behind``
    False); then lost for ``misses`` frames, its cloud spread over 2000 px (no detection is
    likely under it)."""
    x2 = 210.0 if behind else 300.0
    seen, other = _target(1, (200.0, 300.0), 2.0), _target(2, (x2, 300.0), 2.0, seed=5)
    m = a.associate([other, seen], _dets([(x2, 300.0), (200.0, 300.0)], [0.9, 0.9])).matches
    assert sorted(m.tolist()) == [[0, 0], [1, 1]]
    a.associate([other, seen], _dets([(x2, 300.0), (200.0, 300.0)], [0.9, 0.9]))
    return _target(1, (200.0, 300.0), 2000.0, misses=misses, **kw)


def test_a_lost_track_is_re_found_where_the_person_could_have_walked():
    # at 25 frames a second, lost for 1 s (24 misses: matched 25 frames ago): the reach is
    # margin 0.3 + speed 0.5 x 1 s = 0.8 heights of its last box = 80 px
    a = _assoc()
    lost = _seen_then_lost(a, 24)
    d = _dets([(270.0, 300.0)], [0.9])  # 70 px away
    assert a.associate([lost], d).matches.tolist() == [[0, 0]]
    assert a.cost_[0, 0] > a.max_cost  # the cloud alone would not have taken it
    a = _assoc()
    lost = _seen_then_lost(a, 24)
    assert len(a.associate([lost], _dets([(290.0, 300.0)], [0.9])).matches) == 0  # 90 px
    # after 2 s the reach is 1.3 heights: 90 px is within it
    a = _assoc()
    lost = _seen_then_lost(a, 49)
    assert a.associate([lost], _dets([(290.0, 300.0)], [0.9])).matches.tolist() == [[0, 0]]


def test_used_without_setup_it_runs_at_the_default_frame_rate():
    # costs() first, then associate(), never set up: the re-find's reach is that of a run at
    # 25 frames a second (0.8 heights after 24 misses, as above)
    a = CloudAssociator()
    assert a.costs([_target(9, (0.0, 0.0), 2.0)], _dets([(0.0, 0.0)], [0.9])).shape == (1, 1)
    lost = _seen_then_lost(a, 24)
    assert a.associate([lost], _dets([(270.0, 300.0)], [0.9])).matches.tolist() == [[0, 0]]
    a = CloudAssociator()
    lost = _seen_then_lost(a, 24)
    assert len(a.associate([lost], _dets([(290.0, 300.0)], [0.9])).matches) == 0  # 90 px


def test_a_re_found_detection_has_the_height_colours_and_confidence_of_the_track():
    a = _assoc()
    lost = _seen_then_lost(a, 24)
    # 30 % taller: |log 1.3| = 0.26 > size 0.2; 15 % taller passes
    assert len(a.associate([lost], _dets([(220.0, 300.0)], [0.9], h=130.0)).matches) == 0
    assert a.associate([lost], _dets([(220.0, 300.0)], [0.9], h=115.0)).matches.tolist() == \
        [[0, 0]]
    # a weak detection (below high_score) does not re-find a lost track
    a = _assoc()
    lost = _seen_then_lost(a, 24)
    assert len(a.associate([lost], _dets([(220.0, 300.0)], [0.4])).matches) == 0
    # colours: below min_appearance bars the pair, above it passes
    lost.appearance_scores = np.array([0.4])
    assert len(a.associate([lost], _dets([(220.0, 300.0)], [0.9])).matches) == 0
    lost.appearance_scores = np.array([0.6])
    assert a.associate([lost], _dets([(220.0, 300.0)], [0.9])).matches.tolist() == [[0, 0]]


def test_only_tracks_lost_behind_another_for_recent_misses_frames_are_re_found():
    a = _assoc(recent_misses=2)
    lost = _seen_then_lost(a, 1)  # one miss: not yet lost
    assert len(a.associate([lost], _dets([(220.0, 300.0)], [0.9])).matches) == 0
    # lost in the open (no track over it when last seen): a passing miss, not re-found
    a = _assoc()
    lost = _seen_then_lost(a, 24, behind=False)
    assert len(a.associate([lost], _dets([(220.0, 300.0)], [0.9])).matches) == 0
    assert a._hidden == {1: False}
    # a track this associator never matched has no last box to reach from
    never = _target(7, (200.0, 300.0), 2000.0, misses=30)
    assert len(_assoc().associate([never], _dets([(200.0, 300.0)], [0.9])).matches) == 0
    # two people side by side, each half behind the other, both lost: the detection 90 px
    # from track 1's last box is beyond its reach (80 px), so track 2 takes it (75 px) and
    # track 1 the other (50 px)
    a = _assoc()
    s1, s2 = _target(1, (200.0, 300.0), 2.0, seed=1), _target(2, (215.0, 300.0), 2.0, seed=2)
    for _ in range(2):
        a.associate([s1, s2], _dets([(200.0, 300.0), (215.0, 300.0)], [0.9, 0.9]))
    l1 = _target(1, (300.0, 300.0), 2000.0, misses=24, seed=1)
    l2 = _target(2, (300.0, 300.0), 2000.0, misses=24, seed=2)
    m = a.associate([l1, l2], _dets([(290.0, 300.0), (150.0, 300.0)], [0.9, 0.9])).matches
    assert sorted(m.tolist()) == [[0, 1], [1, 0]]
    # an ended track is forgotten
    a.associate([], _dets([], []))
    assert a._last_box == {}


@pytest.mark.parametrize(("value", "match"), [({"size": 0.0}, "refind.size"),
                                              ({"covered": 1.2}, "refind.covered"),
                                              ({"min_appearance": 1.5}, "refind.min_appearance"),
                                              ({"speed": -1.0}, "refind.speed"),
                                              ({"speeed": 1.0}, "speeed")])
def test_a_bad_refind_parameter_is_named(value, match):
    with pytest.raises(ValueError, match=match):
        CloudAssociator(refind=value)
