"""MOTChallenge files: track/ground-truth CSV rows and ``seqinfo.ini``.

A MOTChallenge CSV holds one box per line::

    frame, id, left, top, width, height, conf, x, y, z

``left, top, width, height`` are the image box in pixels (top-left corner, MOT's 1-based pixel
convention is kept as is: pftrack never shifts it); ``conf`` is the detector/tracker confidence in a
tracker file and the *consider* flag in a ground-truth file (0 = ignore this box); ``x, y, z`` are
the world position in metres (ground plane: ``x, y``; ``z`` height) or ``-1`` when unknown.

In memory a file is an ``(M, 10)`` float64 array in exactly that column order (the constants
``FRAME, ID, LEFT, ...`` index it); :class:`MotTable` is a small read-only view with named
accessors. Files with 6 to 9 columns are accepted and the missing trailing columns are filled with
``-1`` (2D MOT 2015 detections have 7, some tools write 9). Any malformed line raises a ValueError
naming the file and line number.
"""

from __future__ import annotations

import configparser
import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pftrack.io.atomic import atomic_write_text

__all__ = [
    "COLUMNS",
    "CONF",
    "FRAME",
    "HEIGHT",
    "ID",
    "LEFT",
    "TOP",
    "WIDTH",
    "MotTable",
    "SeqInfo",
    "X",
    "Y",
    "Z",
    "has_world",
    "read_mot",
    "read_seqinfo",
    "validate_mot_rows",
    "write_mot",
    "write_seqinfo",
]

COLUMNS: tuple[str, ...] = ("frame", "id", "left", "top", "width", "height", "conf", "x", "y", "z")
FRAME, ID, LEFT, TOP, WIDTH, HEIGHT, CONF, X, Y, Z = range(10)
UNKNOWN = -1.0


MAX_EXACT_INT = 2**53


def _parse_line(text: str, where: str) -> list[float]:
    parts = [p.strip() for p in (text.split(",") if "," in text else text.split())]
    if len(parts) < 6 or len(parts) > 10:
        raise ValueError(
            f"{where}: expected 6 to 10 comma-separated columns "
            f"(frame,id,left,top,width,height[,conf,x,y,z]), got {len(parts)}: {text!r}")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"{where}: non-numeric value in {text!r}") from None
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{where}: NaN or infinite value in {text!r}")
    if values[0] != int(values[0]) or values[1] != int(values[1]):
        raise ValueError(f"{where}: frame and id must be integers, got {parts[0]!r}, {parts[1]!r}")
    # exact integers (a float64 holds integers exactly only up to 2**53)
    for col, what in ((0, "frame"), (1, "id")):
        try:
            exact = int(parts[col].strip())
        except ValueError:
            exact = int(values[col])
        if abs(exact) > MAX_EXACT_INT:
            raise ValueError(f"{where}: {what} {parts[col].strip()} is too large (at most "
                             f"2**53 = {MAX_EXACT_INT}, exactly representable)")
    if values[0] < 1:
        raise ValueError(f"{where}: frame {parts[0].strip()} must be >= 1 (MOTChallenge frames "
                         "count from 1)")
    if values[1] < -1:
        raise ValueError(f"{where}: id {parts[1].strip()} must be >= 0 (or -1: no identity)")
    if values[WIDTH] < 0 or values[HEIGHT] < 0:
        raise ValueError(f"{where}: negative box width/height in {text!r}")
    return values + [UNKNOWN] * (10 - len(values))


def read_mot(path: str | os.PathLike[str], *, check_unique: bool = True,
             allow_empty: bool = True, what: str = "MOT file") -> np.ndarray:
    """Read a MOTChallenge CSV file.

    Parameters
    ----------
    path
        The file. Blank lines and lines starting with ``#`` are skipped; columns may be separated by
        commas (MOTChallenge) or whitespace.
    check_unique
        Raise if an id appears twice in the same frame (MOTChallenge forbids it and every metric
        would be ill-defined).
    allow_empty
        False: a file with no row (empty, or only blank and comment lines) is a ``ValueError``
        (a ground truth to score against). True: it reads as no rows (a run that tracked
        nothing writes such a ``tracks.txt``).
    what
        What the file is, for the messages (``"MOT file"``, ``"--gt"``, ...).

    Returns
    -------
    rows : ndarray, shape (M, 10), float64
        ``frame, id, left, top, width, height, conf, x, y, z`` (pixels; world columns in metres,
        ``-1`` where the file has no such column). Rows keep the file's order.

    Raises
    ------
    FileNotFoundError, IsADirectoryError
        When ``path`` does not exist, or is a folder.
    ValueError
        On a malformed line (wrong column count, non-numeric value, non-integer frame/id, negative
        size, NaN) or a duplicated (frame, id), naming the file and line number.
    """
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"{what} {path}: is a folder, expected a MOTChallenge file")
    if not path.is_file():
        raise FileNotFoundError(f"{what} not found: {path}")
    rows: list[list[float]] = []
    lines: list[int] = []
    with path.open("r", encoding="utf-8-sig") as fh:
        for lineno, text in enumerate(fh, start=1):
            text = text.strip()
            if not text or text.startswith("#"):
                continue
            rows.append(_parse_line(text, f"{path}, line {lineno}"))
            lines.append(lineno)
    out = np.asarray(rows, dtype=np.float64).reshape(-1, 10)
    if not allow_empty and not len(out):
        raise ValueError(f"{what} {path}: no rows (the file is empty, or only blank and comment "
                         "lines): nothing to score against")
    if check_unique and len(out):
        dup = _first_duplicate(out)
        if dup is not None:
            i, j = dup
            raise ValueError(
                f"{path}, line {lines[j]}: id {int(out[j, ID])} appears twice in frame "
                f"{int(out[j, FRAME])} (first at line {lines[i]})")
    return out


