"""From a configuration to tracks, metrics and report pictures: what ``pftrack run`` does.

A configuration (a YAML file, or the name of a preset a plugin registered) names the components
by their registered names; this module builds them through the plugin host, so every component of
a run is replaceable by a third-party plugin::

    name: str                     the run's name (report titles, progress bar)
    description: str              one paragraph: what the configuration tracks and how
    state: world | image          default observation: camera-box (ground plane) or image-box
    observation: {type, params}   a registered observation model (legacy: its parameters only)
    motion: {type, params}        a registered motion model
    likelihood: {type, params}    a registered likelihood (e.g. ``composite``)
    detector: {type, params, train: {frames, params, seed}, detect: true}
                                  ``detect: false``: trained (``pftrack detector train``) and its
                                  model handed to the components (``--detector-model``), not run
                                  per frame (the coastal paper: the eigenspace likelihood's model)
    associator: {type, params}    a registered associator (detections to targets; none: no detector)
    tracks: {type, params}        a registered track manager (default ``confirmed``)
    births: {...}                 legacy: the ``confirmed`` track manager's parameters
    tracker: {...}                engine options (n_particles, max_misses, dt, ...)
    valid_region_m: [x0, x1, y0, y1]   optional ground rectangle (metres) people live in
    detections: FILE              optional MOTChallenge det.txt (relative to the YAML file):
                                  these detections are tracked and the detector is not run
    report: {writer}              the registered report writer of ``report/*.png`` (``tracks``)

Data flow per frame, in the one frame loop :func:`pftrack.engine.runner.run_frames`: video frame ->
detector (timed on its own) -> the one engine,
:meth:`pftrack.engine.tracker.MultiTargetTracker.step` (predict, associate, weight, estimate,
resample, the filter's deaths; then the track manager's births, confirmation and merging) -> track
records -> MOTChallenge rows (world columns filled for ground-plane state, and for image-plane
state when a camera is given: each box's foot point on the ground, :func:`rows_on_ground`).

Frame numbers are the ground truth's (MOTChallenge, 1-based): MOT frame N is video frame N - 1.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pftrack.contracts.components import Detections, Frame, RunContext
from pftrack.engine.tracker import MultiTargetTracker, records_to_mot
from pftrack.io.frames import parse_frames

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera, CameraSpec

__all__ = [
    "DetectionScoreWarning",
    "RunResult",
    "build_detector",
    "build_engine",
    "evaluate_tracks",
    "iter_frames",
    "load_config",
    "parse_frames",
    "read_ground_truth",
    "rows_on_ground",
    "run_pipeline",
    "score_scale_warning",
    "train_detector",
]

CONFIG_KEYS = {"name", "description", "state", "observation", "motion", "likelihood", "detector",
               "associator", "tracker", "tracks", "births", "valid_region_m", "report",
               "detections"}
# what a run owns in its --out folder
RUN_OUTPUTS = ("tracks.txt", "tracks_uncertainty.csv", "metrics.json", "report")
TRACKER_KEYS = {"n_particles", "resampling", "ess_threshold", "dt", "init_spread",
                "recover_spread", "max_misses", "max_misses_s", "min_log_likelihood",
                "kill_out_of_view",
                "detection_proposal", "birth_velocity_spread", "target_size"}


# --------------------------------------------------------------------------------------------
# Configuration
# --------------------------------------------------------------------------------------------


def load_config(spec: str | os.PathLike[str] | dict[str, Any]) -> dict[str, Any]:
    """A run configuration from a dict, a YAML file path, or a registered preset name.

    Raises
    ------
    FileNotFoundError
        ``spec`` is neither an existing file nor a registered preset (the message lists the
        presets).
    ValueError
        The YAML does not parse; :class:`pftrack.host.config.ConfigError` (a ``ValueError``) when
        it does not match the schema or its components' declared parameters (the message
        names the file, each key at fault and what it allows).
    """
    import yaml

    if isinstance(spec, dict):
        cfg = dict(spec)
        where = str(cfg.pop("_source", "config"))
    else:
        path = Path(spec)
        if not path.is_file():
            from pftrack.host import UnknownComponentError, get_host

            host = get_host()
            try:
                path = Path(host.get("preset", str(spec)))
            except UnknownComponentError:
                names = ", ".join(host.names("preset")) or "none"
                raise FileNotFoundError(f"config {spec}: no such file and no preset of that "
                                        f"name (presets: {names})") from None
        where = str(path)
        try:
            cfg = yaml.safe_load(path.read_text())
        except yaml.YAMLError as exc:
            raise ValueError(f"config {where}: not valid YAML: {exc}") from None
        if not isinstance(cfg, dict):
            raise ValueError(f"config {where}: expected a mapping at the top level")  # noqa: TRY004
        if isinstance(cfg.get("detections"), str) and not Path(cfg["detections"]).is_absolute():
            cfg["detections"] = str(path.parent / cfg["detections"])
    from pftrack.host.config import validate_config

    # keys, types, ranges, required sections and component parameters, every problem at once
    validate_config(cfg, source=where)
    cfg["_source"] = where
    return cfg


def seeded_rng(seed: Any, option: str = "seed") -> np.random.Generator:
    """``numpy.random.default_rng(seed)``; a seed it refuses (a negative integer, a float) is a
    :class:`ValueError` naming ``option``."""
    try:
        return np.random.default_rng(seed)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{option} {seed!r}: not a random seed (an integer >= 0): "
                         f"{exc}") from None


# --------------------------------------------------------------------------------------------
# Frames and ground truth
# --------------------------------------------------------------------------------------------


def iter_frames(video: str | os.PathLike[str], first: int = 1, last: int | None = None,
                ) -> Iterator[Frame]:
    """Stream frames ``first..last`` (ground-truth numbering: MOT frame N = video frame N-1),
    numbered from the decoder's position; a gap or a short read is warned
    (:class:`FrameWarning`) when the stream ends."""
    from pftrack.scenes.source import FrameSource

    source = FrameSource(video, first, last)
    yield from source.frames()
    _warn_frames(source.report)


def video_fps(video: str | os.PathLike[str]) -> float:
    from pftrack.scenes.video import VideoScene

    return float(VideoScene(str(video)).fps)


def read_ground_truth(path: str | os.PathLike[str] | np.ndarray, first: int = 1,
                      last: int | None = None) -> np.ndarray:
    """MOT rows (M, 10) of frames ``first..last`` (``path``: a MOTChallenge file, or its rows
    already read)."""
    from pftrack.io.mot import read_mot

    if isinstance(path, np.ndarray):
        rows = np.asarray(path, dtype=np.float64).reshape(-1, 10)
    else:
        rows = read_mot(path, allow_empty=False, what="ground truth")
    keep = rows[:, 0] >= first
    if last is not None:
        keep &= rows[:, 0] <= last
    return rows[keep]


def rows_on_ground(rows: np.ndarray, camera: Camera) -> np.ndarray:
    """MOT rows (M, 10) with their world columns (x, y, z) set to their boxes' foot points
    (bottom centres) back-projected to the ground (z = 0) through ``camera``, metres; rows
    whose foot point does not meet the ground (on or above the horizon) get -1 (no world
    position). A copy; the input is not changed."""
    from pftrack.geometry.boxes import foot_points

    rows = np.array(rows, dtype=np.float64).reshape(-1, 10)  # a copy
    if len(rows):
        pts = camera.image_to_ground(foot_points(rows[:, 2:6]))
        ok = np.all(np.isfinite(pts), axis=1)
        rows[:, 7:10] = np.where(ok[:, None], pts, -1.0)
    return rows


def ground_truth_in_camera_frame(gt_rows: np.ndarray, camera: Camera) -> np.ndarray:
    """MOT ground-truth rows with their world columns replaced by their boxes' foot points
    on the ground through ``camera`` (:func:`rows_on_ground`): a camera estimated from the
    video has a world frame of its own (origin under it, axes from its view), so the ground
    truth's world columns, in the frame of whoever surveyed the scene, cannot be compared with
    its tracks; the rows carried to its frame can."""
    return rows_on_ground(gt_rows, camera)


# --------------------------------------------------------------------------------------------
# Detector
# --------------------------------------------------------------------------------------------


def build_detector(cfg: dict[str, Any], context: RunContext | None = None):
    """The configured detector (None when the configuration has none), built through the
    context's host and set up with the context (its camera, its detector model)."""
    spec = cfg.get("detector")
    if not spec:
        return None
    context = context or RunContext()
    spec = {"type": spec["type"], "params": dict(spec.get("params") or {})}
    det = context.get_host().build("detector", spec)
    det.setup(context)
    return det


