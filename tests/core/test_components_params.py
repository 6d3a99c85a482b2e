"""Declared parameters (pftrack.contracts.components.Param): the generated __init__, signature,
docstring, inheritance and redeclaration, and the scikit-learn conventions the conformance kit
checks."""

from __future__ import annotations

import inspect

import numpy as np
import pytest
from pftrack.contracts.components import Group, Likelihood, Param, ParamGroup
from pftrack.testing import check_component


class _Base(Likelihood):
    """A base.

    {params}
    """

    scale: float = Param(2.0, "Scale, pixels.")
    floor: float = Param(0.0, "Added to every log-likelihood.")

    def log_likelihood(self, boxes_xywh_px, target):
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        return -b[:, 0] / float(self.scale) + float(self.floor)


class _Child(_Base):
    """A child with one more parameter and a new default for ``scale``.

    {params}
    """

    scale: float = Param(5.0, "Scale, pixels (the child's default).")
    name_tag: str = Param("x", "A tag.")


class _Required(Likelihood):
    must: float = Param(doc="No default.")

    def log_likelihood(self, boxes_xywh_px, target):
        return np.zeros(len(boxes_xywh_px))


def test_generated_init_signature_and_storage():
    sig = inspect.signature(_Child.__init__)
    assert list(sig.parameters) == ["self", "scale", "floor", "name_tag"]  # the base's first
    assert sig.parameters["scale"].default == 5.0
    c = _Child(floor=1.5)
    assert c.get_params() == {"scale": 5.0, "floor": 1.5, "name_tag": "x"}
    assert _Base().get_params() == {"scale": 2.0, "floor": 0.0}
    with pytest.raises(TypeError, match=r"unexpected parameters \['bogus'\]"):
        _Child(bogus=1)
    with pytest.raises(TypeError, match="missing parameter 'must'"):
        _Required()
    assert _Required(must=3).must == 3


def test_docstring_gets_a_numpydoc_parameters_section():
    doc = _Child.__doc__
    assert "{params}" not in doc
    assert "    Parameters\n    ----------\n    scale : float\n        Scale, pixels (the child's" \
        in doc
    assert "    name_tag : str\n        A tag." in doc
    assert "Scale, pixels.\n" in _Base.__doc__


def test_declared_components_pass_the_conformance_kit():
    assert all(r.passed for r in check_component(_Child))


# --------------------------------------------------------------------------------------------
# Ranges, choices, lengths: checked at construction, in set_params and in a configuration
# --------------------------------------------------------------------------------------------


class _Ranged(Likelihood):
    """Declarations with ranges.

    {params}
    """

    sigma: float = Param(1.0, "A deviation.", unit="px", low=0.0, low_open=True)
    rate: float = Param(0.5, "A rate.", unit="1", low=0.0, high=1.0, high_open=True)
    count: int = Param(3, "A count.", unit="count", low=1)
    mode: str = Param("a", "A mode.", choices=("a", "b"))
    size: tuple[float, float] | None = Param(None, "A size.", unit="m", low=0.0, length=2)
    noise: float | tuple[float, float] = Param(1.0, "One or two deviations.", low=0.0, length=2)
    floor: float = Param(0.0, "May be -inf.", high=np.inf, high_open=True, finite=False)
    lo: float = Param(0.0, "Below hi.")
    hi: float = Param(1.0, "Above lo.")

    def _check_relations(self) -> None:
        if not self.lo < self.hi:
            raise ValueError(f"_Ranged: lo ({self.lo}) must be below hi ({self.hi})")

    def log_likelihood(self, boxes_xywh_px, target):
        return np.zeros(len(boxes_xywh_px))