def _first_duplicate(rows: np.ndarray) -> tuple[int, int] | None:
    """Indices (first, second) of the first repeated (frame, id) pair, or None."""
    key = rows[:, [FRAME, ID]].astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    dup = np.flatnonzero(first[inverse] != np.arange(len(rows)))
    if len(dup) == 0:
        return None
    j = int(dup.min())
    return int(first[inverse[j]]), j


def validate_mot_rows(rows: np.ndarray, name: str = "rows") -> np.ndarray:
    """Check an in-memory MOT array and return it as a C-contiguous float64 ``(M, 10)`` array.

    ``(M, 6)`` to ``(M, 9)`` arrays are padded with ``-1``. ``name`` is used in error messages
    (e.g. the file or argument the rows came from).
    """
    arr = np.asarray(rows, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, 10))
    if arr.ndim != 2 or not 6 <= arr.shape[1] <= 10:
        raise ValueError(f"{name}: expected an (M, 6..10) MOT array, got shape {arr.shape}")
    if arr.shape[1] < 10:
        arr = np.hstack([arr, np.full((len(arr), 10 - arr.shape[1]), UNKNOWN)])
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr).all(axis=1))[0])
        raise ValueError(f"{name}: row {bad} has a NaN or infinite value")
    fi = arr[:, [FRAME, ID]]
    if np.any(fi != np.round(fi)):
        bad = int(np.flatnonzero((fi != np.round(fi)).any(axis=1))[0])
        raise ValueError(f"{name}: row {bad} has a non-integer frame or id")
    if np.any(arr[:, [WIDTH, HEIGHT]] < 0):
        bad = int(np.flatnonzero((arr[:, [WIDTH, HEIGHT]] < 0).any(axis=1))[0])
        raise ValueError(f"{name}: row {bad} has a negative box width/height")
    dup = _first_duplicate(arr)
    if dup is not None:
        raise ValueError(f"{name}: id {int(arr[dup[1], ID])} appears twice in frame "
                         f"{int(arr[dup[1], FRAME])} (rows {dup[0]} and {dup[1]})")
    return np.ascontiguousarray(arr)


def has_world(rows: np.ndarray) -> np.ndarray:
    """Per row, whether it carries a world position: shape (M,) bool.

    A row's world position is unknown when ``x``, ``y`` and ``z`` are all ``-1`` (MOTChallenge's
    marker); a single ``-1`` is a legitimate coordinate in metres.
    """
    rows = np.asarray(rows, dtype=np.float64).reshape(-1, 10)
    return ~np.all(rows[:, [X, Y, Z]] == UNKNOWN, axis=1)


def write_mot(path: str | os.PathLike[str], rows: np.ndarray) -> Path:
    """Write rows as a MOTChallenge CSV file, atomically.

    Parameters
    ----------
    path
        Output file; its folder is created. Written through :mod:`pftrack.io.atomic`, so a failure
        never leaves a truncated file.
    rows : array_like, shape (M, 6..10)
        As returned by :func:`read_mot`; shorter rows are padded with ``-1``. Frame and id are
        written as integers, the other columns with 10 significant digits (round-trips pixels and
        metres far below their precision).

    Returns
    -------
    Path
        ``path``.
    """
    arr = validate_mot_rows(rows, name=str(path))
    buf = io.StringIO()
    np.savetxt(buf, arr, fmt=["%d", "%d"] + ["%.10g"] * 8, delimiter=",")
    # no rows -> an empty file: a tracker that found nothing still leaves its (empty) output
    return atomic_write_text(path, buf.getvalue())


