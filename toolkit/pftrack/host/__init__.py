"""The plugin host: discovers plugins through the ``pftrack`` entry-point group and keeps a typed
registry of their components. Its sub-module :mod:`pftrack.host.config` checks a run
configuration against the schema and the registered components' parameters.

Environment variables
---------------------
``PFTRACK_DISABLE_PLUGINS``
    Comma-separated plugin (entry-point) names that are not loaded, built-in or not.
``PFTRACK_DISABLE_PLUGIN_AUTOLOAD``
    When set to ``1``/``true``/``yes``, third-party plugins are not loaded; the built-ins
    (entry points of the ``pftrack`` distribution itself) still are.

A plugin that fails to import, or whose registration hook raises, gives a
:class:`PluginLoadWarning` naming it; the other plugins still load. A registration that clashes
with an existing name, or registers a class of the wrong kind, is rejected at once with
:class:`RegistrationError` naming the plugin: raised for plugins handed to ``Host(plugins=...)``,
a :class:`PluginLoadWarning` (the plugin's error shows in the listing) for installed plugins, whose
other registrations and the other plugins still load.
"""

from __future__ import annotations

import difflib
import importlib
import os
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import pluggy

from pftrack.contracts import hookspecs
from pftrack.contracts.components import Component
from pftrack.contracts.extensions import Benchmark, Command, Demo, ReportWriter
from pftrack.contracts.kinds import KINDS

ENTRY_POINT_GROUP = "pftrack"
ENV_DISABLE = "PFTRACK_DISABLE_PLUGINS"
ENV_NO_AUTOLOAD = "PFTRACK_DISABLE_PLUGIN_AUTOLOAD"
BUILTIN_DIST = "pftrack"

# hook name -> registry kind
_REGISTER_HOOKS = {
    "pftrack_register_detectors": "detector",
    "pftrack_register_likelihoods": "likelihood",
    "pftrack_register_motion_models": "motion",
    "pftrack_register_associators": "associator",
    "pftrack_register_scenes": "scene",
    "pftrack_register_observation_models": "observation",
    "pftrack_register_track_managers": "tracks",
    "pftrack_register_lifecycle_stages": "stage",
    "pftrack_register_presets": "preset",
    "pftrack_register_volumes": "volumes",
    "pftrack_register_metrics": "metric",
    "pftrack_register_benchmarks": "benchmark",
    "pftrack_register_commands": "command",
    "pftrack_register_demos": "demo",
    "pftrack_register_report_writers": "report",
}
_RECORD_TYPES: dict[str, type] = {"benchmark": Benchmark, "command": Command, "demo": Demo,
                                  "report": ReportWriter}
ALL_KINDS = ("detector", "likelihood", "motion", "associator", "scene", "observation", "tracks",
             "stage", "preset", "volumes", "metric", "benchmark", "command", "demo", "report")


class RegistrationError(ValueError):
    """A plugin registered a duplicate name or an object of the wrong kind."""


class PluginLoadWarning(UserWarning):
    """A plugin could not be imported or registered; the others were loaded."""


class PluginSettingWarning(UserWarning):
    """A plugin setting names nothing: an unknown plugin in ``PFTRACK_DISABLE_PLUGINS``."""


class UnknownComponentError(KeyError):
    """No component of that kind and name is registered."""

    def __str__(self) -> str:  # KeyError quotes its message; keep it readable
        return str(self.args[0])


@dataclass
class Entry:
    """One registered component."""

    kind: str
    name: str
    obj: Any
    plugin: str


@dataclass
class PluginInfo:
    """One loaded (or failed) plugin."""

    name: str
    version: str
    builtin: bool
    source: str  # "module:..." or "entry point ..." for listing
    components: dict[str, list[str]] = field(default_factory=dict)
    error: str | None = None

    def as_dict(self) -> dict[str, Any]:
        d = {
            "name": self.name,
            "version": self.version,
            "builtin": self.builtin,
            "source": self.source,
            "components": {k: list(v) for k, v in self.components.items()},
        }
        if self.error:
            d["error"] = self.error
        return d