@pytest.mark.parametrize("kwargs, words", [
    ({"sigma": 0.0}, "parameter 'sigma' must be a number > 0 (px), got 0.0"),
    ({"sigma": float("nan")}, "'sigma' must be a number > 0"),
    ({"sigma": float("inf")}, "'sigma' must be a number > 0"),
    ({"sigma": "1"}, "'sigma' must be a number > 0 (px), got '1'"),
    ({"rate": 1.0}, "'rate' must be a number in [0, 1), got 1.0"),
    ({"count": 0}, "'count' must be an integer >= 1, got 0"),
    ({"count": 2.0}, "'count' must be an integer >= 1, got 2.0"),
    ({"count": True}, "'count' must be an integer >= 1, got True"),
    ({"mode": "c"}, "'mode' must be one of 'a', 'b', got 'c'"),
    ({"size": (1.0, 2.0, 3.0)}, "'size' must be 2 numbers >= 0 or None (m), got (1.0, 2.0, 3.0)"),
    ({"size": (1.0, -2.0)}, "'size' must be 2 numbers >= 0 or None (m)"),
    ({"noise": (1.0,)}, "'noise' must be a number or 2 numbers >= 0, got (1.0,)"),
    ({"floor": np.inf}, "'floor' must be a number < inf, got inf"),
    ({"lo": 2.0}, "lo (2.0) must be below hi (1.0)"),
])
def test_a_value_outside_its_declaration_is_refused_naming_component_and_parameter(kwargs,
                                                                                   words):
    with pytest.raises(ValueError) as info:
        _Ranged(**kwargs)
    assert str(info.value).startswith("_Ranged") and words in str(info.value)


def test_values_inside_their_declarations_are_stored_unchanged():
    size = np.array([1.0, 2.0])
    r = _Ranged(sigma=np.float32(2.0), rate=0, count=np.int64(4), mode="b", size=size,
                noise=[0.0, 3.0], floor=-np.inf)
    assert r.size is size and r.count == 4 and r.floor == -np.inf
    assert _Ranged(noise=2).noise == 2 and _Ranged(size=None).size is None


def test_every_problem_is_reported_at_once_and_set_params_checks_too():
    with pytest.raises(ValueError, match=r"'sigma' .*; parameter 'count'"):
        _Ranged(sigma=-1, count=0)
    r = _Ranged()
    with pytest.raises(ValueError, match="'rate' must be a number in"):
        r.set_params(rate=2.0)
    with pytest.raises(ValueError, match="lo .* must be below hi"):
        _Ranged().set_params(lo=5.0)
    assert r.set_params(rate=0.25).rate == 0.25


def test_positional_arguments_follow_the_declaration_order():
    r = _Ranged(2.0, 0.1)
    assert (r.sigma, r.rate) == (2.0, 0.1)
    with pytest.raises(TypeError, match="'sigma' twice"):
        _Ranged(2.0, sigma=3.0)


def test_a_plain_class_attribute_removes_an_inherited_parameter():
    class _Fixed(_Ranged):
        mode = "b"

    assert "mode" not in _Fixed.declared_params()
    assert _Fixed().mode == "b" and "mode" not in _Fixed().get_params()


def test_the_docstring_and_the_configuration_read_the_declarations():
    assert "Allowed: > 0. Unit: px." in _Ranged.__doc__
    assert "Allowed: one of 'a', 'b'." in _Ranged.__doc__
    from pftrack.host import Host
    from pftrack.host.config import component_param_issues

    class _Registered(_Ranged):
        pass

    host = Host(load_entry_points=False)
    host.registry.add("likelihood", "ranged", _Registered, plugin="test")
    issues = component_param_issues("likelihood", "ranged",
                                     {"sigma": -1, "mode": "b", "size": [1, 2, 3]}, "x", host)
    assert [str(i) for i in issues] == [
        "x.sigma: likelihood 'ranged' expects a number > 0 (px), got -1",
        "x.size: likelihood 'ranged' expects 2 numbers >= 0 or None (m), got [1, 2, 3]"]


# --------------------------------------------------------------------------------------------
# Parameter groups: parameters that belong together, one nested mapping
# --------------------------------------------------------------------------------------------


