"""Built-in plugin ``basic``: motion models, a Gaussian likelihood, generic associators and a
background-subtraction detector. Registered through the ``pftrack`` entry-point group exactly as a
third-party plugin is.

Components (registered name -> class):

* motion: ``random-walk`` :class:`~pftrack_basic.motion.RandomWalkMotion`,
  ``constant-velocity-2d`` / ``constant-velocity-3d``
  :class:`~pftrack_basic.motion.ConstantVelocity2DMotion` / ``...3DMotion``,
  ``constant-acceleration`` :class:`~pftrack_basic.motion.ConstantAccelerationMotion`;
* likelihood: ``gaussian`` :class:`~pftrack_basic.gaussian.GaussianLikelihood`;
* associator: ``hungarian-iou`` :class:`~pftrack_basic.association.HungarianIoUAssociator`,
  ``greedy-iou`` :class:`~pftrack_basic.association.GreedyIoUAssociator`;
* detector: ``mog2`` :class:`~pftrack_basic.background.BackgroundSubtractionDetector`;
* observation: ``image-box`` :class:`pftrack.builtin.image_box.ImageBoxObservation` (image-plane box
  centre), ``camera-box`` :class:`pftrack.builtin.world_observation.CameraBoxObservation`
  (ground-plane position through the run's camera), ``camera-volume``
  :class:`pftrack.builtin.world_observation.CameraVolumeObservation` (3-D points in a volume, the
  coastal paper);
* tracks: ``manual`` :class:`pftrack.engine.lifecycle.ManualTracks` (targets added by the caller),
  ``stages`` :class:`pftrack.engine.lifecycle.StagedTracks` (an explicit list of lifecycle stages),
  ``births`` :class:`~pftrack_basic.tracks.DetectionBirthTracks`, ``confirmed``
  :class:`~pftrack_basic.tracks.ConfirmedTracks` (tentative -> confirmed, merging, appearance);
* stage (:mod:`pftrack.engine.lifecycle`): ``unmatched-births`` and ``detection-births``
  (initiators), ``hit-confirmation`` (confirmer), ``border-exit`` (terminator),
  ``duplicate-merge`` (merger), ``colour-reid`` (reidentifier), ``output-boxes`` (reporter),
  all in :mod:`pftrack_basic.tracks`;
* report writer: ``tracks`` (:func:`pftrack.render.report.write_report`: overlays and image
  trajectories beside the ground-plane top view), ``pftrack run``'s default.

Only this module is imported when the host loads the plugin; the component modules are light
(numpy only; scipy and OpenCV are imported inside the methods that need them).
"""

from __future__ import annotations

from pftrack import hookimpl

__version__ = "0.1.0"


@hookimpl
def pftrack_register_motion_models(register):
    from pftrack_basic.motion import (
        ConstantAccelerationMotion,
        ConstantVelocity2DMotion,
        ConstantVelocity3DMotion,
        RandomWalkMotion,
    )

    register("random-walk", RandomWalkMotion)
    register("constant-velocity-2d", ConstantVelocity2DMotion)
    register("constant-velocity-3d", ConstantVelocity3DMotion)
    register("constant-acceleration", ConstantAccelerationMotion)


@hookimpl
def pftrack_register_likelihoods(register):
    from pftrack_basic.gaussian import GaussianLikelihood

    register("gaussian", GaussianLikelihood)


@hookimpl
def pftrack_register_associators(register):
    from pftrack_basic.association import GreedyIoUAssociator, HungarianIoUAssociator

    register("hungarian-iou", HungarianIoUAssociator)
    register("greedy-iou", GreedyIoUAssociator)
    from pftrack_basic.cloud_association import CloudAssociator

    register("cloud", CloudAssociator)


@hookimpl
def pftrack_register_detectors(register):
    from pftrack_basic.background import BackgroundSubtractionDetector

    register("mog2", BackgroundSubtractionDetector)



@hookimpl
def pftrack_register_observation_models(register):
    from pftrack.builtin.image_box import ImageBoxObservation
    from pftrack.builtin.world_observation import CameraBoxObservation, CameraVolumeObservation

    register("image-box", ImageBoxObservation)
    register("camera-box", CameraBoxObservation)
    register("camera-volume", CameraVolumeObservation)


@hookimpl
def pftrack_register_track_managers(register):
    from pftrack.engine.lifecycle import ManualTracks, StagedTracks

    from pftrack_basic.tracks import ConfirmedTracks, DetectionBirthTracks

    register("manual", ManualTracks)
    register("stages", StagedTracks)
    register("births", DetectionBirthTracks)
    register("confirmed", ConfirmedTracks)


@hookimpl
def pftrack_register_lifecycle_stages(register):
    from pftrack_basic import tracks

    register("unmatched-births", tracks.UnmatchedBirthInitiator)
    register("detection-births", tracks.DetectionBirthInitiator)
    register("hit-confirmation", tracks.HitConfirmer)
    register("border-exit", tracks.BorderTerminator)
    register("duplicate-merge", tracks.DuplicateMerger)
    register("colour-reid", tracks.ColourReidentifier)
    register("output-boxes", tracks.OutputBoxReporter)


@hookimpl
def pftrack_register_report_writers(register):
    from pftrack.contracts.extensions import ReportWriter
    from pftrack.render.report import write_report

    register("tracks", ReportWriter(
        summary="overlays (boxes, ids, foot points) and image trajectories beside the top view",
        write=write_report))
