"""A component at fault, named: the error the engine raises when a component returns what its
contract forbids, and the label that names the component, its plugin and its module."""


from __future__ import annotations

from typing import Any


class ComponentOutputError(RuntimeError):
    """A component returned what its contract forbids (NaN log-likelihoods, a wrong shape or
    dtype); the message names the component and the module it comes from."""


def component_label(component: Any) -> str:
    """``likelihood 'name' of plugin 'p' (Class from module)``: a component named for a
    message (its plugin when the process's host registered this class under that name)."""
    cls = type(component)
    kind = getattr(component, "kind", "component")
    name = getattr(component, "name", None) or cls.__name__
    plugin = ""
    try:
        from pftrack.host import get_host

        entry = get_host().registry.get(kind, name)
        plugin = f" of plugin {entry.plugin!r}" if entry.obj is cls else ""
    except Exception:  # noqa: BLE001 - naming the plugin must not hide the fault itself
        pass
    return f"{kind} {name!r}{plugin} ({cls.__name__} from {cls.__module__})"
