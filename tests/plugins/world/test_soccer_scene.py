"""The soccer scene: real kloppy trajectories, the pitch through the soccer paper's camera, players
with occlusion, and ground truth in pitch metres."""

from __future__ import annotations

import inspect

import numpy as np
import pytest
from pftrack_world.soccer import (
    PitchTracks,
    SoccerScene,
    _raw_tracks,
    load_pitch_tracks,
    marking_quads,
)

FPS = 25.0


@pytest.fixture(scope="module")
def tracks() -> PitchTracks:
    return load_pitch_tracks("hawkeye", fps=FPS, duration_s=20.0)


@pytest.fixture(scope="module")
def scene() -> SoccerScene:
    # supersample=1 keeps the background cheap; the geometry is the same
    return SoccerScene(duration_s=2.0, seed=3, supersample=1).prepare()


# ---- trajectories -------------------------------------------------------------------------


def test_hawkeye_gives_20_s_of_22_players(tracks: PitchTracks) -> None:
    assert tracks.n_frames == 500
    assert tracks.n_players == 22
    assert np.isfinite(tracks.positions_m).all()
    np.testing.assert_allclose(np.diff(tracks.times_s), 1 / FPS)
    assert sorted(np.bincount(tracks.teams).tolist()) == [11, 11]
    assert tracks.goalkeeper.sum() == 2
    assert set(tracks.teams[tracks.goalkeeper].tolist()) == {0, 1}
    assert (tracks.pitch_length_m, tracks.pitch_width_m) == (104.0, 67.0)
    # centre frame: everyone within the pitch plus a few metres
    assert np.all(np.abs(tracks.positions_m[..., 0]) < 52 + 3)
    assert np.all(np.abs(tracks.positions_m[..., 1]) < 33.5 + 3)
    # real footballers: fast but not superhuman (< 11 m/s frame to frame)
    speed = np.linalg.norm(np.diff(tracks.positions_m, axis=0), axis=2) * FPS
    assert 0.5 < speed.mean() < 5.0
    assert speed.max() < 11.0


def test_interpolation_stays_on_the_provider_samples() -> None:
    raw = _raw_tracks("hawkeye")
    tr = load_pitch_tracks("hawkeye", fps=50.0, duration_s=4.0)
    # the minute is one continuous run (its single 40 ms hiccup is bridged); grid times
    # coincide with 50 Hz samples to within their jitter, so positions agree to centimetres
    t0 = raw.times_s[0]
    grid = t0 + tr.times_s[:100]
    k = np.abs(raw.times_s[:, None] - grid[None, :]).argmin(axis=0)
    on_sample = np.abs(raw.times_s[k] - grid) < 0.005
    assert on_sample.sum() == 99  # one grid time falls in the hiccup, 20 ms from any sample
    np.testing.assert_allclose(tr.positions_m[:100][on_sample], raw.positions_m[k[on_sample]],
                               atol=0.05)
    # ... and there it lies between the two samples around it
    g = int(np.flatnonzero(~on_sample)[0])
    j = np.searchsorted(raw.times_s, grid[g])
    lo = np.minimum(raw.positions_m[j - 1], raw.positions_m[j]) - 1e-9
    hi = np.maximum(raw.positions_m[j - 1], raw.positions_m[j]) + 1e-9
    assert np.all((tr.positions_m[g] >= lo) & (tr.positions_m[g] <= hi))


def test_sources_without_20_s_of_play_say_so() -> None:
    with pytest.raises(ValueError, match=r"'pff' has 0\.80 s of continuous play"):
        load_pitch_tracks("pff", duration_s=20.0)
    with pytest.raises(ValueError, match=r"'sportec' has 4\.00 s"):
        load_pitch_tracks("sportec", duration_s=20.0)
    short = load_pitch_tracks("pff", duration_s=0.8, fps=FPS)
    assert short.positions_m.shape == (20, 22, 2)
    with pytest.raises(ValueError, match="unknown source 'nope'"):
        load_pitch_tracks("nope")