@dataclass(frozen=True)
class MotTable:
    """Named read-only view of MOT rows.

    Attributes
    ----------
    rows : ndarray, shape (M, 10), float64
        ``frame, id, left, top, width, height, conf, x, y, z``.
    """

    rows: np.ndarray

    def __post_init__(self) -> None:
        arr = validate_mot_rows(self.rows, name="MotTable")
        arr.setflags(write=False)
        object.__setattr__(self, "rows", arr)

    @classmethod
    def read(cls, path: str | os.PathLike[str]) -> MotTable:
        """Read a file with :func:`read_mot`."""
        return cls(read_mot(path))

    def write(self, path: str | os.PathLike[str]) -> Path:
        """Write the rows with :func:`write_mot`."""
        return write_mot(path, self.rows)

    def __len__(self) -> int:
        return len(self.rows)

    @property
    def frames(self) -> np.ndarray:
        """Frame numbers, shape (M,), int64."""
        return self.rows[:, FRAME].astype(np.int64)

    @property
    def ids(self) -> np.ndarray:
        """Target ids, shape (M,), int64."""
        return self.rows[:, ID].astype(np.int64)

    @property
    def boxes_xywh_px(self) -> np.ndarray:
        """Image boxes (left, top, width, height) in pixels, shape (M, 4)."""
        return self.rows[:, LEFT:CONF]

    @property
    def centres_px(self) -> np.ndarray:
        """Box centres (u, v) in pixels, shape (M, 2)."""
        b = self.rows
        return np.column_stack([b[:, LEFT] + b[:, WIDTH] / 2, b[:, TOP] + b[:, HEIGHT] / 2])

    @property
    def foot_px(self) -> np.ndarray:
        """Bottom-centre points (u, v) of the boxes in pixels, shape (M, 2)."""
        from pftrack.geometry.boxes import foot_points

        return foot_points(self.rows[:, LEFT:HEIGHT + 1])

    @property
    def conf(self) -> np.ndarray:
        """Confidence (tracker) or consider flag (ground truth), shape (M,)."""
        return self.rows[:, CONF]

    @property
    def world_m(self) -> np.ndarray:
        """World positions (x, y, z) in metres, shape (M, 3); ``-1`` rows are unknown."""
        return self.rows[:, X:]

    @property
    def has_world(self) -> np.ndarray:
        """Whether each row carries a world position, shape (M,) bool."""
        return has_world(self.rows)

    def frame(self, frame: int) -> MotTable:
        """The rows of one frame."""
        return MotTable(self.rows[self.rows[:, FRAME] == frame])

    def track(self, target_id: int) -> MotTable:
        """The rows of one id, in file order."""
        return MotTable(self.rows[self.rows[:, ID] == target_id])


# --------------------------------------------------------------------------------------------
# seqinfo.ini

@dataclass(frozen=True)
class SeqInfo:
    """A MOTChallenge ``seqinfo.ini`` ``[Sequence]`` section.

    Attributes
    ----------
    name : str
        Sequence name (``PETS09-S2L1``).
    im_dir : str
        Image folder relative to the sequence folder (``img1``).
    frame_rate : float
        Frames per second.
    seq_length : int
        Number of frames.
    im_width, im_height : int
        Image size in pixels.
    im_ext : str
        Image file extension with its dot (``.jpg``).
    """

    name: str
    im_dir: str = "img1"
    frame_rate: float = 25.0
    seq_length: int = 0
    im_width: int = 0
    im_height: int = 0
    im_ext: str = ".jpg"


_SEQINFO_KEYS = {"name": "name", "im_dir": "imDir", "frame_rate": "frameRate",
                 "seq_length": "seqLength", "im_width": "imWidth", "im_height": "imHeight",
                 "im_ext": "imExt"}


def read_seqinfo(path: str | os.PathLike[str]) -> SeqInfo:
    """Read a ``seqinfo.ini`` (keys are case-insensitive; ``name`` is required).

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    ValueError
        When it has no ``[Sequence]`` section, no ``name``, or a non-numeric number (the
        message names the file).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"seqinfo file not found: {path}")
    cp = configparser.ConfigParser(interpolation=None)
    try:
        cp.read(path, encoding="utf-8")
    except configparser.Error as exc:
        raise ValueError(f"{path}: not a valid seqinfo.ini: {exc}") from None
    if not cp.has_section("Sequence"):
        raise ValueError(f"{path}: no [Sequence] section")
    sec = cp["Sequence"]
    if "name" not in sec:
        raise ValueError(f"{path}: [Sequence] has no 'name'")
    kwargs: dict[str, object] = {}
    for field, key in _SEQINFO_KEYS.items():
        if key.lower() not in sec:
            continue
        raw = sec[key.lower()].strip()
        try:
            if field == "frame_rate":
                kwargs[field] = float(raw)
            elif field in ("seq_length", "im_width", "im_height"):
                kwargs[field] = int(raw)
            else:
                kwargs[field] = raw
        except ValueError:
            raise ValueError(f"{path}: [Sequence] {key} = {raw!r} is not a number") from None
    return SeqInfo(**kwargs)  # type: ignore[arg-type]


def write_seqinfo(path: str | os.PathLike[str], info: SeqInfo) -> Path:
    """Write ``info`` as a ``seqinfo.ini`` with MOTChallenge's camelCase keys, atomically."""
    cp = configparser.ConfigParser(interpolation=None)
    cp.optionxform = str  # type: ignore[assignment,method-assign]  # keep imDir, frameRate...
    rate = info.frame_rate
    cp["Sequence"] = {
        key: (f"{rate:.10g}" if field == "frame_rate" else str(getattr(info, field)))
        for field, key in _SEQINFO_KEYS.items()
    }
    buf = io.StringIO()
    cp.write(buf, space_around_delimiters=False)
    return atomic_write_text(path, buf.getvalue())
