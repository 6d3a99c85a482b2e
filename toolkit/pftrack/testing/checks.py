"""The conformance checks behind :func:`pftrack.testing.check_component`.

Every check exercises the component through its public contract (see
:mod:`pftrack.contracts.components`) on a small seeded synthetic scene, or on the context its
``_conformance_example()`` returns. A run of the component's *workflow* (all the calls a tracker
would make, for its kind) gives a dict of output arrays; the checks compare such runs: twice with
one seed, with two seeds, after ``clone()``, after a pickle round trip, after rebuilding from
``to_config()``. The runs themselves, one workflow per kind, and :class:`ConformanceExample`
are in :mod:`pftrack.testing.exercise`.
"""

from __future__ import annotations

import json
import pickle
import random
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pftrack.contracts.components import Component, _plain, _unvalidated
from pftrack.testing.exercise import (  # noqa: F401 (the kit's components: read by the tests)
    _WORKFLOWS,
    ConformanceExample,
    _describe_exc,
    _execute,
    _KitAssociator,
    _KitNearest,
    _KitWalk,
    _make_factory,
    _Run,
)

# ConformanceExample imports from here as well, but is listed only where it is defined
# (pftrack.testing.exercise) and in pftrack.testing: a third listing would describe it twice
# under other names in the API reference.
__all__ = [
    "CHECKS",
    "CHECK_FUNCTIONS",
    "CheckResult",
    "assert_conforms",
    "check_component",
    "parametrize_with_checks",
    "run_check",
]

PASS, FAIL, SKIP = "pass", "fail", "skip"


@dataclass
class CheckResult:
    """Outcome of one check.

    Attributes
    ----------
    check : str
        Name of the check (one of :data:`CHECKS`).
    status : {"pass", "fail", "skip"}
    message : str
        Why it failed or was skipped; empty when it passed.
    component : str
        ``ClassName`` (``registered-name``) of the component checked.
    """

    check: str
    status: str
    message: str = ""
    component: str = ""

    @property
    def passed(self) -> bool:
        return self.status != FAIL

    def __str__(self) -> str:
        tail = f": {self.message}" if self.message else ""
        return f"[{self.status}] {self.component} {self.check}{tail}"


CHECKS = (
    "construct",
    "init_stores_params",
    "config_round_trip",
    "clone",
    "shapes_dtypes",
    "empty_input",
    "inputs_unchanged",
    "finite_output",
    "deterministic_same_seed",
    "different_seeds_differ",
    "pickle_round_trip",
    "no_global_random_state",
)


