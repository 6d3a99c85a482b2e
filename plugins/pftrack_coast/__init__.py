"""Built-in plugin ``coast``: seed 003, coastal surveillance with a thermal camera (Okamura and
Fujimoto, eigenspace method and particle filter).

Components (registered name -> class):

* detector: ``eigenspace`` :class:`~pftrack_coast.detector.EigenspaceDetector` (block
  eigenspace background model, :mod:`pftrack_coast.eigenspace`: per-block PCA, relative
  variation r_D, dimension-dependent threshold v_D, 4-connected intruder blocks -> boxes);
* likelihood: ``eigenspace`` :class:`~pftrack_coast.likelihood.EigenspaceLikelihood` (eq.
  12-13: the sigmoid of r_D - v_D of the block each particle projects into);
* benchmark: ``background`` (:mod:`pftrack_coast.bench_background`: the model against OpenCV's
  background subtractors on real water, campus and thermal video).

Only this module is imported when the host loads the plugin; the component modules are imported
inside the hooks.
"""

from __future__ import annotations

from pftrack import hookimpl

__version__ = "0.1.0"


@hookimpl
def pftrack_register_detectors(register):
    from pftrack_coast.detector import EigenspaceDetector

    register("eigenspace", EigenspaceDetector)


@hookimpl
def pftrack_register_likelihoods(register):
    from pftrack_coast.likelihood import EigenspaceLikelihood

    register("eigenspace", EigenspaceLikelihood)


@hookimpl
def pftrack_register_benchmarks(register):
    from pftrack.extensions import Benchmark

    from pftrack_coast import bench_background

    register("background", Benchmark.from_module(bench_background))