def _is_builtin(ep: metadata.EntryPoint) -> bool:
    return ep.dist is not None and ep.dist.name == BUILTIN_DIST


def _env_list(var: str) -> set[str]:
    raw = os.environ.get(var, "")
    return {p.strip() for p in raw.split(",") if p.strip()}


def _env_flag(var: str) -> bool:
    return os.environ.get(var, "").strip().lower() in {"1", "true", "yes", "on"}


class Registry:
    """Components by kind and name, with the plugin that registered each."""

    def __init__(self) -> None:
        self._entries: dict[str, dict[str, Entry]] = {k: {} for k in ALL_KINDS}
        self.hint = ""  # appended to an unknown name's error: the plugins and how to add one

    def bind(self, kind: str, plugin: str) -> Callable[..., None]:
        """A ``register(name, obj, *, override=False)`` callable for ``plugin`` and ``kind``."""

        def register(name: str, obj: Any, *, override: bool = False) -> None:
            self.add(kind, name, obj, plugin=plugin, override=override)

        register.__doc__ = f"Register a {kind} on behalf of plugin {plugin!r}."
        return register

    def add(self, kind: str, name: str, obj: Any, *, plugin: str, override: bool = False) -> None:
        if kind not in self._entries:
            raise RegistrationError(f"plugin {plugin!r}: unknown kind {kind!r}")
        if not isinstance(name, str) or not name or name != name.strip():
            raise RegistrationError(f"plugin {plugin!r}: {kind} name must be a non-empty string, "
                                    f"got {name!r}")
        base = KINDS.get(kind)
        if base is not None:
            if not (isinstance(obj, type) and issubclass(obj, base)):
                raise RegistrationError(
                    f"plugin {plugin!r} registered {kind} {name!r} as {obj!r}, which is not a "
                    f"subclass of {base.__module__}.{base.__name__}"
                )
            if obj.kind != kind:
                raise RegistrationError(
                    f"plugin {plugin!r}: {obj.__name__} has kind {obj.kind!r}, registered as {kind}"
                )
        elif kind in ("preset", "volumes"):
            if not Path(obj).is_file():
                raise RegistrationError(f"plugin {plugin!r}: {kind} {name!r} file not found: {obj}")
        elif kind == "metric" and not callable(obj):
            raise RegistrationError(f"plugin {plugin!r}: metric {name!r} is not callable")
        elif kind in _RECORD_TYPES:
            rtype = _RECORD_TYPES[kind]
            if not isinstance(obj, rtype):
                raise RegistrationError(
                    f"plugin {plugin!r} registered {kind} {name!r} as {obj!r}, which is not a "
                    f"{rtype.__module__}.{rtype.__name__}")
        existing = self._entries[kind].get(name)
        if existing is not None and not override:
            raise RegistrationError(
                f"plugin {plugin!r} registered {kind} {name!r}, already registered by plugin "
                f"{existing.plugin!r}; pass override=True to replace it on purpose"
            )
        if existing is not None:
            warnings.warn(
                f"plugin {plugin!r} overrides {kind} {name!r} of plugin {existing.plugin!r}",
                stacklevel=3,
            )
        if base is not None and isinstance(obj, type):
            # the registered name is what to_config() writes and Host.build() reads back
            obj.name = name  # type: ignore[attr-defined]
        self._entries[kind][name] = Entry(kind, name, obj, plugin)

    def get(self, kind: str, name: str) -> Entry:
        try:
            return self._entries[kind][name]
        except KeyError:
            known = ", ".join(sorted(self._entries.get(kind, {}))) or "none"
            raise UnknownComponentError(
                f"no {kind} named {name!r} is registered (known: {known}){self.hint}"
            ) from None

    def names(self, kind: str) -> list[str]:
        return sorted(self._entries[kind])

    def entries(self, kind: str | None = None) -> Iterable[Entry]:
        kinds = [kind] if kind else list(self._entries)
        for k in kinds:
            yield from self._entries[k].values()


