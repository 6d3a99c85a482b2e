"""The soccer paper's likelihoods: EMD (exactness), NCC (against a direct computation), detection
(eq. 6) and the configurable composite (eq. 5, 9)."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.contracts.components import DetectionMatch, Detections, Frame, Likelihood, Target
from pftrack_world.likelihoods import (
    CompositeLikelihood,
    DetectionLikelihood,
    EMDLikelihood,
    NCCLikelihood,
    emd_1d,
)
from pftrack_world.regions import cell_means, grid_samples, integral_image
from scipy.stats import wasserstein_distance


def _frame(seed: int = 0, index: int = 1) -> Frame:
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, (120, 160, 3), dtype=np.uint8)
    img[30:90, 60:85] = (30, 40, 200)  # a red "person"
    img[45:60, 60:85] = (200, 60, 30)
    return Frame(index, img)


def _target(box, tid: int = 1, state=(0.0, 0.0)) -> Target:
    st = np.zeros(6)
    st[:2] = state
    return Target(id=tid, state=st, box_xywh_px=np.asarray(box, dtype=np.float64))


def test_emd_1d_is_the_exact_wasserstein_distance():
    rng = np.random.default_rng(3)
    for _ in range(20):
        a = rng.random(16)
        b = rng.random(16)
        a /= a.sum()
        b /= b.sum()
        bins = np.arange(16)
        ref = wasserstein_distance(bins, bins, a, b)
        assert emd_1d(a, b) == pytest.approx(ref, rel=1e-12, abs=1e-12)
    # vectorised over leading axes
    H = rng.random((5, 3, 8))
    H /= H.sum(axis=-1, keepdims=True)
    out = emd_1d(H, H[:1])
    assert out.shape == (5, 3) and np.allclose(out[0], 0)


def test_emd_likelihood_matches_a_direct_computation():
    f = _frame()
    lik = EMDLikelihood(bins=8, grid_wh=(4, 6), region=None, sigma=0.1)
    t = _target([60, 30, 25, 60])
    lik.init_target(f, t)
    lik.begin_frame(f, [t])
    boxes = np.array([[60, 30, 25, 60], [70, 35, 25, 60], [0, 0, 25, 60], [150, 100, 25, 60]],
                     dtype=float)
    d = lik.distance(boxes, t)
    q = lik.quantised_
    # direct: every pixel of the template box; the window's grid of nearest pixels
    tmpl = np.stack([np.bincount(q[30:90, 60:85, c].ravel(), minlength=8) for c in range(3)])
    tmpl = tmpl / tmpl.sum(axis=1, keepdims=True)
    for i, (x, y, w, h) in enumerate(boxes):
        xs = np.floor(x + w * (np.arange(4) + 0.5) / 4).astype(int)
        ys = np.floor(y + h * (np.arange(6) + 0.5) / 6).astype(int)
        pts = [(yy, xx) for yy in ys for xx in xs if 0 <= xx < 160 and 0 <= yy < 120]
        hist = np.zeros((3, 8))
        for yy, xx in pts:
            for c in range(3):
                hist[c, q[yy, xx, c]] += 1
        hist /= len(pts)
        ref = np.mean([wasserstein_distance(np.arange(8), np.arange(8), hist[c], tmpl[c])
                       for c in range(3)]) / 7
        assert d[i] == pytest.approx(ref, rel=1e-9, abs=1e-12)
    ll = lik.log_likelihood(boxes, t)
    assert np.argmax(ll) == 0
    np.testing.assert_allclose(ll, -0.5 * (d / 0.1) ** 2)


def test_cell_means_are_exact_area_averages_and_flag_outside_cells():
    img = np.arange(12 * 10, dtype=np.float64).reshape(12, 10)
    ii = integral_image(img.astype(np.float32))
    means, valid = cell_means(ii, np.array([[2.0, 3.0, 4.0, 6.0], [-8.0, 0.0, 4.0, 4.0]]),
                              (2, 3))
    ref = img[3:9, 2:6].reshape(3, 2, 2, 2).mean(axis=(1, 3))
    np.testing.assert_allclose(means[0], ref)
    assert valid[0].all() and not valid[1].any()
    vals, ok = grid_samples(img, np.array([[0.0, 0.0, 10.0, 12.0]]), (2, 2))
    assert vals.tolist() == [[img[3, 2], img[3, 7], img[9, 2], img[9, 7]]] and ok.all()


def test_ncc_matches_a_direct_computation_and_peaks_on_the_target():
    f = _frame()
    lik = NCCLikelihood(grid_wh=(5, 6), sigma=0.25)
    t = _target([60, 30, 25, 60])
    lik.init_target(f, t)
    lik.begin_frame(f, [t])
    boxes = np.array([[60, 30, 25, 60], [65, 33, 25, 60], [10, 10, 25, 60]], dtype=float)
    r = lik.ncc(boxes, t)
    import cv2

    grey = cv2.cvtColor(f.image, cv2.COLOR_BGR2GRAY).astype(np.float64)

    def cells(b):
        x, y, w, h = b
        out = np.empty((6, 5))
        for i in range(6):
            for j in range(5):
                x0 = int(np.floor(x + w * j / 5 + 0.5))
                x1 = int(np.floor(x + w * (j + 1) / 5 + 0.5))
                y0 = int(np.floor(y + h * i / 6 + 0.5))
                y1 = int(np.floor(y + h * (i + 1) / 6 + 0.5))
                out[i, j] = grey[y0:y1, x0:x1].mean()
        return out.ravel()

    T = cells(boxes[0])
    for i, b in enumerate(boxes):
        ref = np.corrcoef(cells(b), T)[0, 1]
        assert r[i] == pytest.approx(ref, abs=1e-9)
    assert r[0] == pytest.approx(1.0)
    ll = lik.log_likelihood(boxes, t)
    assert ll[0] == pytest.approx(0.0) and ll[0] > max(ll[1], ll[2])
    # the paper's raw NCC value
    raw = NCCLikelihood(grid_wh=(5, 6), sigma=None)
    raw.init_target(f, t)
    raw.begin_frame(f, [t])
    np.testing.assert_allclose(raw.log_likelihood(boxes[:2], t),
                               np.log(np.clip(r[:2], 1e-3, 1)))
    # a window wholly outside the image: floor, not NaN
    out = lik.log_likelihood(np.array([[500.0, 500.0, 20.0, 40.0]]), t)
    assert out[0] == pytest.approx(np.log(1e-3))


def test_detection_likelihood_eq6():
    lik = DetectionLikelihood(phi=0.5, psi=2.0, sigma=0.1, floor=0.0)
    t = _target([60, 30, 20, 50])
    dets = Detections([[60, 30, 20, 50], [0, 0, 20, 50]], [0.8, 1.2])
    lik.begin_frame(_frame(), [t], dets)
    boxes = np.array([[60, 30, 20, 50], [63, 30, 20, 50]], dtype=float)
    # I(tr*) = 0: no matched detection -> p_D = 0
    assert np.all(lik.log_likelihood(boxes, t) == -np.inf)
    t.detection = DetectionMatch(dets.boxes_xywh_px[0], 0.8, 0)
    p = np.exp(lik.log_likelihood(boxes, t))
    iou1 = (17 * 50) / (2 * 1000 - 17 * 50)
    expect = [2.0 * 1.0 + 0.5 * 0.8 * 1.0,
              2.0 * np.exp(-0.5 * (3 / 50 / 0.1) ** 2) + 0.5 * 0.8 * iou1]
    np.testing.assert_allclose(p, expect, rtol=1e-9)


class _Const(Likelihood):
    """A test likelihood returning a constant log value (and counting calls)."""

    def __init__(self, value: float = 0.0) -> None:
        self.value = value

    def log_likelihood(self, boxes_xywh_px, target):
        self.calls_ = getattr(self, "calls_", 0) + 1
        return np.full(len(boxes_xywh_px), float(self.value))


@pytest.fixture()
def host_with_const(monkeypatch):
    from pftrack import host as host_mod
    from pftrack.host import Host

    class Plugin:
        @staticmethod
        def pftrack_register_likelihoods(register):
            register("const-test", _Const)

    from pftrack import hookimpl

    Plugin.pftrack_register_likelihoods = staticmethod(
        hookimpl(Plugin.pftrack_register_likelihoods))
    h = Host(plugins=[("const-test-plugin", Plugin)])
    monkeypatch.setattr(host_mod, "_HOST", h)
    return h


def test_composite_sum_and_product_and_beta(host_with_const):
    a = {"type": "const-test", "params": {"value": np.log(0.2)}}
    b = {"type": "const-test", "params": {"value": np.log(0.6)}}
    comp = CompositeLikelihood(terms=[{"likelihood": a, "weight": 1.0},
                                      {"likelihood": b, "weight": "beta"},
                                      {"likelihood": a, "weight": "1-beta"}], beta_sigma=2.0)
    f = _frame()
    t1, t2, t3 = _target([0, 0, 5, 5], 1, (0, 0)), _target([0, 0, 5, 5], 2, (3, 4)), \
        _target([0, 0, 5, 5], 3, (30, 0))
    for t in (t1, t2, t3):
        comp.init_target(f, t)
    comp.begin_frame(f, [t1, t2, t3])
    beta = np.exp(-0.5 * (5.0 / 2.0) ** 2)  # t1's nearest other target is 5 m away
    assert comp.beta_[1] == pytest.approx(beta)
    out = comp.log_likelihood(np.zeros((3, 4)), t1)
    assert out.shape == (3,)
    np.testing.assert_allclose(out, np.log(0.2 + beta * 0.6 + (1 - beta) * 0.2))
    prod = CompositeLikelihood(terms=comp.terms, mix="product", beta_sigma=2.0)
    prod.begin_frame(f, [t1, t2, t3])
    np.testing.assert_allclose(prod.log_likelihood(np.zeros((2, 4)), t1),
                               np.log(0.2) + beta * np.log(0.6) + (1 - beta) * np.log(0.2))
    # alone: beta = 0, so the "beta" term is never computed
    solo = CompositeLikelihood(terms=comp.terms, beta_sigma=2.0)
    solo.begin_frame(f, [t1])
    solo.log_likelihood(np.zeros((1, 4)), t1)
    assert not hasattr(solo.terms_[1], "calls_") and solo.terms_[0].calls_ == 1


def test_composite_validation():
    with pytest.raises(ValueError, match="terms is empty"):
        CompositeLikelihood().begin_frame(_frame(), [])
    with pytest.raises(ValueError, match="weight"):
        CompositeLikelihood(terms=[{"likelihood": "ncc", "weight": "gamma"}]).begin_frame(
            _frame(), [])
    with pytest.raises(ValueError, match="mix"):
        CompositeLikelihood(terms=[{"likelihood": "ncc"}], mix="max").begin_frame(_frame(), [])
    with pytest.raises(KeyError, match="no likelihood named"):
        CompositeLikelihood(terms=[{"likelihood": "nope"}]).begin_frame(_frame(), [])
    with pytest.raises(ValueError, match="colour_space"):
        EMDLikelihood(colour_space="xyz").begin_frame(_frame(), [])


def test_composite_exclusion_keeps_a_coasting_target_off_a_detected_one(host_with_const):
    """A target without a detection is weighted by prod_j (1 - exp(-d_j^2 / 2 r^2)) over the
    targets that have one; detected targets and the exclusion-free composite are unchanged."""
    a = {"type": "const-test", "params": {"value": np.log(0.5)}}
    comp = CompositeLikelihood(terms=[{"likelihood": a, "weight": 1.0}], exclusion_m=0.3)
    plain = CompositeLikelihood(terms=[{"likelihood": a, "weight": 1.0}])
    f = _frame()
    coasting = _target([0, 0, 5, 5], 1, (0.0, 0.0))
    detected = _target([0, 0, 5, 5], 2, (0.4, 0.0))
    far = _target([0, 0, 5, 5], 3, (10.0, 0.0))  # no detection either: excludes nobody
    rng = np.random.default_rng(0)
    for t, centre in ((coasting, (0.0, 0.0)), (detected, (0.4, 0.0)), (far, (10.0, 0.0))):
        p = np.zeros((4, 6))
        p[:, :2] = np.asarray(centre) + rng.normal(0, 0.05, (4, 2))
        t.particles = p
    detected.detection = DetectionMatch(np.zeros(4), 1.0, 0)
    for c in (comp, plain):
        c.begin_frame(f, [coasting, detected, far])
    assert set(comp.anchors_) == {2}
    anchor = detected.particles[:, :2].mean(axis=0)
    d2 = ((coasting.particles[:, :2] - anchor) ** 2).sum(axis=1)
    want = np.log(0.5) + np.log(1.0 - np.exp(-0.5 * d2 / 0.3 ** 2))
    np.testing.assert_allclose(comp.log_likelihood(np.zeros((4, 4)), coasting), want)
    # particles nearer the detected person weigh less
    near = np.argsort(d2)
    assert np.all(np.diff(comp.log_likelihood(np.zeros((4, 4)), coasting)[near]) > 0)
    for t in (detected, far):
        np.testing.assert_allclose(comp.log_likelihood(np.zeros((4, 4)), t), np.log(0.5))
    np.testing.assert_allclose(plain.log_likelihood(np.zeros((4, 4)), coasting), np.log(0.5))
    # boxes that are not the target's own particles: no exclusion (nothing to place them)
    np.testing.assert_allclose(comp.log_likelihood(np.zeros((2, 4)), coasting), np.log(0.5))
    with pytest.raises(ValueError, match="exclusion_m"):
        CompositeLikelihood(terms=[{"likelihood": a}], exclusion_m=0.0).begin_frame(f, [])


def _awkward_boxes(rng, n: int, w_img: int, h_img: int) -> np.ndarray:
    """Particle windows as a tracker makes them, and the awkward ones: reaching out of the
    image, wholly outside, tiny, NaN."""
    b = np.column_stack([rng.uniform(-30, w_img, n), rng.uniform(-40, h_img, n),
                         rng.uniform(0.3, 70, n), rng.uniform(0.3, 120, n)])
    b[::17] = np.nan
    b[5::23, 0] = 1e4
    return b


@pytest.mark.parametrize("lik_cls, params", [
    (EMDLikelihood, {"bins": 16, "grid_wh": (8, 16)}),
    (EMDLikelihood, {"bins": 7, "grid_wh": (3, 5), "region": None, "colour_space": "hsv"}),
    (NCCLikelihood, {"grid_wh": (8, 16)}),
    (NCCLikelihood, {"grid_wh": (5, 3), "region": (0.2, 0.1, 0.8, 0.6), "min_valid": 0.9}),
    (NCCLikelihood, {"grid_wh": (20, 16)}),  # 320 cells: numpy's pairwise sums split in halves
    (NCCLikelihood, {"grid_wh": (22, 44)}),  # 968 cells: 3 levels of halving
    (NCCLikelihood, {"grid_wh": (40, 50)}),  # 2000 cells
])
def test_compiled_emd_and_ncc_give_the_numpy_numbers_bit_for_bit(lik_cls, params, monkeypatch):
    import pftrack_world.appearance as mod  # the NCC and EMD likelihoods and their kernels

    if mod._kernels() is None:
        pytest.skip("numba kernels disabled (PFTRACK_NO_JIT)")
    rng = np.random.default_rng(11)
    f = _frame(seed=4)
    lik = lik_cls(**params)
    targets = [_target([60, 30, 25, 60]), _target([-10, 100, 30, 50], tid=2)]
    for t in targets:
        lik.init_target(f, t)
    f2 = _frame(seed=5, index=2)
    lik.begin_frame(f2, targets)
    boxes = _awkward_boxes(rng, 600, 160, 120)
    measure = lik.distance if lik_cls is EMDLikelihood else lik.ncc
    for t in targets:
        fast = measure(boxes, t)
        monkeypatch.setattr(mod, "_KERNELS", False)
        slow = measure(boxes, t)
        ll_slow = lik.log_likelihood(boxes, t)
        monkeypatch.undo()
        assert np.isnan(fast).sum() > 0
        np.testing.assert_array_equal(fast, slow)
        np.testing.assert_array_equal(lik.log_likelihood(boxes, t), ll_slow)


def _rows_scene(seed: int = 0):
    """Four targets (two matched to detections, one far from everyone) with 60 particle boxes
    each, some NaN, and the frame's detections."""
    rng = np.random.default_rng(seed)
    dets = Detections([[60, 30, 20, 50], [100, 40, 22, 55], [10, 10, 18, 40]], [0.8, 1.2, 0.4])
    targets = [_target([60, 30, 20, 50], 1, (70, 80)), _target([100, 40, 22, 55], 2, (111, 95)),
               _target([10, 10, 18, 40], 3, (19, 50)), _target([300, 10, 20, 50], 4, (310, 60))]
    targets[0].detection = DetectionMatch(dets.boxes_xywh_px[0], 0.8, 0)
    targets[1].detection = DetectionMatch(dets.boxes_xywh_px[1], 1.2, 1)
    boxes = np.array([t.box_xywh_px + rng.normal(0.0, 4.0, (60, 4)) * [1, 1, 0.2, 0.2]
                      for t in targets])
    boxes[2, 5] = np.nan
    for t, b in zip(targets, boxes):
        t.particles = np.column_stack([b[:, :2] + 0.5 * b[:, 2:], np.zeros((60, 4))])
    return targets, dets, boxes


