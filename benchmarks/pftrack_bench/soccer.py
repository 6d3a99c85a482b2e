"""The soccer paper on the soccer scene: 22 real player trajectories, MOTA, IDF1, HOTA, error, fps.

``pftrack bench soccer --json`` renders the ``soccer`` scene (Hawk-Eye trajectories from kloppy's
sample files, the soccer paper's camera, 1280 x 720), tracks every player for ``--duration-s``
seconds with the ``soccer-ground`` preset (the soccer paper's ground-plane particle filter) and
reports:

* ``MOTA``, ``IDF1``, ``HOTA``, ``median_error_m``, ``p90_error_m``: exactly as
  ``pets09-ground`` reports them (:func:`pftrack.workflows.pipeline.evaluate_tracks`): image boxes
  matched at IoU 0.5, and the ground-plane distance (metres) of IoU-matched pairs. The players are
  only ~8-14 px tall, so IoU 0.5 is a pixel-level criterion here;
* ``MOTA_world``, ``IDF1_world``, ``HOTA_world``: the same scores on the ground plane, a match
  within ``--threshold-m`` metres (default 1 m, TrackEval's position-only convention; with this
  camera one pixel of foot height is 0.5-1.8 m of depth, so 1 m is strict at the far side);
  ``median_error_m_by_id`` / ``p90_error_m_by_id``: distance of every track row to the player
  its track follows (IDF1-optimal id map), lost tracks included;
* ``accuracy_5px``: the soccer paper's sec. 4.1, per player the fraction of frames whose estimated
  foot point lies within 5 px of the true one, averaged over players;
* ``detection_s_per_frame``, ``tracking_s_per_frame``, ``frames_per_second``: wall time of the
  detector and of the tracker per frame, and ``1 / (their sum)``. Rendering is excluded: each
  frame is drawn first, untimed, then detected and tracked under ``time.perf_counter``. OpenCV
  runs on one thread (``cv2.setNumThreads(1)``).

Before play, the detector learns the background from ``--background-frames`` frames of the empty
pitch (a fixed camera can film it before kick-off; untimed). Targets start from the ground truth
of the first frame (``--init gt``, the default: the paper
starts its filters by hand) or from detections (``--init detections``: the session's
confirmed-detection births, with no ground truth used at all).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from typing import Any

from pftrack_bench.protocol import Protocol

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="the built-in soccer scene (real player trajectories rendered through the "
         "paper's camera)",
    chosen_on="the scene's own settings (see the soccer-ground preset)",
    reported_on="the clip the benchmark renders",
)


KEYS = ("MOTA", "IDF1", "HOTA", "median_error_m", "p90_error_m", "accuracy_5px",
        "detection_s_per_frame", "tracking_s_per_frame", "frames_per_second", "players",
        "particles")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--preset", default="soccer-ground",
                        help="tracking configuration: a preset name or a YAML file "
                             "(default soccer-ground)")
    parser.add_argument("--source", default="hawkeye", help="trajectory source (default hawkeye)")
    parser.add_argument("--start-s", type=float, default=0.0, help="clip start, s")
    parser.add_argument("--duration-s", type=float, default=20.0, help="clip length, s "
                        "(default 20)")
    parser.add_argument("--fps", type=float, default=25.0, help="video frame rate (default 25)")
    parser.add_argument("--scene-seed", type=int, default=0, help="scene seed (default 0)")
    parser.add_argument("--seed", type=int, default=0, help="tracker seed (default 0)")
    parser.add_argument("--camera", default=None, help="camera file (default the plugin's soccer "
                        "camera, pftrack_world/data/soccer_camera.yaml)")
    parser.add_argument("--particles", type=int, default=None,
                        help="particles per player (default: the preset's, 300)")
    parser.add_argument("--background-frames", type=int, default=25,
                        help="frames of the empty pitch the detector learns the background from "
                             "before play, untimed (0: it learns from the clip itself)")
    parser.add_argument("--init", choices=("gt", "detections"), default="gt",
                        help="start targets from first-frame ground truth or from detections")
    parser.add_argument("--no-births", action="store_true",
                        help="never start targets from detections (with --init gt: only the "
                             "first frame's players are tracked, lost ones are not replaced)")
    parser.add_argument("--threshold-m", type=float, default=1.0,
                        help="ground-plane match distance for MOTA/IDF1/HOTA, m (default 1)")
    parser.add_argument("--out-tracks", default=None, help="also write the tracks (MOT CSV)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar on stderr")


def build_detector_for(cfg: dict[str, Any], camera: str | None) -> Any:
    """The preset's detector (``pitch-blob`` falls back to the soccer module's class when no
    plugin registered that name)."""
    from pftrack.host import UnknownComponentError, get_host
    from pftrack.workflows.pipeline import build_detector

    spec = cfg.get("detector")
    if not spec:
        raise ValueError(f"config {cfg.get('_source', '')}: the soccer bench needs a detector")
    try:
        get_host().get("detector", spec["type"])
    except UnknownComponentError:
        if spec["type"] != "pitch-blob":
            raise
        from pftrack_world.soccer import PitchBlobDetector

        det = PitchBlobDetector(**dict(spec.get("params") or {}))
    else:
        det = build_detector(cfg)
    if "camera" in det.get_params() and det.get_params()["camera"] is None and camera:
        det.set_params(camera=camera)
    return det


def _load_preset(spec: str) -> dict[str, Any]:
    """``load_config``, falling back on the preset files shipped in ``pftrack/presets`` when no
    plugin registered that name."""
    from importlib import resources

    from pftrack.workflows.pipeline import load_config

    try:
        return load_config(spec)
    except FileNotFoundError:
        shipped = resources.files("pftrack") / "presets" / f"{spec}.yaml"
        if not shipped.is_file():
            raise
        return load_config(str(shipped))


@dataclass
class SoccerRun:
    """What :func:`track_scene` produced.

    Attributes
    ----------
    scene : SoccerScene
        The prepared scene (camera, pitch, trajectories).
    gt : ndarray, shape (M, 10)
        Ground truth (MOTChallenge rows, boxes in pixels, x, y in metres).
    rows : ndarray, shape (R, 10)
        Tracks, sorted by frame and id (world columns filled).
    timing : dict
        ``detection_s_per_frame``, ``tracking_s_per_frame``, ``frames_per_second``, ``frames``.
    clouds : dict of int to ParticleCloud
        Every target's particles (world metres, labels = track ids) after the frames asked for,
        weighted by that frame's likelihood (best particle of each target: 1).
    images : dict of int to ndarray
        The frames asked for (BGR).
    particles : int
        Particles per target.
    """

    scene: Any
    gt: Any
    rows: Any
    timing: dict[str, float]
    clouds: dict[int, Any] = field(default_factory=dict)
    images: dict[int, Any] = field(default_factory=dict)
    particles: int = 0


def track_scene(scene: Any, preset: str | dict[str, Any] = "soccer-ground", *, seed: int = 0,
                particles: int | None = None, init: str = "gt", births: bool = True,
                background_frames: int = 25, camera: str | None = None,
                keep_frames: tuple[int, ...] = (), progress: bool = False) -> SoccerRun:
    """Track every player of a soccer scene with a preset; time detection and tracking only.

    Parameters
    ----------
    scene : SoccerScene
    preset : str or dict
        Preset name, YAML path or configuration dict.
    seed : int
        Tracker seed.
    particles : int, optional
        Overrides the preset's ``n_particles``.
    init : {"gt", "detections"}
        Start from the first frame's ground truth (the players added before the first step,
        untimed), or from detections only.
    births : bool
        Keep the preset's births (start targets for players nobody tracks).
    background_frames : int
        Frames of the empty pitch the detector learns the background from (untimed).
    camera : str, optional
        Camera file for the detector (default: the project's soccer camera).
    keep_frames : tuple of int
        Frames (1-based) whose image and particle clouds are kept.
    progress : bool
        A progress bar on stderr.
    """
    from pftrack.engine.runner import FrameStep, run_frames
    from pftrack.geometry.clouds import ParticleCloud
    from pftrack.workflows.pipeline import build_engine

    if init not in ("gt", "detections"):
        raise ValueError(f"init must be 'gt' or 'detections', got {init!r}")
    cfg = dict(preset) if isinstance(preset, dict) else _load_preset(preset)
    if particles is not None:
        if int(particles) < 1:
            raise ValueError(f"particles must be >= 1, got {particles}")
        cfg["tracker"] = {**(cfg.get("tracker") or {}), "n_particles": int(particles)}
    if not births:
        spec = cfg.get("tracks") or {"type": "confirmed", "params": cfg.pop("births", None)}
        cfg["tracks"] = {"type": spec["type"],
                         "params": {**(spec.get("params") or {}), "min_score": float("inf")}}
    scene.prepare()
    gt = scene.ground_truth()
    engine = build_engine(cfg, camera=scene.camera_, fps=float(scene.fps), seed=seed)
    detector = build_detector_for(cfg, camera if camera is not None else scene.camera)
    if background_frames > 0:
        # the fixed camera films the empty pitch before play: the background is learned there
        detector.fit(list(scene.empty_frames(background_frames)), {})
    first = gt[gt[:, 0] == 1]
    keep_at = {int(k) for k in keep_frames}
    out = SoccerRun(scene, gt, None, {}, particles=int(engine.n_particles))

    def start_players(step: FrameStep) -> None:
        if step.frame.index == 1 and init == "gt":
            for row in first:
                engine.add_target(step.frame, position=row[7:9], target_id=int(row[1]))

    def keep(step: FrameStep) -> None:
        if step.frame.index in keep_at:
            out.images[step.frame.index] = step.frame.image.copy()
            out.clouds[step.frame.index] = _clouds(engine, ParticleCloud)

    # the frames are drawn by the scene as the loop asks for them, outside the timed sections;
    # one OpenCV thread: the figures are one core's
    loop = run_frames(engine, scene.frames(), detector=detector,
                      before_step={"start players": start_players},
                      after_step={"keep frames": keep}, cv2_threads=1,
                      progress="soccer" if progress else False, total=scene.n_frames)
    out.rows = loop.rows()
    n = max(loop.n_frames, 1)
    t_det, t_trk = float(loop.frame_detection_s.sum()), float(loop.frame_tracking_s.sum())
    out.timing = {"detection_s_per_frame": t_det / n, "tracking_s_per_frame": t_trk / n,
                  "frames_per_second": n / max(t_det + t_trk, 1e-12), "frames": n}
    return out


def _clouds(tracker: Any, cloud_cls: Any) -> Any:
    """All targets' particles as one cloud on the ground (z = 0), labels = track ids.

    The tracker has just resampled (equal weights), so each particle is weighted by what this
    frame's likelihood says of it, scaled per target so that its best particle has weight 1.
    """
    import numpy as np

    pts, labels, weights = [], [], []
    for t in tracker.targets:
        if t.particles is None or len(t.particles) == 0:
            continue
        p = np.zeros((len(t.particles), 3))
        p[:, :2] = t.particles[:, :2]
        boxes = tracker.observation.to_boxes(t.particles, t)
        logl = np.asarray(tracker.likelihood.log_likelihood(boxes, t), dtype=np.float64)
        w = np.exp(logl - np.max(logl)) if np.isfinite(np.max(logl)) else np.ones(len(p))
        pts.append(p)
        labels.append(np.full(len(p), t.id))
        weights.append(np.nan_to_num(w))
    if not pts:
        return cloud_cls(np.zeros((0, 3)), np.zeros(0))
    return cloud_cls(np.concatenate(pts), np.concatenate(weights), np.concatenate(labels))


def score_run(run: SoccerRun, threshold_m: float = 1.0) -> dict[str, Any]:
    """The bench's figures for a :class:`SoccerRun` (see the module docstring)."""
    import numpy as np
    from pftrack.metrics import evaluate
    from pftrack.workflows.pipeline import evaluate_tracks

    gt, rows = run.gt, run.rows
    world = evaluate(gt, rows, metric="world", threshold=threshold_m)
    img = evaluate_tracks(gt, rows)
    err = _id_errors(gt, rows, threshold_m)
    return {
        "MOTA": img["MOTA"], "IDF1": img["IDF1"], "HOTA": img["HOTA"],
        "median_error_m": img["median_error_m"], "p90_error_m": img["p90_error_m"],
        "accuracy_5px": img["accuracy_5px"],
        "detection_s_per_frame": run.timing["detection_s_per_frame"],
        "tracking_s_per_frame": run.timing["tracking_s_per_frame"],
        "frames_per_second": run.timing["frames_per_second"],
        "players": len(np.unique(gt[:, 1])),
        "particles": run.particles,
        "metric": "iou", "threshold": 0.5,
        "MOTA_world": world["MOTA"], "IDF1_world": world["IDF1"], "HOTA_world": world["HOTA"],
        "threshold_m": float(threshold_m),
        "median_error_m_by_id": float(np.median(err)) if len(err) else float("nan"),
        "p90_error_m_by_id": float(np.percentile(err, 90)) if len(err) else float("nan"),
        "IDSW": img["IDSW"], "FP": img["FP"], "FN": img["FN"],
        "IDSW_world": world["IDSW"], "FP_world": world["FP"], "FN_world": world["FN"],
        "frames": run.timing["frames"], "fps_video": float(run.scene.fps),
        "source": run.scene.source, "start_s": float(run.scene.start_s),
        "image_size": list(run.scene.camera_.image_size),
        "rendering": "excluded (frames drawn before the timed detector and tracker calls)",
    }


def run(args: argparse.Namespace) -> dict[str, Any]:
    from pftrack_world.soccer import SoccerScene

    scene = SoccerScene(source=args.source, start_s=args.start_s, duration_s=args.duration_s,
                        fps=args.fps, seed=args.scene_seed, camera=args.camera)
    result = track_scene(scene, args.preset, seed=args.seed, particles=args.particles,
                         init=args.init, births=not args.no_births,
                         background_frames=args.background_frames, camera=args.camera,
                         progress=not args.quiet)
    if args.out_tracks:
        from pftrack.io.mot import write_mot

        write_mot(args.out_tracks, result.rows)
    out = score_run(result, args.threshold_m)
    out.update(init=args.init, preset=str(args.preset))
    return out


def _id_errors(gt: Any, rows: Any, threshold_m: float) -> Any:
    """Ground-plane distance (m) of every track row to the player its track follows (the
    IDF1-optimal id map on ground-plane distance); rows of unmapped tracks are left out."""
    import numpy as np
    from pftrack.metrics import match_ids

    if len(rows) == 0:
        return np.zeros(0)
    mapping = match_ids(gt, rows, metric="world", threshold=threshold_m)
    inv = {int(t): int(g) for g, t in mapping.items()}
    key = {(int(f), int(i)): (x, y) for f, i, x, y in gt[:, [0, 1, 7, 8]]}
    errs = []
    for r in rows:
        g = inv.get(int(r[1]))
        if g is None or (int(r[0]), g) not in key:
            continue
        x, y = key[(int(r[0]), g)]
        errs.append(np.hypot(r[7] - x, r[8] - y))
    return np.asarray(errs)


def format_table(result: dict[str, Any]) -> str:
    lines = [(f"soccer ({result['source']}, {result['players']} players, {result['frames']} "
             f"frames at {result['fps_video']:g} fps, {result['particles']} particles, "
             f"init {result['init']})")]
    for k in KEYS[:6]:
        lines.append(f"  {k:<22} {result[k]:.4f}")
    lines.append(f"  {'MOTA/IDF1/HOTA (world)':<22} {result['MOTA_world']:.4f} / "
                 f"{result['IDF1_world']:.4f} / {result['HOTA_world']:.4f} "
                 f"(within {result['threshold_m']:g} m)")
    lines.append(f"  {'detection s/frame':<22} {result['detection_s_per_frame']:.4f}")
    lines.append(f"  {'tracking s/frame':<22} {result['tracking_s_per_frame']:.4f}")
    lines.append(f"  {'frames per second':<22} {result['frames_per_second']:.1f}")
    return "\n".join(lines)


def scores_markdown(result: dict[str, Any]) -> str:
    """A :func:`score_run` result as a Markdown table (for the notebook)."""
    rows = [
        ("MOTA / IDF1 / HOTA (IoU 0.5, as pets09-ground)",
         f"{result['MOTA']:.3f} / {result['IDF1']:.3f} / {result['HOTA']:.3f}"),
        (f"MOTA / IDF1 / HOTA (ground plane, {result['threshold_m']:g} m)",
         (f"{result['MOTA_world']:.3f} / {result['IDF1_world']:.3f} / "
         f"{result['HOTA_world']:.3f}")),
        ("position error, median / p90 (m)",
         f"{result['median_error_m']:.2f} / {result['p90_error_m']:.2f}"),
        ("the soccer paper's accuracy (foot within 5 px)", f"{result['accuracy_5px']:.3f}"),
        ("id switches / FP / FN (IoU)", f"{result['IDSW']} / {result['FP']} / {result['FN']}"),
        ("detection / tracking (ms per frame)",
         (f"{1000 * result['detection_s_per_frame']:.1f} / "
         f"{1000 * result['tracking_s_per_frame']:.1f}")),
        ("frames per second (rendering excluded)", f"{result['frames_per_second']:.1f}"),
        ("players x particles", f"{result['players']} x {result['particles']}"),
        ("frames", f"{result['frames']} at {result['fps_video']:g} fps"),
    ]
    return "\n".join(["| measure | value |", "|---|---|"] + [f"| {a} | {b} |" for a, b in rows])


def zoom_bounds(points_world_m: Any, half_m: float = 15.0) -> Any:
    """A (2, 2) ground rectangle ``[[x0, y0], [x1, y1]]`` of half-size ``half_m`` metres around
    the median of ``points_world_m`` (N, >= 2): a close-up for the top view."""
    import numpy as np

    c = np.median(np.asarray(points_world_m, dtype=np.float64)[:, :2], axis=0)
    return np.array([c - half_m, c + half_m])
