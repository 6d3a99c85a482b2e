"""The ``coast`` scene: the coastal paper's thermal set-up, synthetic, through the shipped
camera.

Okamura and Fujimoto watch a coast with a 384 x 288 thermal camera upscaled 2x to 768 x 576
(the coastal paper). Their video is not public; this scene renders the same set-up through
``calib/coast_camera.yaml`` (20 m up on a mast at the origin, looking out to sea 7.6 deg down;
coast frame: x along the shore, y out to sea, z up, metres, origin at the mast foot on the sea
level) so that the detection volumes of :func:`pftrack.geometry.volumes.coast_volumes` have
something to watch: ``near`` (43 x 10 x 6 m at y = 95..105 m) lies on LAND, ``far``
(170 x 310 x 9 m at y = 145..455 m) on the SEA, the shore line between (y ~ 118..134 m).

Picture (grey levels, white-hot; rendered at 384 x 288 px with the camera's intrinsics halved,
then upscaled 2x bilinearly to 768 x 576, returned as BGR uint8 with three equal channels):

* sky above the horizon: cool, smooth, brighter towards the horizon haze, faint static clouds;
* sea: a sum of travelling sinusoids (deep-water dispersion, directions spread around "towards
  the shore") evaluated at each pixel's point on the sea plane, its slope along the view
  shading the pixel (a slope facing the camera emits more); each wave is attenuated by the
  pixel's footprint on the sea (an analytic anti-alias), so waves shrink and fade with distance
  as they should; sun glints where the fine waves are steepest and random sparkles (per frame);
  haze towards the horizon;
* the shore: a wiggly water line that moves with a slow tide, wet sand behind it and a wash
  of foam on it;
* land from the camera out to the shore: warmer, textured in world coordinates (so the texture
  has perspective), a promenade along the shore (y ~ 62-68 m) and a slipway perpendicular to it
  (x = 6 +- 3.5 m) down to the water, on which the car drives;
* a moored boat (a hull and a cabin, cuboids) at (-55, 185) m that bobs a little: background;
* a thermal camera's automatic exposure: gain and offset that change slowly over a clip (gain
  +-2 %, offset +-2.5 grey levels) and more between training days (gain +-6 %, offset +-5,
  land temperature +-6, sea +-3); Gaussian sensor noise at 384 x 288 (so it is 2 x 2
  correlated after the upscale). The swings are kept to what an automatic gain leaves after
  normalising: with about twice these (and a car 10-15 grey levels cooler) the global level
  dominated every block's eigenspace (D = 1 to 3), and the block eigenspace model found only
  43 % of the car's blocks.

Rendering costs about 6 ms per frame on one core (vectorised; no loop over pixels).

Intruders (warmer than what they stand on) are solid cuboids, projected corner by corner
through the camera (lens included); the faces facing the camera are filled with 4 x 4
super-sampled coverage, far objects first (painter's order), so silhouettes match the objects'
3-D size and position to a fraction of a pixel.

Clips (``clip=``): ``boat`` (a 7.5 x 1.8 x 2.3 m boat crosses the far volume along x at 5 m/s,
entering and leaving it), ``car`` (a 1.7 x 1.5 x 4.7 m car drives up the slipway along y at
3 m/s through the near volume), ``multi`` (two boats and the car, entering at different times),
``empty`` (background only, the clip's conditions), ``training`` (the training frames as a
clip, for code that trains from a scene's frames). Sizes are (w, h, d): across x, height, along
y, metres. ``training_frames()`` gives 400 background-only frames spread over three "days"
(sea state, glint, tide, gain, offset, temperatures differ between days and over each day).

Ground truth: :meth:`CoastScene.ground_truth` gives MOTChallenge rows ``(frame, id, left, top,
width, height, 1, x, y, 0)`` (box = bounding box of the projected cuboid in 768 x 576 pixels;
x, y = the footprint centre on z = 0, metres), one per object and frame in which its box overlaps
the image; :meth:`CoastScene.objects` gives centres and sizes per frame, and the first and last
frame each object's centre is inside its volume.

Everything random comes from ``np.random.default_rng([seed, ...])``: the site (textures, wave
set, coast line), the training conditions, each clip's conditions, and each frame's noise from
its own generator, so :meth:`CoastScene.render` is random-access and the same seed gives the
same frames bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
from pftrack.contracts.components import Frame, Param, Scene

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera

__all__ = ["CLIPS", "CoastObject", "CoastScene", "Conditions", "default_coast_camera"]

#: Clip name -> short description.
CLIPS: dict[str, str] = {
    "boat": "a 7.5 x 1.8 x 2.3 m boat crosses the far volume along x (5 m/s), 200 frames",
    "car": "a 1.7 x 1.5 x 4.7 m car drives up the slipway through the near volume (3 m/s), "
           "100 frames",
    "multi": "two boats and the car, entering at different times, 200 frames",
    "empty": "background only, the clip's conditions, 100 frames",
    "training": "the background-only training frames (training_frames()) as the clip",
}
_CLIP_INDEX = {name: i for i, name in enumerate(CLIPS)}
_CLIP_FRAMES = {"boat": 200, "car": 100, "multi": 200, "empty": 100, "training": 0}

RENDER_WH = (384, 288)  # the thermal sensor
OUTPUT_WH = (768, 576)  # upscaled 2x, the camera file's size
BOAT_SIZE_M = (7.5, 1.8, 2.3)  # w (along x), h, d (beam, along y)
CAR_SIZE_M = (1.7, 1.5, 4.7)  # w (across x), h, d (length, along y)
SLIPWAY_X_M = 6.0  # slipway centre line, x
SLIPWAY_HALF_M = 3.5
SHORE_BASE_M = 126.0  # mean water line, y
TIDE_RANGE_M = 4.0  # tide level in [-4, 4] m about it (water line moves along y)
CAR_STOP_Y_M = 116.0  # the car parks at the slipway's end, above the lowest water line

# grey levels (before gain/offset), white-hot
_SKY_TOP, _SKY_HORIZON = 38.0, 78.0
_SEA, _HAZE = 88.0, 80.0
_LAND = 138.0


def default_coast_camera() -> Camera:
    """The project's coastal camera, package data ``pftrack_coast/data/coast_camera.yaml``
    (``calib/coast_camera.yaml`` in a checkout points to it)."""
    from importlib import resources

    from pftrack.geometry.formats import load_camera

    return load_camera(Path(str(resources.files("pftrack_coast") / "data" / "coast_camera.yaml")))


# ------------------------------------------------------------------------------------------------
# Conditions and objects
# ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Conditions:
    """What changes between (and within) days: one frame's weather and camera state.

    Attributes
    ----------
    time_s : float
        Wave clock, seconds (phases of the travelling sinusoids).
    sea_state : float
        Wave amplitude factor (1: the site's usual swell and chop).
    glint : float
        Glint and sparkle amount (0: none).
    tide_m : float
        Water line offset along y, metres (positive: the water line is further out).
    gain, offset : float
        Automatic exposure: ``out = gain * (grey - 110) + 110 + offset``.
    sea_temp, land_temp, sky_temp : float
        Grey-level offsets of sea, land and sky (the day's temperatures).
    """

    time_s: float
    sea_state: float = 1.0
    glint: float = 1.0
    tide_m: float = 0.0
    gain: float = 1.0
    offset: float = 0.0
    sea_temp: float = 0.0
    land_temp: float = 0.0
    sky_temp: float = 0.0


@dataclass
class CoastObject:
    """One intruder of a clip.

    Attributes
    ----------
    id : int
        Ground-truth id (1-based).
    kind : {"boat", "car"}
    size_m : ndarray, shape (3,)
        (w, h, d): across x, height, along y, metres.
    centres_m : ndarray, shape (n_frames, 3)
        Centre of the cuboid in each clip frame, world metres (z = h/2 plus any bobbing).
    volume : str
        The detection volume it crosses (``near`` or ``far``).
    first_inside, last_inside : int or None
        First and last clip frame (1-based, as :class:`Frame.index`) in which the centre is
        inside the volume (None if never).
    faces : dict
        Grey level of each face before exposure: ``front`` (-y, towards the camera), ``back``
        (+y), ``left`` (-x), ``right`` (+x), ``top`` (the bottom is never seen).
    """

    id: int
    kind: str
    size_m: np.ndarray
    centres_m: np.ndarray
    volume: str
    first_inside: int | None = None
    last_inside: int | None = None
    faces: dict[str, float] = field(default_factory=dict)

    def corners_m(self, k: int) -> np.ndarray:
        """The cuboid's 8 corners (8, 3) in frame ``k`` (0-based), world metres."""
        return _cuboid_corners(self.centres_m[k], self.size_m)


def _cuboid_corners(centre: np.ndarray, size_whd: np.ndarray) -> np.ndarray:
    """Corners (8, 3) of the world-axis-aligned cuboid of ``size_whd`` = (w across x, h
    height, d along y) about ``centre`` (x, y, z), metres."""
    w, h, d = (float(v) for v in size_whd)
    s = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                  [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], np.float64)
    return np.asarray(centre, np.float64) + 0.5 * s * np.array([w, d, h])


# faces of _cuboid_corners: name, corner indices (in order round the face), outward normal
_FACES = (
    ("front", (0, 1, 5, 4), (0.0, -1.0, 0.0)),
    ("back", (2, 3, 7, 6), (0.0, 1.0, 0.0)),
    ("left", (3, 0, 4, 7), (-1.0, 0.0, 0.0)),
    ("right", (1, 2, 6, 5), (1.0, 0.0, 0.0)),
    ("top", (4, 5, 6, 7), (0.0, 0.0, 1.0)),
    ("bottom", (0, 3, 2, 1), (0.0, 0.0, -1.0)),
)


# ------------------------------------------------------------------------------------------------
# The scene
# ------------------------------------------------------------------------------------------------


class CoastScene(Scene):
    """The coastal paper's coast through ``calib/coast_camera.yaml``: sea, shore, land, intruders.

    {params}

    Attributes
    ----------
    camera_ : Camera
        The 768 x 576 camera (ground truth boxes are in its pixels).
    render_camera_ : Camera
        The same camera at 384 x 288 (what is rendered).
    objects_ : list of CoastObject
        The clip's intruders.
    """

    seed: int = Param(
        3, "Seeds everything random (site, conditions, noise): the same seed gives the same "
        "frames.", unit="none", low=0)
    clip: str = Param(
        "boat", "Which clip :meth:`frames` and :meth:`ground_truth` give (see :data:`CLIPS`).",
        choices=tuple(CLIPS))
    n_frames: int | None = Param(
        None, "Clip length in frames; None: the clip's own (boat 200, car 100, multi 200, empty "
        "100). Objects move the same whatever the length (a shorter clip is the start of the "
        "clip).", unit="frames", low=1)
    fps: float = Param(  # a parameter here (Scene.fps is a property)
        5.0, "Frames per second of the clip (object speeds are in m/s, so fewer fps = longer "
        "steps).", unit="frames/s", low=0.0, low_open=True)
    n_training: int = Param(
        400, "Number of background-only training frames (:meth:`training_frames`).",
        unit="frames", low=0)
    noise_std: float = Param(
        2.0, "Sensor noise, grey levels at 384 x 288.", unit="grey levels", low=0.0)
    camera: str | None = Param(
        None,
        "A camera file (:func:`pftrack.geometry.formats.load_camera`) of size 768 x 576; None: "
        ":func:`default_coast_camera`.")

    @classmethod
    def _conformance_example(cls) -> CoastScene:
        """A short car clip for :mod:`pftrack.testing` (the kit reads two frames)."""
        return cls(clip="car", n_frames=5)

    # -- set-up ----------------------------------------------------------------------------------

    @property
    def clip_frames(self) -> int:
        """Number of frames of the clip."""
        name = self._clip_name()
        if name == "training":
            n = int(self.n_training)
            return n if self.n_frames is None else min(int(self.n_frames), n)
        return int(_CLIP_FRAMES[name] if self.n_frames is None else self.n_frames)

    def _clip_name(self) -> str:
        return str(self.clip)

    def prepare(self) -> CoastScene:
        """Camera, per-pixel sea-plane geometry, static textures, waves, conditions and objects
        (once; cheap: about 0.1 s)."""
        key = (self.seed, self.clip, self.n_frames, self.fps, self.n_training, self.noise_std,
               self.camera)
        if getattr(self, "key_", None) == key:
            return self
        name = self._clip_name()
        n = self.clip_frames
        if self.camera is None:
            cam = default_coast_camera()
        else:
            from pftrack.geometry.formats import load_camera

            cam = load_camera(Path(self.camera))
        if tuple(cam.image_size) != OUTPUT_WH:
            cam = cam.resized(OUTPUT_WH)
        self.camera_ = cam
        self.render_camera_ = cam.resized(RENDER_WH)
        self._site(np.random.default_rng([int(self.seed), 0]))
        self.training_conditions_ = _training_conditions(
            np.random.default_rng([int(self.seed), 1]), int(self.n_training))
        crng = np.random.default_rng([int(self.seed), 2, _CLIP_INDEX[name]])
        self.clip_conditions_ = _clip_conditions(crng, n, float(self.fps))
        self.objects_ = _clip_objects(name, n, float(self.fps), crng)
        self.key_ = key
        return self

    def _site(self, rng: np.random.Generator) -> None:
        """Everything static: per-pixel sea-plane points, footprints, textures, wave set."""
        cam = self.render_camera_
        w, h = RENDER_WH
        uu, vv = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        origin, dirs = cam.rays(np.stack([uu.ravel(), vv.ravel()], axis=1))
        dz = dirs[:, 2]
        ground = dz < -1e-6
        s = np.where(ground, -origin[:, 2] / np.where(ground, dz, -1.0), np.inf)
        gx = (origin[:, 0] + s * dirs[:, 0]).reshape(h, w)
        gy = (origin[:, 1] + s * dirs[:, 1]).reshape(h, w)
        ground = ground.reshape(h, w) & (s.reshape(h, w) < 2e4)
        gx[~ground] = 0.0
        gy[~ground] = 2e4
        dist = np.where(ground, s.reshape(h, w), 2e4)
        # footprint of a pixel on the sea plane (m per pixel along x and y)
        fy = np.abs(np.gradient(gy, axis=0))
        fx = np.abs(np.gradient(gx, axis=1))
        fy[~ground] = 1e4
        self.ground_ = ground
        self.dist_ = dist
        # the coast line y(x) (before the tide): two wiggles, never below 118 m with the tide
        a1, a2 = rng.uniform(1.5, 2.5), rng.uniform(0.5, 1.0)
        p1, p2 = rng.uniform(0, 2 * np.pi, 2)
        self.shore0_ = (SHORE_BASE_M + a1 * np.sin(gx / 37.0 + p1)
                        + a2 * np.sin(gx / 11.0 + p2)).astype(np.float32)
        self.gy_ = gy.astype(np.float32)
        # pixels that may be sea under some tide (waves are evaluated only there)
        maybe_sea = ground & (gy > SHORE_BASE_M - TIDE_RANGE_M - 4.0 - 6.0)
        self.sea_idx_ = np.flatnonzero(maybe_sea)
        sx, sy = gx.ravel()[self.sea_idx_], gy.ravel()[self.sea_idx_]
        sfx, sfy = fx.ravel()[self.sea_idx_], fy.ravel()[self.sea_idx_]
        # wave set: swell and chop travelling towards the shore (-y), spread +-40 deg
        wl = np.array([38.0, 27.0, 19.0, 13.0, 9.0, 6.5, 4.5, 3.2, 2.3, 1.6])
        heading = -np.pi / 2 + rng.uniform(-0.7, 0.7, len(wl))
        k = 2 * np.pi / wl
        kx, ky = k * np.cos(heading), k * np.sin(heading)
        amp = 0.06 * wl * rng.uniform(0.7, 1.3, len(wl)) * (wl / 10.0) ** -0.3  # slope ~ const
        self.wave_omega_ = np.sqrt(9.81 * k)
        self.wave_phase0_ = rng.uniform(0, 2 * np.pi, len(wl))
        # per pixel and wave: phase k.p and the anti-aliased slope along y (shading)
        self.wave_kp_ = (sx[:, None] * kx + sy[:, None] * ky).astype(np.float32)
        atten = np.exp(-0.5 * ((kx * sfx[:, None]) ** 2 + (ky * sfy[:, None]) ** 2))
        self.wave_slope_ = (amp * ky * atten).astype(np.float32)  # d h / d y coefficient
        self.fine_ = wl < 5.0  # the chop that makes glints
        # shading gain grows towards grazing view; haze towards the horizon
        sdist = dist.ravel()[self.sea_idx_]
        self.sea_haze_ = (1.0 - np.exp(-sdist / 1500.0)).astype(np.float32)
        self.sea_shade_ = (90.0 * np.clip(sdist / 150.0, 0.4, 3.0) ** 0.5).astype(np.float32)
        # slow sea temperature patches (currents), world coordinates
        patch = _smooth(rng, (24, 24), (64, 64))
        self.sea_patch_ = (3.0 * cv2.remap(
            patch, ((sx + 600.0) / 1200.0 * 63).astype(np.float32).reshape(1, -1),
            (np.clip(sy, 0, 2000) / 2000.0 * 63).astype(np.float32).reshape(1, -1),
            cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT).ravel()).astype(np.float32)
        self.land_ = _land(rng, gx, gy, ground)
        self.sky_ = _sky(rng, ground)
        # the moored boat: a hull and a cabin, background
        self.moored_ = [(np.array([-55.0, 185.0, 0.8]), np.array([6.0, 1.6, 2.2]),
                         {"front": 118.0, "back": 112.0, "left": 114.0, "right": 114.0,
                          "top": 122.0}),
                        (np.array([-56.0, 185.0, 2.3]), np.array([2.4, 1.4, 1.6]),
                         {"front": 124.0, "back": 118.0, "left": 120.0, "right": 120.0,
                          "top": 114.0})]
        self.moored_phase_ = float(rng.uniform(0, 2 * np.pi))
        self.sparkle_amp_ = np.clip(1.0 - self.sea_haze_, 0.2, 1.0)

    # -- rendering -----------------------------------------------------------------------------

    def render_conditions(self, cond: Conditions, objects: list[tuple[np.ndarray, np.ndarray,
                                                                       dict[str, float]]],
                          rng: np.random.Generator | None) -> np.ndarray:
        """One frame under ``cond`` with these cuboids ``(centre_m, size_m, faces)``, as a
        (576, 768, 3) uint8 BGR image (equal channels); ``rng`` draws the sparkles and the
        sensor noise (None: neither)."""
        self.prepare()
        w, h = RENDER_WH
        img = self.sky_ + np.float32(cond.sky_temp)
        land = self.land_ + np.float32(cond.land_temp)
        # the water line and the wet sand behind it
        shore = self.shore0_ + np.float32(cond.tide_m)
        behind = shore - self.gy_  # > 0 on land, metres from the water line
        wet = np.exp(-np.clip(behind, 0, None) / 3.0) * 14.0
        land = land - wet
        ground = self.ground_
        img = np.where(ground, land, img)
        flat = img.reshape(-1)
        # the sea
        idx = self.sea_idx_
        arg = self.wave_kp_ - np.float32(cond.time_s) * self.wave_omega_.astype(np.float32) \
            + self.wave_phase0_.astype(np.float32)
        c = np.cos(arg)
        slope_all = np.einsum("nk,nk->n", c, self.wave_slope_) * np.float32(cond.sea_state)
        fine = np.einsum("nk,nk->n", c[:, self.fine_], self.wave_slope_[:, self.fine_])
        sea = (np.float32(_SEA + cond.sea_temp) + self.sea_patch_
               + self.sea_shade_ * slope_all)
        # glints: where the chop faces the camera steeply
        gthr = 0.6 * np.abs(self.wave_slope_[:, self.fine_]).sum(axis=1) + 1e-6
        glint = np.clip(fine * np.float32(cond.sea_state) / gthr - 0.55, 0, None)
        sea += np.float32(60.0 * cond.glint) * glint * self.sparkle_amp_
        if rng is not None and cond.glint > 0:
            p = 0.004 * cond.glint
            hit = rng.random(len(idx)) < p
            sea[hit] += rng.exponential(35.0, int(hit.sum())).astype(np.float32) \
                * self.sparkle_amp_[hit]
        sea = sea * (1 - self.sea_haze_) + np.float32(_HAZE + cond.sea_temp) * self.sea_haze_
        # foam wash on the water line
        d = self.gy_.reshape(-1)[idx] - shore.reshape(-1)[idx]  # metres seaward of the line
        wash = np.exp(-np.abs(d) / 1.5) * (0.6 + 0.4 * np.cos(0.9 * d - 0.8 * cond.time_s))
        is_sea = d > 0
        flat[idx] = np.where(is_sea, sea + 16.0 * wash, flat[idx] - 6.0 * wash)
        # cuboids: the moored boat, then the intruders, far first
        bob = 0.12 * math.sin(0.9 * cond.time_s + self.moored_phase_)
        boxes = [(c0 + np.array([0.0, 0.0, bob]), s0, f0) for c0, s0, f0 in self.moored_]
        boxes += list(objects)
        boxes.sort(key=lambda b: -float(self.render_camera_.depth(b[0][None])[0]))
        for centre, size, faces in boxes:
            _draw_cuboid(img, self.render_camera_, centre, size, faces, self.dist_)
        # automatic exposure, noise, the 2x upscale, 8 bits
        img = img * np.float32(cond.gain) + np.float32(110.0 * (1 - cond.gain) + cond.offset)
        if rng is not None and self.noise_std > 0:
            img += rng.standard_normal((h, w), dtype=np.float32) * np.float32(self.noise_std)
        big = cv2.resize(img, OUTPUT_WH, interpolation=cv2.INTER_LINEAR)
        out = np.clip(big + 0.5, 0, 255).astype(np.uint8)
        return cv2.cvtColor(out, cv2.COLOR_GRAY2BGR)

    def render(self, k: int, with_objects: bool = True, noise: bool = True) -> np.ndarray:
        """Clip frame ``k`` (0-based) as (576, 768, 3) uint8 BGR. ``with_objects=False`` draws
        the same frame (same conditions, sparkles and noise) without the intruders. For
        ``clip="training"``, training frame ``k``."""
        self.prepare()
        if self.clip == "training":
            return self._training_image(k)
        cond = self.clip_conditions_[k]
        objs = [(o.centres_m[k], o.size_m, o.faces) for o in self.objects_] if with_objects \
            else []
        rng = np.random.default_rng([int(self.seed), 3, _CLIP_INDEX[self.clip], k]) \
            if noise else None
        return self.render_conditions(cond, objs, rng)

    def frames(self) -> Iterator[Frame]:
        """The clip's frames (index 1-based, BGR uint8 768 x 576, time_s = (index - 1) / fps);
        for ``clip="training"`` the training frames (:meth:`training_frames`)."""
        self.prepare()
        if self.clip == "training":
            yield from self.training_frames(self.clip_frames)
            return
        for k in range(self.clip_frames):
            yield Frame(index=k + 1, image=self.render(k), time_s=k / float(self.fps))

    def training_frames(self, n: int | None = None) -> Iterator[Frame]:
        """Background-only frames (no intruders) over three "days" of varied conditions: the
        first ``n`` (default all ``n_training``), index 1-based, time_s = the wave clock."""
        self.prepare()
        conds = self.training_conditions_
        m = len(conds) if n is None else min(int(n), len(conds))
        for j in range(m):
            yield Frame(index=j + 1, image=self._training_image(j), time_s=float(conds[j].time_s))

    def _training_image(self, j: int) -> np.ndarray:
        rng = np.random.default_rng([int(self.seed), 4, j])
        return self.render_conditions(self.training_conditions_[j], [], rng)

    # -- ground truth --------------------------------------------------------------------------

    def objects(self) -> list[CoastObject]:
        """The clip's intruders: ids, sizes, per-frame centres, volume entry and exit frames."""
        return list(self.prepare().objects_)

    def volume_events(self) -> dict[int, tuple[int | None, int | None, str]]:
        """Object id -> (first frame inside its volume, last frame inside, volume name); frames
        1-based."""
        return {o.id: (o.first_inside, o.last_inside, o.volume) for o in self.objects()}

    def boxes_px(self, obj: CoastObject) -> np.ndarray:
        """(n_frames, 4) boxes (left, top, width, height) of ``obj``'s projected cuboid in the
        768 x 576 image (NaN where a corner is behind the camera)."""
        cam = self.prepare().camera_
        n = len(obj.centres_m)
        corners = np.stack([_cuboid_corners(c, obj.size_m) for c in obj.centres_m])
        p = cam.project(corners.reshape(-1, 3)).reshape(n, 8, 2)
        lo, hi = p.min(axis=1), p.max(axis=1)
        # the project's convention (soccer scene, the volume tracker's cuboid_box): the box
        # spans the projected corners' coordinates, pixel centres at integers
        return np.concatenate([lo, hi - lo], axis=1)

    def ground_truth(self) -> np.ndarray:
        """MOTChallenge rows ``(frame, id, left, top, width, height, 1, x, y, 0)``, (M, 10):
        the projected cuboid's bounding box in pixels and the footprint centre (x, y) on the
        support plane z = 0 in metres, for each object and frame where the box meets the image.
        """
        self.prepare()
        rows = []
        w, h = OUTPUT_WH
        for o in self.objects_:
            b = self.boxes_px(o)
            ok = np.isfinite(b).all(axis=1) & (b[:, 0] < w) & (b[:, 1] < h) \
                & (b[:, 0] + b[:, 2] > 0) & (b[:, 1] + b[:, 3] > 0)
            k = np.flatnonzero(ok)
            r = np.zeros((len(k), 10))
            r[:, 0] = k + 1
            r[:, 1] = o.id
            r[:, 2:6] = b[k]
            r[:, 6] = 1.0
            r[:, 7:9] = o.centres_m[k, :2]
            rows.append(r)
        out = np.concatenate(rows) if rows else np.zeros((0, 10))
        return out[np.lexsort((out[:, 1], out[:, 0]))]


# ------------------------------------------------------------------------------------------------
# Conditions, objects
# ------------------------------------------------------------------------------------------------


def _training_conditions(rng: np.random.Generator, n: int) -> list[Conditions]:
    """``n`` frames over three days: each day has its own sea state, glint, temperatures and
    exposure; within a day, frames are at random times (tide on a 12.4 h cycle, exposure and
    temperatures drifting with the time of day)."""
    days = []
    for _ in range(3):
        days.append({"sea": rng.uniform(0.6, 1.5), "glint": rng.uniform(0.2, 1.6),
                     "gain": rng.uniform(0.94, 1.06), "offset": rng.uniform(-5, 5),
                     "sea_t": rng.uniform(-3, 3), "land_t": rng.uniform(-6, 6),
                     "sky_t": rng.uniform(-6, 6), "tide_phase": rng.uniform(0, 2 * np.pi)})
    out = []
    for j in range(n):
        d = days[j % 3]
        tau = rng.uniform(0.0, 12.0 * 3600.0)  # seconds into the day's daylight
        x = tau / (12.0 * 3600.0)
        out.append(Conditions(
            time_s=float(tau),
            sea_state=float(d["sea"] * (1 + 0.15 * math.sin(2 * np.pi * x + 1.0))),
            glint=float(d["glint"] * (0.6 + 0.4 * math.sin(np.pi * x))),
            tide_m=float(TIDE_RANGE_M * math.sin(2 * np.pi * tau / 44640.0 + d["tide_phase"])),
            gain=float(d["gain"] * (1 + 0.02 * math.sin(2 * np.pi * x * 3 + 0.3))),
            offset=float(d["offset"] + 3.0 * math.sin(2 * np.pi * x * 2)),
            sea_temp=float(d["sea_t"] + 1.5 * math.sin(np.pi * x)),
            land_temp=float(d["land_t"] + 4.0 * math.sin(np.pi * x)),
            sky_temp=float(d["sky_t"])))
    return out


def _clip_conditions(rng: np.random.Generator, n: int, fps: float) -> list[Conditions]:
    """A clip's conditions: one day's draw (inside the training ranges), then per frame a slow
    tide (1.5 m over the clip), exposure gain and offset drifting, the wave clock running."""
    sea = rng.uniform(0.8, 1.3)
    glint = rng.uniform(0.5, 1.2)
    gain0, off0 = rng.uniform(0.96, 1.04), rng.uniform(-3, 3)
    tide0 = rng.uniform(-TIDE_RANGE_M + 1.5, TIDE_RANGE_M - 1.5)
    sea_t, land_t, sky_t = rng.uniform(-2, 2), rng.uniform(-4, 4), rng.uniform(-4, 4)
    t0 = rng.uniform(0, 3600.0)
    ph = rng.uniform(0, 2 * np.pi, 2)
    out = []
    for k in range(n):
        t = k / fps
        out.append(Conditions(
            time_s=float(t0 + t), sea_state=float(sea), glint=float(glint),
            tide_m=float(tide0 + 1.5 * (k / max(n - 1, 1)) * (1 if tide0 < 0 else -1)),
            gain=float(gain0 * (1 + 0.02 * math.sin(2 * np.pi * t / 25.0 + ph[0]))),
            offset=float(off0 + 2.5 * math.sin(2 * np.pi * t / 40.0 + ph[1])),
            sea_temp=float(sea_t), land_temp=float(land_t), sky_temp=float(sky_t)))
    return out


_BOAT_FACES = {"front": 186.0, "back": 166.0, "left": 176.0, "right": 176.0, "top": 192.0}
_CAR_FACES = {"front": 215.0, "back": 195.0, "left": 200.0, "right": 200.0, "top": 185.0}


def _boat(oid: int, y_m: float, x0: float, vx: float, n: int, fps: float,
          rng: np.random.Generator) -> CoastObject:
    t = np.arange(n) / fps
    size = np.array(BOAT_SIZE_M)
    c = np.empty((n, 3))
    c[:, 0] = x0 + vx * t
    c[:, 1] = y_m
    c[:, 2] = size[1] / 2 + 0.08 * np.sin(1.3 * t + rng.uniform(0, 2 * np.pi))
    return CoastObject(oid, "boat", size, c, "far", faces=dict(_BOAT_FACES))


def _car(oid: int, y0: float, vy: float, n: int, fps: float) -> CoastObject:
    t = np.arange(n) / fps
    size = np.array(CAR_SIZE_M)
    c = np.empty((n, 3))
    c[:, 0] = SLIPWAY_X_M
    c[:, 1] = np.minimum(y0 + vy * t, CAR_STOP_Y_M)
    c[:, 2] = size[1] / 2
    return CoastObject(oid, "car", size, c, "near", faces=dict(_CAR_FACES))


def _clip_objects(name: str, n: int, fps: float, rng: np.random.Generator) -> list[CoastObject]:
    """The clip's intruders, with their volume entry and exit frames. Paths are fixed in
    metres per second of clip time, so they do not depend on ``n`` or ``fps`` beyond sampling."""
    from pftrack.geometry.volumes import coast_volumes

    if name == "boat":
        objs = [_boat(1, 230.0, -95.0, 5.0, n, fps, rng)]
    elif name == "car":
        objs = [_car(1, 57.0, 3.0, n, fps)]
    elif name == "multi":
        objs = [_boat(1, 210.0, -95.0, 5.0, n, fps, rng),
                _boat(2, 330.0, 140.0, -6.5, n, fps, rng),
                _car(3, 21.0, 3.0, n, fps)]
    else:
        objs = []
    vols = coast_volumes()
    for o in objs:
        inside = np.flatnonzero(vols[o.volume].contains(o.centres_m))
        if len(inside):
            o.first_inside, o.last_inside = int(inside[0]) + 1, int(inside[-1]) + 1
    return objs


# ------------------------------------------------------------------------------------------------
# Drawing
# ------------------------------------------------------------------------------------------------


def _smooth(rng: np.random.Generator, cells: tuple[int, int], shape: tuple[int, int]) -> np.ndarray:
    """Zero-mean unit-std smooth random field (H, W) float32 (bicubic up-sampled grid)."""
    coarse = rng.standard_normal(cells).astype(np.float32)
    f = cv2.resize(coarse, (shape[1], shape[0]), interpolation=cv2.INTER_CUBIC)
    return ((f - f.mean()) / (f.std() + 1e-6)).astype(np.float32)


def _land(rng: np.random.Generator, gx: np.ndarray, gy: np.ndarray, ground: np.ndarray,
          ) -> np.ndarray:
    """Static land (H, W) float32: warm ground textured in world coordinates (0.5 m texels over
    x -200..200, y 0..160 m), a promenade, the slipway, grass, and image grain."""
    h, w = gx.shape
    tex_w, tex_h = 800, 320  # 0.5 m texels
    coarse = _smooth(rng, (16, 40), (tex_h, tex_w))
    mid = _smooth(rng, (64, 160), (tex_h, tex_w))
    fine = rng.standard_normal((tex_h, tex_w)).astype(np.float32)
    tex = 9.0 * coarse + 5.0 * mid + 3.0 * fine
    # world-space features (texel centres)
    tx = (np.arange(tex_w) + 0.5) * 0.5 - 200.0
    ty = (np.arange(tex_h) + 0.5) * 0.5
    TX, TY = np.meshgrid(tx, ty)
    # grass (cooler) in soft-edged patches where the coarse field is high
    tex -= 14.0 * np.clip((coarse - 0.3) / 0.6, 0, 1) * (TY < 100)
    promenade = (TY > 62) & (TY < 68)
    tex[promenade] = 150.0 - _LAND + 2.0 * fine[promenade]
    slip = np.abs(TX - SLIPWAY_X_M) < SLIPWAY_HALF_M
    tex[slip] = 128.0 - _LAND + 2.0 * fine[slip]
    # a kerb line either side of the slipway
    kerb = np.abs(np.abs(TX - SLIPWAY_X_M) - SLIPWAY_HALF_M) < 0.3
    tex[kerb] = 160.0 - _LAND
    mapx = ((gx + 200.0) / 0.5 - 0.5).astype(np.float32)
    mapy = (np.clip(gy, 0, 160) / 0.5 - 0.5).astype(np.float32)
    land = cv2.remap(tex, mapx, mapy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    # the ground gets cooler towards the water (damp sand), image grain
    land = land + _LAND - 10.0 * np.clip((gy - 80.0) / 50.0, 0, 1)
    land = land + 1.5 * rng.standard_normal((h, w)).astype(np.float32)
    return np.where(ground, land, 0).astype(np.float32)


def _sky(rng: np.random.Generator, ground: np.ndarray) -> np.ndarray:
    """Static sky (H, W) float32: cool, brighter towards the horizon, faint clouds."""
    h, w = ground.shape
    sky_rows = ~ground.all(axis=1)
    horizon = float(np.flatnonzero(sky_rows)[-1] + 1) if sky_rows.any() else 0.0
    v = np.arange(h, dtype=np.float32)[:, None]
    r = np.clip(v / max(horizon, 1.0), 0, 1)
    sky = _SKY_TOP + (_SKY_HORIZON - _SKY_TOP) * r ** 3
    sky = sky + 3.0 * _smooth(rng, (4, 8), (h, w)) * (1 - r)
    return np.broadcast_to(sky, (h, w)).astype(np.float32).copy()


def _draw_cuboid(img: np.ndarray, cam: Camera, centre: np.ndarray, size: np.ndarray,
                 faces: dict[str, float], dist: np.ndarray, ss: int = 4) -> None:
    """Fill the faces of a world-axis-aligned cuboid that face the camera into ``img`` (H, W)
    float32 in place, with ``ss`` x ``ss`` super-sampled coverage; grey levels hazed by
    distance like the sea."""
    corners = _cuboid_corners(centre, size)
    if not cam.in_front(corners).all():
        return
    p = cam.project(corners)
    h, w = img.shape
    x0 = int(max(np.floor(p[:, 0].min() - 1), 0))
    y0 = int(max(np.floor(p[:, 1].min() - 1), 0))
    x1 = int(min(np.ceil(p[:, 0].max() + 2), w))
    y1 = int(min(np.ceil(p[:, 1].max() + 2), h))
    if x1 <= x0 or y1 <= y0:
        return
    eye = cam.center_m
    d = float(np.linalg.norm(np.asarray(centre) - eye))
    haze = 1.0 - math.exp(-d / 1500.0)
    roi = img[y0:y1, x0:x1]
    for name, idx, normal in _FACES:
        if name not in faces:
            continue
        fc = corners[list(idx)].mean(axis=0)
        if np.dot(normal, eye - fc) <= 0:
            continue
        q = p[list(idx)] - [x0, y0]
        # pixel centres at integers; in the super-sampled grid sub-pixel a covers
        # [(a)/ss - 0.5, (a+1)/ss - 0.5]
        qs = np.round(((q + 0.5) * ss - 0.5) * 16).astype(np.int32)
        mask = np.zeros(((y1 - y0) * ss, (x1 - x0) * ss), np.uint8)
        cv2.fillConvexPoly(mask, qs, 255, cv2.LINE_8, shift=4)
        cov = cv2.resize(mask.astype(np.float32) / 255.0, (x1 - x0, y1 - y0),
                         interpolation=cv2.INTER_AREA)
        val = faces[name] * (1 - haze) + _HAZE * haze
        roi += cov * (np.float32(val) - roi)
