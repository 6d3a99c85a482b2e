"""The coastal paper through the one engine: intruders found and tracked in 3-D volumes with no
detector.

``pftrack bench coast --json`` runs, on real video:

* ``pets09``: PETS 2009 S2.L1 with the preset ``pets09-volume`` -- the block eigenspace model
  trained on frames 1-400 (people's boxes, grown by 8 px, as foreground) exactly as
  ``pftrack detector train --config pets09-volume`` trains it, then the people found and tracked
  in the walkway cuboid (``calib/pets09_walkway.yaml``) on the test frames (default 401-795).
  Reported:

  - ``MOTA``, ``IDF1``, ``HOTA``: image boxes (each estimate's cuboid projected) at IoU 0.5;
  - ``MOTA_world``, ``IDF1_world``, ``HOTA_world``: footprints on the ground plane against the
    ground truth's world positions, matched within 1 m;
  - ``median_error_m``: ground-plane distance of the track/ground-truth pairs matched within 1 m
    frame by frame;
  - ``entry_error_frames``, ``exit_error_frames``: per person, ``|the first (last) frame a track
    is matched to them within 1 m - the first (last) frame the ground truth has them inside the
    volume|`` (identity is IDF1's business); the medians, and ``entry_exit_within_10`` the
    fraction of people with both within 10 frames (a person never matched counts as outside);
  - ``size_error_m``: median ``|estimated - true|`` size per axis (x = width across the view, y =
    depth along the view, z = height; the truth a person's 0.5 x 0.5 x 1.75 m) over the
    estimates matched within 1 m: after the support-plane correction, and ``size_error_raw_m``
    the paper's eq. 10 (2 sqrt of the particles' variance along the same axes);
  - ``frames_per_second``: frames over the time of scoring and tracking (one OpenCV thread;
    video decoding not included; ``frames_per_second_with_decoding`` includes it);
    ``frames_per_second_cpu`` over its CPU time;
  - ``frames_per_second_3x5000``: the speed goal's configuration -- frames per second of CPU
    time over the ``frames_3x5000`` frames in which exactly 3 particle groups (the detection
    group and two people) of 5000 particles were alive (background scoring, estimates and
    track management included); the goal (>= 100) is checked against it. The frames are
    tracked ``--speed-runs`` times (default 3; the same tracks each time, checked) and this is
    the best of them (``timeit``'s convention: on a shared host the same run's speed moves by
    up to 40 %), each run's in ``frames_per_second_3x5000_runs``;
  - ``mog2``: the same run and figures with the likelihood ``mog2-fraction`` (OpenCV's MOG2
    shown the training frames, then learning online) in place of the eigenspace one.

* ``coast``: the paper's coast, the built-in ``coast`` scene (:mod:`pftrack_coast.scene`) through
  ``calib/coast_camera.yaml`` with the preset ``coast-volumes``: the eigenspace model trained on
  the scene's 400 background-only frames; the ``boat`` clip (a 7.5 x 1.8 x 2.3 m boat crossing
  the far volume) and the ``car`` clip (a 1.7 x 1.5 x 4.7 m car through the near volume) give
  Table 1 -- per object the median size of the estimates matched to it, the paper's eq. 10
  (``estimated_m``) and after the support-plane correction (``depth_corrected_m``), as width
  across the view, height, depth along it -- and the entry / exit frame errors; the ``multi``
  clip (two boats and a car) gives ``MOTA_world`` and ``IDF1_world``; ``frames_per_second``
  is over all three clips' CPU time, ``frames_per_second_boat_clip`` the boat clip's and
  ``frames_per_second_3x5000`` that of the frames of the three clips with exactly 3 groups
  (the two detection groups and one intruder) of 5000 particles, against which the speed goal
  is checked (the best of ``--speed-runs`` runs of the three clips, as for PETS). Matches on
  the coast are
  within 20 m (``COAST_MATCH_M``: a block spans tens of metres of sea along the line of sight).

Tracking parameters were chosen on frames 201-400 (``--frames 201:400``); the identity ones
(``entry.gather_frames``, ``exit.frames``, ``merge.speed_m``, ``reid.frames``,
``reid.distance_m``, ``mask.colour_share``) on frames 401-600, the first half of the test
frames: 601-795 alone (``--frames 601:795``) are unseen.
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pftrack_bench.protocol import Protocol

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="PETS 2009 S2.L1 with its Tsai camera and the walkway cuboid; the built-in "
         "coast scene through its camera",
    chosen_on="PETS frames 1-400 train the eigenspace model; tracking parameters on "
              "frames 201-400, the identity ones on 401-600",
    reported_on="PETS frames as in args (default 401-795; 601-795 alone chose "
                "nothing), the coast scene's boat, car and multi clips",
)


#: a person's size (width across the view, height, depth along the view), metres
PERSON_M = (0.5, 1.75, 0.5)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--data", default=None,
                        help="folder holding pets09/ (default: $PFTRACK_DATA or ../shared/data)")
    parser.add_argument("--parts", default="pets09,coast", help="pets09, coast (default both)")
    parser.add_argument("--config", default="pets09-volume",
                        help="PETS configuration: preset name or YAML (default pets09-volume)")
    parser.add_argument("--frames", default="401:795", metavar="A:B",
                        help="PETS test frames, ground-truth numbering (default 401:795)")
    parser.add_argument("--coast-config", default="coast-volumes",
                        help="coast configuration: preset name or YAML (default coast-volumes)")
    parser.add_argument("--scene-seed", type=int, default=3,
                        help="seed of the coast scene (default 3)")
    parser.add_argument("--model", default=None,
                        help="eigenspace model (.npz) to use instead of training one")
    parser.add_argument("--particles", type=int, default=None,
                        help="particles per group (default: the preset's, 5000)")
    parser.add_argument("--seed", type=int, default=0, help="tracking seed (default 0)")
    parser.add_argument("--no-mog2", action="store_true", help="skip the MOG2 comparison")
    parser.add_argument("--speed-runs", type=int, default=3, metavar="N",
                        help="track the PETS frames and the coast clips N times (the same "
                             "seed: the same tracks, checked) and give the speed goal's "
                             "figure as the best of the N (default 3; 1: one run)")
    parser.add_argument("--images", default=None, metavar="DIR",
                        help="write the report pictures here: the PETS frame 160 frames into "
                             "the test (particles, corrected cuboids, the volume), a 3-D view "
                             "of the particle clouds in the volume, the top view of the tracks")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


def track_frames(cfg: dict[str, Any], frames: list[Any], camera: Camera, seed: int,
           model: str | None, fit_frames: Any = None,
           snapshot: tuple[int, Any] | None = None) -> dict[str, Any]:
    """Run the configuration over ``frames``: MOT rows, the track manager, timings
    (``fit_frames``: images the likelihood's ``fit`` is shown first, untimed; ``snapshot``:
    ``(frame, f(engine, frame))`` called after that frame, its time not counted)."""
    from pftrack.engine.runner import FrameStep, run_frames
    from pftrack.workflows.pipeline import build_engine

    engine = build_engine(cfg, camera=camera, fps=7.0, seed=seed, detector_model=model)
    if fit_frames is not None:
        engine.likelihood.fit(fit_frames)
    frame_targets: list[int] = []  # per frame: the live targets it weighted

    def count_targets(step: FrameStep) -> None:
        frame_targets.append(len(step.engine.targets))

    def draw_snapshot(step: FrameStep) -> None:
        if snapshot is not None and step.frame.index == snapshot[0]:
            snapshot[1](step.engine, step.frame)

    # one OpenCV thread: the figures are one core's
    loop = run_frames(engine, frames, before_step={"targets": count_targets},
                      after_step={"snapshot": draw_snapshot} if snapshot else None,
                      cv2_threads=1)
    return {"rows": loop.rows(), "records": loop.records, "tracks": engine.tracks,
            "wall_s": loop.loop_s, "cpu_s": loop.loop_cpu_s, "frames": len(frames),
            "frame_cpu_s": loop.frame_tracking_cpu_s,
            "frame_targets": np.array(frame_targets, dtype=int),
            "n_particles": int(engine.n_particles)}


#: the speed goal's configuration: this many particle groups (detection groups and tracks)
GOAL_GROUPS = 3
#: ... of this many particles each
GOAL_PARTICLES = 5000


def speed_3x5000(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Frames per second of CPU time over the frames of ``runs`` that weighted exactly
    ``GOAL_GROUPS`` particle groups of ``GOAL_PARTICLES`` particles (the issue's speed goal's
    configuration; background scoring, estimates and track management included; a frame's
    groups are those alive when it starts)."""
    cpu = frames = 0.0
    for r in runs:
        if r["n_particles"] != GOAL_PARTICLES:
            continue
        sel = r["frame_targets"] == GOAL_GROUPS
        cpu += float(r["frame_cpu_s"][sel].sum())
        frames += int(sel.sum())
    return {"frames_per_second_3x5000": frames / cpu if cpu > 0 else None,
            "frames_3x5000": int(frames)}