# --------------------------------------------------------------------------------------------
# Comparisons
# --------------------------------------------------------------------------------------------


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape or a.dtype != b.dtype:
            return False
        if a.dtype.kind in "fc":
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(np.array_equal(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    try:
        return bool(a == b)
    except Exception:  # noqa: BLE001
        return False


def _diff_keys(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    return sorted(k for k in a.keys() | b.keys() if k not in a or k not in b
                  or not _equal(a[k], b[k]))


def _global_state() -> tuple[Any, Any]:
    return np.random.get_state(legacy=False), random.getstate()


def _same_global_state(a: tuple[Any, Any], b: tuple[Any, Any]) -> tuple[bool, bool]:
    return _equal(a[0], b[0]), a[1] == b[1]


# --------------------------------------------------------------------------------------------
# The checks
# --------------------------------------------------------------------------------------------


def _label(obj: type[Component] | Component) -> str:
    cls = obj if isinstance(obj, type) else type(obj)
    name = getattr(cls, "name", None)
    return f"{cls.__name__} ({name})" if name else cls.__name__


def check_component(obj: type[Component] | Component, *, rng_seed: int = 0,
                    host: Any = None) -> list[CheckResult]:
    """Run every conformance check on a component class or instance.

    Parameters
    ----------
    obj : Component subclass or instance
        A class is instantiated with its defaults, or through its ``_conformance_example()``
        classmethod when it has one (see :mod:`pftrack.testing`). An instance is deep-copied for
        each run, so a fitted instance is checked as it is.
    rng_seed : int
        Seed of the ``numpy.random.Generator`` handed to the component; ``rng_seed + 1`` is the
        "different seed".
    host : pftrack.host.Host, optional
        When given and the class is registered there, the config round trip rebuilds the
        component with ``host.build(kind, config)``, as a pipeline file would.

    Returns
    -------
    list of CheckResult
        One per name in :data:`CHECKS`, in that order.
    """
    return _check_component(obj, rng_seed, host)


class _Session:
    """The shared work of the checks on one component: its example factory and the reference
    runs, each made once on first use, so that the checks can run one at a time (one pytest
    item each) or all together without repeating a run."""

    def __init__(self, obj: type[Component] | Component, rng_seed: int = 0,
                 host: Any = None) -> None:
        self.obj, self.rng_seed, self.host = obj, rng_seed, host
        self.label = _label(obj)
        self.factory: Callable[[], ConformanceExample] | None = None
        self.comp: Component | None = None
        self.construct_error = ""
        try:
            self.factory = _make_factory(obj)
            ex = self.factory()
            self.comp = ex.component
            if self.comp.kind not in _WORKFLOWS:
                raise TypeError(f"kind {self.comp.kind!r} has no conformance workflow; kinds: "
                                f"{sorted(_WORKFLOWS)}")
        except Exception as exc:  # noqa: BLE001 - reported as a failed check, not a crash
            hint = ("" if hasattr(obj, "_conformance_example") else
                    "; if it needs set-up, give the class a _conformance_example() classmethod "
                    "(see pftrack.testing)")
            self.construct_error = f"could not build an example: {_describe_exc(exc)}{hint}"
        self._runs: dict[str, _Run | None] = {}

    @property
    def cls(self) -> type[Component]:
        assert self.comp is not None
        return type(self.comp)

    def execute(self, seed: int, component: Component | None = None) -> _Run:
        assert self.factory is not None
        return _execute(self.factory, seed, component)

    @property
    def ref(self) -> _Run:
        """The reference run (seed ``rng_seed``)."""
        if "ref" not in self._runs:
            self._runs["ref"] = self.execute(self.rng_seed)
        run = self._runs["ref"]
        assert run is not None
        return run

    @property
    def same(self) -> _Run | None:
        """A second run with the same seed (None when the reference run raised)."""
        if "same" not in self._runs:
            self._runs["same"] = self.execute(self.rng_seed) if self.ref.error is None else None
        return self._runs["same"]

    @property
    def ref_error(self) -> str:
        return f"the workflow raised {self.ref.error}" if self.ref.error else ""

    @property
    def same_diff(self) -> list[str]:
        same = self.same
        return (_diff_keys(self.ref.outputs, same.outputs)
                if same is not None and same.error is None else [])

    @property
    def comparable(self) -> bool:
        """Outputs of rebuilt/cloned/unpickled copies are compared only when two plain runs
        agree; otherwise the nondeterminism is reported once, by deterministic_same_seed."""
        same = self.same
        return same is not None and same.error is None and not self.same_diff


_Outcome = tuple[str, str]  # (status, message)


def check_construct(s: _Session) -> _Outcome:
    """The class builds with its defaults (or through ``_conformance_example()``)."""
    return (FAIL, s.construct_error) if s.construct_error else (PASS, "")


def check_init_stores_params(s: _Session) -> _Outcome:
    """``__init__`` only stores each parameter unchanged; ``cls(**get_params())`` rebuilds."""
    cls, comp = s.cls, s.comp
    assert comp is not None
    msgs = []
    try:
        names = cls._param_names()
        params = comp.get_params()
        sentinels = {n: _Sentinel(n) for n in names}
        try:
            # declared parameters are checked against their declarations when stored: the
            # placeholders would fail that check, which is no logic of the component's own
            with _unvalidated():
                probe = cls(**sentinels)
        except Exception as exc:  # noqa: BLE001
            probe = None
            msgs.append(f"__init__ does logic on its parameters (it failed on placeholder "
                        f"values: {type(exc).__name__}: {exc}); it must only store them")
        if probe is not None:
            for n in names:
                if getattr(probe, n, None) is not sentinels[n]:
                    msgs.append(f"parameter {n!r} is not stored unchanged as attribute {n!r}")
            extra = [k for k in vars(probe) if k not in sentinels and not
                     (k.startswith("_") and not k.endswith("_"))]
            if extra:
                msgs.append(f"__init__ sets attributes that are not parameters: {sorted(extra)} "
                            "(per-frame or learned state belongs in attributes ending with '_' "
                            "set outside __init__)")
        rebuilt = cls(**params)
        if not _equal(_plain(rebuilt.get_params()), _plain(params)):
            msgs.append("cls(**get_params()) has different parameters")
    except Exception as exc:  # noqa: BLE001
        msgs.append(_describe_exc(exc))
    return (FAIL if msgs else PASS), "; ".join(msgs)


def check_config_round_trip(s: _Session) -> _Outcome:
    """``to_config()`` is JSON, names the registered type and rebuilds the same component."""
    cls, comp, host = s.cls, s.comp, s.host
    assert comp is not None
    msgs = []
    try:
        cfg = comp.to_config()
        text = json.dumps(cfg)
        cfg2 = json.loads(text)
        if set(cfg2) != {"type", "params"}:
            msgs.append(f"to_config() keys {sorted(cfg2)}, expected ['params', 'type']")
        if cls.name is not None and cfg2.get("type") != cls.name:
            msgs.append(f"to_config()['type'] is {cfg2.get('type')!r}, registered as "
                        f"{cls.name!r}")
        if host is not None and cls.name is not None and cls.name in host.names(comp.kind) \
                and host.get(comp.kind, cls.name) is cls:
            rebuilt = host.build(comp.kind, cfg2)
        else:
            rebuilt = cls(**cfg2["params"])
        if not _equal(_plain(rebuilt.get_params()), _plain(comp.get_params())):
            msgs.append("the rebuilt component has different parameters")
        elif s.comparable:
            again = s.execute(s.rng_seed, component=rebuilt)
            if again.error:
                msgs.append(f"the component rebuilt from JSON config failed: {again.error}")
            elif _diff_keys(s.ref.outputs, again.outputs):
                msgs.append(f"the component rebuilt from its JSON config gives different outputs: "
                            f"{_diff_keys(s.ref.outputs, again.outputs)}")
    except Exception as exc:  # noqa: BLE001
        msgs.append(f"to_config -> JSON -> rebuild failed: {_describe_exc(exc)}")
    return (FAIL if msgs else PASS), "; ".join(msgs)


def check_clone(s: _Session) -> _Outcome:
    """``clone()`` is a new, stateless instance with the same parameters and outputs."""
    assert s.factory is not None
    cls = s.cls
    msgs = []
    try:
        fresh = s.factory().component
        c = fresh.clone()
        if c is fresh or type(c) is not cls:
            msgs.append("clone() must return a new instance of the same class")
        if not _equal(_plain(c.get_params()), _plain(fresh.get_params())):
            msgs.append("clone() has different parameters")
        state = [k for k in vars(c) if k.endswith("_") and not k.startswith("__")]
        if state:
            msgs.append(f"clone() carries state attributes {state}")
        if s.comparable and not isinstance(s.obj, Component):
            again = s.execute(s.rng_seed, component=c)
            if again.error:
                msgs.append(f"the clone failed: {again.error}")
            elif _diff_keys(s.ref.outputs, again.outputs):
                msgs.append(f"the clone gives different outputs: "
                            f"{_diff_keys(s.ref.outputs, again.outputs)}")
    except Exception as exc:  # noqa: BLE001
        msgs.append(_describe_exc(exc))
    return (FAIL if msgs else PASS), "; ".join(msgs)


def _contract(check: str) -> Callable[[_Session], _Outcome]:
    def run(s: _Session) -> _Outcome:
        probs = [p.message for p in s.ref.problems if p.category == check]
        if s.ref.error and not probs:
            return FAIL, s.ref_error
        return (FAIL if probs else PASS), "; ".join(probs)

    run.__name__ = f"check_{check}"
    run.__doc__ = f"The reference run's {check.replace('_', ' ')} contract (per kind)."
    return run


check_shapes_dtypes = _contract("shapes_dtypes")
check_empty_input = _contract("empty_input")
check_inputs_unchanged = _contract("inputs_unchanged")
check_finite_output = _contract("finite_output")


def check_deterministic_same_seed(s: _Session) -> _Outcome:
    """The same Generator seed gives bit-identical outputs."""
    if s.ref.error:
        return SKIP, s.ref_error
    same = s.same
    assert same is not None
    if same.error:
        return FAIL, f"second run raised {same.error}"
    diff = s.same_diff
    return ((FAIL, f"two runs with seed {s.rng_seed} differ in {diff} (hidden randomness: use "
                   "only the Generator passed in)") if diff else (PASS, ""))


def check_different_seeds_differ(s: _Session) -> _Outcome:
    """Outputs drawn from the Generator change with its seed (skipped when none are)."""
    if s.ref.error:
        return SKIP, s.ref_error
    if not s.ref.rng_used:
        return SKIP, "deterministic: draws nothing from the rng"
    other = s.execute(s.rng_seed + 1)
    if other.error:
        return FAIL, f"run with seed {s.rng_seed + 1} raised {other.error}"
    # every output computed with draws from the Generator must change with its seed
    unchanged = sorted(k for k in s.ref.rng_keys if k in other.outputs
                       and _equal(s.ref.outputs[k], other.outputs[k]))
    return ((FAIL, f"{unchanged} draw from the Generator but do not depend on its seed")
            if unchanged else (PASS, ""))


def check_pickle_round_trip(s: _Session) -> _Outcome:
    """An unpickled component gives the same outputs; a used one still pickles."""
    assert s.factory is not None
    cls, factory = s.cls, s.factory
    msgs = []
    try:
        fresh = factory().component
        copy_ = pickle.loads(pickle.dumps(fresh))
        if type(copy_) is not cls or not _equal(_plain(copy_.get_params()),
                                                _plain(fresh.get_params())):
            msgs.append("the unpickled component differs in class or parameters")
        elif s.comparable:
            again = s.execute(s.rng_seed, component=copy_)
            if again.error:
                msgs.append(f"the unpickled component failed: {again.error}")
            elif _diff_keys(s.ref.outputs, again.outputs):
                msgs.append(f"the unpickled component gives different outputs: "
                            f"{_diff_keys(s.ref.outputs, again.outputs)}")
        used = factory().component
        ex_used = _with(factory(), used)
        if ex_used.context is not None:
            used.setup(ex_used.context)
        _WORKFLOWS[cls.kind](ex_used, np.random.default_rng(s.rng_seed), _Run())
        pickle.loads(pickle.dumps(used))  # mid-stream state must pickle too (worker processes)
    except Exception as exc:  # noqa: BLE001
        msgs.append(f"pickle round trip failed: {_describe_exc(exc)}")
    return (FAIL if msgs else PASS), "; ".join(msgs)


def check_no_global_random_state(s: _Session) -> _Outcome:
    """A whole run leaves the global ``numpy.random`` and ``random`` states alone."""
    np.random.seed(987654321)
    random.seed(987654321)
    before = _global_state()
    run = s.execute(s.rng_seed)
    np_same, py_same = _same_global_state(before, _global_state())
    bad = [n for n, ok in (("numpy.random (global)", np_same), ("random", py_same)) if not ok]
    if bad:
        return FAIL, (f"the component changed the global state of {' and '.join(bad)}: draw "
                      "from the Generator passed in instead")
    if run.error:
        return SKIP, f"the workflow raised {run.error}"
    return PASS, ""


#: Every check by name, in the order they run (:data:`CHECKS` is its keys).
CHECK_FUNCTIONS: dict[str, Callable[[_Session], _Outcome]] = {
    "construct": check_construct,
    "init_stores_params": check_init_stores_params,
    "config_round_trip": check_config_round_trip,
    "clone": check_clone,
    "shapes_dtypes": check_shapes_dtypes,
    "empty_input": check_empty_input,
    "inputs_unchanged": check_inputs_unchanged,
    "finite_output": check_finite_output,
    "deterministic_same_seed": check_deterministic_same_seed,
    "different_seeds_differ": check_different_seeds_differ,
    "pickle_round_trip": check_pickle_round_trip,
    "no_global_random_state": check_no_global_random_state,
}
assert tuple(CHECK_FUNCTIONS) == CHECKS


def _run_check(s: _Session, check: str) -> CheckResult:
    """One check on a session, the caller's global random states kept."""
    if check not in CHECK_FUNCTIONS:
        raise ValueError(f"unknown conformance check {check!r}; checks: {list(CHECKS)}")
    if s.construct_error and check != "construct":
        return CheckResult(check, SKIP, "no example could be built", s.label)
    saved = _global_state()
    try:
        status, message = CHECK_FUNCTIONS[check](s)
    finally:  # a component that draws from the global generators must not disturb the caller
        np.random.set_state(saved[0])
        random.setstate(saved[1])
    return CheckResult(check, status, message, s.label)


def run_check(obj: type[Component] | Component, check: str, *, rng_seed: int = 0,
              host: Any = None) -> CheckResult:
    """Run the one conformance check named ``check`` (one of :data:`CHECKS`) on a component."""
    return _run_check(_Session(obj, rng_seed, host), check)


def parametrize_with_checks(components: Sequence[type[Component] | Component], *,
                            host: Any = None, rng_seed: int = 0,
                            ids: Sequence[str] | None = None, skip: Sequence[str] = (),
                            must_run: Sequence[str] = ()) -> Any:
    """A ``pytest.mark.parametrize`` giving one test item per (component, check), as
    scikit-learn's ``parametrize_with_checks`` does::

        from pftrack.testing import parametrize_with_checks

        @parametrize_with_checks([MyLikelihood, MyMotion(noise=2.0)])
        def test_conforms(component, check):
            check(component)

    Each item is named ``LABEL-CHECK`` (``-k clone`` selects one check everywhere); ``check``
    raises ``AssertionError`` naming the component and the check when it fails and skips the
    item when the check does not apply. The runs the checks share (the reference run and its
    repeat) are made once per component and process.

    Parameters
    ----------
    components : sequence of Component classes or instances
    host : pftrack.host.Host, optional
        As for :func:`check_component`.
    rng_seed : int
    ids : sequence of str, optional
        Labels of the components in the item names (default ``ClassName (registered-name)``).
    skip : sequence of str
        Checks left out (say why in your test).
    must_run : sequence of str
        Checks that must pass, not skip: a skip of one of these fails its item.
    """
    import pytest

    unknown = (set(skip) | set(must_run)) - set(CHECKS)
    if unknown:
        raise ValueError(f"parametrize_with_checks: unknown checks {sorted(unknown)}; "
                         f"checks: {list(CHECKS)}")
    comps = list(components)
    labels = list(ids) if ids is not None else [_label(c) for c in comps]
    if len(labels) != len(comps):
        raise ValueError(f"parametrize_with_checks: {len(labels)} ids for {len(comps)} "
                         "components")
    sessions: dict[int, _Session] = {}

    def make(name: str) -> Callable[[type[Component] | Component], None]:
        def check(component: type[Component] | Component) -> None:
            session = sessions.get(id(component))
            if session is None:
                session = sessions[id(component)] = _Session(component, rng_seed, host)
            r = _run_check(session, name)
            if r.status == FAIL or (r.status == SKIP and name in must_run):
                raise AssertionError(f"{r.component} does not conform to the pftrack component "
                                     f"contract: {r}")
            if r.status == SKIP:
                pytest.skip(str(r))

        check.__name__ = f"check_{name}"
        return check

    checks = {name: make(name) for name in CHECKS if name not in skip}
    params = [pytest.param(c, fn, id=f"{label}-{name}")
              for c, label in zip(comps, labels) for name, fn in checks.items()]
    return pytest.mark.parametrize(("component", "check"), params)


def _check_component(obj: type[Component] | Component, rng_seed: int,
                     host: Any) -> list[CheckResult]:
    s = _Session(obj, rng_seed, host)
    return [_run_check(s, c) for c in CHECKS]


def _with(ex: ConformanceExample, component: Component) -> ConformanceExample:
    ex.component = component
    return ex


class _Sentinel:
    """A placeholder parameter value: __init__ must store it without looking at it."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __repr__(self) -> str:
        return f"<param {self.name}>"


def assert_conforms(obj: type[Component] | Component, *, rng_seed: int = 0,
                    host: Any = None, skip: Sequence[str] = ()) -> list[CheckResult]:
    """Like :func:`check_component`, raising ``AssertionError`` listing every failed check.

    ``skip`` names checks to leave out (say why in your test).
    """
    unknown = set(skip) - set(CHECKS)
    if unknown:
        raise ValueError(f"assert_conforms: unknown checks in skip: {sorted(unknown)}; "
                         f"checks: {list(CHECKS)}")
    results = check_component(obj, rng_seed=rng_seed, host=host)
    failed = [r for r in results if r.status == FAIL and r.check not in skip]
    if failed:
        lines = "\n  ".join(str(r) for r in failed)
        raise AssertionError(f"{_label(obj)} does not conform to the pftrack component "
                             f"contract:\n  {lines}")
    return results
