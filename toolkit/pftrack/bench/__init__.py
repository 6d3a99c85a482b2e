"""Benchmarks: each module here is a ``pftrack bench`` sub-command (see :mod:`pftrack.cli.bench`)."""
