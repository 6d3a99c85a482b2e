"""What a plugin registers besides components: benchmarks, command-line commands and demos.

Each is a small typed record a ``pftrack_register_*`` hook hands to its ``register`` callable; the
host rejects anything else at once, naming the plugin. The core finds them through the host
(``pftrack bench NAME``, ``pftrack NAME``, ``pftrack demo``) and never imports the plugin that
registered them: a paper arrives as a plugin package without editing ``toolkit/``.

All three share one shape: a one-line ``summary`` (the ``--help`` line), ``add_arguments(parser)``
to declare the options, and ``run(args)``. Heavy imports belong inside ``run``: building the
command line imports only the plugin's top-level module and what these callables' module needs.

Example (a plugin's ``__init__.py``)::

    from pftrack import hookimpl
    from pftrack.contracts.extensions import Benchmark

    @hookimpl
    def pftrack_register_benchmarks(register):
        from my_plugin import bench
        register("my-bench", Benchmark.from_module(bench))
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass
from types import ModuleType
from typing import Any

__all__ = ["Benchmark", "Command", "Demo", "ReportWriter"]


def _nothing(parser: argparse.ArgumentParser) -> None:
    """``add_arguments`` of an extension without options."""


def _summary(module: ModuleType) -> str:
    doc = (module.__doc__ or "").strip()
    first = " ".join(doc.split("\n\n")[0].split())  # the first paragraph, on one line
    return first or module.__name__


@dataclass(frozen=True)
class Benchmark:
    """A benchmark: ``pftrack bench NAME [--json] [--out FILE] ...``.

    Attributes
    ----------
    summary : str
        One line for ``pftrack bench --help``.
    run : callable ``(argparse.Namespace) -> dict``
        Measures and returns the figures (JSON-serialisable; floats, ints, strings, lists,
        dicts). ``--json`` prints it; ``--out`` writes it atomically.
    add_arguments : callable ``(argparse.ArgumentParser) -> None``
        Declares the benchmark's own options (``--json`` and ``--out`` are added by pftrack).
    format_table : callable ``(dict) -> str``, optional
        The human-readable report of ``run``'s result (default: the JSON).
    """

    summary: str
    run: Callable[[argparse.Namespace], dict[str, Any]]
    add_arguments: Callable[[argparse.ArgumentParser], None] = _nothing
    format_table: Callable[[dict[str, Any]], str] | None = None

    @classmethod
    def from_module(cls, module: ModuleType) -> Benchmark:
        """A benchmark from a module with ``run``, optional ``add_arguments`` and
        ``format_table``; its docstring's first line is the summary."""
        return cls(summary=_summary(module), run=module.run,
                   add_arguments=getattr(module, "add_arguments", _nothing),
                   format_table=getattr(module, "format_table", None))


@dataclass(frozen=True)
class Command:
    """A sub-command of the ``pftrack`` command line: ``pftrack NAME ...``.

    Attributes
    ----------
    summary : str
        One line for ``pftrack --help``.
    run : callable ``(argparse.Namespace) -> int``
        The handler; returns the exit status. Raising ``FileNotFoundError``, ``ValueError`` or
        ``KeyError`` prints one clear line (``pftrack NAME: error: ...``) and exits 2.
    add_arguments : callable ``(argparse.ArgumentParser) -> None``
        Declares the command's options.
    description : str, optional
        The longer ``pftrack NAME --help`` text (default: the summary).
    """

    summary: str
    run: Callable[[argparse.Namespace], int]
    add_arguments: Callable[[argparse.ArgumentParser], None] = _nothing
    description: str | None = None


@dataclass(frozen=True)
class ReportWriter:
    """The report pictures of a run (``pftrack run``'s ``DIR/report/``), chosen by a run
    configuration's ``report: {writer: NAME}`` (default ``tracks``).

    Attributes
    ----------
    summary : str
        One line for ``pftrack plugins``.
    write : callable
        ``write(out_dir, rows, frames, *, gt_rows, title) -> list[Path]``: ``rows`` the run's
        MOTChallenge rows (M, 10) (world columns filled where the run had a camera), ``frames``
        ``{frame number: image (H, W, 3) BGR}`` of the frames kept for the report, ``gt_rows``
        the ground truth or None. Writes every file atomically and returns the paths written.
    """

    summary: str
    write: Callable[..., list[Any]]


@dataclass(frozen=True)
class Demo:
    """A demo: ``pftrack demo [NAME] --out DIR ...``, the first thing a newcomer runs.

    Attributes
    ----------
    summary : str
        One line for ``pftrack demo --help``.
    run : callable ``(argparse.Namespace) -> int``
        Runs the demo end to end into ``args.out`` (created) and prints what it wrote.
    add_arguments : callable ``(argparse.ArgumentParser) -> None``
        The demo's own options (``--out`` is added by pftrack).
    default : bool
        The demo ``pftrack demo`` runs when no NAME is given (the built-in ``walkers`` demo
        is; a third-party demo is run by name unless none other is registered).
    """

    summary: str
    run: Callable[[argparse.Namespace], int]
    add_arguments: Callable[[argparse.ArgumentParser], None] = _nothing
    default: bool = False
