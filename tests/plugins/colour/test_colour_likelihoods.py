"""The four colour likelihoods of the colour paper: numbers against brute-force per-pixel loops, the
cross-entropy identities (eq. 14 = eq. 18, eq. 21 = eq. 22), clipping, joint weighting with the
background, template update, parameters and the conformance kit."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import Frame, Target
from pftrack.testing import check_component
from pftrack_colour.histograms import ColourBins, ParticleRegion, normalise_histogram
from pftrack_colour.likelihoods import (
    BhattacharyyaBackgroundLikelihood,
    BhattacharyyaLikelihood,
    CrossEntropyBackgroundLikelihood,
    CrossEntropyLikelihood,
)

ALL = [BhattacharyyaLikelihood, BhattacharyyaBackgroundLikelihood, CrossEntropyLikelihood,
       CrossEntropyBackgroundLikelihood]


def _scene(seed: int = 0):
    """A 80 x 60 noisy frame with a red and a blue 12 x 12 patch, and two targets on them."""
    rng = np.random.default_rng(seed)
    img = rng.integers(60, 200, (60, 80, 3), dtype=np.uint8)
    img[10:22, 10:22] = (40, 40, 210)
    img[30:42, 50:62] = (210, 60, 30)
    img = np.clip(img.astype(int) + rng.integers(-6, 7, img.shape), 0, 255).astype(np.uint8)
    t1 = Target(id=1, state=np.array([16.0, 16.0]), box_xywh_px=np.array([10.0, 10, 12, 12]))
    t2 = Target(id=2, state=np.array([56.0, 36.0]), box_xywh_px=np.array([50.0, 30, 12, 12]))
    return Frame(1, img), [t1, t2]


def _boxes(rng, n=40, size=12.0, w=80, h=60):
    c = np.column_stack([rng.uniform(-8, w + 8, n), rng.uniform(-8, h + 8, n)])
    b = np.column_stack([c - size / 2, np.full((n, 2), size)])
    b[0] = [w + 30, 5, size, size]  # wholly outside
    b[1] = [10.0, 10.0, size, size]  # on target 1
    return b


def _rect(box, w, h):
    x0, y0 = int(np.floor(box[0] + 0.5)), int(np.floor(box[1] + 0.5))
    x1, y1 = x0 + int(np.floor(box[2] + 0.5)), y0 + int(np.floor(box[3] + 0.5))
    return max(x0, 0), max(y0, 0), min(x1, w), min(y1, h), (x1 - x0) * (y1 - y0)


def _ready(lik, frame, targets):
    for t in targets:
        lik.init_target(frame, t)
    lik.begin_frame(frame, targets)
    return lik


def test_template_is_the_initial_box_histogram():
    frame, (t1, _) = _scene()
    lik = CrossEntropyLikelihood(eps=1e-3)
    lik.init_target(frame, t1)
    counts = ColourBins(8).histogram(frame.image[10:22, 10:22])
    np.testing.assert_allclose(lik.template(1)[0], normalise_histogram(counts, 1e-3))
    assert lik.template(1).shape == (1, 512)


def test_cross_entropy_is_the_sum_of_log_q_over_the_box():
    """eq. 18: with λ = n, log P = Σ_{x in box} log q(bin(x)); clipped boxes: n × mean."""
    frame, targets = _scene()
    lik = _ready(CrossEntropyLikelihood(), frame, targets)
    rng = np.random.default_rng(1)
    boxes = _boxes(rng)
    ll = lik.log_likelihood(boxes, targets[0])
    logq = np.log(lik.template(1)[0])
    bins = ColourBins(8)(frame.image)
    for i, b in enumerate(boxes):
        x0, y0, x1, y1, area = _rect(b, 80, 60)
        if x1 <= x0 or y1 <= y0:
            assert ll[i] == -np.inf
            continue
        vals = logq[bins[y0:y1, x0:x1]]
        assert ll[i] == pytest.approx(area * vals.mean(), rel=1e-5), i
    assert np.argmax(ll) == 1  # the box on target 1


@pytest.mark.parametrize("cls", [CrossEntropyLikelihood, CrossEntropyBackgroundLikelihood])
@pytest.mark.parametrize("parts", [1, 3])
def test_integral_equals_sample_histograms(cls, parts):
    """eq. 14 (a histogram per sample) and the integral image give the same numbers."""
    frame, targets = _scene(2)
    kw = {"overlap": "independent"} if cls is CrossEntropyBackgroundLikelihood else {}
    fast = _ready(cls(parts=parts, **kw), frame, targets)
    slow = _ready(cls(parts=parts, method="histogram", **kw), frame, targets)
    boxes = _boxes(np.random.default_rng(3))
    for t in targets:
        a, b = fast.log_likelihood(boxes, t), slow.log_likelihood(boxes, t)
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-3)


def test_integral_path_builds_no_sample_histogram(monkeypatch):
    frame, targets = _scene()
    lik = _ready(CrossEntropyBackgroundLikelihood(), frame, targets)

    def forbidden(*a, **k):
        raise AssertionError("the O(1) path must not build sample histograms")

    monkeypatch.setattr(ParticleRegion, "box_histograms", forbidden)
    boxes = _boxes(np.random.default_rng(0), n=5000)
    ll = lik.log_likelihood(boxes, targets[0])
    assert ll.shape == (5000,) and not np.isnan(ll).any()


def test_background_histogram_excludes_every_target_box():
    frame, targets = _scene()
    lik = _ready(CrossEntropyBackgroundLikelihood(background_stride=1, eps=1e-6), frame,
                 targets)
    bins = ColourBins(8)(frame.image)
    mask = np.ones(bins.shape, bool)
    mask[10:22, 10:22] = False
    mask[30:42, 50:62] = False
    expected = normalise_histogram(np.bincount(bins[mask], minlength=512).astype(float), 1e-6)
    np.testing.assert_allclose(lik.background_, expected)
    # the red patch's colour is (nearly) absent from the background
    red = bins[15, 15]
    assert lik.background_[red] < 1e-4


@pytest.mark.parametrize("space, stride", [("rgb", 3), ("hsv", 2), ("lab", 1)])
def test_background_counts_one_histogram_call_equal_the_bin_image_path(space, stride):
    """cross-entropy-bg counts the background with one masked histogram call, the
    Bhattacharyya background (which also needs per-target counts) from the bin image: the same
    numbers, also when the targets cover the whole image."""
    frame, targets = _scene(7)
    big = Target(id=3, state=np.array([40.0, 30.0]), box_xywh_px=np.array([-5.0, -5, 90, 70]))
    for ts in (targets, [*targets, big]):
        kw = {"colour_space": space, "background_stride": stride}
        ce = _ready(CrossEntropyBackgroundLikelihood(**kw), frame, ts)
        bh = _ready(BhattacharyyaBackgroundLikelihood(**kw), frame, ts)
        assert np.array_equal(ce.background_counts_, bh.background_counts_)
        assert np.array_equal(ce.background_, bh.background_)
        assert ce.background_counts_.sum() > 0


def test_cross_entropy_background_is_the_log_ratio_sum():
    """eq. 21-22: log L = Σ_{x in box} log(q / h_back)(bin(x)) for a box clear of other targets."""
    frame, targets = _scene()
    lik = _ready(CrossEntropyBackgroundLikelihood(background_stride=1), frame, targets)
    box = np.array([[20.0, 40.0, 12.0, 12.0], [10.0, 10.0, 12.0, 12.0]])
    ll = lik.log_likelihood(box, targets[0])
    bins = ColourBins(8)(frame.image)
    ratio = np.log(lik.template(1)[0]) - np.log(lik.background_)
    assert ll[0] == pytest.approx(ratio[bins[40:52, 20:32]].sum(), rel=1e-5)
    assert ll[1] == pytest.approx(ratio[bins[10:22, 10:22]].sum(), rel=1e-5)
    assert ll[1] > 0 > ll[0]  # target-like vs background-like


@pytest.mark.parametrize("overlap", ["mixture", "product", "independent"])
def test_joint_weighting_inside_another_targets_box(overlap):
    frame, targets = _scene()
    t1 = targets[0]
    lik = _ready(CrossEntropyBackgroundLikelihood(background_stride=1, overlap=overlap), frame,
                 targets)
    # a box of target 1 straddling target 2's box
    box = np.array([[44.0, 26.0, 12.0, 12.0]])
    ll = lik.log_likelihood(box, t1)[0]
    bins = ColourBins(8)(frame.image)
    q1, q2 = lik.template(1)[0], lik.template(2)[0]
    hb = lik.background_
    expected = 0.0
    for y in range(26, 38):
        for x in range(44, 56):
            b = bins[y, x]
            inside2 = 50 <= x < 62 and 30 <= y < 42
            if not inside2 or overlap == "independent":
                expected += np.log(q1[b] / hb[b])
            elif overlap == "product":
                expected += np.log(q1[b])
            else:
                expected += np.log((q1[b] + q2[b]) / 2) - np.log(q2[b])
    assert ll == pytest.approx(expected, rel=1e-4)


def _three_targets(seed: int = 4):
    """The two-patch scene plus a third target whose box overlaps target 2's."""
    frame, (t1, t2) = _scene(seed)
    t3 = Target(id=3, state=np.array([62.0, 42.0]), box_xywh_px=np.array([56.0, 36.0, 12, 12]))
    return frame, [t1, t2, t3]


