"""The plugin hooks at the path plugins import them from: every public name of
:mod:`pftrack.contracts.hookspecs` (the ``pftrack_register_*`` specifications, ``hookimpl``),
where they are defined and documented."""

from pftrack.contracts.hookspecs import *  # noqa: F403
