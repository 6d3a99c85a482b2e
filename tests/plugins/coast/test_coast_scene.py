"""The ``coast`` scene (the coastal paper's coast, :mod:`pftrack_coast.scene`): frame format,
seeding, ground truth against the rendered pixels and the volumes, and what the block eigenspace
model (against OpenCV's MOG2) sees in it.

``python tests/test_coast_scene.py`` prints the figures (render time, block precision/recall).
"""

from __future__ import annotations

import time
import warnings

import cv2
import numpy as np
import pytest
from pftrack.contracts.components import Frame
from pftrack.geometry.volumes import coast_volumes
from pftrack_coast.eigenspace import BlockEigenspaceModel
from pftrack_coast.scene import CoastScene

BS = 8  # eigenspace block size, pixels at 768 x 576
# Rows 232..352 (block rows 29..43): the far volume's sea (y 145..455 m lies in rows ~235..290)
# and the near volume's land. Blocks are modelled independently (PCA per block; every block is
# trained on background-only frames), so a model fitted on this block-aligned band gives the
# same r_D as the full-frame model for these blocks, at a quarter of the cost.
BAND = (232, 352)


def test_registered_and_frame_format():
    from pftrack.host import get_host

    assert get_host().get("scene", "coast") is CoastScene
    sc = CoastScene(clip="boat", n_frames=3)
    frames = list(sc.frames())
    assert [f.index for f in frames] == [1, 2, 3]
    assert all(isinstance(f, Frame) for f in frames)
    img = frames[0].image
    assert img.shape == (576, 768, 3) and img.dtype == np.uint8
    assert np.array_equal(img[..., 0], img[..., 1]) and np.array_equal(img[..., 0], img[..., 2])
    assert frames[1].time_s == pytest.approx(1 / sc.fps)
    assert sc.fps == 5.0 and sc.clip_frames == 3
    assert CoastScene(clip="multi").clip_frames == 200


def test_same_seed_same_frames_other_seed_differs():
    a = [f.image for f in CoastScene(seed=3, clip="multi", n_frames=4).frames()]
    b = [f.image for f in CoastScene(seed=3, clip="multi", n_frames=4).frames()]
    c = [f.image for f in CoastScene(seed=4, clip="multi", n_frames=4).frames()]
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not np.array_equal(a[0], c[0])
    sc = CoastScene(seed=3, clip="multi", n_frames=4)
    assert np.array_equal(sc.render(2), a[2])  # random access = streaming
    t1 = [f.image for f in CoastScene(n_training=6).training_frames()]
    t2 = [f.image for f in CoastScene(n_training=6).training_frames(3)]
    assert len(t1) == 6 and len(t2) == 3
    assert all(np.array_equal(x, y) for x, y in zip(t1, t2))
    # the training frames as a clip, streamed or random-access
    tc = CoastScene(clip="training", n_training=6, n_frames=4)
    assert tc.clip_frames == 4 and len(tc.ground_truth()) == 0
    assert all(np.array_equal(f.image, x) for f, x in zip(tc.frames(), t1))
    assert np.array_equal(tc.render(5), t1[5])
    # the frames differ from one another (moving sea, sparkles, noise)
    assert not np.array_equal(t1[0], t1[1]) and not np.array_equal(a[0], a[1])


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match=r"'clip' must be one of .*got 'ferry'"):
        CoastScene(clip="ferry").prepare()
    with pytest.raises(ValueError, match="fps"):
        CoastScene(fps=0).prepare()


def test_sky_sea_land_layout_and_thermal_order():
    """Sky on top (cool), sea in the middle band, land below (warm); the near volume on land,
    the far one on sea."""
    sc = CoastScene(clip="empty", n_frames=1, noise_std=0.0)
    img = sc.render(0)[..., 0].astype(float)
    cam = sc.camera_
    horizon_v = cam.project(np.array([[0.0, 1e6, 0.0]]))[0, 1]
    assert 200 < horizon_v < 216
    sky = img[: int(horizon_v) - 30].mean()
    sea_v = cam.project(np.array([[0.0, 300.0, 0.0]]))[0, 1]
    sea = img[int(sea_v) - 4: int(sea_v) + 4].mean()
    land_v = cam.project(np.array([[-20.0, 100.0, 0.0]]))[0, 1]
    land = img[int(land_v) - 4: int(land_v) + 4, :300].mean()
    assert sky < sea < land
    # the water line lies between the volumes for every frame of every clip
    for clip in ("boat", "car", "multi"):
        s = CoastScene(clip=clip)
        s.prepare()
        tides = [c.tide_m for c in s.clip_conditions_]
        shore = s.shore0_[s.ground_]
        assert shore.min() + min(tides) > 112.0 and shore.max() + max(tides) < 142.0