@pytest.mark.parametrize("overlap", ["mixture", "product"])
def test_joint_weighting_where_two_other_targets_overlap(overlap):
    """Pixels under two other targets (K = 2) take the general path: brute force per pixel."""
    frame, targets = _three_targets()
    t1 = targets[0]
    lik = _ready(CrossEntropyBackgroundLikelihood(background_stride=1, overlap=overlap), frame,
                 targets)
    box = np.array([[48.0, 28.0, 14.0, 14.0]])  # over targets 2 and 3 and their overlap
    ll = lik.log_likelihood(box, t1)[0]
    bins = ColourBins(8)(frame.image)
    q = {t.id: lik.template(t.id)[0] for t in targets}
    hb = lik.background_
    expected = 0.0
    n_two = 0
    for y in range(28, 42):
        for x in range(48, 62):
            b = bins[y, x]
            under = [tid for tid, (x0, y0) in ((2, (50, 30)), (3, (56, 36)))
                     if x0 <= x < x0 + 12 and y0 <= y < y0 + 12]
            n_two += len(under) == 2
            if not under:
                expected += np.log(q[1][b] / hb[b])
            elif overlap == "product":
                expected += np.log(q[1][b])
            else:
                s = sum(q[tid][b] for tid in under)
                expected += np.log((q[1][b] + s) / (len(under) + 1)) - np.log(s / len(under))
    assert n_two == 36  # the case under test does occur
    assert ll == pytest.approx(expected, rel=1e-4)


