"""Where the shared real data lives (PETS 2009 S2.L1, the chessboard set).

The project never ships that data; it is read by path: ``$PFTRACK_DATA`` when set, otherwise
``shared/data`` beside the working directory or one of its parents (``../shared/data`` beside the
repository checkout when run from it). Nothing here depends on where pftrack is installed.
"""

from __future__ import annotations

import os
from pathlib import Path


def data_dir() -> Path:
    """The shared data folder: ``$PFTRACK_DATA``, else the first ``shared/data`` folder beside
    the working directory or one of its parents, else ``../shared/data`` (not checked)."""
    env = os.environ.get("PFTRACK_DATA")
    if env:
        return Path(env)
    cwd = Path.cwd().resolve()
    for d in (cwd, *cwd.parents):
        if (d.parent / "shared" / "data").is_dir():
            return d.parent / "shared" / "data"
    return cwd.parent / "shared" / "data"


def data_path(*parts: str) -> Path:
    """A file under :func:`data_dir`; raises FileNotFoundError naming it and the variable."""
    p = data_dir().joinpath(*parts)
    if not p.exists():
        raise FileNotFoundError(
            f"{p} not found: set PFTRACK_DATA to the folder holding pets09/ and chessboard/ "
            "(default: ../shared/data beside the repository)"
        )
    return p


def pets09_files(data: str | os.PathLike[str] | None = None) -> tuple[Path, Path, Path]:
    """PETS 2009 S2.L1's video, ground truth and Tsai camera (``vtest.avi``, ``gt.txt``,
    ``View_001.xml``) in ``data`` (the pets09 folder itself or the folder holding it; default
    :func:`data_dir`'s pets09); FileNotFoundError naming the first file missing."""
    root = Path(data) if data is not None else data_dir() / "pets09"
    if data is not None and (root / "pets09").is_dir():
        root = root / "pets09"
    files = (root / "vtest.avi", root / "gt.txt", root / "View_001.xml")
    for p in files:
        if not p.is_file():
            raise FileNotFoundError(f"{p} not found: set PFTRACK_DATA or --data to the folder "
                                    "holding pets09/")
    return files
