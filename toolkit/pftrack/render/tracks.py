"""Trajectories for drawing: world tracks from MOTChallenge rows, dashes as separate segments.

A trajectory is an (K, 3) float64 array of world positions (metres) in time order; a set of
tracks is ``{track_id: trajectory}``. Nothing here imports pyvista or OpenCV.
"""

from __future__ import annotations

import numpy as np

__all__ = ["dashed_segments", "polyline_length", "tracks_from_mot"]

#: MOTChallenge columns (0-based): frame, id, left, top, width, height, conf/flag, x, y, z.
MOT_WORLD_COLS = (7, 8)


def tracks_from_mot(rows: np.ndarray, world_cols: tuple[int, int] = MOT_WORLD_COLS,
                    source: str = "tracks") -> dict[int, np.ndarray]:
    """World trajectories per id from MOTChallenge rows.

    Parameters
    ----------
    rows : ndarray, shape (M, >= 9)
        MOTChallenge rows; columns ``world_cols`` (0-based, default 7 and 8, i.e. the 8th and
        9th) hold the ground position x, y in metres.
    world_cols : (int, int)
    source : str
        Name used in error messages (e.g. the file path).

    Returns
    -------
    dict of int to ndarray, shape (K, 3)
        Per id, positions (x, y, 0) sorted by frame; rows whose x or y is not finite, or whose
        x, y, z are all -1 (unknown), are skipped. Ids in increasing order.
    """
    rows = np.asarray(rows, dtype=np.float64)
    if rows.ndim != 2 or rows.shape[1] <= max(world_cols):
        raise ValueError(f"{source}: needs world columns {world_cols[0] + 1}-{world_cols[1] + 1} "
                         f"(x, y metres); rows have shape {rows.shape}")
    xy = rows[:, list(world_cols)]
    ok = np.all(np.isfinite(xy), axis=1)
    if rows.shape[1] >= 10 and tuple(world_cols) == MOT_WORLD_COLS:
        # MOTChallenge's marker of an unknown world position: x, y and z all -1
        ok &= ~np.all(rows[:, 7:10] == -1, axis=1)
    if len(rows) and not ok.any():
        raise ValueError(f"{source}: no finite, known (not -1) world positions in columns "
                         f"{world_cols[0] + 1}-{world_cols[1] + 1}")
    rows, xy = rows[ok], xy[ok]
    order = np.lexsort((rows[:, 0], rows[:, 1]))  # by id, then frame
    rows, xy = rows[order], xy[order]
    ids, starts = np.unique(rows[:, 1].astype(np.int64), return_index=True)
    pts = np.column_stack([xy, np.zeros(len(xy))])
    return {int(i): p for i, p in zip(ids, np.split(pts, starts[1:]))}


def polyline_length(points: np.ndarray) -> float:
    """Length of a polyline (K, D), same unit as the points."""
    p = np.asarray(points, dtype=np.float64)
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if len(p) > 1 else 0.0


def dashed_segments(points: np.ndarray, dash: float, gap: float | None = None) -> np.ndarray:
    """Cut a polyline into dashes, each dash its own straight segment (VTK has no dashed lines).

    Parameters
    ----------
    points : ndarray, shape (K, 3)
        The polyline (world metres).
    dash, gap : float
        Dash and gap lengths along the line (metres); ``gap`` defaults to ``dash``.

    Returns
    -------
    ndarray, shape (E, 2, 3)
        Segments. A dash that spans a vertex is split there so it follows the curve. Vectorised
        with ``np.interp`` over arc length.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    gap = dash if gap is None else gap
    if dash <= 0 or gap < 0:
        raise ValueError(f"dashed_segments: dash must be > 0 and gap >= 0, got {dash}, {gap}")
    if len(p) < 2:
        return np.zeros((0, 2, 3))
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    total = s[-1]
    if total <= 0:
        return np.zeros((0, 2, 3))
    period = dash + gap
    starts = np.arange(0.0, total, period)
    ends = np.minimum(starts + dash, total)
    # break points: dash starts/ends plus the vertices inside dashes
    inside = np.searchsorted(starts, s, side="right") - 1
    vert_in_dash = (inside >= 0) & (s > starts[np.maximum(inside, 0)]) & \
        (s < ends[np.maximum(inside, 0)])
    cuts = np.concatenate([starts, ends, s[vert_in_dash]])
    dash_of = np.concatenate([np.arange(len(starts)), np.arange(len(starts)),
                              inside[vert_in_dash]])
    order = np.lexsort((cuts, dash_of))
    cuts, dash_of = cuts[order], dash_of[order]
    xyz = np.column_stack([np.interp(cuts, s, p[:, k]) for k in range(3)])
    same = dash_of[1:] == dash_of[:-1]
    seg = np.stack([xyz[:-1][same], xyz[1:][same]], axis=1)
    keep = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1) > 0
    return seg[keep]
