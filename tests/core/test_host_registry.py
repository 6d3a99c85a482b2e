"""The plugin host and its typed registry: registration errors name the plugin, overrides are
explicit, a broken plugin does not stop the others, nothing loads at import."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from importlib import metadata

import numpy as np
import pftrack.host as host_mod
import pytest
from conftest import SampleWalk
from pftrack import hookimpl
from pftrack.contracts.components import Likelihood
from pftrack.host import Host, PluginLoadWarning, RegistrationError, UnknownComponentError


class _Walk(SampleWalk):
    """The sample walk under this module's own class (registering a class sets its name)."""


class _OtherWalk(_Walk):
    pass


class _Flat(Likelihood):
    def __init__(self, level: float = 0.0) -> None:
        self.level = level

    def log_likelihood(self, boxes_xywh_px, target):
        return np.full(len(boxes_xywh_px), float(self.level))


class _Plugin:
    """A plugin object registering one motion model under ``name``."""

    def __init__(self, name, cls, override=False):
        self.name, self.cls, self.override = name, cls, override

    @hookimpl
    def pftrack_register_motion_models(self, register):
        register(self.name, self.cls, override=self.override)


class _LikelihoodAsMotion:
    @hookimpl
    def pftrack_register_motion_models(self, register):
        register("flat", _Flat)


class _NotAClass:
    @hookimpl
    def pftrack_register_likelihoods(self, register):
        register("flat", _Flat(level=1.0))  # an instance, not a class


class _Raises:
    @hookimpl
    def pftrack_register_likelihoods(self, register):
        raise RuntimeError("model file missing")


def _host(*plugins):
    return Host(load_entry_points=False, plugins=list(plugins))


def test_builtins_register_every_component_kind():
    h = Host()
    assert {"basic", "colour", "world"} <= set(h.plugins)
    assert all(h.plugins[n].builtin for n in ("basic", "colour", "world"))
    assert {"random-walk", "constant-velocity-2d", "constant-velocity-3d",
            "constant-acceleration"} <= set(h.names("motion"))
    assert "gaussian" in h.names("likelihood")
    assert {"hungarian-iou", "greedy-iou"} <= set(h.names("associator"))
    assert "mog2" in h.names("detector")
    assert h.registry.get("motion", "random-walk").plugin == "basic"


def test_build_from_name_config_and_instance_round_trips():
    h = Host()
    m = h.build("motion", {"type": "constant-acceleration",
                           "params": {"position_noise": 0.2, "max_frames_tracked": 30}})
    assert m.position_noise == 0.2 and m.max_frames_tracked == 30
    cfg = json.loads(json.dumps(m.to_config()))
    assert cfg["type"] == "constant-acceleration"
    m2 = h.build("motion", cfg)
    assert type(m2) is type(m) and m2.get_params() == m.get_params()
    assert h.build("motion", m) is m
    assert type(h.build("associator", "greedy-iou")).__name__ == "GreedyIoUAssociator"
    with pytest.raises(UnknownComponentError, match="no motion named 'nope'.*random-walk"):
        h.build("motion", "nope")
    with pytest.raises(ValueError, match=r"motion 'random-walk' \(plugin 'basic'\): bad param"):
        h.build("motion", {"type": "random-walk", "params": {"sigma": 1}})


def test_duplicate_name_is_rejected_naming_both_plugins():
    with pytest.raises(RegistrationError, match=r"plugin 'second'.*'walk'.*plugin 'first'"):
        _host(("first", _Plugin("walk", _Walk)), ("second", _Plugin("walk", _OtherWalk)))


def test_a_plugin_cannot_silently_replace_a_builtin():
    class Shadow:
        @hookimpl
        def pftrack_register_motion_models(self, register):
            register("random-walk", _Walk)

    with pytest.raises(RegistrationError, match=r"plugin 'shadow'.*'random-walk'.*'basic'"):
        Host(plugins=[("shadow", Shadow())])


def test_wrong_kind_and_non_class_are_rejected_naming_the_plugin():
    with pytest.raises(RegistrationError, match=r"plugin 'mixup'.*motion 'flat'.*MotionModel"):
        _host(("mixup", _LikelihoodAsMotion()))
    with pytest.raises(RegistrationError, match=r"plugin 'inst'.*not a subclass"):
        _host(("inst", _NotAClass()))


