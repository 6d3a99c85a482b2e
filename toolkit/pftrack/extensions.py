"""Benchmarks, commands, demos and report writers at the path plugins import them from: every
public name of :mod:`pftrack.contracts.extensions`, where they are defined and documented."""

from pftrack.contracts.extensions import *  # noqa: F403