def speed_runs(first: list[dict[str, Any]], again: Any, n: int) -> dict[str, Any]:
    """The speed goal's figure over ``n`` runs of the same tracking: ``first`` the runs
    already made (one per clip), ``again()`` makes them once more. Each repeat must give the
    same rows (the same seed: the same tracks; a difference raises). ``frames_per_second_3x5000``
    is the best of the ``n`` (the convention of Python's ``timeit``: the code's time is the
    least it took, the rest is what the host took from it), each one in
    ``frames_per_second_3x5000_runs``."""
    figures = [speed_3x5000(first)]
    for _ in range(max(int(n), 1) - 1):
        runs = again()
        for a, b in zip(first, runs):
            if a["rows"].shape != b["rows"].shape or not np.array_equal(a["rows"], b["rows"],
                                                                        equal_nan=True):
                raise RuntimeError("coast: a repeated run gave other tracks (the tracking "
                                   "is not deterministic for a seed)")
        figures.append(speed_3x5000(runs))
    fps = [f["frames_per_second_3x5000"] for f in figures]
    known = [f for f in fps if f is not None]
    return {"frames_per_second_3x5000": max(known) if known else None,
            "frames_per_second_3x5000_runs": fps,
            "frames_3x5000": figures[0]["frames_3x5000"]}


