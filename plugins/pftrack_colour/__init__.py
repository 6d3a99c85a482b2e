"""Built-in plugin ``colour`` (the colour paper): colour-histogram likelihoods (Bhattacharyya and
cross entropy, with and without a background histogram), the synthetic ``walkers`` scene and a
generic ``video`` scene (a video file with optional MOTChallenge ground truth), the default
demo ``walkers`` (``pftrack demo``), the ``image-box-sized`` observation model (box size
following the matched detections) and the ``people-colour`` preset (the colour likelihood for a
user's own detections, ``pftrack run``). The paper's tables are the benchmarks ``colour`` and
``pets09-colour`` of the repository's benchmark package ``pftrack_bench``.

Registered through the ``pftrack`` entry-point group exactly as a third-party plugin is; nothing
is imported from here until the host loads the plugin.
"""

from __future__ import annotations

from pftrack import hookimpl

__version__ = "0.1.0"


@hookimpl
def pftrack_register_likelihoods(register):
    from pftrack_colour.likelihoods import (
        BhattacharyyaBackgroundLikelihood,
        BhattacharyyaLikelihood,
        CrossEntropyBackgroundLikelihood,
        CrossEntropyLikelihood,
    )

    register("bhattacharyya", BhattacharyyaLikelihood)
    register("bhattacharyya-bg", BhattacharyyaBackgroundLikelihood)
    register("cross-entropy", CrossEntropyLikelihood)
    register("cross-entropy-bg", CrossEntropyBackgroundLikelihood)


@hookimpl
def pftrack_register_scenes(register):
    from pftrack.host import RegistrationError
    from pftrack.scenes.video import VideoScene

    from pftrack_colour.walkers import WalkersScene

    register("walkers", WalkersScene)
    try:
        # a generic video scene; if the ``basic`` plugin (loaded first) already provides one,
        # that one stays
        register("video", VideoScene)
    except RegistrationError:
        pass



@hookimpl
def pftrack_register_demos(register):
    from pftrack.contracts.extensions import Demo

    from pftrack_colour import demo

    register("walkers", Demo(summary="track the colour paper's synthetic walkers and write a "
                             "report",
                             run=demo.run_cli, add_arguments=demo.add_arguments, default=True))


@hookimpl
def pftrack_register_track_managers(register):
    from pftrack_colour.experiment import GivenBoxTracks

    register("given-boxes", GivenBoxTracks)


@hookimpl
def pftrack_register_lifecycle_stages(register):
    from pftrack_colour.experiment import BoxSizeSizer, GivenEndsTerminator, GivenStartsInitiator

    register("given-starts", GivenStartsInitiator)
    register("given-ends", GivenEndsTerminator)
    register("box-size-search", BoxSizeSizer)


@hookimpl
def pftrack_register_observation_models(register):
    from pftrack_colour.observation import SizedImageBoxObservation

    register("image-box-sized", SizedImageBoxObservation)


@hookimpl
def pftrack_register_presets(register):
    from importlib import resources

    presets = resources.files("pftrack_colour") / "presets"
    register("people-colour", str(presets / "people-colour.yaml"))
