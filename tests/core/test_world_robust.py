"""Ground-plane tracking where the geometry is hard: a camera at waist height whose horizon
passes through the people, people taller than the picture and cut by its edge, boxes whose feet
are above the horizon, states beside or behind the camera; and the trust test of a camera
estimated from people (:func:`pftrack.workflows.track.camera_trust`)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pftrack.builtin.world_observation import CameraBoxObservation
from pftrack.geometry.people import camera_from_parameters
from pftrack.io.data import data_dir

MOT = data_dir() / "mot17-09"
needs_mot = pytest.mark.skipif(not (MOT / "MOT17-09.mp4").is_file(),
                               reason="MOT17-09 not in the data folder")

#: a camera of the kind people give for MOT17-09 squeezed to 640 x 480: 0.9 m up (the horizon
#: through the people's waists), a lens whose model folds back just outside the picture
WAIST = dict(focal_px=822.6, tilt_deg=-0.623, roll_deg=-1.949, camera_height_m=0.8995,
             image_size=(640, 480), distortion_k=-0.265)


def waist_camera(**kw):
    return camera_from_parameters(**{**WAIST, **kw})


def test_points_past_the_lens_models_field_get_pixels_outside_the_image():
    cam = waist_camera()
    # a row of points 1 m in front, from straight ahead to far to the right, at the camera's
    # height
    x = np.linspace(0.0, 6.0, 601)
    pts = np.column_stack([x, np.full_like(x, 1.0), np.full_like(x, 0.8995)])
    plain = cam.project(pts)
    px = cam.project_beyond_lens(pts)
    inside = np.isfinite(plain).all(axis=1)
    assert inside.any() and not inside.all()  # the lens model ends along this row
    assert np.isfinite(px).all()
    # where the lens model has a value, the same pixels, bit for bit
    np.testing.assert_array_equal(px[inside], plain[inside])
    # beyond it: outside the image, further out the further out, without a jump at the edge
    beyond = ~inside
    w, h = cam.image_size
    assert not cam.in_image(px[beyond]).any()
    centre = np.array([(w - 1) / 2, (h - 1) / 2])
    r = np.linalg.norm(px - centre, axis=1)
    assert np.all(np.diff(r[beyond]) > 0)
    last_in, first_out = np.flatnonzero(inside)[-1], np.flatnonzero(beyond)[0]
    assert first_out == last_in + 1
    step_in = r[last_in] - r[last_in - 1]
    assert abs(r[first_out] - r[last_in]) < 3 * step_in
    # behind the camera's centre plane: still no pixel
    assert np.isnan(cam.project_beyond_lens(np.array([[0.0, -1.0, 0.0]]))).all()


def test_tsai_field_edge_scale_is_three_halves_as_the_bisection_finds():
    """Tsai's lens with kappa1 < 0 ends where r_u = r_d (1 + kappa1 r_d^2) stops growing; the
    radial scale there is 3/2 in closed form, which a bisection on the model finds too."""
    from pftrack.geometry.lens import TsaiDistortion

    cam = waist_camera()
    assert isinstance(cam.distortion, TsaiDistortion) and cam.distortion.kappa1 < 0
    rng = np.random.default_rng(0)
    ang = rng.uniform(0, 2 * np.pi, 50)
    xy = 3.0 * np.column_stack([np.cos(ang), np.sin(ang)])  # beyond the field, every way
    np.testing.assert_array_equal(cam.distortion.edge_scale(xy), np.full(50, 1.5))
    np.testing.assert_allclose(cam._bisected_edge_scale(xy), 1.5, atol=2e-4)
    assert TsaiDistortion(0.1).edge_scale(xy) is None  # barrel-free: no edge


def test_a_person_taller_than_the_picture_and_cut_by_its_edge_has_a_finite_box():
    cam = waist_camera()
    obs = CameraBoxObservation(cam, height_m=1.7, width_ratio=0.34)
    # people 1.2 m in front, from the middle to beyond the right edge, and their particles
    states = np.zeros((50, 6))
    states[:, 0] = np.linspace(0.0, 1.5, 50)
    states[:, 1] = 1.2
    assert np.isnan(cam.project(np.column_stack([states[:, :2], np.full(50, 1.7)]))).any()
    boxes = obs.to_boxes(states)
    assert np.isfinite(boxes).all()
    foot = cam.project_beyond_lens(obs.ground_points(states))
    np.testing.assert_allclose(boxes[:, 0] + boxes[:, 2] / 2, foot[:, 0])
    np.testing.assert_allclose(boxes[:, 1] + boxes[:, 3], foot[:, 1])
    assert np.all(boxes[:, 3] > 480)  # taller than the picture: cut at its top and bottom


def test_states_behind_the_camera_have_no_box_and_are_not_in_view():
    cam = waist_camera()
    obs = CameraBoxObservation(cam, height_m=1.7)
    states = np.zeros((3, 6))
    states[:, 1] = [5.0, -0.5, -3.0]  # in front; beside and behind the camera
    boxes = obs.to_boxes(states)
    assert np.isfinite(boxes[0]).all() and np.isnan(boxes[1:]).all()
    np.testing.assert_array_equal(obs.in_view(states, (640, 480)), [True, False, False])


def test_a_box_above_the_horizon_is_not_placed_and_starts_no_track():
    import pftrack

    cam = waist_camera(distortion_k=0.0, roll_deg=0.0)
    obs = CameraBoxObservation(cam, height_m=1.7)
    sign = np.array([400.0, 40.0, 40.0, 100.0])  # foot row 140, the horizon near row 248
    assert np.isnan(obs.position_from_box(sign)).all()
    person = obs.to_boxes(np.array([[0.3, 6.0, 0, 0, 0, 0]]))[0]
    tracker = pftrack.Tracker("people-ground", camera=cam, image_size=(640, 480), fps=30,
                              seed=0)
    image = np.random.default_rng(0).integers(0, 255, (480, 640, 3), dtype=np.uint8)
    for _ in range(8):
        boxes = np.array([[*sign[:2], *(sign[:2] + sign[2:]), 0.9],
                          [*person[:2], *(person[:2] + person[2:]), 0.9]])
        out = tracker.update(boxes, frame=image)
    assert len(out) == 1  # the person, not the sign
    np.testing.assert_allclose(out.xyxy[0, 3], person[1] + person[3], atol=5.0)
    assert np.isfinite(out.xyxy).all() and np.isfinite(out.world_m).all()


def _squeezed_slice(tmp_path, last: int):
    """MOT17-09's frames 1..last squeezed to 640 x 480, and its people's boxes (as a detector
    gives them: clipped to the frame) as a det.txt."""
    import cv2

    cap = cv2.VideoCapture(str(MOT / "MOT17-09.mp4"))
    video = tmp_path / "squeezed.mp4"
    out = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 30, (640, 480))
    try:
        for _ in range(last):
            ok, img = cap.read()
            assert ok
            out.write(cv2.resize(img, (640, 480), interpolation=cv2.INTER_AREA))
    finally:
        cap.release()
        out.release()
    gt = np.loadtxt(MOT / "gt" / "gt.txt", delimiter=",")
    gt = gt[(gt[:, 0] <= last) & (gt[:, 6] == 1) & (gt[:, 7] == 1)]
    sx, sy = 640 / 1920, 480 / 1080
    x0, y0 = np.clip(gt[:, 2] * sx, 0, 640), np.clip(gt[:, 3] * sy, 0, 480)
    x1 = np.clip((gt[:, 2] + gt[:, 4]) * sx, 0, 640)
    y1 = np.clip((gt[:, 3] + gt[:, 5]) * sy, 0, 480)
    keep = (x1 - x0 > 2) & (y1 - y0 > 4)
    det = tmp_path / "det.txt"
    det.write_text("".join(f"{int(f)},-1,{a:.2f},{b:.2f},{c - a:.2f},{d - b:.2f},0.9\n"
                           for f, a, b, c, d in zip(gt[keep, 0], x0[keep], y0[keep], x1[keep],
                                                    y1[keep])))
    return video, det


@needs_mot
def test_people_ground_on_a_squeezed_waist_height_street_writes_no_nan(tmp_path):
    """MOT17-09 squeezed to 640 x 480 through the camera people give for it: people taller
    than the picture at its edges, whose heads lie past the lens model's field."""
    from pftrack.cli import main
    from pftrack.geometry.formats import save_camera
    from pftrack.io.mot import read_mot

    video, det = _squeezed_slice(tmp_path, 20)
    cam = tmp_path / "cam.yaml"
    save_camera(waist_camera(), cam)
    out = tmp_path / "out"
    assert main(["run", "people-ground", "--video", str(video), "--detections", str(det),
                 "--camera", str(cam), "--frames", "1:20", "--out", str(out), "--no-report",
                 "--quiet"]) == 0
    rows = read_mot(out / "tracks.txt")
    assert len(np.unique(rows[:, 1])) >= 5
    unc = np.genfromtxt(out / "tracks_uncertainty.csv", delimiter=",", names=True)
    assert len(unc) == len(rows)
    for name in unc.dtype.names:
        assert np.isfinite(unc[name]).all(), name


