"""The command line's top-level error handling: what a user can rely on.

Every exception that reaches :func:`pftrack.cli.main` becomes one line on stderr,
``pftrack COMMAND: error: MESSAGE``, and an exit code:

* ``0``: done;
* ``1``: internal error (a bug in pftrack or a plugin; the line says so and names the
  exception), or plugin error (a plugin's component returned what its contract forbids: NaN,
  a wrong shape or dtype; the line names the component and its plugin); ``--debug`` (anywhere
  on the command line, or ``PFTRACK_DEBUG=1``) prints the traceback instead;
* ``2``: bad input: a missing or malformed file, a bad parameter or configuration, an output
  path that cannot be written (read-only, under a regular file, a full disk); the message names
  the file or parameter;
* ``130``: interrupted (Ctrl-C, SIGINT);
* ``141``: the reader of standard output went away (``pftrack presets --json | head``): no
  message, as for SIGPIPE.
"""

from __future__ import annotations

import errno
import os
import sys
import traceback
from typing import Any

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141

DEBUG_FLAG = "--debug"
ENV_DEBUG = "PFTRACK_DEBUG"


def split_debug(argv: list[str]) -> tuple[list[str], bool]:
    """``argv`` without ``--debug`` (accepted anywhere before a ``--``), and whether it was
    there (or ``PFTRACK_DEBUG`` is set)."""
    out: list[str] = []
    debug = os.environ.get(ENV_DEBUG, "").strip().lower() in ("1", "true", "yes")
    rest = False
    for a in argv:
        if a == "--":
            rest = True
        if a == DEBUG_FLAG and not rest:
            debug = True
            continue
        out.append(a)
    return out, debug


def _is_bad_input(exc: BaseException) -> bool:
    import yaml

    # OSError: a file, a folder, permissions, a full disk: the user's to fix
    return isinstance(exc, (ValueError, LookupError, yaml.YAMLError, OSError))


def describe(exc: BaseException) -> str:
    """One line for ``exc``: its message, with the file an OSError names."""
    if isinstance(exc, KeyError) and exc.args:
        msg = str(exc.args[0])
    elif isinstance(exc, OSError) and exc.strerror:
        what = "no space left on the device" if exc.errno == errno.ENOSPC else exc.strerror
        names = [str(n) for n in (exc.filename, exc.filename2) if n is not None]
        msg = f"{what}: {' -> '.join(names)}" if names else what
    else:
        msg = str(exc)
    msg = " ".join(msg.split())  # one line
    return msg or type(exc).__name__


def handle(command: str | None, exc: BaseException, debug: bool, inputs: str = "") -> int:
    """Print the line for ``exc`` (the traceback too with ``debug``) and return the exit
    code."""
    prog = f"pftrack {command}" if command else "pftrack"
    if isinstance(exc, BrokenPipeError):
        _silence_stdout()
        return EXIT_BROKEN_PIPE
    if isinstance(exc, KeyboardInterrupt):
        if debug:
            traceback.print_exception(exc)
        _print(f"{prog}: interrupted; outputs left as they were before the run")
        return EXIT_INTERRUPTED
    if debug:
        traceback.print_exception(exc)
    if _is_bad_input(exc):
        _print(f"{prog}: error: {describe(exc)}")
        return EXIT_BAD_INPUT
    where = f" ({inputs})" if inputs else ""
    if _is_component_fault(exc):
        _print(f"{prog}: plugin error{where}: {describe(exc)} (the component's fault, not the "
               "input's: tell its plugin's authors)")
        return EXIT_INTERNAL
    _print(f"{prog}: internal error{where}: {type(exc).__name__}: {describe(exc)}"
           + ("" if debug else f" (run again with {DEBUG_FLAG} for the traceback)"))
    return EXIT_INTERNAL


def _is_component_fault(exc: BaseException) -> bool:
    """A component broke its contract (:class:`pftrack.engine.tracker.ComponentOutputError`)."""
    try:
        from pftrack.engine.tracker import ComponentOutputError
    except Exception:  # noqa: BLE001 - an engine that does not import: an internal error
        return False
    return isinstance(exc, ComponentOutputError)


def precheck_out(args: Any) -> None:
    """Before any command works: its ``--out`` (file or folder) must not lie under a regular
    file, and the folder it would be written in must be writable."""
    out = getattr(args, "out", None)
    if not isinstance(out, (str, os.PathLike)) or not str(out):
        return
    from pathlib import Path

    from pftrack.io.outputs import check_output_dir

    p = Path(out)
    check_output_dir(p.parent if not p.is_dir() else p, option=f"--out {p}: folder"
                     if not p.is_dir() else "--out")


def inputs_of(args: Any) -> str:
    """The files a command was given (its arguments that name existing paths), for the line of
    an internal error."""
    names = []
    for k, v in sorted(vars(args).items()):
        if k in ("func",) or not isinstance(v, str) or not v:
            continue
        if os.path.exists(v):
            names.append(f"{k}={v}")
    return ", ".join(names)


def one_line_warnings(command: str | None) -> None:
    """Show warnings as ``pftrack COMMAND: warning: MESSAGE`` (one line, no source line)."""
    import warnings

    prog = f"pftrack {command}" if command else "pftrack"

    def fmt(message, category, filename, lineno, line=None):
        text = " ".join(str(message).split())
        return f"{prog}: warning: {text}\n"

    warnings.formatwarning = fmt


def _print(line: str) -> None:
    try:
        print(line, file=sys.stderr)
        sys.stderr.flush()
    except (OSError, ValueError):  # stderr closed too: nothing more to say
        pass


def _silence_stdout() -> None:
    """After a broken pipe: point stdout at /dev/null, so that the interpreter's final flush
    does not raise again (Python docs, 'Note on SIGPIPE')."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # no real stdout (captured in tests)
        pass