@pytest.mark.parametrize("overlap", ["mixture", "product"])
@pytest.mark.parametrize("parts", [1, 2])
def test_per_pair_tables_equal_the_general_path_bit_for_bit(overlap, parts):
    """Where each covered pixel lies under one other target, values come from per-pair tables;
    they are the numbers the general (masked) path computes."""
    frame, targets = _scene(5)
    lik = _ready(CrossEntropyBackgroundLikelihood(overlap=overlap, parts=parts), frame,
                 targets)
    boxes = _boxes(np.random.default_rng(6), n=300)
    t = targets[0]
    region = ParticleRegion(frame.image, boxes)
    bins = lik.binner_(region.pixels())
    cover = lik._coverage(region, t.id)
    assert cover  # some sample boxes reach into target 2's box
    for k in range(parts):
        lik._cover_cache = None
        fast = lik._value_image(region, bins, lik.values_[t.id], k, t.id)
        lik._cover_cache = (None, *lik._cover_sums(region, bins, t.id))
        general = lik._value_image(region, bins, lik.values_[t.id], k, t.id)
        assert np.array_equal(fast, general)


def test_bhattacharyya_matches_brute_force():
    frame, targets = _scene(4)
    lik = _ready(BhattacharyyaLikelihood(lam=20.0), frame, targets)
    boxes = _boxes(np.random.default_rng(5))
    ll = lik.log_likelihood(boxes, targets[1])
    q = lik.template(2)[0]
    bins = ColourBins(8)(frame.image)
    for i, b in enumerate(boxes):
        x0, y0, x1, y1, _ = _rect(b, 80, 60)
        if x1 <= x0 or y1 <= y0:
            assert ll[i] == -np.inf
            continue
        p = np.bincount(bins[y0:y1, x0:x1].ravel(), minlength=512) / ((x1 - x0) * (y1 - y0))
        expected = -20.0 * np.sqrt(max(0.0, 1 - np.sum(np.sqrt(p * q))))
        assert ll[i] == pytest.approx(expected, rel=1e-6, abs=1e-9), i


