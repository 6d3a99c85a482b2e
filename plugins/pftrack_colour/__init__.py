"""Built-in plugin ``colour`` (seed 000): colour-histogram likelihoods (Bhattacharyya and cross
entropy, with and without a background histogram), the synthetic ``walkers`` scene and a generic
``video`` scene (a video file with optional MOTChallenge ground truth).

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
