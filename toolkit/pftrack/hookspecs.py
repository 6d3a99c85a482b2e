"""Hook specifications: every extension point of pftrack, in one module.

A plugin is any module or object with functions named like the specs below and marked with
:data:`pftrack.hookimpl`; it is found through the entry-point group ``pftrack`` (the built-in
plugins use the same group). Hooks run at set-up, never per frame, particle or pixel.

Each ``pftrack_register_*`` hook receives a ``register`` callable bound to the calling plugin::

    @pftrack.hookimpl
    def pftrack_register_likelihoods(register):
        register("my-colour", MyColourLikelihood)

``register(name, cls, *, override=False)`` raises :class:`pftrack.registry.RegistrationError`
naming the plugin at fault when ``name`` is already taken (unless ``override=True``) or when
``cls`` is not a subclass of the kind's base class.
"""

from __future__ import annotations

from typing import Protocol

import pluggy

PROJECT = "pftrack"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


class Register(Protocol):
    """The callable a registration hook receives."""

    def __call__(self, name: str, obj: object, *, override: bool = False) -> None: ...


@hookspec
def pftrack_register_detectors(register: Register) -> None:
    """Register :class:`pftrack.components.Detector` subclasses. Called once when the host loads."""


@hookspec
def pftrack_register_likelihoods(register: Register) -> None:
    """Register :class:`pftrack.components.Likelihood` subclasses. Called once when the host loads."""


@hookspec
def pftrack_register_motion_models(register: Register) -> None:
    """Register :class:`pftrack.components.MotionModel` subclasses. Called once when the host loads."""


@hookspec
def pftrack_register_associators(register: Register) -> None:
    """Register :class:`pftrack.components.Associator` subclasses. Called once when the host loads."""


@hookspec
def pftrack_register_scenes(register: Register) -> None:
    """Register :class:`pftrack.components.Scene` subclasses (videos, synthetic scenes)."""


@hookspec
def pftrack_register_presets(register: Register) -> None:
    """Register tracking presets: ``register(name, path_to_yaml)``; ``pftrack run NAME`` uses them."""


@hookspec
def pftrack_register_metrics(register: Register) -> None:
    """Register metric functions ``f(gt_rows, track_rows, **options) -> dict[str, float]``
    taking MOTChallenge arrays; ``pftrack eval`` reports every registered metric."""