def _inside(volume: Any, gt: np.ndarray) -> np.ndarray:
    """Ground-truth rows whose world foot point lies in the volume's footprint."""
    p = np.column_stack([gt[:, 7], gt[:, 8], np.full(len(gt), float(volume.center_m[2]))])
    return volume.contains(p)


def _frame_pairs(gt: np.ndarray, rows: np.ndarray, max_m: float = 1.0
                 ) -> list[tuple[int, int]]:
    """(gt row, track row) index pairs matched per frame within ``max_m`` on the ground."""
    from scipy.optimize import linear_sum_assignment

    out = []
    tf = rows[:, 0].astype(int)
    gf = gt[:, 0].astype(int)
    for f in np.unique(gf):
        gi = np.flatnonzero(gf == f)
        ti = np.flatnonzero(tf == f)
        if not len(ti):
            continue
        d = np.hypot(gt[gi, 7][:, None] - rows[ti, 7][None], gt[gi, 8][:, None] - rows[ti, 8][None])
        r, c = linear_sum_assignment(np.where(d <= max_m, d, 1e6))
        for a, b in zip(r, c):
            if d[a, b] <= max_m:
                out.append((int(gi[a]), int(ti[b])))
    return out


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def score_pets(gt: np.ndarray, run: dict[str, Any], volume: Any) -> dict[str, Any]:
    """The figures of one PETS run (see the module docstring)."""
    from pftrack.metrics import evaluate

    rows = run["rows"]
    out: dict[str, Any] = {}
    mi = evaluate(gt, rows, metric="iou", threshold=0.5)
    mw = evaluate(gt, rows, metric="world", threshold=1.0)
    out.update(MOTA=mi["MOTA"], IDF1=mi["IDF1"], HOTA=mi["HOTA"], MOTA_world=mw["MOTA"],
               IDF1_world=mw["IDF1"], HOTA_world=mw["HOTA"], IDSW_world=mw["IDSW"],
               FP_world=mw["FP"], FN_world=mw["FN"], tracks=int(len(np.unique(rows[:, 1])))
               if len(rows) else 0)
    pairs = _frame_pairs(gt, rows)
    gi, ti = np.array(pairs, dtype=np.intp).reshape(-1, 2).T
    err = np.hypot(gt[gi, 7] - rows[ti, 7], gt[gi, 8] - rows[ti, 8])
    out["median_error_m"] = float(np.median(err)) if len(err) else float("nan")
    # entry and exit: per person, the first and last frame some track is matched to them
    # (within 1 m) against the first and last frame the ground truth has them in the volume
    inside = gt[_inside(volume, gt)]
    matched: dict[int, list[int]] = {}
    for g, _ in pairs:
        matched.setdefault(int(gt[g, 1]), []).append(int(gt[g, 0]))
    entry, exit_, both = [], [], []
    for pid in np.unique(inside[:, 1]).astype(int):
        g = inside[inside[:, 1] == pid, 0]
        m = matched.get(pid)
        if not m:
            entry.append(np.inf)
            exit_.append(np.inf)
        else:
            entry.append(abs(float(min(m)) - float(g.min())))
            exit_.append(abs(float(max(m)) - float(g.max())))
        both.append(entry[-1] <= 10 and exit_[-1] <= 10)
    # a person never matched counts as an infinite error (reported as null when the median is)
    out["entry_error_frames"] = _finite(np.median(entry)) if entry else None
    out["exit_error_frames"] = _finite(np.median(exit_)) if exit_ else None
    out["entry_exit_within_10"] = float(np.mean(both)) if both else float("nan")
    out["people_in_volume"] = len(both)
    # size per axis, after and before the correction, over estimates matched within 1 m
    est = {(e["frame"], e["id"]): e for e in run["tracks"].estimates_}
    truth = np.array(PERSON_M)
    after, before = [], []
    for _, t in pairs:
        e = est.get((int(rows[t, 0]), int(rows[t, 1])))
        if e is None or "size_m" not in e:
            continue
        after.append(np.abs(e["size_m"] - truth))
        before.append(np.abs(e["size_raw_m"] - truth))
    # estimates are (across, height, along): x = across, y = along, z = height
    for key, vals in (("size_error_m", after), ("size_error_raw_m", before)):
        med = np.median(np.array(vals), axis=0) if vals else np.full(3, np.nan)
        out[key] = {"x": float(med[0]), "y": float(med[2]), "z": float(med[1])}
    out["frames_per_second"] = run["frames"] / max(run["wall_s"], 1e-12)
    out["frames_per_second_cpu"] = run["frames"] / max(run["cpu_s"], 1e-12)
    return out


