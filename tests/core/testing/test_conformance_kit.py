"""The conformance kit itself: it passes good components and catches each kind of broken one,
naming the check that failed."""

from __future__ import annotations

import importlib
import random
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT
from conftest import SampleWalk as _Walk
from pftrack.contracts.components import (
    Assignment,
    Associator,
    Likelihood,
    ObservationModel,
    TrackManager,
)
from pftrack.testing import (
    CHECKS,
    ConformanceExample,
    assert_conforms,
    check_component,
    synthetic_scene,
)
from pftrack_basic.motion import RandomWalkMotion


def _status(obj, **kw):
    return {r.check: r for r in check_component(obj, **kw)}


def _failed(obj, **kw):
    return {name for name, r in _status(obj, **kw).items() if r.status == "fail"}


# -- broken components: each breaks one rule -----------------------------------------------------


class GlobalRandomMotion(_Walk):
    def predict(self, states, dt, rng, target=None):
        return states + np.random.normal(0.0, self.sigma, states.shape)


class InPlaceMotion(_Walk):
    def predict(self, states, dt, rng, target=None):
        states += rng.normal(0.0, self.sigma, states.shape)
        return states


class UnseededMotion(_Walk):
    def predict(self, states, dt, rng, target=None):
        return states + np.random.default_rng().normal(0.0, self.sigma, states.shape)


class SeedIgnoringMotion(_Walk):
    def predict(self, states, dt, rng, target=None):
        rng.random()  # touches the Generator, but the noise does not come from it
        return states + np.random.default_rng(0).normal(0.0, self.sigma, states.shape)


class PythonRandomMotion(_Walk):
    def predict(self, states, dt, rng, target=None):
        return states + random.gauss(0.0, self.sigma)


class OffCentreMotion(_Walk):
    def init_states(self, position, n, rng, spread=1.0):
        return rng.normal(0.0, 1.0, (n, 2)) * spread  # forgets the position


class ZeroFailsMotion(_Walk):
    def predict(self, states, dt, rng, target=None):
        if len(states) == 0:
            raise ValueError("no particles")
        return super().predict(states, dt, rng, target)


class _Centre(Likelihood):
    def __init__(self, sigma_px: float = 5.0) -> None:
        self.sigma_px = sigma_px

    def log_likelihood(self, boxes_xywh_px, target):
        c = boxes_xywh_px[:, :2] + boxes_xywh_px[:, 2:] / 2
        d = c - target.observation_px
        return -np.sum(d * d, axis=1) / (2 * self.sigma_px**2)


class LogicInInitLikelihood(_Centre):
    def __init__(self, sigma_px: float = 5.0) -> None:
        self.sigma_px = float(sigma_px)


class StateInInitLikelihood(_Centre):
    def __init__(self, sigma_px: float = 5.0) -> None:
        self.sigma_px = sigma_px
        self.templates_ = {}


class NotStoredLikelihood(_Centre):
    def __init__(self, sigma_px: float = 5.0) -> None:
        self.sigma = sigma_px


class MeanColourLikelihood(Likelihood):
    """Mean brightness inside the clipped box: NaN for a box wholly outside the image."""

    def __init__(self, target_level: float = 100.0) -> None:
        self.target_level = target_level

    def begin_frame(self, frame, targets, detections=None):
        self.grey_ = frame.image.mean(axis=2)

    def log_likelihood(self, boxes_xywh_px, target):
        h, w = self.grey_.shape
        out = []
        for x, y, bw, bh in boxes_xywh_px:  # a loop is fine for a broken test double
            x0, y0 = int(np.clip(x, 0, w)), int(np.clip(y, 0, h))
            x1, y1 = int(np.clip(x + bw, 0, w)), int(np.clip(y + bh, 0, h))
            m = np.mean(self.grey_[y0:y1, x0:x1]) if (x1 > x0 and y1 > y0) else np.nan
            out.append(-abs(m - self.target_level))
        return np.asarray(out)


class Float32Likelihood(_Centre):
    def log_likelihood(self, boxes_xywh_px, target):
        return super().log_likelihood(boxes_xywh_px, target).astype(np.float32)


class ColumnLikelihood(_Centre):
    def log_likelihood(self, boxes_xywh_px, target):
        return super().log_likelihood(boxes_xywh_px, target)[:, None]


class UnpicklableLikelihood(_Centre):
    def begin_frame(self, frame, targets, detections=None):
        self.score_ = lambda d2: -d2  # a closure: cannot be pickled