@pytest.mark.parametrize("phi, floor", [(0.5, 1e-3), (0.0, 0.0)])
def test_detection_rows_equal_one_target_at_a_time_bit_for_bit(phi, floor):
    lik = DetectionLikelihood(phi=phi, psi=10.0, sigma=0.13, floor=floor)
    targets, dets, boxes = _rows_scene()
    lik.begin_frame(_frame(), targets, dets)
    rows = lik.log_likelihood_rows(boxes, targets)
    one = np.array([lik.log_likelihood(b, t) for b, t in zip(boxes, targets)])
    assert rows.shape == (4, 60) and rows.tobytes() == one.tobytes()
    assert np.all(rows[2:] == np.log(floor) if floor else rows[2:] == -np.inf)


@pytest.mark.parametrize("mix", ["sum", "product"])
def test_composite_rows_equal_one_target_at_a_time_bit_for_bit(host_with_const, mix):
    """Terms with rows of their own (detection) and without (a constant, called per target),
    beta weights that vanish for a target far from the others (its group mixes fewer terms),
    the exclusion prior on the unmatched targets: every row is the per-target call's."""
    terms = [{"likelihood": {"type": "detection", "params": {"floor": 1e-3}}, "weight": 1.0},
             {"likelihood": {"type": "const-test", "params": {"value": np.log(0.6)}},
              "weight": "beta"},
             {"likelihood": {"type": "const-test", "params": {"value": np.log(0.2)}},
              "weight": "1-beta"}]
    comp = CompositeLikelihood(terms=terms, mix=mix, beta_sigma=3.0, exclusion_m=40.0)
    targets, dets, boxes = _rows_scene(1)
    f = _frame()
    for t in targets:
        comp.init_target(f, t)
    comp.begin_frame(f, targets, dets)
    assert comp.offers_rows()
    assert comp.beta_[4] == 0.0 and 0.0 < comp.beta_[1] < 1.0
    rows = comp.log_likelihood_rows(boxes, targets)
    one = np.array([comp.log_likelihood(b, t) for b, t in zip(boxes, targets)])
    assert rows.shape == (4, 60) and rows.tobytes() == one.tobytes()
    assert np.nanmax(comp._exclusion(targets[2])) < -0.01  # the prior weighs the unmatched rows
