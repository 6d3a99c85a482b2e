"""The conformance checks behind :func:`pftrack.testing.check_component`.

Every check exercises the component through its public contract (see
:mod:`pftrack.contracts.components`) on a small seeded synthetic scene, or on the context its
``_conformance_example()`` returns. A run of the component's *workflow* (all the calls a tracker
would make, for its kind) gives a dict of output arrays; the checks compare such runs: twice with
one seed, with two seeds, after ``clone()``, after a pickle round trip, after rebuilding from
``to_config()``.
"""

from __future__ import annotations

import copy
import itertools
import json
import pickle
import random
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pftrack.contracts.components import (
    Assignment,
    Associator,
    Component,
    Detections,
    Detector,
    Frame,
    Likelihood,
    MotionModel,
    ObservationModel,
    Scene,
    Target,
    TrackManager,
    TrackRecord,
    _plain,
    _unvalidated,
)
from pftrack.contracts.stages import Birth, FrameView, Initiator, LifecycleStage
from pftrack.engine.lifecycle import StagedTracks
from pftrack.testing.synthetic import SyntheticScene, synthetic_scene, target_from_box

__all__ = [
    "CHECKS",
    "CHECK_FUNCTIONS",
    "CheckResult",
    "ConformanceExample",
    "assert_conforms",
    "check_component",
    "parametrize_with_checks",
    "run_check",
]

PASS, FAIL, SKIP = "pass", "fail", "skip"


@dataclass
class CheckResult:
    """Outcome of one check.

    Attributes
    ----------
    check : str
        Name of the check (one of :data:`CHECKS`).
    status : {"pass", "fail", "skip"}
    message : str
        Why it failed or was skipped; empty when it passed.
    component : str
        ``ClassName`` (``registered-name``) of the component checked.
    """

    check: str
    status: str
    message: str = ""
    component: str = ""

    @property
    def passed(self) -> bool:
        return self.status != FAIL

    def __str__(self) -> str:
        tail = f": {self.message}" if self.message else ""
        return f"[{self.status}] {self.component} {self.check}{tail}"


@dataclass
class ConformanceExample:
    """What a component's ``_conformance_example()`` classmethod may return.

    Only ``component`` is required; every other field left as None is filled from the kit's
    synthetic scene (:func:`pftrack.testing.synthetic.synthetic_scene`).

    Attributes
    ----------
    component : Component
        A configured, fresh instance (not yet fitted or fed frames). The hook is called again for
        every run, so it must return a new instance each time.
    frames : list of Frame, optional
        At least 3 frames (likelihoods and detectors, scenes ignore it).
    targets : list of Target, optional
        Targets for likelihoods (the first is scored) and associators (at least one).
    detections : Detections, optional
        Detections of ``frames[1]`` for likelihoods and associators.
    boxes_xywh_px : ndarray (N, 4), optional
        Particle boxes a likelihood scores; the kit appends boxes partly and wholly outside the
        image.
    states : ndarray (N, D), optional
        Particle states a motion model propagates.
    position : ndarray (P,), optional
        Where a motion model's ``init_states`` centres its particles.
    dt : float
        Time step for ``predict``.
    fit_boxes : dict of int -> (K, 4) ndarray, optional
        Ground truth for ``Detector.fit`` by frame index (a detector that learns).
    size_m : float
        ``Target.size_m`` of the target handed to ``MotionModel.predict``.
    context : RunContext, optional
        Handed to the component's ``setup`` before each workflow run (a camera, say), as a run
        would.
    engine : dict, optional
        For track managers: the engine the kit runs them in, ``motion``, ``likelihood`` and
        ``observation`` components and engine options (``n_particles``, ...) that replace the
        kit's image-plane random walk (a manager of 3-D volumes needs 3-D states and a camera).
    """

    component: Component
    frames: list[Frame] | None = None
    targets: list[Target] | None = None
    detections: Detections | None = None
    boxes_xywh_px: np.ndarray | None = None
    states: np.ndarray | None = None
    position: np.ndarray | None = None
    dt: float = 1.0
    fit_boxes: dict[int, np.ndarray] | None = None
    size_m: float = 1.7
    context: Any = None
    engine: dict[str, Any] | None = None


CHECKS = (
    "construct",
    "init_stores_params",
    "config_round_trip",
    "clone",
    "shapes_dtypes",
    "empty_input",
    "inputs_unchanged",
    "finite_output",
    "deterministic_same_seed",
    "different_seeds_differ",
    "pickle_round_trip",
    "no_global_random_state",
)


# --------------------------------------------------------------------------------------------
# Building examples
# --------------------------------------------------------------------------------------------


class _Problem(Exception):
    """Raised inside a workflow when a contract is broken; ``category`` names the check."""

    def __init__(self, category: str, message: str) -> None:
        super().__init__(message)
        self.category = category
        self.message = message


def _describe_exc(exc: BaseException) -> str:
    tb = traceback.extract_tb(exc.__traceback__)
    where = f" (at {tb[-1].filename}:{tb[-1].lineno})" if tb else ""
    return f"{type(exc).__name__}: {exc}{where}"


def _make_factory(obj: type[Component] | Component) -> Callable[[], ConformanceExample]:
    """A function returning a fresh :class:`ConformanceExample` each call."""
    if isinstance(obj, Component):
        cls: type[Component] = type(obj)
        template = obj
        hook = getattr(cls, "_conformance_example", None)

        def fresh_component() -> Component:
            try:
                return copy.deepcopy(template)
            except Exception:  # noqa: BLE001 - unpicklable native state: fall back on params
                return template.clone()

        def factory() -> ConformanceExample:
            ex = _normalise_example(hook(), cls) if hook is not None else ConformanceExample(
                fresh_component())
            ex.component = fresh_component()
            return ex

        return factory
    if not (isinstance(obj, type) and issubclass(obj, Component)):
        raise TypeError(f"check_component needs a Component subclass or instance, got {obj!r}")
    cls = obj
    hook = getattr(cls, "_conformance_example", None)
    if hook is not None:
        return lambda: _normalise_example(hook(), cls)
    return lambda: ConformanceExample(cls())


def _normalise_example(value: Any, cls: type) -> ConformanceExample:
    if isinstance(value, ConformanceExample):
        ex = value
    elif isinstance(value, Component):
        ex = ConformanceExample(value)
    elif isinstance(value, tuple) and len(value) == 2 and isinstance(value[1], dict):
        ex = ConformanceExample(value[0], **value[1])
    else:
        raise TypeError(f"{cls.__name__}._conformance_example() must return a component, a "
                        f"ConformanceExample or (component, dict of context); got {value!r}")
    if not isinstance(ex.component, cls):
        raise TypeError(f"{cls.__name__}._conformance_example() returned a "
                        f"{type(ex.component).__name__}, not a {cls.__name__}")
    return ex


