"""Sample third-party pftrack plugin (test fixture).

It shows the whole surface a plugin author needs: components subclassing the contracts in
:mod:`pftrack.components` (a detector, likelihoods, a motion model, an associator, a scene, an
observation model, a track manager in the legacy form that drives the engine itself, and a lifecycle
stage that only returns decisions), a preset shipped as package data, a metric, a report writer,
and a command, a benchmark and a demo (:mod:`pftrack.extensions`), all registered through
``pftrack_register_*`` hooks and exposed through the ``pftrack`` entry-point group in
``pyproject.toml``. The project's tests install it into a temporary folder and check that ``pftrack
plugins`` lists it, that every piece runs through the ``pftrack`` command line without editing
pftrack, and that the ``PFTRACK_DISABLE_*`` environment variables block it.
"""

from __future__ import annotations

import numpy as np
from pftrack import hookimpl
from pftrack.components import (
    Assignment,
    Associator,
    Detections,
    Detector,
    Frame,
    Likelihood,
    MotionModel,
    ObservationModel,
    Scene,
    Target,
    TrackManager,
)
from pftrack.lifecycle import End, FrameView, Terminator

__version__ = "0.3.1"


class DriftMotion(MotionModel):
    """Image-plane state (x, y) in pixels drifting by a constant velocity plus Gaussian noise.

    Parameters
    ----------
    velocity_px : tuple of float
        Drift (vx, vy) in pixels per unit of ``dt``.
    sigma_px : float
        Noise standard deviation in pixels per unit of ``dt``.
    """

    def __init__(self, velocity_px: tuple[float, float] = (1.0, 0.0), sigma_px: float = 1.0):
        self.velocity_px = velocity_px
        self.sigma_px = sigma_px

    @property
    def state_dim(self) -> int:
        return 2

    def predict(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                target: Target | None = None) -> np.ndarray:
        s = np.asarray(states, dtype=np.float64).reshape(-1, 2)
        noise = rng.standard_normal(s.shape) * (self.sigma_px * np.sqrt(dt))
        return s + np.asarray(self.velocity_px, dtype=np.float64) * dt + noise

    def init_states(self, position: np.ndarray, n: int, rng: np.random.Generator,
                    spread: float | np.ndarray = 1.0) -> np.ndarray:
        p = np.asarray(position, dtype=np.float64).reshape(2)
        return p + rng.standard_normal((n, 2)) * np.asarray(spread, dtype=np.float64)


class BoxAreaLikelihood(Likelihood):
    """Prefers boxes whose area is close to ``area_px`` (a toy likelihood).

    ``log L = -((w h - area_px) / scale_px)^2 / 2`` for boxes (N, 4) xywh px.
    """

    def __init__(self, area_px: float = 400.0, scale_px: float = 100.0):
        self.area_px = area_px
        self.scale_px = scale_px

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
        z = (b[:, 2] * b[:, 3] - self.area_px) / self.scale_px
        return -0.5 * z * z


class BrightnessLikelihood(Likelihood):
    """Prefers boxes over bright pixels: ``log L = mean grey level in the box / scale``, the
    mean from one integral image per frame (O(1) per box, no loop over particles)."""

    def __init__(self, scale: float = 30.0):
        self.scale = scale

    def begin_frame(self, frame, targets, detections=None) -> None:
        import cv2

        grey = cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY)
        self.integral_ = cv2.integral(grey, sdepth=cv2.CV_64F)

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        ii = self.integral_
        h, w = ii.shape[0] - 1, ii.shape[1] - 1
        b = np.asarray(boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
        x0 = np.clip(np.round(b[:, 0]), 0, w).astype(int)
        y0 = np.clip(np.round(b[:, 1]), 0, h).astype(int)
        x1 = np.clip(np.round(b[:, 0] + b[:, 2]), 0, w).astype(int)
        y1 = np.clip(np.round(b[:, 1] + b[:, 3]), 0, h).astype(int)
        area = np.maximum((x1 - x0) * (y1 - y0), 1)
        s = ii[y1, x1] - ii[y0, x1] - ii[y1, x0] + ii[y0, x0]
        return s / area / float(self.scale)


class BrightSpotDetector(Detector):
    """Connected regions of pixels brighter than ``threshold`` (grey level), as boxes with
    score 1."""

    def __init__(self, threshold: int = 128, min_area_px: int = 20):
        self.threshold = threshold
        self.min_area_px = min_area_px

    def detect(self, frame: Frame) -> Detections:
        import cv2

        grey = cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY)
        mask = (grey > self.threshold).astype(np.uint8)
        n, _, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=4)
        keep = stats[1:, cv2.CC_STAT_AREA] >= self.min_area_px
        boxes = stats[1:, :4][keep].astype(np.float64)
        return Detections(boxes, np.ones(len(boxes)))


