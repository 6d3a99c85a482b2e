"""The ``pftrack`` console script.

Each sub-command lives in its own module of this package and exposes
``register(subparsers)``, which adds its parser and sets ``func=handler(args) -> int``.
Modules are found by scanning this package, so adding a command never edits a shared list.
Plugins add their own commands (:class:`pftrack.contracts.extensions.Command`, hook
``pftrack_register_commands``); one whose name a core command has is refused with a warning
naming the plugin.
Heavy imports (OpenCV, Open3D, pyvista) happen inside the handlers, not at parser build time.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Sequence

from pftrack import __version__


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pftrack",
        description="Particle-filter multi-object tracking for video (headless).",
    )
    parser.add_argument("--version", action="version", version=f"pftrack {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for mod in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if mod.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{mod.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(sub)
    _plugin_commands(sub)
    return parser


def _plugin_commands(sub: argparse._SubParsersAction) -> None:
    import warnings

    from pftrack.cli import _args
    from pftrack.host import PluginLoadWarning, get_host

    for entry in sorted(get_host().registry.entries("command"), key=lambda e: e.name):
        if entry.name in sub.choices:
            warnings.warn(f"pftrack plugin {entry.plugin!r}: command {entry.name!r} is a core "
                          "command and was not added", PluginLoadWarning, stacklevel=2)
            continue
        cmd = entry.obj
        p = sub.add_parser(entry.name, help=f"{cmd.summary} [{entry.plugin}]",
                           description=cmd.description or cmd.summary)
        cmd.add_arguments(p)
        _args.name_seed_options(p)
        p.set_defaults(func=cmd.run)


def main(argv: Sequence[str] | None = None) -> int:
    """Run a command; every exception becomes one line and an exit code (0 ok, 1 internal
    error, 2 bad input, 130 interrupted, 141 closed output pipe; see
    :mod:`pftrack.cli._errors`). ``--debug`` anywhere prints the traceback too."""
    from pftrack.cli import _alloc, _errors

    _alloc.keep_large_arrays()  # per-frame arrays reused from the heap (glibc; see _alloc)
    argv, debug = _errors.split_debug(list(sys.argv[1:] if argv is None else argv))
    command = None
    args = None
    _errors.one_line_warnings(None)
    try:
        parser = build_parser()
        parser.add_argument(_errors.DEBUG_FLAG, action="store_true",
                            help="print the traceback of an error (also: PFTRACK_DEBUG=1)")
        args = parser.parse_args(argv)
        command = getattr(args, "command", None)
        _errors.one_line_warnings(command)
        if not getattr(args, "func", None):
            parser.print_help()
            return 2
        _errors.precheck_out(args)
        code = int(args.func(args) or 0)
        sys.stdout.flush()
        return code
    except (Exception, KeyboardInterrupt) as exc:  # noqa: BLE001 - the one place that must
        return _errors.handle(command, exc, debug,
                              _errors.inputs_of(args) if args is not None else "")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
