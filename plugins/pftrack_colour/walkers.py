"""The ``walkers`` scene: a synthetic sequence like the colour paper's test video (its Fig. 4).

360 x 240 px, 180 frames, three people with blue, red and purple torsos walking freely over a
static textured plaza, crossing and occluding each other (the nearer person, lower in the image,
is drawn on top). Heads and legs are in neutral colours; the plaza has a brick wall, flower beds,
a bench and posters whose colours are close to the torsos', so that a likelihood that ignores the
background is drawn to them. Every frame gets a little Gaussian pixel noise.

Ground truth: MOTChallenge rows, one per person and frame, the 30 x 30 px torso box (the paper's
tracking box; its centre is the torso's centre), ids 1 (blue), 2 (red), 3 (purple).

Everything random comes from ``np.random.default_rng(seed)``: the layout (plaza, paths, gait)
first, then a noise generator seeded from it, so the same seed gives bit-identical frames and
streaming twice gives the same frames.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import cv2
import numpy as np
from pftrack.contracts.components import Frame, Param, Scene

__all__ = ["TARGET_NAMES", "TORSO_COLOURS_BGR", "WalkersScene", "torso_visibility"]

#: Torso colours (BGR) of the three people.
TORSO_COLOURS_BGR: dict[str, tuple[int, int, int]] = {
    "blue": (196, 96, 36),
    "red": (44, 40, 200),
    "purple": (150, 46, 138),
}
#: Ground-truth id -> name.
TARGET_NAMES: dict[int, str] = {1: "blue", 2: "red", 3: "purple"}

TORSO_PX = 30  # torso (and tracking box) side, pixels
WALK_FRAMES = 180  # the walk's length; shorter scenes show its start


class WalkersScene(Scene):
    """Three walkers with blue, red and purple torsos (the colour paper's experiment).

    {params}

    Attributes
    ----------
    layout_ : dict
        Built on first use: ``background`` (H, W, 3) uint8, ``centres`` (n_frames, 3, 2) torso
        centres in px, ``phase`` (n_frames, 3) gait phase, ``noise_seed``.
    """

    width = 360
    height = 240

    seed: int = Param(
        0, "Seeds ``np.random.default_rng`` for the layout, the paths and the per-frame noise.",
        unit="none", low=0)
    n_frames: int = Param(
        180,
        "Number of frames (the paper: 180). Fewer frames are the start of the 180-frame walk "
        "(same speed); more frames stretch the walk over them (slower walkers).",
        unit="frames", low=1)
    noise_sigma: float = Param(
        3.0, "Standard deviation of the per-pixel Gaussian noise added to every frame (grey "
        "levels).", unit="grey levels", low=0.0)

    @property
    def target_names(self) -> dict[int, str]:
        """Ground-truth id -> torso colour name."""
        return dict(TARGET_NAMES)

    # -- layout ---------------------------------------------------------------------------------

    @property
    def layout(self) -> dict[str, Any]:
        key = (self.seed, self.n_frames)
        if getattr(self, "layout_", None) is None or self.layout_["key"] != key:
            rng = np.random.default_rng(self.seed)
            background = _plaza(rng, self.width, self.height)
            n = int(self.n_frames)
            centres, phase = _paths(rng, max(n, WALK_FRAMES), self.width, self.height)
            centres, phase = centres[:n], phase[:n]
            self.layout_ = {"key": key, "background": background, "centres": centres,
                            "phase": phase, "noise_seed": int(rng.integers(2**63 - 1))}
        return self.layout_

    def background(self) -> np.ndarray:
        """The static plaza without people, (H, W, 3) uint8 BGR."""
        return self.layout["background"].copy()

    # -- Scene --------------------------------------------------------------------------------

    def render(self, k: int, noise: np.ndarray | None = None) -> np.ndarray:
        """Frame ``k`` (0-based) as a BGR uint8 image; ``noise`` (H, W, 3) float32 is added."""
        lay = self.layout
        img = lay["background"].copy()
        centres, phase = lay["centres"][k], lay["phase"][k]
        # nearer (lower) people are drawn last
        for p in np.argsort(centres[:, 1], kind="stable"):
            name = TARGET_NAMES[int(p) + 1]
            _draw_person(img, centres[p], phase[p], TORSO_COLOURS_BGR[name])
        if noise is not None:
            img = np.clip(img.astype(np.float32) + noise, 0, 255).astype(np.uint8)
        return img

    def frames(self) -> Iterator[Frame]:
        lay = self.layout
        noise_rng = np.random.default_rng(lay["noise_seed"])
        shape = (self.height, self.width, 3)
        for k in range(int(self.n_frames)):
            noise = None
            if self.noise_sigma > 0:
                noise = noise_rng.standard_normal(shape, dtype=np.float32)
                noise *= np.float32(self.noise_sigma)
            yield Frame(index=k + 1, image=self.render(k, noise), time_s=k / float(self.fps))

    def ground_truth(self) -> np.ndarray:
        """MOT rows (3 * n_frames, 10): the 30 x 30 torso box of each person in each frame."""
        c = self.layout["centres"]
        n = len(c)
        frames = np.repeat(np.arange(1, n + 1), 3)
        ids = np.tile(np.arange(1, 4), n)
        xy = c.reshape(-1, 2)
        rows = np.full((3 * n, 10), -1.0)
        rows[:, 0] = frames
        rows[:, 1] = ids
        rows[:, 2] = xy[:, 0] - TORSO_PX / 2
        rows[:, 3] = xy[:, 1] - TORSO_PX / 2
        rows[:, 4] = TORSO_PX
        rows[:, 5] = TORSO_PX
        rows[:, 6] = 1.0
        return rows


# ------------------------------------------------------------------------------------------------
# Drawing
# ------------------------------------------------------------------------------------------------


def _smooth_field(rng: np.random.Generator, shape: tuple[int, int], cells: tuple[int, int],
                  ) -> np.ndarray:
    """Zero-mean, unit-std smooth random field (bicubic up-sampling of a coarse grid)."""
    coarse = rng.standard_normal(cells).astype(np.float32)
    f = cv2.resize(coarse, (shape[1], shape[0]), interpolation=cv2.INTER_CUBIC)
    return (f - f.mean()) / (f.std() + 1e-6)


def _plaza(rng: np.random.Generator, w: int, h: int) -> np.ndarray:
    """Static background: paving, a brick wall, lawns, flower beds, a bench and posters."""
    img = np.empty((h, w, 3), np.float32)
    # paving: warm grey with slow variation, fine grain and joints every 20 px
    base = np.array([150, 162, 170], np.float32)
    img[:] = base
    img += 14 * _smooth_field(rng, (h, w), (6, 9))[..., None]
    img += 5 * rng.standard_normal((h, w, 1)).astype(np.float32)
    img[::20, :] *= 0.78
    img[:, ::20] *= 0.78
    # brick wall along the top (reds close to, but mostly not in, the red torso's bins)
    wall_h = 34
    for r0 in range(0, wall_h, 8):
        off = 0 if (r0 // 8) % 2 == 0 else 11
        for c0 in range(-off, w, 22):
            col = np.array([58, 66, 150], np.float32) + rng.normal(0, [6, 6, 14]).astype(np.float32)
            cv2.rectangle(img, (c0 + 1, r0 + 1), (c0 + 20, r0 + 6), col.tolist(), -1)
    img[wall_h - 2:wall_h] = (90, 95, 100)
    # lawns: two green strips with texture
    for (y0, y1) in ((34, 50), (218, 240)):
        g = np.array([70, 140, 80], np.float32)
        patch = g + 18 * _smooth_field(rng, (y1 - y0, w), (3, 12))[..., None] * [0.5, 1, 0.6]
        img[y0:y1] = patch + 6 * rng.standard_normal((y1 - y0, w, 1)).astype(np.float32)
    # flower beds in purple and red on the lawns (close to the purple / red torsos)
    for cx in rng.uniform(20, w - 20, 9):
        cy = rng.uniform(36, 48) if rng.random() < 0.5 else rng.uniform(222, 236)
        colour = (140, 50, 130) if rng.random() < 0.6 else (50, 46, 190)
        for _ in range(7):
            dx, dy = rng.normal(0, [7, 2.5])
            cv2.circle(img, (int(cx + dx), int(cy + dy)), int(rng.integers(2, 4)),
                       (np.array(colour) + rng.normal(0, 8, 3)).tolist(), -1, cv2.LINE_AA)
    # a blue bench and two posters (one blue, one purple) on the wall; a red door
    cv2.rectangle(img, (150, 196), (210, 206), (180, 100, 50), -1)
    cv2.rectangle(img, (154, 206), (158, 214), (40, 40, 40), -1)
    cv2.rectangle(img, (202, 206), (206, 214), (40, 40, 40), -1)
    cv2.rectangle(img, (40, 6), (64, 28), (200, 110, 40), -1)
    cv2.rectangle(img, (290, 5), (312, 28), (150, 60, 140), -1)
    cv2.rectangle(img, (228, 2), (246, 33), (50, 45, 185), -1)
    # a dark puddle / drain and a lamp post shadow for extra texture
    cv2.ellipse(img, (300, 150), (22, 7), 0, 0, 360, (95, 100, 105), -1, cv2.LINE_AA)
    cv2.line(img, (20, 200), (80, 120), (120, 128, 134), 4, cv2.LINE_AA)
    return np.clip(img, 0, 255).astype(np.uint8)


def _paths(rng: np.random.Generator, n: int, w: int, h: int,
           min_visible: float = 0.3, attempts: int = 500) -> tuple[np.ndarray, np.ndarray]:
    """Torso-centre paths (n, 3, 2) px that cross each other, and the gait phase (n, 3).

    Blue walks left to right, red right to left a little nearer the camera, purple diagonally
    from the far left to the near right; start and end points, speed changes and sideways sway
    are drawn from ``rng``. Candidates in which a torso is ever less than ``min_visible`` visible
    (hidden by nearer people), or in which nobody is ever hidden by more than 20 %, are drawn
    again: people cross and occlude each other, but nobody vanishes for long (a colour tracker
    cannot see through a person, and the paper's sequence has none either).
    """
    for _ in range(attempts):
        centres, phase = _draw_paths(rng, n, w, h)
        vis = torso_visibility(centres)
        if vis.min() >= min_visible and vis.min() < 0.8:
            return centres, phase
    raise RuntimeError(f"walkers: no path set with every torso at least {min_visible:.0%} visible "
                       f"in {attempts} draws")


def _draw_paths(rng: np.random.Generator, n: int, w: int, h: int,
                ) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.0, n)
    starts = np.array([[45, 100], [315, 122], [70, 62]], float) + rng.uniform(-12, 12, (3, 2))
    ends = np.array([[305, 112], [60, 128], [285, 168]], float) + rng.uniform(-12, 12, (3, 2))
    centres = np.empty((n, 3, 2))
    phase = np.empty((n, 3))
    for p in range(3):
        # monotone progress with a speed change (walk, slow down, speed up)
        a = rng.uniform(0.03, 0.07)
        u = t + a * np.sin(2 * np.pi * (t * rng.uniform(0.8, 1.6) + rng.uniform(0, 1)))
        u = (u - u[0]) / (u[-1] - u[0])
        d = ends[p] - starts[p]
        normal = np.array([-d[1], d[0]]) / (np.linalg.norm(d) + 1e-9)
        sway = rng.uniform(6, 14) * np.sin(2 * np.pi * (t * rng.uniform(1.0, 2.0)
                                                         + rng.uniform(0, 1)))
        xy = starts[p] + u[:, None] * d + sway[:, None] * normal
        # stride length ~ 18 px per gait cycle
        dist = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
        phase[:, p] = 2 * np.pi * dist / 18.0 + rng.uniform(0, 2 * np.pi)
        xy[:, 1] -= 1.5 * np.abs(np.sin(phase[:, p]))  # bob
        centres[:, p] = xy
    centres[..., 0] = np.clip(centres[..., 0], 20, w - 20)
    centres[..., 1] = np.clip(centres[..., 1], 45, h - 55)
    return centres, phase


def torso_visibility(centres: np.ndarray) -> np.ndarray:
    """Visible fraction of each torso box in each frame, (n, P), from the people drawn in front
    (their bodies approximated by rectangles: arms and torso, head, legs)."""
    n, n_people = centres.shape[:2]
    vis = np.ones((n, n_people))
    half = TORSO_PX / 2
    corner = np.floor(centres - half + 0.5)  # torso top-left, as drawn
    for k in range(n):
        order = np.argsort(centres[k, :, 1], kind="stable")
        for i, p in enumerate(order):
            in_front = order[i + 1:]
            if len(in_front) == 0:
                continue
            px, py = corner[k, p]
            mask = np.zeros((TORSO_PX, TORSO_PX), dtype=bool)
            for q in in_front:
                qx, qy = corner[k, q]
                cx = qx + half
                for x0, y0, x1, y1 in ((qx - 8, qy, qx + TORSO_PX + 8, qy + TORSO_PX),
                                       (cx - 9, qy - 19, cx + 9, qy),
                                       (cx - 11, qy + TORSO_PX - 2, cx + 11, qy + TORSO_PX + 34)):
                    a0, a1 = int(max(x0 - px, 0)), int(min(x1 - px, TORSO_PX))
                    b0, b1 = int(max(y0 - py, 0)), int(min(y1 - py, TORSO_PX))
                    if a1 > a0 and b1 > b0:
                        mask[b0:b1, a0:a1] = True
            vis[k, p] = 1.0 - mask.mean()
    return vis


def _limb(img: np.ndarray, top: tuple[float, float], angle: float, length: float, width: float,
          colour: tuple[float, float, float]) -> None:
    """A limb as a filled quadrilateral hanging from ``top`` at ``angle`` (radians from down)."""
    d = np.array([np.sin(angle), np.cos(angle)])
    nrm = np.array([d[1], -d[0]]) * width / 2
    p0 = np.asarray(top, float)
    p1 = p0 + d * length
    pts = np.array([p0 + nrm, p0 - nrm, p1 - nrm, p1 + nrm])
    cv2.fillConvexPoly(img, np.round(pts * 4).astype(np.int32), colour, cv2.LINE_AA, shift=2)


def _draw_person(img: np.ndarray, centre: np.ndarray, phase: float,
                 torso_bgr: tuple[int, int, int]) -> None:
    """Legs, arms, a 30 x 30 torso (with shading) and a head, centred on ``centre``."""
    cx, cy = float(centre[0]), float(centre[1])
    half = TORSO_PX / 2
    x0, y0 = int(np.floor(cx - half + 0.5)), int(np.floor(cy - half + 0.5))
    swing = 0.45 * np.sin(phase)
    trousers = (62, 60, 58)
    # legs from the hips
    for side, sgn in ((-5.5, 1), (5.5, -1)):
        _limb(img, (x0 + half + side, y0 + TORSO_PX - 2), sgn * swing, 34, 9, trousers)
        foot = (x0 + half + side + np.sin(sgn * swing) * 34, y0 + TORSO_PX - 2
                + np.cos(sgn * swing) * 34)
        cv2.ellipse(img, (int(foot[0]), int(foot[1])), (5, 3), 0, 0, 360, (25, 25, 28), -1,
                    cv2.LINE_AA)
    arm = tuple(0.8 * c for c in torso_bgr)
    _limb(img, (x0 - 2, y0 + 4), -swing, 26, 6, arm)
    # torso: the shirt's colour shaded across (lighter in the middle), a collar at the top
    h_img, w_img = img.shape[:2]
    xs = np.arange(TORSO_PX)
    shade = 1.0 - 0.16 * ((xs - (TORSO_PX - 1) / 2) / ((TORSO_PX - 1) / 2)) ** 2
    torso = np.asarray(torso_bgr, np.float32)[None, None, :] * shade[None, :, None]
    torso = np.repeat(torso, TORSO_PX, axis=0)
    torso[:3] *= 0.9
    tx0, ty0 = max(x0, 0), max(y0, 0)
    tx1, ty1 = min(x0 + TORSO_PX, w_img), min(y0 + TORSO_PX, h_img)
    if tx1 > tx0 and ty1 > ty0:
        img[ty0:ty1, tx0:tx1] = torso[ty0 - y0:ty1 - y0, tx0 - x0:tx1 - x0]
    _limb(img, (x0 + TORSO_PX + 2, y0 + 4), swing, 26, 6, arm)
    # neck and head (skin), hair on top
    hc = (round(cx), y0 - 9)
    cv2.rectangle(img, (hc[0] - 3, y0 - 3), (hc[0] + 3, y0), (120, 150, 190), -1)
    cv2.circle(img, hc, 9, (135, 165, 205), -1, cv2.LINE_AA)
    cv2.ellipse(img, (hc[0], hc[1] - 3), (9, 6), 0, 180, 360, (35, 45, 60), -1, cv2.LINE_AA)