# --------------------------------------------------------------------------------------------
# Per-kind workflows: run the component as a tracker would, validate, collect outputs
# --------------------------------------------------------------------------------------------


@dataclass
class _Run:
    outputs: dict[str, Any] = field(default_factory=dict)
    problems: list[_Problem] = field(default_factory=list)
    rng_used: bool = False
    rng_keys: set[str] = field(default_factory=set)  # outputs whose call drew from the rng
    error: str | None = None  # an exception that stopped the workflow

    def need(self, cond: bool, category: str, message: str) -> None:
        if not cond:
            self.problems.append(_Problem(category, message))

    def guarded(self, category: str, what: str, fn: Callable[[], Any]) -> Any:
        """Call ``fn``; an exception is a problem of ``category`` (the workflow goes on)."""
        try:
            return fn()
        except Exception as exc:  # noqa: BLE001
            self.problems.append(_Problem(category, f"{what} raised {_describe_exc(exc)}"))
            return None

    def output(self, key: str, value: Any, rng: np.random.Generator, before: Any) -> None:
        """Record an output and whether computing it advanced ``rng`` (state ``before``)."""
        self.outputs[key] = value
        if rng.bit_generator.state != before:
            self.rng_keys.add(key)
            self.rng_used = True


def _float_array(run: _Run, value: Any, shape: tuple[int, ...], what: str,
                 category: str = "shapes_dtypes") -> np.ndarray:
    if not isinstance(value, np.ndarray):
        run.need(False, category, f"{what} returned {type(value).__name__}, expected an ndarray")
        value = np.asarray(value)
    run.need(value.shape == shape, category, f"{what} returned shape {value.shape}, "
                                             f"expected {shape}")
    run.need(value.dtype == np.float64, category, f"{what} returned dtype {value.dtype}, "
                                                  f"expected float64")
    return value


def _scene(ex: ConformanceExample) -> SyntheticScene:
    return synthetic_scene(seed=0)


def _motion_workflow(ex: ConformanceExample, rng: np.random.Generator, run: _Run) -> None:
    m = ex.component
    assert isinstance(m, MotionModel)
    d = m.state_dim
    run.need(isinstance(d, (int, np.integer)) and d >= 1, "shapes_dtypes",
             f"state_dim must be a positive int, got {d!r}")
    d = int(d)
    pos_dims = tuple(m.position_dims)
    run.need(len(pos_dims) >= 1 and len(set(pos_dims)) == len(pos_dims)
             and all(isinstance(i, (int, np.integer)) and 0 <= i < d for i in pos_dims),
             "shapes_dtypes", f"position_dims {pos_dims!r} must be distinct ints in [0, {d})")
    p = len(pos_dims)
    position = (np.arange(1.0, p + 1.0) * 10.0 if ex.position is None
                else np.asarray(ex.position, dtype=np.float64))
    kit_rng = np.random.default_rng(20240607)  # inputs do not depend on the seed under test
    if ex.states is None:
        states = m.init_states(position, 64, kit_rng, spread=2.0)
        states = states + kit_rng.normal(0.0, 0.5, states.shape)
    else:
        states = np.array(ex.states, dtype=np.float64)
    n = len(states)
    target = Target(id=1, state=states.mean(axis=0), box_xywh_px=np.array([10.0, 10.0, 20, 40]),
                    particles=states.copy(), extent=np.ones(d), frames_tracked=5,
                    size_m=float(ex.size_m), age=5)

    before = rng.bit_generator.state
    init = m.init_states(position, 200, rng, spread=1.0)
    run.output("init_states", init, rng, before)
    _float_array(run, init, (200, d), "init_states(position, 200, rng)")
    if init.shape == (200, d):
        run.need(bool(np.all(np.isfinite(init))), "finite_output",
                 "init_states returned non-finite values")
        dev = np.abs(init[:, list(pos_dims)].mean(axis=0) - position)
        run.need(bool(np.all(dev < 1.0)), "shapes_dtypes",
                 f"init_states(position={position.tolist()}, spread=1) has position mean "
                 f"{init[:, list(pos_dims)].mean(axis=0).round(3).tolist()}: the particles "
                 "are not centred on the position")
    init0 = run.guarded("empty_input", "init_states(position, 0, rng)",
                        lambda: m.init_states(position, 0, rng, spread=1.0))
    if init0 is not None:
        _float_array(run, init0, (0, d), "init_states(position, 0, rng)", "empty_input")

    for label, dt, tgt in (("predict", ex.dt, None), ("predict_target", ex.dt, target),
                           ("predict_half_dt", 0.5 * ex.dt, target)):
        inp = states.copy()
        before = rng.bit_generator.state
        out = m.predict(inp, dt, rng, target=tgt)
        run.output(label, out, rng, before)
        _float_array(run, out, (n, d), f"{label.replace('_', ' ')}: predict((N={n}, {d}))")
        run.need(np.array_equal(inp, states), "inputs_unchanged",
                 "predict modified its input states in place")
        if isinstance(out, np.ndarray):
            run.need(not np.shares_memory(out, inp), "inputs_unchanged",
                     "predict returned (a view of) its input instead of a new array")
            run.need(bool(np.all(np.isfinite(out))), "finite_output",
                     f"predict returned non-finite states ({label})")
    out0 = run.guarded("empty_input", "predict on zero particles",
                       lambda: m.predict(np.zeros((0, d)), ex.dt, rng, target=target))
    if out0 is not None:
        _float_array(run, out0, (0, d), "predict on zero particles", "empty_input")


