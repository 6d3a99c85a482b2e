"""The volume tracker's compiled paths (the coastal paper's speed): each gives the numpy path's
numbers, and the whole run's tracks do not change; the benchmark's speed figure in the goal's
configuration (3 groups of 5000 particles)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from pftrack.geometry import camera as camera_module
from pftrack_bench.coast import speed_3x5000, speed_runs
from pftrack_coast import likelihood as likelihood_module
from pftrack_coast import volume_book as volume_book_module
from pftrack_coast._kernels import blocks_of_pixels
from pftrack_coast.volume_geometry import _quantiles

from tests.plugins.coast.test_coast_volumes import _run


def _no_kernels(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every coastal-paper kernel off: the numpy paths (as PFTRACK_NO_JIT=1)."""
    monkeypatch.setattr(volume_book_module, "_kernel", lambda name: None)
    monkeypatch.setattr(camera_module, "_ROWS_KERNEL", [None])
    monkeypatch.setenv("PFTRACK_NO_JIT", "1")
    from pftrack.filter import _jit

    monkeypatch.setattr(_jit, "ENABLED", False)


def test_volume_run_with_and_without_the_compiled_paths_gives_the_same_tracks(monkeypatch):
    """Two people walking through a volume (perfect foreground): records, estimates and
    events of the compiled run equal the numpy run's, bit for bit."""
    engine, tracks, rows, *_ = _run(seed=5, n_frames=45)
    assert len(rows) > 40 and len(np.unique(rows[:, 1])) >= 2  # people were tracked
    _no_kernels(monkeypatch)
    engine2, tracks2, rows2, *_ = _run(seed=5, n_frames=45)
    assert rows.tobytes() == rows2.tobytes()
    assert tracks.events_ == tracks2.events_
    for a, b in zip(tracks.estimates_, tracks2.estimates_, strict=True):
        assert a.keys() == b.keys()
        for k in a:
            assert np.asarray(a[k]).tobytes() == np.asarray(b[k]).tobytes(), k


def test_region_kernel_equals_the_numpy_region(monkeypatch):
    """A detection group's region (off the tracked people's boxes and gates) and a track's
    gate, on particles in and out of the volume and NaN pixels: the same masks."""
    engine, tracks, *_ = _run(seed=2, n_frames=30)
    assert tracks.boxes_ and tracks.gates_
    vol = next(iter(tracks.volumes_.values()))
    rng = np.random.default_rng(0)
    pts = np.concatenate([vol.sample(3000, rng), rng.normal(0.0, 20.0, (1000, 3))])
    gid, tid = next(iter(tracks.groups_)), next(iter(tracks.tracks_))
    fast = [tracks.book_.in_region(i, vol, m, pts) for i, m in ((gid, "exclude"), (tid, "gate"))]
    monkeypatch.setattr(volume_book_module, "_kernel", lambda name: None)
    slow = [tracks.book_.in_region(i, vol, m, pts) for i, m in ((gid, "exclude"), (tid, "gate"))]
    for a, b in zip(fast, slow):
        assert a.dtype == b.dtype == bool and np.array_equal(a, b)
    assert 0 < fast[0].sum() < 3000 and 0 < fast[1].sum() < 100  # both masks do something


def test_block_lookup_kernel_equals_numpy(monkeypatch):
    rng = np.random.default_rng(1)
    px = rng.uniform(-30.0, 800.0, (5000, 2))
    px[:10] = np.nan
    px[10:20] = [[-0.0, 0.0], [767.999, 575.999], [768.0, 0.0], [-1e-12, 5.0], [np.inf, 3.0],
                 [8.0, 8.0], [7.999999, 8.0], [0.0, -np.inf], [1e300, 1e300], [64.0, 575.0]]
    ok, idx = likelihood_module._blocks_of_pixels(px, 8, (72, 96))
    from pftrack.filter import _jit

    monkeypatch.setattr(_jit, "ENABLED", False)
    ok2, idx2 = likelihood_module._blocks_of_pixels(px, 8, (72, 96))
    assert np.array_equal(ok, ok2) and idx.dtype == idx2.dtype and np.array_equal(idx, idx2)
    assert 0 < ok.sum() < len(px)
    o, i = np.empty(2, dtype=bool), np.empty(2, dtype=np.intp)
    assert blocks_of_pixels(np.array([[9.0, 17.0], [np.nan, 1.0]]), 8.0, 72, 96, o, i) == 1
    assert o.tolist() == [True, False] and i[0] == 2 * 96 + 1


