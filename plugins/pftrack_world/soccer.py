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
"""

from __future__ import annotations

import functools
import itertools
import math
import os
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pftrack.contracts.components import Detections, Detector, Frame, Param, RunContext, Scene

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

#: Source name -> short description (see the module docstring's table).
SOURCES: dict[str, str] = {
    "hawkeye": "Hawk-Eye centroids, 1st half minute 1 (50 Hz, 22 players, 60 s continuous)",
    "hawkeye-2": "Hawk-Eye centroids, 2nd half minute 46 (50 Hz, 22 players, 60 s continuous)",
    "pff": "PFF FC match 10517 (29.97 Hz, 22 players, clips of 0.83 s)",
    "sportec": "Sportec/DFL positional sample (25 Hz, 1-3 players, 4 s)",
    "skillcorner": "SkillCorner broadcast tracking (10 Hz, players in view only)",
}

#: Candidate file names of the project's soccer camera, searched in ``calib/``.
_CAMERA_FILE = "soccer_camera.yaml"
#: Default pitch volume (in the camera's world frame), looked up with
#: :func:`pftrack.geometry.volumes.resolve_volume` (``pftrack_world/data/volumes.yaml``).
_DEFAULT_VOLUME = "pitch_corner"

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


def default_soccer_camera_path() -> Path:
    """The plugin's soccer camera, package data ``pftrack_world/data/soccer_camera.yaml``
    (the soccer paper's Table 1 camera; ``calib/soccer_camera.yaml`` in a checkout points to it).

    Raises
    ------
    FileNotFoundError
        When the package data is missing (a broken install), naming the path.
    """
    from importlib import resources

    path = Path(str(resources.files("pftrack_world") / "data" / _CAMERA_FILE))
    if not path.is_file():
        raise FileNotFoundError(f"soccer scene: the plugin's camera {path} is missing (package "
                                "data of pftrack_world); pass camera=PATH")
    return path


# ---------------------------------------------------------------------------------------------
# Trajectories from kloppy
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _RawTracks:
    """One provider dataset as arrays, pitch metres (centre frame)."""

    source: str
    times_s: np.ndarray  # (F,) period-relative seconds
    periods: np.ndarray  # (F,) int
    positions_m: np.ndarray  # (F, P, 2), NaN where absent
    player_ids: tuple[str, ...]
    teams: np.ndarray  # (P,) int 0 home, 1 away
    jerseys: np.ndarray  # (P,) int
    goalkeeper: np.ndarray  # (P,) bool
    pitch_length_m: float
    pitch_width_m: float
    rate_hz: float


@dataclass(frozen=True)
class PitchTracks:
    """Player trajectories on the video's regular time grid, pitch metres.

    Attributes
    ----------
    source : str
        Source name (a key of :data:`SOURCES`).
    times_s : ndarray, shape (T,)
        Time of each video frame, seconds from the start of the clip.
    positions_m : ndarray, shape (T, P, 2)
        Ground position (x, y) of each player, metres, centre frame (origin at the centre spot,
        x along the length, y across); NaN where the player is absent.
    player_ids : tuple of str
        Provider player ids, length P.
    teams : ndarray, shape (P,), int
        0 for the home team, 1 for the away team.
    jerseys : ndarray, shape (P,), int
        Shirt numbers (0 when unknown).
    goalkeeper : ndarray, shape (P,), bool
    pitch_length_m, pitch_width_m : float
        Pitch size the provider reports.
    start_s : float
        Clip start, seconds into the provider's longest continuous run of play.
    provider_rate_hz : float
        The provider's sampling rate.
    """

    source: str
    times_s: np.ndarray
    positions_m: np.ndarray
    player_ids: tuple[str, ...]
    teams: np.ndarray
    jerseys: np.ndarray
    goalkeeper: np.ndarray
    pitch_length_m: float
    pitch_width_m: float
    start_s: float
    provider_rate_hz: float

    @property
    def n_frames(self) -> int:
        return int(self.times_s.shape[0])

    @property
    def n_players(self) -> int:
        return int(self.positions_m.shape[1])


def _kloppy_files() -> Path:
    try:
        import kloppy
    except ImportError as exc:  # pragma: no cover - kloppy is a dependency
        raise ImportError("soccer scene: the 'kloppy' package is required for player "
                          "trajectories (pip install kloppy)") from exc
    folder = Path(kloppy.__file__).parent / "tests" / "files"
    if not folder.is_dir():
        raise FileNotFoundError(f"soccer scene: kloppy's sample files are missing: {folder}")
    return folder


def _load_dataset(source: str) -> Any:
    """Load one provider sample with kloppy, in pitch metres, centre origin, y up."""
    F = _kloppy_files()
    cs = "secondspectrum"  # centre origin, metres, y bottom-to-top: our pitch frame
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # kloppy warns about unknown attacking direction
        if source in ("hawkeye", "hawkeye-2"):
            from kloppy import hawkeye

            stem = "hawkeye_1_1" if source == "hawkeye" else "hawkeye_2_46"
            return hawkeye.load(ball_feeds=F / f"{stem}.football.samples.ball",
                                player_centroid_feeds=F / f"{stem}.football.samples.centroids",
                                meta_data=F / "hawkeye_meta.json", coordinates=cs)
        if source == "pff":
            from kloppy import pff

            return pff.load_tracking(F / "pff_metadata_10517.json", F / "pff_rosters_10517.json",
                                     F / "pff_10517.jsonl", coordinates=cs)
        if source == "sportec":
            from kloppy import sportec

            return sportec.load_tracking(F / "sportec_meta.xml", F / "sportec_positional.xml",
                                         coordinates=cs)
        if source == "skillcorner":
            from kloppy import skillcorner

            return skillcorner.load(meta_data=F / "skillcorner_match_data.json",
                                    raw_data=F / "skillcorner_structured_data.json",
                                    coordinates=cs)
    raise ValueError(f"soccer scene: unknown source {source!r}; known: {sorted(SOURCES)}")


@functools.lru_cache(maxsize=4)
def _raw_tracks(source: str) -> _RawTracks:
    """The provider sample as arrays (cached per process: Hawk-Eye takes ~2 s to parse)."""
    ds = _load_dataset(source)
    md = ds.metadata
    players = [p for team in md.teams for p in team.players]
    index = {p.player_id: i for i, p in enumerate(players)}
    n_f = len(ds.frames)
    pos = np.full((n_f, len(players), 2), np.nan)
    times = np.empty(n_f)
    periods = np.empty(n_f, dtype=np.int64)
    for k, fr in enumerate(ds.frames):
        times[k] = fr.timestamp.total_seconds()
        periods[k] = fr.period.id
        for p, d in fr.players_data.items():
            c = d.coordinates
            if c is not None and c.x is not None and c.y is not None:
                pos[k, index[p.player_id]] = (c.x, c.y)
    seen = np.isfinite(pos[..., 0]).any(axis=0)
    keep = np.flatnonzero(seen)
    grounds = [str(getattr(getattr(t, "ground", None), "value", "")).lower() for t in md.teams]
    home = md.teams[grounds.index("home")] if "home" in grounds else md.teams[0]
    teams = np.array([0 if p.team is home else 1 for p in players])[keep]
    jerseys = np.array([int(p.jersey_no or 0) for p in players])[keep]
    gk = []
    for i in keep:
        sp = getattr(players[i], "starting_position", None)
        gk.append(sp is not None and "goalkeeper" in str(getattr(sp, "name", sp)).lower())
    dims = md.pitch_dimensions
    return _RawTracks(
        source=source, times_s=times, periods=periods, positions_m=pos[:, keep],
        player_ids=tuple(str(players[i].player_id) for i in keep), teams=teams,
        jerseys=jerseys, goalkeeper=np.array(gk, dtype=bool),
        pitch_length_m=float(dims.pitch_length or (dims.x_dim.max - dims.x_dim.min)),
        pitch_width_m=float(dims.pitch_width or (dims.y_dim.max - dims.y_dim.min)),
        rate_hz=float(md.frame_rate))


def _continuous_runs(times_s: np.ndarray, periods: np.ndarray,
                     max_gap_s: float) -> list[tuple[int, int]]:
    """Half-open index ranges [a, b) of samples with no time gap above ``max_gap_s``."""
    if len(times_s) == 0:
        return []
    dt = np.diff(times_s)
    brk = np.flatnonzero((dt > max_gap_s) | (dt <= 0) | (np.diff(periods) != 0)) + 1
    edges = np.concatenate([[0], brk, [len(times_s)]])
    return [(int(a), int(b)) for a, b in itertools.pairwise(edges) if b > a]


def load_pitch_tracks(source: str = "hawkeye", fps: float = 25.0, start_s: float = 0.0,
                      duration_s: float = 20.0, max_gap_s: float = 0.5) -> PitchTracks:
    """Real player trajectories from kloppy's sample files, on a regular time grid.

    Parameters
    ----------
    source : str
        A key of :data:`SOURCES`.
    fps : float
        Frame rate of the grid (frames per second).
    start_s : float
        Clip start in seconds from the beginning of the source's longest continuous run of play.
    duration_s : float
        Clip length, seconds; the grid has ``floor(duration_s * fps)`` frames.
    max_gap_s : float
        Largest gap between provider samples that is bridged by linear interpolation, both for
        the whole sequence (defines the continuous runs) and per player.

    Returns
    -------
    PitchTracks

    Raises
    ------
    ValueError
        Unknown source, non-positive ``fps``/``duration_s``, or a window that does not fit in the
        source's longest continuous run (the message gives its length).
    """
    if source not in SOURCES:
        raise ValueError(f"soccer scene: unknown source {source!r}; known: {sorted(SOURCES)}")
    if not fps > 0:
        raise ValueError(f"soccer scene: fps must be > 0, got {fps}")
    if not duration_s > 0:
        raise ValueError(f"soccer scene: duration_s must be > 0, got {duration_s}")
    if start_s < 0:
        raise ValueError(f"soccer scene: start_s must be >= 0, got {start_s}")
    raw = _raw_tracks(source)
    runs = _continuous_runs(raw.times_s, raw.periods, max_gap_s)
    if not runs:
        raise ValueError(f"soccer scene: source {source!r} holds no tracking frames")
    a, b = max(runs, key=lambda r: raw.times_s[r[1] - 1] - raw.times_s[r[0]])
    t = raw.times_s[a:b]
    length = float(t[-1] - t[0])
    n = math.floor(duration_s * fps + 1e-9)
    grid = t[0] + start_s + np.arange(n) / fps
    if n == 0 or grid[-1] > t[-1] + 1e-9:
        raise ValueError(
            f"soccer scene: source {source!r} has {length:.2f} s of continuous play "
            f"(longest run, {b - a} samples at {raw.rate_hz:g} Hz); start_s={start_s} + "
            f"duration_s={duration_s} does not fit")
    pos = raw.positions_m[a:b]
    # Linear interpolation per player, only between samples at most max_gap_s apart.
    j = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 1)
    j1 = np.minimum(j + 1, len(t) - 1)
    span = t[j1] - t[j]
    w = np.where(span > 0, (grid - t[j]) / np.where(span > 0, span, 1.0), 0.0)
    w = np.clip(w, 0.0, 1.0)[:, None, None]
    p0, p1 = pos[j], pos[j1]
    out = (1 - w) * p0 + w * p1
    exact = np.isclose(w[:, 0, 0], 0.0)
    out[exact] = p0[exact]  # on a sample: the sample itself even if the next is missing
    out[~exact & (span[:, None] > max_gap_s)[:, 0]] = np.nan
    # Players never present in the clip are dropped.
    present = np.isfinite(out[..., 0]).any(axis=0)
    keep = np.flatnonzero(present)
    return PitchTracks(
        source=source, times_s=grid - grid[0], positions_m=np.ascontiguousarray(out[:, keep]),
        player_ids=tuple(raw.player_ids[i] for i in keep), teams=raw.teams[keep],
        jerseys=raw.jerseys[keep], goalkeeper=raw.goalkeeper[keep],
        pitch_length_m=raw.pitch_length_m, pitch_width_m=raw.pitch_width_m,
        start_s=float(start_s), provider_rate_hz=raw.rate_hz)


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
# Static background
# ---------------------------------------------------------------------------------------------


def _noise_bank(rng: np.random.Generator, shape: tuple[int, int], std: float,
                n: int = 4) -> list[tuple[np.ndarray, np.ndarray]] | None:
    """A few frames of sensor noise split into positive and negative uint8 parts."""
    if std <= 0:
        return None
    bank = []
    for _ in range(n):
        z = np.rint(rng.normal(0.0, std, shape + (3,))).clip(-255, 255)
        bank.append((np.maximum(z, 0).astype(np.uint8), np.maximum(-z, 0).astype(np.uint8)))
    return bank


def _scaled_camera(camera: Camera, factor: int) -> Camera:
    """The same camera rendering at ``factor`` times the resolution (pixel centres kept)."""
    if factor == 1:
        return camera
    w, h = camera.image_size
    return camera.resized((w * factor, h * factor))


def marking_quads(pitch: Any, line_width_m: float = 0.12, step_m: float = 0.25) -> np.ndarray:
    """The pitch markings as thin ground quads, world metres.

    Parameters
    ----------
    pitch : SoccerPitchVolume
    line_width_m : float
        Painted line width (FIFA: at most 0.12 m).
    step_m : float
        Polyline sampling step; each short segment becomes one quad, so curves and the lens's
        bending of straight lines are followed.

    Returns
    -------
    ndarray, shape (Q, 4, 3)
        Quad corners on z = 0.
    """
    quads = []
    for poly in pitch.markings(step_m=step_m).values():
        p = poly[:, :2]
        d = np.diff(p, axis=0)
        ln = np.linalg.norm(d, axis=1)
        keep = ln > 1e-9
        if not keep.any():
            continue
        a, b, d, ln = p[:-1][keep], p[1:][keep], d[keep], ln[keep]
        u = d / ln[:, None]
        nrm = np.stack([-u[:, 1], u[:, 0]], axis=1) * (line_width_m / 2)
        ext = u * (line_width_m / 2)  # overlap the joints
        q = np.stack([a - ext + nrm, b + ext + nrm, b + ext - nrm, a - ext - nrm], axis=1)
        quads.append(np.concatenate([q, np.zeros(q.shape[:2] + (1,))], axis=2))
    return np.concatenate(quads) if quads else np.zeros((0, 4, 3))


def _goal_boxes(pitch: Any) -> np.ndarray:
    """Posts and crossbars of both goals as thin boxes, (B, 8, 3) world metres."""
    from pftrack.geometry.volumes import GOAL_WIDTH_M

    hl = pitch.length_m / 2
    gw = GOAL_WIDTH_M / 2
    r = 0.06
    gh = 2.44
    boxes = []
    off = pitch.origin_offset_m
    for sgn in (-1.0, 1.0):
        x = sgn * (hl + r)
        for lo, hi in (([x - r, -gw - 2 * r, 0], [x + r, -gw, gh + r]),
                       ([x - r, gw, 0], [x + r, gw + 2 * r, gh + r]),
                       ([x - r, -gw - 2 * r, gh], [x + r, gw + 2 * r, gh + 2 * r])):
            lo, hi = np.array(lo), np.array(hi)
            c = np.array([[lo[0] if i & 1 == 0 else hi[0], lo[1] if i & 2 == 0 else hi[1],
                           lo[2] if i & 4 == 0 else hi[2]] for i in range(8)])
            boxes.append(c + off)
    return np.array(boxes)


def render_pitch_background(camera: Camera, pitch: Any, rng: np.random.Generator,
                            centre_m: Any = None, supersample: int = 2,
                            n_stripes: int = 18) -> np.ndarray:
    """The empty pitch seen by ``camera``: grass with mowing stripes, markings, goals, stands.

    Every pixel is cast onto the ground (z = 0) through the camera's lens model; the stripes
    and the grass texture are functions of the ground point, the markings are ground quads
    projected and filled, so all of it bends with the lens exactly as the players do.

    Parameters
    ----------
    camera : Camera
        Output size is ``camera.image_size``.
    pitch : SoccerPitchVolume
        Size and markings; its ``margin_m`` is the grass run-off around the lines.
    rng : numpy.random.Generator
        Grass texture and crowd speckle.
    centre_m : array_like, shape (3,), optional
        World position of the centre spot in the camera's frame; default the pitch's own
        ``origin_offset_m`` (0 for a centre-frame pitch).
    supersample : int
        Render at this factor and average down (anti-aliasing).
    n_stripes : int
        Mowing stripes across the length of the pitch.

    Returns
    -------
    ndarray, shape (H, W, 3), uint8, BGR
    """
    import cv2

    W, H = camera.image_size
    cam = _scaled_camera(camera, supersample)
    Ws, Hs = cam.image_size
    u, v = np.meshgrid(np.arange(Ws, dtype=np.float64), np.arange(Hs, dtype=np.float64))
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        g = cam.image_to_ground(np.column_stack([u.ravel(), v.ravel()]))
    c = np.asarray(pitch.origin_offset_m if centre_m is None else centre_m, dtype=np.float64)
    shift = c - np.asarray(pitch.origin_offset_m, dtype=np.float64)  # pitch frame -> world
    gx = (g[:, 0] - c[0]).reshape(Hs, Ws)
    gy = (g[:, 1] - c[1]).reshape(Hs, Ws)
    hl, hw, m = pitch.length_m / 2, pitch.width_m / 2, pitch.margin_m
    on_ground = np.isfinite(gx)
    # far away the ground is seen at grazing angles: everything beyond the run-off is stands
    grass = on_ground & (np.abs(gx) <= hl + m) & (np.abs(gy) <= hw + m)
    # grass: two shades in stripes along x, low-frequency texture, fine noise
    stripe = np.floor((np.nan_to_num(gx) + hl) / (pitch.length_m / n_stripes)).astype(np.int64)
    shade = np.where(stripe % 2 == 0, 1.0, 0.86)
    tex_small = rng.normal(0.0, 1.0, (48, 80)).astype(np.float32)
    tex = cv2.resize(cv2.GaussianBlur(tex_small, (0, 0), 1.5), (Ws, Hs),
                     interpolation=cv2.INTER_CUBIC)
    tex = 1.0 + 0.06 * tex / max(float(np.std(tex)), 1e-6)
    base = np.array([60.0, 140.0, 70.0])  # BGR grass green
    img = np.empty((Hs, Ws, 3), np.float32)
    img[:] = (shade * tex)[..., None] * base
    # outside the run-off: advertising boards, a running track 8 m wide, then (and above the
    # horizon) the stands with a blurred crowd texture
    track = on_ground & ~grass & (np.abs(gx) <= hl + m + 8.0) & (np.abs(gy) <= hw + m + 8.0)
    stands = ~grass & ~track
    if stands.any():
        palette = np.array([[70, 60, 55], [95, 90, 100], [55, 50, 65], [110, 105, 100],
                            [60, 70, 95]], np.float32)
        crowd = palette[rng.integers(0, len(palette), (Hs // 4 + 1, Ws // 4 + 1))]
        crowd = cv2.GaussianBlur(crowd, (0, 0), 0.8)
        cimg = cv2.resize(crowd, (Ws, Hs), interpolation=cv2.INTER_LINEAR)
        rows = np.linspace(0.8, 1.0, Hs, dtype=np.float32)[:, None, None]
        img[stands] = (cimg * rows)[stands]
    img[track] = (70, 85, 110)  # a dull brown-grey track
    board = on_ground & ~grass & (np.abs(gx) <= hl + m + 0.8) & (np.abs(gy) <= hw + m + 0.8)
    img[board] = (40, 40, 150)
    img = np.clip(img, 0, 255).astype(np.uint8)
    # markings: thin ground quads projected through the lens, filled one by one (fillPoly with
    # several overlapping polygons would cancel their overlaps), anti-aliased by downsampling
    quads = marking_quads(pitch, 0.12, 0.25) + shift
    qpx = cam.project(quads.reshape(-1, 3)).reshape(-1, 4, 2)
    good = np.isfinite(qpx).all(axis=(1, 2))
    qpx = qpx[good]
    inside = ((qpx[..., 0].max(1) >= -2) & (qpx[..., 0].min(1) <= Ws + 2)
              & (qpx[..., 1].max(1) >= -2) & (qpx[..., 1].min(1) <= Hs + 2))
    for q in np.round(qpx[inside] * 16).astype(np.int32):
        cv2.fillConvexPoly(img, q, (235, 238, 235), lineType=cv2.LINE_8, shift=4)
    # goals: posts and crossbar as projected thin boxes
    gb = _goal_boxes(pitch) + shift
    gpx = cam.project(gb.reshape(-1, 3)).reshape(-1, 8, 2)
    for q in gpx:
        if np.isfinite(q).all():
            hull = cv2.convexHull(np.round(q * 16).astype(np.int32))
            cv2.fillConvexPoly(img, hull, (245, 245, 245), lineType=cv2.LINE_AA, shift=4)
    if supersample > 1:
        img = cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA)
    return np.ascontiguousarray(img)




# ---------------------------------------------------------------------------------------------
# A detector for a fixed camera over a pitch
# ---------------------------------------------------------------------------------------------


class PitchBlobDetector(Detector):
    """Players as foreground blobs inside the pitch's image region, sized by the camera.

    A fixed, calibrated camera over a pitch knows where players can be and how tall they look
    there. Per frame: OpenCV's MOG2 background model is updated on the pitch's bounding band of
    rows only (the run-off included); its foreground (shadows dropped) outside the projected
    pitch is cleared, closed vertically (limbs and torso join), and split into 8-connected blobs.
    For each blob the expected box of a ``height_m`` x ``width_m`` player standing at its bottom
    centre is computed through the camera (the same cuboid as the soccer scene's ground truth);
    blobs much smaller than that are dropped, blobs much wider are split into side-by-side
    players and blobs much taller into a near (bottom) and a far (top) player.

    {params}

    Attributes
    ----------
    camera_ : Camera
    band_ : tuple of int
        Rows ``(top, bottom)`` and columns ``(left, right)`` processed, ``(y0, y1, x0, x1)``.
    region_ : ndarray, shape (y1 - y0, x1 - x0), uint8
        255 where the pitch (with margin) is seen.
    subtractor_ : cv2.BackgroundSubtractorMOG2
    frames_seen_ : int

    Notes
    -----
    Detections carry ``points_world_m``: the ground point under each box's bottom centre.
    Scores are the blob's foreground fill of its box times its height agreement (times
    ``split_score`` for the parts of a split blob), in (0, 1].
    """

    camera: str | os.PathLike[str] | None = Param(
        None, "Camera file; default the project's soccer camera "
        "(:func:`default_soccer_camera_path`).")
    volume: str = Param(
        _DEFAULT_VOLUME,
        "Pitch volume (camera's world frame) whose run-off bounds the search region.")
    margin_m: float = Param(
        2.0, "Extra ground margin around the volume, metres.", unit="m", low=0.0)
    history: int = Param(
        500, "MOG2's history (frames its background model remembers).", unit="frames", low=1)
    var_threshold: float = Param(
        16.0, "MOG2's varThreshold (squared Mahalanobis distance of a foreground pixel).",
        unit="1", low=0.0, low_open=True)
    learning_rate: float | None = Param(
        None,
        "MOG2's learning rate. None: automatic -- OpenCV's ``1 / min(frames, history)`` while "
        "the detector learns the background from the stream itself, and 0 (a frozen "
        "background) once :meth:`fit` has learned it from frames of the empty pitch, so "
        "players who stand still are never absorbed into the background.",
        unit="1/frame", high=1.0)
    detect_shadows: bool = Param(True, "MOG2 marks shadows (then counted as background).")
    height_m: float = Param(
        1.8, "Player height (its cuboid gives the expected box at each foot point).",
        unit="m", low=0.0, low_open=True)
    width_m: float = Param(
        0.6, "Player width (its cuboid gives the expected box at each foot point).",
        unit="m", low=0.0, low_open=True)
    min_height_frac: float = Param(
        0.4, "Blobs shorter than this fraction of the expected height are dropped.",
        unit="1", low=0.0)
    split_factor: float = Param(
        1.6, "A blob wider (taller) than ``split_factor`` times the expected width (height) is "
        "split.", unit="1", low=0.0, low_open=True)
    split_score: float = Param(
        0.4, "Factor on the score of the parts of a split blob (their positions are guesses), so "
        "that births (``min_score``) can ignore them while the tracker still uses them.",
        unit="1", low=0.0)
    foot_depth_m: float = Param(
        0.7,
        "Ground distance from a blob's lowest point (the nearest foot, plus the anti-aliased "
        "fringe) to the player's centre, away from the camera, added to ``points_world_m``. "
        "0.7 m removes the mean depth bias on the soccer scene with the soccer paper's camera "
        "(measured: mean error along the viewing direction -0.57 m at 0.3, ~0 at 0.7).", unit="m")
    boxes: str = Param(
        "model",
        '``"model"``: each detection\'s box is the box of a ``height_m`` player standing at '
        "its ``points_world_m`` (:meth:`model_boxes`), the convention of the tracker's "
        ":class:`~pftrack.builtin.world_observation.CameraBoxObservation`, so foot points compare "
        'without the bias of the blob\'s lowest pixel; ``"blob"``: the (split) blob\'s own '
        "bounding box.", choices=("model", "blob"))
    warmup_frames: int = Param(
        1, "Frames at the start of a stream that only teach the background (unless fitted).",
        unit="frames", low=0)

    _STATE = ("camera_", "band_", "region_", "subtractor_", "frames_seen_", "image_shape_")

    def setup(self, context: RunContext) -> None:
        """The run's camera (``--camera``) when ``camera`` is not set."""
        if context.camera is not None:
            self.run_camera_ = context.camera

    def fit(self, frames: Any, boxes_by_frame: dict[int, np.ndarray] | None = None,
            rng: np.random.Generator | None = None,
            ignore_by_frame: dict[int, np.ndarray] | None = None) -> PitchBlobDetector:
        """Learn the background from frames of the pitch before play (a fixed camera can film
        the empty pitch; :meth:`SoccerScene.empty_frames` renders such frames).

        Frames with moving players work too (MOG2 averages them away), but players standing
        still would become background. ``boxes_by_frame`` and ``rng`` are not used. The learned
        band of each frame is kept (``fit_crops_``) so that :meth:`reset`, copies and unpickled
        detectors start from the same background. Returns ``self``.
        """
        crops = []
        shape = None
        self.__dict__.pop("fit_crops_", None)
        self.reset()
        for frame in frames:
            img = np.asarray(frame.image)
            if img.ndim != 3 or img.dtype != np.uint8:
                raise ValueError(f"PitchBlobDetector.fit: frame {frame.index} must be an "
                                 f"(H, W, 3) uint8 image, got {img.shape} {img.dtype}")
            if shape is None:
                shape = img.shape
                self._setup(shape)
            elif img.shape != shape:
                raise ValueError(f"PitchBlobDetector.fit: frame {frame.index} has shape "
                                 f"{img.shape}, the first had {shape}")
            y0, y1, x0, x1 = self.band_
            crops.append(np.ascontiguousarray(img[y0:y1, x0:x1]))
        self.fit_crops_ = crops
        self.fit_shape_ = shape
        self.reset()
        return self

    @classmethod
    def _conformance_example(cls) -> tuple[PitchBlobDetector, dict[str, Any]]:
        """A detector and 6 frames of the soccer scene at 640 x 360 for :mod:`pftrack.testing`."""
        return cls(), {"frames": [Frame(f.index, f.image.copy(), f.time_s)
                                  for f in _example_frames()]}

    def reset(self) -> PitchBlobDetector:
        """Start a new stream: forget what the stream taught (what :meth:`fit` learned stays)."""
        for k in self._STATE:
            self.__dict__.pop(k, None)
        return self

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        for k in self._STATE:  # OpenCV's model cannot be pickled: a new stream starts over
            state.pop(k, None)
        return state

    def _setup(self, shape: tuple[int, ...]) -> None:
        import cv2
        from pftrack.geometry.formats import load_camera
        from pftrack.geometry.volumes import resolve_volume

        given = self.camera if self.camera is not None else getattr(self, "run_camera_", None)
        if given is not None and not isinstance(given, (str, os.PathLike)):
            cam, path = given, "(the run's camera)"
        else:
            path = Path(given) if given is not None else default_soccer_camera_path()
            if not path.is_file():
                raise FileNotFoundError(f"PitchBlobDetector: camera file not found: {path}")
            cam = load_camera(path)
        h, w = shape[:2]
        if tuple(cam.image_size) != (w, h):
            cam = cam.resized((w, h))
        lo, hi = np.asarray(resolve_volume(self.volume).bounds(), dtype=np.float64)[:, :2]
        m = float(self.margin_m)
        lo, hi = lo - m, hi + m
        # the ground rectangle's outline, densely sampled so the lens bends it
        from pftrack.geometry.volumes import sample_polyline

        ring = sample_polyline(np.array([[lo[0], lo[1], 0], [hi[0], lo[1], 0],
                                         [hi[0], hi[1], 0], [lo[0], hi[1], 0],
                                         [lo[0], lo[1], 0]]), 0.5)
        px = cam.project(ring)
        px = px[np.isfinite(px).all(axis=1)]
        if len(px) < 3:
            raise ValueError(f"PitchBlobDetector: volume {self.volume!r} is not in view of "
                             f"camera {path}")
        full = np.zeros((h, w), np.uint8)
        cv2.fillPoly(full, [np.round(px).astype(np.int32)], 255)
        # head room above the far edge: players stand up to height_m above the ground
        pad = int(np.ceil(cam.fy * self.height_m / max(float(np.min(
            cam.depth(ring[::10]))), 1.0))) + 2
        ys, xs = np.nonzero(full)
        if len(ys) == 0:
            raise ValueError(f"PitchBlobDetector: volume {self.volume!r} projects outside the "
                             f"{w}x{h} image of camera {path}")
        y0, y1 = max(int(ys.min()) - pad, 0), min(int(ys.max()) + 2, h)
        x0, x1 = max(int(xs.min()) - 2, 0), min(int(xs.max()) + 2, w)
        region = cv2.dilate(full, np.ones((2 * pad + 1, 1), np.uint8), anchor=(0, 2 * pad))
        self.camera_ = cam
        self.band_ = (y0, y1, x0, x1)
        self.region_ = np.ascontiguousarray(region[y0:y1, x0:x1])
        self.subtractor_ = cv2.createBackgroundSubtractorMOG2(
            history=int(self.history), varThreshold=float(self.var_threshold),
            detectShadows=bool(self.detect_shadows))
        self.frames_seen_ = 0
        self.image_shape_ = tuple(shape)
        if self._fitted():
            if tuple(self.fit_shape_) != tuple(shape):
                raise ValueError(f"PitchBlobDetector: frames of shape {tuple(shape)} but the "
                                 f"background was fitted on {tuple(self.fit_shape_)}")
            for crop in self.fit_crops_:
                self.subtractor_.apply(crop, learningRate=-1.0)

    def _fitted(self) -> bool:
        return bool(getattr(self, "fit_crops_", None))

    def _rate(self) -> float:
        if self.learning_rate is not None:
            return float(self.learning_rate)
        return 0.0 if self._fitted() else -1.0

    def expected_boxes(self, foot_px: np.ndarray) -> np.ndarray:
        """Boxes (K, 4) xywh px of a player cuboid standing at each foot pixel (K, 2)."""
        cam = self.camera_
        g = cam.image_to_ground(np.asarray(foot_px, dtype=np.float64).reshape(-1, 2))
        k = len(g)
        hw = self.width_m / 2
        off = np.array([[sx * hw, sy * hw, sz * self.height_m]
                        for sz in (0, 1) for sy in (-1, 1) for sx in (-1, 1)])
        pts = (g[:, None, :] + off[None]).reshape(-1, 3)
        px = cam.project(pts).reshape(k, 8, 2)
        lo, hi = px.min(axis=1), px.max(axis=1)
        return np.column_stack([lo, hi - lo])

    def foreground_mask(self, frame: Frame) -> np.ndarray:
        """Update the model; the cleaned foreground of the processed band, (y1-y0, x1-x0)."""
        import cv2

        img = np.asarray(frame.image)
        if img.ndim != 3 or img.dtype != np.uint8:
            raise ValueError(f"PitchBlobDetector: frame {frame.index} must be an (H, W, 3) "
                             f"uint8 image, got {img.shape} {img.dtype}")
        if getattr(self, "image_shape_", None) is None:
            self._setup(img.shape)
        elif self.image_shape_ != img.shape:
            raise ValueError(f"PitchBlobDetector: frame {frame.index} has shape {img.shape} "
                             f"but the stream started with {self.image_shape_}; call reset()")
        y0, y1, x0, x1 = self.band_
        raw = self.subtractor_.apply(np.ascontiguousarray(img[y0:y1, x0:x1]),
                                     learningRate=self._rate())
        self.frames_seen_ += 1
        mask = np.where((raw == 255) & (self.region_ > 0), np.uint8(255), np.uint8(0))
        return cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((3, 1), np.uint8))

    def detect(self, frame: Frame) -> Detections:
        import cv2

        mask = self.foreground_mask(frame)
        if not self._fitted() and self.frames_seen_ <= int(self.warmup_frames):
            return Detections.empty()
        _, _, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        stats = stats[1:]
        stats = stats[stats[:, cv2.CC_STAT_AREA] >= 3]
        if len(stats) == 0:
            return Detections.empty()
        y0, _, x0, _ = self.band_
        bx = stats[:, [cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH,
                       cv2.CC_STAT_HEIGHT]].astype(np.float64)
        bx[:, 0] += x0
        bx[:, 1] += y0
        # a blob covers pixel centres left..left+w-1; its outermost pixels are mostly the
        # half-covered anti-aliased fringe, so the figure's edges lie at those centres
        bx[:, 2:] = np.maximum(bx[:, 2:] - 1.0, 1.0)
        area = stats[:, cv2.CC_STAT_AREA].astype(np.float64)
        foot = np.column_stack([bx[:, 0] + bx[:, 2] / 2, bx[:, 1] + bx[:, 3]])
        exp = self.expected_boxes(foot)
        ok = np.isfinite(exp).all(axis=1) & (bx[:, 3] >= self.min_height_frac * exp[:, 3])
        boxes, scores = [], []
        for b, a, e in zip(bx[ok], area[ok], exp[ok]):  # loop over blobs (a few dozen)
            fill = a / max(b[2] * b[3], 1.0)
            n_wide = round(b[2] / e[2]) if b[2] > self.split_factor * e[2] else 1
            tall = b[3] > self.split_factor * e[3]
            parts = []
            for i in range(max(n_wide, 1)):
                wi = b[2] / n_wide
                left = b[0] + i * wi
                parts.append([left, b[1] + (b[3] - e[3] if tall else 0.0), wi,
                              e[3] if tall else b[3]])
                if tall:  # a far player whose feet are hidden behind the near one
                    parts.append([left, b[1], wi, e[3]])
            agree = min(1.0, b[3] / e[3]) if not tall else 1.0
            # a split guesses where the players of a merged blob stand: less confident
            conf = fill * agree * (float(self.split_score) if len(parts) > 1 else 1.0)
            for p in parts:
                boxes.append(p)
                scores.append(float(np.clip(conf, 1e-3, 1.0)))
        if not boxes:
            return Detections.empty()
        boxes_a = np.asarray(boxes, dtype=np.float64)
        foot = np.column_stack([boxes_a[:, 0] + boxes_a[:, 2] / 2, boxes_a[:, 1] + boxes_a[:, 3]])
        world = self.camera_.image_to_ground(foot)
        # the lowest pixel is the nearest foot: the player's centre lies a little further away
        away = world[:, :2] - self.camera_.center_m[None, :2]
        away /= np.maximum(np.linalg.norm(away, axis=1, keepdims=True), 1e-9)
        world[:, :2] += float(self.foot_depth_m) * away
        if self.boxes == "model":
            boxes_a = self.model_boxes(world)
            ok = np.isfinite(boxes_a).all(axis=1)
            boxes_a, world = boxes_a[ok], world[ok]
            scores = list(np.asarray(scores)[ok])
        return Detections(boxes_a, np.asarray(scores, dtype=np.float64), world)

    def model_boxes(self, points_world_m: np.ndarray) -> np.ndarray:
        """Boxes (K, 4) of ``height_m`` players standing at ground points (K, 3): bottom centre
        at the projected point, top at the projected head, width ``width_m / height_m`` of the
        height (the convention of
        :class:`pftrack.builtin.world_observation.CameraBoxObservation`)."""
        g = np.asarray(points_world_m, dtype=np.float64).reshape(-1, 3).copy()
        g[:, 2] = 0.0
        head = g.copy()
        head[:, 2] = float(self.height_m)
        px = self.camera_.project(np.concatenate([g, head]))
        foot, top = px[: len(g)], px[len(g):]
        h = np.hypot(*(foot - top).T)
        w = h * float(self.width_m) / float(self.height_m)
        return np.column_stack([foot[:, 0] - w / 2, foot[:, 1] - h, w, h])


@functools.lru_cache(maxsize=1)
def _example_frames() -> tuple[Frame, ...]:
    """Six small frames of the soccer scene (cached; the conformance kit asks repeatedly)."""
    scene = SoccerScene(duration_s=0.24, image_size=(640, 360), supersample=1)
    return tuple(scene.frames())


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
