"""Filter-core speed: one predict + weight + resample step, pftrack against Stone Soup.

For each particle count N the benchmark times, on one target:

* ``step_s``: pftrack's step as the tracker runs it: 6-D constant-acceleration predict
  (:class:`pftrack_basic.motion.ConstantAccelerationMotion`), states -> image boxes
  (:class:`pftrack.builtin.image_box.ImageBoxObservation`), Gaussian log-likelihood of the box
  centre (:class:`pftrack_basic.gaussian.GaussianLikelihood`), weight normalisation, weighted-mean
  estimate, systematic resampling and the gather ``particles.take(idx, axis=0)`` (as the
  tracker gathers; the same rows as ``particles[idx]``, in about half the time);
* ``stonesoup_step_s``: the same step with Stone Soup's ``ParticlePredictor`` (a
  ``CombinedLinearGaussianTransitionModel`` of two ``ConstantAcceleration`` models),
  ``ParticleUpdater`` with a ``LinearGaussian`` position measurement and its
  ``SystematicResampler`` (which resamples at every update);
* ``resample_systematic_s``: :func:`pftrack.filter.systematic_resample` alone on the step's
  weights.

Each figure is the median of several repeats (``time.perf_counter``) after one untimed warm-up;
the pftrack and Stone Soup steps are timed alternately so that both meet the same machine load.
Large N gets fewer repeats (200 / 20 / 5 by default), Stone Soup at most 30 s worth, and it is
timed once when one step takes longer than ``--slow-s``. The two libraries do not draw the same
noise (Stone Soup samples the correlated constant-acceleration covariance; pftrack the per-axis
noise of the soccer paper), so the comparison is of cost, not of numbers.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from pftrack_bench.protocol import Protocol

#: What chose this benchmark's settings and what it reports (its JSON result carries it).
PROTOCOL = Protocol(
    data="synthetic particle clouds, the same for both libraries",
    chosen_on="nothing is tuned: one predict, weight and resample step",
    reported_on="the step's time, pftrack against Stone Soup in the same process",
)


DEFAULT_PARTICLES = (1_000, 100_000, 1_000_000)
GOAL_SPEEDUP_1K = 5.0
GOAL_RESAMPLE_1M_S = 0.030
GOAL_STEP_1M_S = 0.060  # seconds: the whole engine step at 1M particles


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--particles", type=int, nargs="+", default=list(DEFAULT_PARTICLES),
                        metavar="N", help="particle counts (default: 1000 100000 1000000)")
    parser.add_argument("--repeats", type=int, default=None,
                        help="timed repeats per figure (default: 200 / 20 / 5 by size)")
    parser.add_argument("--no-stonesoup", action="store_true",
                        help="time pftrack only (Stone Soup not needed)")
    parser.add_argument("--slow-s", type=float, default=5.0,
                        help="a Stone Soup step slower than this (s) is timed only once")
    parser.add_argument("--seed", type=int, default=0, help="seed of pftrack's Generator")
    parser.add_argument("--blas-threads", type=int, default=None,
                        help="limit BLAS threads (threadpoolctl) for both libraries; default: "
                             "as installed. On a busy machine multi-threaded BLAS stalls")


def _repeats(n: int, requested: int | None) -> int:
    if requested is not None:
        if requested < 1:
            raise ValueError(f"--repeats must be >= 1, got {requested}")
        return requested
    return 200 if n <= 10_000 else 20 if n <= 200_000 else 5


def _timed(fn: Callable[[Any], Any], arg: Any) -> float:
    t0 = time.perf_counter()
    fn(arg)
    return time.perf_counter() - t0


def _median_time(fn: Callable[[], Any], repeats: int, setup: Callable[[], Any] | None = None,
                 ) -> tuple[float, int]:
    """Median wall time of ``fn(setup())`` over ``repeats`` (setup untimed), after a warm-up."""
    arg = setup() if setup else None
    fn(arg)  # warm-up: page faults, caches, lazy imports
    times = []
    for _ in range(repeats):
        arg = setup() if setup else None
        t0 = time.perf_counter()
        fn(arg)
        times.append(time.perf_counter() - t0)
    return statistics.median(times), repeats


# -- pftrack ---------------------------------------------------------------------------------


def _pftrack_step(n: int, seed: int) -> tuple[Callable[[Any], Any], Callable[[], Any],
                                               Callable[[], np.ndarray]]:
    from pftrack.builtin.image_box import ImageBoxObservation
    from pftrack.contracts.components import Target
    from pftrack.filter import normalize_log_weights, systematic_resample, weighted_mean
    from pftrack_basic.gaussian import GaussianLikelihood
    from pftrack_basic.motion import ConstantAccelerationMotion

    rng = np.random.default_rng(seed)
    motion = ConstantAccelerationMotion(position_noise=2.0, velocity_noise=1.0,
                                        acceleration_noise=0.5)
    observation = ImageBoxObservation(30.0, 30.0)
    likelihood = GaussianLikelihood(sigma_px=5.0)
    target = Target(id=1, state=np.zeros(6), box_xywh_px=np.zeros(4), frames_tracked=3,
                    size_m=1.0)
    target.observation_px = np.array([203.0, 148.0])
    start = motion.init_states(np.array([200.0, 150.0]), n, rng, spread=5.0)
    log_w0 = np.full(n, -np.log(n))

    def step(particles: np.ndarray) -> np.ndarray:
        particles = motion.predict(particles, 1.0, rng, target)
        boxes = observation.to_boxes(particles, target)
        logl = likelihood.log_likelihood(boxes, target)
        w, _ = normalize_log_weights(log_w0 + logl)
        target.state = weighted_mean(particles, w)
        # the gather as the tracker does it: take() is about twice as fast as particles[idx]
        return particles.take(systematic_resample(w, rng), axis=0)

    def weights() -> np.ndarray:
        p = motion.predict(start, 1.0, rng, target)
        w, _ = normalize_log_weights(log_w0 + likelihood.log_likelihood(
            observation.to_boxes(p, target), target))
        return w

    return step, lambda: start, weights


# -- Stone Soup ------------------------------------------------------------------------------


def _stonesoup_step(n: int, seed: int) -> tuple[Callable[[Any], Any], Callable[[], Any]]:
    import datetime as dt

    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (
        CombinedLinearGaussianTransitionModel,
        ConstantAcceleration,
    )
    from stonesoup.predictor.particle import ParticlePredictor
    from stonesoup.resampler.particle import SystematicResampler
    from stonesoup.types.array import StateVectors
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import ParticleState
    from stonesoup.updater.particle import ParticleUpdater

    # Stone Soup orders a combined state per axis: (x, vx, ax, y, vy, ay)
    transition = CombinedLinearGaussianTransitionModel(
        [ConstantAcceleration(noise_diff_coeff=1.0), ConstantAcceleration(noise_diff_coeff=1.0)])
    measurement = LinearGaussian(ndim_state=6, mapping=(0, 3), noise_covar=np.diag([25.0, 25.0]))
    predictor = ParticlePredictor(transition_model=transition)
    updater = ParticleUpdater(measurement_model=measurement, resampler=SystematicResampler())
    rng = np.random.default_rng(seed)
    sv = np.zeros((6, n))
    sv[0] = 200.0 + rng.normal(0.0, 5.0, n)
    sv[3] = 150.0 + rng.normal(0.0, 5.0, n)
    t0 = dt.datetime(2024, 1, 1)
    t1 = t0 + dt.timedelta(seconds=1)
    detection = Detection(np.array([[203.0], [148.0]]), timestamp=t1,
                          measurement_model=measurement)
    log_w0 = np.full(n, -np.log(n))

    def setup() -> Any:
        # a new prior each time: Stone Soup caches predictions by prior
        return ParticleState(StateVectors(sv.copy()), log_weight=log_w0.copy(), timestamp=t0)

    def step(prior: Any) -> Any:
        prediction = predictor.predict(prior, timestamp=t1)
        return updater.update(SingleHypothesis(prediction, detection))

    return step, setup


# -- the benchmark ---------------------------------------------------------------------------


def run(args: argparse.Namespace) -> dict[str, Any]:
    if args.blas_threads is not None:
        from threadpoolctl import threadpool_limits

        if args.blas_threads < 1:
            raise ValueError(f"--blas-threads must be >= 1, got {args.blas_threads}")
        # load every BLAS first: a limit applies only to libraries already loaded
        import scipy.linalg
        import scipy.stats  # noqa: F401

        if not args.no_stonesoup:
            _stonesoup_step(2, args.seed)
        with threadpool_limits(limits=args.blas_threads, user_api="blas"):
            return _run(args)
    return _run(args)


def _blas_threads() -> list[int]:
    try:
        from threadpoolctl import threadpool_info
    except ImportError:  # pragma: no cover - threadpoolctl comes with scikit-learn
        return []
    return [int(i["num_threads"]) for i in threadpool_info() if i.get("user_api") == "blas"]


def _run(args: argparse.Namespace) -> dict[str, Any]:
    from pftrack.filter import systematic_resample

    sizes = [int(n) for n in args.particles]
    if any(n < 1 for n in sizes):
        raise ValueError(f"--particles must be positive, got {sizes}")
    use_ss = not args.no_stonesoup
    ss_version = None
    if use_ss:
        import stonesoup

        ss_version = getattr(stonesoup, "__version__", "?")
    rows = []
    notes = []
    for n in sizes:
        reps = _repeats(n, args.repeats)
        step, start, weights = _pftrack_step(n, args.seed)
        w = weights()
        rs_rng = np.random.default_rng(args.seed + 1)
        res_s, _ = _median_time(lambda _, w=w, r=rs_rng: systematic_resample(w, r),
                                max(reps, 5))
        row: dict[str, Any] = {"particles": n}
        if not use_ss:
            step_s, _ = _median_time(step, reps, start)
        else:
            ss_step, ss_setup = _stonesoup_step(n, args.seed)
            step(start())  # warm-ups; the first Stone Soup step says how slow it is
            first = _timed(ss_step, ss_setup())
            if first > args.slow_s:
                ss_reps = 1
                notes.append(f"Stone Soup at {n} particles took {first:.1f} s per step "
                             f"(> --slow-s {args.slow_s}): timed once")
            else:
                ss_reps = max(1, min(reps, int(30.0 / max(first, 1e-6))))
            # interleaved, so that both libraries meet the same machine load
            ours, theirs = [], []
            for k in range(reps):
                ours.append(_timed(step, start()))
                if k < ss_reps:
                    theirs.append(_timed(ss_step, ss_setup()))
            step_s = statistics.median(ours)
            ss_s = statistics.median(theirs)
            row.update({"stonesoup_step_s": ss_s, "speedup_vs_stonesoup": ss_s / step_s,
                        "stonesoup_repeats": ss_reps})
        row.update({"step_s": step_s, "resample_systematic_s": res_s, "repeats": reps})
        rows.append(row)
    goals: dict[str, Any] = {}
    by_n = {r["particles"]: r for r in rows}
    if 1000 in by_n and "speedup_vs_stonesoup" in by_n[1000]:
        goals["speedup_1k"] = {"goal": f">= {GOAL_SPEEDUP_1K}",
                               "value": by_n[1000]["speedup_vs_stonesoup"],
                               "met": by_n[1000]["speedup_vs_stonesoup"] >= GOAL_SPEEDUP_1K}
    if 1_000_000 in by_n:
        v = by_n[1_000_000]["resample_systematic_s"]
        goals["resample_systematic_1M_s"] = {"goal": f"< {GOAL_RESAMPLE_1M_S}", "value": v,
                                             "met": v < GOAL_RESAMPLE_1M_S}
        v = by_n[1_000_000]["step_s"]
        goals["step_1M_s"] = {"goal": f"< {GOAL_STEP_1M_S}", "value": v,
                              "met": v < GOAL_STEP_1M_S}
    return {
        "benchmark": "core",
        "rows": rows,
        "goals": goals,
        "notes": notes,
        "state_dim": 6,
        "environment": {"python": platform.python_version(), "numpy": np.__version__,
                        "stonesoup": ss_version, "cpus": os.cpu_count(),
                        "machine": platform.machine(), "blas_threads": _blas_threads(),
                        "load_average_1min": (os.getloadavg()[0]
                                              if hasattr(os, "getloadavg") else None),
                        "heap_keeps_large_arrays": _heap_kept()},
    }


def _heap_kept() -> bool:
    """Whether the process keeps large arrays in its heap (:mod:`pftrack.cli._alloc`: set by
    the ``pftrack`` command; ``PFTRACK_MALLOC=default`` turns it off), which saves the step at
    1M particles about 10 ms of page zeroing."""
    from pftrack.cli import _alloc

    return _alloc.kept()


def format_table(result: dict[str, Any]) -> str:
    head = (f"{'particles':>10} {'pftrack step':>14} {'Stone Soup step':>16} {'speed-up':>9} "
            f"{'resample (sys)':>15}")
    lines = [head, "-" * len(head)]
    for r in result["rows"]:
        ss = r.get("stonesoup_step_s")
        sp = r.get("speedup_vs_stonesoup")
        lines.append(f"{r['particles']:>10} {r['step_s'] * 1e3:>11.3f} ms "
                     f"{(f'{ss * 1e3:.3f} ms' if ss is not None else '-'):>16} "
                     f"{(f'{sp:.1f}x' if sp is not None else '-'):>9} "
                     f"{r['resample_systematic_s'] * 1e3:>12.3f} ms")
    for name, g in result.get("goals", {}).items():
        lines.append(f"goal {name}: {g['goal']}, got {g['value']:.4g} "
                     f"({'met' if g['met'] else 'NOT met'})")
    lines.extend(f"note: {n}" for n in result.get("notes", []))
    return "\n".join(lines)