class NearestAssociator(Associator):
    """Greedy nearest box centres, closer than ``max_distance_px``."""

    def __init__(self, max_distance_px: float = 30.0):
        self.max_distance_px = max_distance_px

    def associate(self, targets, detections) -> Assignment:
        if not len(targets) or not len(detections):
            return Assignment.from_matches([], len(targets), len(detections))
        tb = np.array([t.box_xywh_px for t in targets])
        db = detections.boxes_xywh_px
        tc = tb[:, :2] + tb[:, 2:] / 2
        dc = db[:, :2] + db[:, 2:] / 2
        d = np.linalg.norm(tc[:, None] - dc[None], axis=2)
        matches = []
        while np.isfinite(d).any() and d.min() < self.max_distance_px:
            i, j = np.unravel_index(np.argmin(d), d.shape)
            matches.append((i, j))
            d[i, :] = np.inf
            d[:, j] = np.inf
        return Assignment.from_matches(matches, len(targets), len(detections))


class DotsScene(Scene):
    """``n_dots`` bright 20 x 20 squares moving in straight lines on a black 160 x 120 picture,
    with their ground truth (MOTChallenge rows)."""

    def __init__(self, n_dots: int = 2, n_frames: int = 40, seed: int = 0):
        self.n_dots = n_dots
        self.n_frames = n_frames
        self.seed = seed

    def _tracks(self) -> np.ndarray:
        rng = np.random.default_rng(self.seed)
        start = np.column_stack([np.linspace(20, 120, self.n_dots), rng.uniform(20, 80,
                                                                               self.n_dots)])
        vel = np.column_stack([np.zeros(self.n_dots), np.full(self.n_dots, 0.5)])
        k = np.arange(self.n_frames)[:, None, None]
        return start[None] + k * vel[None]  # (F, n, 2) top-left corners

    def frames(self):
        for k, corners in enumerate(self._tracks()):
            img = np.zeros((120, 160, 3), np.uint8)
            for x, y in np.round(corners).astype(int):
                img[y:y + 20, x:x + 20] = 255
            yield Frame(k + 1, img, k / self.fps)

    def ground_truth(self) -> np.ndarray:
        rows = [[k + 1, i + 1, *np.round(c), 20, 20, 1, -1, -1, -1]
                for k, corners in enumerate(self._tracks()) for i, c in enumerate(corners)]
        return np.asarray(rows, dtype=np.float64)


class SquareObservation(ObservationModel):
    """Image-plane state (x, y): the box centre in pixels; every box a ``side_px`` square."""

    def __init__(self, side_px: float = 20.0):
        self.side_px = side_px

    def to_boxes(self, states, target=None):
        s = np.asarray(states, dtype=np.float64).reshape(-1, 2)
        half = 0.5 * float(self.side_px)
        return np.column_stack([s - half, np.full((len(s), 2), float(self.side_px))])

    def position_from_box(self, box_xywh_px):
        b = np.asarray(box_xywh_px, dtype=np.float64)
        return b[:2] + 0.5 * b[2:]


class SeenTwiceTracks(TrackManager):
    """A detection nobody matched starts a target; the target is output from its second frame
    with a matched detection on, and ended after ``max_unmatched`` frames without one."""

    def __init__(self, max_unmatched: int = 3):
        self.max_unmatched = max_unmatched

    def after_frame(self, engine, frame, detections, records, unmatched_detections):
        hits = self.__dict__.setdefault("hits_", {})
        for t in engine.targets:
            if t.detection is not None:
                hits[t.id] = hits.get(t.id, 0) + 1
            elif t.misses > self.max_unmatched:
                engine.remove_target(t.id)
        out = [r for r in records if hits.get(r.id, 0) >= 2 and r.id in hits]
        if detections is not None:
            for k in unmatched_detections:
                t = engine.add_target(frame, box_xywh_px=detections.boxes_xywh_px[k])
                hits[t.id] = 1
        return out

    def end_target(self, target):
        self.__dict__.setdefault("hits_", {}).pop(target.id, None)


class MissLimitTerminator(Terminator):
    """A lifecycle stage: a track ends once it has gone more than ``max_unmatched`` frames
    without a matched detection (its record of that frame is withdrawn). It sees the tracks
    read-only and returns :class:`~pftrack.lifecycle.End` decisions; the lifecycle runner
    applies them.

    Parameters
    ----------
    max_unmatched : int
        Frames without a matched detection a track survives. Unit: frames.
    """

    def __init__(self, max_unmatched: int = 3):
        self.max_unmatched = max_unmatched

    def terminate(self, view: FrameView) -> list[End]:
        return [End(t.id, f"{t.misses} frames unmatched") for t in view.tracks
                if t.misses > self.max_unmatched]


