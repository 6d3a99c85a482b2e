"""From one camera's video and pftrack's ``tracks.txt`` to the camera-network paper's tracklets:
each track id becomes a :class:`~pftrack_network.network.Tracklet` holding person images cut out of
the frames, so that the tracklets of several cameras can be linked over a camera network.

Frame numbers follow pftrack's files (MOTChallenge, 1-based): MOT frame N is video frame N - 1.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from pftrack_network.network import Tracklet

__all__ = ["tracklets_from_tracks"]


def tracklets_from_tracks(video: str | os.PathLike[str],
                          tracks: str | os.PathLike[str] | np.ndarray,
                          camera: str, *, fps: float | None = None, t0_s: float = 0.0,
                          images_per_tracklet: int = 8, min_rows: int = 2,
                          min_size_px: int = 8) -> list[Tracklet]:
    """Cut every track's person images out of ``video``.

    Parameters
    ----------
    video : path
        The camera's video (anything OpenCV decodes).
    tracks : path or ndarray (M, 10)
        pftrack's ``tracks.txt`` (MOTChallenge rows: frame, id, left, top, width, height, ...;
        pixels), or the rows themselves.
    camera : str
        The camera's name in the network.
    fps : float, optional
        Frames per second (default: the video's own).
    t0_s : float
        Time of video frame 0 on the network's clock, seconds.
    images_per_tracklet : int
        Images kept per track, evenly spaced over its rows (all when it has fewer).
    min_rows : int
        Tracks with fewer rows are skipped.
    min_size_px : int
        Boxes narrower or lower than this after clipping to the frame are not cut.

    Returns
    -------
    list of Tracklet
        One per track id, sorted by start time; ``t_start_s``/``t_end_s`` are the times of the
        track's first and last rows, ``images`` BGR crops, ``rows`` the track's rows.
    """
    import cv2
    from pftrack.io.mot import FRAME, HEIGHT, ID, LEFT, TOP, WIDTH, read_mot, validate_mot_rows

    video = Path(video)
    if not video.is_file():
        raise FileNotFoundError(f"video not found: {video}")
    if isinstance(tracks, np.ndarray):
        rows = validate_mot_rows(tracks, "tracks")
    else:
        rows = read_mot(tracks)
    if images_per_tracklet < 1 or min_rows < 1:
        raise ValueError("images_per_tracklet and min_rows must be >= 1")
    cap = cv2.VideoCapture(str(video))
    if not cap.isOpened():
        raise ValueError(f"{video}: OpenCV cannot open this video")
    try:
        rate = float(fps) if fps is not None else float(cap.get(cv2.CAP_PROP_FPS))
        if not rate > 0:
            raise ValueError(f"{video}: no frame rate in the file; pass fps=")
        # the rows to cut, per track: evenly spaced over the track
        wanted: dict[int, list[int]] = {}  # video frame -> row indices
        per_id: dict[int, np.ndarray] = {}
        for tid in np.unique(rows[:, ID]).astype(int):
            idx = np.flatnonzero(rows[:, ID] == tid)
            idx = idx[np.argsort(rows[idx, FRAME], kind="stable")]
            if len(idx) < min_rows:
                continue
            per_id[tid] = idx
            take = idx[np.unique(np.linspace(0, len(idx) - 1,
                                             min(images_per_tracklet, len(idx))).round()
                                 .astype(int))]
            for r in take:
                wanted.setdefault(int(rows[r, FRAME]) - 1, []).append(int(r))
        crops: dict[int, np.ndarray] = {}
        last = max(wanted) if wanted else -1
        k = 0
        while k <= last:
            ok, frame = cap.read()
            if not ok:
                raise ValueError(f"{video}: ended at frame {k}, but the tracks need frame "
                                 f"{last} (MOT frame {last + 1})")
            for r in wanted.get(k, ()):
                h, w = frame.shape[:2]
                x0 = int(np.clip(np.floor(rows[r, LEFT]), 0, w))
                y0 = int(np.clip(np.floor(rows[r, TOP]), 0, h))
                x1 = int(np.clip(np.ceil(rows[r, LEFT] + rows[r, WIDTH]), 0, w))
                y1 = int(np.clip(np.ceil(rows[r, TOP] + rows[r, HEIGHT]), 0, h))
                if x1 - x0 >= min_size_px and y1 - y0 >= min_size_px:
                    crops[r] = frame[y0:y1, x0:x1].copy()
            k += 1
    finally:
        cap.release()
    out = []
    for idx in per_id.values():
        images = [crops[r] for r in idx if r in crops]
        if not images:
            continue
        f = rows[idx, FRAME] - 1
        out.append(Tracklet(camera, t0_s + f.min() / rate, t0_s + f.max() / rate, images,
                            rows=rows[idx].copy(), person=None))
    out.sort(key=lambda t: t.t_start_s)
    return out
