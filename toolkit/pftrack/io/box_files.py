"""Person boxes read from files for a camera fit (:mod:`pftrack.geometry.people`): boxes a
user clicked (:func:`read_boxes_csv`) and a MOTChallenge ``det.txt``
(:func:`read_detection_boxes`)."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["read_boxes_csv", "read_detection_boxes"]


def read_boxes_csv(path: Any) -> np.ndarray:
    """Boxes a user clicked: a CSV of ``x,y,w,h[,frame]`` per line (pixels; an optional header
    line of names is skipped; ``#`` starts a comment).

    Returns
    -------
    ndarray, shape (N, 5)
        ``x, y, w, h, frame`` (frame 0 when the file has no such column).

    Raises
    ------
    ValueError
        Naming the file and line of a malformed row.
    """
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"boxes CSV not found: {p}")
    rows: list[list[float]] = []
    for lineno, text in enumerate(p.read_text(encoding="utf-8-sig").splitlines(), start=1):
        text = text.split("#", 1)[0].strip()
        if not text:
            continue
        parts = [t.strip() for t in text.replace(";", ",").split(",")]
        try:
            vals = [float(t) for t in parts]
        except ValueError:
            if not rows and lineno == 1 or all(not t[:1].isdigit() for t in parts):
                continue  # a header
            raise ValueError(f"{p}, line {lineno}: expected numbers x,y,w,h[,frame], got "
                             f"{text!r}") from None
        if len(vals) not in (4, 5):
            raise ValueError(f"{p}, line {lineno}: expected 4 or 5 columns x,y,w,h[,frame], got "
                             f"{len(vals)}")
        if vals[2] <= 0 or vals[3] <= 0:
            raise ValueError(f"{p}, line {lineno}: width and height must be > 0, got {text!r}")
        rows.append(vals if len(vals) == 5 else [*vals, 0.0])
    if not rows:
        raise ValueError(f"{p}: no boxes (expected lines x,y,w,h[,frame])")
    return np.asarray(rows, dtype=np.float64)


def read_detection_boxes(path: Any, first: int = 1, last: int | None = None,
                         min_score: float | None = None) -> np.ndarray:
    """Boxes of a MOTChallenge ``det.txt`` in frames ``first..last`` (and score >= min_score).

    Returns
    -------
    ndarray, shape (N, 6)
        ``x, y, w, h, frame, score``.
    """
    from pftrack.io.mot import read_mot

    rows = read_mot(path, check_unique=False)
    keep = rows[:, 0] >= first
    if last is not None:
        keep &= rows[:, 0] <= last
    if min_score is not None:
        keep &= rows[:, 6] >= min_score
    r = rows[keep]
    return np.column_stack([r[:, 2:6], r[:, 0], r[:, 6]])
