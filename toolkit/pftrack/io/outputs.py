"""Output paths checked before work starts, and a run's outputs written as one unit.

:func:`check_output_dir`, :func:`check_output_file` and :func:`check_input_file` raise at once
(before the first frame) for what would otherwise fail after a long run: an output folder that
is a regular file, lies under one, or cannot be written; an input that is missing, a folder or
unreadable. Their errors name the option (``--out``, ``--gt``) and the path.

:class:`OutputSet` writes a run's outputs (``tracks.txt``, ``metrics.json``, ``report/``) into a
staging folder beside them and then moves them into place together, removing the outputs of an
earlier run that this run did not produce (an old ``metrics.json`` beside new tracks). A run
that fails or is killed before the move leaves the earlier outputs untouched; its staging folder
and temporary files (``.NAME.*.tmp*`` of :mod:`pftrack.io.atomic`) are removed by the next run
into the same folder (:func:`clean_stale`). The move itself is journalled: a run killed during
it is completed by the next start, so the folder never mixes two runs' outputs.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import threading
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

__all__ = [
    "OutputSet",
    "check_input_file",
    "check_output_dir",
    "check_output_file",
    "check_output_tree",
    "clean_stale",
    "read_track_uncertainty",
    "write_track_uncertainty",
]

STAGING_PREFIX = ".pftrack-staging-"
_JOURNAL = "COMMIT.json"


def _file_ancestor(path: Path) -> Path | None:
    """The first existing ancestor of ``path`` (itself excluded) that is not a folder."""
    for parent in reversed(path.absolute().parents):
        if parent.exists() and not parent.is_dir():
            return parent
    return None


def _nearest_existing(path: Path) -> Path:
    p = path.absolute()
    while not p.exists():
        p = p.parent
    return p


def check_output_dir(path: str | os.PathLike[str], option: str = "--out") -> Path:
    """Raise unless ``path`` is, or can be created as, a writable folder.

    Raises
    ------
    NotADirectoryError
        ``path`` is a regular file, or lies under one.
    PermissionError
        The folder (or the existing folder it would be created in) is not writable.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise NotADirectoryError(f"{option} {p}: is a file, not a folder")
    bad = _file_ancestor(p)
    if bad is not None:
        raise NotADirectoryError(f"{option} {p}: {bad} is a file, not a folder")
    base = _nearest_existing(p)
    if not os.access(base, os.W_OK | os.X_OK):
        raise PermissionError(f"{option} {p}: folder {base} is not writable")
    return p


def check_output_tree(path: str | os.PathLike[str], outputs: dict[str, str],
                      option: str = "--out") -> Path:
    """:func:`check_output_dir`, and every existing output of ``outputs`` (name -> ``"file"``
    or ``"dir"``) of the right kind, so that replacing them cannot fail half-way."""
    p = check_output_dir(path, option)
    for name, kind in outputs.items():
        q = p / name
        if kind == "dir" and q.exists() and not q.is_dir():
            raise NotADirectoryError(f"{option} {p}: {q} is a file, where the run writes a "
                                     "folder; move it away")
        if kind == "file" and q.is_dir():
            raise IsADirectoryError(f"{option} {p}: {q} is a folder, where the run writes a "
                                    "file; move it away")
    return p


