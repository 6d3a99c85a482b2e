"""Built-in plugin ``coast``: the coastal paper, coastal surveillance with a thermal camera (Okamura
and Fujimoto, eigenspace method and particle filter).

Components (registered name -> class):

* detector: ``eigenspace`` :class:`~pftrack_coast.detector.EigenspaceDetector` (block
  eigenspace background model, :mod:`pftrack_coast.eigenspace`: per-block PCA, relative
  variation r_D, dimension-dependent threshold v_D, 4-connected intruder blocks -> boxes);
* likelihood: ``eigenspace`` :class:`~pftrack_coast.likelihood.EigenspaceLikelihood` (eq.
  12-13: the sigmoid of r_D - v_D of the block each particle projects into);
* likelihood: ``mog2-fraction`` :class:`~pftrack_coast.likelihood.ForegroundFractionLikelihood`
  (the foreground fraction of OpenCV's MOG2 in the particle's block: the comparison);
* track manager: ``volumes`` :class:`~pftrack_coast.volumes.VolumeTracks` (sec. 3 and 4.2:
  detection groups in cuboid volumes, entry and exit by particle counts, several intruders at
  once, size with the support-plane correction);
* scene: ``coast`` :class:`~pftrack_coast.scene.CoastScene` (the paper's coast, synthetic,
  through its camera, package data ``pftrack_coast/data/coast_camera.yaml``: sea, shore, land,
  boats and a car, training frames);
* volumes: ``pets09-walkway`` (package data ``pftrack_coast/data/pets09_walkway.yaml``: the
  ``walkway`` cuboid of preset ``pets09-volume``).

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
    from pftrack_coast.likelihood import EigenspaceLikelihood, ForegroundFractionLikelihood

    register("eigenspace", EigenspaceLikelihood)
    register("mog2-fraction", ForegroundFractionLikelihood)


@hookimpl
def pftrack_register_track_managers(register):
    from pftrack_coast.volumes import VolumeTracks

    register("volumes", VolumeTracks)


@hookimpl
def pftrack_register_scenes(register):
    from pftrack_coast.scene import CoastScene

    register("coast", CoastScene)


@hookimpl
def pftrack_register_presets(register):
    from importlib import resources

    presets = resources.files("pftrack_coast") / "presets"
    register("pets09-volume", str(presets / "pets09-volume.yaml"))
    register("coast-volumes", str(presets / "coast-volumes.yaml"))


@hookimpl
def pftrack_register_volumes(register):
    from importlib import resources

    register("pets09-walkway",
             str(resources.files("pftrack_coast") / "data" / "pets09_walkway.yaml"))

