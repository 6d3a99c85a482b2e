"""pftrack.Tracker, the frame-by-frame Python API: inputs of every accepted kind give the same
tracks, bad input is refused before anything changes, uncertainty comes from the particle
clouds, earlier frames made known at confirmation are kept apart, several classes never mix,
and the tracks equal ``pftrack run``'s on the same detections."""

from __future__ import annotations

import copy
import re

import numpy as np
import pftrack
import pytest
from pftrack.contracts.components import Detections, Likelihood
from pftrack.host import UnknownComponentError
from pftrack.io.data import data_dir
from pftrack.workflows.stream import Tracker, Tracks, image_readers

PETS = data_dir() / "pets09"

# detections only: no component reads pixels, so frames need no image
DET_ONLY = {
    "name": "det-only",
    "state": "image",
    "observation": {"type": "image-box", "params": {"size_from_box": True}},
    "motion": {"type": "constant-velocity-2d",
               "params": {"position_noise": 2.0, "velocity_noise": 0.5}},
    "likelihood": {"type": "detection", "params": {"phi": 0.5, "psi": 10.0, "sigma": 0.1}},
    "associator": {"type": "greedy-iou", "params": {}},
    "tracker": {"n_particles": 100, "init_spread": 1.0, "max_misses": 5, "dt": 1.0},
    "tracks": {"type": "confirmed", "params": {"min_score": 0.5, "confirm_hits": 3,
                                               "confirm_window": 4}},
}
SIZE = (640, 480)


def _walkers(n_frames: int = 30, n: int = 3) -> list[np.ndarray]:
    """Boxes (x1, y1, x2, y2, score) of ``n`` people walking right, one array per frame."""
    out = []
    for k in range(n_frames):
        rows = [[50.0 + 5 * k + 150 * i, 100.0 + 60 * i, 90.0 + 5 * k + 150 * i,
                 180.0 + 60 * i, 0.9] for i in range(n)]
        out.append(np.array(rows))
    return out


def _run(tracker: Tracker, frames: list, **kw) -> np.ndarray:
    for det in frames:
        tracker.update(det, **kw)
    return tracker.to_mot()


def test_top_level_names():
    assert pftrack.Tracker is Tracker
    assert pftrack.Detections is Detections
    for name in ("evaluate", "read_mot", "write_mot", "read_detections", "load_config"):
        assert callable(getattr(pftrack, name))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        pftrack.nope  # noqa: B018


def test_numpy_tracks_and_late_rows_apart():
    tr = Tracker(DET_ONLY, seed=0, image_size=SIZE)
    frames = _walkers()
    outs = [tr.update(d) for d in frames]
    # tentative for two frames: confirmed at frame 3, when frames 1-2 become known
    assert [len(o) for o in outs[:3]] == [0, 0, 3]
    assert outs[2].frame.tolist() == [3, 3, 3]
    assert sorted(outs[2].confirmed_earlier.frame.tolist()) == [1, 1, 1, 2, 2, 2]
    assert all(len(o.confirmed_earlier) == 0 for o in outs[3:])
    for o, d in zip(outs[2:], frames[2:]):
        assert (o.frame == o.frame[0]).all()
        assert set(o.tracker_id.tolist()) == {1, 2, 3}
        # boxes on their detections once the velocity is learnt, ids in birth order (left to
        # right: the detections' order)
        order = np.argsort(o.tracker_id)
        if o.frame[0] >= 10:
            assert np.abs(o.xyxy[order] - d[:, :4]).max() < 5.0
    df = tr.to_dataframe()
    assert len(df) == 3 * 30
    assert (df.published_frame > df.frame).sum() == 6
    assert {"x1_sd", "y1_sd", "x2_sd", "y2_sd"} <= set(df.columns)