def train_detector(video: str | os.PathLike[str], gt: str | os.PathLike[str],
                   frames: str | tuple[int, int | None], *, out: str | os.PathLike[str] | None,
                   cfg: dict[str, Any] | None = None, camera: CameraSpec | None = None,
                   params: dict[str, Any] | None = None, seed: int = 0,
                   progress: bool = False):
    """Train the configured detector on ground-truth boxes and save its model (``out``).

    Positives are the ground-truth rows with flag 1; flag-0 rows (partly hidden people) are
    neither positives nor negatives. Returns the fitted detector.
    """
    import numpy as np

    from pftrack.host.config import training_params
    from pftrack.io.outputs import check_input_file, check_output_file

    # checked before training, not after it
    if out is not None:
        check_output_file(out, "--out")
    check_input_file(video, "video")
    check_input_file(gt, "--gt")
    cfg = cfg or {"detector": {"type": "svm", "params": {}}}
    det_cfg = dict(cfg.get("detector") or {"type": "svm"})
    train_cfg = det_cfg.get("train") or {}
    name = det_cfg.get("type", "svm")
    merged = training_params(name, det_cfg.get("params") or {},
                             {**(train_cfg.get("params") or {}), **(params or {})})
    det_cfg = {"type": name, "params": merged}
    det = build_detector({"detector": det_cfg}, RunContext(camera=_load_camera(camera)))
    first, last = parse_frames(frames)
    if out is not None:
        if not det.learns:
            raise ValueError(f"detector {det_cfg['type']!r} learns nothing to save")
        suffix = getattr(det, "model_suffix", None)
        if suffix and Path(out).suffix != suffix:
            raise ValueError(f"--out {out}: detector {det_cfg['type']!r} writes {suffix} "
                             f"models; give a file name ending in {suffix}")
    rows = read_ground_truth(gt, first, last)
    pos: dict[int, np.ndarray] = {}
    ign: dict[int, np.ndarray] = {}
    for f in np.unique(rows[:, 0]).astype(int):
        r = rows[rows[:, 0] == f]
        pos[int(f)] = r[r[:, 6] != 0, 2:6]
        ign[int(f)] = r[r[:, 6] == 0, 2:6]
    rng = seeded_rng(seed)
    frames_it = iter_frames(video, first, last)
    if progress:
        from tqdm.auto import tqdm

        n = (last - first + 1) if last is not None else None
        frames_it = tqdm(frames_it, total=n, desc="detector: training frames", unit="frame")
    try:
        with np.errstate(divide="ignore", invalid="ignore"):
            det.fit(frames_it, pos, rng=rng, ignore_by_frame=ign)
    except ValueError as exc:
        raise ValueError(f"detector {det_cfg['type']!r} trained on --video {video} frames "
                         f"{first}:{'' if last is None else last}: {exc}") from None
    if out is not None:
        det.save(out)
    return det