def _pets09(args: argparse.Namespace, root: Path, say: Any) -> dict[str, Any]:
    import tempfile

    from pftrack.geometry.formats import load_camera
    from pftrack.geometry.volumes import resolve_volume
    from pftrack.io.data import pets09_files
    from pftrack.io.frames import parse_frames
    from pftrack.workflows.pipeline import (
        iter_frames,
        load_config,
        read_ground_truth,
        train_detector,
    )

    video, gt_path, cam_path = pets09_files(root)
    cfg = load_config(args.config)
    if args.particles is not None:
        cfg["tracker"] = {**cfg["tracker"], "n_particles": int(args.particles)}
    first, last = parse_frames(args.frames)
    camera = load_camera(cam_path)
    volume = resolve_volume(cfg["tracks"]["params"]["volumes"])
    model = args.model
    tmp = None
    if model is None:
        say("coast: training the eigenspace model on frames 1-400")
        tmp = tempfile.TemporaryDirectory(prefix="pftrack-coast-")
        model = str(Path(tmp.name) / "eigenspace.npz")
        train_detector(video, gt_path, cfg["detector"]["train"]["frames"], out=model, cfg=cfg,
                       camera=camera)
    try:
        frames = list(iter_frames(video, first, last))
        gt = read_ground_truth(gt_path, first, last)
        t0 = time.perf_counter()
        say(f"coast: pets09 eigenspace, frames {first}-{last}")
        snap = None
        if args.images:
            at = min(max(first + 160, first), last if last is not None else first + 160)
            snap = (at, lambda engine, frame: pets_images(Path(args.images), engine, frame,
                                                           camera, volume))
        run = track_frames(cfg, frames, camera, args.seed, model, snapshot=snap)
        if args.images:
            pets_topview(Path(args.images), run, gt, volume)
        decode = time.perf_counter() - t0 - run["wall_s"]
        out = score_pets(gt, run, volume)
        out["frames_per_second_with_decoding"] = run["frames"] / (run["wall_s"] + max(decode, 0))
        if args.speed_runs > 1:
            say(f"coast: pets09 eigenspace again for its speed ({args.speed_runs - 1} more)")
        out.update(speed_runs([run], lambda: [track_frames(cfg, frames, camera, args.seed,
                                                           model)], args.speed_runs))
        if not args.no_mog2:
            say("coast: pets09 mog2-fraction")
            a, b = parse_frames(cfg["detector"]["train"]["frames"])
            mcfg = copy.deepcopy(cfg)
            mcfg["likelihood"] = {"type": "mog2-fraction", "params": {
                "block_size": int(cfg["detector"]["params"].get("block_size", 8))}}
            run2 = track_frames(mcfg, frames, camera, args.seed, model,
                          fit_frames=(f.image for f in iter_frames(video, a, b)))
            out["mog2"] = score_pets(gt, run2, volume)
        out["setup"] = {"frames": f"{first}:{last}", "train_frames": cfg["detector"]["train"][
            "frames"], "particles_per_group": int(cfg["tracker"]["n_particles"]),
            "volume": volume.to_dict(), "seed": args.seed,
            "tuned_on": "frames 201:400 (tracking parameters); entry.gather_frames, "
                        "exit.frames, merge.speed_m, reid.frames, reid.distance_m, "
                        "mask.colour_share on 401:600"}
    finally:
        if tmp is not None:
            tmp.cleanup()
    return out