def test_quantiles_equal_numpy_quantile():
    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 50, 5000):
        for q in (0.0, 0.02, 0.25, 0.5, 0.7, 1.0):
            x = rng.normal(0.0, 200.0, (n, 2))
            if n > 3:
                x[: n // 3] = np.round(x[: n // 3])  # ties
            lo, hi = _quantiles(x, q, 1.0 - q)
            ref = np.quantile(x, [q, 1.0 - q], axis=0)
            assert lo.tobytes() == ref[0].tobytes() and hi.tobytes() == ref[1].tobytes()


def test_speed_3x5000_counts_only_frames_with_three_groups_of_5000():
    runs = [{"n_particles": 5000, "frame_cpu_s": np.array([0.5, 0.01, 0.02, 0.01, 0.2]),
             "frame_targets": np.array([0, 3, 3, 3, 4])},
            {"n_particles": 5000, "frame_cpu_s": np.array([0.01, 0.03]),
             "frame_targets": np.array([3, 2])},
            {"n_particles": 400, "frame_cpu_s": np.array([0.001]), "frame_targets": np.array([3])}]
    out = speed_3x5000(runs)
    assert out["frames_3x5000"] == 4
    assert out["frames_per_second_3x5000"] == pytest.approx(4 / 0.05)
    assert speed_3x5000(runs[2:]) == {"frames_per_second_3x5000": None, "frames_3x5000": 0}


def test_speed_runs_takes_the_best_of_identical_runs_and_refuses_different_tracks():
    """``speed_runs``: the best of n runs' figure, each listed; a repeat whose rows differ
    (tracking not deterministic for its seed) raises."""
    rows = np.arange(20.0).reshape(2, 10)

    def run(cpu: float, r: np.ndarray = rows) -> dict:
        return {"n_particles": 5000, "frame_cpu_s": np.array([cpu, cpu]),
                "frame_targets": np.array([3, 3]), "rows": r}

    again = iter([[run(0.01)], [run(0.04)]])
    out = speed_runs([run(0.02)], lambda: next(again), 3)
    assert out["frames_per_second_3x5000_runs"] == pytest.approx([50.0, 100.0, 25.0])
    assert out["frames_per_second_3x5000"] == pytest.approx(100.0)
    assert out["frames_3x5000"] == 2
    assert speed_runs([run(0.02)], lambda: 1 / 0, 1)["frames_per_second_3x5000"] == \
        pytest.approx(50.0)  # one run: none made again
    moved = rows.copy()
    moved[1, 3] += 1e-9
    with pytest.raises(RuntimeError, match="not deterministic"):
        speed_runs([run(0.02)], lambda: [run(0.01, moved)], 2)


def _small_scene(rng: np.random.Generator) -> tuple[Any, np.ndarray]:
    """A block eigenspace model (8-px blocks) fitted on 12 noisy 96x64 ramps drawn from
    ``rng``, and the first of them with a bright intruder (rows 20-40, columns 30-60)."""
    from pftrack_coast.eigenspace import BlockEigenspaceModel

    base = np.linspace(40.0, 200.0, 96)[None, :, None] + np.zeros((64, 96, 3))
    frames = [np.clip(base + rng.normal(0, 5, base.shape), 0, 255).astype(np.uint8)
              for _ in range(12)]
    model = BlockEigenspaceModel(block_size=8).fit(frames)
    img = frames[0].copy()
    img[20:40, 30:60] = 250  # an intruder
    return model, img


def test_block_scores_from_the_integer_grey_and_the_compiled_gather_equal_numpy(monkeypatch):
    """relative_variation_at on OpenCV's integer grey levels (compiled gather) gives the
    numbers of the float64 frame through numpy's gather; the likelihood's values do not
    depend on which path scored the blocks."""
    import cv2
    from pftrack.contracts.components import Frame
    from pftrack.filter import _jit
    from pftrack_coast.likelihood import EigenspaceLikelihood

    rng = np.random.default_rng(4)
    model, img = _small_scene(rng)
    raw = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    blocks = np.array([0, 5, 13, 30, 50, 95])
    fast = model.relative_variation_at(raw, blocks)
    assert fast.tobytes() == model.relative_variation_at(model.grey(img), blocks).tobytes()
    like = EigenspaceLikelihood().set_model(model)
    like.prepare()
    px = np.column_stack([rng.uniform(0, 96, 3000), rng.uniform(0, 64, 3000)])
    boxes = np.column_stack([px, np.zeros((3000, 2))])
    like.begin_frame(Frame(1, img), [])
    a = like.log_likelihood(boxes, None)
    monkeypatch.setattr(_jit, "ENABLED", False)
    slow = model.relative_variation_at(model.grey(img), blocks)
    assert fast.tobytes() == slow.tobytes()
    like.begin_frame(Frame(1, img), [])
    assert a.tobytes() == like.log_likelihood(boxes, None).tobytes()
    assert np.isfinite(a).any() and (a > np.log(0.5)).any() and (a < np.log(0.5)).any()


def test_eigenspace_rows_equal_the_per_target_calls_bit_for_bit(monkeypatch):
    """log_likelihood_rows scores every group in one lookup: each row equals what successive
    log_likelihood calls give, also when a later row scores the whole frame after an earlier
    row scored a few blocks by gathering (the blocks are scored row by row, in order)."""
    from pftrack.contracts.components import Frame, Target
    from pftrack.filter import _jit
    from pftrack_coast.likelihood import EigenspaceLikelihood

    rng = np.random.default_rng(7)
    model, img = _small_scene(rng)
    n = 3000
    # row 0: a few blocks (gathered); row 1: the whole grid (the frame at once); row 2: some
    # pixels outside the image and NaN (behind the camera)
    px = np.stack([
        np.column_stack([rng.uniform(28, 44, n), rng.uniform(18, 30, n)]),
        np.column_stack([rng.uniform(0, 96, n), rng.uniform(0, 64, n)]),
        np.column_stack([rng.uniform(-20, 120, n), rng.uniform(10, 50, n)]),
    ])
    px[2, :50] = np.nan
    for jit in (True, False):
        monkeypatch.setattr(_jit, "ENABLED", jit)
        for alpha in (1.0, 0.5):
            like = EigenspaceLikelihood(alpha=alpha).set_model(model)
            assert like.offers_rows()
            boxes = np.concatenate([px, np.zeros((3, n, 2))], axis=2)  # (T, N, 4) points
            targets = []
            for b in boxes:  # the engine's rows: each target's boxes view the stacked array
                t = Target(id=len(targets) + 1, state=np.zeros(6), box_xywh_px=np.zeros(4))
                t.particle_boxes_xywh_px = b
                targets.append(t)
            like.begin_frame(Frame(1, img), targets)
            one = [like.log_likelihood(t.particle_boxes_xywh_px, t) for t in targets]
            excess_one = like.excess_.copy()
            like.begin_frame(Frame(1, img), targets)
            rows = like.log_likelihood_rows(boxes, targets)
            assert rows.shape == (3, n) and rows.dtype == np.float64
            assert rows.tobytes() == np.array(one).tobytes()
            assert like.excess_.tobytes() == excess_one.tobytes()
            assert np.isneginf(rows[2, :50]).all() and np.isfinite(rows[0]).all()
            assert (rows[1] > np.log(0.5)).any() and (rows[1] < np.log(0.5)).any()
            # the order matters: row 0 alone gathers its blocks, which the whole-frame pass
            # of row 1 would have scored otherwise (a different path, the same blocks)
            like.begin_frame(Frame(1, img), targets)
            like.log_likelihood_rows(boxes[:1], targets[:1])
            assert np.isnan(like.excess_).sum() > 0.5 * len(like.excess_)
            # boxes that are not the targets' own: the per-target path (projected again)
            copy = boxes.copy()
            like.begin_frame(Frame(1, img), targets)
            assert like.log_likelihood_rows(copy, targets).tobytes() == rows.tobytes()