# --------------------------------------------------------------------------------------------
# The tracking loop
# --------------------------------------------------------------------------------------------


class DetectionScoreWarning(UserWarning):
    """Given detections whose scores are not on the 0-1 scale the configuration's score
    thresholds are written for."""


def score_scale_warning(cfg: dict[str, Any], detections: dict[int, Detections],
                        source: str) -> str:
    """A message when given detections score outside 0-1 while the configuration's score
    thresholds (``tracks.params.min_score``, ``associator.params.high_score``) read scores as
    probabilities; empty when they are in range or nothing reads them."""
    scores = [d.scores for d in detections.values() if len(d.scores)]
    if not scores:
        return ""
    every = np.concatenate(scores)
    lo, hi = float(every.min()), float(every.max())
    if lo >= 0.0 and hi <= 1.0:
        return ""
    used = []
    for section, key in (("tracks", "min_score"), ("associator", "high_score")):
        part = cfg.get(section)
        value = (part.get("params") or {}).get(key) if isinstance(part, dict) else None
        if value is not None:
            used.append(f"{section}.params.{key} = {value:g}")
    if not used:
        return ""
    share = float(np.mean(every >= 0.5))
    return (f"detections {source}: scores range from {lo:.3g} to {hi:.3g}, not 0-1; this "
            f"configuration reads scores as probabilities ({', '.join(used)}), so "
            f"{share:.0%} of the detections count as confident. Rescale the scores to 0-1 "
            "(a detector's probability of a person), or set those parameters on your scale "
            "(a copy of the preset: pftrack presets --show NAME)")