def test_bhattacharyya_background_matches_brute_force():
    """eq. 23: the sample's background histogram is everything outside the other targets'
    boxes and the sample's box."""
    frame, targets = _scene(6)
    t1 = targets[0]
    lik = _ready(BhattacharyyaBackgroundLikelihood(lam=10.0, background_stride=1), frame,
                 targets)
    boxes = np.array([[20.0, 40.0, 12, 12], [11.0, 9.0, 12, 12], [45.0, 28.0, 12, 12],
                      [-4.0, 50.0, 12, 12]])
    ll = lik.log_likelihood(boxes, t1)
    bins = ColourBins(8)(frame.image)
    q, hb = lik.template(1)[0], lik.background_
    for i, b in enumerate(boxes):
        x0, y0, x1, y1, _ = _rect(b, 80, 60)
        p = np.bincount(bins[y0:y1, x0:x1].ravel(), minlength=512) / ((x1 - x0) * (y1 - y0))
        bg = np.ones(bins.shape, bool)
        bg[30:42, 50:62] = False  # the other target
        bg[y0:y1, x0:x1] = False  # the sample
        pb = np.bincount(bins[bg], minlength=512) / bg.sum()
        expected = -10.0 * (np.sqrt(1 - np.sum(np.sqrt(p * q)))
                            + np.sqrt(max(0.0, 1 - np.sum(np.sqrt(pb * hb)))))
        assert ll[i] == pytest.approx(expected, rel=1e-6), i


@pytest.mark.parametrize("cls", ALL)
def test_the_target_box_wins_and_nothing_is_nan(cls):
    frame, targets = _scene(7)
    lik = _ready(cls(), frame, targets)
    boxes = _boxes(np.random.default_rng(8), n=300)
    for t, true in zip(targets, ([10.0, 10, 12, 12], [50.0, 30, 12, 12])):
        b = boxes.copy()
        b[1] = [30.0, 45.0, 12, 12]
        b[2] = true
        ll = lik.log_likelihood(b, t)
        assert not np.isnan(ll).any()
        assert ll[0] == -np.inf  # wholly outside
        assert np.argmax(ll) == 2


def test_template_update_option():
    frame, targets = _scene()
    t1 = targets[0]
    fixed = _ready(CrossEntropyLikelihood(), frame, [t1])
    moving = _ready(CrossEntropyLikelihood(update_rate=0.5), frame, [t1])
    q0 = fixed.template(1).copy()
    img2 = frame.image.copy()
    img2[10:22, 10:22] = (30, 200, 30)  # the target turns green
    f2 = Frame(2, img2)
    for lik in (fixed, moving):
        lik.begin_frame(f2, [t1])
        lik.begin_frame(Frame(3, img2), [t1])  # the update reads the previous frame
    np.testing.assert_array_equal(fixed.template(1), q0)
    green = ColourBins(8)(img2)[15, 15]
    expected = 0.5 * q0[0, green] + 0.5 * (1 + 1e-4) / (1 + 512e-4)  # floored histogram
    assert moving.template(1)[0, green] == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("kwargs, word", [
    ({"eps": 0}, "eps"), ({"region": (0.5, 0, 0.2, 1)}, "region"), ({"parts": 0}, "parts"),
    ({"update_rate": 2}, "update_rate"), ({"lam": -1.0}, "lam"), ({"method": "fast"}, "method"),
    ({"overlap": "max"}, "overlap"), ({"background_stride": 0}, "background_stride"),
    ({"method": "histogram"}, "independent"),
])
def test_bad_parameters_are_named(kwargs, word):
    frame, targets = _scene()
    with pytest.raises(ValueError, match=word):
        CrossEntropyBackgroundLikelihood(**kwargs).init_target(frame, targets[0])


def test_errors_before_set_up():
    frame, targets = _scene()
    lik = CrossEntropyLikelihood()
    with pytest.raises(RuntimeError, match="begin_frame"):
        lik.log_likelihood(np.zeros((1, 4)), targets[0])
    lik.begin_frame(frame, [])
    with pytest.raises(KeyError, match="init_target"):
        lik.log_likelihood(np.zeros((1, 4)), targets[0])
    with pytest.raises(ValueError, match="outside"):
        lik.init_target(frame, Target(id=5, state=np.zeros(2),
                                      box_xywh_px=np.array([500.0, 5, 10, 10])))


@pytest.mark.parametrize("cls", ALL)
def test_conformance_kit(cls):
    bad = [str(r) for r in check_component(cls) if not r.passed]
    assert bad == []


@pytest.mark.parametrize("cls", ALL)
def test_registered_under_the_papers_names(cls):
    import pftrack_colour
    from pftrack.host import Host

    host = Host(load_entry_points=False, plugins=[("colour", pftrack_colour)])
    names = {BhattacharyyaLikelihood: "bhattacharyya",
             BhattacharyyaBackgroundLikelihood: "bhattacharyya-bg",
             CrossEntropyLikelihood: "cross-entropy",
             CrossEntropyBackgroundLikelihood: "cross-entropy-bg"}
    assert host.get("likelihood", names[cls]) is cls
    lik = host.build("likelihood", {"type": names[cls], "params": {"parts": 2}})
    assert lik.to_config()["params"]["parts"] == 2
