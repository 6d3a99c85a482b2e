"""A user's own detections: pftrack against the usual trackers on identical boxes, over noise seeds.

``pftrack bench own-detections`` answers the question a user with a detector of their own asks:
given the same boxes, which tracker keeps each person's identity? Every tracker in one run gets
the very same detections, frame by frame; their tracks are scored with TrackEval's definitions
(:func:`pftrack.metrics.evaluate`); each tracker's time per frame counts its own work only.

**Videos and parts** (:data:`VIDEOS`; ground-truth frame numbering, 1-based, which is the
pipeline's: frame N is the N-th decoded frame of the file):

* ``pets09``: PETS 2009 S2.L1, ``pets09/vtest.avi`` and ``gt.txt``, 795 frames, 768x576, a raised
  camera. Tune part frames 1-400, report part 401-795. Ground-truth rows flagged 0 (partly hidden
  people) are scored as the other benches score them: dropped together with the tracker boxes
  that match them in their frame (``zero_marked="drop_matched"``).
* ``mot17-09``: MOT17-09, ``mot17-09/MOT17-09.mp4`` and ``gt/gt.txt``, 525 frames, 1920x1080, a
  waist-high camera on a shopping street. Tune part 1-262, report part 263-525. MOT17's rule:
  pedestrians only (``consider`` 1 and ``class`` 1) are scored; a tracker box matched (one to
  one per frame, Hungarian over every ground-truth box of the frame, IoU >= 0.5) to a box of class
  2, 7, 8 or 12 (person on vehicle, static person, distractor, reflection) is removed before
  scoring; boxes of the other classes count neither way (:func:`mot17_scoring_rows`).

Settings are chosen on the tune parts only; the report parts chose nothing. Every tracker runs
on the part's frames alone, starting fresh at its first frame (the detections of the other part
are not given to it). The bench refuses to print tune-part results unless ``--part tune`` is
asked for, and its JSON says which part was reported and which part chose the settings.

**Detections** (``--levels``):

* ``clean`` and ``noisy``: simulated from the ground truth (:func:`simulate_detections`, levels
  :data:`LEVELS`), one detection set per noise seed (``--seeds``, default 0-4), the same set
  for every tracker. A detectable person is a PETS row flagged 1, or a MOT17-09 pedestrian row
  (consider 1, class 1) at least :data:`MOT17_MIN_VISIBILITY` visible: a real detector does not
  see a person hidden behind another (a quarter of MOT17-09's pedestrian boxes are 0-10 %
  visible). The level's miss rate applies on top of that.
* ``hog``: the built-in ``hog-people`` detector as the ``people-image`` preset configures it
  (:func:`hog_detections`), run once over the whole video (its search state carries from frame to
  frame, as it would for a user) and cached on disk.

**Trackers** (:func:`default_trackers`; ``--trackers``): pftrack's presets that take detections,
``people-image`` through :func:`pftrack.workflows.pipeline.run_pipeline` (what ``pftrack run
people-image
--detections det.txt`` runs) and ``track`` through :func:`pftrack.workflows.track.track_video` (what
``pftrack track VIDEO --detections det.txt`` runs: a camera estimated from the detections, the
tracks kept in the image plane with ``people-image`` and placed on the ground through that
camera); the peers with their documented defaults: norfair (IoU distance), and
roboflow ``trackers``' ByteTrack, SORT, OC-SORT and BoT-SORT (camera-motion compensation on, no
appearance model), fed ``supervision.Detections`` of the same boxes. ``--config FILE.yaml`` adds
pftrack with that configuration (a row named after the file). A tracker that fails on a video (no
camera, a NaN in its output) gives a failure row with its message, not a crash.

**Figures**: HOTA, IDF1, MOTA, IDSW and Frag per tracker, video and level; for the simulated
levels the mean and the min-max over seeds. Time per frame: CPU seconds spent in the tracker's
own update calls (pftrack: its engine steps, :attr:`pftrack.workflows.pipeline.RunResult.timing`),
with the detections given and the video's decoding excluded, and its ratio to ByteTrack's in the
same run. Each tracker first runs once on the first cell's first :data:`WARM_UP_FRAMES` frames,
untimed and discarded (imports, compiled kernels).

From Python, e.g. a modified preset against the peers on the tune part::

    from pftrack.workflows.pipeline import load_config
    from pftrack_bench import own_detections as bod

    cfg = load_config("people-image")
    cfg["tracker"]["max_misses"] = 40
    r = bod.run_benchmark(part="tune", levels=["clean", "noisy"], seeds=[0, 1, 2],
                          trackers=["bytetrack", "norfair"],
                          extra=[bod.pftrack_config_entry("people-image-40", cfg)])
    print(bod.format_table(r))

:func:`simulate_detections`, :func:`hog_detections`, :func:`run_pftrack_config` and
:func:`score_tracks` are the pieces, usable alone.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pftrack_bench.protocol import (
    REPORT_PART,
    TUNE_PART,
    Protocol,
    add_part_argument,
)
from pftrack_bench.protocol import part_frames as _part_frames

__all__ = [
    "LEVELS",
    "MOT17_MIN_VISIBILITY",
    "VIDEOS",
    "NoiseLevel",
    "TrackerEntry",
    "TrackResult",
    "VideoSpec",
    "default_trackers",
    "detectable_mask",
    "hog_detections",
    "merge_results",
    "mot17_scoring_rows",
    "pftrack_config_entry",
    "run_benchmark",
    "run_pftrack_config",
    "score_tracks",
    "simulate_detections",
]


# --------------------------------------------------------------------------------------------
# The protocol: videos, parts, detection levels
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class VideoSpec:
    """One benchmark video: files (relative to the data folder), size and its two parts.

    ``tune`` and ``report`` are inclusive frame ranges in ground-truth numbering (from 1);
    ``rule`` names the scoring rule (``"pets"``: flag-0 rows dropped with the boxes matching
    them; ``"mot17"``: MOT17's pedestrian and distractor rule).
    """

    name: str
    title: str
    video: str
    gt: str
    n_frames: int
    image_wh: tuple[int, int]
    tune: tuple[int, int]
    report: tuple[int, int]
    rule: str


VIDEOS: dict[str, VideoSpec] = {
    "pets09": VideoSpec("pets09", "PETS 2009 S2.L1", "pets09/vtest.avi", "pets09/gt.txt", 795,
                        (768, 576), (1, 400), (401, 795), "pets"),
    "mot17-09": VideoSpec("mot17-09", "MOT17-09", "mot17-09/MOT17-09.mp4", "mot17-09/gt/gt.txt",
                          525, (1920, 1080), (1, 262), (263, 525), "mot17"),
}

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="PETS 2009 S2.L1 and MOT17-09: detections simulated from the ground truth "
         "(clean: 20 % missed, 3 px corner, 4 % size; noisy: 30 % missed, 6 px, 8 %, "
         "false positives 10 %) over noise seeds, and the hog-people detector's boxes",
    chosen_on="PETS frames 1-400 and MOT17-09 frames 1-262 (the presets' settings); "
              "the peers keep their documented defaults",
    reported_on="PETS frames 401-795 and MOT17-09 frames 263-525, noise and tracking "
                "seeds 0-4",
    chosen_frames={k: v.tune for k, v in VIDEOS.items()},
    reported_frames={k: v.report for k, v in VIDEOS.items()},
)


#: MOT17 classes whose matched tracker boxes are removed before scoring: person on vehicle,
#: static person, distractor, reflection (TrackEval's MOT17 preprocessing).
MOT17_DISTRACTOR_CLASSES = (2, 7, 8, 12)
#: A MOT17-09 pedestrian is detectable when at least this fraction of it is visible (the
#: ground truth's ``visibility`` column): a quarter of a person is about what a person
#: detector needs; fully hidden people keep their boxes in MOT17's ground truth.
MOT17_MIN_VISIBILITY = 0.25


@dataclass(frozen=True)
class NoiseLevel:
    """A simulated detector (:func:`simulate_detections`).

    Attributes
    ----------
    name : str
    miss_rate : float
        Probability that a detectable person gets no box in a frame (independent per box).
    corner_sd_px : float
        Standard deviation of the box's top-left corner, pixels (each coordinate).
    size_sd : float
        Standard deviation of the width and height, as a fraction of the true size.
    score_mean, score_sd : float
        Scores of true detections: normal, clipped to [0.01, 1].
    fp_rate : float
        False positives per true (detectable) box of the frame, on average (Poisson count per
        frame); placed uniformly in the image, sizes those of true boxes of the same frame.
    fp_score_mean, fp_score_sd : float
        Scores of the false positives, normal, clipped to [0.01, 1].
    """

    name: str
    miss_rate: float
    corner_sd_px: float
    size_sd: float
    score_mean: float = 0.85
    score_sd: float = 0.05
    fp_rate: float = 0.0
    fp_score_mean: float = 0.55
    fp_score_sd: float = 0.05


LEVELS: dict[str, NoiseLevel] = {
    "clean": NoiseLevel("clean", miss_rate=0.20, corner_sd_px=3.0, size_sd=0.04),
    "noisy": NoiseLevel("noisy", miss_rate=0.30, corner_sd_px=6.0, size_sd=0.08, fp_rate=0.10),
}
#: The detector level: the ``hog-people`` detector's own boxes (one set, no seed).
HOG_LEVEL = "hog"
#: The preset whose detector settings ``hog`` uses.
HOG_PRESET = "people-image"
DEFAULT_SEEDS = (0, 1, 2, 3, 4)


def protocol() -> dict[str, Any]:
    """The protocol as JSON: videos and parts, levels, rules."""
    return {
        "videos": {k: asdict(v) for k, v in VIDEOS.items()},
        "levels": {k: asdict(v) for k, v in LEVELS.items()},
        "hog": {"detector_preset": HOG_PRESET, "run_over": "the whole video, once"},
        "mot17_min_visibility": MOT17_MIN_VISIBILITY,
        "mot17_distractor_classes": list(MOT17_DISTRACTOR_CLASSES),
        "settings_chosen_on": TUNE_PART,
        "trackers_start_at": "the first frame of the part",
    }


def data_files(name: str, data: str | os.PathLike[str] | None = None) -> tuple[Path, Path]:
    """(video, ground truth) of a benchmark video in ``data`` (default
    :func:`pftrack.io.data.data_dir`); FileNotFoundError naming the missing file."""
    from pftrack.io.data import data_dir

    spec = video_spec(name)
    root = Path(data) if data is not None else data_dir()
    files = (root / spec.video, root / spec.gt)
    for p in files:
        if not p.is_file():
            raise FileNotFoundError(f"own-detections: {p} not found: set PFTRACK_DATA or --data "
                                    f"to the folder holding {spec.video.split('/')[0]}/")
    return files


def video_spec(name: str) -> VideoSpec:
    if name not in VIDEOS:
        raise ValueError(f"own-detections: unknown video {name!r} (known: {', '.join(VIDEOS)})")
    return VIDEOS[name]


def part_frames(name: str, part: str) -> tuple[int, int]:
    """The inclusive frame range of ``part`` (``"report"`` or ``"tune"``) of video ``name``."""
    video_spec(name)
    return _part_frames("own-detections", PROTOCOL, part, video=name)


def read_gt(name: str, data: str | os.PathLike[str] | None = None) -> np.ndarray:
    """The video's ground truth as MOT rows (M, 10) (MOT17's 9th and 8th columns, class and
    visibility, sit in columns 7 and 8)."""
    from pftrack.io.mot import read_mot

    return read_mot(data_files(name, data)[1])


# --------------------------------------------------------------------------------------------
# Detections
# --------------------------------------------------------------------------------------------


def detectable_mask(gt_rows: np.ndarray, rule: str) -> np.ndarray:
    """Which ground-truth rows a detector could find: ``"pets"``: flag 1; ``"mot17"``: consider
    1, class 1 and visibility >= :data:`MOT17_MIN_VISIBILITY`."""
    g = np.asarray(gt_rows, dtype=np.float64).reshape(len(gt_rows), -1)
    if rule == "pets":
        return g[:, 6] != 0
    if rule == "mot17":
        return (g[:, 6] == 1) & (g[:, 7] == 1) & (g[:, 8] >= MOT17_MIN_VISIBILITY)
    raise ValueError(f"own-detections: unknown scoring rule {rule!r} (pets, mot17)")


def _level(level: str | NoiseLevel) -> NoiseLevel:
    if isinstance(level, NoiseLevel):
        return level
    if level not in LEVELS:
        raise ValueError(f"own-detections: unknown noise level {level!r} (known: "
                         f"{', '.join(LEVELS)})")
    return LEVELS[level]


def _clip_rows(frames: np.ndarray, x0: np.ndarray, y0: np.ndarray, x1: np.ndarray,
               y1: np.ndarray, scores: np.ndarray, image_wh: tuple[int, int]) -> np.ndarray:
    w_img, h_img = float(image_wh[0]), float(image_wh[1])
    x0, x1 = np.clip(x0, 0.0, w_img), np.clip(x1, 0.0, w_img)
    y0, y1 = np.clip(y0, 0.0, h_img), np.clip(y1, 0.0, h_img)
    ok = (x1 - x0 >= 1.0) & (y1 - y0 >= 1.0)  # a box left with less than a pixel is no box
    return np.column_stack([frames, -np.ones_like(frames), x0, y0, x1 - x0, y1 - y0,
                            scores])[ok]


def simulate_detections(gt_rows: np.ndarray, level: str | NoiseLevel, seed: int,
                        image_wh: tuple[int, int], *, detectable: np.ndarray | None = None
                        ) -> np.ndarray:
    """Detections simulated from ground truth at a noise level (:data:`LEVELS`).

    Each detectable box is missed with probability ``miss_rate``; otherwise its top-left corner
    moves by normal noise of ``corner_sd_px`` pixels per coordinate and its width and height are
    scaled by ``1 + N(0, size_sd)``, score ``N(score_mean, score_sd)``. False positives: a
    Poisson number per frame with mean ``fp_rate`` times the frame's detectable boxes, each the
    size of a random detectable box of that frame, placed uniformly in the image. Every box is
    clipped to the image as a detector's is (boxes left smaller than 1 px are dropped).

    Parameters
    ----------
    gt_rows : ndarray (M, >= 7)
        MOT rows ``frame, id, left, top, width, height, flag, ...``.
    level : str or NoiseLevel
        ``"clean"``, ``"noisy"`` or a :class:`NoiseLevel`.
    seed : int
        Seed of the ``numpy.random.Generator``: same seed, same detections.
    image_wh : (int, int)
        Image width and height, pixels.
    detectable : bool ndarray (M,), optional
        Rows a detector could find (:func:`detectable_mask`); default: flag (column 6) not 0.

    Returns
    -------
    ndarray (N, 7)
        MOTChallenge det rows ``frame, -1, left, top, width, height, score``, sorted by frame.
    """
    lv = _level(level)
    g = np.asarray(gt_rows, dtype=np.float64)
    if g.ndim != 2 or g.shape[1] < 7:
        raise ValueError(f"simulate_detections: gt_rows must be MOT rows (M, >= 7), got shape "
                         f"{g.shape}")
    mask = g[:, 6] != 0 if detectable is None else np.asarray(detectable, dtype=bool)
    if mask.shape != (len(g),):
        raise ValueError(f"simulate_detections: detectable has shape {mask.shape}, need "
                         f"({len(g)},)")
    t = g[mask]
    t = t[np.argsort(t[:, 0], kind="stable")]
    rng = np.random.default_rng(seed)
    n = len(t)
    # every draw made for every box, so that one box's noise does not depend on another's miss
    hit = rng.random(n) >= lv.miss_rate
    corner = rng.normal(0.0, lv.corner_sd_px, (n, 2))
    scale = 1.0 + rng.normal(0.0, lv.size_sd, (n, 2))
    scores = np.clip(rng.normal(lv.score_mean, lv.score_sd, n), 0.01, 1.0)
    x0 = t[:, 2] + corner[:, 0]
    y0 = t[:, 3] + corner[:, 1]
    w = t[:, 4] * np.maximum(scale[:, 0], 0.05)
    h = t[:, 5] * np.maximum(scale[:, 1], 0.05)
    parts = [_clip_rows(t[hit, 0], x0[hit], y0[hit], (x0 + w)[hit], (y0 + h)[hit], scores[hit],
                        image_wh)]
    if lv.fp_rate > 0 and n:
        frames, start, count = np.unique(t[:, 0], return_index=True, return_counts=True)
        k = rng.poisson(lv.fp_rate * count)
        which = np.repeat(np.arange(len(frames)), k)
        m = len(which)
        src = start[which] + np.minimum((rng.random(m) * count[which]).astype(np.int64),
                                        count[which] - 1)
        fw = np.minimum(t[src, 4], image_wh[0])
        fh = np.minimum(t[src, 5], image_wh[1])
        fx = rng.random(m) * (image_wh[0] - fw)
        fy = rng.random(m) * (image_wh[1] - fh)
        fs = np.clip(rng.normal(lv.fp_score_mean, lv.fp_score_sd, m), 0.01, 1.0)
        parts.append(_clip_rows(frames[which], fx, fy, fx + fw, fy + fh, fs, image_wh))
    rows = np.concatenate(parts)
    return rows[np.argsort(rows[:, 0], kind="stable")]


def default_cache_dir() -> Path:
    """``$PFTRACK_CACHE`` or ``$XDG_CACHE_HOME/pftrack`` (``~/.cache/pftrack``)."""
    env = os.environ.get("PFTRACK_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "pftrack"


def _hog_key(video: Path, det_spec: Any, frames: tuple[int, int | None]) -> dict[str, Any]:
    import inspect

    from pftrack_world import people

    st = video.stat()
    code = hashlib.sha256(Path(inspect.getsourcefile(people) or "").read_bytes()).hexdigest()
    return {"video": str(video.resolve()), "video_bytes": st.st_size,
            "video_mtime_ns": st.st_mtime_ns, "detector": det_spec,
            "frames": [frames[0], frames[1]], "detector_code_sha256": code[:16]}


def hog_detections(video: str | os.PathLike[str], frames: str | tuple[int, int | None] | None,
                   cache_dir: str | os.PathLike[str] | None = None, *,
                   config: str | dict[str, Any] = HOG_PRESET, progress: bool = False
                   ) -> np.ndarray:
    """The ``hog-people`` detector's boxes on ``video``, computed once and cached on disk.

    The detector is built as ``config`` (default the ``people-image`` preset) configures it and
    run over ``frames`` (``"A:B"``, ground-truth numbering; None: the whole video) on one
    OpenCV thread. The result is a MOT det file in ``cache_dir`` (default
    :func:`default_cache_dir`) named by a hash of the video (path, size, modification time), the
    detector's type and parameters, the frames and the detector's source code; a second call
    with the same key reads the file. Beside it a ``.json`` holds the key and the detection time
    (``wall_s``, ``cpu_s``, ``frames``).

    Returns
    -------
    ndarray (N, 7)
        ``frame, -1, left, top, width, height, score``.
    """
    import cv2
    from pftrack.io.atomic import atomic_write_text
    from pftrack.io.detections import write_detections
    from pftrack.io.mot import read_mot
    from pftrack.workflows.track import detect_video

    video = Path(video)
    if not video.is_file():
        raise FileNotFoundError(f"hog_detections: video {video} not found")
    cfg, key, path, meta = _hog_cache(video, frames, cache_dir, config)
    if not (path.is_file() and meta.is_file()):
        path.parent.mkdir(parents=True, exist_ok=True)
        threads = cv2.getNumThreads()
        cv2.setNumThreads(1)
        try:
            dets, _, timing = detect_video(video, cfg, key["frames"], progress=progress)
        finally:
            cv2.setNumThreads(threads)
        write_detections(path, dets)
        atomic_write_text(meta, json.dumps({"key": key, "timing": timing}, indent=2) + "\n")
    rows = read_mot(path, check_unique=False) if path.stat().st_size else np.zeros((0, 10))
    return rows[:, :7].copy()


def hog_timing(video: str | os.PathLike[str], frames: Any = None,
               cache_dir: str | os.PathLike[str] | None = None,
               config: str | dict[str, Any] = HOG_PRESET) -> dict[str, Any] | None:
    """The detection time stored beside a cached :func:`hog_detections` result (None when not
    cached)."""
    meta = _hog_cache(Path(video), frames, cache_dir, config)[3]
    return json.loads(meta.read_text())["timing"] if meta.is_file() else None


def _hog_cache(video: Path, frames: Any, cache_dir: str | os.PathLike[str] | None,
               config: str | dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any], Path, Path]:
    """(configuration, cache key, det file, its key-and-timing file) of a hog run."""
    from pftrack.io.frames import parse_frames
    from pftrack.workflows.pipeline import load_config

    cfg = load_config(config)
    if not cfg.get("detector"):
        raise ValueError(f"hog_detections: config {cfg.get('_source', config)} has no detector")
    key = _hog_key(video, cfg["detector"], parse_frames(frames))
    digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]
    root = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    path = root / f"hog-{video.stem}-{digest}.txt"
    return cfg, key, path, path.with_suffix(".json")


def write_det_file(path: str | os.PathLike[str], det_rows: np.ndarray) -> Path:
    """Write det rows (N, 7) as a MOTChallenge ``det.txt``, atomically."""
    import io

    from pftrack.io.atomic import atomic_write_text

    rows = np.asarray(det_rows, dtype=np.float64).reshape(-1, 7)
    buf = io.StringIO()
    np.savetxt(buf, rows, fmt=["%d", "%d"] + ["%.3f"] * 4 + ["%.4f"], delimiter=",")
    return atomic_write_text(path, buf.getvalue())


# --------------------------------------------------------------------------------------------
# Trackers
# --------------------------------------------------------------------------------------------


@dataclass
class TrackInput:
    """What every tracker of one cell gets: the video, the part's frames (inclusive, ground-truth
    numbering), the detections of those frames as a ``det.txt`` (``det_path``), the seed (the
    noise seed; pftrack's random stream), the video's frame rate and image size."""

    video: Path
    frames: tuple[int, int]
    det_path: Path
    seed: int
    fps: float
    image_wh: tuple[int, int]
    _dets: dict[int, Any] | None = field(default=None, repr=False)

    def detections(self) -> dict[int, Any]:
        """The det file read as ``pftrack run --detections`` reads it."""
        if self._dets is None:
            from pftrack.io.detections import read_detections

            self._dets = read_detections(self.det_path)
        return self._dets


@dataclass
class TrackResult:
    """One tracker's run on one cell: MOT rows (M, 10); its own time (seconds, summed over the
    frames: CPU and wall) and the frames it stepped; ``status`` ``"ok"``, ``"fallback"`` (it
    ran, not as asked: ``message`` says how) or ``"failed"`` (no usable tracks: ``message``
    says why)."""

    rows: np.ndarray
    cpu_s: float = 0.0
    wall_s: float = 0.0
    n_frames: int = 0
    status: str = "ok"
    message: str = ""


@dataclass(frozen=True)
class TrackerEntry:
    """A tracker the bench runs: ``run(TrackInput) -> TrackResult``; ``kind`` ``"pftrack"`` or
    ``"peer"`` (the goals compare the first against the best of the second); ``settings``
    (JSON) say how it is configured."""

    name: str
    kind: str
    run: Callable[[TrackInput], TrackResult]
    settings: dict[str, Any] = field(default_factory=dict)


def _nan_message(rows: np.ndarray) -> str | None:
    bad = ~np.all(np.isfinite(rows), axis=1) if len(rows) else np.zeros(0, bool)
    if bad.any():
        return f"row {int(np.flatnonzero(bad)[0]) + 1} of its tracks has a NaN or infinite value"
    return None


def _pftrack_run(config: str | os.PathLike[str] | dict[str, Any], inp: TrackInput) -> TrackResult:
    """``pftrack run CONFIG --video V --detections det.txt --frames A:B --seed S``'s library
    call, with its engine-step time."""
    import warnings

    from pftrack.workflows.pipeline import FrameWarning, run_pipeline

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FrameWarning)
        run = run_pipeline(config, video=inp.video, frames=inp.frames, seed=inp.seed,
                           detections=str(inp.det_path), progress=False, report=False)
    n = max(run.n_frames, 1)
    res = TrackResult(run.rows, cpu_s=run.timing["tracking_cpu_s_per_frame"] * n,
                      wall_s=run.timing["tracking_s_per_frame"] * n, n_frames=run.n_frames)
    return _check_rows(res)


def _check_rows(res: TrackResult) -> TrackResult:
    why = _nan_message(res.rows)
    if why is not None:
        res.status, res.message = "failed", why
    return res


def run_pftrack_config(config: str | os.PathLike[str] | dict[str, Any],
                       video: str | os.PathLike[str], frames: tuple[int, int],
                       det_rows: np.ndarray, seed: int = 0) -> np.ndarray:
    """pftrack with ``config`` (a preset name, a YAML path or a configuration dict, e.g. a
    preset loaded with :func:`pftrack.workflows.pipeline.load_config` and modified) on given
    detections.

    ``det_rows`` (N, 7) are written to a temporary ``det.txt`` and tracked as ``pftrack run
    CONFIG --video VIDEO --detections det.txt --frames A:B --seed SEED`` does. Returns the MOT
    track rows (M, 10); ValueError when they hold a NaN.
    """
    import tempfile

    from pftrack.workflows.pipeline import video_fps

    first, last = int(frames[0]), int(frames[1])
    with tempfile.TemporaryDirectory() as tmp:
        det = write_det_file(Path(tmp) / "det.txt", _in_frames(det_rows, first, last))
        inp = TrackInput(Path(video), (first, last), det, int(seed), video_fps(video), (0, 0))
        res = _pftrack_run(config, inp)
    if res.status == "failed":
        raise ValueError(f"run_pftrack_config: {res.message}")
    return res.rows


def pftrack_config_entry(name: str, config: str | os.PathLike[str] | dict[str, Any]
                         ) -> TrackerEntry:
    """A tracker entry running pftrack with ``config`` (see :func:`run_pftrack_config`)."""
    from pftrack.workflows.pipeline import load_config

    cfg = load_config(config)  # checked now, not after the first cell
    src = str(config) if not isinstance(config, dict) else cfg.get("_source", "dict")
    return TrackerEntry(name, "pftrack", lambda inp: _pftrack_run(cfg, inp),
                        {"config": src, "preset": cfg.get("name")})


def _pftrack_track(inp: TrackInput) -> TrackResult:
    """``pftrack track VIDEO --detections det.txt --frames A:B --seed S`` (a camera estimated
    from the detections, ``people-image`` tracks placed on the ground through it); engine-step
    time only (not the camera fit)."""
    import warnings

    from pftrack.workflows.pipeline import FrameWarning
    from pftrack.workflows.track import track_video

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FrameWarning)
            fr = track_video(inp.video, None, detections=str(inp.det_path),
                             frames=f"{inp.frames[0]}:{inp.frames[1]}", seed=inp.seed,
                             report=False)
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        return TrackResult(np.zeros((0, 10)), status="failed", message=str(exc))
    run = fr.run
    n = max(run.n_frames, 1)
    res = TrackResult(run.rows, cpu_s=run.timing["tracking_cpu_s_per_frame"] * n,
                      wall_s=run.timing["tracking_s_per_frame"] * n, n_frames=run.n_frames)
    if fr.fit is None:
        res.status = "fallback"
        res.message = "; ".join(m for m in fr.messages if m.startswith("no camera")) or \
            str(fr.summary.get("camera"))
    return _check_rows(res)


#: norfair's settings: IoU distance (1 - IoU) below 0.7 matches; a track dies after 15 frames
#: without a match (its default) and is shown after 2 matched frames.
NORFAIR_SETTINGS = {"distance_function": "iou", "distance_threshold": 0.7,
                    "hit_counter_max": 15, "initialization_delay": 2}


def _norfair(inp: TrackInput) -> TrackResult:
    from pftrack_bench.fresh_video import norfair_tracks

    s = NORFAIR_SETTINGS
    timing: dict[str, float] = {}
    first, last = inp.frames
    rows = norfair_tracks(inp.detections(), range(first, last + 1), 0.0,
                          distance_threshold=s["distance_threshold"],
                          hit_counter_max=s["hit_counter_max"],
                          initialization_delay=s["initialization_delay"], timing=timing)
    return TrackResult(rows, timing["cpu_s"], timing["wall_s"], last - first + 1)


def _roboflow(cls_name: str, needs_frame: bool = False) -> Callable[[TrackInput], TrackResult]:
    """A roboflow ``trackers`` tracker with its defaults (``frame_rate`` the video's), fed
    ``supervision.Detections`` of the boxes; rows from its confirmed tracks (id >= 0)."""

    def run(inp: TrackInput) -> TrackResult:
        import supervision as sv
        import trackers

        tracker = getattr(trackers, cls_name)(frame_rate=float(inp.fps))
        dets = inp.detections()
        first, last = inp.frames
        images: Any = None
        if needs_frame:
            from pftrack.workflows.pipeline import iter_frames

            images = iter_frames(inp.video, first, last)
        rows: list[np.ndarray] = []
        cpu = wall = 0.0
        n = 0
        for f in range(first, last + 1):
            image = None
            if images is not None:
                frame = next(images, None)
                if frame is None:
                    break
                image = frame.image
            d = dets.get(f)
            if d is not None and len(d):
                b = d.boxes_xywh_px
                xyxy = np.column_stack([b[:, :2], b[:, :2] + b[:, 2:]])
                det = sv.Detections(xyxy=xyxy, confidence=d.scores.copy(),
                                    class_id=np.zeros(len(b), dtype=int))
            else:
                det = sv.Detections.empty()
            t0, c0 = time.perf_counter(), time.process_time()
            out = tracker.update(det, frame=image) if needs_frame else tracker.update(det)
            wall += time.perf_counter() - t0
            cpu += time.process_time() - c0
            n += 1
            ids = np.asarray(out.tracker_id if out.tracker_id is not None else [], dtype=int)
            ok = ids >= 0
            if ok.any():
                xy = np.asarray(out.xyxy, dtype=np.float64)[ok]
                r = np.full((int(ok.sum()), 10), -1.0)
                r[:, 0], r[:, 1] = f, ids[ok]
                r[:, 2:4], r[:, 4:6] = xy[:, :2], xy[:, 2:] - xy[:, :2]
                r[:, 6] = 1.0
                rows.append(r)
        out_rows = np.concatenate(rows) if rows else np.zeros((0, 10))
        return TrackResult(out_rows, cpu, wall, n)

    return run


def default_trackers() -> dict[str, TrackerEntry]:
    """The bench's trackers by name: pftrack's ``people-image`` and ``track`` (ground plane),
    and the peers ``norfair``, ``bytetrack``, ``sort``, ``ocsort``, ``botsort``."""
    import trackers

    version = getattr(trackers, "__version__", None)
    if version is None:
        from importlib.metadata import version as _v

        version = _v("trackers")

    def rf(cls: str) -> dict[str, Any]:
        return {"package": f"trackers {version}", "class": cls,
                "arguments": "defaults; frame_rate = the video's"}

    return {
        "people-image": TrackerEntry(
            "people-image", "pftrack", lambda inp: _pftrack_run("people-image", inp),
            {"command": "pftrack run people-image --video V --detections det.txt"}),
        "track": TrackerEntry(
            "track", "pftrack", _pftrack_track,
            {"command": "pftrack track V --detections det.txt (camera estimated from the "
                        "detections, people-image placed on the ground through it)"}),
        "norfair": TrackerEntry("norfair", "peer", _norfair, dict(NORFAIR_SETTINGS)),
        "bytetrack": TrackerEntry("bytetrack", "peer", _roboflow("ByteTrackTracker"),
                                  rf("ByteTrackTracker")),
        "sort": TrackerEntry("sort", "peer", _roboflow("SORTTracker"), rf("SORTTracker")),
        "ocsort": TrackerEntry("ocsort", "peer", _roboflow("OCSORTTracker"),
                               rf("OCSORTTracker")),
        "botsort": TrackerEntry("botsort", "peer", _roboflow("BoTSORTTracker", needs_frame=True),
                                {**rf("BoTSORTTracker"), "note": "camera-motion compensation "
                                 "(sparse optical flow) on the frames; no appearance model"}),
    }


# --------------------------------------------------------------------------------------------
# Scoring
# --------------------------------------------------------------------------------------------


def _in_frames(rows: np.ndarray, first: int, last: int) -> np.ndarray:
    rows = np.asarray(rows, dtype=np.float64)
    return rows[(rows[:, 0] >= first) & (rows[:, 0] <= last)]


def mot17_scoring_rows(gt_rows: np.ndarray, track_rows: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """MOT17's rule as TrackEval applies it: ``(gt, tracks)`` ready for
    :func:`pftrack.metrics.evaluate`.

    In each frame the tracker boxes are matched one to one to *every* ground-truth box of the
    frame (Hungarian on IoU, pairs below 0.5 not allowed); a tracker box matched to a box of
    class 2, 7, 8 or 12 is removed. The ground truth kept is the pedestrians (consider 1, class
    1), flag set to 1, world columns -1; the other classes count neither way.
    """
    from pftrack.geometry.boxes import iou_matrix
    from scipy.optimize import linear_sum_assignment

    g = np.asarray(gt_rows, dtype=np.float64).reshape(-1, 10)
    t = np.asarray(track_rows, dtype=np.float64).reshape(-1, 10)
    drop = np.zeros(len(t), dtype=bool)
    gf, tf = g[:, 0].astype(np.int64), t[:, 0].astype(np.int64)
    distractor = np.isin(g[:, 7], MOT17_DISTRACTOR_CLASSES)
    for f in np.intersect1d(np.unique(gf[distractor]), np.unique(tf)):
        gi, ti = np.flatnonzero(gf == f), np.flatnonzero(tf == f)
        iou = iou_matrix(g[gi, 2:6], t[ti, 2:6])
        iou[iou < 0.5 - np.finfo(float).eps] = 0.0
        r, c = linear_sum_assignment(-iou)
        ok = iou[r, c] > np.finfo(float).eps
        hit = distractor[gi[r[ok]]]
        drop[ti[c[ok][hit]]] = True
    keep_g = (g[:, 6] == 1) & (g[:, 7] == 1)
    gk = g[keep_g].copy()
    gk[:, 6] = 1.0
    gk[:, 7:10] = -1.0
    return gk, t[~drop]


#: The figures reported per tracker (TrackEval's definitions).
FIGURES = ("HOTA", "IDF1", "MOTA", "IDSW", "Frag")


def score_tracks(gt_rows: np.ndarray, track_rows: np.ndarray, rule: str,
                 frames: tuple[int, int]) -> dict[str, Any]:
    """:func:`pftrack.metrics.evaluate` (IoU 0.5) of the tracks on ``frames`` with the video's
    rule: ``"pets"``: flag-0 rows dropped with the tracker boxes matching them
    (``zero_marked="drop_matched"``); ``"mot17"``: :func:`mot17_scoring_rows`, then every kept
    row counts."""
    from pftrack.metrics import evaluate

    g = _in_frames(np.asarray(gt_rows).reshape(-1, 10), *frames)
    t = _in_frames(np.asarray(track_rows).reshape(-1, 10), *frames)
    if rule == "pets":
        return evaluate(g, t, metric="iou", threshold=0.5, zero_marked="drop_matched")
    if rule == "mot17":
        gk, tk = mot17_scoring_rows(g, t)
        return evaluate(gk, tk, metric="iou", threshold=0.5, zero_marked="keep")
    raise ValueError(f"own-detections: unknown scoring rule {rule!r} (pets, mot17)")


# --------------------------------------------------------------------------------------------
# The benchmark
# --------------------------------------------------------------------------------------------


def resolve_frames(name: str, part: str, frames: tuple[int, int] | None = None
                   ) -> tuple[int, int]:
    """The frames to track and score: the part's, or ``frames`` (inclusive) inside it.

    Raises ValueError when ``frames`` reach outside ``part``: tune-part frames are shown only
    when the tune part is asked for, and a report figure never includes a tune frame
    (:func:`pftrack_bench.protocol.part_frames`)."""
    video_spec(name)
    return _part_frames("own-detections", PROTOCOL, part, frames, video=name)


def _select_trackers(names: Sequence[str | TrackerEntry] | None,
                     extra: Sequence[TrackerEntry] = ()) -> list[TrackerEntry]:
    known = default_trackers()
    out: list[TrackerEntry] = []
    for n in (list(known) if names is None else names):
        if isinstance(n, TrackerEntry):
            out.append(n)
        elif n in known:
            out.append(known[n])
        else:
            raise ValueError(f"own-detections: unknown tracker {n!r} (known: "
                             f"{', '.join(known)})")
    out.extend(extra)
    seen: set[str] = set()
    for e in out:
        if e.name in seen:
            raise ValueError(f"own-detections: two trackers named {e.name!r}")
        seen.add(e.name)
    return out


def _git_commit() -> dict[str, Any]:
    import subprocess

    here = Path(__file__).resolve().parent
    try:
        head = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], check=True,
                              capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(here), "status", "--porcelain",
                                "--untracked-files=no"], check=True, capture_output=True,
                               text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return {"commit": None, "dirty": None}
    return {"commit": head, "dirty": bool(dirty)}


def _machine() -> dict[str, Any]:
    import platform

    return {"platform": platform.platform(), "processor": platform.processor() or
            platform.machine(), "cpu_count": os.cpu_count(), "python": platform.python_version()}


def _summarise(cells: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per (video, level, tracker): mean, min and max of the figures over the runs that gave
    tracks, and the CPU time per frame with its ratio to ByteTrack's on the same cells."""
    keys = list(dict.fromkeys((c["video"], c["level"], c["tracker"]) for c in cells))
    out = []
    for video, level, tracker in keys:
        mine = [c for c in cells if (c["video"], c["level"], c["tracker"]) == (video, level,
                                                                               tracker)]
        ok = [c for c in mine if c["status"] != "failed"]
        s: dict[str, Any] = {"video": video, "level": level, "tracker": tracker,
                             "kind": mine[0]["kind"], "runs": len(mine),
                             "failed": len(mine) - len(ok),
                             "fallback": sum(c["status"] == "fallback" for c in mine),
                             "messages": sorted({c["message"] for c in mine if c["message"]})}
        for k in FIGURES:
            v = np.asarray([c[k] for c in ok], dtype=np.float64)
            s[f"{k}_mean"] = float(v.mean()) if len(v) else None
            s[f"{k}_min"] = float(v.min()) if len(v) else None
            s[f"{k}_max"] = float(v.max()) if len(v) else None
            s[f"{k}_sd"] = float(v.std(ddof=1)) if len(v) > 1 else None
        frames = sum(c["n_frames"] for c in ok)
        cpu = sum(c["cpu_s"] for c in ok)
        s["cpu_ms_per_frame"] = 1000.0 * cpu / frames if frames else None
        s["wall_ms_per_frame"] = 1000.0 * sum(c["wall_s"] for c in ok) / frames if frames \
            else None
        out.append(s)
    for s in out:
        bt = next((b for b in out if (b["video"], b["level"], b["tracker"]) ==
                   (s["video"], s["level"], "bytetrack")), None)
        s["cpu_ratio_to_bytetrack"] = (
            s["cpu_ms_per_frame"] / bt["cpu_ms_per_frame"]
            if bt and s["cpu_ms_per_frame"] is not None and bt["cpu_ms_per_frame"] else None)
    return out


def _speed(cells: list[dict[str, Any]]) -> dict[str, Any]:
    """Each tracker's CPU ms per frame over every cell of the run, and its ratio to
    ByteTrack's over the same cells."""
    out: dict[str, Any] = {}
    names = list(dict.fromkeys(c["tracker"] for c in cells))
    for n in names:
        ok = [c for c in cells if c["tracker"] == n and c["status"] != "failed"]
        frames = sum(c["n_frames"] for c in ok)
        out[n] = {"cpu_ms_per_frame": 1000.0 * sum(c["cpu_s"] for c in ok) / frames
                  if frames else None}
    bt = out.get("bytetrack", {}).get("cpu_ms_per_frame")
    for v in out.values():
        v["ratio_to_bytetrack"] = (v["cpu_ms_per_frame"] / bt
                                   if bt and v["cpu_ms_per_frame"] is not None else None)
    return out


def judge_goals(result: dict[str, Any]) -> dict[str, Any]:
    """The issue's goals for each pftrack tracker of a result: in every (video, level) cell,
    mean HOTA and IDF1 above the best peer's mean, mean IDSW no more than the best (lowest)
    peer's; CPU time per frame no more than ByteTrack's over the run. ``applies`` says whether
    the run is one the goals are judged on (report part, >= 5 seeds, both videos, clean, noisy
    and hog)."""
    summary = result["summary"]
    applies = (result["part"] == REPORT_PART and len(result["seeds"]) >= 5
               and set(result["videos"]) >= set(VIDEOS)
               and set(result["levels"]) >= {*LEVELS, HOG_LEVEL})
    out: dict[str, Any] = {"applies": bool(applies), "trackers": {}}
    mine = [n for n in dict.fromkeys(s["tracker"] for s in summary)
            if next(s for s in summary if s["tracker"] == n)["kind"] == "pftrack"]
    for name in mine:
        cells = []
        for s in summary:
            if s["tracker"] != name:
                continue
            peers = [p for p in summary if p["kind"] == "peer" and p["failed"] == 0
                     and (p["video"], p["level"]) == (s["video"], s["level"])]
            if not peers:
                continue
            best = {"HOTA": max(p["HOTA_mean"] for p in peers),
                    "IDF1": max(p["IDF1_mean"] for p in peers),
                    "IDSW": min(p["IDSW_mean"] for p in peers)}
            ok = s["failed"] == 0
            c = {"video": s["video"], "level": s["level"], "best_peer": best,
                 "HOTA": s["HOTA_mean"], "IDF1": s["IDF1_mean"], "IDSW": s["IDSW_mean"],
                 "HOTA_met": ok and s["HOTA_mean"] > best["HOTA"],
                 "IDF1_met": ok and s["IDF1_mean"] > best["IDF1"],
                 "IDSW_met": ok and s["IDSW_mean"] <= best["IDSW"]}
            c["met"] = bool(c["HOTA_met"] and c["IDF1_met"] and c["IDSW_met"])
            cells.append(c)
        sp = result["speed"].get(name, {})
        ratio = sp.get("ratio_to_bytetrack")
        out["trackers"][name] = {
            "cells": cells, "identity_met": bool(cells) and all(c["met"] for c in cells),
            "speed": {"ratio_to_bytetrack": ratio,
                      "met": ratio is not None and ratio <= 1.0}}
    return out


#: Frames of the warm-up run each tracker makes before its first timed run.
WARM_UP_FRAMES = 30


def _warm_up(entry: TrackerEntry, inp: TrackInput) -> None:
    from dataclasses import replace

    first, last = inp.frames
    try:
        entry.run(replace(inp, frames=(first, min(first + WARM_UP_FRAMES - 1, last))))
    except (ValueError, RuntimeError, ArithmeticError, LookupError, np.linalg.LinAlgError):
        pass  # its timed run will say what fails


def run_benchmark(*, videos: Sequence[str] = tuple(VIDEOS),
                  levels: Sequence[str] = (*LEVELS, HOG_LEVEL),
                  seeds: Sequence[int] = DEFAULT_SEEDS, part: str = REPORT_PART,
                  trackers: Sequence[str | TrackerEntry] | None = None,
                  extra: Sequence[TrackerEntry] = (),
                  frames: dict[str, tuple[int, int]] | None = None,
                  data: str | os.PathLike[str] | None = None,
                  cache_dir: str | os.PathLike[str] | None = None,
                  log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run the bench and return its result (JSON-ready; :func:`format_table` prints it).

    Parameters
    ----------
    videos : names in :data:`VIDEOS`
    levels : ``"clean"``, ``"noisy"`` (simulated, one detection set per seed), ``"hog"`` (the
        ``hog-people`` detector, once; pftrack's seed the first of ``seeds``)
    seeds : noise seeds (also pftrack's tracking seed for that detection set)
    part : ``"report"`` (default) or ``"tune"``
    trackers : names of :func:`default_trackers` or :class:`TrackerEntry` (default: all)
    extra : more entries, e.g. :func:`pftrack_config_entry` of a modified preset
    frames : per video, an inclusive frame range inside ``part`` (:func:`resolve_frames`)
    data : the folder holding ``pets09/`` and ``mot17-09/``
    cache_dir : where the ``hog-people`` detections are cached (:func:`hog_detections`)
    log : called with a progress line per run
    """
    import tempfile

    from pftrack.workflows.pipeline import video_fps

    say = log or (lambda s: None)
    commit = _git_commit()  # the code that runs: read before, not after, a long run
    entries = _select_trackers(trackers, extra)
    for lv in levels:
        if lv != HOG_LEVEL:
            _level(lv)
    if not seeds:
        raise ValueError("own-detections: --seeds is empty")
    ranges = {v: resolve_frames(v, part, (frames or {}).get(v)) for v in videos}
    cells: list[dict[str, Any]] = []
    hog_info: dict[str, Any] = {}
    warmed: set[str] = set()
    with tempfile.TemporaryDirectory(prefix="pftrack-own-det-") as tmp:
        for name in videos:
            spec = video_spec(name)
            video, _ = data_files(name, data)
            gt = read_gt(name, data)
            fps = video_fps(video)
            first, last = ranges[name]
            for level in levels:
                for seed in ([None] if level == HOG_LEVEL else list(seeds)):
                    if level == HOG_LEVEL:
                        say(f"own-detections: hog-people detections of {name} (cached) ...")
                        det = hog_detections(video, None, cache_dir, progress=log is not None)
                        hog_info[name] = hog_timing(video, None, cache_dir)
                    else:
                        det = simulate_detections(gt, level, int(seed), spec.image_wh,
                                                  detectable=detectable_mask(gt, spec.rule))
                    det = _in_frames(det, first, last)
                    path = write_det_file(Path(tmp) / f"{name}-{level}-{seed}.txt", det)
                    inp = TrackInput(video, (first, last), path,
                                     int(seeds[0] if seed is None else seed), fps, spec.image_wh)
                    for e in entries:
                        if e.name not in warmed:
                            # first calls pay imports and compiled kernels: not the tracker's
                            # time per frame; a run on the cell's first frames, discarded
                            warmed.add(e.name)
                            _warm_up(e, inp)
                        say(f"own-detections: {name} {level} seed {seed}: {e.name} ...")
                        try:
                            res = e.run(inp)
                        except (ValueError, RuntimeError, ArithmeticError, LookupError,
                                np.linalg.LinAlgError) as exc:  # a failure is a result
                            res = TrackResult(np.zeros((0, 10)), status="failed",
                                              message=f"{type(exc).__name__}: {exc}")
                        cell: dict[str, Any] = {
                            "video": name, "level": level, "seed": seed, "tracker": e.name,
                            "kind": e.kind, "status": res.status, "message": res.message,
                            "n_frames": res.n_frames, "cpu_s": res.cpu_s, "wall_s": res.wall_s,
                            "n_detections": len(det)}
                        if res.status != "failed":
                            m = score_tracks(gt, res.rows, spec.rule, (first, last))
                            cell.update({k: m[k] for k in FIGURES})
                            cell.update({k: m[k] for k in ("DetA", "AssA", "FP", "FN",
                                                           "num_tracker_ids", "num_gt_ids")})
                        cells.append(cell)
    result: dict[str, Any] = {
        "bench": "own-detections", **commit,
        "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "machine": _machine(), "protocol": protocol(),
        "part": part, "settings_chosen_on": TUNE_PART,
        "frames": {v: list(r) for v, r in ranges.items()},
        "videos": list(videos), "levels": list(levels), "seeds": [int(s) for s in seeds],
        "trackers": {e.name: {"kind": e.kind, **e.settings} for e in entries},
        "hog_detection_timing": hog_info, "warm_up_frames": WARM_UP_FRAMES,
        "cells": cells,
    }
    result["summary"] = _summarise(cells)
    result["speed"] = _speed(cells)
    result["goals"] = judge_goals(result)
    return result


def merge_results(results: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """One result from runs of the same commit, part, levels, seeds and trackers on different
    videos (e.g. one process per video on a machine with cores to spare): cells joined,
    summary, speed and goals recomputed. Each video's ratios to ByteTrack stay those of its
    own run; the whole-run speed sums every run's CPU time."""
    if not results:
        raise ValueError("merge_results: no result to merge")
    first = results[0]
    same = ("commit", "part", "levels", "seeds", "trackers")
    for r in results[1:]:
        for k in same:
            if r[k] != first[k]:
                raise ValueError(f"merge_results: the runs differ in {k!r} ({first[k]!r} and "
                                 f"{r[k]!r})")
    videos = [v for r in results for v in r["videos"]]
    if len(set(videos)) != len(videos):
        raise ValueError(f"merge_results: a video appears in two runs ({videos})")
    out = {**first, "videos": videos, "dirty": any(r["dirty"] for r in results),
           "date_utc": max(r["date_utc"] for r in results),
           "frames": {k: v for r in results for k, v in r["frames"].items()},
           "hog_detection_timing": {k: v for r in results
                                    for k, v in r["hog_detection_timing"].items()},
           "cells": [c for r in results for c in r["cells"]], "merged_runs": len(results)}
    out["summary"] = _summarise(out["cells"])
    out["speed"] = _speed(out["cells"])
    out["goals"] = judge_goals(out)
    return out


# --------------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------------


def _csv(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--videos", default=",".join(VIDEOS), metavar="V,...",
                        help=f"videos (default {','.join(VIDEOS)})")
    parser.add_argument("--levels", default=",".join([*LEVELS, HOG_LEVEL]), metavar="L,...",
                        help="detections: clean, noisy (simulated from the ground truth, one "
                             "set per seed), hog (the hog-people detector, once) (default all)")
    parser.add_argument("--seeds", default=",".join(map(str, DEFAULT_SEEDS)), metavar="S,...",
                        help="noise seeds, also pftrack's tracking seeds (default 0,1,2,3,4)")
    add_part_argument(parser, PROTOCOL)
    parser.add_argument("--frames", action="append", default=[], metavar="VIDEO=A:B",
                        help="track and score only frames A:B of VIDEO (inside the part; "
                             "repeatable), for a quick look")
    parser.add_argument("--trackers", default=None, metavar="T,...",
                        help="trackers (default all: people-image, track, norfair, bytetrack, "
                             "sort, ocsort, botsort)")
    parser.add_argument("--config", action="append", default=[], metavar="FILE.yaml",
                        help="also run pftrack with this configuration, a row named after the "
                             "file (repeatable)")
    parser.add_argument("--data", default=None,
                        help="folder holding pets09/ and mot17-09/ (default: $PFTRACK_DATA or "
                             "../shared/data)")
    parser.add_argument("--cache-dir", default=None, metavar="DIR",
                        help="where the hog-people detections are cached (default "
                             "$PFTRACK_CACHE or ~/.cache/pftrack)")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


def run(args: argparse.Namespace) -> dict[str, Any]:
    part = args.part or REPORT_PART
    videos = _csv(args.videos)
    for v in videos:
        video_spec(v)
    frames: dict[str, tuple[int, int]] = {}
    for item in args.frames:
        v, sep, rng = item.partition("=")
        if not sep or v not in videos:
            raise ValueError(f"own-detections: --frames {item!r}: expected VIDEO=A:B with VIDEO "
                             f"one of {', '.join(videos)}")
        from pftrack.io.frames import parse_frames

        a, b = parse_frames(rng)
        frames[v] = (a, b if b is not None else part_frames(v, part)[1])
    try:
        seeds = [int(s) for s in _csv(args.seeds)]
    except ValueError:
        raise ValueError(f"own-detections: --seeds must be integers, got {args.seeds!r}") from None
    extra = []
    for path in args.config:
        p = Path(path)
        if not p.is_file():
            raise FileNotFoundError(f"own-detections: --config {path} not found")
        extra.append(pftrack_config_entry(p.stem, p))
    log = None if args.quiet else (lambda s: print(s, file=sys.stderr, flush=True))
    return run_benchmark(videos=videos, levels=_csv(args.levels), seeds=seeds, part=part,
                         trackers=None if args.trackers is None else _csv(args.trackers),
                         extra=extra, frames=frames, data=args.data, cache_dir=args.cache_dir,
                         log=log)


def _f(x: Any, nd: int = 3) -> str:
    if x is None:
        return "-"
    return f"{x:.{nd}f}" if isinstance(x, float) else str(x)


def _spread(s: dict[str, Any], k: str, nd: int) -> str:
    if s[f"{k}_mean"] is None:
        return "failed"
    if s["runs"] - s["failed"] <= 1 or s[f"{k}_min"] == s[f"{k}_max"]:
        return _f(s[f"{k}_mean"], nd)
    return f"{s[f'{k}_mean']:.{nd}f} [{s[f'{k}_min']:.{nd}f}-{s[f'{k}_max']:.{nd}f}]"


def format_table(result: dict[str, Any]) -> str:
    """The result as text: one table per video and level (mean [min-max] over seeds), the
    speed and the goals."""
    lines = []
    part = result["part"]
    if part == TUNE_PART:
        lines.append("TUNE PART: these frames chose the settings; they are not a result.")
    commit = (result.get("commit") or "?")[:10] + (" (uncommitted changes)" if
                                                   result.get("dirty") else "")
    lines.append(f"own-detections, {part} part (settings chosen on the {TUNE_PART} part), "
                 f"seeds {','.join(map(str, result['seeds']))}; commit {commit}, "
                 f"{result['date_utc']}, {result['machine']['cpu_count']} CPUs")
    head = (f"  {'tracker':<14}{'HOTA':>22}{'IDF1':>22}{'MOTA':>22}{'IDSW':>20}{'Frag':>23}"
            f"{'ms/frame':>10}{'xByteTrack':>11}")
    for v in result["videos"]:
        a, b = result["frames"][v]
        for lv in result["levels"]:
            rows = [s for s in result["summary"] if (s["video"], s["level"]) == (v, lv)]
            if not rows:
                continue
            n = rows[0]["runs"]
            lines.append(f"{VIDEOS[v].title} frames {a}-{b}, {lv} detections"
                         + (f" (mean [min-max] of {n} seeds)" if n > 1 else ""))
            lines.append(head)
            for s in rows:
                note = ""
                if s["failed"]:
                    note = f"  {s['failed']} failed: {'; '.join(s['messages'])[:160]}"
                elif s["fallback"]:
                    note = f"  {s['fallback']} fell back: {'; '.join(s['messages'])[:160]}"
                lines.append(
                    f"  {s['tracker']:<14}{_spread(s, 'HOTA', 3):>22}{_spread(s, 'IDF1', 3):>22}"
                    f"{_spread(s, 'MOTA', 3):>22}{_spread(s, 'IDSW', 1):>20}"
                    f"{_spread(s, 'Frag', 1):>23}{_f(s['cpu_ms_per_frame'], 2):>10}"
                    f"{_f(s['cpu_ratio_to_bytetrack'], 2):>11}{note}")
    lines.append("CPU time per frame over the whole run (tracker's own calls, detections given, "
                 "decoding excluded):")
    lines.append("  " + ", ".join(f"{n} {_f(v['cpu_ms_per_frame'], 2)} ms "
                                  f"(x{_f(v['ratio_to_bytetrack'], 2)})"
                                  for n, v in result["speed"].items()))
    g = result["goals"]
    lines.append("Goals (each level and video: mean HOTA and IDF1 above the best peer's, mean "
                 "IDSW at most the best peer's; CPU per frame at most ByteTrack's)"
                 + ("" if g["applies"] else " -- this run is not one the goals are judged on "
                    "(they need the report part, >= 5 seeds, both videos, clean, noisy, hog)"))
    for name, t in g["trackers"].items():
        missed = [f"{c['video']}/{c['level']} ("
                  + ", ".join(k for k in ("HOTA", "IDF1", "IDSW") if not c[f"{k}_met"]) + ")"
                  for c in t["cells"] if not c["met"]]
        lines.append(f"  {name}: identity {'met' if t['identity_met'] else 'NOT met'}"
                     + (f" (missed: {', '.join(missed)})" if missed else "")
                     + f"; speed {'met' if t['speed']['met'] else 'NOT met'} "
                     f"(x{_f(t['speed']['ratio_to_bytetrack'], 2)} ByteTrack)")
    return "\n".join(lines)
