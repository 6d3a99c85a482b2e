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
people-image --detections det.txt`` runs), ``people-image-boxes`` (the same without its colour
model per track: tracking on the detections alone) and ``track`` through
:func:`pftrack.workflows.track.track_video` (what ``pftrack track VIDEO --detections det.txt``
runs: a camera estimated from the detections, the tracks kept in the image plane with
``people-image`` and placed on the ground through that camera); the peers with their
documented defaults: norfair (IoU distance), and roboflow ``trackers``' ByteTrack, SORT,
OC-SORT and BoT-SORT (camera-motion compensation on, no appearance model), fed
``supervision.Detections`` of the same boxes. ``--config FILE.yaml`` adds pftrack with that
configuration (a row named after the file). A tracker that fails on a video (no camera, a NaN
in its output) gives a failure row with its message, not a crash.

**Figures**: HOTA, IDF1, MOTA, IDSW and Frag per tracker, video and level; for the simulated
levels the mean and the min-max over seeds. Time per frame: CPU seconds spent in the tracker's
own update calls (pftrack: its engine steps, :attr:`pftrack.workflows.pipeline.RunResult.timing`),
with the detections given and the video's decoding excluded, and its ratio to ByteTrack's in the
same run. The speed goals: on detections alone (``people-image-boxes``) no slower than
ByteTrack; with image terms (``people-image``, ``track``) at most
:data:`IMAGE_TERM_MS_PER_FRAME` ms per frame on PETS. Each tracker first runs once on the
first cell's first :data:`WARM_UP_FRAMES` frames, untimed and discarded (imports, compiled
kernels).

From Python, e.g. a modified preset against the peers on the tune part::

    from pftrack.workflows.pipeline import load_config
    from pftrack_bench import own_detections as bod

    cfg = load_config("people-image")
    cfg["tracker"]["max_misses_s"] = 4.0
    r = bod.run_benchmark(part="tune", levels=["clean", "noisy"], seeds=[0, 1, 2],
                          trackers=["bytetrack", "norfair"],
                          extra=[bod.pftrack_config_entry("people-image-4s", cfg)])
    print(bod.format_table(r))

:func:`simulate_detections`, :func:`hog_detections`, :func:`run_pftrack_config` and
:func:`score_tracks` are the pieces, usable alone.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pftrack_bench.own_detection_sets import (  # noqa: F401 (public here as well)
    HOG_LEVEL,
    HOG_PRESET,
    LEVELS,
    MOT17_MIN_VISIBILITY,
    NoiseLevel,
    _level,
    default_cache_dir,
    detectable_mask,
    hog_detections,
    hog_timing,
    simulate_detections,
)
from pftrack_bench.own_trackers import (
    TrackerEntry,
    TrackInput,
    TrackResult,
    _in_frames,
    default_trackers,
    pftrack_config_entry,
    run_pftrack_config,
    write_det_file,
)
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
# Scoring
# --------------------------------------------------------------------------------------------


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
        s["cpu_ms_per_frame"] = _ms_per_frame(mine)
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


def _ms_per_frame(cells: list[dict[str, Any]]) -> float | None:
    ok = [c for c in cells if c["status"] != "failed"]
    frames = sum(c["n_frames"] for c in ok)
    return 1000.0 * sum(c["cpu_s"] for c in ok) / frames if frames else None


def _speed(cells: list[dict[str, Any]]) -> dict[str, Any]:
    """Each tracker's CPU ms per frame over every cell of the run and over the PETS cells
    alone (``pets09_cpu_ms_per_frame``: the density the speed goal with image terms names),
    and its ratio to ByteTrack's over the same cells."""
    out: dict[str, Any] = {}
    names = list(dict.fromkeys(c["tracker"] for c in cells))
    for n in names:
        mine = [c for c in cells if c["tracker"] == n]
        out[n] = {"cpu_ms_per_frame": _ms_per_frame(mine),
                  "pets09_cpu_ms_per_frame": _ms_per_frame(
                      [c for c in mine if c["video"] == "pets09"])}
    bt = out.get("bytetrack", {}).get("cpu_ms_per_frame")
    for v in out.values():
        v["ratio_to_bytetrack"] = (v["cpu_ms_per_frame"] / bt
                                   if bt and v["cpu_ms_per_frame"] is not None else None)
    return out


#: The speed goal of a tracker with image terms (colour, templates): CPU ms per frame at most
#: this on PETS 2009 S2.L1 (about 6 people a frame), detections given.
IMAGE_TERM_MS_PER_FRAME = 5.0


def judge_goals(result: dict[str, Any]) -> dict[str, Any]:
    """The goals for each pftrack tracker of a result: in every (video, level) cell, mean HOTA
    and IDF1 above the best peer's mean, mean IDSW no more than the best (lowest) peer's. Speed,
    detections given: a tracker on detections alone (settings ``image_term`` false) no slower
    per frame than ByteTrack over the run; one with image terms at most
    :data:`IMAGE_TERM_MS_PER_FRAME` ms per frame on PETS. ``applies`` says whether the run is
    one the goals are judged on (report part, >= 5 seeds, both videos, clean, noisy and hog)."""
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
        pets_ms = sp.get("pets09_cpu_ms_per_frame")
        image_term = bool(result.get("trackers", {}).get(name, {}).get("image_term", True))
        if image_term:
            speed = {"goal": f"<= {IMAGE_TERM_MS_PER_FRAME:g} ms per frame on PETS",
                     "met": pets_ms is not None and pets_ms <= IMAGE_TERM_MS_PER_FRAME}
        else:
            speed = {"goal": "no slower than ByteTrack",
                     "met": ratio is not None and ratio <= 1.0}
        out["trackers"][name] = {
            "cells": cells, "identity_met": bool(cells) and all(c["met"] for c in cells),
            "speed": {"image_term": image_term, "ratio_to_bytetrack": ratio,
                      "pets09_cpu_ms_per_frame": pets_ms, **speed}}
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
                        help="trackers (default all: people-image, people-image-boxes, "
                             "track, norfair, bytetrack, sort, ocsort, botsort)")
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
                 "IDSW at most the best peer's; CPU per frame on detections alone at most "
                 f"ByteTrack's, with image terms at most {IMAGE_TERM_MS_PER_FRAME:g} ms on PETS)"
                 + ("" if g["applies"] else " -- this run is not one the goals are judged on "
                    "(they need the report part, >= 5 seeds, both videos, clean, noisy, hog)"))
    for name, t in g["trackers"].items():
        missed = [f"{c['video']}/{c['level']} ("
                  + ", ".join(k for k in ("HOTA", "IDF1", "IDSW") if not c[f"{k}_met"]) + ")"
                  for c in t["cells"] if not c["met"]]
        lines.append(f"  {name}: identity {'met' if t['identity_met'] else 'NOT met'}"
                     + (f" (missed: {', '.join(missed)})" if missed else "")
                     + f"; speed {'met' if t['speed']['met'] else 'NOT met'} "
                     f"({t['speed']['goal']}: x{_f(t['speed']['ratio_to_bytetrack'], 2)} "
                     f"ByteTrack, {_f(t['speed']['pets09_cpu_ms_per_frame'], 2)} ms on PETS)")
    return "\n".join(lines)
