"""Report pictures for the colour experiments, drawn with OpenCV (no matplotlib): frames with
boxes and particles, image-plane trajectories, and line charts (per-frame error curves).

Every function returns a BGR ``uint8`` image; :func:`pftrack.io.images.write_png` writes one
atomically.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import cv2
import numpy as np

__all__ = [
    "WALKER_COLOURS_BGR",
    "draw_frame",
    "draw_trajectories",
    "frames_montage",
    "id_colour",
    "label",
    "likelihood_map",
    "likelihood_maps",
    "line_chart",
    "montage",
]

_PALETTE_BGR = [(180, 119, 31), (14, 127, 255), (44, 160, 44), (40, 39, 214), (189, 103, 148),
                (75, 86, 140), (194, 119, 227), (127, 127, 127), (34, 189, 188), (207, 190, 23)]
_FONT = cv2.FONT_HERSHEY_SIMPLEX


def id_colour(track_id: int, named: Mapping[int, tuple[int, int, int]] | None = None,
              ) -> tuple[int, int, int]:
    """BGR colour of a track id: ``named[id]`` if given, else the project's track palette."""
    if named and track_id in named:
        return tuple(int(c) for c in named[track_id])  # type: ignore[return-value]
    try:
        from pftrack.render.colours import track_colour_bgr
    except ImportError:  # the palette module is optional here
        return _PALETTE_BGR[int(track_id) % len(_PALETTE_BGR)]
    return track_colour_bgr(int(track_id))


def label(img: np.ndarray, text: str, org: tuple[int, int], scale: float = 0.45,
          colour: tuple[int, int, int] = (255, 255, 255), thickness: int = 1) -> None:
    """Text with a dark outline, readable on any background (in place)."""
    cv2.putText(img, text, org, _FONT, scale, (0, 0, 0), thickness + 2, cv2.LINE_AA)
    cv2.putText(img, text, org, _FONT, scale, colour, thickness, cv2.LINE_AA)


def _box(img: np.ndarray, box: Sequence[float], colour, thickness: int = 1) -> None:
    x, y, w, h = (float(v) for v in box)
    cv2.rectangle(img, (round(x), round(y)), (round(x + w) - 1, round(y + h) - 1),
                  colour, thickness, cv2.LINE_AA)


