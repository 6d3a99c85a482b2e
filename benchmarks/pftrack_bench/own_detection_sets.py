"""The detections ``pftrack bench own-detections`` feeds every tracker: simulated from the
ground truth at a noise level (:data:`LEVELS`, one set per noise seed, only the people a
detector could see), or the built-in ``hog-people`` detector's own boxes (:data:`HOG_LEVEL`,
cached on disk). :mod:`pftrack_bench.own_detections` describes the benchmark, and these names
import from there as well.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

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