@pytest.mark.parametrize("clip", ["boat", "car", "multi"])
def test_ground_truth_matches_objects_and_volumes(clip):
    sc = CoastScene(clip=clip)
    gt = sc.ground_truth()
    objs = sc.objects()
    assert gt.shape[1] == 10 and np.all(gt[:, 6] == 1) and np.all(gt[:, 9] == 0)
    assert set(gt[:, 1].astype(int)) == {o.id for o in objs}
    vols = coast_volumes()
    for o in objs:
        rows = gt[gt[:, 1] == o.id]
        k = rows[:, 0].astype(int) - 1
        assert np.allclose(rows[:, 7:9], o.centres_m[k, :2])
        # sizes as the issue gives them (w across x, h, d along y) and the support plane
        want = (7.5, 1.8, 2.3) if o.kind == "boat" else (1.7, 1.5, 4.7)
        assert tuple(o.size_m) == want
        assert np.allclose(o.centres_m[:, 2], o.size_m[1] / 2, atol=0.1)
        inside = vols[o.volume].contains(o.centres_m)
        first, last = o.first_inside, o.last_inside
        assert first is not None and inside[first - 1] and inside[last - 1]
        assert not inside[: first - 1].any() and not inside[last:].any()
        assert inside[first - 1: last].all()
        assert first > 1  # enters the volume during the clip
        assert sc.volume_events()[o.id] == (first, last, o.volume)
        # the object is seen entering: its box is in the image before it enters
        assert (k < first - 1).any()
    # boats on the sea in the far volume, the car on land in the near volume
    for o in objs:
        assert o.volume == ("far" if o.kind == "boat" else "near")
    if clip != "multi":
        assert all(o.last_inside < sc.clip_frames for o in objs)  # leaves during the clip


@pytest.mark.parametrize("clip", ["boat", "car", "multi"])
def test_boxes_contain_the_rendered_object(clip):
    """The projected cuboid's box holds every pixel the object changed, and most of the box is
    changed (the silhouette fills it); checked on frames across the clip."""
    sc = CoastScene(clip=clip)
    gt = sc.ground_truth()
    for k in range(0, sc.clip_frames, 23):
        with_ = sc.render(k).astype(np.int16)[..., 0]
        without = sc.render(k, with_objects=False).astype(np.int16)[..., 0]
        changed = np.abs(with_ - without) > 3
        rows = gt[gt[:, 0] == k + 1]
        allowed = np.zeros_like(changed)
        for r in rows:
            left, t, w, h = r[2:6]
            # 1.5 px: the bilinear 2x upscale spreads an edge over one output pixel
            allowed[max(int(np.floor(t - 1.5)), 0): int(np.ceil(t + h + 1.5)) + 1,
                    max(int(np.floor(left - 1.5)), 0): int(np.ceil(left + w + 1.5)) + 1] = True
            # inside the image and mostly filled
            inner = changed[int(np.ceil(t + 1)): int(np.floor(t + h - 1)) + 1,
                            int(np.ceil(left + 1)): int(np.floor(left + w - 1)) + 1]
            if inner.size and left > 0 and left + w < 767:
                assert inner.mean() > 0.8, (clip, k, r[1], inner.mean())
        assert not (changed & ~allowed).any(), (clip, k)
        if len(rows):
            assert changed.any()


# --------------------------------------------------------------------------------------------
# What background models see
# --------------------------------------------------------------------------------------------


