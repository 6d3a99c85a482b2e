"""Built-in plugin ``world`` (seed 001): ground-plane tracking with an SVM detector, score-based
association and detection/EMD/NCC likelihoods; the ``soccer`` scene."""

from __future__ import annotations

from pftrack import hookimpl

__version__ = "0.1.0"


@hookimpl
def pftrack_register_likelihoods(register):
    pass
