"""World volumes: containment, uniform sampling, edges, pitch markings, YAML round trip."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.geometry.volumes import (
    CuboidVolume,
    SoccerPitchVolume,
    builtin_volumes,
    coast_volumes,
    load_volumes,
    resolve_volume,
    sample_polyline,
    save_volumes,
)


def test_cuboid_contains_matches_open3d_on_rotated_box():
    o3d = pytest.importorskip("open3d")
    box = CuboidVolume.from_yaw([10.0, -5.0, 2.0], [8.0, 3.0, 4.0], yaw_deg=35.0)
    rng = np.random.default_rng(0)
    pts = rng.uniform(-1, 1, size=(5000, 3)) * [6, 6, 3] + box.center_m
    ours = box.contains(pts)
    idx = box.to_open3d().get_point_indices_within_bounding_box(o3d.utility.Vector3dVector(pts))
    theirs = np.zeros(len(pts), bool)
    theirs[np.asarray(idx, dtype=np.intp)] = True
    assert 200 < ours.sum() < 4800  # a real mix of in and out
    assert np.array_equal(ours, theirs)
    # Open3D round trip
    back = CuboidVolume.from_open3d(box.to_open3d())
    assert np.allclose(back.corners(), box.corners())


def test_cuboid_contains_exact_points():
    box = CuboidVolume.from_bounds([0, 0, 0], [2, 4, 6])
    pts = np.array([[1, 2, 3], [0, 0, 0], [2, 4, 6], [2.001, 1, 1], [1, -0.01, 1], [1, 1, 6.5]])
    assert box.contains(pts).tolist() == [True, True, True, False, False, False]
    assert box.contains([1.0, 1.0, 1.0]).shape == (1,)
    assert box.volume_m3 == pytest.approx(48.0)


def test_cuboid_sample_is_uniform_and_seeded():
    box = CuboidVolume.from_yaw([0, 100, 3], [43, 10, 6], yaw_deg=20)
    a = box.sample(20000, np.random.default_rng(3))
    b = box.sample(20000, np.random.default_rng(3))
    assert a.shape == (20000, 3) and np.array_equal(a, b)
    assert box.contains(a).all()
    local = box.to_local(a) / box.size_m + 0.5  # uniform on [0, 1]^3
    assert np.allclose(local.mean(axis=0), 0.5, atol=0.01)
    assert np.allclose(local.var(axis=0), 1 / 12, atol=0.003)
    # each octant gets 1/8 of the points
    octant = (local > 0.5) @ np.array([1, 2, 4])
    counts = np.bincount(octant, minlength=8) / len(a)
    assert np.allclose(counts, 1 / 8, atol=0.01)
    assert box.sample(0, np.random.default_rng(0)).shape == (0, 3)
    with pytest.raises(TypeError):
        box.sample(3, 42)


def test_cuboid_edges_are_the_twelve_box_edges():
    box = CuboidVolume.from_bounds([0, 0, 0], [2, 4, 6])
    e = box.edges()
    assert e.shape == (12, 2, 3)
    lengths = np.sort(np.linalg.norm(e[:, 1] - e[:, 0], axis=1))
    assert np.allclose(lengths, [2] * 4 + [4] * 4 + [6] * 4)
    assert np.allclose(box.bounds(), [[0, 0, 0], [2, 4, 6]])
    foot = box.ground_lines()["footprint"]
    assert foot.shape == (5, 3) and np.allclose(foot[0], foot[-1]) and np.all(foot[:, 2] == 0)


@pytest.mark.parametrize("bad", [{"center_m": [0, 0], "size_m": [1, 1, 1]},
                                 {"center_m": [0, 0, 0], "size_m": [1, 0, 1]},
                                 {"center_m": [0, 0, 0], "size_m": [1, 1, 1],
                                      "rotation": np.diag([1, 1, -1.0])}])
def test_cuboid_rejects_bad_parameters(bad):
    with pytest.raises(ValueError, match="volume 'cuboid'"):
        CuboidVolume(**bad)


def test_coast_volumes_sizes_and_distances():
    v = coast_volumes()
    assert np.allclose(v["near"].size_m, [43, 10, 6])
    assert np.allclose(v["far"].size_m, [170, 310, 9])
    assert v["near"].center_m[1] == 100 and v["far"].center_m[1] == 300
    assert v["near"].bounds()[0, 2] == 0 and v["far"].bounds()[0, 2] == 0
    assert v["far"].volume_m3 / v["near"].volume_m3 == pytest.approx(170 * 310 * 9 / (43 * 60))


def test_pitch_markings_dimensions():
    pitch = SoccerPitchVolume()
    m = pitch.markings(step_m=0.5)
    expected = {"boundary", "halfway_line", "centre_circle", "centre_spot"}
    for side in ("left", "right"):
        expected |= {f"penalty_area_{side}", f"goal_area_{side}", f"penalty_spot_{side}",
                     f"penalty_arc_{side}"}
    assert expected <= set(m)
    for pts in m.values():
        assert pts.shape[1] == 3 and np.all(pts[:, 2] == 0)
        assert np.max(np.linalg.norm(np.diff(pts, axis=0), axis=1)) <= 0.5 + 1e-9
    b = m["boundary"]
    assert np.allclose(b.min(axis=0)[:2], [-52.5, -34]) and np.allclose(b.max(axis=0)[:2],
                                                                          [52.5, 34])
    assert np.allclose(np.linalg.norm(m["centre_circle"][:, :2], axis=1), 9.15)
    pa = m["penalty_area_left"]
    assert np.isclose(pa[:, 0].max(), -52.5 + 16.5) and np.isclose(pa[:, 1].max(), 3.66 + 16.5)
    ga = m["goal_area_right"]
    assert np.isclose(ga[:, 0].min(), 52.5 - 5.5) and np.isclose(ga[:, 1].max(), 3.66 + 5.5)
    spot = m["penalty_spot_left"][:, :2].mean(axis=0)
    assert np.allclose(spot, [-52.5 + 11, 0], atol=0.02)
    arc = m["penalty_arc_left"]
    assert np.allclose(np.linalg.norm(arc[:, :2] - [-41.5, 0], axis=1), 9.15)
    assert np.all(arc[:, 0] >= -36 - 1e-9)  # outside the penalty area only
    assert np.isclose(arc[:, 0].min(), -36) and np.isclose(arc[:, 0].max(), -41.5 + 9.15)


def test_pitch_corner_frame_and_volume():
    corner = SoccerPitchVolume(frame="corner")
    b = corner.markings()["boundary"]
    assert np.allclose(b.min(axis=0), 0) and np.allclose(b.max(axis=0)[:2], [105, 68])
    assert np.allclose(corner.penalty_spots()[0], [52.5, 34, 0])
    centre = SoccerPitchVolume(height_m=2.0, margin_m=3.0)
    assert centre.contains(np.array([[0, 0, 1], [54, 0, 1], [56, 0, 1], [0, 0, 2.5]])).tolist() \
        == [True, True, False, False]
    pts = centre.sample(1000, np.random.default_rng(0))
    assert centre.contains(pts).all() and pts[:, 0].min() < -50
    with pytest.raises(ValueError, match="frame"):
        SoccerPitchVolume(frame="middle")


def test_sample_polyline_keeps_vertices():
    v = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 1.0]])
    s = sample_polyline(v, 3.0)
    assert len(s) == 4 + 1 + 1
    assert np.allclose(s[0], v[0]) and np.allclose(s[-1], v[-1])
    assert any(np.allclose(p, v[1]) for p in s)


def test_volumes_yaml_round_trip(tmp_path):
    vols = dict(coast_volumes())
    vols["tilted"] = CuboidVolume.from_yaw([1, 2, 3], [4, 5, 6], 30.0, name="tilted")
    vols["pitch"] = SoccerPitchVolume(length_m=100, width_m=64, frame="corner")
    path = save_volumes(tmp_path / "v.yaml", vols)
    back = load_volumes(path)
    assert list(back) == list(vols)
    for k, v in vols.items():
        assert np.allclose(back[k].edges(), v.edges())
    assert back["pitch"].frame == "corner" and back["pitch"].length_m == 100


def test_volumes_yaml_yaw_and_errors(tmp_path):
    f = tmp_path / "v.yaml"
    f.write_text("- {name: a, center_m: [0, 0, 1], size_m: [2, 2, 2], yaw_deg: 90}\n")
    a = load_volumes(f)["a"]
    assert np.allclose(a.rotation[:, 0], [0, 1, 0], atol=1e-12)
    f.write_text("volumes:\n  - {name: a, center_m: [0, 0, 1]}\n")
    with pytest.raises(ValueError, match="v.yaml.*'a'.*size_m"):
        load_volumes(f)
    f.write_text("volumes:\n  - {name: a, type: sphere}\n")
    with pytest.raises(ValueError, match="unknown type 'sphere'"):
        load_volumes(f)
    f.write_text("volumes:\n  - {name: a, center_m: [0,0,0], size_m: [1,1,1]}\n"
                 "  - {name: a, center_m: [0,0,0], size_m: [1,1,1]}\n")
    with pytest.raises(ValueError, match="duplicate"):
        load_volumes(f)
    with pytest.raises(FileNotFoundError, match="nope.yaml"):
        load_volumes(tmp_path / "nope.yaml")


def test_resolve_volume(tmp_path):
    assert isinstance(resolve_volume("pitch"), SoccerPitchVolume)
    assert set(builtin_volumes()) >= {"pitch", "near", "far"}
    f = tmp_path / "mine.yaml"
    save_volumes(f, [CuboidVolume([0, 0, 1], [2, 2, 2], name="box"),
                     CuboidVolume([5, 0, 1], [2, 2, 2], name="other")])
    assert resolve_volume(str(f)).name == "box"
    assert resolve_volume(f"{f}:other").center_m[0] == 5
    assert resolve_volume("other", search=[f]).name == "other"
    with pytest.raises(ValueError, match="unknown volume 'moon'"):
        resolve_volume("moon", search=[f])


def test_plugins_ship_volume_files_found_by_name(tmp_path):
    from pftrack import hookimpl
    from pftrack.host import Host, RegistrationError

    # the built-ins' package data: the soccer paper's pitch and the PETS walkway cuboid
    pitch = resolve_volume("pitch_corner")
    assert isinstance(pitch, SoccerPitchVolume) and pitch.frame == "corner"
    walkway = resolve_volume("walkway")
    np.testing.assert_allclose(walkway.size_m, [27.0, 22.0, 2.0])

    f = tmp_path / "mine.yaml"
    save_volumes(f, [CuboidVolume([0, 0, 1], [2, 2, 2], name="shed")])

    class _Ships:
        @hookimpl
        def pftrack_register_volumes(self, register):
            register("sheds", str(f))

    class _Broken:
        @hookimpl
        def pftrack_register_volumes(self, register):
            register("gone", str(tmp_path / "gone.yaml"))

    h = Host(load_entry_points=False, plugins=[("ships", _Ships())])
    assert h.names("volumes") == ["sheds"]
    assert h.plugins["ships"].components == {"volumes": ["sheds"]}
    with pytest.raises(RegistrationError, match=r"plugin 'broken': volumes 'gone' file not found"):
        Host(load_entry_points=False, plugins=[("broken", _Broken())])