def pets_images(folder: Path, engine: Any, frame: Any, camera: Camera, volume: Any) -> None:
    """The frame with particles and corrected cuboids (the coastal paper's figs. 2-3), and the
    particle clouds in the volume in 3-D (off-screen)."""
    from pftrack.geometry.clouds import ParticleCloud
    from pftrack.io.images import write_png
    from pftrack.render.view3d import render_view3d
    from pftrack_coast.report import intruders_image

    folder.mkdir(parents=True, exist_ok=True)
    img = intruders_image(frame.image, camera, [volume], engine, engine.tracks.estimates_,
                          frame.index)
    write_png(folder / "pets09_volume_frame.png", img)
    groups = engine.tracks.groups_
    clouds = []
    for t in engine.targets:
        w = np.full(len(t.particles), 0.2 if t.id in groups else 1.0)
        clouds.append(ParticleCloud(t.particles[:, :3], w))
    render_view3d(folder / "pets09_volume_3d.png", volumes=[volume], clouds=clouds,
                  cameras=[camera],
                  title=f"PETS frame {frame.index}: group (dark), people (bright)")


def pets_topview(folder: Path, run: dict[str, Any], gt: np.ndarray, volume: Any) -> None:
    """Footprint trajectories against the ground truth's, with the volume, from above."""
    from pftrack.render.topview import render_topview

    rows = run["rows"]
    tracks = {int(i): rows[rows[:, 1] == i][:, 7:10] for i in np.unique(rows[:, 1])}
    truth = {int(i): gt[gt[:, 1] == i][:, 7:10] for i in np.unique(gt[:, 1])}
    render_topview(folder / "pets09_volume_topview.png", tracks=tracks, ground_truth=truth,
                   volume=volume, title="PETS09 S2.L1: volume tracks' footprints")


#: world match distance on the coast (m): an 8 px block spans about 35 m of sea along the line
#: of sight at 230 m (a pixel about 4.4 m), so footprints there are no better than tens of metres
COAST_MATCH_M = 20.0


def coast_clip(clip: str, cfg: dict[str, Any], model: str, seed: int, scene_seed: int,
                ) -> dict[str, Any]:
    from pftrack_coast.scene import CoastScene

    scene = CoastScene(seed=scene_seed, clip=clip).prepare()
    frames = list(scene.frames())
    run = track_frames(cfg, frames, scene.camera_, seed, model)
    return {"scene": scene, "run": run, "gt": scene.ground_truth(), "frames": frames}