class Host:
    """Loads plugins and builds components by name.

    Parameters
    ----------
    load_entry_points : bool
        Discover plugins through the ``pftrack`` entry-point group (default True).
    plugins : iterable of (name, module-or-object), optional
        Extra plugins to register directly (tests, notebooks), as if installed.
    """

    def __init__(self, load_entry_points: bool = True,
                 plugins: Iterable[tuple[str, Any]] = ()) -> None:
        self.pm = pluggy.PluginManager(hookspecs.PROJECT)
        self.pm.add_hookspecs(hookspecs)
        self.registry = Registry()
        self.plugins: dict[str, PluginInfo] = {}
        disabled = _env_list(ENV_DISABLE)
        no_autoload = _env_flag(ENV_NO_AUTOLOAD)
        if load_entry_points:
            # built-ins first: a third-party plugin that registers a built-in's name is the one
            # refused (and named), unless it overrides on purpose
            eps = metadata.entry_points(group=ENTRY_POINT_GROUP)
            for ep in sorted(eps, key=lambda e: (not _is_builtin(e), e.name)):
                dist = ep.dist.name if ep.dist is not None else "?"
                builtin = dist == BUILTIN_DIST
                if ep.name in disabled or ep.name in self.plugins:
                    continue
                if no_autoload and not builtin:
                    continue
                version = ep.dist.version if ep.dist is not None else "?"
                info = PluginInfo(ep.name, version, builtin, f"entry point {ep.value} ({dist})")
                try:
                    obj = ep.load()
                except Exception as exc:  # noqa: BLE001 - a broken plugin must not stop the rest
                    info.error = f"{type(exc).__name__}: {exc}"
                    self.plugins[ep.name] = info
                    warnings.warn(f"pftrack plugin {ep.name!r} ({ep.value}) failed to import: "
                                  f"{info.error}", PluginLoadWarning, stacklevel=2)
                    continue
                self._add_plugin(ep.name, obj, info, strict=False)
        plugins = list(plugins)
        if disabled:
            known = {ep.name for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)}
            known |= {n for n, _ in plugins}
            for unknown in sorted(disabled - known):
                close = difflib.get_close_matches(unknown, sorted(known), n=1)
                warnings.warn(f"{ENV_DISABLE} names {unknown!r}, which is no installed plugin"
                              + (f"; did you mean {close[0]!r}?" if close else
                                 f" (plugins: {', '.join(sorted(known))})"),
                              PluginSettingWarning, stacklevel=2)
        for name, obj in plugins:
            if name in disabled:
                continue
            mod = getattr(obj, "__name__", type(obj).__name__)
            self._add_plugin(name, obj, PluginInfo(name, getattr(obj, "__version__", "?"), False,
                                                   f"module {mod}"), strict=True)
        self.registry.hint = self._missing_hint(disabled, no_autoload)

    def _missing_hint(self, disabled: set[str], no_autoload: bool) -> str:
        """What an unknown component name's error adds: the plugins loaded, those that failed
        or were left out, and the ways to add a component."""
        ok = sorted(n for n, p in self.plugins.items() if not p.error)
        failed = sorted(f"{n} ({p.error})" for n, p in self.plugins.items() if p.error)
        text = f"; plugins loaded: {', '.join(ok) or 'none'}"
        if failed:
            text += f"; failed to load: {'; '.join(failed)}"
        if disabled:
            text += f"; disabled by {ENV_DISABLE}: {', '.join(sorted(disabled))}"
        if no_autoload:
            text += f"; third-party plugins not loaded ({ENV_NO_AUTOLOAD} is set)"
        return (text + ". To add one: from Python, pftrack.Tracker(..., plugins=[MyClass]) "
                "registers a component class under its name attribute (or its class name in "
                "kebab case); for every run, install a package that declares a 'pftrack' entry "
                "point (docs: plugins.md), and check `pftrack plugins`")

    def _add_plugin(self, name: str, obj: Any, info: PluginInfo, strict: bool) -> None:
        """Register ``obj``'s components. A registration error is raised for plugins handed in
        directly (``strict``: the caller's own code) and turned into a warning naming the
        plugin for installed ones, so that one bad package cannot stop every other plugin."""
        self.pm.register(obj, name=name)
        self.plugins[name] = info
        self._check_hook_names(name, obj)
        for hook, kind in _REGISTER_HOOKS.items():
            for impl in getattr(self.pm.hook, hook).get_hookimpls():
                if impl.plugin_name != name:
                    continue
                try:
                    impl.function(register=self.registry.bind(kind, name))
                except RegistrationError as exc:
                    if strict:
                        raise
                    info.error = f"{hook}: {exc}"
                    warnings.warn(f"pftrack plugin {name!r} was not fully registered: {exc}",
                                  PluginLoadWarning, stacklevel=2)
                except Exception as exc:  # noqa: BLE001
                    info.error = f"{hook}: {type(exc).__name__}: {exc}"
                    warnings.warn(f"pftrack plugin {name!r}: {hook} raised {info.error}",
                                  PluginLoadWarning, stacklevel=2)
        for e in self.registry.entries():
            if e.plugin == name:
                info.components.setdefault(e.kind, []).append(e.name)

    def _check_hook_names(self, name: str, obj: Any) -> None:
        """Warn about functions named like a hook (``pftrack_*``) that no hook has: a misspelt
        hook name would otherwise be ignored without a word."""
        specs = set(_REGISTER_HOOKS) | {n for n in dir(hookspecs) if n.startswith("pftrack_")}
        for attr in sorted(dir(obj)):
            if not attr.startswith("pftrack_") or attr in specs:
                continue
            if not callable(getattr(obj, attr, None)):
                continue
            close = difflib.get_close_matches(attr, sorted(specs), n=1)
            warnings.warn(f"pftrack plugin {name!r}: {attr} is no pftrack hook and is ignored"
                          + (f"; did you mean {close[0]!r}?" if close else ""),
                          PluginLoadWarning, stacklevel=3)

    # -- lookup -------------------------------------------------------------------------------

    def get(self, kind: str, name: str) -> Any:
        """The registered class (or preset path / metric function) of ``kind`` named ``name``."""
        return self.registry.get(kind, name).obj

    def names(self, kind: str) -> list[str]:
        return self.registry.names(kind)

    def build(self, kind: str, spec: str | dict[str, Any] | Component) -> Component:
        """Instantiate a component from a name, a ``{"type": name, "params": {...}}`` config
        (what :meth:`Component.to_config` writes), or pass an instance through."""
        if isinstance(spec, Component):
            return spec
        if isinstance(spec, str):
            name, params = spec, {}
        elif isinstance(spec, dict):
            if "type" not in spec:
                raise ValueError(f"{kind} config needs a 'type' key, got {sorted(spec)}")
            name = spec["type"]
            params = dict(spec.get("params") or {})
        else:
            raise TypeError(f"cannot build a {kind} from {spec!r}")
        cls = self.get(kind, name)
        try:
            return cls(**params)
        except TypeError as exc:
            raise ValueError(f"{kind} {name!r} (plugin {self.registry.get(kind, name).plugin!r}): "
                             f"bad parameters {params}: {exc}") from None

    def listing(self) -> dict[str, Any]:
        """``{"plugins": [...]}`` as ``pftrack plugins --json`` prints it."""
        return {"plugins": [p.as_dict() for p in sorted(self.plugins.values(),
                                                         key=lambda p: (not p.builtin, p.name))]}


_HOST: Host | None = None


def get_host(refresh: bool = False) -> Host:
    """The process-wide host, created on first use (never at import)."""
    global _HOST
    if _HOST is None or refresh:
        _HOST = Host()
    return _HOST


def list_plugins() -> list[dict[str, Any]]:
    """Every plugin with name, version, origin and components by kind (for notebooks)."""
    return get_host().listing()["plugins"]


def import_object(path: str) -> Any:
    """Import ``"package.module:attr"``."""
    mod, _, attr = path.partition(":")
    obj = importlib.import_module(mod)
    return getattr(obj, attr) if attr else obj
