"""The ``soccer`` scene: a fixed camera filming real player trajectories on a synthetic pitch.

The soccer paper tracks soccer players from one fixed, calibrated camera. Its video is not public,
so this scene re-creates the set-up from public data: the player trajectories are REAL, taken from
the tracking samples that the ``kloppy`` package ships in its wheel (``kloppy/tests/files``) and
read with kloppy's own loaders; the picture is synthetic, rendered through a calibrated camera with
its lens distortion (by default a camera like the soccer paper's, in ``calib/``).

Data flow::

    kloppy dataset (provider coordinates)
      -> pitch metres, centre frame (kloppy's "secondspectrum" system: origin at the centre spot,
         x along the length, y across, z up; the frame of
         :class:`pftrack.geometry.volumes.SoccerPitchVolume` with ``frame="centre"``)
      -> regular time grid at ``fps`` (linear interpolation between provider samples)
      -> per frame: static background (grass, mowing stripes, markings, goals; drawn once)
         + players as projected 3D figures, far to near (painter's order by camera depth)
      -> :class:`pftrack.contracts.components.Frame` (BGR uint8) and MOTChallenge ground truth.

Sources (``source=``)
---------------------
=================  ===========================================  ================================
name               kloppy files                                 continuous play, players, rate
=================  ===========================================  ================================
``hawkeye``        ``hawkeye_1_1.football.samples.*`` + meta    60 s, 22, 50 Hz (default)
``hawkeye-2``      ``hawkeye_2_46.football.samples.*`` + meta   60 s, 22, 50 Hz (2nd half)
``pff``            ``pff_10517.jsonl`` + metadata + rosters     8 clips of 0.83 s, 22, 29.97 Hz
``sportec``        ``sportec_positional.xml`` + meta            2 x 4 s, 1-3 players, 25 Hz
``skillcorner``    ``skillcorner_structured_data.json`` + meta  broadcast (players in view), 10 Hz
=================  ===========================================  ================================

Only Hawk-Eye holds >= 20 s of continuous play with all 22 players, so it is the default; the
other sources load, but a window longer than their longest continuous run raises a ValueError
that says how long that run is (nothing is concatenated or invented). Between provider samples
positions are interpolated linearly onto the video's time grid (Hawk-Eye at 50 Hz is simply
decimated at the default 25 fps). A player missing from the provider data for more than
``max_gap_s`` is absent from the picture and from the ground truth for that time.

Ground truth
------------
One MOTChallenge row per visible player and frame: ``(frame, id, left, top, width, height, 1,
x, y, 0)``; the box is the bounding rectangle of the projected ``0.6 x 0.6 x height`` m
world-axis-aligned cuboid standing on the player's position; ``x, y`` are the position in pitch
metres (centre frame), ``z = 0``. A player is listed while his ground position projects inside
the image; occluded players stay listed (MOTChallenge convention). Ids are 1..P in the order of
:attr:`SoccerScene.tracks_`'s players.

Modules
-------
This module renders the scene (players over the pitch) and draws pictures of it; its parts live
beside it and their public names import from here as well: :mod:`pftrack_world.soccer_tracks`
(the trajectories from kloppy), :mod:`pftrack_world.soccer_pitch` (the default camera and
volume, the empty pitch's picture) and :mod:`pftrack_world.soccer_detector`
(:class:`~pftrack_world.soccer_detector.PitchBlobDetector`, the ``pitch-blob`` detector).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from pftrack.contracts.components import Frame, Param, Scene

from pftrack_world.soccer_detector import PitchBlobDetector
from pftrack_world.soccer_pitch import (
    _DEFAULT_VOLUME,
    _noise_bank,
    default_soccer_camera_path,
    marking_quads,
    render_pitch_background,
)
from pftrack_world.soccer_tracks import (  # noqa: F401 (_raw_tracks: read by the tests)
    SOURCES,
    PitchTracks,
    _raw_tracks,
    load_pitch_tracks,
)

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera

__all__ = [
    "SOURCES",
    "PitchBlobDetector",
    "PitchTracks",
    "SoccerScene",
    "default_soccer_camera_path",
    "load_pitch_tracks",
    "marking_quads",
    "render_pitch_background",
]


# Player body plan in metres for a 1.80 m player (scaled by height): (name, z0, z1, half side
# width, half depth, lateral offset, swing: 0 none, +-1 legs, +-2 forearms, +-3 upper arms, colour).
_PARTS: tuple[tuple[str, float, float, float, float, float, int, str], ...] = (
    ("shin_l", 0.00, 0.46, 0.065, 0.07, -0.10, +1, "socks"),
    ("shin_r", 0.00, 0.46, 0.065, 0.07, +0.10, -1, "socks"),
    ("thigh_l", 0.44, 0.86, 0.075, 0.08, -0.10, +1, "skin"),
    ("thigh_r", 0.44, 0.86, 0.075, 0.08, +0.10, -1, "skin"),
    ("shorts", 0.68, 0.98, 0.19, 0.12, 0.00, 0, "shorts"),
    ("shirt", 0.96, 1.50, 0.22, 0.12, 0.00, 0, "shirt"),
    ("arm_l", 0.88, 1.22, 0.05, 0.05, -0.27, +2, "skin"),
    ("arm_r", 0.88, 1.22, 0.05, 0.05, +0.27, -2, "skin"),
    ("sleeve_l", 1.20, 1.47, 0.06, 0.065, -0.27, +3, "shirt"),
    ("sleeve_r", 1.20, 1.47, 0.06, 0.065, +0.27, -3, "shirt"),
)
_HEAD_CENTRE_Z = 1.64
_HEAD_RADIUS = 0.115
_BOX_HALF_M = 0.30  # ground-truth cuboid: 0.6 x 0.6 m footprint


# ---------------------------------------------------------------------------------------------
# Motion-derived pose: heading and gait
# ---------------------------------------------------------------------------------------------


def _box_smooth(x: np.ndarray, k: int) -> np.ndarray:
    """Moving average along axis 0 (edges use a shrunken window); NaN-aware."""
    if k <= 1:
        return x.copy()
    ok = np.isfinite(x)
    xz = np.where(ok, x, 0.0)
    c = np.cumsum(np.concatenate([np.zeros((1,) + x.shape[1:]), xz]), axis=0)
    cn = np.cumsum(np.concatenate([np.zeros((1,) + x.shape[1:]), ok.astype(float)]), axis=0)
    n = x.shape[0]
    lo = np.clip(np.arange(n) - k // 2, 0, n)
    hi = np.clip(np.arange(n) + k // 2 + 1, 0, n)
    s, m = c[hi] - c[lo], cn[hi] - cn[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(m > 0, s / np.maximum(m, 1), np.nan)


def _pose(positions_m: np.ndarray, fps: float, phase0: np.ndarray,
          stride_m: float = 1.9) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Heading (T, P) radians, gait phase (T, P) radians and speed (T, P) m/s from the tracks."""
    T, P, _ = positions_m.shape
    sm = _box_smooth(positions_m, max(1, round(0.3 * fps)))
    vel = np.gradient(sm, 1.0 / fps, axis=0) if T > 1 else np.zeros_like(sm)
    speed = np.nan_to_num(np.hypot(vel[..., 0], vel[..., 1]))
    ang = np.arctan2(vel[..., 1], vel[..., 0])
    heading = np.zeros((T, P))
    # players initially face the other end's goal direction of their run; hold heading when slow
    cur = np.where(np.isfinite(ang[0]) & (speed[0] > 0.4), ang[0], 0.0)
    for k in range(T):  # loop over frames, vectorised over players (set-up only)
        moving = (speed[k] > 0.4) & np.isfinite(ang[k])
        d = np.angle(np.exp(1j * (np.where(moving, ang[k], cur) - cur)))
        cur = cur + np.clip(d, -0.35, 0.35)  # turn at most 0.35 rad per frame
        heading[k] = cur
    step = np.nan_to_num(np.hypot(*np.moveaxis(np.diff(sm, axis=0, prepend=sm[:1]), -1, 0)))
    phase = phase0[None, :] + 2 * np.pi * np.cumsum(step, axis=0) / stride_m
    return heading, phase, speed


