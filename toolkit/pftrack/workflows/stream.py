"""Track the boxes of your own detector, frame by frame, from Python.

:class:`Tracker` wraps the engine (:class:`pftrack.engine.tracker.MultiTargetTracker`) of a preset
or a configuration behind one call per frame::

    import pftrack

    tracker = pftrack.Tracker("people-image", seed=0)
    # boxes: (N, 4|5|6) arrays x1, y1, x2, y2[, score[, class_id]], pixels
    for image, boxes in zip(frames, detections):
        out = tracker.update(boxes, frame=image)   # this frame's tracks
        out.tracker_id, out.xyxy, out.confidence, out.class_id, out.xyxy_sd

Inputs and outputs use supervision's names (``xyxy``, ``confidence``, ``class_id``,
``tracker_id``); a supervision ``sv.Detections`` in gives an ``sv.Detections`` out, with
``tracker_id`` set and the uncertainty in its ``data``. Every track carries how sure the filter
is of it: ``xyxy_sd``, the standard deviation of each box coordinate over the particle cloud
(pixels), and with a camera its ground position ``world_xy`` (metres) and that position's
covariance ``world_cov`` (m^2), from the same cloud.

The tracker does not run the configuration's detector: the detections you give are tracked, as
``pftrack run CONFIG --detections FILE`` tracks a file's (the same preset, seed and frames give
the same tracks). Detections of different classes are tracked by separate engines, one per
class, so a track keeps its class and tracks of different classes are never associated; each
class's engine is seeded with ``seed``, so a class's tracks are those a tracker fed that class's
detections alone would give. The inputs are read and checked in
:mod:`pftrack.workflows.stream_inputs`.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from pftrack.contracts.components import Component, Detections, Frame, TrackRecord
from pftrack.engine.lifecycle import LifecycleTracks
from pftrack.workflows.spread import _NAN4, _NAN22, RecordSpread
from pftrack.workflows.stream_inputs import _check_inside, _parse

if TYPE_CHECKING:
    from pftrack.engine.tracker import MultiTargetTracker
    from pftrack.geometry.camera import Camera

__all__ = ["Tracker", "Tracks", "image_readers"]

# Built-in components that never read a frame's pixels (module.class). A likelihood or track
# manager not listed, and without a ``reads_image`` attribute of its own, is taken to read them.
_IMAGE_FREE = frozenset({
    "pftrack_world.likelihoods.DetectionLikelihood",
    "pftrack_basic.gaussian.GaussianLikelihood",
    "pftrack.engine.lifecycle.ManualTracks",
    "pftrack_basic.tracks.DetectionBirthTracks",
    "pftrack_basic.tracks.UnmatchedBirthInitiator",
    "pftrack_basic.tracks.DetectionBirthInitiator",
    "pftrack_basic.tracks.HitConfirmer",
    "pftrack_basic.tracks.BorderTerminator",
    "pftrack_basic.tracks.DuplicateMerger",
    "pftrack_basic.tracks.OutputBoxReporter",
    "pftrack_colour.experiment.GivenStartsInitiator",
    "pftrack_colour.experiment.GivenEndsTerminator",
    "pftrack_colour.experiment.BoxSizeSizer",  # asks the likelihood, which is visited itself
})
_COMPOSITE = "pftrack_world.likelihoods.CompositeLikelihood"
_CONFIRMED = "pftrack_basic.tracks.ConfirmedTracks"


def _qualname(obj: Any) -> str:
    cls = type(obj)
    return f"{cls.__module__}.{cls.__qualname__}"


def image_readers(engine: MultiTargetTracker) -> list[str]:
    """The components of ``engine`` that read a frame's pixels (empty: frames without an image
    track the same), each as ``"kind 'name'"``.

    A component says so with a ``reads_image`` attribute (True or False); without one, the
    built-in detection and Gaussian likelihoods and the ``manual`` and ``births`` track managers
    read no pixels, ``composite`` reads them when one of its terms does, ``confirmed`` when it
    keeps a colour model (``appearance``), a list of lifecycle stages when one of its stages
    does (of the built-in stages, only ``colour-reid``), and any other likelihood, track
    manager or stage is taken to read them. Observation models, motion models and associators
    are never handed a frame.
    """
    found: list[str] = []

    def visit(c: Any) -> None:
        flag = getattr(c, "reads_image", None)
        who = f"{c.kind} {c.name or type(c).__name__!r}"
        if isinstance(flag, bool):
            if flag:
                found.append(who)
            return
        key = _qualname(c)
        if key == _COMPOSITE:
            for term in c._build():
                visit(term)
        elif key == _CONFIRMED:
            if c.appearance is not None:
                found.append(f"{who} (its colour model, tracks.appearance)")
        elif isinstance(c, LifecycleTracks) and key not in _IMAGE_FREE:
            for stage in c._stages():  # a list of lifecycle stages: the stages that read them
                visit(stage)
        elif key not in _IMAGE_FREE:
            found.append(who)

    visit(engine.likelihood)
    visit(engine.tracks)
    return found


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------


@dataclass
class Tracks:
    """Tracks of one frame (or of several: ``frame`` says which), in supervision's names.

    Attributes
    ----------
    tracker_id : ndarray (M,), int64
        Track id, unique across classes, stable over the video.
    xyxy : ndarray (M, 4), float64
        The track's box ``x1, y1, x2, y2`` in pixels (what ``tracks.txt`` holds).
    confidence : ndarray (M,), float64
        The logistic of the best particle's log-likelihood (0.5 at a birth).
    class_id : ndarray (M,), int64
        The class of the detections the track follows (0 when none was given).
    xyxy_sd : ndarray (M, 4), float64
        Standard deviation of each box coordinate over the target's particle cloud, pixels:
        how sure the filter is of the box (:class:`RecordSpread` says how it is computed:
        from the engine's extent for image boxes, from the resampled particles' boxes with a
        camera). It is the filter's own spread; an output box moved towards its matched
        detection (``tracks.box_from_detection``) keeps the cloud's. NaN where it is not known.
    world_m : ndarray (M, 3), float64, or None
        Ground position ``x, y, z`` in metres (configurations with a camera), else None.
    world_cov : ndarray (M, 2, 2), float64, or None
        Covariance of the ground position ``x, y`` over the particle cloud, m^2 (with a
        camera, else None). Its ellipse at 2 standard deviations holds about 86 % of the cloud
        when the cloud is Gaussian.
    frame : ndarray (M,), int64
        The frame each row describes (MOTChallenge numbering, from 1).
    xywh : ndarray (M, 4), float64
        The same box as ``left, top, width, height`` in pixels, exactly as the engine output
        it (``tracks.txt``'s columns; ``xyxy`` is computed from it).
    confirmed_earlier : Tracks or None
        Rows of *earlier* frames that became known in this frame: a track manager that waits
        for a new track to be confirmed (the ``confirmed`` track manager: ``confirm_hits``
        detections in ``confirm_window`` frames) outputs the track's frames from its birth on
        when it is confirmed. They are kept apart so that this frame's tracks are only this
        frame's (an overlay never draws an old box on the current image); their ``frame``
        column says which frame each belongs to. None on a result that is itself earlier rows.
    """

    tracker_id: np.ndarray
    xyxy: np.ndarray
    confidence: np.ndarray
    class_id: np.ndarray
    xyxy_sd: np.ndarray
    frame: np.ndarray
    world_m: np.ndarray | None = None
    world_cov: np.ndarray | None = None
    xywh: np.ndarray | None = field(default=None, repr=False)
    confirmed_earlier: Tracks | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return len(self.tracker_id)

    @property
    def world_xy(self) -> np.ndarray | None:
        """Ground position ``x, y`` in metres (M, 2), or None without a camera."""
        return None if self.world_m is None else self.world_m[:, :2]

    @classmethod
    def empty(cls, world: bool = False) -> Tracks:
        return cls(np.zeros(0, np.int64), np.zeros((0, 4)), np.zeros(0), np.zeros(0, np.int64),
                   np.zeros((0, 4)), np.zeros(0, np.int64),
                   np.zeros((0, 3)) if world else None, np.zeros((0, 2, 2)) if world else None,
                   np.zeros((0, 4)))

    def __post_init__(self) -> None:
        if self.xywh is None:
            self.xywh = np.concatenate([self.xyxy[:, :2], self.xyxy[:, 2:] - self.xyxy[:, :2]],
                                       axis=1)

    @classmethod
    def concat(cls, parts: Sequence[Tracks]) -> Tracks:
        """One :class:`Tracks` of the rows of ``parts`` in order (``confirmed_earlier`` not
        kept)."""
        parts = list(parts)
        if not parts:
            return cls.empty()
        world = parts[0].world_m is not None
        out: dict[str, Any] = {}
        for f in fields(cls):
            if f.name == "confirmed_earlier":
                continue
            vals = [getattr(p, f.name) for p in parts]
            if f.name in ("world_m", "world_cov") and not world:
                out[f.name] = None
                continue
            out[f.name] = np.concatenate(vals)
        return cls(**out)

    def to_mot(self) -> np.ndarray:
        """MOTChallenge rows (M, 10): frame, id, left, top, width, height, conf, x, y, z
        (world columns -1 without a camera), as :func:`pftrack.engine.tracker.records_to_mot`."""
        rows = np.full((len(self), 10), -1.0)
        rows[:, 0] = self.frame
        rows[:, 1] = self.tracker_id
        rows[:, 2:6] = self.xywh
        rows[:, 6] = self.confidence
        if self.world_m is not None:
            rows[:, 7:10] = self.world_m
        return rows

    def to_dataframe(self) -> Any:
        """A pandas DataFrame, one row per track and frame, with the uncertainty columns (see
        :meth:`Tracker.to_dataframe`). Needs pandas."""
        return _dataframe(self)

    def draw(self, image_bgr: np.ndarray, k: float = 2.0) -> np.ndarray:
        """A copy of ``image_bgr`` (H, W, 3 uint8, BGR) with the boxes, their ids and each box
        centre's ``k``-sd ellipse (:func:`pftrack.render.overlay.draw_uncertainty`)."""
        from pftrack.render.overlay import draw_boxes, draw_uncertainty

        img = draw_boxes(image_bgr, np.asarray(self.xywh), self.tracker_id)
        return draw_uncertainty(img, self.xyxy, self.xyxy_sd, self.tracker_id, k=k)

    def to_supervision(self) -> Any:
        """The rows as a supervision ``sv.Detections`` with ``tracker_id`` set; ``data`` holds
        ``xyxy_sd``, ``frame`` and, with a camera, ``world_xy`` and ``world_cov``."""
        import supervision as sv

        data: dict[str, Any] = {"xyxy_sd": self.xyxy_sd, "frame": self.frame}
        if self.world_m is not None:
            data["world_xy"] = self.world_m[:, :2]
            data["world_cov"] = self.world_cov
        return sv.Detections(xyxy=self.xyxy, confidence=self.confidence,
                             class_id=self.class_id, tracker_id=self.tracker_id, data=data)


def _dataframe(tracks: Tracks, published: np.ndarray | None = None) -> Any:
    try:
        import pandas as pd
    except ImportError:
        raise ImportError("to_dataframe() needs pandas: pip install pandas") from None
    cols: dict[str, Any] = {
        "frame": tracks.frame, "tracker_id": tracks.tracker_id, "class_id": tracks.class_id,
        "x1": tracks.xyxy[:, 0], "y1": tracks.xyxy[:, 1], "x2": tracks.xyxy[:, 2],
        "y2": tracks.xyxy[:, 3], "confidence": tracks.confidence,
        "x1_sd": tracks.xyxy_sd[:, 0], "y1_sd": tracks.xyxy_sd[:, 1],
        "x2_sd": tracks.xyxy_sd[:, 2], "y2_sd": tracks.xyxy_sd[:, 3],
    }
    if tracks.world_m is not None and tracks.world_cov is not None:
        cols.update({"world_x": tracks.world_m[:, 0], "world_y": tracks.world_m[:, 1],
                     "world_z": tracks.world_m[:, 2],
                     "world_var_x": tracks.world_cov[:, 0, 0],
                     "world_cov_xy": tracks.world_cov[:, 0, 1],
                     "world_var_y": tracks.world_cov[:, 1, 1]})
    if published is not None:
        cols["published_frame"] = published
    return pd.DataFrame(cols)


_NO_LIMIT = 2**62


# --------------------------------------------------------------------------------------------
# The tracker
# --------------------------------------------------------------------------------------------


class _PluginClasses:
    """A plugin object registering component classes handed in from Python (a notebook)."""

    def __init__(self, classes: Sequence[type[Component]]) -> None:
        from pftrack.contracts.hookspecs import hookimpl

        by_kind: dict[str, list[type[Component]]] = {}
        for cls in classes:
            by_kind.setdefault(cls.kind, []).append(cls)
        hooks = {"likelihood": "pftrack_register_likelihoods",
                 "motion": "pftrack_register_motion_models",
                 "detector": "pftrack_register_detectors",
                 "associator": "pftrack_register_associators",
                 "scene": "pftrack_register_scenes",
                 "observation": "pftrack_register_observation_models",
                 "tracks": "pftrack_register_track_managers"}
        for kind, group in by_kind.items():
            def register_all(register: Any, group: list[type[Component]] = group) -> None:
                for c in group:
                    register(component_name(c), c)

            setattr(self, hooks[kind], hookimpl(specname=hooks[kind])(register_all))


def component_name(cls: type[Component]) -> str:
    """The name a component class handed in from Python is registered under: its own ``name``
    when it sets one, else its class name in kebab case (``MyLikelihood`` -> ``my-likelihood``)."""
    own = cls.__dict__.get("name")
    if isinstance(own, str) and own:
        return own
    import re

    # a word starts at a capital after a lower-case letter or digit, or at the last capital of
    # an acronym followed by a lower-case letter: HOGLikelihood -> hog-likelihood
    return re.sub(r"(?<=[a-z0-9])(?=[A-Z])|(?<=[A-Z])(?=[A-Z][a-z])", "-",
                  cls.__name__).lower()


def host_with(plugins: Iterable[Any], name: str = "notebook") -> Any:
    """A :class:`pftrack.host.Host` with the installed plugins and ``plugins``: component classes
    (registered under :func:`component_name`, as plugin ``name``) or plugin objects with
    ``pftrack_register_*`` hooks (a module), each its own plugin."""
    from pftrack.host import Host

    classes, objects = [], []
    for i, p in enumerate(plugins):
        if isinstance(p, type) and issubclass(p, Component):
            if p.kind not in ("likelihood", "motion", "detector", "associator", "scene",
                              "observation", "tracks"):
                raise ValueError(f"plugins[{i}]: {p.__name__} subclasses no component kind "
                                 "(Likelihood, MotionModel, TrackManager, ...)")
            classes.append(p)
        elif isinstance(p, type):
            raise TypeError(f"plugins[{i}]: {p.__name__} is not a pftrack component class "
                             "(subclass pftrack.contracts.components.Likelihood, MotionModel, ...)")
        else:
            objects.append((getattr(p, "__name__", f"{name}-{i}"), p))
    extra = ([(name, _PluginClasses(classes))] if classes else []) + objects
    return Host(plugins=extra)


class Tracker:
    """Multi-object tracking of your own detections, one frame per :meth:`update`.

    Parameters
    ----------
    config : str, path or dict
        A preset name (``pftrack presets`` lists them: ``people-image`` needs no camera), a
        YAML configuration file, or a configuration dict
        (:func:`pftrack.workflows.pipeline.load_config`). Its detector is not run: :meth:`update`
        is given the detections.
    fps : float
        Frames per second of the video (a configuration with ``tracker.dt: auto`` steps
        ``1 / fps`` seconds per frame). Unit: frames/s.
    seed : int
        Seed of the one random generator of each class's engine: the same seed, configuration
        and detections give the same tracks.
    camera : Camera or path, optional
        The calibrated camera of ground-plane configurations (``state: world``); a camera
        file as ``pftrack run --camera`` reads. Tracks then carry ``world_m`` and
        ``world_cov``.
    plugins : sequence, optional
        Component classes defined in your own code (a ``Likelihood`` subclass, say), registered
        for this tracker under their ``name`` attribute or their class name in kebab case
        (``MyLikelihood`` -> ``my-likelihood``), so that the configuration can name them; or
        plugin objects with ``pftrack_register_*`` hooks.
    image_size : (int, int), optional
        Image width and height in pixels, for updates without ``frame=`` (a configuration
        whose components read no pixels); otherwise the first frame's size.
    keep_history : bool
        Keep every frame's tracks for :meth:`to_dataframe` and :attr:`history` (a few hundred
        bytes per track and frame); False for endless streams.

    Attributes
    ----------
    config : dict
        The configuration, as loaded.
    history : list of Tracks
        Every row output so far, this frame's and confirmed earlier ones, in output order.
    confirmed_earlier : Tracks
        The earlier-frame rows the last :meth:`update` made known (also on its result).
    """

    def __init__(self, config: str | os.PathLike[str] | dict[str, Any] = "people-image", *,
                 fps: float = 25.0, seed: int = 0, camera: Camera | str | os.PathLike[str]
                 | None = None, plugins: Sequence[Any] = (),
                 image_size: tuple[int, int] | None = None, keep_history: bool = True) -> None:
        from pftrack.host import get_host
        from pftrack.workflows.pipeline import build_engine, load_config

        if not (isinstance(fps, (int, float)) and not isinstance(fps, bool) and fps > 0
                and np.isfinite(fps)):
            raise ValueError(f"Tracker(fps={fps!r}): must be a positive number (frames/s)")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
            raise TypeError(f"Tracker(seed={seed!r}): must be an integer")
        self.host = host_with(plugins) if plugins else get_host()
        self.config = load_config(config)
        self.fps = float(fps)
        self.seed = int(seed)
        if camera is not None and not hasattr(camera, "project"):
            from pftrack.geometry.formats import load_camera

            camera = load_camera(camera)
        self.camera: Camera | None = camera  # type: ignore[assignment]
        self.keep_history = bool(keep_history)
        self._image_size = None if image_size is None else self._size_arg(image_size)
        self._build = build_engine
        self._first: MultiTargetTracker | None = self._new_engine()  # errors now, not later
        self._readers = image_readers(self._first)
        from pftrack.contracts.components import ObservationModel

        # ground positions: an observation model with a world frame (a camera)
        obs = type(self._first.observation)
        self._world = obs.world_position is not ObservationModel.world_position
        self._clear()

    @staticmethod
    def _size_arg(size: Any) -> tuple[int, int]:
        try:
            w, h = (int(v) for v in size)
        except (TypeError, ValueError):
            raise ValueError(f"Tracker(image_size={size!r}): expected (width, height) in "
                             "pixels") from None
        if w < 1 or h < 1:
            raise ValueError(f"Tracker(image_size={size!r}): width and height must be >= 1")
        return w, h

    def _new_engine(self) -> MultiTargetTracker:
        return self._build(self.config, camera=self.camera, fps=self.fps, seed=self.seed,
                           host=self.host)

    def reset(self) -> None:
        """Forget every track and frame: the next :meth:`update` starts a new video, with the
        tracks a new tracker would give."""
        self._first = self._new_engine()
        self._clear()

    def _clear(self) -> None:
        self._engines: dict[int, MultiTargetTracker] = {}
        self._ids: dict[tuple[int, int], int] = {}
        self._next_id = 1
        self._first_class = -1
        self._first_limit = _NO_LIMIT  # engine ids of the first class kept as tracker ids
        self._max_first_id = 0
        self._spread: dict[int, RecordSpread] = {}
        self._last_index = 0
        self._last_size: tuple[int, int] | None = None
        self._blank: np.ndarray | None = None
        self.history: list[Tracks] = []
        self._published: list[np.ndarray] = []
        self.confirmed_earlier = Tracks.empty(self._world)

    @property
    def engines(self) -> dict[int, MultiTargetTracker]:
        """The engine of each class seen so far, by class id (read them, do not step them)."""
        return dict(self._engines)

    # -- one frame ----------------------------------------------------------------------------

    def update(self, detections: Any, frame: Any = None, *, layout: str = "xyxy",
               class_id: Any = None, frame_index: int | None = None) -> Any:
        """Track one frame's detections; returns this frame's tracks.

        Parameters
        ----------
        detections
            * an array (N, 4), (N, 5) or (N, 6): ``x1, y1, x2, y2[, score[, class_id]]`` in
              pixels (score 1 when left out, class 0);
            * a ``pftrack.Detections`` (boxes ``left, top, width, height``);
            * a supervision ``sv.Detections`` (``xyxy``, ``confidence``, ``class_id``): the
              result is then an ``sv.Detections`` too;
            * with ``layout="mot"``: MOTChallenge rows (N, 6..10) ``frame, id, left, top,
              width, height[, conf, ...]`` of this frame (a ``det.txt``'s; conf -1 reads as
              score 1);
            * None or an empty array: no detection in this frame.
        frame : ndarray (H, W, 3) uint8 or pftrack.Frame, optional
            The image, BGR (OpenCV's order). Needed when the configuration reads pixels
            (an appearance likelihood, a colour model); every frame of a video has one size.
        layout : {"xyxy", "mot"}
            How an array's columns are read.
        class_id : array (N,), optional
            Classes of a ``pftrack.Detections`` or of an array without a class column.
        frame_index : int, optional
            The frame's number (MOTChallenge numbering, from 1); default: one more than the
            last (a ``pftrack.Frame`` brings its own). Must increase.

        Returns
        -------
        Tracks, or sv.Detections for an sv.Detections input
            This frame's tracks only; rows of earlier frames made known now (a track
            confirmed this frame) are in ``.confirmed_earlier`` (for an ``sv.Detections``
            result: :attr:`confirmed_earlier`).

        Raises
        ------
        ValueError
            Bad input, naming the argument and the row: a wrong shape, NaN or infinity, a
            negative or zero size, a box wholly outside the image, a frame of another size
            than the last, a frame index that does not increase, no ``frame`` for a
            configuration that reads pixels. Nothing is changed when it is raised.
        """
        # every check before any engine is touched
        image = None
        if isinstance(frame, Frame):
            image = frame.image
            if frame_index is None:
                frame_index = int(frame.index)
        elif frame is not None:
            image = frame
        index = self._index_arg(frame_index)
        size = self._size_of(image)
        inp = _parse(detections, layout, index, class_id)
        _check_inside(inp, size)
        if image is None:
            if self._blank is None or self._blank.shape[:2] != (size[1], size[0]):
                # never read (checked above): gives the engine the image size it tests with
                self._blank = np.broadcast_to(np.zeros(3, np.uint8), (size[1], size[0], 3))
            image = self._blank
        # -- the frame
        fr = Frame(index=index, image=image, time_s=(index - 1) / self.fps)
        classes = np.unique(inp.classes).tolist()
        for c in classes:
            if c not in self._engines:
                if self._first is not None:
                    self._engines[c] = self._first
                    self._first = None
                    self._first_class = c
                    self._spread[c] = RecordSpread(self._engines[c])
                else:
                    if self._first_limit == _NO_LIMIT:
                        # a second class: the first engine's ids given so far stay, every
                        # later id is numbered on from them
                        first = self._engines[self._first_class]
                        given = max([t.id for t in first.targets] + [self._max_first_id])
                        self._first_limit = given
                        self._next_id = given + 1
                    self._engines[c] = self._new_engine()
                    self._spread[c] = RecordSpread(self._engines[c])
        world = self._world
        now_parts: list[Tracks] = []
        late_parts: list[Tracks] = []
        for c in sorted(self._engines):
            engine = self._engines[c]
            keep = inp.classes == c if len(classes) > 1 else slice(None)
            # the detections' ground points (points_world_m) are those given: no built-in
            # component reads them, and back-projecting every frame's boxes would cost more
            # than the rest of update() (pftrack.io.detections.read_detections adds them)
            d = Detections(inp.xywh[keep], inp.scores[keep],
                           None if inp.points is None else inp.points[keep])
            records = engine.step(fr, d)
            if c == self._first_class and self._first_limit == _NO_LIMIT and records:
                self._max_first_id = max(self._max_first_id, max(r.id for r in records))
            now, late = self._rows(c, engine, records, index, world)
            now_parts.append(now)
            if late is not None:
                late_parts.append(late)
        self._last_index = index
        self._last_size = size
        now = now_parts[0] if len(now_parts) == 1 else Tracks.concat(now_parts)
        late_t = (late_parts[0] if len(late_parts) == 1 else Tracks.concat(late_parts)
                  if late_parts else Tracks.empty(world))
        now.confirmed_earlier = late_t
        self.confirmed_earlier = late_t
        if self.keep_history:
            for part in (late_t, now):
                if len(part):
                    self.history.append(part)
                    self._published.append(np.full(len(part), index, dtype=np.int64))
        if inp.supervision:
            return now.to_supervision()
        return now

    def _index_arg(self, frame_index: Any) -> int:
        if frame_index is None:
            return self._last_index + 1
        if isinstance(frame_index, bool) or not isinstance(frame_index, (int, np.integer)):
            raise TypeError(f"update(frame_index={frame_index!r}): must be an integer")
        if frame_index <= self._last_index:
            raise ValueError(f"update(frame_index={frame_index}): frames must come in order; "
                             f"the last was {self._last_index} (reset() starts a new video)")
        return int(frame_index)

    def _size_of(self, image: Any) -> tuple[int, int]:
        if image is None:
            if self._readers:
                raise ValueError(f"update(frame=None): configuration "
                                 f"{self.config.get('name') or self.config.get('_source')!r} "
                                 f"reads the image ({', '.join(self._readers)}); pass "
                                 "frame=image, the (H, W, 3) uint8 BGR picture (a component "
                                 "of your own that reads no pixels says so with a class "
                                 "attribute reads_image = False)")
            size = self._last_size or self._image_size
            if size is None:
                raise ValueError("update(frame=None): the image size is unknown; pass "
                                 "frame=image or Tracker(..., image_size=(width, height))")
            return size
        if not isinstance(image, np.ndarray):
            raise TypeError(f"update(frame=...): expected an (H, W, 3) uint8 numpy image "
                             f"or a pftrack.Frame, got {type(image).__name__}")
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(f"update(frame=...): expected an (H, W, 3) uint8 BGR image, got "
                             f"shape {image.shape}, dtype {image.dtype}")
        size = (int(image.shape[1]), int(image.shape[0]))
        if self._last_size is not None and size != self._last_size:
            raise ValueError(f"update(frame=...): a {size[0]}x{size[1]} frame, the last was "
                             f"{self._last_size[0]}x{self._last_size[1]}; a new video needs "
                             "reset() or another Tracker")
        return size

    def _ids_of(self, c: int, eids: list[int]) -> np.ndarray:
        """Tracker ids of engine ids ``eids`` of class ``c``: while one class has been seen,
        the engine's own ids (those ``pftrack run`` writes); ids a later class's engine, or
        the first engine after a second class appeared, gives get new numbers, so that ids
        are unique across classes."""
        if c == self._first_class and all(e <= self._first_limit for e in eids):
            return np.array(eids, dtype=np.int64)
        out = []
        for e in eids:
            if c == self._first_class and e <= self._first_limit:
                out.append(e)
                continue
            g = self._ids.get((c, e))
            if g is None:
                g = self._ids[(c, e)] = self._next_id
                self._next_id += 1
            out.append(g)
        return np.array(out, dtype=np.int64)

    def _rows(self, c: int, engine: MultiTargetTracker, records: list[TrackRecord],
              index: int, world: bool) -> tuple[Tracks, Tracks | None]:
        """This frame's records and earlier ones as :class:`Tracks`, their spread filled."""
        if self._first_limit != _NO_LIMIT:
            self._ids_of(c, [t.id for t in engine.targets])  # ids in birth order
        self._spread[c].fill(engine, records, index)
        now_r = [r for r in records if r.frame == index]
        late_r = [r for r in records if r.frame != index] if len(now_r) != len(records) else []
        now = self._tracks(c, now_r, world)
        return now, (self._tracks(c, late_r, world) if late_r else None)

    def _tracks(self, c: int, records: list[TrackRecord], world: bool) -> Tracks:
        n = len(records)
        if n == 0:
            return Tracks.empty(world)
        box = np.array([r.box_xywh_px for r in records], dtype=np.float64)
        xyxy = np.concatenate([box[:, :2], box[:, :2] + box[:, 2:]], axis=1)
        wm = cov = None
        sd = np.array([_NAN4 if r.xyxy_sd is None else r.xyxy_sd for r in records])
        if world:
            wm = np.array([r.world_m if r.world_m is not None else (np.nan,) * 3
                           for r in records], dtype=np.float64)
            cov = np.array([_NAN22 if r.world_cov is None else r.world_cov for r in records])
        return Tracks(
            tracker_id=self._ids_of(c, [r.id for r in records]),
            xyxy=xyxy, confidence=np.array([r.confidence for r in records], dtype=np.float64),
            class_id=np.full(n, c, dtype=np.int64), xyxy_sd=sd,
            frame=np.array([r.frame for r in records], dtype=np.int64), world_m=wm,
            world_cov=cov, xywh=box)

    # -- results ------------------------------------------------------------------------------

    def tracks(self) -> Tracks:
        """Every row output so far (this frame's and confirmed earlier ones), sorted by frame
        and track id (needs ``keep_history``)."""
        if not self.history:
            return Tracks.empty(self._world)
        allt = Tracks.concat(self.history)
        order = np.lexsort((allt.tracker_id, allt.frame))
        return Tracks(**{f.name: (None if getattr(allt, f.name) is None  # type: ignore[arg-type]
                                  else getattr(allt, f.name)[order])
                         for f in fields(Tracks) if f.name != "confirmed_earlier"})

    def to_mot(self) -> np.ndarray:
        """Every row so far as MOTChallenge rows (M, 10), sorted by frame and id: what
        ``pftrack run`` writes to ``tracks.txt`` for the same detections."""
        return self.tracks().to_mot()

    def to_dataframe(self) -> Any:
        """Every row so far as a pandas DataFrame sorted by frame and track id: ``frame,
        tracker_id, class_id, x1, y1, x2, y2, confidence``, the box's standard deviations
        ``x1_sd, y1_sd, x2_sd, y2_sd`` (px), with a camera ``world_x, world_y, world_z`` (m)
        and ``world_var_x, world_cov_xy, world_var_y`` (m^2), and ``published_frame``: the
        frame whose :meth:`update` returned the row (later than ``frame`` for a track's
        frames before its confirmation). Needs pandas and ``keep_history``."""
        if not self.keep_history:
            raise ValueError("to_dataframe(): this Tracker was made with keep_history=False")
        if not self.history:
            return _dataframe(Tracks.empty(self._world), np.zeros(0, np.int64))
        allt = Tracks.concat(self.history)
        pub = np.concatenate(self._published)
        df = _dataframe(allt, pub)
        return df.sort_values(["frame", "tracker_id"], kind="stable").reset_index(drop=True)