class EverythingToFirstAssociator(Associator):
    def __init__(self, gate: float = 1.0) -> None:
        self.gate = gate

    def associate(self, targets, detections):
        m = [(t, 0) for t in range(len(targets))] if len(detections) else []
        return Assignment(np.asarray(m, dtype=np.intp).reshape(-1, 2), np.zeros(0, np.intp),
                          np.arange(1, len(detections)))


class NeedsSetupLikelihood(Likelihood):
    """Needs a field the synthetic targets lack (appearance scores); supplies it through the
    hook."""

    def __init__(self, offset: float = 0.0) -> None:
        self.offset = offset

    def log_likelihood(self, boxes_xywh_px, target):
        c = boxes_xywh_px[:, 0] - target.appearance_scores[0] - self.offset
        return -0.5 * c * c

    @classmethod
    def _conformance_example(cls):
        sc = synthetic_scene(seed=3)
        targets = sc.targets()
        for t in targets:
            t.appearance_scores = np.array([42.0])
        return cls(), {"targets": targets}


class RequiredParamMotion(_Walk):
    def __init__(self, sigma: float) -> None:
        self.sigma = sigma


# -- tests -----------------------------------------------------------------------------------


def test_a_good_component_passes_every_check_in_order():
    results = check_component(_Walk)
    assert [r.check for r in results] == list(CHECKS)
    assert all(r.status == "pass" for r in results), [str(r) for r in results if not r.passed]


@pytest.mark.parametrize("cls, expected", [
    (GlobalRandomMotion, {"no_global_random_state", "deterministic_same_seed"}),
    (InPlaceMotion, {"inputs_unchanged"}),
    (UnseededMotion, {"deterministic_same_seed"}),
    (SeedIgnoringMotion, {"different_seeds_differ"}),
    (PythonRandomMotion, {"no_global_random_state", "deterministic_same_seed"}),
    (OffCentreMotion, {"shapes_dtypes"}),
    (ZeroFailsMotion, {"empty_input"}),
    (LogicInInitLikelihood, {"init_stores_params"}),
    (StateInInitLikelihood, {"init_stores_params", "clone"}),
    (NotStoredLikelihood, {"init_stores_params"}),
    (MeanColourLikelihood, {"finite_output"}),
    (Float32Likelihood, {"shapes_dtypes", "empty_input"}),
    (ColumnLikelihood, {"shapes_dtypes", "empty_input"}),
    (UnpicklableLikelihood, {"pickle_round_trip"}),
    (EverythingToFirstAssociator, {"shapes_dtypes", "empty_input"}),
])
def test_each_broken_component_fails_exactly_its_checks(cls, expected):
    failed = _failed(cls)
    assert expected <= failed, failed
    # nothing unrelated is blamed (the NotStored case also breaks get_params-based checks)
    if cls is not NotStoredLikelihood:
        assert failed <= expected | {"deterministic_same_seed"}, failed


def test_failure_messages_name_the_problem():
    r = _status(MeanColourLikelihood)["finite_output"]
    assert "NaN" in r.message and "outside the image" in r.message
    r = _status(EverythingToFirstAssociator)["shapes_dtypes"]
    assert "used more than once" in r.message
    r = _status(LogicInInitLikelihood)["init_stores_params"]
    assert "only store" in r.message
    r = _status(StateInInitLikelihood)["init_stores_params"]
    assert "templates_" in r.message


def test_assert_conforms_raises_naming_class_and_check():
    with pytest.raises(AssertionError, match=r"InPlaceMotion.*inputs_unchanged"):
        assert_conforms(InPlaceMotion)
    # a listed skip is not reported
    assert_conforms(InPlaceMotion, skip=["inputs_unchanged"])
    with pytest.raises(ValueError, match="unknown checks"):
        assert_conforms(_Walk, skip=["no_such_check"])


def test_kit_restores_the_global_random_state():
    np.random.seed(5)
    random.seed(5)
    np_before, py_before = np.random.get_state(), random.getstate()
    check_component(GlobalRandomMotion)
    check_component(PythonRandomMotion)
    np_after = np.random.get_state()
    assert np.array_equal(np_after[1], np_before[1]) and np_after[2] == np_before[2]
    assert random.getstate() == py_before


def test_setup_hook_supplies_context_and_required_params_get_a_hint():
    assert all(r.passed for r in check_component(NeedsSetupLikelihood))
    res = _status(RequiredParamMotion)
    assert res["construct"].status == "fail"
    assert "_conformance_example" in res["construct"].message
    assert {r.status for k, r in res.items() if k != "construct"} == {"skip"}