def test_xyxy_sd_is_the_particle_spread():
    """Image boxes of a fixed size centred on the state: each edge's sd is the centre's, half
    the engine's extent (2 sd of the weighted particles); at birth the particles' spread,
    init_spread (1 px)."""
    tr = Tracker(DET_ONLY, seed=0, image_size=SIZE)
    frames = _walkers(20)
    for d in frames[:3]:
        out = tr.update(d)
    birth = out.confirmed_earlier.xyxy_sd[out.confirmed_earlier.frame == 1]
    assert np.all((birth > 0.8) & (birth < 1.2))
    for d in frames[3:]:
        out = tr.update(d)
    engine = tr.engines[0]
    ext = {t.id: t.extent for t in engine.targets}
    for tid, sd in zip(out.tracker_id, out.xyxy_sd):
        np.testing.assert_array_equal(sd, ext[int(tid)][[0, 1, 0, 1]] / 2)
        assert sd[0] > 0.3
    # the same from the particles themselves (equal weights after resampling)
    for t in engine.targets:
        p = t.particles
        np.testing.assert_allclose(p[:, :2].std(axis=0), t.extent[:2] / 2, rtol=0.3)


def test_every_input_kind_gives_the_same_tracks():
    frames = _walkers(15)
    ref = _run(Tracker(DET_ONLY, seed=3, image_size=SIZE), frames)
    xywh = [np.c_[d[:, :2], d[:, 2:4] - d[:, :2]] for d in frames]
    dets = [Detections(b, d[:, 4]) for b, d in zip(xywh, frames)]
    got = _run(Tracker(DET_ONLY, seed=3, image_size=SIZE), dets)
    np.testing.assert_array_equal(got, ref)
    mot = [np.c_[np.full(len(d), k + 1), -np.ones(len(d)), b, d[:, 4]]
           for k, (b, d) in enumerate(zip(xywh, frames))]
    got = _run(Tracker(DET_ONLY, seed=3, image_size=SIZE), mot, layout="mot")
    np.testing.assert_array_equal(got, ref)
    # an image given (not read): the same tracks
    img = np.zeros((SIZE[1], SIZE[0], 3), np.uint8)
    got = _run(Tracker(DET_ONLY, seed=3), frames, frame=img)
    np.testing.assert_array_equal(got, ref)
    assert len(ref) == 3 * 15


def test_supervision_in_supervision_out():
    sv = pytest.importorskip("supervision")
    frames = _walkers(10)
    ref = Tracker(DET_ONLY, seed=1, image_size=SIZE)
    tr = Tracker(DET_ONLY, seed=1, image_size=SIZE)
    for d in frames:
        want = ref.update(d)
        got = tr.update(sv.Detections(xyxy=d[:, :4], confidence=d[:, 4],
                                      class_id=np.zeros(len(d), dtype=int)))
        assert isinstance(got, sv.Detections)
        np.testing.assert_array_equal(got.tracker_id, want.tracker_id)
        np.testing.assert_array_equal(got.xyxy, want.xyxy)
        np.testing.assert_array_equal(got.data["xyxy_sd"], want.xyxy_sd)
        assert len(tr.confirmed_earlier) == len(want.confirmed_earlier)
    np.testing.assert_array_equal(tr.to_mot(), ref.to_mot())


def test_classes_are_tracked_apart():
    """Two classes at the same places: never associated across, ids unique, and each class's
    tracks those of a tracker given that class alone (ids aside)."""
    frames = _walkers(12, n=2)
    both = Tracker(DET_ONLY, seed=0, image_size=SIZE)
    for d in frames:
        rows = np.r_[np.c_[d, np.zeros(len(d))], np.c_[d, np.ones(len(d))]]
        out = both.update(rows)
    assert sorted(out.class_id.tolist()) == [0, 0, 1, 1]
    assert len(set(out.tracker_id.tolist())) == 4
    all_rows = both.tracks()
    for c in (0, 1):
        alone = _run(Tracker(DET_ONLY, seed=0, image_size=SIZE), frames)
        mine = all_rows.to_mot()[all_rows.class_id == c]
        np.testing.assert_array_equal(mine[:, [0, *range(2, 10)]], alone[:, [0, *range(2, 10)]])
        # a track keeps its class
        for tid in np.unique(mine[:, 1]):
            assert set(all_rows.class_id[all_rows.tracker_id == tid].tolist()) == {c}


def test_one_class_keeps_the_engines_ids():
    frames = _walkers(8)
    a = _run(Tracker(DET_ONLY, seed=0, image_size=SIZE), frames)
    b = _run(Tracker(DET_ONLY, seed=0, image_size=SIZE),
             [np.c_[d, np.full(len(d), 7)] for d in frames])
    np.testing.assert_array_equal(a, b)