def _valid_region(rect: Sequence[float] | None):
    if rect is None:
        return None
    x0, x1, y0, y1 = (float(v) for v in rect)
    if not (x0 < x1 and y0 < y1):
        raise ValueError(f"valid_region_m must be [x0, x1, y0, y1] with x0 < x1, y0 < y1, got "
                         f"{rect}")

    def inside(p: np.ndarray) -> np.ndarray:
        p = np.asarray(p, dtype=np.float64)
        return (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)

    return inside


def _spec(value: Any, default_type: str) -> dict[str, Any]:
    """A component spec ``{"type", "params"}`` from a config value: a spec, a registered name,
    or (legacy form) a bare parameter mapping of ``default_type``."""
    if isinstance(value, str):
        return {"type": value, "params": {}}
    value = dict(value or {})
    if "type" in value:
        return {"type": value["type"], "params": dict(value.get("params") or {})}
    return {"type": default_type, "params": value}


def build_engine(cfg: dict[str, Any], *, camera: Camera | None = None, fps: float = 25.0,
                 seed: int = 0, host: Any = None,
                 detector_model: str | os.PathLike[str] | None = None) -> MultiTargetTracker:
    """The tracking engine of a configuration: observation model, motion, likelihood,
    associator and track management built by name through the host, each set up with the run's
    :class:`~pftrack.contracts.components.RunContext` (camera, fps), the observation model first:
    a camera given to it (``observation.params.camera``) is the run's when ``camera`` is None,
    and the other parts are set up with it. The detector is built and run
    separately (:func:`build_detector`), so that its time is measured on its own; its detections
    are handed to :meth:`~pftrack.engine.tracker.MultiTargetTracker.step`. ``detector_model`` (a
    file the detector saved) is in the components' context, for those that read it.

    ``observation`` defaults by ``state`` (``world``: ``camera-box``, ``image``:
    ``image-box``); ``tracks`` defaults to ``confirmed`` with the legacy ``births`` options.
    """
    from pftrack.host import get_host

    host = host or get_host()
    state = cfg.get("state", "world")
    obs_spec = _spec(cfg.get("observation"), "camera-box" if state == "world" else "image-box")
    if obs_spec["type"] == "camera-box" and camera is None and obs_spec["params"].get(
            "camera") is None:
        raise ValueError(f"config {cfg.get('_source', '')}: state 'world' needs a camera "
                         "(--camera PATH)")
    if cfg.get("tracks") is not None and cfg.get("births"):
        raise ValueError(f"config {cfg.get('_source', '')}: give 'tracks' or the legacy "
                         "'births', not both")
    tracks_spec = _spec(cfg.get("tracks") if cfg.get("tracks") is not None
                        else cfg.get("births"), "confirmed")
    context = RunContext(host=host, camera=camera, fps=float(fps), detector_model=(
        None if detector_model is None else str(detector_model)))
    parts = {
        "observation": host.build("observation", obs_spec),
        "motion": host.build("motion", cfg["motion"]),
        "likelihood": host.build("likelihood", cfg["likelihood"]),
        "associator": (host.build("associator", cfg["associator"])
                       if cfg.get("associator") else None),
        "tracks": host.build("tracks", tracks_spec),
    }
    parts["observation"].setup(context)
    if context.camera is None and getattr(parts["observation"], "camera", None) is not None:
        # a camera given to the observation model is the run's: the other parts see it too
        context.camera = parts["observation"].get_camera()
    for key, component in parts.items():
        if component is not None and key != "observation":
            component.setup(context)
    topts = dict(cfg.get("tracker") or {})
    seconds = topts.pop("max_misses_s", None)
    if seconds is not None:
        if topts.get("max_misses") is not None:
            raise ValueError(f"config {cfg.get('_source', '')}: give tracker.max_misses "
                             "(frames) or tracker.max_misses_s (seconds), not both")
        topts["max_misses"] = context.frames(float(seconds))
    dt = topts.pop("dt", "auto")
    dt = 1.0 / float(fps) if dt in (None, "auto") else float(dt)
    return MultiTargetTracker(
        parts["motion"], parts["likelihood"], parts["observation"], tracks=parts["tracks"],
        associator=parts["associator"], detection_driven=parts["associator"] is not None,
        dt=dt, valid_region=_valid_region(cfg.get("valid_region_m")),
        rng=seeded_rng(seed), **topts)