def test_instances_are_checked_with_their_own_parameters():
    results = _status(RandomWalkMotion(sigma_px=(0.5, 2.0)))
    assert all(r.passed for r in results.values())
    # a ConformanceExample wrapping works the same
    ex = ConformanceExample(RandomWalkMotion(sigma_px=2.0), states=np.zeros((7, 2)), dt=0.25)
    assert ex.component.sigma_px == 2.0


def test_sample_third_party_plugin_components_conform(monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "tests" / "sample_plugin"))
    mod = importlib.import_module("pftrack_sample")
    assert_conforms(mod.DriftMotion)
    assert_conforms(mod.BoxAreaLikelihood(area_px=900.0))


class _RowsDifferObservation(ObservationModel):
    """Its all-targets form does not equal its one-target form: the engine would see other
    boxes than the likelihood of one target."""

    def to_boxes(self, states, target=None):
        s = np.asarray(states, dtype=np.float64)
        return np.column_stack([s[:, :2] - 10.0, np.full((len(s), 2), 20.0)])

    def to_boxes_rows(self, states, targets):
        return np.array([self.to_boxes(s) + 1.0 for s in states])

    def position_from_box(self, box_xywh_px):
        return np.asarray(box_xywh_px, dtype=np.float64)[:2] + 10.0


class _ListlessTracks(TrackManager):
    """Returns a tuple of records instead of a list."""

    def after_frame(self, engine, frame, detections, records, unmatched_detections):
        return tuple(records)


class _GoodBirthTracks(TrackManager):
    def __init__(self, min_score: float = 0.5) -> None:
        self.min_score = min_score

    def after_frame(self, engine, frame, detections, records, unmatched_detections):
        for k in unmatched_detections:
            if detections.scores[k] >= self.min_score:
                records.append(engine.record(frame, engine.add_target(
                    frame, box_xywh_px=detections.boxes_xywh_px[k])))
        return records


def test_observation_and_track_manager_workflows_catch_broken_contracts():
    assert all(r.passed for r in check_component(_GoodBirthTracks))
    r = _status(_RowsDifferObservation)
    assert not r["shapes_dtypes"].passed
    assert "to_boxes_rows differs" in r["shapes_dtypes"].message
    r = _status(_ListlessTracks)
    assert not r["shapes_dtypes"].passed and "list of TrackRecord" in r["shapes_dtypes"].message


def test_each_check_is_a_named_function_and_runs_alone():
    from pftrack.testing import CHECK_FUNCTIONS, run_check

    assert tuple(CHECK_FUNCTIONS) == CHECKS
    assert all(f.__name__ == f"check_{name}" for name, f in CHECK_FUNCTIONS.items())
    r = run_check(InPlaceMotion, "inputs_unchanged")
    assert r.check == "inputs_unchanged" and r.status == "fail" and "InPlaceMotion" in str(r)
    assert run_check(_Walk, "inputs_unchanged").status == "pass"
    # one check alone gives what the whole kit gives for it
    assert run_check(InPlaceMotion, "clone") == _status(InPlaceMotion)["clone"]
    with pytest.raises(ValueError, match="unknown conformance check 'nope'"):
        run_check(_Walk, "nope")


@pytest.mark.parametrize("bad", [{"skip": ["nope"]}, {"must_run": ["nope"]}])
def test_parametrize_with_checks_rejects_unknown_checks(bad):
    from pftrack.testing import parametrize_with_checks

    with pytest.raises(ValueError, match="unknown checks"):
        parametrize_with_checks([_Walk], **bad)


def test_parametrize_with_checks_gives_one_item_per_component_and_check(pytester):
    pytester.makepyfile(test_kit="""
        from pftrack.testing import parametrize_with_checks
        from test_conformance_kit import InPlaceMotion, _Walk

        @parametrize_with_checks([_Walk, InPlaceMotion], ids=["walk", "inplace"],
                                 skip=["pickle_round_trip"])
        def test_conforms(component, check):
            check(component)
    """)
    pytester.syspathinsert(str(Path(__file__).parent))
    res = pytester.runpytest("-p", "no:cacheprovider", "-q", "-rs")
    n = len(CHECKS) - 1
    # InPlaceMotion fails exactly its inputs_unchanged item, every other item passes
    res.assert_outcomes(passed=2 * n - 1, failed=1)
    res.stdout.fnmatch_lines(["*test_conforms*inplace-inputs_unchanged*"])
    sel = pytester.runpytest("-p", "no:cacheprovider", "-q", "-k", "walk-clone")
    sel.assert_outcomes(passed=1)

