"""Hook specifications: every extension point of pftrack, in one module.

A plugin is any module or object with functions named like the specs below and marked with
:data:`pftrack.hookimpl`; it is found through the entry-point group ``pftrack`` (the built-in
plugins ``basic``, ``colour`` and ``world`` use the same group and the same hooks). Every hook is
called once, when a :class:`pftrack.host.Host` loads the plugin; none is called per frame,
particle or pixel. Nothing is loaded at import time.

Each ``pftrack_register_*`` hook receives a ``register`` callable bound to the calling plugin and
typed by what it accepts::

    @pftrack.hookimpl
    def pftrack_register_likelihoods(register):
        register("my-colour", MyColourLikelihood)

``register(name, obj, *, override=False)`` raises :class:`pftrack.host.RegistrationError`
naming the plugin at fault, at once, when ``name`` is already taken (unless ``override=True``)
or when ``obj`` is not of the kind's type (a subclass of the kind's base class in
:mod:`pftrack.contracts.components`, or the record type of :mod:`pftrack.contracts.extensions`). A
built-in's name is replaced only with ``override=True``, and the host warns which plugin did it.

Groups
------
* **Components** (classes, built by name from a run's configuration): detectors, likelihoods,
  motion models, associators, scenes, observation models and track managers (the two parts of
  the one tracking engine that vary between papers).
* **Run configurations**: presets.
* **Evaluation**: metrics (``pftrack eval`` reports every registered one).
* **Command line and reports**: benchmarks (``pftrack bench NAME``), commands (``pftrack NAME``),
  demos (``pftrack demo``) and report writers (``pftrack run``'s pictures).
"""

from __future__ import annotations

from collections.abc import Callable
from os import PathLike
from typing import TYPE_CHECKING, Protocol, TypeVar

import pluggy

if TYPE_CHECKING:  # typing only: the specs import nothing heavy
    from pftrack.contracts.components import (
        Associator,
        Detector,
        Likelihood,
        MotionModel,
        ObservationModel,
        Scene,
        TrackManager,
    )
    from pftrack.contracts.extensions import Benchmark, Command, Demo, ReportWriter
    from pftrack.contracts.stages import LifecycleStage

PROJECT = "pftrack"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)

T_contra = TypeVar("T_contra", contravariant=True)


class Register(Protocol[T_contra]):
    """The callable a registration hook receives, typed by what it accepts."""

    def __call__(self, name: str, obj: T_contra, *, override: bool = False) -> None: ...


#: A metric: ``f(gt_rows (M, 10), track_rows (K, 10), **options) -> {name: float}`` on
#: MOTChallenge arrays; ``options`` are ``pftrack eval``'s (``metric``, ``threshold``,
#: ``zero_marked``), a metric ignores the ones it does not take.
MetricFunction = Callable[..., "dict[str, float]"]


# -- components ------------------------------------------------------------------------------


@hookspec
def pftrack_register_detectors(register: Register[type[Detector]]) -> None:
    """Register :class:`pftrack.contracts.components.Detector` subclasses by name."""


@hookspec
def pftrack_register_likelihoods(register: Register[type[Likelihood]]) -> None:
    """Register :class:`pftrack.contracts.components.Likelihood` subclasses by name."""


@hookspec
def pftrack_register_motion_models(register: Register[type[MotionModel]]) -> None:
    """Register :class:`pftrack.contracts.components.MotionModel` subclasses by name."""


@hookspec
def pftrack_register_associators(register: Register[type[Associator]]) -> None:
    """Register :class:`pftrack.contracts.components.Associator` subclasses by name."""


@hookspec
def pftrack_register_scenes(register: Register[type[Scene]]) -> None:
    """Register :class:`pftrack.contracts.components.Scene` subclasses (videos, synthetic
    scenes)."""


@hookspec
def pftrack_register_observation_models(register: Register[type[ObservationModel]]) -> None:
    """Register :class:`pftrack.contracts.components.ObservationModel` subclasses by name (states ->
    image boxes: image-plane boxes, boxes through a camera, points in a volume)."""


