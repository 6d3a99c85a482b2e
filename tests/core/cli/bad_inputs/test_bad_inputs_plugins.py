"""Catalogue: hostile and broken plugins. A likelihood that raises or returns NaN, +inf, the
wrong shape or the wrong dtype stops the run with exit 1 and a one-line "plugin error" naming
the component, its plugin and its module, leaving the previous outputs; a plugin that takes a
built-in's name is refused (the built-in wins) unless it overrides on purpose, and the warning
names it; an unknown name in PFTRACK_DISABLE_PLUGINS and a misspelt hook name are warned."""

from __future__ import annotations

import copy
import sys
import types
import warnings
from importlib import metadata

import numpy as np
import pftrack.host as host_mod
import pytest
import yaml
from pftrack import hookimpl
from pftrack.contracts.components import Likelihood
from pftrack.host import Host, PluginLoadWarning, PluginSettingWarning, RegistrationError

from ._catalogue import CONFIG, assert_untouched, one_line, snapshot

BEHAVIOURS = {
    "raises": lambda n: (_ for _ in ()).throw(RuntimeError("kaboom")),
    "nan-all": lambda n: np.full(n, np.nan),
    "nan-one": lambda n: np.r_[np.zeros(n - 1), np.nan],
    "plus-inf": lambda n: np.r_[np.inf, np.zeros(n - 1)],
    "short": lambda n: np.zeros(n - 1),
    "long": lambda n: np.zeros(n + 1),
    "column": lambda n: np.zeros((n, 1)),
    "scalar": lambda n: 0.0,
    "empty": lambda n: np.zeros(0),
    "int-dtype": lambda n: np.zeros(n, dtype=np.int64),
    "bool-dtype": lambda n: np.ones(n, dtype=bool),
    "complex-dtype": lambda n: np.zeros(n, dtype=complex),
    "strings": lambda n: np.array(["0"] * n),
    "objects": lambda n: np.array([None] * n, dtype=object),
    "none": lambda n: None,
}
EXPECT = {
    "raises": "raised RuntimeError: kaboom",
    "nan-all": "NaN or +inf log-likelihood(s)",
    "nan-one": "returned 1 NaN or +inf log-likelihood(s)",
    "plus-inf": "returned 1 NaN or +inf log-likelihood(s)",
    "short": "of shape", "long": "of shape", "column": "of shape", "scalar": "of shape",
    "empty": "of shape",
    "int-dtype": "of dtype int64, expected floating point",
    "bool-dtype": "of dtype bool", "complex-dtype": "of dtype complex128",
    "strings": "of dtype <U1", "objects": "of dtype object", "none": "of dtype object",
}
GOOD = {
    "list-of-floats": lambda n: [0.0] * n,
    "float32": lambda n: np.zeros(n, dtype=np.float32),
    "minus-inf": lambda n: np.full(n, -np.inf),
}


def _likelihood(behaviour):
    class Evil(Likelihood):
        def __init__(self) -> None:
            pass

        def log_likelihood(self, boxes_xywh_px, target):
            return behaviour(len(boxes_xywh_px))

    Evil.__module__ = "evil_plugin.likelihoods"
    return Evil


class _Registers:
    def __init__(self, kind_hook, entries):
        self.entries = entries
        self.hook = kind_hook

    @hookimpl
    def pftrack_register_likelihoods(self, register):
        for name, cls, override in self.entries:
            register(name, cls, override=override)


def _config(work, likelihood: str):
    cfg = yaml.safe_load(CONFIG)
    cfg["likelihood"] = {"type": likelihood, "params": {}}
    p = work.dir / "evil.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


