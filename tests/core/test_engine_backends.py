"""The engine's two backends give the same records: the reference (one target at a time) and the
rows backend (every target's particles as one array), on presets and component mixes that
exercise births, deaths, detections, valid regions and composite likelihoods.

"The same" is bit for bit: every field of every output record, and the random generator's
state after the run (so the draws and their order agree too)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from pftrack.contracts.components import Detections
from pftrack.engine.tracker import MultiTargetTracker, records_to_mot

from tests.core.test_tracker import _record_bytes

DATA = Path(os.environ.get("PFTRACK_DATA", Path(__file__).resolve().parents[3] / "shared"
                           / "data"))
PETS = DATA / "pets09"
needs_pets = pytest.mark.skipif(not (PETS / "vtest.avi").exists(),
                                reason="PETS 2009 data not found ($PFTRACK_DATA)")


def _run(engine: MultiTargetTracker, backend: str, frames, detections=None, starts=None):
    """Every frame's output records and the generator's next number, on ``backend``; the
    backend the engine chose by itself."""
    chosen = engine.uses_rows()
    engine.backend = backend
    recs = []
    for k, frame in enumerate(frames):
        if starts is not None and k == 0:
            for tid, pos in starts.items():
                engine.add_target(frame, pos, target_id=tid)
            continue
        dets = None if detections is None else detections.get(frame.index, Detections.empty())
        recs.extend(engine.step(frame, dets))
    return _record_bytes(recs), engine.rng.random(), engine.recoveries, chosen


def _pets_detections(tmp_path, camera=None):
    """PETS ground-truth boxes of frames 401-440 as detections, one in five dropped (misses),
    scores 0.85."""
    from pftrack.io.detections import read_detections

    gt = np.loadtxt(PETS / "gt.txt", delimiter=",")
    gt = gt[(gt[:, 0] >= 401) & (gt[:, 0] <= 440)]
    gt = gt[(gt[:, 0] + gt[:, 1]) % 5 != 0]
    rows = np.column_stack([gt[:, 0], -np.ones(len(gt)), gt[:, 2:6], np.full(len(gt), 0.85)])
    path = tmp_path / "det.txt"
    np.savetxt(path, rows, delimiter=",", fmt="%.3f")
    return read_detections(path, camera=camera)


def _pets_frames():
    from pftrack.workflows.pipeline import iter_frames

    return list(iter_frames(PETS / "vtest.avi", 401, 440))


@needs_pets
@pytest.mark.parametrize("preset", ["people-image", "people-colour", "pets09-ground"])
def test_presets_on_pets_give_the_same_records_on_both_backends(tmp_path, preset):
    """Detections given (ground truth with misses), the preset's own associator, track
    management (births, confirmation, merging), detection proposal and composite likelihood;
    pets09-ground adds the camera, the ground-plane state, the EMD and NCC terms weighted by
    beta, the exclusion prior and the valid region."""
    from pftrack.geometry.formats import load_camera
    from pftrack.workflows.pipeline import build_engine, load_config

    camera = load_camera(PETS / "View_001.xml") if preset == "pets09-ground" else None
    dets = _pets_detections(tmp_path, camera)
    frames = _pets_frames()
    cfg = load_config(preset)
    ref = _run(build_engine(cfg, camera=camera, fps=7.0, seed=3), "reference", frames, dets)
    rows = _run(build_engine(cfg, camera=camera, fps=7.0, seed=3), "rows", frames, dets)
    assert rows[:3] == ref[:3]
    ids = {r[1] for r in ref[0]}
    assert len(ref[0]) > 80 and len(ids) >= 3  # several people tracked at once
    # the engine's own choice: rows where every component offers its rows (pets09-ground's
    # camera-box observation boxes one target at a time: the reference)
    assert ref[3] is (preset != "pets09-ground")


def _walkers(n_frames=50):
    from pftrack_colour.walkers import WalkersScene

    scene = WalkersScene(seed=0)
    frames = [f for f, _ in zip(scene.frames(), range(n_frames))]
    gt = scene.ground_truth()
    starts = {int(r[1]): r[2:4] + 0.5 * r[4:6] for r in gt[gt[:, 0] == 1]}
    return frames, starts


@pytest.mark.parametrize("mix", ["cross-entropy", "composite", "gaussian-walk"])
def test_the_colour_scene_gives_the_same_records_on_both_backends(mix):
    """The colour paper's synthetic scene (three walkers, crossings), targets started by the
    caller: a colour likelihood alone (rows of its own), a composite of two colour terms (one
    without rows: called per target inside the composite's rows), and the engine's own
    random-walk noise with a compiled kernel."""
    from pftrack.builtin.image_box import ImageBoxObservation
    from pftrack.host import get_host
    from pftrack_basic.motion import ConstantAccelerationMotion, RandomWalkMotion

    host = get_host()
    if mix == "composite":
        lik = host.build("likelihood", {"type": "composite", "params": {"terms": [
            {"likelihood": {"type": "cross-entropy-bg"}, "weight": 1.0},
            {"likelihood": {"type": "cross-entropy", "params": {"method": "histogram"}},
             "weight": 0.5}]}})
    else:
        lik = host.build("likelihood", "cross-entropy")
    frames, starts = _walkers()

    def engine():
        motion = (ConstantAccelerationMotion(position_noise=3.0, velocity_noise=0.5)
                  if mix != "gaussian-walk" else RandomWalkMotion(sigma_px=4.0))
        return MultiTargetTracker(motion, lik.clone(), ImageBoxObservation(30, 30),
                                  n_particles=150, rng=np.random.default_rng(7),
                                  kill_out_of_view=False)

    ref = _run(engine(), "reference", frames, starts=starts)
    rows = _run(engine(), "rows", frames, starts=starts)
    assert rows[:3] == ref[:3]
    assert len(ref[0]) == 3 * (len(frames) - 1)
    assert ref[3] is True


def test_the_default_backend_follows_one_rule():
    """Rows where every per-frame component offers its rows and the filter resamples
    systematically every frame; the reference otherwise; forcing rows on a filter that
    does not resample that way is refused."""
    from pftrack.builtin.image_box import ImageBoxObservation
    from pftrack.contracts.components import MotionModel
    from pftrack.host import get_host
    from pftrack_basic.motion import RandomWalkMotion

    lik = get_host().build("likelihood", "cross-entropy")

    def make(motion=None, **kw):
        return MultiTargetTracker(motion or RandomWalkMotion(3.0), lik,
                                  ImageBoxObservation(10, 10), n_particles=20,
                                  rng=np.random.default_rng(0), **kw)

    class NoRows(MotionModel):
        state_dim = 2

        def predict(self, states, dt, rng, target=None):
            return states + rng.standard_normal(states.shape)

        def init_states(self, position, n, rng, spread=1.0):
            return position + spread * rng.standard_normal((n, 2))

    assert make().uses_rows()
    assert not make(NoRows()).uses_rows()
    assert not make(resampling="stratified").uses_rows()
    assert not make(ess_threshold=0.5).uses_rows()
    assert not make(backend="reference").uses_rows()
    assert make(NoRows(), backend="rows").uses_rows()
    with pytest.raises(ValueError, match="backend 'rows' resamples systematically"):
        make(resampling="residual", backend="rows")
    with pytest.raises(ValueError, match="tracker.backend must be one of"):
        make(backend="fast")


@needs_pets
def test_people_image_rows_are_used_and_equal_the_mot_rows(tmp_path):
    """people-image through the public runner: MOT rows of the rows backend equal the
    reference's (the records above, as written to tracks.txt)."""
    from pftrack.workflows.pipeline import build_engine, load_config

    dets = _pets_detections(tmp_path)
    frames = _pets_frames()[:20]
    out = {}
    for backend in ("reference", "rows"):
        eng = build_engine(load_config("people-image"), fps=7.0, seed=0)
        eng.backend = backend
        recs = [r for f in frames for r in eng.step(f, dets.get(f.index, Detections.empty()))]
        out[backend] = records_to_mot(recs)
    assert len(out["rows"]) > 20
    assert out["rows"].tobytes() == out["reference"].tobytes()