# ---- scene contract ---------------------------------------------------------------------


def test_frames_stream_lazily_and_are_deterministic(scene: SoccerScene) -> None:
    gen = scene.frames()
    assert inspect.isgenerator(gen)
    f1 = next(gen)
    assert f1.index == 1 and f1.time_s == 0.0
    assert f1.image.shape == (720, 1280, 3) and f1.image.dtype == np.uint8
    f2 = next(gen)
    assert f2.index == 2 and f2.time_s == pytest.approx(1 / FPS)
    assert scene.n_frames == 50
    same = SoccerScene(duration_s=2.0, seed=3, supersample=1)
    np.testing.assert_array_equal(next(same.frames()).image, f1.image)
    other = SoccerScene(duration_s=2.0, seed=4, supersample=1)
    assert not np.array_equal(next(other.frames()).image, f1.image)
    assert scene.get_params()["fps"] == FPS
    assert scene.clone().get_params() == scene.get_params()


def test_markings_are_drawn_through_the_lens(scene: SoccerScene) -> None:
    cam = scene.camera_
    quads = marking_quads(scene.markings_pitch_) + scene.centre_m_
    centres = quads.mean(axis=1)
    px = cam.project(centres)
    ok = cam.in_image(px, margin_px=2)
    u, v = np.round(px[ok]).astype(int).T
    bg = scene.background_.astype(int)
    on_line = bg[v, u].mean(axis=1)
    # the grass next to the lines, 6 px below, is much darker than the painted lines
    off_line = bg[np.clip(v + 6, 0, 719), u].mean(axis=1)
    assert np.median(on_line) > 150
    assert np.median(on_line - off_line) > 40
    # a straight line bends through the lens: the near touch line's midpoint is off the chord
    near = np.array([[x, 0.0, 0.0] for x in (0.0, 52.0, 104.0)])
    near[:, :2] += scene.centre_m_[:2] - [52.0, 33.5]
    a, m, b = cam.project(near)
    t = b - a
    dist = abs(t[0] * (m - a)[1] - t[1] * (m - a)[0]) / np.hypot(*t)
    assert dist > 3.0


def test_ground_truth_rows(scene: SoccerScene) -> None:
    gt = scene.ground_truth()
    assert gt.shape[1] == 10
    # the soccer paper's camera sees the whole pitch: every player in every frame
    assert len(gt) == 50 * 22
    assert set(np.unique(gt[:, 1]).astype(int)) == set(range(1, 23))
    f1 = gt[gt[:, 0] == 1]
    np.testing.assert_allclose(f1[:, 7:9], scene.positions_world_m_[0][f1[:, 1].astype(int) - 1])
    assert np.all(f1[:, 9] == 0) and np.all(f1[:, 6] == 1)
    # the foot point projects onto the bottom part of the box, centred horizontally
    foot = scene.camera_.project(np.column_stack([f1[:, 7:9], np.zeros(len(f1))]))
    cx = f1[:, 2] + f1[:, 4] / 2
    assert np.all(np.abs(foot[:, 0] - cx) < 0.25 * f1[:, 4] + 0.5)
    assert np.all(foot[:, 1] > f1[:, 3] + 0.7 * f1[:, 5])
    # size from the camera: height ~ f * 1.8 m / depth
    depth = scene.camera_.depth(np.column_stack([f1[:, 7:9], np.ones(len(f1))]))
    expect_h = scene.camera_.fy * 1.8 / depth
    np.testing.assert_allclose(f1[:, 5], expect_h, rtol=0.25)