@pytest.mark.parametrize("name", sorted(BEHAVIOURS))
def test_bad_likelihood_output_stops_the_run(work, cli, plugin_host, name):
    plugin_host(("evil", _Registers("l", [(f"evil-{name}", _likelihood(BEHAVIOURS[name]),
                                           False)])))
    cfg = _config(work, f"evil-{name}")
    before = snapshot(work.dir)
    r = cli("run", cfg, "--video", work.video, "--out", work.out, "--quiet")
    assert r.rc == 1
    line = one_line(r.err)
    assert line.startswith("pftrack run: plugin error")
    assert f"likelihood 'evil-{name}' of plugin 'evil' (Evil from evil_plugin.likelihoods)" in line
    assert EXPECT[name] in line
    assert_untouched(before, work.dir)


@pytest.mark.parametrize("name", sorted(GOOD))
def test_acceptable_likelihood_output_runs(work, cli, plugin_host, name):
    plugin_host(("fine", _Registers("l", [(f"fine-{name}", _likelihood(GOOD[name]), False)])))
    cfg = _config(work, f"fine-{name}")
    r = cli("run", cfg, "--video", work.video, "--out", work.out, "--quiet", "--no-report")
    assert r.rc == 0, r.err
    assert (work.out / "tracks.txt").is_file()


def test_debug_shows_the_plugins_traceback(work, cli, plugin_host):
    plugin_host(("evil", _Registers("l", [("evil-raises", _likelihood(BEHAVIOURS["raises"]),
                                           False)])))
    cfg = _config(work, "evil-raises")
    r = cli("run", cfg, "--video", work.video, "--out", work.out, "--quiet", "--debug")
    assert r.rc == 1
    assert "Traceback" in r.err and "kaboom" in r.err


def test_in_process_plugin_cannot_take_a_builtin_name():
    with pytest.raises(RegistrationError, match=r"plugin 'thief' registered likelihood "
                                                r"'gaussian', already registered by plugin "
                                                r"'basic'; pass override=True"):
        Host(plugins=[("thief", _Registers("l", [("gaussian", _likelihood(GOOD["minus-inf"]),
                                                  False)]))])


def test_override_on_purpose_is_warned_and_used():
    evil = _likelihood(GOOD["minus-inf"])
    with pytest.warns(UserWarning, match="plugin 'mine' overrides likelihood 'gaussian' of "
                                         "plugin 'basic'"):
        h = Host(plugins=[("mine", _Registers("l", [("gaussian", evil, True)]))])
    assert h.get("likelihood", "gaussian") is evil


def _fake_entry_point(monkeypatch, module_name: str, plugin_obj, ep_name: str):
    mod = types.ModuleType(module_name)
    mod.plugin = plugin_obj
    monkeypatch.setitem(sys.modules, module_name, mod)
    real = metadata.entry_points

    def entry_points(**kw):
        eps = list(real(**kw))
        if kw.get("group") == host_mod.ENTRY_POINT_GROUP:
            eps.append(metadata.EntryPoint(ep_name, f"{module_name}:plugin",
                                           host_mod.ENTRY_POINT_GROUP))
        return eps

    monkeypatch.setattr(host_mod.metadata, "entry_points", entry_points)


@pytest.mark.parametrize("ep_name", ["aaa", "zzz"])
def test_installed_third_party_cannot_replace_a_builtin(monkeypatch, ep_name):
    """Installed (entry point) plugins load after the built-ins whatever their name ('aaa'
    sorts before 'basic'): the built-in keeps the name, the warning names the one that tried."""
    builtin = Host().get("likelihood", "gaussian")
    _fake_entry_point(monkeypatch, f"thief_{ep_name}",
                      _Registers("l", [("gaussian", _likelihood(GOOD["minus-inf"]), False)]),
                      ep_name)
    with pytest.warns(PluginLoadWarning, match=f"pftrack plugin '{ep_name}' was not fully "
                                               "registered: .*'gaussian', already registered "
                                               "by plugin 'basic'"):
        h = Host()
    assert h.get("likelihood", "gaussian") is builtin
    assert h.plugins[ep_name].error