def _object_blocks(rows: np.ndarray, grid: tuple[int, int], min_cover: float = 0.25):
    """(object blocks: >= min_cover of the block inside a box, near blocks: touching a box
    grown by one block) as (rows, cols) bool grids."""
    obj = np.zeros(grid, bool)
    near = np.zeros(grid, bool)
    ys = np.arange(grid[0]) * BS
    xs = np.arange(grid[1]) * BS
    for r in rows:
        left, t, w, h = r[2:6]
        ox = np.clip(np.minimum(xs + BS, left + w) - np.maximum(xs, left), 0, None)
        oy = np.clip(np.minimum(ys + BS, t + h) - np.maximum(ys, t), 0, None)
        obj |= (oy[:, None] * ox[None, :]) >= min_cover * BS * BS
        gx = (xs + BS > left - BS) & (xs < left + w + BS)
        gy = (ys + BS > t - BS) & (ys < t + h + BS)
        near |= gy[:, None] & gx[None, :]
    return obj, near


def _region_blocks(sc: CoastScene, band: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(sea blocks: centre on the sea plane beyond 145 m, land blocks: before 110 m) of the
    image rows ``band``."""
    rows, cols = (band[1] - band[0]) // BS, 768 // BS
    v, u = np.mgrid[0:rows, 0:cols]
    px = np.stack([u.ravel() * BS + BS / 2 - 0.5,
                   band[0] + v.ravel() * BS + BS / 2 - 0.5], axis=1)
    g = sc.camera_.image_to_ground(px)
    y = g[:, 1].reshape(rows, cols)
    return np.nan_to_num(y, nan=-1) > 145.0, (np.nan_to_num(y, nan=1e9) < 110.0) & (y > 0)


def block_figures(model: BlockEigenspaceModel, sc: CoastScene, mog2_training=None,
                  step: int = 1, band: tuple[int, int] = (0, 576)) -> dict[str, dict[str, float]]:
    """Per-block recall / precision of the object blocks and false alarms on sea and land, for
    the eigenspace model (r_D > v_D) and for MOG2 (a block is foreground when > 25 % of its
    pixels are), over the clip frames where an object is in view, on the image rows ``band``
    (the model and the MOG2 training frames must be of that band).

    recall: flagged object blocks (>= 25 % inside a ground-truth box) / object blocks;
    recall_50: the same for blocks >= 50 % inside a box; frames_seen: fraction of the frames
    with object blocks in which a block touching a box is flagged;
    precision: flagged blocks touching a box grown by one block / flagged blocks;
    false_alarm_sea / _land: flagged / all blocks on the sea beyond 145 m (land before 110 m)
    away from the boxes; mog2 ``px_sea``: MOG2's mean foreground pixel fraction there."""
    gt = sc.ground_truth().copy()
    gt[:, 3] -= band[0]
    sea, land = _region_blocks(sc, band)
    h = band[1] - band[0]
    mog = None
    if mog2_training is not None:
        mog = cv2.createBackgroundSubtractorMOG2(history=500, detectShadows=False)
        for img in mog2_training:
            mog.apply(img)
    acc = {m: {"tp": 0, "obj": 0, "tp50": 0, "obj50": 0, "seen": 0, "frames": 0, "flag": 0,
               "flag_near": 0, "fa_sea": 0, "fa_land": 0, "n_sea": 0, "n_land": 0, "px_sea": 0.0}
           for m in ("eigenspace", "mog2")}
    for k in range(sc.clip_frames):
        img = sc.render(k)[band[0]:band[1]]
        fg = mog.apply(img) if mog is not None else None
        if k % step:
            continue
        rows = gt[gt[:, 0] == k + 1]
        res = model.score(img)
        obj, near = _object_blocks(rows, res.intruder_mask.shape)
        obj50, _ = _object_blocks(rows, res.intruder_mask.shape, 0.5)
        maps = {"eigenspace": res.intruder_mask}
        if fg is not None:
            frac = (fg > 0).reshape(h // BS, BS, 768 // BS, BS).mean(axis=(1, 3))
            maps["mog2"] = frac > 0.25
            far_sea = np.kron(sea & ~near, np.ones((BS, BS), bool))
            acc["mog2"]["px_sea"] += float((fg > 0)[far_sea].mean())
            acc["mog2"]["n_px"] = acc["mog2"].get("n_px", 0) + 1
        if not len(rows):
            continue
        for m, flag in maps.items():
            a = acc[m]
            a["tp"] += int((flag & obj).sum())
            a["obj"] += int(obj.sum())
            a["tp50"] += int((flag & obj50).sum())
            a["obj50"] += int(obj50.sum())
            if obj.any():  # object frames: one of its blocks flagged (all objects' blocks)
                a["frames"] += 1
                a["seen"] += int((flag & near).any())
            a["flag"] += int(flag.sum())
            a["flag_near"] += int((flag & near).sum())
            a["fa_sea"] += int((flag & sea & ~near).sum())
            a["n_sea"] += int((sea & ~near).sum())
            a["fa_land"] += int((flag & land & ~near).sum())
            a["n_land"] += int((land & ~near).sum())
    out = {}
    for m, a in acc.items():
        if not a["obj"]:
            continue
        out[m] = {"recall": a["tp"] / a["obj"], "recall_50": a["tp50"] / max(a["obj50"], 1),
                  "frames_seen": a["seen"] / max(a["frames"], 1),
                  "precision": a["flag_near"] / max(a["flag"], 1),
                  "false_alarm_sea": a["fa_sea"] / max(a["n_sea"], 1),
                  "false_alarm_land": a["fa_land"] / max(a["n_land"], 1)}
        if a.get("n_px"):
            out[m]["px_sea"] = a["px_sea"] / a["n_px"]
    return out


@pytest.fixture(scope="module")
def fitted():
    sc = CoastScene()
    training = [f.image[BAND[0]:BAND[1]] for f in sc.training_frames()]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = BlockEigenspaceModel(block_size=BS).fit(training)
    return model, training


def test_training_frames_are_background_and_varied(fitted):
    model, training = fitted
    assert len(training) == 400
    means = np.array([t[::8, ::8, 0].mean() for t in training])
    assert np.ptp(means) > 8.0  # exposure and temperatures vary between and within days
    conds = CoastScene().prepare().training_conditions_
    tide = np.array([c.tide_m for c in conds])
    sea = np.array([c.sea_state for c in conds])
    glint = np.array([c.glint for c in conds])
    assert tide.min() < -3 and tide.max() > 3
    assert np.ptp(sea) > 0.4 and np.ptp(glint) > 0.4
    # the model, scored on its own training frames, flags few blocks
    flagged = np.mean([model.score(t).intruder_mask.mean() for t in training[::40]])
    assert flagged < 0.02


@pytest.mark.parametrize("clip", ["boat", "car"])
def test_eigenspace_sees_the_object_and_mostly_not_the_sea(fitted, clip):
    model, training = fitted
    fig = block_figures(model, CoastScene(clip=clip), mog2_training=training[-100:], step=3,
                        band=BAND)
    e, m = fig["eigenspace"], fig["mog2"]
    # measured (seed 3, every frame): boat recall 0.65, recall_50 0.74, seen in 80 % of the
    # frames, precision 0.80; car 0.74, 0.88, 94 %, 0.89 -- the thresholds leave a margin
    assert e["recall"] > 0.55 and e["recall_50"] > 0.65, fig
    assert e["frames_seen"] > 0.7, fig
    assert e["precision"] > 0.7, fig
    assert e["false_alarm_sea"] < 0.01 and e["false_alarm_land"] < 0.01, fig
    # the sea does give MOG2 false alarms: it finds the object, and the waves and glints
    assert m["recall"] > 0.9 and m["px_sea"] > 0.002, fig
    assert m["precision"] < 0.5 * e["precision"], fig


if __name__ == "__main__":  # the figures of the note
    sc = CoastScene(clip="multi")
    sc.prepare()
    t = time.perf_counter()
    for k in range(100):
        sc.render(k)
    print(f"render: {(time.perf_counter() - t) * 10:.2f} ms/frame (multi clip, 100 frames)")
    import sys

    band = BAND if "--full" not in sys.argv else (0, 576)
    t = time.perf_counter()
    training = [f.image[band[0]:band[1]] for f in CoastScene().training_frames()]
    print(f"400 training frames: {time.perf_counter() - t:.1f} s")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = time.perf_counter()
        model = BlockEigenspaceModel(block_size=BS).fit(training)
        print(f"eigenspace fit: {time.perf_counter() - t:.1f} s")
    for clip in ("boat", "car", "multi"):
        s = CoastScene(clip=clip)
        print(clip, {o.id: (o.kind, o.first_inside, o.last_inside) for o in s.objects()})
        fig = block_figures(model, s, mog2_training=training[-100:], band=band)
        for m, f in fig.items():
            print(f"  {m:10s} " + " ".join(f"{k}={v:.3f}" for k, v in f.items()))
