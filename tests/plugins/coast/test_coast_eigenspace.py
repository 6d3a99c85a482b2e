"""The block eigenspace background model and detector of the coast plugin (the coastal paper's sec.
2): exact numbers on synthetic blocks, masked training, 16-bit range, model files, the real water
data, and the conformance kit."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pftrack_coast
import pytest
from pftrack.contracts.components import Frame, RunContext, Target
from pftrack.host import Host
from pftrack.io.data import data_dir
from pftrack.testing import check_component, synthetic_scene
from pftrack_coast.detector import EigenspaceDetector, boxes_to_mask
from pftrack_coast.eigenspace import BlockEigenspaceModel, block_fractions, blocks_of

WATER = data_dir() / "water"
DATA = data_dir()


def image_from_blocks(x: np.ndarray, rows: int, cols: int, bs: int) -> np.ndarray:
    """Inverse of blocks_of: (rows * cols, bs²) -> (rows * bs, cols * bs)."""
    return x.reshape(rows, cols, bs, bs).transpose(0, 2, 1, 3).reshape(rows * bs, cols * bs)


def noise_frames(n: int, shape=(64, 64), sigma=5.0, seed=0, base=100.0, dtype=np.float64):
    rng = np.random.default_rng(seed)
    texture = np.random.default_rng(99).uniform(-30, 30, shape)
    return [(base + texture + rng.normal(0.0, sigma, shape)).astype(dtype) for _ in range(n)]


def fit_quiet(model: BlockEigenspaceModel, frames, masks=None) -> BlockEigenspaceModel:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return model.fit(frames, masks)


def reference_r(train: np.ndarray, x: np.ndarray, q: float = 0.8) -> tuple[int, float]:
    """One block, straight from the paper: PCA of the (N, P) training vectors, D by eq. 1,
    s = E^T (x - mean) (eq. 2, centred), r_D by eq. 3."""
    lam, vec = np.linalg.eigh(np.cov(train, rowvar=False))
    lam, vec = lam[::-1], vec[:, ::-1]
    cum = np.cumsum(lam) / lam.sum()
    d = int(np.argmax(cum >= q - 1e-12)) + 1
    s = vec[:, :d].T @ (x - train.mean(axis=0))
    return d, float(np.mean(s ** 2 / lam[:d]))


# -- exact numbers on synthetic blocks ------------------------------------------------------------


def test_two_dimensional_block_subspace_gives_d2_and_exact_r():
    bs, rows, cols = 8, 2, 3
    P, B, n = bs * bs, rows * cols, 16
    rng = np.random.default_rng(3)
    # per block two orthonormal directions u, v and a mean; coefficients with orthogonal sign
    # patterns so the sample variances are exactly 100 n/(n-1) and 64 n/(n-1), uncorrelated
    q_, _ = np.linalg.qr(rng.normal(size=(B, P, 3)))
    u, v, w = q_[:, :, 0], q_[:, :, 1], q_[:, :, 2]
    mean = rng.uniform(50, 200, (B, P))
    a = 10.0 * np.tile([1, -1], n // 2)
    b = 8.0 * np.tile([1, 1, -1, -1], n // 4)
    train = mean[None] + a[:, None, None] * u[None] + b[:, None, None] * v[None]  # (n, B, P)
    frames = [image_from_blocks(t, rows, cols, bs) for t in train]
    m = BlockEigenspaceModel(block_size=bs, min_samples=3).fit(frames)
    assert m.grid_shape_ == (rows, cols)
    np.testing.assert_array_equal(m.dims_, 2)  # q(1) = 100 / 164 < 0.8 <= q(2) = 1
    lam1, lam2 = 100.0 * n / (n - 1), 64.0 * n / (n - 1)
    np.testing.assert_allclose(m.eigenvalues_[:, :2], [[lam1, lam2]] * B, rtol=1e-10)
    # a test block 3 u + 4 v + 50 w off the mean: the w part is outside the eigenspace
    x = mean + 3.0 * u + 4.0 * v + 50.0 * w
    r = m.relative_variation(image_from_blocks(x, rows, cols, bs))
    np.testing.assert_allclose(r, 0.5 * (9.0 / lam1 + 16.0 / lam2), rtol=1e-9)
    # and 40 u: r = 1600 / lam1 / 2 = 7.5 (n-1)/n < v_D = 15: background; 60 u: intruder
    for k, flagged in ((40.0, False), (60.0, True)):
        res = m.score(image_from_blocks(mean + k * u, rows, cols, bs))
        np.testing.assert_allclose(res.r_map, k * k / lam1 / 2, rtol=1e-9)
        assert np.all(res.intruder_mask == flagged)


def test_bright_square_flagged_exactly_in_its_blocks():
    m = BlockEigenspaceModel().fit(noise_frames(40))
    test = noise_frames(1, seed=7)[0]
    test[16:32, 24:40] += 80.0  # blocks (2, 3), (2, 4), (3, 3), (3, 4)
    res = m.score(test)
    expected = np.zeros((8, 8), bool)
    expected[2:4, 3:5] = True
    np.testing.assert_array_equal(res.intruder_mask, expected)
    assert res.r_map[~expected].max() < 15.0 / 2
    np.testing.assert_array_equal(res.boxes_xywh_px, [[24.0, 16.0, 16.0, 16.0]])
    np.testing.assert_allclose(res.scores, [(res.r_map - m.v_.reshape(8, 8))[expected].max()])
    # two separate groups -> two boxes; diagonal neighbours are not 4-connected
    test2 = noise_frames(1, seed=8)[0]
    test2[0:8, 0:8] += 80.0
    test2[8:16, 8:16] += 80.0
    assert len(m.score(test2).boxes_xywh_px) == 2


def test_batched_equals_per_block_loop_reference():
    frames = noise_frames(30, shape=(40, 48), sigma=4.0)
    # give the blocks different structure: a few strong directions per block
    rng = np.random.default_rng(5)
    pat = rng.normal(size=(3, 40, 48))
    frames = [f + (rng.normal(size=3)[:, None, None] * pat * [[[9.0]], [[5.0]], [[2.0]]]).sum(0)
              for f in frames]
    m = BlockEigenspaceModel(min_samples=3).fit(frames)
    test = noise_frames(1, shape=(40, 48), seed=11)[0] + 3.0 * pat[0]
    r = m.relative_variation(test)
    X = np.stack([blocks_of(f, 8) for f in frames])  # (N, B, P)
    xt = blocks_of(test, 8)
    for blk in (0, 7, 13, 29):
        d, r_ref = reference_r(X[:, blk], xt[blk])
        assert m.dims_[blk] == d
        np.testing.assert_allclose(r.ravel()[blk], r_ref, rtol=1e-8)
    assert len(set(m.dims_.tolist())) > 1  # blocks really have different D


# -- masked training ------------------------------------------------------------------------------


def test_masked_training_excludes_foreground_blocks_and_reports_starved_ones():
    frames = noise_frames(20)
    masks = [np.zeros((64, 64), bool) for _ in frames]
    for k in range(12):  # block (1, 1) holds a bright object in 12 of 20 frames
        frames[k][8:16, 8:16] += 150.0
        masks[k][8:16, 8:16] = True
    for k in range(17):  # block (5, 6) is foreground in 17 frames: 3 samples left
        frames[k][40:48, 48:56] = 255.0
        masks[k][40:48, 48:56] = True
    masks[19][0, 0] = True  # one foreground pixel in block (0, 0) of the last frame
    with pytest.warns(UserWarning, match=r"1 of 64 blocks have fewer.*are never intruders"
                      r".*\(5, 6\)"):
        m = BlockEigenspaceModel(min_samples=5, untrained="ignore").fit(frames, masks)
    n = m.n_samples_.reshape(8, 8)
    assert n[1, 1] == 8 and n[5, 6] == 3 and n[0, 0] == 19 and n[0, 1] == 20
    # the object's frames did not enter block (1, 1): its mean is that of the other 8 frames
    blk = 1 * 8 + 1
    clean = np.stack([blocks_of(f, 8)[blk] for f in frames[12:]])
    np.testing.assert_allclose(m.mean_[blk], clean.mean(axis=0), rtol=1e-12)
    np.testing.assert_array_equal(m.untrained_blocks_, [[5, 6]])
    assert not m.trained_.reshape(8, 8)[5, 6]
    # an untrained block is never an intruder, whatever it shows
    test = noise_frames(1, seed=9)[0]
    test[40:48, 48:56] = 0.0
    res = m.score(test)
    assert not res.intruder_mask.any() and res.r_map[5, 6] == 0.0
    # the default is the same: an untrained block is never an intruder
    assert fit_quiet(BlockEigenspaceModel(min_samples=5), frames, masks).untrained == "ignore"
    # untrained="nearest": it borrows its nearest trained neighbour's eigenspace (one at grid
    # distance 1), so the dark square, which that neighbour never saw, is found
    with pytest.warns(UserWarning, match=r"1 of 64 blocks.*nearest trained block"):
        mb = BlockEigenspaceModel(min_samples=5, untrained="nearest").fit(frames, masks)
    assert mb.trained_.all() and mb.untrained_blocks_.tolist() == [[5, 6]]
    src = int(mb.source_[5 * 8 + 6])
    assert src != 5 * 8 + 6 and max(abs(src // 8 - 5), abs(src % 8 - 6)) == 1
    np.testing.assert_array_equal(mb.mean_[5 * 8 + 6], mb.mean_[src])
    res_b = mb.score(test)
    assert res_b.intruder_mask[5, 6] and res_b.intruder_mask.sum() == 1
    assert mb.describe()["n_borrowed"] == 1
    import tempfile
    from pathlib import Path

    back = BlockEigenspaceModel.load(mb.save(Path(tempfile.mkdtemp()) / "b.npz"))
    np.testing.assert_array_equal(back.source_, mb.source_)
    assert back.untrained_blocks_.tolist() == [[5, 6]] and back.trained_.all()
    np.testing.assert_array_equal(back.score(test).r_map, res_b.r_map)
    # a tolerant block (at least 95 % background) keeps the frame with one foreground pixel
    m2 = fit_quiet(BlockEigenspaceModel(min_samples=5, min_background_fraction=0.95),
                   frames, masks)
    assert m2.n_samples_.reshape(8, 8)[0, 0] == 20


def test_block_fractions_and_box_masks():
    mask = np.zeros((20, 17), bool)
    mask[0:4, 0:8] = True
    np.testing.assert_allclose(block_fractions(mask, 8), [[0.5, 0.0], [0.0, 0.0]])
    bm = boxes_to_mask(np.array([[2.5, 1.0, 3.0, 2.2], [-5, -5, 7, 7]]), (10, 10))
    assert bm[1:4, 2:6].all() and bm[0:2, 0:2].all() and bm.sum() == 12 + 4 - 0


def test_detector_fit_with_boxes_equals_fit_with_masks():
    sc = synthetic_scene(seed=2, n_frames=12)
    boxes = {k: b for k, b in sc.boxes_by_frame.items() if k % 2 == 0}  # odd frames: no boxes
    a = EigenspaceDetector(min_samples=3)
    b = EigenspaceDetector(min_samples=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a.fit(sc.frames, boxes)
        masks = [boxes_to_mask(boxes[f.index], f.image.shape[:2]) if f.index in boxes else None
                 for f in sc.frames]
        b.fit_masks(sc.frames, masks)
    np.testing.assert_array_equal(a.model_.n_samples_, b.model_.n_samples_)
    np.testing.assert_array_equal(a.score(sc.frames[3]).r_map, b.score(sc.frames[3]).r_map)
    assert a.model_.n_samples_.min() < len(sc.frames)  # some blocks did lose frames


# -- input types ----------------------------------------------------------------------------------


def test_sixteen_bit_frames_keep_their_range():
    frames = noise_frames(30, sigma=20.0, base=30000.0, dtype=np.uint16)
    m = BlockEigenspaceModel().fit(frames)
    assert m.mean_.min() > 29000  # not clipped or scaled to 8 bits
    test = noise_frames(1, sigma=20.0, base=30000.0, seed=5, dtype=np.uint16)[0]
    base = m.score(test)
    assert not base.intruder_mask.any()
    hot = test.copy()
    hot[32:40, 8:16] += 400  # a warm object: +400 counts, well above 8-bit range, 20 sigma
    res = m.score(hot)
    assert res.intruder_mask[4, 1] and res.intruder_mask.sum() == 1
    assert res.r_map[4, 1] > 100 * base.r_map[4, 1]
    # the same frame cut to 8 bits would show nothing at all (everything saturates at 255)
    assert np.all(np.minimum(hot, 255) == np.minimum(test, 255))


def test_colour_frame_with_equal_channels_scores_as_grey():
    frames = noise_frames(20, dtype=np.uint8)
    m = BlockEigenspaceModel().fit(frames)
    test = noise_frames(1, seed=3, dtype=np.uint8)[0]
    np.testing.assert_array_equal(m.relative_variation(np.repeat(test[:, :, None], 3, axis=2)),
                                  m.relative_variation(test))
    with pytest.raises(ValueError, match="trained on 64x64"):
        m.relative_variation(np.zeros((48, 64), np.uint8))


def test_frame_offset_median_ignores_a_global_level_change(tmp_path):
    frames = noise_frames(30, sigma=20.0, base=30000.0, dtype=np.uint16)
    test = noise_frames(1, sigma=20.0, base=30000.0, seed=5, dtype=np.uint16)[0] + 300
    test[32:40, 8:16] += 400
    paper = BlockEigenspaceModel().fit(frames)
    assert paper.score(test).intruder_mask.all()  # +300 counts everywhere: all intruders
    m = BlockEigenspaceModel(frame_offset="median").fit(frames)
    res = m.score(test)
    assert res.intruder_mask[4, 1] and res.intruder_mask.sum() == 1
    loaded = BlockEigenspaceModel.load(m.save(tmp_path / "m.npz"))
    assert loaded.frame_offset == "median"
    np.testing.assert_array_equal(loaded.relative_variation(test), res.r_map)
    with pytest.raises(ValueError, match="frame_offset"):
        BlockEigenspaceModel(frame_offset="mean").fit(frames)


# -- model files ----------------------------------------------------------------------------------


def test_save_load_round_trip_and_bad_files(tmp_path):
    frames = noise_frames(20)
    masks = [None] * 20
    masks[0] = np.zeros((64, 64), bool)
    masks[0][:8, :8] = True
    det = EigenspaceDetector(min_samples=3)
    det.fit_masks(frames, masks)
    path = det.save(tmp_path / "coast.npz")
    test = noise_frames(1, seed=4)[0]
    test[20:30, 20:30] += 60
    loaded = EigenspaceDetector(model=str(path))
    np.testing.assert_array_equal(loaded.score(test).r_map, det.score(test).r_map)
    np.testing.assert_array_equal(loaded.model_.n_samples_, det.model_.n_samples_)
    frame = Frame(1, test)
    d1, d2 = det.detect(frame), loaded.detect(frame)
    np.testing.assert_array_equal(d1.boxes_xywh_px, d2.boxes_xywh_px)
    assert len(d1) == 1
    via_setup = EigenspaceDetector()
    via_setup.setup(RunContext(detector_model=str(path)))
    np.testing.assert_array_equal(via_setup.score(test).r_map, det.score(test).r_map)
    info = json.loads(json.dumps(loaded.describe()))
    assert info["format"] == "pftrack-block-eigenspace" and info["n_blocks"] == 64
    # the same data gives the same model
    again = EigenspaceDetector(min_samples=3).fit_masks(frames, masks)
    np.testing.assert_array_equal(again.score(test).r_map, det.score(test).r_map)
    # broken files: ValueError naming the file
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"not a zip at all")
    other = tmp_path / "other.npz"
    np.savez(other, weights=np.zeros(3), params=np.array(json.dumps({"format": "x"})))
    objects = tmp_path / "objects.npz"
    np.savez(objects, **{k: np.array([None], dtype=object) for k in
                         ("params", "mean", "components", "eigenvalues", "dims", "n_samples")})
    trunc = tmp_path / "truncated.npz"
    trunc.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    bad_shape = tmp_path / "bad_shape.npz"
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["mean"] = arrays["mean"][:-1]
    np.savez(bad_shape, **arrays)
    for p in (garbage, other, objects, trunc, bad_shape):
        with pytest.raises(ValueError, match=p.name):
            EigenspaceDetector().load(p)
    with pytest.raises(FileNotFoundError):
        EigenspaceDetector().load(tmp_path / "missing.npz")
    with pytest.raises(ValueError, match="no model"):
        EigenspaceDetector().detect(frame)


# -- real data: UCSD water sequences ---------------------------------------------------------------


def _water(name: str, n: int):
    import cv2

    folder = WATER / name
    if not folder.is_dir():
        pytest.skip(f"{folder} not found (shared data)")
    frames = [cv2.imread(str(folder / "input" / f"frame_{i}.jpg"), cv2.IMREAD_UNCHANGED)
              for i in range(1, n + 1)]
    gt = [cv2.imread(str(folder / "groundtruth" / f"gt{i:04d}.png"), cv2.IMREAD_GRAYSCALE) > 127
          for i in range(1, n + 1)]
    return frames, gt


def block_prf(model: BlockEigenspaceModel, frames, gt, min_fraction: float = 0.25):
    """Block-level precision, recall, F: a ground-truth block is foreground when at least
    ``min_fraction`` of its pixels are."""
    tp = fp = fn = 0
    for f, g in zip(frames, gt):
        pred = model.score(f).intruder_mask
        truth = block_fractions(g, model.block_size) >= min_fraction
        tp += int((pred & truth).sum())
        fp += int((pred & ~truth).sum())
        fn += int((~pred & truth).sum())
    p, r = tp / max(tp + fp, 1), tp / max(tp + fn, 1)
    return p, r, 2 * p * r / max(p + r, 1e-12)


def test_zodiac_block_f_measure():
    frames, gt = _water("zodiac", 50)
    # the paper's parameters; untrained blocks borrow their neighbour's eigenspace
    m = fit_quiet(BlockEigenspaceModel(untrained="nearest"), frames[:25], gt[:25])
    p, r, f = block_prf(m, frames[25:], gt[25:])
    # measured: P 0.702, R 0.465, F 0.559 over frames 26-50 (ground-truth blocks at least a
    # quarter foreground; the boat covers about 3 such blocks per frame); with
    # untrained="ignore": P 0.711, R 0.451, F 0.552
    assert f > 0.50 and p > 0.6 and r > 0.4
    m = fit_quiet(BlockEigenspaceModel(untrained="ignore"), frames[:25], gt[:25])
    assert block_prf(m, frames[25:], gt[25:])[2] > 0.50


def test_ocean_people_standing_in_the_training_frames_are_found_with_borrowed_eigenspaces():
    """On the beach the walkers occupy the same blocks in every training frame (frames 1-15):
    those blocks have no background sample of their own. Judged by the nearest trained block's
    eigenspace they are found; left untrained they never can be."""
    frames, gt = _water("ocean", 30)
    near = fit_quiet(BlockEigenspaceModel(untrained="nearest"), frames[:15], gt[:15])
    ignore = fit_quiet(BlockEigenspaceModel(untrained="ignore"), frames[:15], gt[:15])
    p, r, f = block_prf(near, frames[15:], gt[15:])
    # measured (frames 16-30): P 0.335, R 0.908, F 0.490 (MOG2: F 0.415 in the same protocol,
    # pftrack bench background); with untrained="ignore": F 0.041
    assert f > 0.45 and r > 0.85
    assert block_prf(ignore, frames[15:], gt[15:])[2] < 0.1


def test_zodiac_frames_give_boxes_on_the_boat():
    frames, gt = _water("zodiac", 50)
    det = EigenspaceDetector()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        det.fit_masks(frames[:25], gt[:25])
    hits = 0
    for f, g in zip(frames[25:], gt[25:]):
        d = det.detect(Frame(0, f))
        ys, xs = np.nonzero(g)
        cx, cy = xs.mean(), ys.mean()
        b = d.boxes_xywh_px
        hits += bool(np.any((b[:, 0] <= cx) & (cx <= b[:, 0] + b[:, 2])
                            & (b[:, 1] <= cy) & (cy <= b[:, 1] + b[:, 3])))
    # measured: the boat's centre lies in a box in 20 of the 25 test frames
    assert hits >= 18


def test_thermal_clip_first_detection_with_frame_offset():
    cptv = pytest.importorskip("cptv")
    path = data_dir() / "thermal" / "animal_entry.cptv"
    if not path.is_file():
        pytest.skip(f"{path} not found (shared data)")
    with open(path, "rb") as fh:
        pix = [f.pix for f in cptv.CPTVReader(fh)]  # uint16 LWIR counts, about 28700-29100
    n = {}
    for offset in ("median", "none"):
        # frames 1-30 as they are: the animal rests at the left (x 8-18) through them (see
        # pftrack_coast/data/animal_entry_gt.txt), so the model learns it there as background
        m = BlockEigenspaceModel(frame_offset=offset).fit(pix[1:31])
        n[offset] = np.array([m.score(p).intruder_mask.sum() for p in pix])
    # measured (median): no block in frames 31-41, where the animal still rests where it was
    # learnt; from frame 43, once it has walked right, every frame has 1-15 intruder blocks
    assert n["median"][31:42].max() == 0
    assert n["median"][43:].min() >= 1 and n["median"][43:].max() <= 20
    # without it the camera's slow drift makes the whole picture an intruder (measured:
    # 30-299 blocks from frame 52 on, 299 by the end)
    assert n["none"][31:42].max() == 0 and n["none"][120:].min() > 250


# -- plugin and conformance -----------------------------------------------------------------------


def test_registered_and_conforms():
    host = Host(load_entry_points=False, plugins=[("coast", pftrack_coast)])
    cls = host.get("detector", "eigenspace")
    assert cls is EigenspaceDetector
    det = host.build("detector", {"type": "eigenspace", "params": {"block_size": 16}})
    assert det.block_size == 16 and det.to_config()["type"] == "eigenspace"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = check_component(cls, host=host)
    status = {r.check: r.status for r in results}
    assert all(s == "pass" for c, s in status.items() if c != "different_seeds_differ"), results
    # training and detection draw nothing from the Generator: the seed check does not apply
    assert status["different_seeds_differ"] == "skip"


# -- the eigenspace likelihood (eq. 12-13) ---------------------------------------------------


def test_likelihood_is_the_log_sigmoid_of_the_block_excess_through_the_camera(tmp_path):
    """Particles in world metres are projected through the run's camera to their block;
    log f = log sigmoid(alpha (r_D - v_D)) of that block; behind the camera or outside the
    image: -inf, never NaN; only the touched blocks are scored."""
    from pftrack.geometry.camera import Camera
    from pftrack_coast.likelihood import EigenspaceLikelihood

    rng = np.random.default_rng(0)
    base = np.linspace(40.0, 90.0, 160)[None, :] + np.zeros((120, 1))
    train = [base + rng.normal(0.0, 3.0, base.shape) for _ in range(30)]
    model = BlockEigenspaceModel(block_size=8).fit(train)
    path = model.save(tmp_path / "m.npz")
    test = base + rng.normal(0.0, 3.0, base.shape)
    test[40:56, 80:96] = 250.0  # an intruder covering blocks (5..6, 10..11)
    cam = Camera.look_at((0.0, -10.0, 6.0), (0.0, 0.0, 0.0), (160, 120), fx=120.0)
    lik = EigenspaceLikelihood(model=str(path), alpha=0.5)
    lik.setup(RunContext(camera=cam))
    lik.prepare()
    frame = Frame(1, test.astype(np.uint8)[:, :, None].repeat(3, axis=2))
    lik.begin_frame(frame, [])
    # particles: two on the intruder's pixels, one on water, one behind, one off the image
    targets_px = np.array([[84.0, 44.0], [90.0, 50.0], [20.0, 100.0]])
    ground = cam.image_to_ground(targets_px)
    pts = np.vstack([ground, [[0.0, -20.0, 0.0], [500.0, 40.0, 0.0]]])
    t = Target(id=1, state=np.zeros(6), box_xywh_px=np.zeros(4),
               particles=np.column_stack([pts, np.zeros((5, 3))]))
    ll = lik.log_likelihood(np.zeros((5, 4)), t)
    assert ll.dtype == np.float64 and not np.isnan(ll).any()
    assert ll[3] == -np.inf and ll[4] == -np.inf
    res = model.score(frame.image)
    for k, (x, y) in enumerate(targets_px):
        r, c = int(y // 8), int(x // 8)
        z = 0.5 * res.excess_map[r, c]
        assert np.isclose(ll[k], -np.log1p(np.exp(-z)), rtol=1e-12, atol=1e-12)
    assert ll[0] > np.log(0.99) and ll[1] > np.log(0.99) and ll[2] < np.log(0.01)
    assert np.count_nonzero(~np.isnan(lik.excess_)) == 3  # only the touched blocks scored
    # without a camera: each particle's box centre pixel
    plain = EigenspaceLikelihood(model=str(path), alpha=0.5)
    plain.begin_frame(frame, [])
    boxes = np.array([[80.0, 40.0, 8.0, 8.0], [16.0, 96.0, 8.0, 8.0]])
    out = plain.log_likelihood(boxes, Target(id=2, state=np.zeros(2), box_xywh_px=np.zeros(4)))
    assert np.isclose(out[0], -np.log1p(np.exp(-0.5 * res.excess_map[5, 10])))
    assert out[1] < np.log(0.01)
    with pytest.raises(ValueError, match="no model"):
        EigenspaceLikelihood().prepare()


def test_likelihood_prefers_the_boat_on_real_infrared_water():
    from pftrack_coast.likelihood import EigenspaceLikelihood

    frames, gt = _water("zodiac", 50)
    m = fit_quiet(BlockEigenspaceModel(), frames[:25], gt[:25])
    lik = EigenspaceLikelihood().set_model(m)
    on, off = [], []
    for img, mask in zip(frames[25:], gt[25:]):
        lik.begin_frame(Frame(1, img), [])
        ys, xs = np.nonzero(mask)
        fg = np.column_stack([xs, ys])[:: max(len(xs) // 50, 1)].astype(float)
        bg = np.random.default_rng(0).uniform([0, 0], [300, 220], (200, 2))
        bg = bg[~mask[bg[:, 1].astype(int), bg[:, 0].astype(int)]]
        tgt = Target(id=1, state=np.zeros(2), box_xywh_px=np.zeros(4))
        on.append(lik.log_likelihood(np.column_stack([fg - 0.5, np.ones((len(fg), 2))]), tgt))
        off.append(lik.log_likelihood(np.column_stack([bg - 0.5, np.ones((len(bg), 2))]), tgt))
    f_on, f_off = np.exp(np.concatenate(on)), np.exp(np.concatenate(off))
    # measured: mean f 0.446 on 1976 sampled boat pixels, 0.0008 on 4999 water pixels
    # (frames 26-50; alpha 1, the paper's v_D)
    assert f_on.mean() > 0.35 and f_off.mean() < 0.005


def test_background_benchmark_on_water_and_thermal(capsys):
    """``pftrack bench background`` on the infrared sea and the thermal clip (PETS is left to
    the full benchmark): its rows, the eigenspace model against MOG2, the thermal goals (more
    in test_coast_thermal.py)."""
    import json

    from pftrack.cli import main

    if not (WATER / "zodiac").is_dir() or not (DATA / "thermal" / "animal_entry.cptv").is_file():
        pytest.skip("shared data not found")
    pytest.importorskip("cptv")
    import cv2

    # an OpenCV contrib subtractor (8-bit images only) runs on the sea, not on the thermal clip
    contrib = ["cnt"] if hasattr(getattr(cv2, "bgsegm", None), "createBackgroundSubtractorCNT") \
        else []
    assert main(["bench", "background", "--sequences", "zodiac,thermal", "--methods",
                 ",".join(["eigenspace", "mog2", *contrib]), "--thermal-recalibration", "none",
                 "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    rows = {(r["sequence"], r["method"], r["level"]): r for r in out["rows"]}
    assert set(rows) == {("zodiac", m, lv) for m in ("eigenspace", "mog2", *contrib)
                         for lv in ("pixel", "block")}
    assert set(out["thermal"]["skipped_methods"]) == set(contrib)
    eig, mog = rows["zodiac", "eigenspace", "block"], rows["zodiac", "mog2", "block"]
    # measured: eigenspace block F 0.552 (untrained blocks ignored), MOG2 0.124 (frames 26-50)
    assert eig["f_measure"] > 0.5 and eig["f_measure"] > 2 * mog["f_measure"]
    assert all(0 <= r["pwc"] <= 100 and r["frames"] == 25 for r in rows.values())
    # the animal is in view from frame 1: measured first detection at 1 (eigenspace; MOG2 at
    # 23: it learns the resting animal from the training frames), the empty frame 0 clear
    t = {r["method"]: r for r in out["thermal"]["runs"]}
    assert set(t) == {"eigenspace", "mog2"}
    assert t["eigenspace"]["first_detection_frame"] == 1
    assert t["eigenspace"]["false_alarm_frames"] == 0 and t["eigenspace"]["empty_frames"] == 1
    assert t["mog2"]["recall"] < t["eigenspace"]["recall"]
