"""``pftrack bench soccer``: the tracker on the soccer scene, its figures and JSON keys."""

from __future__ import annotations

import json
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest
from pftrack_bench.soccer import (
    KEYS,
    _load_preset,
    score_run,
    scores_markdown,
    track_scene,
    zoom_bounds,
)
from pftrack_world.soccer import SoccerScene


@pytest.fixture(scope="module")
def run():
    scene = SoccerScene(duration_s=2.0, supersample=1)
    return track_scene(scene, "soccer-ground", keep_frames=(1, 50))


def test_tracks_every_player_on_a_short_slice(run) -> None:
    res = score_run(run)
    for k in KEYS:
        assert k in res, k
    assert res["players"] == 22 and res["particles"] == 300 and res["frames"] == 50
    # measured on this slice: MOTA 0.89 (IoU), 0.87 (1 m), accuracy 1.0, median 0.18 m
    assert res["MOTA"] > 0.8
    assert res["IDF1"] > 0.85
    assert res["MOTA_world"] > 0.75
    assert res["accuracy_5px"] > 0.95
    assert res["median_error_m"] < 0.4
    assert res["IDSW"] <= 2
    assert res["detection_s_per_frame"] > 0 and res["tracking_s_per_frame"] > 0
    # every row carries a ground position on the pitch
    rows = run.rows
    assert rows.shape[1] == 10 and len(rows) >= 50 * 20
    assert np.all((rows[:, 7] > -3) & (rows[:, 7] < 108) & (rows[:, 8] > -3) & (rows[:, 8] < 71))
    assert "| 22 x 300 |" in scores_markdown(res)


def test_particle_clouds_follow_the_players(run) -> None:
    cloud = run.clouds[50]
    ids = np.unique(cloud.labels)
    assert len(ids) >= 20
    assert len(cloud) == 300 * len(ids)
    assert np.all(cloud.points_world_m[:, 2] == 0)
    # each target's best particle weighs 1; its cloud sits on its track's estimate
    last = run.rows[run.rows[:, 0] == 50]
    for tid in ids[:5]:
        w = cloud.weights[cloud.labels == tid]
        assert w.max() == pytest.approx(1.0)
        c = np.average(cloud.points_world_m[cloud.labels == tid, :2], axis=0)
        est = last[last[:, 1] == tid, 7:9]
        if len(est):
            assert np.linalg.norm(c - est[0]) < 1.0
    b = zoom_bounds(cloud.points_world_m, 10.0)
    assert b.shape == (2, 2) and np.allclose(b[1] - b[0], 20.0)
    assert 1 in run.images and run.images[50].shape == (720, 1280, 3)


def test_detections_only_start(run) -> None:
    scene = SoccerScene(duration_s=1.2, supersample=1)
    r = track_scene(scene, "soccer-ground", init="detections")
    res = score_run(r)
    # no ground truth used: the background is learned before play, so players are detected in
    # frame 1; a birth is confirmed after 4 matched detections in 5 frames and its records are
    # output from its birth frame on
    assert r.rows[:, 0].min() == 1
    late = r.rows[r.rows[:, 0] == r.rows[:, 0].max()]
    assert len(late) >= 18
    assert res["MOTA"] > 0.5


def test_preset_and_bad_arguments() -> None:
    cfg = _load_preset("soccer-ground")
    assert cfg["state"] == "world" and cfg["tracker"]["n_particles"] == 300
    assert cfg["detector"]["type"] == "pitch-blob"
    with pytest.raises(FileNotFoundError, match="no-such-preset"):
        _load_preset("no-such-preset")
    with pytest.raises(ValueError, match="init"):
        track_scene(SoccerScene(duration_s=0.2), init="hand")
    with pytest.raises(ValueError, match="particles"):
        track_scene(SoccerScene(duration_s=0.2), particles=0)


def test_frames_stream_in_constant_memory() -> None:
    scene = SoccerScene(duration_s=3.0, supersample=1, noise_std=0.0).prepare()
    frames = scene.frames()
    next(frames)
    tracemalloc.start()
    try:
        for _ in range(10):
            next(frames)
        _, peak10 = tracemalloc.get_traced_memory()
        for _ in range(50):
            next(frames)
        _, peak60 = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # one 1280 x 720 frame is 2.8 MB: 50 more frames kept would add 140 MB
    assert peak60 < peak10 + 8e6


@pytest.mark.slow
def test_cli_json() -> None:
    out = subprocess.run([sys.executable, "-m", "pftrack", "bench", "soccer", "--json",
                          "--quiet", "--duration-s", "1"], capture_output=True, text=True,
                         check=True, timeout=600)
    res = json.loads(out.stdout)
    for k in KEYS:
        assert k in res, k
    assert res["frames"] == 25 and res["players"] == 22
    assert res["MOTA"] > 0.7