def test_installed_third_party_override_on_purpose(monkeypatch):
    evil = _likelihood(GOOD["minus-inf"])
    _fake_entry_point(monkeypatch, "override_aaa", _Registers("l", [("gaussian", evil, True)]),
                      "aaa")
    with pytest.warns(UserWarning, match="plugin 'aaa' overrides likelihood 'gaussian'"):
        h = Host()
    assert h.get("likelihood", "gaussian") is evil


@pytest.mark.parametrize(("value", "expect"), [
    ("colur", "did you mean 'colour'"),
    ("basic,nosuchplugin", "'nosuchplugin', which is no installed plugin"),
    (" wrld ", "did you mean 'world'"),
])
def test_unknown_disabled_plugin_is_warned(monkeypatch, value, expect):
    monkeypatch.setenv("PFTRACK_DISABLE_PLUGINS", value)
    with pytest.warns(PluginSettingWarning, match=expect):
        Host()


def test_known_disabled_plugin_is_not_warned(monkeypatch):
    monkeypatch.setenv("PFTRACK_DISABLE_PLUGINS", "colour")
    with warnings.catch_warnings():
        warnings.simplefilter("error", PluginSettingWarning)
        h = Host()
    assert "colour" not in h.plugins


class _Misspelt:
    @hookimpl(optionalhook=True)
    def pftrack_register_likelihood(self, register):  # the hook is ..._likelihoods
        register("never", _likelihood(GOOD["minus-inf"]))


class _MisspeltUnmarked:
    def pftrack_regster_detectors(self, register):
        pass


@pytest.mark.parametrize(("plugin", "expect"), [
    (_Misspelt(), ("pftrack_register_likelihood is no pftrack hook and is ignored; did you "
                   "mean 'pftrack_register_likelihoods'")),
    (_MisspeltUnmarked(), "did you mean 'pftrack_register_detectors'"),
])
def test_misspelt_hook_is_warned(plugin, expect):
    with pytest.warns(PluginLoadWarning, match=f"pftrack plugin 'typo': .*{expect}"):
        h = Host(plugins=[("typo", plugin)])
    assert "never" not in h.names("likelihood")


class _RaisingHook:
    @hookimpl
    def pftrack_register_likelihoods(self, register):
        raise RuntimeError("registration exploded")


def test_registration_hook_that_raises_is_named():
    with pytest.warns(PluginLoadWarning, match="pftrack plugin 'boom': pftrack_register_"
                                               "likelihoods raised .*RuntimeError: registration "
                                               "exploded"):
        h = Host(plugins=[("boom", _RaisingHook())])
    assert "gaussian" in h.names("likelihood")


def test_bad_component_parameters_name_the_plugin(work, cli, plugin_host):
    plugin_host(("fine", _Registers("l", [("fine-one", _likelihood(GOOD["float32"]), False)])))
    cfg = yaml.safe_load(CONFIG)
    cfg["likelihood"] = {"type": "fine-one", "params": {"sigma": 2}}
    p = work.dir / "c.yaml"
    p.write_text(yaml.safe_dump(cfg))
    before = snapshot(work.dir)
    r = cli("run", p, "--video", work.video, "--out", work.out, "--quiet")
    assert r.rc == 2
    line = one_line(r.err)
    assert "likelihood.params.sigma: unknown parameter of likelihood 'fine-one'" in line
    assert_untouched(before, work.dir)


def test_tracker_checks_are_per_call_and_cheap():
    """The checks run on every call and name the target; a valid float64 array passes as is."""
    from pftrack.engine.tracker import ComponentOutputError, MultiTargetTracker

    assert issubclass(ComponentOutputError, RuntimeError)
    t = copy.copy(MultiTargetTracker.__new__(MultiTargetTracker))
    t.likelihood = _likelihood(GOOD["float32"])()
    arr = t._checked_dtype(np.zeros(3, np.float32))
    assert arr.dtype == np.float64 and arr.shape == (3,)
    with pytest.raises(ComponentOutputError, match="of dtype int32"):
        t._checked_dtype(np.zeros(3, np.int32))
