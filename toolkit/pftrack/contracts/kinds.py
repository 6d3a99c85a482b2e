"""The component kinds a plugin registers, each with the base class its components subclass:
:data:`KINDS` maps a kind's name (the ``kind`` of ``pftrack plugins`` and of a configuration's
component sections) to that class. The plugin host checks every registered component against it.
"""

from __future__ import annotations

from pftrack.contracts.components import (
    Associator,
    Component,
    Detector,
    Likelihood,
    MotionModel,
    ObservationModel,
    Scene,
    TrackManager,
)
from pftrack.contracts.stages import LifecycleStage

__all__ = ["KINDS"]

KINDS: dict[str, type[Component]] = {
    "detector": Detector,
    "likelihood": Likelihood,
    "motion": MotionModel,
    "associator": Associator,
    "scene": Scene,
    "observation": ObservationModel,
    "tracks": TrackManager,
    "stage": LifecycleStage,
}