# --------------------------------------------------------------------------------------------
# Evaluation
# --------------------------------------------------------------------------------------------


def _matched_world_errors(gt: np.ndarray, tracks: np.ndarray, iou_threshold: float = 0.5
                          ) -> np.ndarray:
    """Ground-plane distances (m) of gt/track rows matched per frame (Hungarian on IoU >= thr);
    ground-truth rows without a world position (x, y, z all -1) are matched but not measured."""
    from scipy.optimize import linear_sum_assignment

    from pftrack.geometry.boxes import iou_matrix
    from pftrack.io.mot import has_world

    errs = []
    tf = tracks[:, 0].astype(int)
    for f in np.unique(gt[:, 0]).astype(int):
        g = gt[gt[:, 0] == f]
        t = tracks[tf == f]
        if len(g) == 0 or len(t) == 0:
            continue
        iou = iou_matrix(g[:, 2:6], t[:, 2:6])
        r, c = linear_sum_assignment(-iou)
        ok = (iou[r, c] >= iou_threshold) & has_world(g[r])
        d = np.linalg.norm(g[r[ok], 7:9] - t[c[ok], 7:9], axis=1)
        errs.append(d)
    return np.concatenate(errs) if errs else np.zeros(0)


def evaluate_tracks(gt_rows: np.ndarray, track_rows: np.ndarray) -> dict[str, Any]:
    """MOTA, IDF1, HOTA on image boxes (IoU 0.5), ground-plane error of matched boxes (median,
    p90, metres; when the tracks carry world columns) and the soccer paper's accuracy (projected
    foot point within 5 px of the ground-truth foot point, averaged over people)."""
    from pftrack.io.mot import has_world
    from pftrack.metrics import accuracy_within, evaluate, points_by_target

    out: dict[str, Any] = {}
    tracks = np.asarray(track_rows, dtype=np.float64).reshape(-1, 10)
    gt = np.asarray(gt_rows, dtype=np.float64).reshape(-1, 10)
    m = evaluate(gt, tracks, metric="iou", threshold=0.5)
    out.update({k: m[k] for k in ("MOTA", "IDF1", "HOTA", "MOTP", "IDSW", "FP", "FN", "TP",
                                  "Recall", "Precision", "DetA", "AssA", "num_tracker_ids",
                                  "num_gt_ids") if k in m})
    visible = gt[gt[:, 6] != 0]
    if len(tracks) and np.all(has_world(tracks)):
        e = _matched_world_errors(visible, tracks)
        out["median_error_m"] = float(np.median(e)) if len(e) else float("nan")
        out["p90_error_m"] = float(np.percentile(e, 90)) if len(e) else float("nan")
        out["n_world_pairs"] = len(e)
    else:
        out["median_error_m"] = out["p90_error_m"] = float("nan")
    if len(tracks):
        pts = points_by_target(visible, tracks, id_map="match", point="foot")
        acc, _ = accuracy_within(pts["estimated_px"], pts["truth_px"], 5.0)
        out["accuracy_5px"] = float(acc)
    else:
        out["accuracy_5px"] = 0.0
    return out


# --------------------------------------------------------------------------------------------
# Whole runs
# --------------------------------------------------------------------------------------------


@dataclass
class RunResult:
    """What :func:`run_pipeline` produced.

    ``rows``: MOT rows (M, 10) sorted by frame and id; ``detections``: per frame (reusable by
    another run on the same frames); ``timing``: seconds per frame for detection and tracking;
    ``metrics``: :func:`evaluate_tracks` when ground truth was given; ``uncertainty``: the
    spread of each row's estimate (M, 9), rows in ``rows``' order
    (:func:`pftrack.engine.tracker.records_uncertainty`). With an output folder, ``timing``
    also has ``outputs_s`` and ``outputs_cpu_s``: the seconds (wall, CPU) of writing the
    outputs, the report's images included (a cost per run, not per frame).
    """

    rows: np.ndarray
    detections: dict[int, Detections]
    timing: dict[str, float]
    metrics: dict[str, Any] | None = None
    out_dir: Path | None = None
    n_frames: int = 0
    uncertainty: np.ndarray | None = None