class _Fitting(ParamGroup):
    """How it is fitted.

    {params}
    """

    rate: float = Param(0.1, "A learning rate.", unit="1", low=0.0, low_open=True)
    rounds: int = Param(2, "Rounds.", unit="count", low=0)
    lo: float = Param(0.0, "Below hi.")
    hi: float = Param(1.0, "Above lo.")

    def _check_relations(self) -> None:
        if not self.lo < self.hi:
            raise ValueError(f"lo ({self.lo}) must be below hi ({self.hi})")


class _Grouped(Likelihood):
    """A likelihood with a group.

    {params}
    """

    sigma: float = Param(1.0, "A deviation.", unit="px", low=0.0, low_open=True)
    fitting: _Fitting = Group(_Fitting, "How it is fitted.")

    def log_likelihood(self, boxes_xywh_px, target):
        return np.full(len(boxes_xywh_px), -float(self.sigma) * self.fitting.rate)


def test_a_group_is_built_from_a_mapping_with_defaults_for_the_keys_left_out():
    g = _Grouped(fitting={"rate": 0.5})
    assert isinstance(g.fitting, _Fitting)
    assert (g.fitting.rate, g.fitting.rounds) == (0.5, 2)
    given = _Fitting(rounds=5)
    assert _Grouped(fitting=given).fitting is given  # a group object is stored unchanged
    # the default is a fresh copy per component, equal to the declared one
    a, b = _Grouped(), _Grouped()
    assert a.fitting == b.fitting == _Fitting() and a.fitting is not b.fitting
    assert list(inspect.signature(_Grouped.__init__).parameters) == ["self", "sigma", "fitting"]


def test_a_group_value_outside_its_declaration_is_refused_with_its_dotted_name():
    with pytest.raises(ValueError, match=r"^_Grouped: parameter 'fitting\.rate' must be a "
                                         r"number > 0, got 0; parameter 'fitting\.rounds'"):
        _Grouped(fitting={"rate": 0, "rounds": -1})
    with pytest.raises(ValueError, match=r"_Grouped: fitting: lo \(2\) must be below hi"):
        _Grouped(fitting={"lo": 2})
    with pytest.raises(ValueError, match=r"unknown parameter 'fitting\.rat' \(parameters of "
                                         r"fitting: rate, rounds, lo, hi\)"):
        _Grouped(fitting={"rat": 1})
    with pytest.raises(ValueError, match="'fitting' must be a mapping of fitting parameters"):
        _Grouped(fitting=3)
    with pytest.raises(ValueError, match=r"^_Fitting: parameter 'rate' must be"):
        _Fitting(rate=-1.0)


def test_set_params_takes_a_mapping_or_a_dotted_name():
    g = _Grouped(fitting={"rate": 0.5})
    assert g.set_params(**{"fitting.rounds": 7}).fitting.get_params() == \
        {"rate": 0.5, "rounds": 7, "lo": 0.0, "hi": 1.0}
    assert g.set_params(fitting={"hi": 3.0}).fitting == _Fitting(hi=3.0)
    with pytest.raises(ValueError, match="'fitting.rate' must be a number > 0"):
        g.set_params(**{"fitting.rate": 0.0})


def test_a_group_round_trips_through_the_configuration_and_the_conformance_kit():
    import json

    g = _Grouped(sigma=2.0, fitting={"rounds": 4})
    cfg = json.loads(json.dumps(g.to_config()))
    assert cfg["params"] == {"sigma": 2.0, "fitting": {"rate": 0.1, "rounds": 4, "lo": 0.0,
                                                       "hi": 1.0}}
    assert _Grouped(**cfg["params"]).fitting == g.fitting
    assert g.clone().fitting == g.fitting and g.clone().fitting is not g.fitting
    assert all(r.passed for r in check_component(_Grouped))