@needs_mot
def test_the_python_api_on_a_squeezed_waist_height_street_gives_no_nan(tmp_path):
    """The same slice frame by frame through :class:`pftrack.Tracker`: every track's box, its
    spread and its ground position finite."""
    import cv2
    import pftrack
    from pftrack.io.detections import read_detections

    video, det = _squeezed_slice(tmp_path, 12)
    dets = read_detections(det)
    tracker = pftrack.Tracker("people-ground", camera=waist_camera(), fps=30, seed=0)
    cap = cv2.VideoCapture(str(video))
    rows = []
    try:
        for f in range(1, 13):
            ok, img = cap.read()
            assert ok
            out = tracker.update(dets[f], frame=img)
            rows.append(out)
            if out.confirmed_earlier is not None:
                rows.append(out.confirmed_earlier)
    finally:
        cap.release()
    tracks = pftrack.Tracks.concat(rows)
    assert len(np.unique(tracks.tracker_id)) >= 5
    for name in ("xyxy", "xyxy_sd", "confidence", "world_m", "world_cov"):
        assert np.isfinite(getattr(tracks, name)).all(), name


def test_camera_trust_passes_people_at_every_distance_with_the_horizon_through_them():
    from pftrack.geometry.people import estimate_camera_from_people
    from pftrack.workflows.track import camera_trust

    rng = np.random.default_rng(1)
    cam = camera_from_parameters(1000.0, 0.0, 0.0, 0.9, (1280, 720))
    n = 400
    ground = np.column_stack([rng.uniform(-4, 4, n), rng.uniform(2.5, 40, n), np.zeros(n)])
    tall = rng.normal(1.7, 0.07, n)
    foot = cam.project(ground)
    head = cam.project(ground + np.column_stack([np.zeros((n, 2)), tall]))
    h = foot[:, 1] - head[:, 1]
    boxes = np.column_stack([foot[:, 0] - 0.17 * h, head[:, 1], 0.34 * h, h])
    ok = (boxes[:, 1] > 3) & (boxes[:, 1] + boxes[:, 3] < 716)
    boxes, frames = boxes[ok], np.arange(n)[ok]
    fit = estimate_camera_from_people(boxes, (1280, 720), n_bootstrap=0, rng=0)
    assert abs(fit.horizon_row - 359.5) < 10
    t = camera_trust(fit, boxes, frames, (1280, 720))
    assert t["trusted"], t["reasons"]
    assert t["above_horizon"] == 0.0 and t["spread"] < 0.1 and t["height_ratio"] < 1.2
    assert t["horizon_through_people"] > 0.9  # the horizon passes through the people