def _load_camera(camera: CameraSpec | None) -> Camera | None:
    if camera is None or not isinstance(camera, (str, os.PathLike)):
        return camera
    from pftrack.geometry.formats import load_camera

    return load_camera(camera)


def run_pipeline(config: str | os.PathLike[str] | dict[str, Any], *, video: str | os.PathLike[str],
                 camera: CameraSpec | None = None, out_dir: str | os.PathLike[str] | None = None,
                 gt: str | os.PathLike[str] | np.ndarray | None = None,
                 frames: str | tuple[int, int | None] | None = None,
                 detector_model: str | os.PathLike[str] | None = None, seed: int = 0,
                 detections: dict[int, Detections] | None = None,
                 progress: bool | str = True, report: bool = True,
                 keep_rows: Callable[[np.ndarray, float], np.ndarray] | None = None
                 ) -> RunResult:
    """Track ``video`` with ``config`` and write ``out_dir/tracks.txt`` (and ``metrics.json``
    with ground truth, ``report/*.png``).

    Parameters
    ----------
    progress : bool or str
        Show a progress bar on stderr; a string is its label (the command the user ran, e.g.
        ``"pftrack track"``), followed by the configuration's name. True: ``"tracking"``.
    gt : path or ndarray (M, 10), optional
        MOTChallenge ground truth (a file, or its rows): scored into ``metrics.json`` and drawn
        in the report.
    detections : dict {frame: Detections} or path, optional
        Precomputed detections (another run's ``RunResult.detections``, or a MOTChallenge
        ``det.txt`` file, :func:`pftrack.io.detections.read_detections`): the detector is not
        run. Default: the configuration's ``detections`` file, if any.
    keep_rows : callable, optional
        ``keep_rows(rows, fps)``: which of the tracked rows (MOTChallenge, (M, 10)) are
        reported, a boolean mask (M,); the others are left out of ``tracks.txt``, the metrics
        and the report (e.g. :func:`pftrack.workflows.track.track_video`'s static things).
    """
    from pftrack.io.outputs import check_input_file, check_output_tree

    cfg = load_config(config)
    if detections is None and cfg.get("detections") is not None:
        detections = cfg["detections"]
    # everything that can be checked is checked before the first frame
    if out_dir is not None:
        check_output_tree(out_dir, {"tracks.txt": "file", "tracks_uncertainty.csv": "file",
                                    "metrics.json": "file", "report": "dir"})
    if report and out_dir is not None:
        report_writer(cfg)  # an unknown writer stops the run before it tracks, not after
    for option, path in (("video", video),
                         ("--gt", gt if isinstance(gt, (str, os.PathLike)) else None),
                         ("--detector-model", detector_model),
                         ("--camera", camera if isinstance(camera, (str, os.PathLike)) else None),
                         ("--detections", detections if isinstance(detections, (str, os.PathLike))
                          else None)):
        if path is not None:
            check_input_file(path, option)
    cam = _load_camera(camera)
    video = Path(video)
    first, last = parse_frames(frames)
    gt_all = None if gt is None else read_ground_truth(gt, first, last if last is not None
                                                         else 10**9)
    if gt_all is not None and not len(gt_all):
        import warnings

        # a stretch with nobody in it is a legitimate test (of false positives)
        warnings.warn(f"--gt {gt if isinstance(gt, (str, os.PathLike)) else '(rows)'}: no "
                      f"ground-truth row in frames {first}..{'' if last is None else last}: "
                      "the metrics count only the tracks' false positives", FrameWarning,
                      stacklevel=2)
    if gt_all is not None and cam is not None and "people_fit" in cam.metadata:
        import warnings

        gt_all = ground_truth_in_camera_frame(gt_all, cam)
        warnings.warn(f"--gt {gt if isinstance(gt, (str, os.PathLike)) else '(rows)'}: the "
                      "camera was estimated from the people (pftrack calib people), its world "
                      "frame is its own: the ground truth's world positions are its boxes' foot "
                      "points through that camera (ground errors measure the tracking in its "
                      "frame, not the camera)", GroundTruthFrameWarning, stacklevel=2)
    from pftrack.scenes.source import FrameSource

    source = FrameSource(video, first, last)
    fps, n_announced = source.probe()
    if n_announced and first > n_announced:
        raise ValueError(f"--frames {first}:{'' if last is None else last}: the video {video} "
                         f"has {n_announced} frames (1..{n_announced})")
    engine = build_engine(cfg, camera=cam, fps=fps, seed=seed, detector_model=detector_model)
    if isinstance(detections, (str, os.PathLike)):
        from pftrack.io.detections import read_detections

        source_name = str(detections)
        detections = read_detections(detections, camera=cam)
        line = score_scale_warning(cfg, detections, source_name)
        if line:
            import warnings

            warnings.warn(line, DetectionScoreWarning, stacklevel=2)
    detector = None
    if detections is None and cfg.get("detector") and \
            (cfg["detector"].get("detect", True) if isinstance(cfg["detector"], dict) else True):
        detector = build_detector(cfg, RunContext(camera=cam, fps=fps, detector_model=(
            None if detector_model is None else str(detector_model))))
    from pftrack.engine.runner import FrameStep, run_frames
    from pftrack.workflows.spread import RecordSpread

    spread = RecordSpread(engine)  # each record's spread, from its particle cloud
    keep_frames: dict[int, np.ndarray] = {}
    drawing = report and out_dir is not None
    # the middle from the frames announced when the run goes to the end; the last frame is the
    # last one decoded, whatever the container announced
    want = _report_frames(first, last if last is not None else (n_announced or None)) \
        if drawing else set()
    last_seen: tuple[int, np.ndarray] | None = None

    def fill_spread(step: FrameStep) -> None:
        spread.fill(engine, step.records, step.frame.index)

    def keep_frame(step: FrameStep) -> None:
        nonlocal last_seen
        frame = step.frame
        if frame.index in want:
            keep_frames[frame.index] = frame.image.copy()
        else:
            last_seen = (frame.index, frame.image)

    # the uncertainty output and the report's frames are hooks: not timed (the uncertainty's
    # own time is reported apart)
    hooks: dict[str, Callable[[FrameStep], None]] = {"uncertainty": fill_spread}
    if drawing:
        hooks["report"] = keep_frame
    bar: bool | str = False
    if progress:
        label = progress if isinstance(progress, str) else "tracking"
        bar = f"{label} ({cfg['name']})" if cfg.get("name") else label
    loop = run_frames(engine, source.frames(fps), detector=detector, detections=detections,
                      after_step=hooks, progress=bar,
                      total=None if last is None else last - first + 1)
    records, dets_out, n = loop.records, loop.detections, loop.n_frames
    if last_seen is not None and last_seen[0] > max(keep_frames, default=0):
        keep_frames[last_seen[0]] = last_seen[1].copy()
    if n == 0:
        raise ValueError(f"video {video}: no frame decoded in frames {first}.."
                         f"{'' if last is None else last}")
    from pftrack.engine.tracker import records_uncertainty

    rows = records_to_mot(records)
    if cam is not None and cfg.get("state", "world") == "image":
        # image-plane tracks placed on the ground through the camera: their boxes' feet
        rows = rows_on_ground(rows, cam)
    spread_rows = records_uncertainty(records)
    _warn_frames(source.report)
    if len(rows):
        order = np.lexsort((rows[:, 1], rows[:, 0]))
        rows, spread_rows = rows[order], spread_rows[order]
    if keep_rows is not None and len(rows):
        mask = np.asarray(keep_rows(rows, fps), dtype=bool).reshape(-1)
        rows, spread_rows = rows[mask], spread_rows[mask]
    # frames per second of the whole loop: decoding, detection and tracking (not the report
    # nor the uncertainty of tracks_uncertainty.csv, timed on its own).
    # Wall time, and the process's CPU time (the same on an idle core; on a shared, loaded
    # machine the CPU time is the one-core cost and the wall time includes waiting for a core).
    timing = {**loop.timing(),
              "uncertainty_cpu_s_per_frame": loop.hook_cpu_s["uncertainty"] / max(n, 1)}
    metrics = None
    gt_rows = None
    if gt_all is not None:
        # scored over the frames actually tracked, and said so
        tracked = np.asarray(source.report.indices, dtype=np.int64)
        gt_rows = gt_all[np.isin(gt_all[:, 0].astype(np.int64), tracked)]
        n_gt_frames = len(np.unique(gt_all[:, 0]))
        n_scored = len(np.unique(gt_rows[:, 0]))
        if n_scored < n_gt_frames:
            import warnings

            warnings.warn(f"--gt {gt}: scored over the {n_scored} ground-truth frames that were "
                          f"tracked, of {n_gt_frames} in frames {first}.."
                          f"{'' if last is None else last}", FrameWarning, stacklevel=2)
        metrics = evaluate_tracks(gt_rows, rows)
        metrics.update(timing)
        metrics.update({"frames_tracked": len(tracked), "gt_frames_scored": n_scored,
                        "gt_frames_in_range": n_gt_frames,
                        "frame_problems": source.report.problems(),
                        # frames lost somewhere in the file: later numbers may be off
                        "frame_numbers_verified": source.report.numbers_trusted})
    result = RunResult(rows, dets_out, timing, metrics, None, n, spread_rows)
    if out_dir is not None:
        import time

        t0, c0 = time.perf_counter(), time.process_time()
        result.out_dir = write_outputs(out_dir, cfg, result, keep_frames, gt_rows)
        timing.update(outputs_s=time.perf_counter() - t0, outputs_cpu_s=time.process_time() - c0)
    return result