def _likelihood_workflow(ex: ConformanceExample, rng: np.random.Generator, run: _Run) -> None:
    lik = ex.component
    assert isinstance(lik, Likelihood)
    sc = _scene(ex)
    frames = ex.frames if ex.frames is not None else sc.frames
    if len(frames) < 3:
        raise ValueError("the conformance example needs at least 3 frames")
    targets = ex.targets if ex.targets is not None else sc.targets(frames[0].index)
    detections = (ex.detections if ex.detections is not None
                  else sc.detections(frames[1].index) if ex.frames is None else None)
    w, h = frames[0].size_wh
    kit_rng = np.random.default_rng(20240607)
    t0 = targets[0]
    b0 = np.asarray(t0.box_xywh_px, dtype=np.float64)
    if ex.boxes_xywh_px is None:
        centres = b0[:2] + 0.5 * b0[2:] + kit_rng.normal(0.0, 6.0, (48, 2))
        inside = np.column_stack([centres - 0.5 * b0[2:], np.tile(b0[2:], (48, 1))])
    else:
        inside = np.asarray(ex.boxes_xywh_px, dtype=np.float64).reshape(-1, 4)
    bw, bh = b0[2], b0[3]
    edge = np.array([
        [-0.5 * bw, -0.5 * bh, bw, bh],            # over the top-left corner
        [w - 0.5 * bw, h - 0.5 * bh, bw, bh],      # over the bottom-right corner
        [-0.5 * bw, 0.5 * h, bw, bh],              # over the left edge
        [0.3 * w, h - 0.3 * bh, bw, bh],           # over the bottom edge
        [w + 40.0, h + 40.0, bw, bh],              # wholly outside
        [-3.0 * bw, 0.2 * h, bw, bh],              # wholly outside, left
        [-5.0, -5.0, w + 10.0, h + 10.0],          # larger than the image
        [0.5 * w, 0.5 * h, 1.0, 1.0],              # one pixel
    ])
    boxes = np.vstack([inside, edge])
    n_in = len(inside)

    for t in targets:
        lik.init_target(frames[0], t)
    for k, (frame, dets) in enumerate(((frames[1], detections), (frames[2], None))):
        for t in targets:
            tb = np.asarray(t.box_xywh_px, dtype=np.float64)
            shift = np.array([tb[0] - b0[0], tb[1] - b0[1], 0.0, 0.0])
            t.particle_boxes_xywh_px = boxes + shift if t is not t0 else boxes
            t.particles = t.particle_boxes_xywh_px[:, :2] + 0.5 * t.particle_boxes_xywh_px[:, 2:]
        lik.begin_frame(frame, targets, dets)
        for j, t in enumerate(targets[:2]):
            inp = t.particle_boxes_xywh_px.copy()  # type: ignore[union-attr]
            ll = lik.log_likelihood(inp, t)
            tag = f"frame {frame.index} target {t.id}"
            _float_array(run, ll, (len(boxes),), f"log_likelihood(({len(boxes)}, 4)) [{tag}]")
            run.need(np.array_equal(inp, t.particle_boxes_xywh_px), "inputs_unchanged",  # type: ignore[arg-type]
                     "log_likelihood modified the boxes it was given")
            if isinstance(ll, np.ndarray) and ll.shape == (len(boxes),):
                run.need(not np.any(np.isnan(ll)), "finite_output",
                         f"log_likelihood returned NaN for particle rows "
                         f"{np.flatnonzero(np.isnan(ll)).tolist()} [{tag}] (rows >= {n_in} are "
                         "boxes partly or wholly outside the image)")
                run.need(not np.any(np.isposinf(ll)), "finite_output",
                         f"log_likelihood returned +inf [{tag}]")
            run.outputs[f"log_likelihood_{k}_{j}"] = ll
        ll0 = run.guarded("empty_input", "log_likelihood on zero particles",
                          lambda: lik.log_likelihood(np.zeros((0, 4)), t0))
        if ll0 is not None:
            _float_array(run, ll0, (0,), "log_likelihood on zero particles", "empty_input")
    for t in targets:
        lik.end_target(t)
    # the same likelihood must accept a frame with no live target
    run.guarded("empty_input", "begin_frame(frame, [], no detections)",
                lambda: lik.begin_frame(frames[2], [], Detections.empty()))


def _detector_workflow(ex: ConformanceExample, rng: np.random.Generator, run: _Run) -> None:
    det = ex.component
    assert isinstance(det, Detector)
    sc = _scene(ex)
    frames = ex.frames if ex.frames is not None else sc.frames
    fit_boxes = ex.fit_boxes if ex.fit_boxes is not None else (
        sc.boxes_by_frame if ex.frames is None else {})
    before = rng.bit_generator.state
    if type(det).fit is not Detector.fit:
        ret = det.fit(list(frames), fit_boxes, rng=rng)
        run.need(ret is det, "shapes_dtypes", "fit must return self")
    fit_drew = rng.bit_generator.state != before
    blank = Frame(frames[-1].index + 1, np.zeros_like(frames[-1].image), frames[-1].time_s + 0.04)
    for k, frame in enumerate([*frames, blank]):
        tag = f"detect(frame {frame.index})" + (" on a blank frame" if frame is blank else "")
        if frame is blank:
            d = run.guarded("empty_input", tag, lambda: det.detect(blank))
            if d is None:
                continue
        else:
            d = det.detect(frame)
        if not isinstance(d, Detections):
            run.need(False, "shapes_dtypes", f"{tag} returned {type(d).__name__}, "
                                             "expected Detections")
            continue
        kk = len(d.scores)
        _float_array(run, d.boxes_xywh_px, (kk, 4), f"{tag}: boxes_xywh_px")
        _float_array(run, d.scores, (kk,), f"{tag}: scores")
        if d.points_world_m is not None:
            _float_array(run, d.points_world_m, (kk, 3), f"{tag}: points_world_m")
        run.need(bool(np.all(np.isfinite(d.boxes_xywh_px))) and bool(np.all(np.isfinite(d.scores))),
                 "finite_output", f"{tag} returned non-finite boxes or scores")
        run.need(bool(np.all(d.boxes_xywh_px[:, 2:] >= 0)), "shapes_dtypes",
                 f"{tag} returned boxes with negative width or height")
        run.outputs[f"boxes_{k}"] = d.boxes_xywh_px
        run.outputs[f"scores_{k}"] = d.scores
        if fit_drew:  # a model fitted with the rng: every detection depends on the seed
            run.rng_keys.update((f"boxes_{k}", f"scores_{k}"))
    run.rng_used = rng.bit_generator.state != before


