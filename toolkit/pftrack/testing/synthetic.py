"""A small seeded synthetic scene for the conformance kit: frames, ground-truth boxes, targets and
detections, so a component can be exercised without any data file.

The scene is a noisy grey gradient (160 x 120 px by default) crossed by three uniformly coloured
rectangles (blue, red and purple, like the colour paper's walkers) moving in straight lines.
Everything is drawn from ``numpy.random.default_rng(seed)``: the same seed gives the same pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pftrack.contracts.components import DetectionMatch, Detections, Frame, Target

__all__ = ["SyntheticScene", "synthetic_scene", "target_from_box"]

# BGR (OpenCV order): blue, red, purple torsos
_COLOURS_BGR = np.array([[200, 60, 30], [40, 40, 210], [160, 40, 140]], dtype=np.uint8)


@dataclass
class SyntheticScene:
    """Frames and ground truth of the synthetic scene.

    Attributes
    ----------
    frames : list of Frame
        ``n_frames`` BGR uint8 frames, indices 1, 2, ... (MOTChallenge style), 25 fps.
    boxes_by_frame : dict of int -> ndarray, shape (3, 4)
        Ground-truth boxes (left, top, width, height) in pixels of the three objects per frame
        index, object order fixed.
    """

    frames: list[Frame]
    boxes_by_frame: dict[int, np.ndarray]

    @property
    def size_wh(self) -> tuple[int, int]:
        return self.frames[0].size_wh

    def detections(self, frame_index: int, extra_box: bool = True) -> Detections:
        """The ground-truth boxes of a frame as detections (scores 0.9, 0.8, 0.7), plus one
        spurious box away from every object (score 0.2) when ``extra_box``."""
        b = self.boxes_by_frame[frame_index]
        scores = [0.9, 0.8, 0.7][: len(b)]
        if extra_box:
            w = self.size_wh[0]
            b = np.vstack([b, [w - 22.0, 2.0, 20.0, 20.0]])
            scores = scores + [0.2]
        return Detections(b.copy(), np.asarray(scores, dtype=np.float64))

    def targets(self, frame_index: int | None = None, state_dim: int = 2) -> list[Target]:
        """One :class:`Target` per object at ``frame_index`` (default: the first frame), ids 1..3.

        the target carries ``observation_px`` (the true box centre) and ``detection``
        (the true box as the tracker's associator would put it), so likelihoods that read either
        find them.
        """
        k = self.frames[0].index if frame_index is None else frame_index
        return [target_from_box(box, i + 1, state_dim=state_dim, detection_index=i)
                for i, box in enumerate(self.boxes_by_frame[k])]


def target_from_box(box_xywh_px: np.ndarray, target_id: int = 1, state_dim: int = 2,
                    detection_index: int | None = 0, size: float = 1.0) -> Target:
    """A :class:`Target` at an image box, its state the box centre (pixels) padded with zeros to
    ``state_dim``, as an image-plane tracker would make it."""
    b = np.asarray(box_xywh_px, dtype=np.float64).reshape(4)
    centre = b[:2] + 0.5 * b[2:]
    state = np.zeros(max(int(state_dim), 2))
    state[:2] = centre
    t = Target(id=int(target_id), state=state, box_xywh_px=b.copy(),
               extent=np.ones_like(state), frames_tracked=3, size_m=float(size), age=3)
    t.observation_px = centre.copy()
    if detection_index is not None:
        t.detection = DetectionMatch(b.copy(), 0.9, int(detection_index))
    return t


def synthetic_scene(seed: int = 0, n_frames: int = 4, size_wh: tuple[int, int] = (160, 120),
                    noise_sigma: float = 6.0) -> SyntheticScene:
    """Build the seeded synthetic scene (see the module docstring)."""
    w, h = int(size_wh[0]), int(size_wh[1])
    if w < 64 or h < 48 or n_frames < 1:
        raise ValueError(f"synthetic_scene: size must be at least 64 x 48 px and n_frames >= 1, "
                         f"got {size_wh}, {n_frames}")
    rng = np.random.default_rng(seed)
    gx = np.linspace(60.0, 120.0, w)[None, :, None]
    gy = np.linspace(0.0, 40.0, h)[:, None, None]
    base = np.broadcast_to(gx + gy, (h, w, 3))
    # three objects: start boxes and per-frame velocity (px)
    start = np.array([[0.10 * w, 0.30 * h, 0.14 * w, 0.30 * h],
                      [0.55 * w, 0.20 * h, 0.12 * w, 0.35 * h],
                      [0.35 * w, 0.55 * h, 0.13 * w, 0.28 * h]])
    vel = np.array([[3.0, 1.0], [-2.0, 1.5], [2.5, -1.0]])
    frames, boxes = [], {}
    for k in range(n_frames):
        img = base + rng.normal(0.0, noise_sigma, (h, w, 3))
        img = np.clip(np.rint(img), 0, 255).astype(np.uint8)
        b = start.copy()
        b[:, :2] += vel * k
        b = np.round(b)
        for (x, y, bw, bh), c in zip(b.astype(int), _COLOURS_BGR):
            img[max(y, 0):y + bh, max(x, 0):x + bw] = c
        frames.append(Frame(index=k + 1, image=img, time_s=k / 25.0))
        boxes[k + 1] = b
    return SyntheticScene(frames, boxes)