def draw_frame(image: np.ndarray, track_rows: np.ndarray, *,
               particles: Mapping[int, np.ndarray] | None = None,
               gt_rows: np.ndarray | None = None,
               colours: Mapping[int, tuple[int, int, int]] | None = None,
               names: Mapping[int, str] | None = None, scale: int = 1,
               title: str | None = None, max_particles: int = 400) -> np.ndarray:
    """One frame with the estimates (thick boxes in each id's colour), the ground truth (thin
    white boxes) and the particles (dots, at most ``max_particles`` per target).

    Parameters
    ----------
    image : ndarray (H, W, 3) uint8, BGR
    track_rows, gt_rows : MOT rows of this frame
    particles : {id: (N, >=2) states}, box centres in px
    scale : int
        Nearest-neighbour enlargement (small synthetic frames read better at 2x).
    """
    img = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST) \
        if scale != 1 else image.copy()
    s = float(scale)
    if gt_rows is not None:
        for g in np.asarray(gt_rows, float).reshape(-1, 10):
            _box(img, g[2:6] * s, (255, 255, 255), 1)
    for tid, p in (particles or {}).items():
        col = id_colour(tid, colours)
        pts = np.asarray(p, float)[:, :2]
        if len(pts) > max_particles:
            pts = pts[np.linspace(0, len(pts) - 1, max_particles).astype(int)]
        for x, y in np.round(pts * s).astype(int):
            cv2.circle(img, (int(x), int(y)), max(1, scale // 2), (0, 255, 255), -1)
            cv2.circle(img, (int(x), int(y)), max(1, scale // 2) + 1, col, 1)
    for r in np.asarray(track_rows, float).reshape(-1, 10):
        tid = int(r[1])
        col = id_colour(tid, colours)
        _box(img, r[2:6] * s, col, 2)
        text = names.get(tid, str(tid)) if names else str(tid)
        label(img, text, (int(r[2] * s), max(int(r[3] * s) - 4, 10)), 0.4 * max(1, scale / 1.5),
              col)
    if title:
        label(img, title, (6, 18), 0.5 * max(1, scale / 1.5))
    return img


def draw_trajectories(background: np.ndarray, track_rows: np.ndarray,
                      gt_rows: np.ndarray | None = None, *,
                      colours: Mapping[int, tuple[int, int, int]] | None = None,
                      names: Mapping[int, str] | None = None, scale: int = 2,
                      title: str | None = None) -> np.ndarray:
    """Image-plane trajectories of the box centres over a faded ``background``: estimates as
    thick lines in each id's colour, ground truth as thin dark lines on top, start (circle) and
    end (square) marked."""
    bg = cv2.resize(background, None, fx=scale, fy=scale, interpolation=cv2.INTER_LINEAR)
    img = cv2.addWeighted(bg, 0.45, np.full_like(bg, 255), 0.55, 0)
    s = float(scale)

    def centres(rows, tid):
        r = rows[rows[:, 1] == tid]
        r = r[np.argsort(r[:, 0], kind="stable")]
        return (r[:, 2:4] + r[:, 4:6] / 2) * s

    t = np.asarray(track_rows, float).reshape(-1, 10)
    for tid in np.unique(t[:, 1]).astype(int):
        c = centres(t, tid)
        col = id_colour(tid, colours)
        cv2.polylines(img, [np.round(c).astype(np.int32)], False, col, 2, cv2.LINE_AA)
        p0, p1 = np.round(c[0]).astype(int), np.round(c[-1]).astype(int)
        cv2.circle(img, tuple(int(v) for v in p0), 5, col, -1, cv2.LINE_AA)
        cv2.rectangle(img, (int(p1[0]) - 4, int(p1[1]) - 4), (int(p1[0]) + 4, int(p1[1]) + 4),
                      col, -1)
        text = names.get(tid, str(tid)) if names else str(tid)
        label(img, text, (int(p0[0]) + 7, int(p0[1]) - 7), 0.5, col)
    if gt_rows is not None:  # on top, thin, so that both show where they coincide
        g = np.asarray(gt_rows, float).reshape(-1, 10)
        for tid in np.unique(g[:, 1]).astype(int):
            c = centres(g, tid)
            cv2.polylines(img, [np.round(c).astype(np.int32)], False, (40, 40, 40), 1,
                          cv2.LINE_AA)
    y = img.shape[0] - 10
    label(img, "thick: estimate   thin dark: ground truth   o start   # end", (8, y), 0.45)
    if title:
        label(img, title, (8, 20), 0.55)
    return img


def _nice_ticks(lo: float, hi: float, n: int = 5) -> np.ndarray:
    span = max(hi - lo, 1e-9)
    raw = span / n
    mag = 10 ** np.floor(np.log10(raw))
    step = min((m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw), default=10 * mag)
    return np.arange(np.ceil(lo / step) * step, hi + 1e-9, step)


def line_chart(series: Sequence[tuple[str, np.ndarray, np.ndarray, tuple[int, int, int], int]],
               *, size_wh: tuple[int, int] = (760, 380), title: str = "", xlabel: str = "",
               ylabel: str = "", ymax: float | None = None) -> np.ndarray:
    """A line chart: ``series`` of ``(name, x, y, bgr, thickness)``, with axes, ticks, a
    legend (top right), the title and the y label above the plot, the x label below."""
    w, h = size_wh
    img = np.full((h, w, 3), 255, np.uint8)
    left, right, top, bottom = 62, 16, 44, 46
    pw, ph = w - left - right, h - top - bottom
    xs = np.concatenate([np.asarray(s[1], float) for s in series]) if series else np.zeros(1)
    ys = np.concatenate([np.asarray(s[2], float) for s in series]) if series else np.zeros(1)
    ys = ys[np.isfinite(ys)]
    x0, x1 = float(np.min(xs)), float(np.max(xs))
    if x1 <= x0:
        x1 = x0 + 1
    y0 = 0.0
    y1 = float(ymax) if ymax is not None else (float(np.max(ys)) * 1.08 if len(ys) else 1.0)
    y1 = max(y1, 1e-6)

    def px(x, y):
        return (left + (np.asarray(x) - x0) / (x1 - x0) * pw,
                top + ph - (np.clip(np.asarray(y), y0, y1) - y0) / (y1 - y0) * ph)

    for t in _nice_ticks(y0, y1):
        _, yy = px(x0, t)
        cv2.line(img, (left, int(yy)), (left + pw, int(yy)), (228, 228, 228), 1)
        cv2.putText(img, f"{t:g}", (4, int(yy) + 4), _FONT, 0.4, (60, 60, 60), 1, cv2.LINE_AA)
    for t in _nice_ticks(x0, x1, 8):
        xx, _ = px(t, y0)
        cv2.line(img, (int(xx), top + ph), (int(xx), top + ph + 4), (60, 60, 60), 1)
        cv2.putText(img, f"{t:g}", (int(xx) - 10, top + ph + 18), _FONT, 0.4, (60, 60, 60), 1,
                    cv2.LINE_AA)
    cv2.rectangle(img, (left, top), (left + pw, top + ph), (90, 90, 90), 1)
    for _name, x, y, col, thick in series:
        px_, py_ = px(x, y)
        pts = np.column_stack([px_, py_])[np.isfinite(np.asarray(y, float))]
        if len(pts) > 1:
            cv2.polylines(img, [np.round(pts).astype(np.int32)], False, col, int(thick),
                          cv2.LINE_AA)
    # legend
    width = max((cv2.getTextSize(s[0], _FONT, 0.4, 1)[0][0] for s in series), default=0)
    lx = left + pw - width - 44
    ly = top + 14
    for name, _, _, col, thick in series:
        cv2.line(img, (lx, ly - 4), (lx + 28, ly - 4), col, int(thick), cv2.LINE_AA)
        cv2.putText(img, name, (lx + 34, ly), _FONT, 0.4, (30, 30, 30), 1, cv2.LINE_AA)
        ly += 16
    cv2.putText(img, title, (left, 18), _FONT, 0.5, (20, 20, 20), 1, cv2.LINE_AA)
    cv2.putText(img, ylabel, (4, top - 8), _FONT, 0.42, (40, 40, 40), 1, cv2.LINE_AA)
    cv2.putText(img, xlabel, (left + pw // 2 - 4 * len(xlabel), h - 8), _FONT, 0.45,
                (40, 40, 40), 1, cv2.LINE_AA)
    return img


def montage(images: Sequence[np.ndarray], cols: int = 2, gap: int = 4) -> np.ndarray:
    """Images of equal size in a grid, white gaps."""
    if not images:
        raise ValueError("montage: no images")
    h, w = images[0].shape[:2]
    rows = -(-len(images) // cols)
    out = np.full((rows * h + (rows - 1) * gap, cols * w + (cols - 1) * gap, 3), 255, np.uint8)
    for k, im in enumerate(images):
        r, c = divmod(k, cols)
        if im.shape[:2] != (h, w):
            im = cv2.resize(im, (w, h), interpolation=cv2.INTER_AREA)
        out[r * (h + gap):r * (h + gap) + h, c * (w + gap):c * (w + gap) + w] = im
    return out


def _diverging_lut() -> np.ndarray:
    t = np.linspace(-1.0, 1.0, 256)
    lut = np.empty((256, 3), np.float64)
    neg = t < 0
    # blue (negative) -> white (0) -> red (positive), BGR
    lut[neg] = np.column_stack([np.full(neg.sum(), 255.0), 255 * (1 + t[neg]),
                                255 * (1 + t[neg])])
    lut[~neg] = np.column_stack([255 * (1 - t[~neg]), 255 * (1 - t[~neg]),
                                 np.full((~neg).sum(), 255.0)])
    return lut.astype(np.uint8)


def likelihood_map(likelihood, frame_bgr: np.ndarray, target_id: int, part: int = 0,
                   limit: float = 8.0) -> np.ndarray:
    """What a cross-entropy likelihood adds up: the per-pixel value of one target (``log q`` for
    ``cross-entropy``, ``log q / h_back`` for ``cross-entropy-bg``, of stripe ``part``) over a
    whole frame, red where a pixel looks like the target, blue where it looks like background
    (clipped to +-``limit``). Call after ``begin_frame`` on that frame."""
    table = likelihood.values_.get(target_id) if hasattr(likelihood, "values_") else None
    if table is None:
        raise ValueError(f"likelihood map: no per-pixel table for target {target_id}; call "
                         "init_target and begin_frame of a cross-entropy likelihood first")
    v = np.asarray(table[part], float)[likelihood.binner_(frame_bgr)]
    idx = np.clip((v / limit + 1.0) * 127.5, 0, 255).astype(np.uint8)
    return _diverging_lut()[idx]


#: Drawing colours of the walkers (BGR), brighter than their torsos so boxes stand out.
WALKER_COLOURS_BGR = {1: (255, 140, 40), 2: (40, 40, 255), 3: (230, 60, 220)}


def frames_montage(frames, gt_rows: np.ndarray, indices, *, names=None, colours=None,
                   scale: int = 2, cols: int | None = None) -> np.ndarray:
    """The frames numbered ``indices`` with their ground-truth boxes, side by side."""
    wanted = {int(i) for i in indices}
    gt = np.asarray(gt_rows, float).reshape(-1, 10)
    panels = [draw_frame(f.image, gt[gt[:, 0] == f.index], colours=colours or WALKER_COLOURS_BGR,
                         names=names, scale=scale, title=f"frame {f.index}")
              for f in frames if f.index in wanted]
    return montage(panels, cols=cols or len(panels))


def likelihood_maps(likelihood, frame, boxes: Mapping[int, np.ndarray]) -> np.ndarray:
    """:func:`likelihood_map` of each target started from ``boxes`` ({id: xywh px}) in
    ``frame``, side by side (the likelihood is set up on that frame)."""
    from pftrack.contracts.components import Target

    targets = [Target(id=int(tid), state=np.asarray(b[:2], float) + np.asarray(b[2:], float) / 2,
                      box_xywh_px=np.asarray(b, float)) for tid, b in boxes.items()]
    for t in targets:
        likelihood.init_target(frame, t)
    likelihood.begin_frame(frame, targets)
    maps = [likelihood_map(likelihood, frame.image, t.id) for t in targets]
    for im, t in zip(maps, targets):
        _box(im, t.box_xywh_px, (0, 0, 0), 1)
        label(im, f"target {t.id}", (6, 16))
    return montage(maps, cols=len(maps))
