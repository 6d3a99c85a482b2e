"""The track lifecycle at the path plugins import it from: the stage contracts of
:mod:`pftrack.contracts.stages` (views, decisions, one base class per role) and the runner of
:mod:`pftrack.engine.lifecycle` (:class:`~pftrack.engine.lifecycle.LifecycleTracks`,
:class:`~pftrack.engine.lifecycle.StagedTracks`, :class:`~pftrack.engine.lifecycle.ManualTracks`,
whose docstring gives the order the roles run in), where they are defined and documented."""

from pftrack.contracts.stages import *  # noqa: F403
from pftrack.engine.lifecycle import *  # noqa: F403
