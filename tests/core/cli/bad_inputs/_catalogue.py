"""Shared pieces of the bad-input catalogue: tiny synthetic inputs and the checks every case
makes (exit code, the message names the culprit, nothing on disk changed)."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

W, H, N_FRAMES, SIDE = 96, 72, 24, 14

CONFIG = """\
name: tiny
state: image
observation: {type: image-box, params: {size_from_box: true}}
motion: {type: random-walk, params: {sigma_px: 2.0}}
likelihood: {type: gaussian, params: {sigma_px: 4.0}}
detector: {type: mog2, params: {min_area_px: 30, warmup_frames: 2, detect_shadows: false}}
associator: {type: hungarian-iou, params: {metric: iou, min_iou: 0.1}}
tracks: {type: births, params: {min_score: 0.0}}
tracker: {n_particles: 40, init_spread: 1.0, max_misses: 3, dt: 1.0}
"""


def square_box(i: int) -> tuple[int, int]:
    """Top-left corner (px) of the square in video frame ``i`` (0-based)."""
    return 10 + 2 * i, 20 + (i % 5)


def frames(n: int = N_FRAMES) -> list[np.ndarray]:
    out = []
    for i in range(n):
        img = np.full((H, W, 3), 60, np.uint8)
        x, y = square_box(i)
        img[y:y + SIDE, x:x + SIDE] = 230
        out.append(img)
    return out


def write_video(path: Path, images: list[np.ndarray] | None = None, fps: float = 10.0,
                fourcc: str = "MJPG") -> Path:
    import cv2

    images = frames() if images is None else images
    h, w = images[0].shape[:2]
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, (w, h))
    assert vw.isOpened(), path
    for img in images:
        vw.write(img)
    vw.release()
    return path


def gt_text(n: int = N_FRAMES) -> str:
    rows = []
    for i in range(n):
        x, y = square_box(i)
        rows.append(f"{i + 1},1,{x},{y},{SIDE},{SIDE},1,-1,-1,-1")
    return "\n".join(rows) + "\n"


def snapshot(*roots: Path) -> dict[str, tuple[str, int]]:
    """Every file under ``roots``: content hash and mtime (ns), to assert nothing changed."""
    out: dict[str, tuple[str, int]] = {}
    for root in roots:
        root = Path(root)
        if root.is_file():
            items = [root]
        elif root.is_dir():
            items = sorted(p for p in root.rglob("*") if p.is_file() or p.is_symlink())
        else:
            items = []
        for p in items:
            try:
                data = p.read_bytes()
            except OSError:
                data = b"<unreadable>"
            out[str(p)] = (hashlib.sha1(data).hexdigest(), os.lstat(p).st_mtime_ns)
        if root.is_dir():
            for d in sorted(p for p in root.rglob("*") if p.is_dir()):
                out[str(d) + "/"] = ("dir", 0)
    return out




def assert_untouched(before: dict, *roots: Path) -> None:
    after = snapshot(*roots)
    assert after == before, {k: (before.get(k), after.get(k)) for k in set(before) | set(after)
                             if before.get(k) != after.get(k)}


def one_line(err: str) -> str:
    """The error line (warnings before it allowed); asserts no traceback."""
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines, "no message on stderr"
    return lines[-1]


def marked_frames(n: int, seed: int = 0) -> list[np.ndarray]:
    """``n`` 112 x 72 frames, each carrying its 1-based number as 7 black/white blocks along the
    top (read back by :func:`read_mark`) above noise (so that every frame costs bytes)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        img = np.full((72, 112, 3), 60, np.uint8)
        for b in range(7):
            img[0:16, b * 16:(b + 1) * 16] = 255 if ((i + 1) >> b) & 1 else 0
        img[40:72] = rng.integers(0, 256, (32, 112, 3), dtype=np.uint8)
        out.append(img)
    return out


def read_mark(img: np.ndarray) -> int:
    g = img[4:12].mean(axis=(0, 2))
    return sum(1 << b for b in range(7) if g[b * 16 + 4:b * 16 + 12].mean() > 128)


def damage_middle(src: Path, dst: Path, fraction: float = 1 / 8, seed: int = 9) -> Path:
    """``src`` with random bytes over ``fraction`` of it from its middle on."""
    data = bytearray(src.read_bytes())
    n = len(data)
    k = int(n * fraction)
    data[n // 2:n // 2 + k] = np.random.default_rng(seed).integers(0, 256, k, dtype=np.uint8
                                                                      ).tobytes()
    dst.write_bytes(bytes(data))
    return dst