def test_reset_starts_over():
    frames = _walkers(10)
    tr = Tracker(DET_ONLY, seed=5, image_size=SIZE)
    first = _run(tr, frames)
    tr.reset()
    assert tr.to_mot().shape == (0, 10)
    np.testing.assert_array_equal(_run(tr, frames), first)


# -- bad input -------------------------------------------------------------------------------


def _state(tr: Tracker):
    e = tr.engines.get(0)
    return (tr._last_index, tr._last_size, len(tr.history),
            None if e is None else [(t.id, t.particles.copy()) for t in e.targets],
            None if e is None else copy.deepcopy(e.rng.bit_generator.state))


@pytest.mark.parametrize(("bad", "match"), [
    (np.zeros((2, 3)), r"update\(detections\): expected an \(N, 4\), \(N, 5\) or \(N, 6\) "
                       r"array .* got shape \(2, 3\)"),
    (np.zeros((2, 7)), r"got shape \(2, 7\)"),
    (np.zeros(4), r"got shape \(4,\)"),
    (np.array([[10, 10, 50, 90.0], [10, np.nan, 50, 90]]), r"row 1 has a NaN or infinite"),
    (np.array([[10, 10, 50, np.inf]]), r"row 0 has a NaN or infinite"),
    (np.array([[10, 10, 50, 90, np.nan]]), r"row 0 has a NaN or infinite"),
    (np.array([[10, 10, 50, 90.0], [50, 10, 10, 90]]), r"row 1 has a negative or zero size"),
    (np.array([[10, 90, 50, 10.0]]), r"row 0 has a negative or zero size"),
    (np.array([[10, 10, 50, 90.0], [700, 10, 750, 90]]),
     r"row 1 lies wholly outside the 640x480 image"),
    (np.array([[-80, 10, -20, 90.0]]), r"row 0 lies wholly outside"),
    (np.array([[10, 10, 50, 90, 0.9, -1]]), r"row 0: class_id -1 is negative"),
    (np.array([[10, 10, 50, 90, 0.9, 1.5]]), r"row 0: class_id 1.5 is not an integer"),
    ("boxes", r"update\(detections\)"),
])
def test_bad_detections_change_nothing(bad, match):
    frames = _walkers(6)
    tr = Tracker(DET_ONLY, seed=0, image_size=SIZE)
    ref = Tracker(DET_ONLY, seed=0, image_size=SIZE)
    for d in frames[:4]:
        tr.update(d)
        ref.update(d)
    before = _state(tr)
    with pytest.raises(ValueError, match=match):
        tr.update(bad)
    after = _state(tr)
    assert before[:3] == after[:3] and before[4] == after[4]
    for (i, p), (j, q) in zip(before[3], after[3]):
        assert i == j and np.array_equal(p, q)
    for d in frames[4:]:  # and it goes on as if the bad call never happened
        np.testing.assert_array_equal(tr.update(d).xyxy, ref.update(d).xyxy)


def test_bad_frames_and_calls():
    tr = Tracker(DET_ONLY, seed=0)
    with pytest.raises(ValueError, match=r"update\(frame=None\): the image size is unknown"):
        tr.update(np.zeros((0, 4)))
    img = np.zeros((480, 640, 3), np.uint8)
    tr.update(_walkers(1)[0], frame=img)
    with pytest.raises(ValueError, match=r"a 320x240 frame, the last was 640x480.*reset\(\)"):
        tr.update(_walkers(1)[0], frame=np.zeros((240, 320, 3), np.uint8))
    with pytest.raises(ValueError, match=r"uint8 BGR image, got shape \(480, 640\)"):
        tr.update(None, frame=np.zeros((480, 640), np.uint8))
    with pytest.raises(ValueError, match=r"frame_index=1\): frames must come in order"):
        tr.update(None, frame=img, frame_index=1)
    with pytest.raises(ValueError, match=r"row 0 is of frame 9, this update is frame 2"):
        tr.update(np.array([[9, -1, 10, 10, 40, 80, 0.9]]), layout="mot")
    with pytest.raises(ValueError, match=r"layout='nope'"):
        tr.update(np.zeros((1, 4)) + 5, layout="nope")
    assert tr._last_index == 1
    out = tr.update(None)  # no detections, no image: the last frame's size
    assert len(out) == 0 and tr._last_index == 2


