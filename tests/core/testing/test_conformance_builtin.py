"""Every registered built-in component, of every kind, passes the conformance kit.

The parameters come from the registry at collection time, so components other plugins add later
are checked without editing this file.
"""

from __future__ import annotations

import pytest
from pftrack.host import get_host
from pftrack.testing import assert_conforms, parametrize_with_checks

_COMPONENT_KINDS = ("detector", "likelihood", "motion", "associator", "scene", "observation",
                    "tracks", "stage")


def _builtin_entries():
    host = get_host()
    builtin = {name for name, p in host.plugins.items() if p.builtin}
    return [e for e in host.registry.entries()
            if e.kind in _COMPONENT_KINDS and e.plugin in builtin]


_ENTRIES = _builtin_entries()


def test_every_kind_has_a_builtin_component():
    kinds = {e.kind for e in _ENTRIES}
    assert {"detector", "likelihood", "motion", "associator", "observation", "tracks",
            "stage"} <= kinds, \
        kinds


# one item per (component, check): `-k "likelihood:ncc and clone"` runs one check of one
# component; the checks that always apply must really run (a skip of one of them fails)
@parametrize_with_checks([e.obj for e in _ENTRIES], host=get_host(),
                         ids=[f"{e.kind}:{e.name}" for e in _ENTRIES],
                         must_run=["construct", "init_stores_params", "config_round_trip", "clone",
                                   "shapes_dtypes", "deterministic_same_seed",
                                   "pickle_round_trip", "no_global_random_state"])
def test_builtin_component_conforms(component, check):
    check(component)


@pytest.mark.parametrize("name", ["random-walk", "constant-velocity-2d", "constant-velocity-3d",
                                  "constant-acceleration"])
def test_builtin_motion_models_are_stochastic_under_the_kit(name):
    results = {r.check: r for r in assert_conforms(get_host().get("motion", name))}
    assert results["different_seeds_differ"].status == "pass"
