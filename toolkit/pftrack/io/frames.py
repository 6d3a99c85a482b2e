"""Which frames to process: :func:`parse_frames` reads a frame range (``--frames A:B``, a
configuration's ``frames``) in ground-truth numbering (1-based, inclusive)."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["parse_frames"]


def parse_frames(text: str | tuple[int, int | None] | Sequence[int] | None,
                 option: str = "--frames") -> tuple[int, int | None]:
    """Frames to process, inclusive, in ground-truth numbering (1-based).

    ``"A:B"`` -> (A, B); ``"A:"`` -> (A, None) (to the end); ``":B"`` -> (1, B); ``"A"`` ->
    (A, A); ``None`` -> (1, None) (all frames); a pair ``(A, B)`` of integers (``B`` may be
    None) as it is. Anything else (an empty string, a number that is not an integer, ``A < 1``,
    ``B < A``) is a :class:`ValueError` naming ``option``.
    """
    import operator

    form = "A:B (1-based, inclusive; A: to the end; leave it out for all frames)"
    if text is None:
        return 1, None
    if isinstance(text, str):
        if not text.strip():
            raise ValueError(f"{option} is empty: give {form}")
        a, sep, b = text.partition(":")
        try:
            first = int(a) if a.strip() else 1
            last = int(b) if b.strip() else None
        except ValueError:
            raise ValueError(f"{option} must look like {form}, got {text!r}") from None
        if not sep:
            last = first
    else:
        try:
            lo, hi = text
            # operator.index: integers only (1.7 or "3" is not a frame number)
            first = operator.index(lo)
            last = None if hi is None else operator.index(hi)
        except (TypeError, ValueError):
            raise ValueError(f"{option} must be {form} or a pair of integers (A, B), got "
                             f"{text!r}") from None
    if first < 1 or (last is not None and last < first):
        raise ValueError(f"{option} {text!r}: need 1 <= A <= B (1-based, inclusive), got "
                         f"A = {first}, B = {'(end)' if last is None else last}")
    return int(first), None if last is None else int(last)