def _check_assignment(run: _Run, a: Any, n_t: int, n_d: int, tag: str, category: str) -> None:
    if not isinstance(a, Assignment):
        run.need(False, category, f"{tag} returned {type(a).__name__}, expected Assignment")
        return
    m = np.asarray(a.matches)
    run.need(m.ndim == 2 and m.shape[1] == 2, category,
             f"{tag}: matches has shape {m.shape}, expected (M, 2)")
    run.need(np.issubdtype(m.dtype, np.integer), category,
             f"{tag}: matches dtype {m.dtype}, expected an integer dtype")
    if m.ndim != 2 or m.shape[1] != 2:
        return
    ti, di = m[:, 0], m[:, 1]
    run.need(bool(np.all((ti >= 0) & (ti < n_t))) and bool(np.all((di >= 0) & (di < n_d))),
             category, f"{tag}: match indices out of range ({n_t} targets, {n_d} detections): "
                       f"{m.tolist()}")
    run.need(len(np.unique(ti)) == len(ti) and len(np.unique(di)) == len(di), category,
             f"{tag}: a target or a detection is used more than once: {m.tolist()}")
    ut = np.sort(np.asarray(a.unmatched_tracks).reshape(-1))
    ud = np.sort(np.asarray(a.unmatched_detections).reshape(-1))
    run.need(np.array_equal(ut, np.setdiff1d(np.arange(n_t), ti)), category,
             f"{tag}: unmatched_tracks {ut.tolist()} is not the complement of the matches")
    run.need(np.array_equal(ud, np.setdiff1d(np.arange(n_d), di)), category,
             f"{tag}: unmatched_detections {ud.tolist()} is not the complement of the matches")


def _associator_workflow(ex: ConformanceExample, rng: np.random.Generator, run: _Run) -> None:
    asc = ex.component
    assert isinstance(asc, Associator)
    sc = _scene(ex)
    f0 = sc.frames[0].index
    if ex.targets is not None:
        targets = ex.targets
    else:  # the objects' boxes one frame earlier, slightly off, as a tracker's estimates
        targets = [target_from_box(b + np.array([1.0, -1.0, 0.0, 0.0]), i + 1, detection_index=None)
                   for i, b in enumerate(sc.boxes_by_frame[f0])]
        for t in targets:
            t.observation_px = t.detection = None
    dets = ex.detections if ex.detections is not None else sc.detections(f0 + 1)
    saved = (dets.boxes_xywh_px.copy(), dets.scores.copy(),
             [np.array(t.box_xywh_px, copy=True) for t in targets])
    a = asc.associate(targets, dets)
    _check_assignment(run, a, len(targets), len(dets), "associate(targets, detections)",
                      "shapes_dtypes")
    run.need(np.array_equal(saved[0], dets.boxes_xywh_px) and np.array_equal(saved[1], dets.scores)
             and all(np.array_equal(s, t.box_xywh_px) for s, t in zip(saved[2], targets)),
             "inputs_unchanged", "associate modified the detections or the targets' boxes")
    if isinstance(a, Assignment):
        run.outputs["matches"] = np.asarray(a.matches)
    for tag, tt, dd in (("associate([], detections)", [], dets),
                        ("associate(targets, no detections)", targets, Detections.empty()),
                        ("associate([], no detections)", [], Detections.empty())):
        a = run.guarded("empty_input", tag, lambda: asc.associate(tt, dd))  # noqa: B023
        if a is not None:
            _check_assignment(run, a, len(tt), len(dd), tag, "empty_input")
    # one target, one detection: a shape-only check that a plain 1x1 problem works
    one = asc.associate(targets[:1], Detections(dets.boxes_xywh_px[:1], dets.scores[:1]))
    _check_assignment(run, one, 1, 1, "associate(1 target, 1 detection)", "shapes_dtypes")


def _scene_workflow(ex: ConformanceExample, rng: np.random.Generator, run: _Run) -> None:
    s = ex.component
    assert isinstance(s, Scene)
    fps = float(s.fps)
    run.need(np.isfinite(fps) and fps > 0, "shapes_dtypes", f"fps must be > 0, got {fps}")
    frames = list(itertools.islice(s.frames(), 2))
    run.need(len(frames) >= 1, "shapes_dtypes", "frames() yielded no frame")
    for k, f in enumerate(frames):
        if not isinstance(f, Frame):
            run.need(False, "shapes_dtypes", f"frames() yielded {type(f).__name__}, not Frame")
            continue
        img = np.asarray(f.image)
        run.need(img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3, "shapes_dtypes",
                 f"frame {f.index}: image must be (H, W, 3) uint8, got {img.shape} {img.dtype}")
        run.outputs[f"image_{k}"] = img
    gt = s.ground_truth()
    if gt is not None:
        _float_array(run, gt, (len(gt), 10), "ground_truth()")
        run.outputs["ground_truth"] = gt


def _observation_workflow(ex: ConformanceExample, rng: np.random.Generator, run: _Run) -> None:
    obs = ex.component
    assert isinstance(obs, ObservationModel)
    sc = _scene(ex)
    targets = ex.targets if ex.targets is not None else sc.targets()
    if ex.states is None:  # image-plane states: the targets' box centres, jittered
        kit_rng = np.random.default_rng(20240607)
        rows = np.array([t.state + kit_rng.normal(0.0, 2.0, (32, len(t.state)))
                         for t in targets])
    else:
        st = np.asarray(ex.states, dtype=np.float64)
        rows = np.array([st] * len(targets))
    for t, r in zip(targets, rows):
        obs.init_target(t, obs.to_boxes(r[:1], None)[0])
    saved = rows.copy()
    boxes = obs.to_boxes(rows[0], targets[0])
    run.outputs["boxes"] = boxes
    n = rows.shape[1]
    _float_array(run, boxes, (n, 4), f"to_boxes((N={n}, D))")
    run.need(np.array_equal(rows, saved), "inputs_unchanged", "to_boxes modified its states")
    if isinstance(boxes, np.ndarray) and boxes.shape == (n, 4):
        run.need(bool(np.isfinite(boxes).any(axis=1).all()), "finite_output",
                 "to_boxes gave rows that are NaN throughout for states in view")
    every = obs.to_boxes_rows(rows, targets)
    run.outputs["boxes_rows"] = every
    _float_array(run, every, (len(targets), n, 4), "to_boxes_rows((T, N, D))")
    if isinstance(every, np.ndarray) and every.shape == (len(targets), n, 4):
        one_by_one = np.array([obs.to_boxes(r, t) for r, t in zip(rows, targets)])
        run.need(np.array_equal(every, one_by_one, equal_nan=True), "shapes_dtypes",
                 "to_boxes_rows differs from to_boxes row by row")
    if isinstance(boxes, np.ndarray) and boxes.shape == (n, 4):
        pos = np.asarray(obs.position_from_box(boxes[0]), dtype=np.float64)
        run.outputs["position_from_box"] = pos
        run.need(pos.ndim == 1 and pos.size >= 1 and bool(np.all(np.isfinite(pos))),
                 "finite_output", f"position_from_box gave {pos!r} for a box in view")
    vis = np.asarray(obs.in_view(rows[0], sc.size_wh, targets[0]))
    run.need(vis.shape == (n,) and vis.dtype == bool, "shapes_dtypes",
             f"in_view must return bool (N,), got {vis.dtype} {vis.shape}")
    empty = run.guarded("empty_input", "to_boxes on zero states",
                        lambda: obs.to_boxes(rows[0, :0], targets[0]))
    if empty is not None:
        _float_array(run, empty, (0, 4), "to_boxes on zero states", "empty_input")
    for t in targets:
        obs.end_target(t)