def test_camera_trust_refuses_people_who_do_not_determine_the_camera():
    """The people of the first half of the frames stand as a camera 2.7 m up would see them,
    those of the second as one 0.85 m up would (one distance band each, as in a frame cut
    below the people's feet): no single camera explains both."""
    from pftrack.geometry.people import estimate_camera_from_people
    from pftrack.workflows.track import camera_trust

    rng = np.random.default_rng(2)
    parts = []
    for k, height in enumerate((2.7, 0.85)):
        cam = camera_from_parameters(1000.0, 0.0, 0.0, height, (1280, 720))
        n = 150
        ground = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(8, 20, n), np.zeros(n)])
        tall = rng.normal(1.7, 0.05, n)
        foot = cam.project(ground)
        head = cam.project(ground + np.column_stack([np.zeros((n, 2)), tall]))
        h = foot[:, 1] - head[:, 1]
        parts.append(np.column_stack([foot[:, 0] - 0.17 * h, head[:, 1], 0.34 * h, h,
                                      np.full(n, k * 1000) + np.arange(n)]))
    rows = np.concatenate(parts)
    fit = estimate_camera_from_people(rows[:, :4], (1280, 720), n_bootstrap=0, rng=0)
    t = camera_trust(fit, rows[:, :4], rows[:, 4], (1280, 720))
    assert not t["trusted"]
    assert t["height_ratio"] > 2.0
    assert any("puts the camera" in r for r in t["reasons"])


