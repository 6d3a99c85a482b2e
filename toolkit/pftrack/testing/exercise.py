"""Each component kind's run in the conformance kit: the calls a tracker would make.

:func:`pftrack.testing.check_component` runs a component through the workflow of its kind
(motion model, likelihood, detector, associator, scene, observation model, track manager,
lifecycle stage) on a :class:`ConformanceExample` (the component's own
``_conformance_example()``, the gaps filled from the kit's synthetic scene); each run checks the
shapes and dtypes of what the component returns and collects its outputs, which the checks of
:mod:`pftrack.testing.checks` compare between runs.
"""

from __future__ import annotations

import copy
import itertools
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
)
from pftrack.contracts.stages import Birth, FrameView, Initiator, LifecycleStage
from pftrack.engine.lifecycle import StagedTracks
from pftrack.testing.synthetic import SyntheticScene, synthetic_scene, target_from_box


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