def test_players_are_drawn_in_team_colours(scene: SoccerScene) -> None:
    img = scene.render(0).astype(int)
    bg = scene.background_.astype(int)
    gt = scene.ground_truth()
    f1 = gt[gt[:, 0] == 1]
    changed = np.abs(img - bg).sum(axis=2) > 60
    home, away = [], []
    for row in f1:
        x, y, w, h = row[2:6]
        x0, y0 = int(np.floor(x)), int(np.floor(y))
        box = changed[y0:int(np.ceil(y + h)) + 1, x0:int(np.ceil(x + w)) + 1]
        assert box.sum() >= 4, f"player {int(row[1])} is not drawn"
        # shirt: the pixels of the upper part of the box that differ from the background
        top = slice(y0 + int(0.15 * h), y0 + int(0.5 * h) + 1)
        pix = img[top, x0:int(np.ceil(x + w)) + 1][changed[top, x0:int(np.ceil(x + w)) + 1]]
        i = int(row[1]) - 1
        if len(pix) and not scene.tracks_.goalkeeper[i]:
            (home if scene.tracks_.teams[i] == 0 else away).append(pix.mean(axis=0))
    home, away = np.array(home), np.array(away)
    assert len(home) >= 6 and len(away) >= 6
    # home in red (BGR: R high, G low), away in white (all channels high)
    assert np.median(home[:, 2] - home[:, 1]) > 60
    assert np.median(away.min(axis=1)) > 140


def _two_players(scene_kw: dict, near_team: int) -> SoccerScene:
    """Player 0 (team ``near_team``) right in front of player 1 as the camera sees them."""
    probe = SoccerScene(**scene_kw).prepare()
    cam, c = probe.camera_, probe.centre_m_
    # a ground point in the middle of the pitch, and one 6 m further along the viewing ray
    p_near = np.array([0.0, -10.0]) + c[:2]
    ray = p_near - cam.center_m[:2]
    p_far = p_near + 6.0 * ray / np.linalg.norm(ray)
    pos = np.stack([p_near, p_far])[None].repeat(3, axis=0) - c[:2]
    tr = PitchTracks(source="test", times_s=np.arange(3) / FPS, positions_m=pos,
                     player_ids=("near", "far"), teams=np.array([near_team, 1 - near_team]),
                     jerseys=np.array([1, 2]), goalkeeper=np.zeros(2, bool),
                     pitch_length_m=104.0, pitch_width_m=67.0, start_s=0.0,
                     provider_rate_hz=FPS)
    return SoccerScene(**scene_kw).with_tracks(tr).prepare()


@pytest.mark.parametrize("near_team", [0, 1])
def test_nearer_player_occludes_the_farther(near_team: int) -> None:
    kw = {"duration_s": 0.12, "seed": 1, "supersample": 1, "noise_std": 0.0}
    s = _two_players(kw, near_team)
    img = s.render(0).astype(int)
    gt = s.ground_truth()
    near, far = gt[gt[:, 1] == 1][0], gt[gt[:, 1] == 2][0]
    # they overlap in the image: the near box covers the far one's lower part
    assert near[2] < far[2] + far[4] and far[2] < near[2] + near[4]
    # look at the near player's shirt (upper-middle of its box)
    x, y, w, h = near[2:6]
    patch = img[int(y + 0.3 * h):int(y + 0.45 * h) + 1, int(x + 0.35 * w):int(x + 0.65 * w) + 1]
    bgr = patch.reshape(-1, 3).mean(axis=0)
    if near_team == 0:  # red in front
        assert bgr[2] - bgr[1] > 80
    else:  # white in front of red
        assert bgr.min() > 150


def test_bad_parameters_name_the_culprit(tmp_path) -> None:
    with pytest.raises(FileNotFoundError, match="nowhere.yaml"):
        SoccerScene(camera=str(tmp_path / "nowhere.yaml"), duration_s=1).prepare()
    with pytest.raises(ValueError, match=r"'source' must be one of .*got 'hawk'"):
        SoccerScene(source="hawk", duration_s=1).prepare()
    with pytest.raises(ValueError, match="duration_s"):
        SoccerScene(duration_s=0).prepare()
    with pytest.raises(ValueError, match=r"'hawkeye' has 60\.00 s"):
        SoccerScene(start_s=50, duration_s=20).prepare()