class _KitWalk(MotionModel):
    """The tracks workflow's motion: a 2-D random walk of the box centre (px)."""

    @property
    def state_dim(self) -> int:
        return 2

    def predict(self, states: np.ndarray, dt: float, rng: np.random.Generator,
                target: Target | None = None) -> np.ndarray:
        return states + rng.standard_normal(states.shape) * 2.0

    def init_states(self, position: np.ndarray, n: int, rng: np.random.Generator,
                    spread: float | np.ndarray = 1.0) -> np.ndarray:
        return position + rng.standard_normal((n, 2)) * spread


class _KitNearest(Likelihood):
    """The tracks workflow's likelihood: Gaussian in the distance to the nearest detection."""

    def begin_frame(self, frame: Frame, targets: Sequence[Target],
                    detections: Detections | None = None) -> None:
        b = detections.boxes_xywh_px if detections is not None else np.zeros((0, 4))
        self.centres_ = b[:, :2] + b[:, 2:] / 2

    def log_likelihood(self, boxes_xywh_px: np.ndarray, target: Target) -> np.ndarray:
        if not len(self.centres_):
            return np.zeros(len(boxes_xywh_px))
        c = boxes_xywh_px[:, :2] + boxes_xywh_px[:, 2:] / 2
        d2 = ((c[:, None, :] - self.centres_[None]) ** 2).sum(axis=2).min(axis=1)
        return -d2 / 50.0


class _KitAssociator(Associator):
    """The tracks workflow's associator: greedy nearest centres within 15 px."""

    def associate(self, targets: Sequence[Target], detections: Detections) -> Assignment:
        if not len(targets) or not len(detections):
            return Assignment.from_matches([], len(targets), len(detections))
        tb = np.array([t.box_xywh_px for t in targets])
        db = detections.boxes_xywh_px
        d = np.linalg.norm((tb[:, None, :2] + tb[:, None, 2:] / 2)
                           - (db[None, :, :2] + db[None, :, 2:] / 2), axis=2)
        m = []
        while np.isfinite(d).any() and d.min() < 15.0:
            i, j = np.unravel_index(np.argmin(d), d.shape)
            m.append((int(i), int(j)))
            d[i, :] = np.inf
            d[:, j] = np.inf
        return Assignment.from_matches(m, len(targets), len(detections))


def _tracks_workflow(ex: ConformanceExample, rng: np.random.Generator, run: _Run) -> None:
    from pftrack.builtin.image_box import ImageBoxObservation
    from pftrack.engine.runner import FrameStep, run_frames
    from pftrack.engine.tracker import MultiTargetTracker

    tracks = ex.component
    assert isinstance(tracks, TrackManager)
    sc = synthetic_scene(seed=1, n_frames=8) if ex.frames is None else _scene(ex)
    from pftrack.contracts.components import RunContext

    context = ex.context if ex.context is not None else RunContext()
    tracks.setup(context)
    parts: dict[str, Any] = {"motion": _KitWalk(), "likelihood": _KitNearest(),
                             "observation": ImageBoxObservation(20, 40),
                             "associator": _KitAssociator(), "detection_driven": True,
                             "n_particles": 64, "init_spread": 2.0, "max_misses": 3}
    parts.update(ex.engine or {})
    for key in ("motion", "likelihood", "observation", "associator"):
        if parts.get(key) is not None:
            parts[key].setup(context)
    engine = MultiTargetTracker(parts.pop("motion"), parts.pop("likelihood"),
                                parts.pop("observation"), tracks=tracks, rng=rng, **parts)
    rows = []

    def check(step: FrameStep) -> None:
        f, out = step.frame, step.records
        run.need(isinstance(out, list) and all(isinstance(r, TrackRecord) for r in out),
                 "shapes_dtypes", f"frame {f.index}: after_frame must return a list of "
                 f"TrackRecord, got {type(out).__name__}")
        for r in out:
            run.need(1 <= r.frame <= f.index and r.id >= 1, "shapes_dtypes",
                     f"frame {f.index}: a record of frame {r.frame}, id {r.id}")
            rows.append([r.frame, r.id, *np.asarray(r.box_xywh_px, dtype=np.float64)])
        # the engine draws from the Generator, the manager does not: outputs are compared
        # between runs, but not asked to depend on the seed
        run.outputs[f"records_{f.index}"] = np.array(rows[-len(out):] if out else [])

    run_frames(engine, sc.frames, after_step={"check": check},
               detections={f.index: sc.detections(f.index, extra_box=False) for f in sc.frames})
    run.outputs["rows"] = np.array(rows).reshape(-1, 6)


class _KitBirths(Initiator):
    """The stage workflow's initiator: every detection the associator left unmatched starts a
    track (a stage of another role then has tracks to act on)."""

    def initiate(self, view: FrameView) -> list[Birth]:
        d = view.detections
        if d is None:
            return []
        return [Birth(box_xywh_px=d.boxes_xywh_px[i], detection_index=int(i))
                for i in view.unmatched]


def _stage_workflow(ex: ConformanceExample, rng: np.random.Generator, run: _Run) -> None:
    """A lifecycle stage runs as the engine's track management (:class:`StagedTracks`), with
    the kit's initiator beside it unless it is an initiator itself: the tracks workflow."""
    stage = ex.component
    assert isinstance(stage, LifecycleStage)
    stages: list[Any] = [stage] if stage.role == "initiator" else [stage, _KitBirths()]
    inner = copy.copy(ex)
    inner.component = StagedTracks(stages=stages)
    _tracks_workflow(inner, rng, run)


_WORKFLOWS: dict[str, Callable[[ConformanceExample, np.random.Generator, _Run], None]] = {
    "motion": _motion_workflow,
    "likelihood": _likelihood_workflow,
    "detector": _detector_workflow,
    "associator": _associator_workflow,
    "scene": _scene_workflow,
    "observation": _observation_workflow,
    "tracks": _tracks_workflow,
    "stage": _stage_workflow,
}