def coast_objects(res: dict[str, Any]) -> list[dict[str, Any]]:
    """Per object of a clip: the sizes (eq. 10 and corrected) of the estimates matched to it
    within COAST_MATCH_M, and its entry / exit frame errors."""
    gt, rows, scene = res["gt"], res["run"]["rows"], res["scene"]
    est = {(e["frame"], e["id"]): e for e in res["run"]["tracks"].estimates_}
    pairs = _frame_pairs(gt, rows, max_m=COAST_MATCH_M) if len(rows) else []
    out = []
    events = scene.volume_events()
    for obj in scene.objects():
        oid = int(obj.id)
        mine = [(g, t) for g, t in pairs if int(gt[g, 1]) == oid]
        raw, corr = [], []
        for _, t in mine:
            e = est.get((int(rows[t, 0]), int(rows[t, 1])))
            if e is not None and "size_m" in e:
                raw.append(e["size_raw_m"])
                corr.append(e["size_m"])
        first, last, volume = events[oid]
        frames = [int(gt[g, 0]) for g, _ in mine]
        entry = abs(min(frames) - first) if frames and first is not None else None
        exit_ = abs(max(frames) - last) if frames and last is not None else None
        # sizes as (width across the view, height, depth along the view)
        out.append({"object": str(obj.kind), "volume": volume,
                    "real_m": [float(x) for x in obj.size_m],
                    "estimated_m": [float(x) for x in np.median(raw, axis=0)] if raw else None,
                    "depth_corrected_m": [float(x) for x in np.median(corr, axis=0)]
                    if corr else None,
                    "frames_matched": len(mine),
                    "entry_error_frames": None if entry is None else float(entry),
                    "exit_error_frames": None if exit_ is None else float(exit_),
                    "first_inside": first,
                    "last_inside": last})
    return out


def _coast(args: argparse.Namespace, say: Any) -> dict[str, Any]:
    import tempfile
    import warnings

    from pftrack.metrics import evaluate
    from pftrack.workflows.pipeline import load_config
    from pftrack_coast.eigenspace import BlockEigenspaceModel
    from pftrack_coast.scene import CoastScene

    cfg = load_config(args.coast_config)
    if args.particles is not None:
        cfg["tracker"] = {**cfg["tracker"], "n_particles": int(args.particles)}
    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="pftrack-coast-coast-") as tmp:
        model = str(Path(tmp) / "coast.npz")
        say("coast: coast, training the eigenspace model on the 400 background frames")
        bs = int(cfg["detector"]["params"].get("block_size", 8))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # untrained blocks borrow; counted in the model
            BlockEigenspaceModel(block_size=bs).fit(
                f.image for f in CoastScene(seed=args.scene_seed).training_frames()).save(model)
        table, entry, exit_ = [], [], []
        seconds = frames = 0.0
        runs, clips = [], []
        for clip in ("boat", "car"):
            say(f"coast: coast, clip {clip}")
            res = coast_clip(clip, cfg, model, args.seed, args.scene_seed)
            runs.append(res["run"])
            clips.append(res)
            seconds += res["run"]["cpu_s"]
            frames += res["run"]["frames"]
            if clip == "boat":
                out["frames_per_second_boat_clip"] = res["run"]["frames"] / max(
                    res["run"]["cpu_s"], 1e-12)
            for o in coast_objects(res):
                table.append(o)
                entry.append(o["entry_error_frames"])
                exit_.append(o["exit_error_frames"])
        out["table1"] = table
        # objects never found have no error (None); the medians are over those found
        found_e = [e for e in entry if e is not None]
        found_x = [e for e in exit_ if e is not None]
        out["entry_error_frames"] = float(np.median(found_e)) if found_e else None
        out["exit_error_frames"] = float(np.median(found_x)) if found_x else None
        out["objects_found"] = f"{len(found_e)} of {len(entry)}"
        say("coast: coast, clip multi")
        res = coast_clip("multi", cfg, model, args.seed, args.scene_seed)
        runs.append(res["run"])
        clips.append(res)
        seconds += res["run"]["cpu_s"]
        frames += res["run"]["frames"]
        rows = res["run"]["rows"]
        m = evaluate(res["gt"], rows, metric="world", threshold=COAST_MATCH_M)
        out["multi"] = {"MOTA_world": m["MOTA"], "IDF1_world": m["IDF1"], "IDSW": m["IDSW"],
                        "FP": m["FP"], "FN": m["FN"], "objects": coast_objects(res),
                        "match_m": COAST_MATCH_M}
        out["frames_per_second"] = frames / max(seconds, 1e-12)
        if args.speed_runs > 1:
            say(f"coast: coast clips again for their speed ({args.speed_runs - 1} more)")
        out.update(speed_runs(runs, lambda: [
            track_frames(cfg, c["frames"], c["scene"].camera_, args.seed, model)
            for c in clips], args.speed_runs))
        out["setup"] = {"scene_seed": args.scene_seed, "seed": args.seed,
                        "particles_per_group": int(cfg["tracker"]["n_particles"]),
                        "match_m": COAST_MATCH_M, "config": str(args.coast_config),
                        "frames_per_second": "CPU time of tracking (scoring included), all "
                                             "clips; the boat clip alone has 3 groups most of "
                                             "the time (2 detection groups, 1 track)"}
    return out


