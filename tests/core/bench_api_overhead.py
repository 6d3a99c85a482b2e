"""What :meth:`pftrack.Tracker.update` adds to the engine's own time per frame (a measurement,
not a test).

PETS 2009 S2.L1, detections from the ground truth's boxes (score 0.9), given as numpy xyxy
arrays. In one process, on the same frames: every ``engine.step`` inside ``update`` is timed,
and the rest of ``update`` (input checks, the particle clouds' spread, the output arrays, the
history) is the overhead. Each configuration runs ``--repeats`` times; the ratio printed is
overhead / engine time summed over the runs, with the smallest and largest run's ratio. Times
are the thread's CPU time (on a shared, loaded machine wall time mostly measures waiting for a
core).

    python tests/core/bench_api_overhead.py --frames 1:150
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from pftrack.io.data import data_dir
from pftrack.io.frames import parse_frames
from pftrack.io.mot import read_mot
from pftrack.workflows.pipeline import iter_frames
from pftrack.workflows.stream import Tracker


def measure(config: str, frames: list, gt: np.ndarray, camera: str | None) -> tuple[float, float]:
    """(engine seconds, update seconds) of one run."""
    tr = Tracker(config, seed=0, fps=7, camera=camera)
    step_s = [0.0]
    timed: set[int] = set()

    def wrap(engine):
        if id(engine) in timed:
            return
        timed.add(id(engine))
        inner = engine.step

        def step(frame, detections=None):
            t0 = time.thread_time()
            out = inner(frame, detections)
            step_s[0] += time.thread_time() - t0
            return out

        engine.step = step

    wrap(tr._first)
    total = 0.0
    for fr in frames:
        g = gt[gt[:, 0] == fr.index]
        det = np.c_[g[:, 2:4], g[:, 2:4] + g[:, 4:6], np.full(len(g), 0.9)]
        t0 = time.thread_time()
        tr.update(det, frame=fr.image)
        total += time.thread_time() - t0
    return step_s[0], total


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", default="1:150")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    pets = data_dir() / "pets09"
    first, last = parse_frames(args.frames)
    gt = read_mot(pets / "gt.txt")
    gt = gt[gt[:, 6] != 0]
    frames = list(iter_frames(pets / "vtest.avi", first, last))
    for config, camera in (("people-image", None),
                           ("people-ground", str(pets / "View_001.xml"))):
        runs = [measure(config, frames, gt, camera) for _ in range(args.repeats)]
        eng = sum(r[0] for r in runs)
        upd = sum(r[1] for r in runs)
        ratios = [(u - e) / e for e, u in runs]
        print(f"{config}: {len(frames)} frames x {len(runs)} runs; engine "
              f"{1e3 * eng / len(runs) / len(frames):.2f} ms/frame, update adds "
              f"{1e3 * (upd - eng) / len(runs) / len(frames):.3f} ms/frame = "
              f"{100 * (upd - eng) / eng:.2f} % (runs {100 * min(ratios):.2f}-"
              f"{100 * max(ratios):.2f} %)")


if __name__ == "__main__":
    main()
