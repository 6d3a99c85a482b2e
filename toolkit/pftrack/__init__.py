"""pftrack: plugin-based particle-filter multi-object tracking for video.

The names a notebook needs are here::

    import pftrack

    tracker = pftrack.Tracker("people-image", seed=0)       # a preset, a YAML file or a dict
    out = tracker.update(boxes_xyxy, frame=image)          # this frame's tracks and their sd
    pftrack.evaluate(pftrack.read_mot("gt.txt"), tracker.to_mot())

* :class:`Tracker`, :class:`Tracks`: track your own detections frame by frame
  (:mod:`pftrack.workflows.stream`);
* :class:`Detections`, :class:`Frame`: the exchange types (:mod:`pftrack.contracts.components`);
* :func:`read_mot`, :func:`write_mot`: MOTChallenge files; :func:`read_detections`: a
  ``det.txt`` as per-frame :class:`Detections`;
* :func:`evaluate`: MOTA, IDF1, HOTA of tracks against ground truth;
* :func:`iter_frames`: a video's frames as :class:`Frame` (numbered from 1);
* :func:`load_config`, :func:`run_pipeline`: what ``pftrack run`` does;
* :func:`list_plugins`: the installed plugins and their components.

Nothing is loaded at import time: each name is imported when first used, and plugins are
discovered when a :class:`pftrack.host.Host` is created (``pftrack.host.get_host()`` gives a
shared one).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from pftrack.contracts.hookspecs import hookimpl

if TYPE_CHECKING:
    from pftrack.contracts.components import Detections, Frame
    from pftrack.host import list_plugins
    from pftrack.io.detections import read_detections
    from pftrack.io.mot import read_mot, write_mot
    from pftrack.metrics.mot import evaluate
    from pftrack.workflows.pipeline import iter_frames, load_config, run_pipeline
    from pftrack.workflows.stream import Tracker, Tracks

__version__ = "0.1.0"

_LAZY = {
    "Tracker": "pftrack.workflows.stream",
    "Tracks": "pftrack.workflows.stream",
    "Detections": "pftrack.contracts.components",
    "Frame": "pftrack.contracts.components",
    "read_mot": "pftrack.io.mot",
    "write_mot": "pftrack.io.mot",
    "read_detections": "pftrack.io.detections",
    "evaluate": "pftrack.metrics.mot",
    "load_config": "pftrack.workflows.pipeline",
    "run_pipeline": "pftrack.workflows.pipeline",
    "iter_frames": "pftrack.workflows.pipeline",
    "list_plugins": "pftrack.host",
}

__all__ = ["Detections", "Frame", "Tracker", "Tracks", "evaluate", "hookimpl", "iter_frames",
           "list_plugins", "load_config", "read_detections", "read_mot", "run_pipeline",
           "write_mot", "__version__"]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'pftrack' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