def test_camera_trust_counts_a_static_box_once():
    from pftrack.workflows.track import _distinct

    still = np.tile([[100.0, 50.0, 30.0, 90.0]], (300, 1))
    walking = np.column_stack([np.linspace(0, 600, 30), np.full(30, 200.0), np.full(30, 30.0),
                               np.full(30, 90.0)])
    assert len(_distinct(np.concatenate([still, walking]))) == 1 + 30


def _two_camera_people(tmp_path, n_frames: int = 40):
    """A still 640 x 360 video of ``n_frames`` frames and a det.txt whose people in the first
    half of the frames stand as a camera 2.7 m up sees them, in the second half as one 0.85 m
    up does: people that no single camera explains."""
    import cv2

    rng = np.random.default_rng(3)
    lines = []
    half = n_frames // 2
    for k, height in enumerate((2.7, 0.85)):
        cam = camera_from_parameters(500.0, 0.0, 0.0, height, (640, 360))
        for f in range(1 + k * half, 1 + (k + 1) * half):
            ground = np.column_stack([rng.uniform(-3, 3, 6), rng.uniform(8, 20, 6),
                                      np.zeros(6)])
            foot = cam.project(ground)
            head = cam.project(ground + [0.0, 0.0, 1.7])
            h = foot[:, 1] - head[:, 1]
            lines += [f"{f},-1,{u - 0.17 * hh:.2f},{v:.2f},{0.34 * hh:.2f},{hh:.2f},0.9\n"
                      for u, v, hh in zip(foot[:, 0], head[:, 1], h)]
    det = tmp_path / "det.txt"
    det.write_text("".join(lines))
    video = tmp_path / "still.mp4"
    out = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 10, (640, 360))
    img = np.random.default_rng(0).integers(0, 255, (360, 640, 3), dtype=np.uint8)
    for _ in range(n_frames):
        out.write(img)
    out.release()
    return video, det


def test_track_does_not_draw_boxes_from_a_camera_it_cannot_trust(tmp_path):
    from pftrack.workflows.track import track_video

    video, det = _two_camera_people(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "camera.yaml").write_text("an earlier run's estimate\n")
    res = track_video(video, out, detections=det, report=False)
    s = json.loads((out / "summary.json").read_text())
    assert s["state"] == "image" and s["preset"] == "people-image"
    assert s["camera"].startswith("not trusted: estimated from")
    assert s["camera_trust"]["trusted"] is False and s["camera_trust"]["height_ratio"] > 2
    assert s["camera_fit"]["camera_height_m"] > 0  # the estimate, described
    assert any(m.startswith("no camera: the camera estimated from the people is not trusted")
               for m in res.messages)
    assert res.fit is None and not (out / "camera.yaml").exists()
    assert s["tracks"] > 0
    # asked for the ground plane: the estimate is used, with the warning
    res2 = track_video(video, tmp_path / "out2", detections=det, report=False,
                       preset="people-ground")
    assert res2.summary["state"] == "world" and res2.fit is not None
    assert any("not trusted" in m and "as --preset people-ground asks" in m
               for m in res2.messages)


def test_detections_above_the_horizon_are_written_without_nan(tmp_path):
    from pftrack.contracts.components import Detections
    from pftrack.io.detections import read_detections, write_detections

    cam = waist_camera(distortion_k=0.0, roll_deg=0.0)
    det = tmp_path / "det.txt"
    det.write_text("1,-1,300,200,40,120,0.9\n1,-1,400,40,40,100,0.8\n")
    dets = read_detections(det, camera=cam)
    pts = dets[1].points_world_m
    assert np.isfinite(pts[0]).all() and np.isnan(pts[1]).all()  # the second: above
    out = tmp_path / "again.txt"
    write_detections(out, {1: Detections(dets[1].boxes_xywh_px, dets[1].scores, pts)})
    assert "nan" not in out.read_text().lower()
    rows = np.loadtxt(out, delimiter=",")
    np.testing.assert_array_equal(rows[1, 7:10], [-1.0, -1.0, -1.0])
    np.testing.assert_allclose(rows[0, 7:10], pts[0], rtol=1e-5)


