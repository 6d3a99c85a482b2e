"""Built-in plugin ``colour`` (seed 000): colour-histogram likelihoods (Bhattacharyya and cross
entropy, with and without a background histogram) and the synthetic ``walkers`` scene."""

from __future__ import annotations

from pftrack import hookimpl

__version__ = "0.1.0"


@hookimpl
def pftrack_register_likelihoods(register):
    pass
