"""Real player trajectories for the ``soccer`` scene, read from kloppy's sample files.

The tracking samples ``kloppy`` ships in its wheel (``kloppy/tests/files``) are loaded with
kloppy's own loaders in pitch metres, centre frame (origin at the centre spot, x along the
length, y across), and resampled onto the video's regular time grid (linear interpolation
between provider samples, only across gaps up to ``max_gap_s``). The sources and how long each
plays continuously are in :mod:`pftrack_world.soccer`'s docstring.
"""

from __future__ import annotations

import functools
import itertools
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

#: Source name -> short description (see the module docstring's table).
SOURCES: dict[str, str] = {
    "hawkeye": "Hawk-Eye centroids, 1st half minute 1 (50 Hz, 22 players, 60 s continuous)",
    "hawkeye-2": "Hawk-Eye centroids, 2nd half minute 46 (50 Hz, 22 players, 60 s continuous)",
    "pff": "PFF FC match 10517 (29.97 Hz, 22 players, clips of 0.83 s)",
    "sportec": "Sportec/DFL positional sample (25 Hz, 1-3 players, 4 s)",
    "skillcorner": "SkillCorner broadcast tracking (10 Hz, players in view only)",
}


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
