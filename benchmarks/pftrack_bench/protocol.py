"""The protocol every benchmark declares once, and the one check that keeps its report off the
frames that chose its settings.

Each benchmark module of this package has a module-level ``PROTOCOL``
(:class:`Protocol`): the data, what chose the settings and what the figures are reported on, in
words, and, where the data has a frame split, the split itself per video
(:attr:`Protocol.chosen_frames`, :attr:`Protocol.reported_frames`). :func:`benchmark` registers
the module so that the JSON it prints carries ``"protocol"`` (the words, added to the details a
benchmark puts there itself) and, for a split, ``"part"``; ``docs/_ext/pftrack_results.py``
records that protocol with the result.

A benchmark with a split takes ``--part {report,tune}`` (:func:`add_part_argument`): ``report``
(the default) runs on the frames that chose nothing; its ``--frames`` must lie inside them
(:func:`part_frames`), so a figure on the frames that chose the settings is printed only when
``--part tune`` asks for it.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

__all__ = ["PARTS", "REPORT_PART", "TUNE_PART", "Protocol", "add_part_argument", "benchmark",
           "checked_frames", "part_frames"]

#: The part whose frames chose every setting (presets, thresholds, trained models).
TUNE_PART = "tune"
#: The part the figures are reported on; it chose nothing.
REPORT_PART = "report"
PARTS = (REPORT_PART, TUNE_PART)


@dataclass(frozen=True)
class Protocol:
    """What a benchmark's settings were chosen on and what its figures are reported on.

    Attributes
    ----------
    data : str
        The data the benchmark runs on.
    chosen_on : str
        The frames, seeds or settings that chose its settings (in words).
    reported_on : str
        What its figures are reported on (in words).
    chosen_frames, reported_frames : mapping of str to (int, int)
        Per video (``""`` when there is one), the inclusive frame ranges (ground-truth
        numbering, from 1) of the two parts, for a benchmark with a frame split; empty when it
        has none.
    """

    data: str
    chosen_on: str
    reported_on: str
    chosen_frames: Mapping[str, tuple[int, int]] = field(default_factory=dict)
    reported_frames: Mapping[str, tuple[int, int]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if set(self.chosen_frames) != set(self.reported_frames):
            raise ValueError("Protocol: chosen_frames and reported_frames must name the same "
                             f"videos, got {sorted(self.chosen_frames)} and "
                             f"{sorted(self.reported_frames)}")
        for video, (a, b) in self.chosen_frames.items():
            c, d = self.reported_frames[video]
            if not (1 <= a <= b and 1 <= c <= d) or (a <= d and c <= b):
                raise ValueError(f"Protocol: the parts of {video or 'the video'} must be "
                                 f"non-empty and apart, got {a}:{b} and {c}:{d}")

    @property
    def has_split(self) -> bool:
        """Whether the benchmark's data has frames that chose its settings."""
        return bool(self.chosen_frames)

    def as_dict(self) -> dict[str, str]:
        """The protocol in words, as the JSON result and ``results/`` carry it."""
        return {"data": self.data, "chosen_on": self.chosen_on,
                "reported_on": self.reported_on}


def add_part_argument(parser: argparse.ArgumentParser, protocol: Protocol) -> None:
    """Add ``--part {report,tune}`` (default ``report``), its help naming the two parts."""

    def frames(spans: Mapping[str, tuple[int, int]]) -> str:
        return ", ".join(f"{v + ' ' if v else ''}{a}-{b}" for v, (a, b) in spans.items())

    parser.add_argument("--part", choices=PARTS, default=REPORT_PART,
                        help=f"report (default: frames {frames(protocol.reported_frames)}, "
                             "which chose nothing) or tune (frames "
                             f"{frames(protocol.chosen_frames)}, which chose the settings; "
                             "printed only when asked for)")


def part_frames(bench: str, protocol: Protocol, part: str, frames: str | None = None,
                video: str = "") -> tuple[int, int]:
    """The inclusive frames to run: the part's, or ``frames`` (``"A:B"``, ``"A:"`` to the
    part's end) inside it.

    Raises
    ------
    ValueError
        ``part`` is not one of :data:`PARTS`, ``video`` has no split, or ``frames`` reach
        outside the part (a report never includes a frame that chose the settings; those are
        run only with ``--part tune``). The message names the benchmark.
    """
    from pftrack.io.frames import parse_frames

    if part not in PARTS:
        raise ValueError(f"{bench}: --part must be one of {', '.join(PARTS)}, got {part!r}")
    if video not in protocol.reported_frames:
        raise ValueError(f"{bench}: no frame split for {video or 'the video'} (known: "
                         f"{', '.join(protocol.reported_frames) or 'none'})")
    spans = {REPORT_PART: protocol.reported_frames[video], TUNE_PART: protocol.chosen_frames[video]}
    a, b = spans[part]
    if frames is None:
        return a, b
    f0, f1 = parse_frames(frames)
    f1 = b if f1 is None else f1
    if not a <= f0 <= f1 <= b:
        other = TUNE_PART if part == REPORT_PART else REPORT_PART
        oa, ob = spans[other]
        where = f" of {video}" if video else ""
        raise ValueError(
            f"{bench}: frames {f0}:{f1}{where} are not inside its {part} part ({a}:{b}); the "
            f"{other} part is {oa}:{ob}"
            + ("; results on the frames that chose the settings are printed only with "
               "--part tune" if other == TUNE_PART else ""))
    return f0, f1


def checked_frames(bench: str, protocol: Protocol, args: argparse.Namespace,
                   video: str = "") -> str:
    """``args.frames`` (``"A:B"`` or None) checked against ``args.part`` (default ``report``)
    by :func:`part_frames`: the text as given, or the part's frames ``"A:B"`` when none are
    given. Raises ValueError as :func:`part_frames` does."""
    part = getattr(args, "part", None) or REPORT_PART
    a, b = part_frames(bench, protocol, part, args.frames, video)
    return str(args.frames) if args.frames else f"{a}:{b}"


def benchmark(module: ModuleType) -> Any:
    """The :class:`pftrack.contracts.extensions.Benchmark` of a module of this package, its result
    carrying the module's ``PROTOCOL`` (``"protocol"``, and ``"part"`` for a frame split).

    Raises
    ------
    TypeError
        The module declares no ``PROTOCOL`` of type :class:`Protocol`.
    """
    from pftrack.contracts.extensions import Benchmark

    protocol = getattr(module, "PROTOCOL", None)
    if not isinstance(protocol, Protocol):
        raise TypeError(f"pftrack_bench: {module.__name__} declares no PROTOCOL (a "
                         "pftrack_bench.protocol.Protocol)")
    plain = Benchmark.from_module(module)

    def run(args: argparse.Namespace) -> dict[str, Any]:
        result = plain.run(args)
        if protocol.has_split:
            result.setdefault("part", getattr(args, "part", None) or REPORT_PART)
        own = result.get("protocol")  # a benchmark's own protocol details stay beside the words
        result["protocol"] = {**(own if isinstance(own, dict) else {}), **protocol.as_dict()}
        return result

    return Benchmark(summary=plain.summary, run=run, add_arguments=plain.add_arguments,
                     format_table=plain.format_table)