@hookspec
def pftrack_register_track_managers(register: Register[type[TrackManager]]) -> None:
    """Register :class:`pftrack.contracts.components.TrackManager` subclasses by name (births,
    confirmation, merging, ends, output). A new track manager is best written as lifecycle
    stages (:func:`pftrack_register_lifecycle_stages`); a :class:`TrackManager` subclass that
    drives the engine itself is the legacy form, still supported."""


@hookspec
def pftrack_register_lifecycle_stages(register: Register[type[LifecycleStage]]) -> None:
    """Register :class:`pftrack.contracts.stages.LifecycleStage` subclasses by name: initiators,
    confirmers, terminators, mergers, reidentifiers, sizers and reporters, which a
    configuration lists under ``tracks: {type: stages, params: {stages: [...]}}``. Each returns
    decisions that the lifecycle runner applies; none receives the engine."""


# -- run configurations ----------------------------------------------------------------------


@hookspec
def pftrack_register_presets(register: Register[str | PathLike[str]]) -> None:
    """Register tracking presets: ``register(name, path_to_yaml)``, the YAML shipped as the
    plugin's package data (``importlib.resources.files(__package__) / "presets" / ...``, never a
    path relative to a repository). ``pftrack run NAME`` and ``pftrack presets`` use them."""


@hookspec
def pftrack_register_volumes(register: Register[str | PathLike[str]]) -> None:
    """Register volume files: ``register(name, path_to_yaml)``, a volumes YAML
    (:func:`pftrack.geometry.volumes.load_volumes`) shipped as the plugin's package data
    (``importlib.resources.files(__package__) / "data" / ...``). The volumes it defines are found
    by name wherever a volume is asked for (:func:`pftrack.geometry.volumes.resolve_volume`,
    ``pftrack render topview --volume NAME``)."""


# -- evaluation ------------------------------------------------------------------------------


@hookspec
def pftrack_register_metrics(register: Register[MetricFunction]) -> None:
    """Register metric functions (:data:`MetricFunction`). ``pftrack eval`` calls every
    registered metric after its own CLEAR/Identity/HOTA figures and reports each result under
    ``"plugin_metrics": {name: {...}}``; one that raises is reported there as
    ``{"error": "..."}`` and the others still run."""


# -- command line ----------------------------------------------------------------------------


@hookspec
def pftrack_register_benchmarks(register: Register[Benchmark]) -> None:
    """Register :class:`pftrack.contracts.extensions.Benchmark` records: ``pftrack bench NAME``."""


@hookspec
def pftrack_register_commands(register: Register[Command]) -> None:
    """Register :class:`pftrack.contracts.extensions.Command` records: ``pftrack NAME``. A name
    that a core command already has is refused with a warning naming the plugin."""


@hookspec
def pftrack_register_demos(register: Register[Demo]) -> None:
    """Register :class:`pftrack.contracts.extensions.Demo` records: ``pftrack demo [NAME]``."""


@hookspec
def pftrack_register_report_writers(register: Register[ReportWriter]) -> None:
    """Register :class:`pftrack.contracts.extensions.ReportWriter` records: the report pictures of
    a run, chosen by its configuration's ``report: {writer: NAME}``."""


__all__ = [
    "MetricFunction",
    "PROJECT",
    "Register",
    "hookimpl",
    "hookspec",
    "pftrack_register_associators",
    "pftrack_register_benchmarks",
    "pftrack_register_commands",
    "pftrack_register_demos",
    "pftrack_register_detectors",
    "pftrack_register_lifecycle_stages",
    "pftrack_register_likelihoods",
    "pftrack_register_metrics",
    "pftrack_register_motion_models",
    "pftrack_register_observation_models",
    "pftrack_register_presets",
    "pftrack_register_volumes",
    "pftrack_register_report_writers",
    "pftrack_register_scenes",
    "pftrack_register_track_managers",
]
