"""pftrack: plugin-based particle-filter multi-object tracking for video.

Nothing is loaded at import time: plugins are discovered when a :class:`pftrack.host.Host` is
created (``pftrack.host.get_host()`` gives a shared one).
"""

from __future__ import annotations

from pftrack.hookspecs import hookimpl

__version__ = "0.1.0"
__all__ = ["hookimpl", "__version__"]