def test_explicit_override_replaces_with_a_warning():
    with pytest.warns(UserWarning, match=r"plugin 'mine' overrides motion 'walk' of plugin 'a'"):
        h = _host(("a", _Plugin("walk", _Walk)), ("mine", _Plugin("walk", _OtherWalk, True)))
    assert h.get("motion", "walk") is _OtherWalk
    assert h.registry.get("motion", "walk").plugin == "mine"
    assert isinstance(h.build("motion", "walk"), _OtherWalk)


def test_hook_that_raises_warns_naming_the_plugin_and_others_still_load():
    with pytest.warns(PluginLoadWarning, match=r"'boom'.*RuntimeError: model file missing"):
        h = _host(("boom", _Raises()), ("ok", _Plugin("walk", _Walk)))
    assert h.names("motion") == ["walk"]
    assert "model file missing" in h.plugins["boom"].error
    assert "error" in next(p for p in h.listing()["plugins"] if p["name"] == "boom")


def test_plugin_that_fails_to_import_warns_and_the_builtins_still_load(monkeypatch):
    real = metadata.entry_points(group="pftrack")
    broken = metadata.EntryPoint(name="broken", value="pftrack_no_such_module_xyz",
                                 group="pftrack")

    def fake_entry_points(group=None, **kw):
        assert group == "pftrack"
        return [*real, broken]

    monkeypatch.setattr(host_mod.metadata, "entry_points", fake_entry_points)
    with pytest.warns(PluginLoadWarning, match=r"'broken'.*pftrack_no_such_module_xyz"):
        h = Host()
    assert "ModuleNotFoundError" in h.plugins["broken"].error
    assert h.plugins["broken"].builtin is False
    assert "random-walk" in h.names("motion") and "gaussian" in h.names("likelihood")


def test_disable_env_blocks_a_builtin_plugin(monkeypatch):
    monkeypatch.setenv("PFTRACK_DISABLE_PLUGINS", "basic, other")
    with warnings.catch_warnings():
        warnings.simplefilter("error", PluginLoadWarning)
        h = Host()
    assert "basic" not in h.plugins and "colour" in h.plugins
    assert "random-walk" not in h.names("motion")


def test_host_is_created_lazily_and_shared():
    h1 = host_mod.get_host()
    assert host_mod.get_host() is h1
    assert host_mod.get_host(refresh=True) is not h1
    names = [p["name"] for p in host_mod.list_plugins()]
    assert names[:1] == ["basic"] and {"colour", "world"} <= set(names)


def test_nothing_is_loaded_at_import():
    code = (
        "import sys, pftrack, pftrack.contracts.components, pftrack.host, pftrack.testing\n"
        "heavy = [m for m in ('pftrack_basic', 'pftrack_colour', 'pftrack_world', 'cv2',"
        " 'open3d', 'pyvista', 'scipy', 'sklearn', 'stonesoup') if m in sys.modules]\n"
        "print(repr(heavy), pftrack.host._HOST is None)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["[]", "True"], out.stdout + out.stderr


def test_installed_plugin_with_a_bad_registration_warns_and_the_others_still_load(monkeypatch):
    """An entry-point plugin that clashes with a built-in is reported, not fatal."""
    import importlib.metadata as md
    import sys
    import types

    mod = types.ModuleType("pftrack_clash_plugin")

    @hookimpl
    def pftrack_register_motion_models(register):
        register("random-walk", _Walk)  # taken by the built-in 'basic'

    mod.pftrack_register_motion_models = pftrack_register_motion_models
    monkeypatch.setitem(sys.modules, "pftrack_clash_plugin", mod)
    real = md.entry_points

    def fake_entry_points(**kw):
        eps = list(real(**kw))
        if kw.get("group") == "pftrack":
            eps.append(md.EntryPoint("clash", "pftrack_clash_plugin", "pftrack"))
        return eps

    monkeypatch.setattr(md, "entry_points", fake_entry_points)
    with pytest.warns(PluginLoadWarning, match=r"'clash'.*random-walk.*'basic'"):
        h = Host()
    assert h.plugins["clash"].error
    assert h.registry.get("motion", "random-walk").plugin == "basic"
    assert "likelihood" in h.plugins["colour"].components