def check_output_file(path: str | os.PathLike[str], option: str = "--out") -> Path:
    """Raise unless a file can be written at ``path`` (not a folder, its folder writable)."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{option} {p}: is a folder, expected a file name")
    if p.exists() and not os.access(p.parent, os.W_OK | os.X_OK):
        raise PermissionError(f"{option} {p}: folder {p.parent} is not writable")
    check_output_dir(p.parent, option=f"{option} {p}: folder")
    return p


def check_input_file(path: str | os.PathLike[str], option: str) -> Path:
    """Raise unless ``path`` is an existing, readable regular file."""
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{option} {p} not found")
    if p.is_dir():
        raise IsADirectoryError(f"{option} {p}: is a folder, expected a file")
    if not os.access(p, os.R_OK):
        raise PermissionError(f"{option} {p}: not readable")
    return p


# --------------------------------------------------------------------------------------------
# The output unit
# --------------------------------------------------------------------------------------------


def _remove(p: Path) -> None:
    if p.is_dir() and not p.is_symlink():
        shutil.rmtree(p, ignore_errors=True)
    elif p.exists() or p.is_symlink():
        p.unlink(missing_ok=True)


def _roll_forward(staging: Path, out: Path) -> None:
    """Finish a journalled move that a killed run began: every staged output into place,
    every output it did not produce removed."""
    journal = json.loads((staging / _JOURNAL).read_text())
    for name in journal["names"]:
        new = staging / "new" / name
        if new.exists():
            _remove(out / name)
            os.replace(new, out / name)
        elif name not in journal["produced"]:
            _remove(out / name)


def clean_stale(out_dir: str | os.PathLike[str]) -> list[Path]:
    """Remove what killed runs left in ``out_dir``: staging folders (a journalled move is
    completed first) and the temporary files of :mod:`pftrack.io.atomic` (``.*.tmp*``), in the
    folder and its ``report/``. Returns what was removed."""
    out = Path(out_dir)
    removed: list[Path] = []
    if not out.is_dir():
        return removed
    for staging in sorted(out.glob(STAGING_PREFIX + "*")):
        if (staging / _JOURNAL).is_file():
            try:
                _roll_forward(staging, out)
            except (OSError, ValueError, KeyError):
                pass
        _remove(staging)
        removed.append(staging)
    for folder in (out, out / "report"):
        if folder.is_dir():
            for tmp in folder.glob(".*.tmp*"):
                _remove(tmp)
                removed.append(tmp)
    return removed


@contextmanager
def _no_interrupts() -> Iterator[None]:
    """SIGINT / SIGTERM held back while the outputs are moved (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    sigs = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


class OutputSet:
    """The outputs of one run in ``out_dir``, replaced together.

    Parameters
    ----------
    out_dir : path
        The run's output folder (checked with :func:`check_output_dir`; stale staging folders
        and temporary files of killed runs are removed on creation).
    names : iterable of str
        Every output name a run of this kind owns (files or folders directly in ``out_dir``);
        those this run does not produce are removed when it commits.

    Examples
    --------
    >>> with OutputSet(out, ["tracks.txt", "metrics.json", "report"]) as o:  # doctest: +SKIP
    ...     write_mot(o.path("tracks.txt"), rows)
    """

    def __init__(self, out_dir: str | os.PathLike[str], names: Iterable[str]) -> None:
        self.out = check_output_dir(out_dir)
        self.names = list(names)
        self.out.mkdir(parents=True, exist_ok=True)
        clean_stale(self.out)
        self.staging = self.out / f"{STAGING_PREFIX}{os.getpid()}"
        _remove(self.staging)
        (self.staging / "new").mkdir(parents=True)

    def path(self, name: str) -> Path:
        """Where to write output ``name`` (inside the staging folder)."""
        if name not in self.names:
            raise ValueError(f"output {name!r} is not one of this run's outputs {self.names}")
        return self.staging / "new" / name

    def commit(self) -> Path:
        """Move every staged output into place and remove the owned outputs not produced."""
        produced = [n for n in self.names if (self.staging / "new" / n).exists()]
        with _no_interrupts():
            journal = self.staging / _JOURNAL
            tmp = journal.with_suffix(".tmp")
            tmp.write_text(json.dumps({"names": self.names, "produced": produced}))
            os.replace(tmp, journal)
            _roll_forward(self.staging, self.out)
            _remove(self.staging)
        return self.out

    def abort(self) -> None:
        """Drop the staged outputs; the earlier ones stay."""
        _remove(self.staging)

    def __enter__(self) -> "OutputSet":  # noqa: UP037
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.commit()
            return
        self.abort()
        if isinstance(exc, OSError) and exc.filename is None and exc.errno is not None:
            # a write that failed without naming its file (a full disk): name the folder
            raise OSError(exc.errno, exc.strerror or str(exc), str(self.out)) from exc


UNCERTAINTY_HEADER = ("frame,id,x1_sd,y1_sd,x2_sd,y2_sd,world_var_x,world_cov_xy,world_var_y")


def write_track_uncertainty(path: str | os.PathLike[str], rows: Any) -> Path:
    """Write the tracks' uncertainty beside ``tracks.txt`` (``tracks_uncertainty.csv``),
    atomically: a header line, then one line per row of ``tracks.txt`` in the same order
    (frame, id: the join key), the standard deviations of the box's x1, y1, x2, y2 in pixels
    and the ground position's covariance var_x, cov_xy, var_y in m^2 (``nan`` without a
    camera). A side file keeps ``tracks.txt`` the 10 columns MOTChallenge readers expect."""
    import io

    import numpy as np

    from pftrack.io.atomic import atomic_write_text

    arr = np.asarray(rows, dtype=np.float64).reshape(-1, 9)
    buf = io.StringIO()
    buf.write(UNCERTAINTY_HEADER + "\n")
    np.savetxt(buf, arr, fmt=["%d", "%d"] + ["%.6g"] * 7, delimiter=",")
    return atomic_write_text(path, buf.getvalue())


def read_track_uncertainty(path: str | os.PathLike[str]) -> Any:
    """The rows (M, 9) :func:`write_track_uncertainty` wrote. Raises ValueError naming the
    file when its header is not that file's."""
    import numpy as np

    p = Path(path)
    text = p.read_text()
    head, _, body = text.partition("\n")
    if head.strip() != UNCERTAINTY_HEADER:
        raise ValueError(f"{p}: not a tracks_uncertainty.csv (header {head.strip()!r}, "
                         f"expected {UNCERTAINTY_HEADER!r})")
    if not body.strip():
        return np.zeros((0, 9))
    import io

    return np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2)