def test_particles_without_a_box_have_zero_likelihood():
    """people-ground's likelihood: a particle the camera has no box for (behind it) weighs
    nothing, in the one-target and the rows call alike; the others are as before."""
    import pftrack
    from pftrack.contracts.components import Detections, Frame

    tracker = pftrack.Tracker("people-ground", camera=waist_camera(), fps=30, seed=0)
    image = np.random.default_rng(0).integers(0, 255, (480, 640, 3), dtype=np.uint8)
    tracker.update(np.array([[300.0, 150, 340, 300, 0.9]]), frame=image)
    engine = tracker.engines[0]
    target = engine.targets[0]
    boxes = target.particle_boxes_xywh_px.copy()
    like = engine.likelihood
    like.begin_frame(Frame(2, image), [target], Detections(boxes[:1].copy(), np.array([0.9])))
    before = like.log_likelihood(boxes, target)
    assert np.isfinite(before).all()
    boxes[:5] = np.nan
    one = like.log_likelihood(boxes, target)
    rows = like.log_likelihood_rows(boxes[None], [target])[0]
    np.testing.assert_array_equal(one, rows)
    assert np.all(one[:5] == -np.inf)
    np.testing.assert_array_equal(one[5:], before[5:])


def _walkers(tmp_path, n_frames: int = 60):
    """A still 640 x 360 video and a det.txt of six people walking across the ground as a
    camera 2.7 m up sees them (boxes 0.34 of their height wide)."""
    import cv2

    cam = camera_from_parameters(500.0, 0.0, 0.0, 2.7, (640, 360))
    start = np.column_stack([np.linspace(-3.0, 3.0, 6), np.linspace(8.0, 20.0, 6),
                             np.zeros(6)])
    lines = []
    for f in range(1, n_frames + 1):
        ground = start + [0.04 * f, 0.0, 0.0]
        foot = cam.project(ground)
        head = cam.project(ground + [0.0, 0.0, 1.7])
        h = foot[:, 1] - head[:, 1]
        lines += [f"{f},-1,{u - 0.17 * hh:.2f},{v:.2f},{0.34 * hh:.2f},{hh:.2f},0.9\n"
                  for u, v, hh in zip(foot[:, 0], head[:, 1], h)]
    det = tmp_path / "det.txt"
    det.write_text("".join(lines))
    video = tmp_path / "still.mp4"
    out = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 10, (640, 360))
    img = np.random.default_rng(0).integers(0, 255, (360, 640, 3), dtype=np.uint8)
    for _ in range(n_frames):
        out.write(img)
    out.release()
    return video, det


def test_given_boxes_are_tracked_in_the_image_plane_with_ground_positions(tmp_path):
    """``pftrack track --detections``: a trusted camera estimated from the boxes, the tracks
    kept in the image plane (people-image), their ground positions their feet through it."""
    from pftrack.io.mot import read_mot
    from pftrack.workflows.track import track_video

    video, det = _walkers(tmp_path)
    out = tmp_path / "out"
    res = track_video(video, out, detections=det, report=False)
    s = json.loads((out / "summary.json").read_text())
    assert s["preset"] == "people-image" and s["state"] == "image"
    assert s["camera"].startswith("estimated from") and s["camera_trust"]["trusted"]
    assert (out / "camera.yaml").is_file() and res.fit is not None
    assert any("tracked in the image plane" in m and "through the camera" in m
               for m in res.messages)
    rows = read_mot(out / "tracks.txt")
    assert s["tracks"] == 6 and len(rows) > 6 * 40
    assert np.all(np.abs(rows[:, 9]) < 1e-6)  # on the ground
    # each track's ground position is its box's foot through the camera written beside it:
    # within a quarter metre of the given boxes' feet in frame 50 (the farthest person is 20 m
    # away, where a pixel of the foot row spans centimetres)
    from pftrack.geometry.boxes import foot_points
    from pftrack.geometry.formats import load_camera

    cam = load_camera(out / "camera.yaml")
    from pftrack.io.detections import read_detections

    feet = cam.image_to_ground(foot_points(read_detections(det)[50].boxes_xywh_px))[:, :2]
    f = rows[rows[:, 0] == 50]
    assert len(f) == 6
    d = np.linalg.norm(f[:, None, 7:9] - feet[None], axis=2).min(axis=1)
    assert d.max() < 0.25, d
    # asked for the ground plane: tracked there
    res2 = track_video(video, tmp_path / "out2", detections=det, report=False,
                       preset="people-ground")
    assert res2.summary["state"] == "world" and res2.summary["preset"] == "people-ground"