def _execute(factory: Callable[[], ConformanceExample], seed: int,
             component: Component | None = None) -> _Run:
    """One workflow run on a fresh example (or on ``component`` with the example's context)."""
    run = _Run()
    try:
        ex = factory()
        if component is not None:
            ex.component = component
        if ex.context is not None:
            ex.component.setup(ex.context)
        _WORKFLOWS[ex.component.kind](ex, np.random.default_rng(seed), run)
    except Exception as exc:  # noqa: BLE001 - reported as a failed check, not a crash
        run.error = _describe_exc(exc)
    return run


# --------------------------------------------------------------------------------------------
# Comparisons
# --------------------------------------------------------------------------------------------


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape or a.dtype != b.dtype:
            return False
        if a.dtype.kind in "fc":
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(np.array_equal(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    try:
        return bool(a == b)
    except Exception:  # noqa: BLE001
        return False


def _diff_keys(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    return sorted(k for k in a.keys() | b.keys() if k not in a or k not in b
                  or not _equal(a[k], b[k]))


def _global_state() -> tuple[Any, Any]:
    return np.random.get_state(legacy=False), random.getstate()


def _same_global_state(a: tuple[Any, Any], b: tuple[Any, Any]) -> tuple[bool, bool]:
    return _equal(a[0], b[0]), a[1] == b[1]


# --------------------------------------------------------------------------------------------
# The checks
# --------------------------------------------------------------------------------------------


def _label(obj: type[Component] | Component) -> str:
    cls = obj if isinstance(obj, type) else type(obj)
    name = getattr(cls, "name", None)
    return f"{cls.__name__} ({name})" if name else cls.__name__


def check_component(obj: type[Component] | Component, *, rng_seed: int = 0,
                    host: Any = None) -> list[CheckResult]:
    """Run every conformance check on a component class or instance.

    Parameters
    ----------
    obj : Component subclass or instance
        A class is instantiated with its defaults, or through its ``_conformance_example()``
        classmethod when it has one (see :mod:`pftrack.testing`). An instance is deep-copied for
        each run, so a fitted instance is checked as it is.
    rng_seed : int
        Seed of the ``numpy.random.Generator`` handed to the component; ``rng_seed + 1`` is the
        "different seed".
    host : pftrack.host.Host, optional
        When given and the class is registered there, the config round trip rebuilds the
        component with ``host.build(kind, config)``, as a pipeline file would.

    Returns
    -------
    list of CheckResult
        One per name in :data:`CHECKS`, in that order.
    """
    return _check_component(obj, rng_seed, host)


class _Session:
    """The shared work of the checks on one component: its example factory and the reference
    runs, each made once on first use, so that the checks can run one at a time (one pytest
    item each) or all together without repeating a run."""

    def __init__(self, obj: type[Component] | Component, rng_seed: int = 0,
                 host: Any = None) -> None:
        self.obj, self.rng_seed, self.host = obj, rng_seed, host
        self.label = _label(obj)
        self.factory: Callable[[], ConformanceExample] | None = None
        self.comp: Component | None = None
        self.construct_error = ""
        try:
            self.factory = _make_factory(obj)
            ex = self.factory()
            self.comp = ex.component
            if self.comp.kind not in _WORKFLOWS:
                raise TypeError(f"kind {self.comp.kind!r} has no conformance workflow; kinds: "
                                f"{sorted(_WORKFLOWS)}")
        except Exception as exc:  # noqa: BLE001 - reported as a failed check, not a crash
            hint = ("" if hasattr(obj, "_conformance_example") else
                    "; if it needs set-up, give the class a _conformance_example() classmethod "
                    "(see pftrack.testing)")
            self.construct_error = f"could not build an example: {_describe_exc(exc)}{hint}"
        self._runs: dict[str, _Run | None] = {}

    @property
    def cls(self) -> type[Component]:
        assert self.comp is not None
        return type(self.comp)

    def execute(self, seed: int, component: Component | None = None) -> _Run:
        assert self.factory is not None
        return _execute(self.factory, seed, component)

    @property
    def ref(self) -> _Run:
        """The reference run (seed ``rng_seed``)."""
        if "ref" not in self._runs:
            self._runs["ref"] = self.execute(self.rng_seed)
        run = self._runs["ref"]
        assert run is not None
        return run

    @property
    def same(self) -> _Run | None:
        """A second run with the same seed (None when the reference run raised)."""
        if "same" not in self._runs:
            self._runs["same"] = self.execute(self.rng_seed) if self.ref.error is None else None
        return self._runs["same"]

    @property
    def ref_error(self) -> str:
        return f"the workflow raised {self.ref.error}" if self.ref.error else ""

    @property
    def same_diff(self) -> list[str]:
        same = self.same
        return (_diff_keys(self.ref.outputs, same.outputs)
                if same is not None and same.error is None else [])

    @property
    def comparable(self) -> bool:
        """Outputs of rebuilt/cloned/unpickled copies are compared only when two plain runs
        agree; otherwise the nondeterminism is reported once, by deterministic_same_seed."""
        same = self.same
        return same is not None and same.error is None and not self.same_diff


_Outcome = tuple[str, str]  # (status, message)


def check_construct(s: _Session) -> _Outcome:
    """The class builds with its defaults (or through ``_conformance_example()``)."""
    return (FAIL, s.construct_error) if s.construct_error else (PASS, "")


def check_init_stores_params(s: _Session) -> _Outcome:
    """``__init__`` only stores each parameter unchanged; ``cls(**get_params())`` rebuilds."""
    cls, comp = s.cls, s.comp
    assert comp is not None
    msgs = []
    try:
        names = cls._param_names()
        params = comp.get_params()
        sentinels = {n: _Sentinel(n) for n in names}
        try:
            # declared parameters are checked against their declarations when stored: the
            # placeholders would fail that check, which is no logic of the component's own
            with _unvalidated():
                probe = cls(**sentinels)
        except Exception as exc:  # noqa: BLE001
            probe = None
            msgs.append(f"__init__ does logic on its parameters (it failed on placeholder "
                        f"values: {type(exc).__name__}: {exc}); it must only store them")
        if probe is not None:
            for n in names:
                if getattr(probe, n, None) is not sentinels[n]:
                    msgs.append(f"parameter {n!r} is not stored unchanged as attribute {n!r}")
            extra = [k for k in vars(probe) if k not in sentinels and not
                     (k.startswith("_") and not k.endswith("_"))]
            if extra:
                msgs.append(f"__init__ sets attributes that are not parameters: {sorted(extra)} "
                            "(per-frame or learned state belongs in attributes ending with '_' "
                            "set outside __init__)")
        rebuilt = cls(**params)
        if not _equal(_plain(rebuilt.get_params()), _plain(params)):
            msgs.append("cls(**get_params()) has different parameters")
    except Exception as exc:  # noqa: BLE001
        msgs.append(_describe_exc(exc))
    return (FAIL if msgs else PASS), "; ".join(msgs)


def check_config_round_trip(s: _Session) -> _Outcome:
    """``to_config()`` is JSON, names the registered type and rebuilds the same component."""
    cls, comp, host = s.cls, s.comp, s.host
    assert comp is not None
    msgs = []
    try:
        cfg = comp.to_config()
        text = json.dumps(cfg)
        cfg2 = json.loads(text)
        if set(cfg2) != {"type", "params"}:
            msgs.append(f"to_config() keys {sorted(cfg2)}, expected ['params', 'type']")
        if cls.name is not None and cfg2.get("type") != cls.name:
            msgs.append(f"to_config()['type'] is {cfg2.get('type')!r}, registered as "
                        f"{cls.name!r}")
        if host is not None and cls.name is not None and cls.name in host.names(comp.kind) \
                and host.get(comp.kind, cls.name) is cls:
            rebuilt = host.build(comp.kind, cfg2)
        else:
            rebuilt = cls(**cfg2["params"])
        if not _equal(_plain(rebuilt.get_params()), _plain(comp.get_params())):
            msgs.append("the rebuilt component has different parameters")
        elif s.comparable:
            again = s.execute(s.rng_seed, component=rebuilt)
            if again.error:
                msgs.append(f"the component rebuilt from JSON config failed: {again.error}")
            elif _diff_keys(s.ref.outputs, again.outputs):
                msgs.append(f"the component rebuilt from its JSON config gives different outputs: "
                            f"{_diff_keys(s.ref.outputs, again.outputs)}")
    except Exception as exc:  # noqa: BLE001
        msgs.append(f"to_config -> JSON -> rebuild failed: {_describe_exc(exc)}")
    return (FAIL if msgs else PASS), "; ".join(msgs)


def check_clone(s: _Session) -> _Outcome:
    """``clone()`` is a new, stateless instance with the same parameters and outputs."""
    assert s.factory is not None
    cls = s.cls
    msgs = []
    try:
        fresh = s.factory().component
        c = fresh.clone()
        if c is fresh or type(c) is not cls:
            msgs.append("clone() must return a new instance of the same class")
        if not _equal(_plain(c.get_params()), _plain(fresh.get_params())):
            msgs.append("clone() has different parameters")
        state = [k for k in vars(c) if k.endswith("_") and not k.startswith("__")]
        if state:
            msgs.append(f"clone() carries state attributes {state}")
        if s.comparable and not isinstance(s.obj, Component):
            again = s.execute(s.rng_seed, component=c)
            if again.error:
                msgs.append(f"the clone failed: {again.error}")
            elif _diff_keys(s.ref.outputs, again.outputs):
                msgs.append(f"the clone gives different outputs: "
                            f"{_diff_keys(s.ref.outputs, again.outputs)}")
    except Exception as exc:  # noqa: BLE001
        msgs.append(_describe_exc(exc))
    return (FAIL if msgs else PASS), "; ".join(msgs)


def _contract(check: str) -> Callable[[_Session], _Outcome]:
    def run(s: _Session) -> _Outcome:
        probs = [p.message for p in s.ref.problems if p.category == check]
        if s.ref.error and not probs:
            return FAIL, s.ref_error
        return (FAIL if probs else PASS), "; ".join(probs)

    run.__name__ = f"check_{check}"
    run.__doc__ = f"The reference run's {check.replace('_', ' ')} contract (per kind)."
    return run


check_shapes_dtypes = _contract("shapes_dtypes")
check_empty_input = _contract("empty_input")
check_inputs_unchanged = _contract("inputs_unchanged")
check_finite_output = _contract("finite_output")


def check_deterministic_same_seed(s: _Session) -> _Outcome:
    """The same Generator seed gives bit-identical outputs."""
    if s.ref.error:
        return SKIP, s.ref_error
    same = s.same
    assert same is not None
    if same.error:
        return FAIL, f"second run raised {same.error}"
    diff = s.same_diff
    return ((FAIL, f"two runs with seed {s.rng_seed} differ in {diff} (hidden randomness: use "
                   "only the Generator passed in)") if diff else (PASS, ""))


def check_different_seeds_differ(s: _Session) -> _Outcome:
    """Outputs drawn from the Generator change with its seed (skipped when none are)."""
    if s.ref.error:
        return SKIP, s.ref_error
    if not s.ref.rng_used:
        return SKIP, "deterministic: draws nothing from the rng"
    other = s.execute(s.rng_seed + 1)
    if other.error:
        return FAIL, f"run with seed {s.rng_seed + 1} raised {other.error}"
    # every output computed with draws from the Generator must change with its seed
    unchanged = sorted(k for k in s.ref.rng_keys if k in other.outputs
                       and _equal(s.ref.outputs[k], other.outputs[k]))
    return ((FAIL, f"{unchanged} draw from the Generator but do not depend on its seed")
            if unchanged else (PASS, ""))


def check_pickle_round_trip(s: _Session) -> _Outcome:
    """An unpickled component gives the same outputs; a used one still pickles."""
    assert s.factory is not None
    cls, factory = s.cls, s.factory
    msgs = []
    try:
        fresh = factory().component
        copy_ = pickle.loads(pickle.dumps(fresh))
        if type(copy_) is not cls or not _equal(_plain(copy_.get_params()),
                                                _plain(fresh.get_params())):
            msgs.append("the unpickled component differs in class or parameters")
        elif s.comparable:
            again = s.execute(s.rng_seed, component=copy_)
            if again.error:
                msgs.append(f"the unpickled component failed: {again.error}")
            elif _diff_keys(s.ref.outputs, again.outputs):
                msgs.append(f"the unpickled component gives different outputs: "
                            f"{_diff_keys(s.ref.outputs, again.outputs)}")
        used = factory().component
        ex_used = _with(factory(), used)
        if ex_used.context is not None:
            used.setup(ex_used.context)
        _WORKFLOWS[cls.kind](ex_used, np.random.default_rng(s.rng_seed), _Run())
        pickle.loads(pickle.dumps(used))  # mid-stream state must pickle too (worker processes)
    except Exception as exc:  # noqa: BLE001
        msgs.append(f"pickle round trip failed: {_describe_exc(exc)}")
    return (FAIL if msgs else PASS), "; ".join(msgs)


def check_no_global_random_state(s: _Session) -> _Outcome:
    """A whole run leaves the global ``numpy.random`` and ``random`` states alone."""
    np.random.seed(987654321)
    random.seed(987654321)
    before = _global_state()
    run = s.execute(s.rng_seed)
    np_same, py_same = _same_global_state(before, _global_state())
    bad = [n for n, ok in (("numpy.random (global)", np_same), ("random", py_same)) if not ok]
    if bad:
        return FAIL, (f"the component changed the global state of {' and '.join(bad)}: draw "
                      "from the Generator passed in instead")
    if run.error:
        return SKIP, f"the workflow raised {run.error}"
    return PASS, ""


#: Every check by name, in the order they run (:data:`CHECKS` is its keys).
CHECK_FUNCTIONS: dict[str, Callable[[_Session], _Outcome]] = {
    "construct": check_construct,
    "init_stores_params": check_init_stores_params,
    "config_round_trip": check_config_round_trip,
    "clone": check_clone,
    "shapes_dtypes": check_shapes_dtypes,
    "empty_input": check_empty_input,
    "inputs_unchanged": check_inputs_unchanged,
    "finite_output": check_finite_output,
    "deterministic_same_seed": check_deterministic_same_seed,
    "different_seeds_differ": check_different_seeds_differ,
    "pickle_round_trip": check_pickle_round_trip,
    "no_global_random_state": check_no_global_random_state,
}
assert tuple(CHECK_FUNCTIONS) == CHECKS


def _run_check(s: _Session, check: str) -> CheckResult:
    """One check on a session, the caller's global random states kept."""
    if check not in CHECK_FUNCTIONS:
        raise ValueError(f"unknown conformance check {check!r}; checks: {list(CHECKS)}")
    if s.construct_error and check != "construct":
        return CheckResult(check, SKIP, "no example could be built", s.label)
    saved = _global_state()
    try:
        status, message = CHECK_FUNCTIONS[check](s)
    finally:  # a component that draws from the global generators must not disturb the caller
        np.random.set_state(saved[0])
        random.setstate(saved[1])
    return CheckResult(check, status, message, s.label)


def run_check(obj: type[Component] | Component, check: str, *, rng_seed: int = 0,
              host: Any = None) -> CheckResult:
    """Run the one conformance check named ``check`` (one of :data:`CHECKS`) on a component."""
    return _run_check(_Session(obj, rng_seed, host), check)


def parametrize_with_checks(components: Sequence[type[Component] | Component], *,
                            host: Any = None, rng_seed: int = 0,
                            ids: Sequence[str] | None = None, skip: Sequence[str] = (),
                            must_run: Sequence[str] = ()) -> Any:
    """A ``pytest.mark.parametrize`` giving one test item per (component, check), as
    scikit-learn's ``parametrize_with_checks`` does::

        from pftrack.testing import parametrize_with_checks

        @parametrize_with_checks([MyLikelihood, MyMotion(noise=2.0)])
        def test_conforms(component, check):
            check(component)

    Each item is named ``LABEL-CHECK`` (``-k clone`` selects one check everywhere); ``check``
    raises ``AssertionError`` naming the component and the check when it fails and skips the
    item when the check does not apply. The runs the checks share (the reference run and its
    repeat) are made once per component and process.

    Parameters
    ----------
    components : sequence of Component classes or instances
    host : pftrack.host.Host, optional
        As for :func:`check_component`.
    rng_seed : int
    ids : sequence of str, optional
        Labels of the components in the item names (default ``ClassName (registered-name)``).
    skip : sequence of str
        Checks left out (say why in your test).
    must_run : sequence of str
        Checks that must pass, not skip: a skip of one of these fails its item.
    """
    import pytest

    unknown = (set(skip) | set(must_run)) - set(CHECKS)
    if unknown:
        raise ValueError(f"parametrize_with_checks: unknown checks {sorted(unknown)}; "
                         f"checks: {list(CHECKS)}")
    comps = list(components)
    labels = list(ids) if ids is not None else [_label(c) for c in comps]
    if len(labels) != len(comps):
        raise ValueError(f"parametrize_with_checks: {len(labels)} ids for {len(comps)} "
                         "components")
    sessions: dict[int, _Session] = {}

    def make(name: str) -> Callable[[type[Component] | Component], None]:
        def check(component: type[Component] | Component) -> None:
            session = sessions.get(id(component))
            if session is None:
                session = sessions[id(component)] = _Session(component, rng_seed, host)
            r = _run_check(session, name)
            if r.status == FAIL or (r.status == SKIP and name in must_run):
                raise AssertionError(f"{r.component} does not conform to the pftrack component "
                                     f"contract: {r}")
            if r.status == SKIP:
                pytest.skip(str(r))

        check.__name__ = f"check_{name}"
        return check

    checks = {name: make(name) for name in CHECKS if name not in skip}
    params = [pytest.param(c, fn, id=f"{label}-{name}")
              for c, label in zip(comps, labels) for name, fn in checks.items()]
    return pytest.mark.parametrize(("component", "check"), params)


def _check_component(obj: type[Component] | Component, rng_seed: int,
                     host: Any) -> list[CheckResult]:
    s = _Session(obj, rng_seed, host)
    return [_run_check(s, c) for c in CHECKS]


def _with(ex: ConformanceExample, component: Component) -> ConformanceExample:
    ex.component = component
    return ex


class _Sentinel:
    """A placeholder parameter value: __init__ must store it without looking at it."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __repr__(self) -> str:
        return f"<param {self.name}>"


def assert_conforms(obj: type[Component] | Component, *, rng_seed: int = 0,
                    host: Any = None, skip: Sequence[str] = ()) -> list[CheckResult]:
    """Like :func:`check_component`, raising ``AssertionError`` listing every failed check.

    ``skip`` names checks to leave out (say why in your test).
    """
    unknown = set(skip) - set(CHECKS)
    if unknown:
        raise ValueError(f"assert_conforms: unknown checks in skip: {sorted(unknown)}; "
                         f"checks: {list(CHECKS)}")
    results = check_component(obj, rng_seed=rng_seed, host=host)
    failed = [r for r in results if r.status == FAIL and r.check not in skip]
    if failed:
        lines = "\n  ".join(str(r) for r in failed)
        raise AssertionError(f"{_label(obj)} does not conform to the pftrack component "
                             f"contract:\n  {lines}")
    return results
