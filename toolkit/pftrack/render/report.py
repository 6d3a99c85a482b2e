"""Report pictures of a tracking run: overlay frames and the image trajectories beside a top view
of the ground plane (the soccer paper figures 9-12).

* ``overlay_FRAME.png``: the frame with each track's box and id in its colour, its recent foot
  trail, and the ground truth's boxes in thin grey;
* ``trajectories_FRAME.png``: left, the frame with every track's image trajectory (foot points)
  up to that frame; right, the same trajectories on the ground plane seen from above (world
  metres), estimate solid and ground truth dashed (:func:`pftrack.render.topview.render_topview`).

Rendering knows nothing of filters: it reads MOTChallenge rows only. All files are written
atomically.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from pftrack.geometry.boxes import foot_points
from pftrack.io.images import write_png
from pftrack.render.colours import track_colour_bgr

__all__ = ["draw_overlay", "draw_trajectories", "write_report"]

TOP_W = 760  # top-view width for a 576 px tall frame (room for the legend)


def draw_overlay(image_bgr: np.ndarray, rows: np.ndarray, frame: int, *,
                 gt_rows: np.ndarray | None = None, trail: int = 30,
                 uncertainty: np.ndarray | None = None) -> np.ndarray:
    """The frame with tracks (boxes, ids, foot trails of ``trail`` frames) and ground truth.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8
    rows : ndarray, shape (M, 10)
        Track rows (MOTChallenge), any frames.
    frame : int
        The frame ``image_bgr`` shows (ground-truth numbering).
    uncertainty : ndarray, shape (M, 9), optional
        ``tracks_uncertainty.csv``'s rows, one per row of ``rows``
        (:func:`pftrack.engine.tracker.records_uncertainty`): each box centre's 2-sd ellipse is
        drawn.

    Returns
    -------
    ndarray, shape (H, W, 3), uint8, BGR
    """
    import cv2

    img = image_bgr.copy()
    if uncertainty is not None:
        from pftrack.render.overlay import draw_uncertainty

        sel = rows[:, 0] == frame
        b = rows[sel, 2:6]
        img = draw_uncertainty(img, np.c_[b[:, :2], b[:, :2] + b[:, 2:]],
                               np.asarray(uncertainty)[sel, 2:6], rows[sel, 1])
    if gt_rows is not None:
        for r in gt_rows[gt_rows[:, 0] == frame]:
            x, y, w, h = r[2:6]
            cv2.rectangle(img, (int(x), int(y)), (int(x + w), int(y + h)), (200, 200, 200), 1,
                          cv2.LINE_AA)
    cur = rows[rows[:, 0] == frame]
    for tid in np.unique(cur[:, 1]).astype(int):
        col = track_colour_bgr(int(tid))
        hist = rows[(rows[:, 1] == tid) & (rows[:, 0] <= frame) & (rows[:, 0] > frame - trail)]
        hist = hist[np.argsort(hist[:, 0])]
        pts = foot_points(hist[:, 2:6]).round().astype(np.int32)
        if len(pts) > 1:
            cv2.polylines(img, [pts.reshape(-1, 1, 2)], False, col, 2, cv2.LINE_AA)
        r = cur[cur[:, 1] == tid][0]
        x, y, w, h = r[2:6]
        cv2.rectangle(img, (int(x), int(y)), (int(x + w), int(y + h)), col, 2, cv2.LINE_AA)
        cv2.putText(img, str(tid), (int(x), int(y) - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.55,
                    (255, 255, 255), 3, cv2.LINE_AA)
        cv2.putText(img, str(tid), (int(x), int(y) - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.55, col,
                    1, cv2.LINE_AA)
    cv2.putText(img, f"frame {frame}", (10, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255),
                3, cv2.LINE_AA)
    cv2.putText(img, f"frame {frame}", (10, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (0, 0, 0), 1,
                cv2.LINE_AA)
    return img


def _world_tracks(rows: np.ndarray, frame: int) -> dict[int, np.ndarray]:
    out = {}
    upto = rows[(rows[:, 0] <= frame) & ~np.all(rows[:, 7:10] == -1, axis=1)]
    for tid in np.unique(upto[:, 1]).astype(int):
        r = upto[upto[:, 1] == tid]
        r = r[np.argsort(r[:, 0])]
        out[tid] = np.column_stack([r[:, 7], r[:, 8], np.zeros(len(r))])
    return out


def draw_trajectories(image_bgr: np.ndarray, rows: np.ndarray, frame: int, *,
                      gt_rows: np.ndarray | None = None, title: str = "",
                      uncertainty: np.ndarray | None = None) -> np.ndarray:
    """The soccer paper figures 9-12: image trajectories beside the top view, as one BGR image.

    The top view shows every track's ground positions (world metres) up to ``frame``, and the
    ground truth's (dashed) when given; its height matches the frame's. With ``uncertainty``
    (``tracks_uncertainty.csv``'s rows, one per row of ``rows``) each track's ground position
    in ``frame`` gets its 2-sd covariance ellipse.
    """
    import cv2

    img = image_bgr.copy()
    upto = rows[rows[:, 0] <= frame]
    for tid in np.unique(upto[:, 1]).astype(int):
        r = upto[upto[:, 1] == tid]
        r = r[np.argsort(r[:, 0])]
        pts = foot_points(r[:, 2:6]).round().astype(np.int32)
        col = track_colour_bgr(int(tid))
        if len(pts) > 1:
            cv2.polylines(img, [pts.reshape(-1, 1, 2)], False, col, 2, cv2.LINE_AA)
        if r[-1, 0] == frame:
            x, y, w, h = r[-1, 2:6]
            cv2.rectangle(img, (int(x), int(y)), (int(x + w), int(y + h)), col, 1, cv2.LINE_AA)
            cv2.putText(img, str(tid), (int(x), int(y) - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.5, col,
                        1, cv2.LINE_AA)
    H = img.shape[0]
    tracks = _world_tracks(rows, frame)
    gt_tracks = _world_tracks(gt_rows, frame) if gt_rows is not None else {}
    top = None
    if tracks or gt_tracks:
        # pyvista is imported only when a top view is drawn (the report writer is registered
        # when the host loads the plugins)
        from pftrack.render.topview import render_topview

        every = [t for t in tracks.values()] + [t for t in gt_tracks.values()]
        allp = np.concatenate(every)
        lo, hi = allp.min(axis=0), allp.max(axis=0)
        size = (TOP_W * H // 576, H)
        label = f"{title} top view, frame {frame}".strip()
        ellipses = {}
        if uncertainty is not None:
            u = np.asarray(uncertainty)
            for r, c in zip(rows[rows[:, 0] == frame], u[rows[:, 0] == frame]):
                cov = np.array([[c[6], c[7]], [c[7], c[8]]])
                if np.all(np.isfinite(cov)) and not np.all(r[7:10] == -1):
                    ellipses[int(r[1])] = (r[7:9], cov)
        rgb = render_topview(tracks=tracks, ground_truth=gt_tracks, size_wh=size, title=label,
                             bounds_m=np.array([lo, hi]), legend=False, ellipses=ellipses)
        top = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
        # the ground truth's line only when there is one (a run without --gt draws none)
        note = "solid: tracks (track ids)" + ("   dashed: ground truth (gt ids)"
                                              if gt_tracks else "")
        cv2.putText(top, note, (60, 44), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (60, 60, 60), 1, cv2.LINE_AA)
    if top is None:
        top = np.full((H, TOP_W * H // 576, 3), 255, np.uint8)
    return np.concatenate([img, cv2.resize(top, (top.shape[1], H))], axis=1)


def write_report(out_dir: str | os.PathLike[str], rows: np.ndarray,
                 frames: Mapping[int, np.ndarray], *,
                 gt_rows: np.ndarray | None = None, title: str = "",
                 uncertainty: np.ndarray | None = None) -> list[Path]:
    """Write ``overlay_FRAME.png`` and ``trajectories_FRAME.png`` for each kept frame;
    with ``uncertainty`` (``tracks_uncertainty.csv``'s rows, one per row of ``rows``) the
    tracks' 2-sd ellipses too (box centres; ground positions in the top view).

    Returns the paths written.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = np.asarray(rows, dtype=np.float64).reshape(-1, 10)
    written = []
    for f in sorted(frames):
        img = frames[f]
        p = out / f"overlay_{f:06d}.png"
        write_png(p, draw_overlay(img, rows, f, gt_rows=gt_rows, uncertainty=uncertainty))
        written.append(p)
        p = out / f"trajectories_{f:06d}.png"
        write_png(p, draw_trajectories(img, rows, f, gt_rows=gt_rows, title=title,
                                       uncertainty=uncertainty))
        written.append(p)
    return written