# ---------------------------------------------------------------------------------------------
# The scene
# ---------------------------------------------------------------------------------------------


_TEAM_KITS: dict[str, dict[str, tuple[int, int, int]]] = {
    # BGR. Home in red with black shorts, away in white with navy shorts (the soccer paper's video
    # has a white and a red team); goalkeepers in yellow and in green-grey.
    "home": {"shirt": (40, 30, 200), "shorts": (30, 30, 30), "socks": (40, 30, 190)},
    "away": {"shirt": (235, 235, 240), "shorts": (90, 40, 25), "socks": (230, 230, 230)},
    "home_gk": {"shirt": (30, 215, 235), "shorts": (30, 30, 30), "socks": (30, 200, 220)},
    "away_gk": {"shirt": (60, 110, 60), "shorts": (40, 40, 40), "socks": (60, 100, 60)},
}
_SKIN = np.array([[150, 180, 225], [120, 155, 205], [95, 125, 175], [70, 95, 135],
                  [50, 70, 105]], dtype=np.float64)  # BGR tones
_HAIR = np.array([[20, 20, 25], [30, 50, 80], [40, 80, 140], [15, 15, 15]], dtype=np.float64)


class SoccerScene(Scene):
    """A fixed camera filming 22 players who move along real tracking data on a synthetic pitch.

    {params}

    Attributes
    ----------
    tracks_ : PitchTracks
        The trajectories (after :meth:`prepare`, done lazily on first use).
    camera_ : pftrack.geometry.camera.Camera
    pitch_ : pftrack.geometry.volumes.SoccerPitchVolume
        The pitch of the source's size, centre frame.
    background_ : ndarray, shape (H, W, 3), uint8
        The empty pitch as the camera sees it.

    Notes
    -----
    Frames are rendered on demand (:meth:`frames` is a generator, :meth:`render` draws one);
    memory does not grow with the clip length beyond the (T, P) trajectory arrays.
    """

    source: str = Param(
        "hawkeye",
        'Trajectory source, a key of :data:`SOURCES` (``"hawkeye"``: 22 players, 50 Hz, the '
        "only built-in source with >= 20 s of continuous play).", choices=tuple(SOURCES))
    start_s: float = Param(
        0.0, "Clip start, seconds into the source's longest continuous run of play.",
        unit="s", low=0.0)
    duration_s: float = Param(20.0, "Clip length in seconds.", unit="s", low=0.0, low_open=True)
    fps: float = Param(  # a parameter here (Scene.fps is a property)
        25.0, "Video frame rate (frames per second); trajectories are interpolated to it.",
        unit="frames/s", low=0.0, low_open=True)
    seed: int = Param(
        0, "Seeds every random choice (player heights, skin tones, gait phases, grass texture, "
        "sensor noise): the same seed gives the same video, bit for bit.", unit="none", low=0)
    camera: str | os.PathLike[str] | None = Param(
        None, "Camera file readable by :func:`pftrack.geometry.formats.load_camera`; default the "
        "project's soccer camera in ``calib/`` (:func:`default_soccer_camera_path`).")
    volume: str = Param(
        _DEFAULT_VOLUME,
        "The pitch drawn and played on: a :class:`~pftrack.geometry.volumes.SoccerPitchVolume` "
        "by name (:func:`pftrack.geometry.volumes.resolve_volume`, ``calib/volumes.yaml``), in "
        "the camera's world frame.")
    image_size: tuple[int, int] = Param(
        (1280, 720),
        "Output (width, height) in pixels. When it differs from the camera's, the camera's "
        "intrinsics are scaled to it.", unit="px", low=1, length=2)
    noise_std: float = Param(
        2.0, "Standard deviation of the additive sensor noise, grey levels (0: none).",
        unit="grey levels", low=0.0)
    max_gap_s: float = Param(
        0.5, "Largest provider-data gap bridged by interpolation (see :func:`load_pitch_tracks`).",
        unit="s", low=0.0)
    supersample: int = Param(
        2, "The static background is rendered at this factor and averaged down (anti-aliased "
        "lines).", unit="1", low=1)

    @classmethod
    def _conformance_example(cls) -> SoccerScene:
        """A small, cheap configuration for :mod:`pftrack.testing` (5 frames at 640 x 360)."""
        return cls(duration_s=0.2, image_size=(640, 360), supersample=1)

    # ---- set-up -------------------------------------------------------------------------

    def prepare(self) -> SoccerScene:
        """Load trajectories, camera and volume, derive poses, draw the background (once)."""
        if getattr(self, "background_", None) is not None:
            return self
        from pftrack.geometry.volumes import SoccerPitchVolume, resolve_volume

        w, h = (int(v) for v in self.image_size)
        tracks = getattr(self, "tracks_", None)
        if tracks is None:
            tracks = load_pitch_tracks(self.source, float(self.fps), float(self.start_s),
                                       float(self.duration_s), float(self.max_gap_s))
        cam = self._load_camera((w, h))
        vol = resolve_volume(self.volume)
        if not isinstance(vol, SoccerPitchVolume):
            raise TypeError(f"soccer scene: volume {self.volume!r} is a "
                             f"{type(vol).__name__}, not a soccer pitch")
        rng = np.random.default_rng(self.seed)
        P = tracks.n_players
        self.heights_m_ = np.clip(rng.normal(1.80, 0.05, P), 1.68, 1.95)
        self.skin_ = _SKIN[rng.integers(0, len(_SKIN), P)]
        self.hair_ = _HAIR[rng.integers(0, len(_HAIR), P)]
        phase0 = rng.uniform(0, 2 * np.pi, P)
        self.heading_, self.phase_, self.speed_ = _pose(tracks.positions_m, float(self.fps),
                                                        phase0)
        self.kits_ = self._kits(tracks)
        # the provider's pitch (its own size) centred on the volume's centre spot
        self.centre_m_ = np.asarray(vol.origin_offset_m, dtype=np.float64)
        self.markings_pitch_ = SoccerPitchVolume(length_m=tracks.pitch_length_m,
                                                 width_m=tracks.pitch_width_m, height_m=2.5,
                                                 margin_m=3.0, frame="centre",
                                                 name=f"pitch-{tracks.source}")
        self.pitch_ = vol
        self.tracks_ = tracks
        self.positions_world_m_ = tracks.positions_m + self.centre_m_[:2]
        self.camera_ = cam
        bg_rng = np.random.default_rng([self.seed, 1])
        self.background_ = render_pitch_background(cam, self.markings_pitch_, bg_rng,
                                                   centre_m=self.centre_m_,
                                                   supersample=int(self.supersample))
        self.noise_bank_ = _noise_bank(np.random.default_rng([self.seed, 2]), (h, w),
                                       float(self.noise_std))
        return self

    def with_tracks(self, tracks: PitchTracks) -> SoccerScene:
        """Use these trajectories instead of loading ``source`` (tests, custom plays).

        ``tracks.times_s`` should be spaced ``1 / fps``; its positions are in the centre frame
        (metres from the centre spot). Returns ``self``, not yet prepared.
        """
        if not isinstance(tracks, PitchTracks):
            raise TypeError(f"soccer scene: with_tracks expects PitchTracks, got "
                            f"{type(tracks).__name__}")
        self.background_ = None
        self.tracks_ = tracks
        return self

    def _load_camera(self, size: tuple[int, int]) -> Camera:
        from pftrack.geometry.formats import load_camera

        path = Path(self.camera) if self.camera is not None else default_soccer_camera_path()
        if not path.is_file():
            raise FileNotFoundError(f"soccer scene: camera file not found: {path}")
        cam = load_camera(path)
        if tuple(cam.image_size) != tuple(size):
            cam = cam.resized(size)
        return cam

    @staticmethod
    def _kits(tracks: PitchTracks) -> np.ndarray:
        """(P, 3, 3) BGR colours of shirt, shorts and socks per player."""
        out = np.empty((tracks.n_players, 3, 3))
        for i in range(tracks.n_players):
            key = ("home" if tracks.teams[i] == 0 else "away") + \
                ("_gk" if tracks.goalkeeper[i] else "")
            k = _TEAM_KITS[key]
            out[i] = [k["shirt"], k["shorts"], k["socks"]]
        return out

    # ---- Scene contract -----------------------------------------------------------------

    @property
    def n_frames(self) -> int:
        """Number of frames in the clip."""
        return self.prepare().tracks_.n_frames

    def frames(self) -> Iterator[Frame]:
        """Yield the frames in order, rendered on demand (index 1-based, BGR uint8)."""
        self.prepare()
        for k in range(self.tracks_.n_frames):
            yield Frame(index=k + 1, image=self.render(k), time_s=float(self.tracks_.times_s[k]))

    def empty_frames(self, n: int = 25) -> Iterator[Frame]:
        """``n`` frames of the empty pitch before play (background plus sensor noise), for a
        detector to learn the background from (:meth:`PitchBlobDetector.fit`). Indices 1..n,
        times ``-n / fps .. -1 / fps`` seconds."""
        import cv2

        self.prepare()
        fps = float(self.fps)
        for k in range(int(n)):
            img = self.background_.copy()
            if self.noise_bank_ is not None:
                pos, neg = self.noise_bank_[k % len(self.noise_bank_)]
                cv2.add(img, pos, dst=img)
                cv2.subtract(img, neg, dst=img)
            yield Frame(index=k + 1, image=img, time_s=(k - int(n)) / fps)

    def ground_truth(self) -> np.ndarray:
        """MOTChallenge rows ``(frame, id, left, top, width, height, 1, x, y, 0)``, (M, 10).

        Boxes in pixels (projected 0.6 x 0.6 x height m cuboids), x, y in pitch metres (centre
        frame). One row per player whose ground position projects inside the image.
        """
        self.prepare()
        T, P = self.tracks_.n_frames, self.tracks_.n_players
        pos = self.positions_world_m_
        boxes, foot = self._gt_boxes(pos.reshape(-1, 2), np.tile(self.heights_m_, T))
        ok = np.isfinite(pos.reshape(-1, 2)).all(axis=1) & self.camera_.in_image(foot) \
            & np.isfinite(boxes).all(axis=1)
        frame = np.repeat(np.arange(1, T + 1), P)
        ids = np.tile(np.arange(1, P + 1), T)
        xy = pos.reshape(-1, 2)
        rows = np.column_stack([frame, ids, boxes, np.ones(T * P), xy, np.zeros(T * P)])
        return np.ascontiguousarray(rows[ok])

    def _gt_boxes(self, xy_m: np.ndarray, heights_m: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Image boxes (N, 4) xywh px of the players' cuboids and their foot pixels (N, 2)."""
        n = len(xy_m)
        sx = np.array([-1, 1, 1, -1, -1, 1, 1, -1]) * _BOX_HALF_M
        sy = np.array([-1, -1, 1, 1, -1, -1, 1, 1]) * _BOX_HALF_M
        sz = np.array([0, 0, 0, 0, 1, 1, 1, 1], dtype=np.float64)
        corners = np.empty((n, 8, 3))
        corners[..., 0] = xy_m[:, :1] + sx
        corners[..., 1] = xy_m[:, 1:2] + sy
        corners[..., 2] = heights_m[:, None] * sz
        fin = np.isfinite(corners).all(axis=(1, 2))
        px = np.full((n, 8, 2), np.nan)
        if fin.any():
            px[fin] = self.camera_.project(corners[fin].reshape(-1, 3)).reshape(-1, 8, 2)
        lo, hi = px.min(axis=1), px.max(axis=1)
        boxes = np.column_stack([lo, hi - lo])
        foot = np.full((n, 2), np.nan)
        if fin.any():
            foot[fin] = self.camera_.project(
                np.column_stack([xy_m[fin], np.zeros(fin.sum())]))
        return boxes, foot

    # ---- rendering ----------------------------------------------------------------------

    def render(self, k: int) -> np.ndarray:
        """Frame ``k`` (0-based) as a BGR uint8 image of ``image_size``."""
        import cv2

        self.prepare()
        tr = self.tracks_
        if not 0 <= k < tr.n_frames:
            raise IndexError(f"soccer scene: frame {k} out of range 0..{tr.n_frames - 1}")
        img = self.background_.copy()
        xy = self.positions_world_m_[k]
        live = np.flatnonzero(np.isfinite(xy).all(axis=1))
        if len(live):
            self._draw_players(img, k, live)
        if self.noise_bank_ is not None:
            pos, neg = self.noise_bank_[k % len(self.noise_bank_)]
            cv2.add(img, pos, dst=img)
            cv2.subtract(img, neg, dst=img)
        return img

    def _draw_players(self, img: np.ndarray, k: int, live: np.ndarray) -> None:
        import cv2

        cam = self.camera_
        xy = self.positions_world_m_[k, live]
        hgt = self.heights_m_[live]
        # painter's order: farthest first (camera depth of each player's waist)
        depth = cam.depth(np.column_stack([xy, 0.9 * np.ones(len(live))]))
        front = depth > 0.5
        order = np.argsort(-depth)
        order = order[front[order]]
        if len(order) == 0:
            return
        live, xy, hgt = live[order], xy[order], hgt[order]
        n = len(live)
        fwd_a = self.heading_[k, live]
        f = np.stack([np.cos(fwd_a), np.sin(fwd_a)], axis=1)  # (n, 2) heading on the ground
        s = np.stack([-f[:, 1], f[:, 0]], axis=1)  # left side
        speed = self.speed_[k, live]
        ph = self.phase_[k, live]
        amp_leg = np.clip(0.05 + 0.06 * speed, 0.0, 0.42)  # foot swing, metres
        amp_arm = 0.5 * amp_leg
        scale = hgt / 1.80

        # shadows (before any player): flat ellipses on the grass, darkening what is there
        a = np.linspace(0, 2 * np.pi, 17)[:-1]
        sh = np.empty((n, 16, 3))
        sun = np.array([0.35, 0.25])  # shadows fall a little to +x, +y
        sh[..., 0] = xy[:, :1] + 0.42 * np.cos(a) + sun[0]
        sh[..., 1] = xy[:, 1:2] + 0.28 * np.sin(a) + sun[1]
        sh[..., 2] = 0.0
        shp = cam.project(sh.reshape(-1, 3)).reshape(n, 16, 2)
        mask = np.zeros(img.shape[:2], np.uint8)
        polys = [np.round(p).astype(np.int32) for p in shp if np.isfinite(p).all()]
        if polys:
            cv2.fillPoly(mask, polys, 255, lineType=cv2.LINE_AA)
            ys, xs = np.nonzero(mask)
            if len(ys):
                m = mask[ys, xs, None].astype(np.float32) / 255.0
                img[ys, xs] = (img[ys, xs] * (1.0 - 0.4 * m)).astype(np.uint8)

        # body parts: (n, n_parts, 8, 3) corners, projected in one call
        n_parts = len(_PARTS)
        corners = np.empty((n, n_parts, 8, 3))
        colours = np.empty((n, n_parts, 3))
        cx_ = np.array([-1, 1, 1, -1, -1, 1, 1, -1], dtype=np.float64)  # along forward
        cy_ = np.array([-1, -1, 1, 1, -1, -1, 1, 1], dtype=np.float64)  # along side
        top = np.array([0, 0, 0, 0, 1, 1, 1, 1], dtype=np.float64)
        for j, (name, z0, z1, hw, hd, lat, swing, ck) in enumerate(_PARTS):
            if abs(swing) == 1:  # legs: hip fixed, foot swings with the gait
                off_bot = np.sign(swing) * amp_leg * np.sin(ph)
                off_top = off_bot * (0.0 if name.startswith("thigh") else 0.5)
                if name.startswith("thigh"):
                    off_bot = off_bot * 0.5
            elif abs(swing) == 2:  # forearms swing opposite to the leg on the same side
                off_bot = -np.sign(swing) * amp_arm * np.sin(ph)
                off_top = 0.45 * off_bot
            elif abs(swing) == 3:  # upper arm (sleeve): pivots at the shoulder
                off_bot = -np.sign(swing) * 0.45 * amp_arm * np.sin(ph)
                off_top = np.zeros(n)
            else:
                off_bot = off_top = np.zeros(n)
            along = np.where(top[None, :] > 0, off_top[:, None], off_bot[:, None]) \
                + cx_[None, :] * hd * scale[:, None]
            side = (lat + cy_ * hw)[None, :] * scale[:, None]
            z = (z0 + (z1 - z0) * top)[None, :] * scale[:, None]
            corners[:, j, :, :2] = (xy[:, None, :] + along[..., None] * f[:, None, :]
                                    + side[..., None] * s[:, None, :])
            corners[:, j, :, 2] = z
            if ck == "skin":
                colours[:, j] = self.skin_[live]
            else:
                colours[:, j] = self.kits_[live, {"shirt": 0, "shorts": 1, "socks": 2}[ck]]
        px = cam.project(corners.reshape(-1, 3)).reshape(n, n_parts, 8, 2)
        part_depth = cam.depth(corners.mean(axis=2).reshape(-1, 3)).reshape(n, n_parts)
        head_c = np.column_stack([xy, _HEAD_CENTRE_Z * scale])
        head_px = cam.project(head_c)
        head_top = cam.project(head_c + np.column_stack([np.zeros((n, 2)), _HEAD_RADIUS * scale]))
        head_r = np.hypot(*(head_top - head_px).T)
        # shade side-lit faces a little: parts get darker toward the bottom edge via outline
        for i in range(n):  # loop over players (22 at most), far to near
            for j in np.argsort(-part_depth[i]):
                q = px[i, j]
                if not np.isfinite(q).all():
                    continue
                hull = cv2.convexHull(np.round(q * 4).astype(np.int32))
                col = tuple(float(c) for c in colours[i, j])
                cv2.fillConvexPoly(img, hull, col, lineType=cv2.LINE_AA, shift=2)
            if np.isfinite(head_px[i]).all() and np.isfinite(head_r[i]):
                c = tuple(int(v) for v in np.round(head_px[i] * 4))
                r = max(1, round(head_r[i] * 4))
                cv2.circle(img, c, r, tuple(float(v) for v in self.skin_[live[i]]), -1,
                           cv2.LINE_AA, shift=2)
                # hair: the upper half of the head
                cv2.ellipse(img, c, (r, r), 0, 180, 360, tuple(float(v) for v in
                            self.hair_[live[i]]), -1, cv2.LINE_AA, shift=2)



# ---------------------------------------------------------------------------------------------
# Pictures for the notebook and reports (OpenCV drawing on frames; no tracking logic)
# ---------------------------------------------------------------------------------------------


def pitch_band(scene: SoccerScene, margin_px: int = 12) -> tuple[int, int, int, int]:
    """Rows and columns ``(y0, y1, x0, x1)`` of the image that hold the pitch (with a margin)."""
    scene.prepare()
    lo, hi = np.asarray(scene.pitch_.bounds(), dtype=np.float64)[:, :2]
    ring = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                     for z in (0.0, 2.0)])
    px = scene.camera_.project(ring)
    px = px[np.isfinite(px).all(axis=1)]
    w, h = scene.camera_.image_size
    x0, y0 = np.floor(px.min(axis=0)).astype(int) - margin_px
    x1, y1 = np.ceil(px.max(axis=0)).astype(int) + margin_px
    return max(int(y0), 0), min(int(y1), h), max(int(x0), 0), min(int(x1), w)


