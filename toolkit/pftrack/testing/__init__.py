"""Conformance kit for pftrack components, in the spirit of scikit-learn's ``check_estimator``.

A plugin author runs it on a component and learns at once whether it honours the contract of
:mod:`pftrack.contracts.components`::

    from pftrack.testing import assert_conforms

    def test_my_likelihood_conforms():
        assert_conforms(MyColourLikelihood)          # a class: built with its defaults
        assert_conforms(MyColourLikelihood(bins=4))  # or a configured instance

:func:`check_component` returns one :class:`CheckResult` per check instead of raising;
:func:`run_check` runs one check by name (each is a function, ``check_<name>`` in
:mod:`pftrack.testing.checks`, listed in :data:`CHECK_FUNCTIONS`). For a test suite,
:func:`parametrize_with_checks` gives one pytest item per (component, check), as scikit-learn's
``parametrize_with_checks`` does, so that a failing check is named and selected on its own::

    from pftrack.testing import parametrize_with_checks

    @parametrize_with_checks([MyColourLikelihood, MyMotion(noise=2.0)])
    def test_conforms(component, check):
        check(component)

The checks (:data:`CHECKS`)
---------------------------
``construct``
    The class builds with its defaults (or through ``_conformance_example()``, below).
``init_stores_params``
    ``__init__`` only stores each keyword argument unchanged as an attribute of the same name
    (checked by passing placeholder objects), sets nothing else, and ``cls(**get_params())``
    rebuilds it.
``config_round_trip``
    ``to_config()`` is JSON-serialisable, its ``type`` is the registered name, and the component
    rebuilt from the JSON gives the same outputs.
``clone``
    ``clone()`` is a new, stateless instance with the same parameters and outputs.
``shapes_dtypes``, ``empty_input``, ``inputs_unchanged``, ``finite_output``
    Per kind: a motion model maps (N, D) to a new (N, D) float64 array, leaves its input alone,
    accepts N = 0 and centres ``init_states`` on the position; a likelihood maps (N, 4) boxes to
    (N,) float64 log-weights, never NaN or +inf, also for boxes partly or wholly outside the image
    and for N = 0; a detector returns :class:`~pftrack.contracts.components.Detections` with
    consistent shapes, also on a blank frame; an associator returns a valid
    :class:`~pftrack.contracts.components.Assignment` (each target and detection used at most once,
    unmatched lists the exact complement), also with no targets or no detections; a scene yields
    uint8 BGR frames and (M, 10) float64 ground truth.
``deterministic_same_seed``, ``different_seeds_differ``
    The same ``numpy.random.Generator`` seed gives bit-identical outputs; a component that draws
    from the Generator gives different outputs for a different seed (one that draws nothing is
    deterministic and this check is skipped).
``pickle_round_trip``
    A pickled and unpickled component gives the same outputs; a component that has already
    processed frames still pickles (``__getstate__`` may drop native state such as OpenCV
    objects).
``no_global_random_state``
    The global ``numpy.random`` and ``random`` states are unchanged by a whole run.

The set-up hook for plugin authors
----------------------------------
By default the kit exercises a component on a small seeded synthetic scene
(:func:`pftrack.testing.synthetic.synthetic_scene`: three coloured boxes moving over a noisy
160 x 120 px background; targets carry ``observation_px`` and ``detection``).
A component that needs more (a camera, a trained model, world-coordinate states, a data file)
defines a classmethod returning a fresh configured instance and, optionally, its context::

    class GroundPlaneLikelihood(Likelihood):
        @classmethod
        def _conformance_example(cls):
            from pftrack.testing import ConformanceExample
            cam = make_test_camera()
            return ConformanceExample(cls(camera=cam), targets=[...], states=None)

It may return the instance alone, a :class:`ConformanceExample`, or ``(instance, {field: value})``;
fields left out come from the synthetic scene. It is called once per run, so it must build a new
instance each time (and be cheap: a run calls it about ten times).
"""

from pftrack.testing.checks import (
    CHECK_FUNCTIONS,
    CHECKS,
    CheckResult,
    ConformanceExample,
    assert_conforms,
    check_component,
    parametrize_with_checks,
    run_check,
)
from pftrack.testing.synthetic import SyntheticScene, synthetic_scene, target_from_box

__all__ = [
    "CHECKS",
    "CHECK_FUNCTIONS",
    "CheckResult",
    "ConformanceExample",
    "SyntheticScene",
    "assert_conforms",
    "check_component",
    "parametrize_with_checks",
    "run_check",
    "synthetic_scene",
    "target_from_box",
]
