"""The compiled kernels of the cross-entropy likelihoods (pftrack_colour._jit): the same numbers
as the numpy path bit for bit, taken where they apply (same-size boxes inside the image, other
targets' stripes disjoint), not taken elsewhere, and the same tracks end to end."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Frame, Target
from pftrack_colour import _jit
from pftrack_colour.histograms import ColourBins, ParticleRegion, subsample
from pftrack_colour.likelihoods import CrossEntropyBackgroundLikelihood, CrossEntropyLikelihood


def _scene(seed: int = 0, third: bool = False):
    """A 120 x 90 noisy frame with coloured patches and targets on them (with ``third``, a
    third target whose box overlaps the second's)."""
    rng = np.random.default_rng(seed)
    img = rng.integers(40, 220, (90, 120, 3), dtype=np.uint8)
    img[10:30, 10:30] = (40, 40, 210)
    img[40:60, 60:80] = (210, 60, 30)
    img[48:68, 70:90] = (30, 200, 60)
    img = np.clip(img.astype(int) + rng.integers(-8, 9, img.shape), 0, 255).astype(np.uint8)
    targets = [Target(id=1, state=np.array([20.0, 20.0]), box_xywh_px=np.array([10.0, 10, 20, 20])),
               Target(id=2, state=np.array([70.0, 50.0]), box_xywh_px=np.array([60.0, 40, 20, 20]))]
    if third:
        targets.append(Target(id=3, state=np.array([80.0, 58.0]),
                              box_xywh_px=np.array([70.0, 48, 20, 20])))
    return Frame(1, img), targets


def _inside_boxes(rng, n, centre, size=20.0, spread=12.0):
    c = rng.normal(centre, spread, (n, 2))
    c = np.clip(c, size / 2 + 1, [120 - size / 2 - 1, 90 - size / 2 - 1])
    return np.column_stack([c - size / 2, np.full((n, 2), size)])


def _both_paths(monkeypatch, lik_factory, frame, targets, boxes, target):
    """log_likelihood through the compiled path and through numpy; also how many compiled
    calls were made."""
    calls = []
    real = _jit.value_box_sums

    def counting(*args):
        calls.append(1)
        return real(*args)

    out = {}
    for enabled in (True, False):
        monkeypatch.setattr(_jit, "ENABLED", enabled)
        monkeypatch.setattr(_jit, "value_box_sums", counting)
        lik = lik_factory()
        for t in targets:
            lik.init_target(frame, t)
        lik.begin_frame(frame, targets)
        out[enabled] = (lik.log_likelihood(boxes, target), lik)
    return out[True], out[False], len(calls)


CASES = [
    (CrossEntropyLikelihood, {}),
    (CrossEntropyLikelihood, {"parts": 3}),
    (CrossEntropyLikelihood, {"lam": 50.0}),
    (CrossEntropyLikelihood, {"colour_space": "hsv", "bins": (6, 4, 4)}),
    (CrossEntropyBackgroundLikelihood, {"overlap": "independent"}),
    (CrossEntropyBackgroundLikelihood, {"overlap": "product", "parts": 2}),
    (CrossEntropyBackgroundLikelihood, {"overlap": "mixture"}),
    (CrossEntropyBackgroundLikelihood, {"overlap": "mixture", "parts": 3,
                                        "region": (0.2, 0.1, 0.8, 0.9)}),
    (CrossEntropyBackgroundLikelihood, {"overlap": "mixture", "colour_space": "lab",
                                        "background_stride": 2}),
]


@pytest.mark.parametrize("cls, kw", CASES)
def test_compiled_path_equals_numpy_bit_for_bit(monkeypatch, cls, kw):
    frame, targets = _scene(1)
    # target 1's samples reach into target 2's box (the per-pair tables are used)
    boxes = _inside_boxes(np.random.default_rng(2), 400, (55.0, 40.0), spread=15.0)
    (fast, lik), (slow, _), n_calls = _both_paths(monkeypatch, lambda: cls(**kw), frame, targets,
                                                  boxes, targets[0])
    assert n_calls == len(lik._parts)  # the compiled path ran, once per stripe
    if cls is CrossEntropyBackgroundLikelihood and kw["overlap"] != "independent":
        region = ParticleRegion(frame.image, lik._colour_boxes(boxes) if lik.region else boxes)
        assert lik._coverage(region, 1)  # some pixels take another target's pair table
    assert np.array_equal(fast, slow)
    assert np.isfinite(fast).all()


def test_compiled_path_is_not_taken_where_it_does_not_apply(monkeypatch):
    # boxes leaving the image, boxes of different sizes, pixels under two other targets
    frame, targets = _scene(3, third=True)
    rng = np.random.default_rng(4)
    leaving = _inside_boxes(rng, 50, (20.0, 20.0))
    leaving[0, :2] = (-5.0, 3.0)
    sizes = _inside_boxes(rng, 50, (20.0, 20.0))
    sizes[1, 2:] = (16.0, 24.0)
    over_two = _inside_boxes(rng, 200, (75.0, 55.0), spread=3.0)
    for boxes in (leaving, sizes, over_two):
        (fast, _), (slow, _), n_calls = _both_paths(
            monkeypatch, lambda: CrossEntropyBackgroundLikelihood(overlap="mixture"), frame,
            targets, boxes, targets[0])
        assert n_calls == 0
        assert np.array_equal(fast, slow)


@pytest.mark.parametrize("stride", [1, 2, 3, 5])
def test_background_grid_histogram_equals_the_masked_histogram(stride):
    frame, _ = _scene(5)
    img = frame.image
    binner = ColourBins(8)
    sub = subsample(img, stride)
    gh, gw = sub.shape[:2]
    # grid rectangles: inside, overlapping each other, past the right and bottom edges
    rects = np.array([[1, 1, 4, 5], [3, 2, 7, 6], [gw - 2, gh - 3, gw + 4, gh + 2]],
                     dtype=np.int64)
    keep = np.ones((gh, gw), dtype=np.uint8)
    for x0, y0, x1, y1 in rects:
        keep[y0:y1, x0:x1] = 0
    got = _jit.grid_histogram(img, stride, *binner.channel_luts, rects, binner.n_bins)
    assert got.dtype == np.float64
    assert np.array_equal(got, binner.histogram(sub, keep))
    got_all = _jit.grid_histogram(img, stride, *binner.channel_luts, rects[:0], binner.n_bins)
    assert np.array_equal(got_all, binner.histogram(sub))
    # a strided view of a frame reads the same pixels
    big = np.zeros((img.shape[0], img.shape[1] * 2, 3), dtype=np.uint8)
    big[:, ::2] = img
    assert np.array_equal(_jit.grid_histogram(big[:, ::2], stride, *binner.channel_luts, rects,
                                              binner.n_bins), got)


def test_background_of_the_likelihood_is_the_same_both_ways(monkeypatch):
    frame, targets = _scene(6, third=True)
    wide = Target(id=9, state=np.array([60.0, 45.0]), box_xywh_px=np.array([-10.0, -10, 140, 110]))
    for ts in (targets, [*targets, wide]):  # the last one covers the whole image
        got = {}
        for enabled in (True, False):
            monkeypatch.setattr(_jit, "ENABLED", enabled)
            lik = CrossEntropyBackgroundLikelihood()
            for t in ts:
                lik.init_target(frame, t)
            lik.begin_frame(frame, ts)
            got[enabled] = (lik.background_counts_, lik.background_)
        assert np.array_equal(got[True][0], got[False][0])
        assert np.array_equal(got[True][1], got[False][1])
        assert got[True][0].sum() > 0


def test_walkers_tracks_are_identical_with_and_without_the_kernels(monkeypatch):
    from pftrack.host import get_host
    from pftrack_colour.experiment import first_boxes, track

    host = get_host()
    scene = host.build("scene", {"type": "walkers", "params": {"seed": 0, "n_frames": 40}})
    frames = list(scene.frames())
    starts = first_boxes(scene.ground_truth(), [1, 2, 3])
    rows = {}
    for enabled in (True, False):
        monkeypatch.setattr(_jit, "ENABLED", enabled)
        for name in ("cross-entropy", "cross-entropy-bg"):
            rows[enabled, name] = track(frames, name, starts, n_particles=300, seed=3,
                                        host=host).rows
    for name in ("cross-entropy", "cross-entropy-bg"):
        assert len(rows[True, name]) == 120
        assert np.array_equal(rows[True, name], rows[False, name])


def test_fixed_layout_is_the_particle_regions():
    """Rounding half up (.5 cases included), the bounding region and the corners, or 'does not
    apply' exactly where ParticleRegion has no fixed-size all-inside layout."""
    rng = np.random.default_rng(8)
    for trial in range(200):
        n = int(rng.integers(1, 30))
        xy = rng.integers(-3, 100, (n, 2)) + rng.choice([0.0, 0.5, 0.49, -0.5, 0.51], (n, 2))
        wh = np.full((n, 2), 12.5 if trial % 3 else 12.0)
        if trial % 7 == 0:
            wh[0] = (13.0, 12.0)
        if trial % 11 == 0:
            xy[0, 0] = np.nan
        boxes = np.column_stack([xy, wh])
        ok, x0, y0, x1, y1, bw, bh, xs, ys = _jit.fixed_layout(boxes, 120, 90)
        try:
            region = ParticleRegion(np.zeros((90, 120, 3), np.uint8), boxes)
        except ValueError:
            assert not ok
            continue
        applies = region.fixed_size is not None and region.all_inside
        assert ok == applies, trial
        if ok:
            assert (x0, y0, x1, y1) == (region.x0, region.y0, region.x1, region.y1)
            assert (bw, bh) == region.fixed_size
            rects = region.rects  # (N, 4) x0, y0, x1, y1, unclipped
            assert np.array_equal(xs, rects[:, 0] - region.x0)
            assert np.array_equal(ys, rects[:, 1] - region.y0)
    assert not _jit.fixed_layout(np.zeros((0, 4)), 120, 90)[0]


def _rows_scene(seed: int):
    """Three targets, the third's box over the second's (pixels under two stripes for the
    first target's samples), and every target's samples: (frame, targets, (3, N, 4) boxes)."""
    frame, targets = _scene(seed, third=True)
    rng = np.random.default_rng(seed + 10)
    boxes = np.stack([_inside_boxes(rng, 300, (75.0, 55.0), spread=8.0),  # over 2 and 3
                      _inside_boxes(rng, 300, (70.0, 50.0), spread=5.0),
                      _inside_boxes(rng, 300, (30.0, 30.0), spread=10.0)])
    return frame, targets, boxes


ROW_CASES = [
    *CASES,
    (CrossEntropyBackgroundLikelihood, {"overlap": "mixture", "parts": 2}),
    (CrossEntropyBackgroundLikelihood, {"overlap": "product", "lam": 40.0}),
]


@pytest.mark.parametrize("cls, kw", ROW_CASES)
def test_rows_equal_the_per_target_log_likelihoods_bit_for_bit(monkeypatch, cls, kw):
    """log_likelihood_rows scores every target in one compiled call; each row is the
    per-target method's array bit for bit, with the kernels on (compiled rows against the
    compiled per-target path) and against the numpy path."""
    frame, targets, boxes = _rows_scene(1)
    got = {}
    for enabled in (True, False):
        monkeypatch.setattr(_jit, "ENABLED", enabled)
        lik = cls(**kw)
        for t in targets:
            lik.init_target(frame, t)
        lik.begin_frame(frame, targets)
        rows = lik.log_likelihood_rows(boxes, targets)
        per = np.array([lik.log_likelihood(b, t) for b, t in zip(boxes, targets)])
        assert rows.shape == (3, 300) and rows.dtype == np.float64
        assert rows.tobytes() == per.tobytes()
        got[enabled] = rows
    assert got[True].tobytes() == got[False].tobytes()
    assert np.isfinite(got[True]).all()


def test_rows_cover_pixels_under_several_stripes_without_the_general_path(monkeypatch):
    """Samples of target 1 reach pixels under both other targets' boxes (which overlap): the
    compiled rows read the tables of that set of stripes instead of falling back to the numpy
    path per target, and still equal it."""
    frame, targets, boxes = _rows_scene(2)
    lik = CrossEntropyBackgroundLikelihood(overlap="mixture")
    for t in targets:
        lik.init_target(frame, t)
    lik.begin_frame(frame, targets)
    region = ParticleRegion(frame.image, boxes[0])
    cover = lik._coverage(region, 1)
    from pftrack_colour.likelihoods import _disjoint

    assert len(cover) == 2 and not _disjoint(cover)  # the case the per-pair tables miss
    per_target = []
    real = CrossEntropyBackgroundLikelihood.log_likelihood

    def counting(self, b, t):
        per_target.append(t.id)
        return real(self, b, t)

    monkeypatch.setattr(CrossEntropyBackgroundLikelihood, "log_likelihood", counting)
    rows = lik.log_likelihood_rows(boxes, targets)
    assert per_target == []  # no target took the general path
    monkeypatch.setattr(_jit, "ENABLED", False)
    assert rows.tobytes() == np.array([real(lik, b, t) for b, t in zip(boxes, targets)]).tobytes()


def test_rows_fall_back_per_target_where_the_kernel_does_not_apply(monkeypatch):
    """A target whose samples leave the image (or differ in size) takes log_likelihood; the
    others stay in the compiled call."""
    frame, targets, boxes = _rows_scene(3)
    boxes[2, 0, :2] = (-6.0, 2.0)  # leaves the image
    boxes[1, 3, 2:] = (18.0, 22.0)  # another size
    lik = CrossEntropyBackgroundLikelihood()
    for t in targets:
        lik.init_target(frame, t)
    lik.begin_frame(frame, targets)
    per_target = []
    real = CrossEntropyBackgroundLikelihood.log_likelihood

    def counting(self, b, t):
        per_target.append(t.id)
        return real(self, b, t)

    monkeypatch.setattr(CrossEntropyBackgroundLikelihood, "log_likelihood", counting)
    rows = lik.log_likelihood_rows(boxes, targets)
    assert sorted(per_target) == [2, 3]
    want = np.array([real(lik, b, t) for b, t in zip(boxes, targets)])
    assert rows.tobytes() == want.tobytes()
    assert np.isfinite(rows).all()  # the box leaving the image is clipped


def test_rows_reject_boxes_of_the_wrong_shape():
    frame, targets, boxes = _rows_scene(4)
    lik = CrossEntropyLikelihood()
    for t in targets:
        lik.init_target(frame, t)
    lik.begin_frame(frame, targets)
    with pytest.raises(ValueError, match=r"CrossEntropyLikelihood.log_likelihood_rows: boxes "
                                         r"must have shape \(T, N, 4\) with T = 2"):
        lik.log_likelihood_rows(boxes, targets[:2])


def test_the_frames_boxes_and_background_from_one_kernel_equal_the_general_path(monkeypatch):
    """begin_frame's compiled pass (integer colour boxes, the background grid histogram)
    gives the rectangles and the background of the Python path, also when the targets cover
    the whole image and when a box reaches outside it."""
    frame, targets = _scene(7, third=True)
    wide = Target(id=9, state=np.array([60.0, 45.0]), box_xywh_px=np.array([-10.0, -10, 140, 110]))
    edge = Target(id=8, state=np.array([5.0, 85.0]), box_xywh_px=np.array([-4.5, 79.5, 12, 12]))
    calls = []
    real = _jit.frame_background
    monkeypatch.setattr(_jit, "frame_background", lambda *a: calls.append(1) or real(*a))
    for ts in (targets, [*targets, edge], [*targets, wide]):
        for cls in (CrossEntropyBackgroundLikelihood, CrossEntropyLikelihood):
            got = {}
            for enabled in (True, False):
                monkeypatch.setattr(_jit, "ENABLED", enabled)
                lik = cls()
                for t in ts:
                    lik.init_target(frame, t)
                lik.begin_frame(frame, ts)
                got[enabled] = lik
            a, b = got[True], got[False]
            assert list(a.target_rects_) == list(b.target_rects_)
            for tid in a.target_rects_:
                assert a.target_rects_[tid].tolist() == b.target_rects_[tid].tolist()
            if cls is CrossEntropyBackgroundLikelihood:
                assert a.background_counts_.tobytes() == b.background_counts_.tobytes()
                assert a.log_background_.tobytes() == b.log_background_.tobytes()
            for tid in a.values_:
                assert a.values_[tid].tobytes() == b.values_[tid].tobytes()
    assert len(calls) == 6  # the compiled pass ran for every frame with the kernels on


@pytest.mark.skipif(not _jit.ENABLED, reason="PFTRACK_NO_JIT is set")
def test_template_counts_of_a_box_inside_the_image_are_compiled_and_the_same(monkeypatch):
    """A template's counts (``init_target``) of a box wholly inside the image come from one
    compiled pass over its pixels (half-pixel boxes rounded as ParticleRegion rounds them):
    the numpy path's templates exactly; boxes leaving the image, stripes and sub-box regions
    keep the numpy path."""
    frame, targets = _scene(8, third=True)
    edge = Target(id=4, state=np.zeros(2), box_xywh_px=np.array([-5.5, 70.4, 20.0, 30.6]))
    odd = Target(id=5, state=np.zeros(2), box_xywh_px=np.array([30.5, 20.49, 17.5, 12.5]))
    calls = []
    real = _jit.grid_histogram
    monkeypatch.setattr(_jit, "grid_histogram", lambda *a: calls.append(a[0].shape) or real(*a))
    for kw in ({}, {"parts": 2}, {"region": (0.1, 0.1, 0.9, 0.9)}):
        got = {}
        for enabled in (True, False):
            monkeypatch.setattr(_jit, "ENABLED", enabled)
            lik = CrossEntropyBackgroundLikelihood(**kw)
            calls.clear()
            for t in [*targets, edge, odd]:
                lik.init_target(frame, t)
            got[enabled] = ({i: q.tobytes() for i, q in lik.templates_.items()}, len(calls))
        assert got[True][0] == got[False][0]
        assert got[False][1] == 0
        # compiled: every box but the one leaving the image, and only for whole boxes
        assert got[True][1] == (4 if not kw else 0)
    monkeypatch.setattr(_jit, "ENABLED", True)
    lik = CrossEntropyBackgroundLikelihood()
    calls.clear()
    lik.init_target(frame, odd)
    assert calls == [(13, 18, 3)]  # x 31-49, y 20-33: floor(v + 0.5) of each value


def test_changed_parameters_rebuild_the_binner_after_frames():
    """The per-frame set-up check is by identity of the parameter values: assigning new ones
    between frames still rebuilds the binner (and validates them)."""
    frame, targets = _scene(9)
    lik = CrossEntropyBackgroundLikelihood()
    for t in targets:
        lik.init_target(frame, t)
    lik.begin_frame(frame, targets)
    assert lik.binner_.n_bins == 512
    assert lik._setup() is lik.binner_  # unchanged values: the same binner
    lik.bins = 4
    assert lik._setup().n_bins == 64
    lik.eps = -1.0  # not part of the binner: validated with the next rebuild
    lik.colour_space = "hsv"
    with pytest.raises(ValueError, match="eps"):
        lik._setup()
    lik.eps = 1e-4
    lik.region = [0.1, 0.1, 0.9, 0.9]  # a list: compared by value every time
    lik._setup()
    lik.region[2] = 0.5
    assert lik._setup() is not None and lik._setup_key[2] == (0.1, 0.1, 0.5, 0.9)