class GroundTruthFrameWarning(UserWarning):
    """The ground truth's world positions were carried into the run camera's own frame."""


class FrameWarning(UserWarning):
    """A run's frames are not what was asked: a gap, a short read, frames renumbered, frames
    not scored."""


def _warn_frames(report: Any) -> None:
    import warnings

    for line in report.problems():
        warnings.warn(line, FrameWarning, stacklevel=3)


def _report_frames(first: int, last: int | None) -> set[int]:
    """Frames kept for the report: the first, about 5 s (50 frames) later, the middle and the
    last of ``first..last`` (``last`` None, not known: the first two; the run adds the last
    frame it decodes)."""
    if last is None:
        return {first, first + 50}
    return {f for f in (first, first + 50, (first + last) // 2, last) if f <= last}


def write_outputs(out_dir: str | os.PathLike[str], cfg: dict[str, Any], result: RunResult,
                  frames: dict[int, np.ndarray], gt_rows: np.ndarray | None) -> Path:
    """``tracks.txt``, ``tracks_uncertainty.csv`` (each row's spread,
    :func:`pftrack.io.outputs.write_track_uncertainty`), ``metrics.json`` (with ground truth)
    and ``report/*.png``, as one unit
    (:class:`pftrack.io.outputs.OutputSet`): all replaced or none."""
    import json

    from pftrack.io.atomic import atomic_write_text
    from pftrack.io.mot import write_mot
    from pftrack.io.outputs import OutputSet

    # one unit: staged, then moved into place together; an earlier run's metrics.json or
    # report/ that this run does not produce is removed, a failure leaves the earlier outputs
    with OutputSet(out_dir, RUN_OUTPUTS) as out:
        write_mot(out.path("tracks.txt"), result.rows)  # no tracks: an empty file, a result
        if result.uncertainty is not None:
            from pftrack.io.outputs import write_track_uncertainty

            write_track_uncertainty(out.path("tracks_uncertainty.csv"), result.uncertainty)
        if result.metrics is not None:
            atomic_write_text(out.path("metrics.json"),
                              json.dumps(result.metrics, indent=2, default=float) + "\n")
        if frames:
            import inspect

            writer = report_writer(cfg)
            extra = {}
            params = inspect.signature(writer.write).parameters
            if "uncertainty" in params or any(p.kind is p.VAR_KEYWORD for p in params.values()):
                extra["uncertainty"] = result.uncertainty  # a writer that draws the ellipses
            writer.write(out.path("report"), result.rows, frames,
                         gt_rows=gt_rows, title=str(cfg.get("name", "")), **extra)
    return Path(out_dir)


def report_writer(cfg: dict[str, Any], host: Any = None) -> Any:
    """The :class:`~pftrack.contracts.extensions.ReportWriter` a configuration names
    (``report: {writer: NAME}``, default ``tracks``)."""
    from pftrack.host import get_host

    opts = cfg.get("report") or {}
    if not isinstance(opts, dict) or set(opts) - {"writer"}:
        raise ValueError(f"config {cfg.get('_source', '')}: report must be {{writer: NAME}}, "
                         f"got {opts!r}")
    return (host or get_host()).get("report", str(opts.get("writer", "tracks")))