def crop_pitch(image_bgr: np.ndarray, scene: SoccerScene, zoom: int = 2) -> np.ndarray:
    """The pitch band of a frame, enlarged ``zoom`` times (nearest neighbour, pixels visible)."""
    import cv2

    y0, y1, x0, x1 = pitch_band(scene)
    crop = np.ascontiguousarray(image_bgr[y0:y1, x0:x1])
    return cv2.resize(crop, None, fx=zoom, fy=zoom, interpolation=cv2.INTER_NEAREST)


def calibration_overlay(scene: SoccerScene, zoom: int = 2, step_m: float = 0.25) -> np.ndarray:
    """The empty pitch with the volume's standard markings projected through the camera drawn
    over it in red (polylines sampled every ``step_m`` metres, so the lens bends them), and the
    players' volume (pitch plus run-off, ``height_m`` high) in yellow; enlarged ``zoom`` times
    over the pitch band. BGR uint8."""
    import cv2

    scene.prepare()
    cam = scene.camera_
    y0, _, x0, _ = pitch_band(scene)
    img = crop_pitch(scene.background_, scene, zoom)
    from pftrack.geometry.volumes import sample_polyline

    def draw(points_world_m: np.ndarray, colour: tuple[int, int, int]) -> None:
        px = cam.project(points_world_m)
        px = px[np.isfinite(px).all(axis=1)]
        if len(px) >= 2:
            q = np.round((px - [x0, y0]) * zoom + (zoom - 1) / 2).astype(np.int32)
            cv2.polylines(img, [q], False, colour, 1, cv2.LINE_AA)

    for poly in scene.pitch_.markings(step_m=step_m).values():
        draw(poly, (0, 0, 255))
    for seg in scene.pitch_.edges():
        draw(sample_polyline(np.asarray(seg), step_m * 4), (0, 220, 255))
    return img