def run(args: argparse.Namespace) -> dict[str, Any]:
    from pftrack.io.data import data_dir

    if int(args.speed_runs) < 1:
        raise ValueError(f"pftrack bench coast: --speed-runs must be >= 1, got "
                         f"{args.speed_runs!r}")
    root = Path(args.data) if args.data else data_dir()
    parts = [p.strip() for p in args.parts.split(",") if p.strip()]
    bad = set(parts) - {"pets09", "coast"}
    if bad:
        raise ValueError(f"--parts: unknown {sorted(bad)}; known: pets09, coast")
    say = (lambda s: None) if args.quiet else (lambda s: print(s, file=sys.stderr, flush=True))
    out: dict[str, Any] = {}
    if "pets09" in parts:
        out["pets09"] = _pets09(args, root, say)
    if "coast" in parts:
        out["coast"] = _coast(args, say)
    out["goals"] = _goals(out)
    return out


#: why a goal is not met, as measured (said in the output, not hidden)
WHY_NOT = {
    "pets09 IDF1_world >= 0.6": "from frame 600 on people walk in groups of two to four: two "
    "live tracks on neighbours swap where their colours do not tell them apart "
    "(mask.colour_share needs templates far enough apart), and a track merged into "
    "its neighbour's comes back under another id unless it is found again within "
    "reid.frames and reid.distance_m",
    "pets09 entry and exit within 10 frames for >= 80 % of people": "a person first found "
    "late, or lost before leaving, is outside",
    "pets09 frames_per_second_3x5000 >= 100": "the frames with 3 groups (one detection group, "
    "two people) of 5000 particles, best of --speed-runs runs: each person's estimates "
    "(support plane, quantiles, cuboids) and the entry candidate's checks take about half a "
    "frame, block scoring (memory-bound on the whitening matrices when a respread detection "
    "group scores the whole frame) a fifth, projecting and resampling the rest; the host's "
    "speed moves by up to 40 % between runs",
    "coast depth error < 2 m (car)": "the car drives along the line of sight: its heading "
    "comes from the travel of its particle cloud's top (its foot is held at the near volume's "
    "face until it is inside), over a few frames in a 10 m deep volume where one 8-px block "
    "row is about 6 m of ground; a wrong or late heading lays its length across the view",
    "coast frames_per_second_3x5000 >= 100": "the frames with 3 groups (two detection groups, "
    "one intruder) of 5000 particles, on a shared, loaded machine",
}


def _speed_goal(part: str, r: dict[str, Any]) -> tuple[str, Any, bool]:
    """The speed goal (3 groups of 5000 particles, 768x576, one core: >= 100 frames per
    second) against ``frames_per_second_3x5000`` of a part (not met when no frame had exactly
    3 groups)."""
    fps = r.get("frames_per_second_3x5000")
    return (f"{part} frames_per_second_3x5000 >= 100", fps, fps is not None and fps >= 100)