def test_a_configuration_that_reads_pixels_needs_frames():
    tr = Tracker("people-image", seed=0)
    readers = image_readers(tr._first)
    assert readers == ["tracks 'confirmed' (its colour model, tracks.appearance)"]
    with pytest.raises(ValueError, match=r"frame=None\): configuration 'people-image' reads "
                                         r"the image \(tracks 'confirmed'"):
        tr.update(np.array([[10, 10, 50, 90.0]]))
    assert image_readers(Tracker(DET_ONLY)._first) == []


# -- your own component ----------------------------------------------------------------------


class CentreLikelihood(Likelihood):
    """log N(box centre; matched detection's centre, sigma_px^2)."""

    reads_image = False

    def __init__(self, sigma_px: float = 4.0) -> None:
        self.sigma_px = sigma_px

    def log_likelihood(self, boxes_xywh_px, target):
        if target.detection is None:
            return np.zeros(len(boxes_xywh_px))
        c = boxes_xywh_px[:, :2] + 0.5 * boxes_xywh_px[:, 2:]
        d = target.detection.box_xywh_px
        dc = c - (d[:2] + 0.5 * d[2:])
        return -0.5 * (dc ** 2).sum(axis=1) / self.sigma_px ** 2


def test_own_component_from_python():
    cfg = dict(DET_ONLY, likelihood={"type": "centre-likelihood", "params": {"sigma_px": 3.0}})
    tr = Tracker(cfg, seed=0, image_size=SIZE, plugins=[CentreLikelihood])
    assert type(tr._first.likelihood) is CentreLikelihood
    assert tr._first.likelihood.sigma_px == 3.0
    out = None
    for d in _walkers(6):
        out = tr.update(d)
    assert len(out) == 3
    with pytest.raises(UnknownComponentError) as err:
        Tracker(cfg, seed=0, image_size=SIZE)
    text = str(err.value)
    assert "no likelihood named 'centre-likelihood' is registered" in text
    # the built-ins, and the repository's benchmarks where ./dev installed them
    assert re.search(r"plugins loaded: basic, (bench, )?coast, colour, network, world\b", text)
    assert "plugins=[MyClass]" in text and "entry point" in text


def test_component_names():
    from pftrack.workflows.stream import component_name

    assert component_name(CentreLikelihood) == "centre-likelihood"
    assert component_name(type("HOGLikelihood", (CentreLikelihood,), {})) == "hog-likelihood"
    assert component_name(type("Mine", (CentreLikelihood,), {"name": "my-own"})) == "my-own"


def test_plugins_refuses_what_is_no_component():
    with pytest.raises(TypeError, match=r"plugins\[0\]: int is not a pftrack component"):
        Tracker(DET_ONLY, plugins=[int])


# -- the same tracks as `pftrack run` --------------------------------------------------------


@pytest.fixture(scope="module")
def pets_slice():
    if not (PETS / "vtest.avi").is_file():
        pytest.skip("PETS 2009 data not found (PFTRACK_DATA)")
    from pftrack.io.mot import read_mot
    from pftrack.workflows.pipeline import iter_frames

    gt = read_mot(PETS / "gt.txt")
    gt = gt[(gt[:, 0] <= 40) & (gt[:, 6] != 0)]
    frames = list(iter_frames(PETS / "vtest.avi", 1, 40))
    return frames, gt