def count_metric(gt_rows: np.ndarray, track_rows: np.ndarray) -> dict[str, float]:
    """Rows of tracks per row of ground truth."""
    return {"rows_ratio": len(track_rows) / max(len(gt_rows), 1),
            "ids": float(len(np.unique(np.asarray(track_rows).reshape(-1, 10)[:, 1])))}


# -- command, benchmark, demo ----------------------------------------------------------------


def _write_args(parser) -> None:
    parser.add_argument("--out", required=True, help="folder for dots.avi and gt.txt")
    parser.add_argument("--frames", type=int, default=40)


def write_dots(args) -> int:
    """``pftrack sample-write-dots``: the dots scene as a video and its ground truth."""
    from pathlib import Path

    import cv2
    from pftrack.io.mot import write_mot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = DotsScene(n_frames=args.frames)
    writer = cv2.VideoWriter(str(out / "dots.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 25.0,
                             (160, 120))
    for f in scene.frames():
        writer.write(f.image)
    writer.release()
    write_mot(out / "gt.txt", scene.ground_truth())
    print(f"wrote {out / 'dots.avi'} and {out / 'gt.txt'}")
    return 0


def bench_brightness(args) -> dict:
    """Time the brightness likelihood over ``--boxes`` boxes."""
    import time

    lik = BrightnessLikelihood()
    scene = DotsScene(n_frames=1)
    frame = next(iter(scene.frames()))
    lik.begin_frame(frame, [])
    boxes = np.random.default_rng(0).uniform(0, 140, (args.boxes, 4))
    t0 = time.perf_counter()
    ll = lik.log_likelihood(boxes, None)
    return {"benchmark": "sample-brightness", "boxes": args.boxes,
            "seconds": time.perf_counter() - t0, "mean_log_likelihood": float(ll.mean())}


def write_box_report(out_dir, rows, frames, *, camera=None, gt_rows=None, title=""):
    """One PNG per kept frame: the frame with its tracked boxes in green."""
    from pathlib import Path

    import cv2
    from pftrack.io.atomic import atomic_write_bytes

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = np.asarray(rows, dtype=np.float64).reshape(-1, 10)
    written = []
    for f, img in sorted(frames.items()):
        pic = img.copy()
        for x, y, w, h in rows[rows[:, 0] == f, 2:6].astype(int):
            cv2.rectangle(pic, (x, y), (x + w, y + h), (0, 255, 0), 1)
        ok, png = cv2.imencode(".png", pic)
        written.append(atomic_write_bytes(out / f"boxes_{f:06d}.png", png.tobytes()))
    return written


def demo_dots(args) -> int:
    """The dots written by :func:`write_dots`, and nothing else."""
    return write_dots(args)


@hookimpl
def pftrack_register_motion_models(register):
    register("sample-drift", DriftMotion)


@hookimpl
def pftrack_register_likelihoods(register):
    register("sample-box-area", BoxAreaLikelihood)
    register("sample-brightness", BrightnessLikelihood)


@hookimpl
def pftrack_register_detectors(register):
    register("sample-bright", BrightSpotDetector)


@hookimpl
def pftrack_register_associators(register):
    register("sample-nearest", NearestAssociator)


@hookimpl
def pftrack_register_scenes(register):
    register("sample-dots", DotsScene)


@hookimpl
def pftrack_register_observation_models(register):
    register("sample-square", SquareObservation)


@hookimpl
def pftrack_register_track_managers(register):
    register("sample-seen-twice", SeenTwiceTracks)


@hookimpl
def pftrack_register_lifecycle_stages(register):
    register("sample-miss-limit", MissLimitTerminator)


@hookimpl
def pftrack_register_metrics(register):
    register("sample-count", count_metric)


@hookimpl
def pftrack_register_presets(register):
    from importlib import resources

    register("sample-dots", str(resources.files("pftrack_sample") / "presets" /
                                "sample-dots.yaml"))


@hookimpl
def pftrack_register_commands(register):
    from pftrack.extensions import Command

    register("sample-write-dots", Command(summary="write the sample dots video and its truth",
                                          run=write_dots, add_arguments=_write_args))


@hookimpl
def pftrack_register_benchmarks(register):
    from pftrack.extensions import Benchmark

    register("sample-brightness", Benchmark(
        summary="time the sample brightness likelihood", run=bench_brightness,
        add_arguments=lambda p: p.add_argument("--boxes", type=int, default=1000)))


@hookimpl
def pftrack_register_report_writers(register):
    from pftrack.extensions import ReportWriter

    register("sample-boxes", ReportWriter(summary="frames with green boxes",
                                          write=write_box_report))


@hookimpl
def pftrack_register_demos(register):
    from pftrack.extensions import Demo

    register("sample-dots", Demo(summary="write the sample dots", run=demo_dots,
                                 add_arguments=lambda p: p.add_argument("--frames", type=int,
                                                                        default=40)))