def test_a_group_is_listed_with_dotted_names_in_the_docstring_and_checked_in_a_config():
    doc = _Grouped.__doc__
    assert "    fitting : _Fitting\n        How it is fitted.\n" in doc
    assert "    fitting.rate : float\n        A learning rate. Allowed: > 0. Unit: 1.\n" in doc
    from pftrack.host import Host
    from pftrack.host.config import component_param_issues

    host = Host(load_entry_points=False)
    host.registry.add("likelihood", "grouped", _Grouped, plugin="test")
    issues = component_param_issues("likelihood", "grouped",
                                    {"fitting": {"rate": -1, "rouds": 2}, "sigma": 1.0}, "x",
                                    host)
    assert [str(i) for i in issues] == [
        "x.fitting.rate: likelihood 'grouped' expects a number > 0 for fitting.rate, got -1",
        "x.fitting.rouds: unknown parameter fitting.rouds of likelihood 'grouped' (parameters "
        "of fitting: rate, rounds, lo, hi); did you mean 'rounds'?"]
    assert [str(i) for i in component_param_issues("likelihood", "grouped", {"fitting": 2},
                                                   "x", host)] == [
        "x.fitting: likelihood 'grouped' expects a mapping of fitting parameters (rate, rounds, "
        "lo, hi), got 2"]


def test_the_param_machinery_is_importable_from_components_and_params():
    from pftrack.contracts import components, params

    for name in ("Param", "Group", "ParamGroup", "_declared", "_plain", "_unvalidated"):
        assert getattr(components, name) is getattr(params, name)


# --------------------------------------------------------------------------------------------
# Every registered component declares its parameters with Param
# --------------------------------------------------------------------------------------------

#: Registered classes that still take their parameters in a hand-written ``__init__`` (their
#: values are then checked only by annotated type, in a configuration), with why. This list
#: only shrinks: a class converted to Param must leave it (the test below says so).
HAND_WRITTEN: dict[str, str] = {}


def _registered_classes():
    from pftrack.contracts.components import Component
    from pftrack.host import get_host

    host = get_host()
    out = {}
    for entry in host.registry.entries():
        obj = entry.obj
        if isinstance(obj, type) and issubclass(obj, Component) and \
                host.plugins[entry.plugin].builtin:
            out[f"{obj.__module__}.{obj.__qualname__}"] = obj
    return out


def test_every_registered_component_declares_its_parameters_with_param():
    from pftrack.contracts.components import _declared

    classes = _registered_classes()
    hand_written, n_params = [], 0
    for key, cls in classes.items():
        params = list(inspect.signature(cls.__init__).parameters)[1:]
        n_params += len(params)
        declared = _declared(cls)
        generated = getattr(cls.__init__, "_pftrack_generated", False)
        if generated and all(p in declared for p in params):
            assert key not in HAND_WRITTEN, f"{key} declares its parameters: unlist it"
            continue
        if cls.__init__ is object.__init__:
            continue  # no __init__ (object's *args, **kwargs): no parameter to declare
        hand_written.append(key)
        assert key in HAND_WRITTEN, (f"{key} takes its parameters in a hand-written __init__: "
                                     "declare them with Param (or list it here with why)")
    assert set(HAND_WRITTEN) <= set(classes), set(HAND_WRITTEN) - set(classes)
    assert sorted(hand_written) == sorted(HAND_WRITTEN)
    # the built-in plugins' registered component classes and their parameters, counted
    assert len(classes) >= 50 and n_params >= 260, (len(classes), n_params)


#: Registered classes allowed more than :data:`MAX_PARAMS` parameters, with why (this list only
#: shrinks).
OVER_MAX: dict[str, str] = {}
MAX_PARAMS = 15


def test_no_registered_component_takes_more_than_15_parameters():
    """Parameters that belong together are one group (``train``, ``partial``,
    ``recalibration``), counted once."""
    counts = {key: len(cls.declared_params()) for key, cls in _registered_classes().items()}
    over = {key: n for key, n in counts.items() if n > MAX_PARAMS and key not in OVER_MAX}
    assert not over, f"more than {MAX_PARAMS} parameters: group what belongs together: {over}"
    assert counts["pftrack_world.detector.SVMDetector"] == 10
    assert counts["pftrack_world.people.HOGPeopleDetector"] == 12
    assert counts["pftrack_coast.detector.EigenspaceDetector"] == 12
    assert counts["pftrack_coast.volumes.VolumeTracks"] == 11