@pytest.mark.slow
def test_same_tracks_as_the_cli(pets_slice, tmp_path):
    """``pftrack run people-image --detections FILE --seed 0`` on PETS frames 1-40 (detections:
    the ground truth's boxes, score 0.9) and the Tracker fed the same rows frame by frame, as
    numpy xyxy and as the file's MOT rows: the same tracks."""
    from pftrack.io.detections import read_detections, write_detections
    from pftrack.io.mot import read_mot
    from pftrack.workflows.pipeline import run_pipeline

    frames, gt = pets_slice
    det_rows = gt.copy()
    det_rows[:, 1] = -1
    det_rows[:, 6] = 0.9
    dets = {f: Detections(det_rows[det_rows[:, 0] == f, 2:6], det_rows[det_rows[:, 0] == f, 6])
            for f in np.unique(det_rows[:, 0]).astype(int)}
    path = tmp_path / "det.txt"
    write_detections(path, dets)
    res = run_pipeline("people-image", video=PETS / "vtest.avi", frames="1:40", seed=0,
                       detections=path, out_dir=tmp_path / "run", progress=False, report=False)
    cli = read_mot(tmp_path / "run" / "tracks.txt")
    np.testing.assert_allclose(cli, res.rows, rtol=0, atol=5e-7)  # the file's 10 digits
    assert len(res.rows) > 150
    file_rows = read_mot(path, check_unique=False)
    tr = Tracker("people-image", seed=0, fps=7)
    tx = Tracker("people-image", seed=0, fps=7)
    for fr in frames:
        rows = file_rows[file_rows[:, 0] == fr.index]
        tr.update(rows, frame=fr.image, layout="mot")
        xyxy = np.c_[rows[:, 2:4], rows[:, 2:4] + rows[:, 4:6], rows[:, 6]]
        tx.update(xyxy, frame=fr)
    np.testing.assert_array_equal(tr.to_mot(), res.rows)
    # the run's side file: one row per tracks.txt row, the Tracker's spread
    from pftrack.io.outputs import read_track_uncertainty

    side = read_track_uncertainty(tmp_path / "run" / "tracks_uncertainty.csv")
    np.testing.assert_array_equal(side[:, :2], cli[:, :2])
    allt = tr.tracks()
    np.testing.assert_allclose(side[:, 2:6], allt.xyxy_sd, rtol=1e-5)
    assert np.all(side[:, 2:6] > 0) and np.all(np.isnan(side[:, 6:]))
    # xyxy -> (left, width) in floating point: the same tracks to rounding
    got = tx.to_mot()
    assert got.shape == res.rows.shape
    np.testing.assert_array_equal(got[:, :2], res.rows[:, :2])
    np.testing.assert_allclose(got, res.rows, rtol=0, atol=1e-6)
    # the reader of the same file gives the same per-frame detections
    assert read_detections(path).keys() == dets.keys()


def test_camera_tracks_carry_ground_position_and_covariance(pets_slice):
    """people-ground with the PETS camera: ground positions near the ground truth's, each
    covariance symmetric positive definite with the variances of the engine's extent (the
    resampled cloud against the weighted one: within a factor), box sds from the particles'
    boxes; rows of frames before a confirmation get their own frame's spread."""
    frames, gt = pets_slice
    tr = Tracker("people-ground", seed=0, fps=7, camera=PETS / "View_001.xml")
    late = []
    for fr in frames[:25]:
        g = gt[gt[:, 0] == fr.index]
        out = tr.update(np.c_[g[:, 2:4], g[:, 2:4] + g[:, 4:6], np.full(len(g), 0.9)], frame=fr)
        late.append(out.confirmed_earlier)
    assert out.world_xy is not None and out.world_cov is not None and len(out) >= 4
    cov = out.world_cov
    np.testing.assert_allclose(cov, cov.transpose(0, 2, 1))
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    ext = {t.id: t.extent for t in tr.engines[0].targets}
    for tid, c in zip(out.tracker_id, cov):
        var = (ext[int(tid)][:2] / 2) ** 2
        assert np.all((np.diag(c) > var / 3) & (np.diag(c) < var * 3))
    assert np.all(np.isfinite(out.xyxy_sd)) and np.all(out.xyxy_sd > 0)
    # ground positions: each track within 1 m of a ground-truth person of its frame
    g = gt[gt[:, 0] == out.frame[0]]
    d = np.linalg.norm(out.world_xy[:, None] - g[None, :, 7:9], axis=2).min(axis=1)
    assert np.all(d < 1.0), d
    early = Tracks.concat([t for t in late if len(t)])
    assert len(early) > 0 and np.all(np.isfinite(early.xyxy_sd))
    assert np.all(np.isfinite(early.world_cov))
    df = tr.to_dataframe()
    assert {"world_x", "world_y", "world_var_x", "world_cov_xy", "world_var_y"} <= set(df)