def draw_tracks(image_bgr: np.ndarray, rows: np.ndarray, frame: int, scene: SoccerScene,
                zoom: int = 3, gt_rows: np.ndarray | None = None) -> np.ndarray:
    """The pitch band of ``image_bgr`` enlarged ``zoom`` times with the boxes of ``rows`` in
    frame ``frame`` (track colours, id above) and, when given, the ground-truth boxes in thin
    white. BGR uint8."""
    import cv2
    from pftrack.render.colours import track_colour_bgr

    y0, _, x0, _ = pitch_band(scene)
    img = crop_pitch(image_bgr, scene, zoom)

    def rect(r: np.ndarray) -> tuple[tuple[int, int], tuple[int, int]]:
        a = (round((r[2] - x0) * zoom), round((r[3] - y0) * zoom))
        b = (round((r[2] + r[4] - x0) * zoom), round((r[3] + r[5] - y0) * zoom))
        return a, b

    if gt_rows is not None:
        for r in gt_rows[gt_rows[:, 0] == frame]:
            cv2.rectangle(img, *rect(r), (255, 255, 255), 1)
    for r in rows[rows[:, 0] == frame]:
        a, b = rect(r)
        col = track_colour_bgr(int(r[1]))
        cv2.rectangle(img, a, b, col, 1)
        cv2.putText(img, str(int(r[1])), (a[0], a[1] - 3), cv2.FONT_HERSHEY_SIMPLEX, 0.35,
                    col, 1, cv2.LINE_AA)
    return img