def _goals(out: dict[str, Any]) -> list[dict[str, Any]]:
    """Each goal of the issue with its measured value, met or not, and why not."""
    rows: list[tuple[str, Any, bool]] = []
    p = out.get("pets09")
    if p:
        rows += [("pets09 MOTA_world >= 0.6", p["MOTA_world"], p["MOTA_world"] >= 0.6),
                 ("pets09 IDF1_world >= 0.6", p["IDF1_world"], p["IDF1_world"] >= 0.6),
                 ("pets09 entry and exit within 10 frames for >= 80 % of people",
                  p["entry_exit_within_10"], p["entry_exit_within_10"] >= 0.8),
                 ("pets09 eigenspace better than mog2-fraction (MOTA_world)",
                  p.get("mog2", {}).get("MOTA_world"),
                  "mog2" in p and p["MOTA_world"] > p["mog2"]["MOTA_world"]),
                 _speed_goal("pets09", p)]
    c = out.get("coast")
    if c:
        for o in c["table1"]:
            corr = o["depth_corrected_m"]
            err = None if corr is None else abs(corr[2] - o["real_m"][2])
            rows.append((f"coast depth error < 2 m ({o['object']})", err,
                         err is not None and err < 2.0))
        rows.append(_speed_goal("coast", c))
    return [{"goal": g, "value": v, "met": bool(m), **({} if m else
             {"why_not": WHY_NOT.get(g, "not met as measured")})} for g, v, m in rows]


def format_table(result: dict[str, Any]) -> str:
    lines = ["The coastal paper: intruders in 3-D volumes (no detector)"]
    p = result.get("pets09")
    if p:
        def row(name: str, r: dict[str, Any]) -> str:
            s, s0 = r["size_error_m"], r["size_error_raw_m"]
            return (f"  {name:<11} MOTA {r['MOTA']:.3f} IDF1 {r['IDF1']:.3f} HOTA {r['HOTA']:.3f}"
                    f" | world MOTA {r['MOTA_world']:.3f} IDF1 {r['IDF1_world']:.3f} HOTA "
                    f"{r['HOTA_world']:.3f} median {r['median_error_m']:.2f} m | entry "
                    f"{r['entry_error_frames']} exit {r['exit_error_frames']} frames, "
                    f"{100 * r['entry_exit_within_10']:.0f}% within 10 | size error x/y/z "
                    f"{s['x']:.2f}/{s['y']:.2f}/{s['z']:.2f} m (eq. 10: {s0['x']:.2f}/"
                    f"{s0['y']:.2f}/{s0['z']:.2f}) | {r['frames_per_second']:.1f} fps")
        lines.append(f"PETS 2009 S2.L1 frames {p['setup']['frames']}:")
        lines.append(row("eigenspace", p))
        if "mog2" in p:
            lines.append(row("mog2", p["mog2"]))
    c = result.get("coast")
    if c:
        def fmt(v: Any) -> str:
            return "-" if v is None else "x".join(f"{x:.1f}" for x in v)

        lines.append("coast (Table 1: width across x height x depth along the view, m):")
        for o in c["table1"]:
            lines.append(f"  {o['object']:<5} real {fmt(o['real_m'])}  eq. 10 "
                         f"{fmt(o['estimated_m'])}  corrected {fmt(o['depth_corrected_m'])}  "
                         f"entry {o['entry_error_frames']} exit "
                         f"{o['exit_error_frames']} frames")
        mm = c["multi"]
        lines.append(f"  multi: MOTA_world {mm['MOTA_world']:.3f} IDF1_world "
                     f"{mm['IDF1_world']:.3f} (match {mm['match_m']:.0f} m) | "
                     f"{c['frames_per_second']:.1f} fps (CPU)")
    for g in result.get("goals", []):
        v = g["value"]
        val = f"{v:.3f}" if isinstance(v, float) else str(v)
        lines.append(f"  [{'met' if g['met'] else 'NOT met'}] {g['goal']}: {val}"
                     + ("" if g["met"] else f" -- {g['why_not']}"))
    return "\n".join(lines)
