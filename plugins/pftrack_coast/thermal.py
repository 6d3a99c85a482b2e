"""Thermal clips for the background benchmark: reading, reference boxes, a simulated
recalibration.

* :func:`read_thermal` reads a CPTV file (the Cacophony Project's trail-camera format, with the
  PyPI package ``cptv``) or a folder of 16-bit PNG/TIFF frames into raw counts, frame times and
  the camera's own record of its last flat-field correction (FFC) per frame.
* :func:`reference_boxes` derives one box per frame for a single warm animal by thresholding
  each frame against an empty background frame; :func:`write_reference_mot` writes them as a
  MOTChallenge file. The annotation shipped for ``thermal/animal_entry.cptv``
  (``pftrack_coast/data/animal_entry_gt.txt``) was made this way and checked by eye.
* :func:`simulate_recalibration` changes a clip from a frame on as a real FFC of a FLIR Lepton
  does: a pause in the recording, a global level step, and a new per-pixel fixed pattern.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["ThermalClip", "read_thermal", "reference_boxes", "simulate_recalibration",
           "write_reference_mot", "DEFAULT_ANNOTATION"]

DEFAULT_ANNOTATION = Path(__file__).parent / "data" / "animal_entry_gt.txt"


@dataclass
class ThermalClip:
    """Raw frames of a thermal clip.

    Attributes
    ----------
    frames : list of (H, W) ndarray
        Raw counts (uint16 for a CPTV file), frame ``k`` at index ``k`` (0-based; the frame
        numbers of the clip's annotation).
    times_s : ndarray, shape (N,)
        Each frame's time in seconds (the camera's time since power-on for a CPTV file; frame
        numbers times ``1 / fps`` for a folder of frames).
    ffc_s : ndarray, shape (N,)
        The camera's time of its last flat-field correction at each frame (NaN when unknown).
    background : ndarray, shape (N,), bool
        Frames the camera stored as its background image (a CPTV file's ``background_frame``).
    source : str
        Where the clip was read from.
    """

    frames: list[np.ndarray]
    times_s: np.ndarray
    ffc_s: np.ndarray
    background: np.ndarray
    source: str
    notes: list[str] = field(default_factory=list)


def read_thermal(path: str | os.PathLike[str], fps: float = 9.0) -> ThermalClip:
    """Read a ``.cptv`` file or a folder of single-channel frames (``*.png``, ``*.tif``,
    ``*.tiff``, read unchanged, sorted by name).

    Raises
    ------
    FileNotFoundError
        No such file or folder.
    ValueError
        Neither a CPTV file nor a folder of frames, frames of different sizes, or none.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"thermal clip {p} not found")
    if p.is_dir():
        import cv2

        files = sorted(f for f in p.iterdir() if f.suffix.lower() in (".png", ".tif", ".tiff"))
        frames = []
        for f in files:
            img = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
            if img is None or img.ndim != 2:
                raise ValueError(f"thermal clip {p}: {f.name} is not a single-channel image")
            frames.append(img)
        if not frames:
            raise ValueError(f"thermal clip {p}: no .png or .tif frames")
        n = len(frames)
        return _checked(ThermalClip(frames, np.arange(n) / float(fps), np.full(n, np.nan),
                                    np.zeros(n, bool), str(p)))
    if p.suffix.lower() != ".cptv":
        raise ValueError(f"thermal clip {p}: expected a .cptv file or a folder of frames")
    from cptv import CPTVReader

    frames, times, ffc, bg = [], [], [], []
    try:
        with open(p, "rb") as fh:
            for f in CPTVReader(fh):
                frames.append(np.asarray(f.pix))
                times.append(_seconds(f.time_on))
                ffc.append(_seconds(f.last_ffc_time))
                bg.append(bool(getattr(f, "background_frame", False)))
    except (OSError, EOFError, ValueError) as exc:
        raise ValueError(f"thermal clip {p}: not a readable CPTV file ({exc})") from None
    if not frames:
        raise ValueError(f"thermal clip {p}: no frames")
    return _checked(ThermalClip(frames, np.array(times), np.array(ffc), np.array(bg), str(p)))


def _seconds(t: object) -> float:
    if t is None:
        return float("nan")
    return float(t.total_seconds()) if hasattr(t, "total_seconds") else float(t)  # type: ignore[arg-type]


def _checked(clip: ThermalClip) -> ThermalClip:
    shape = clip.frames[0].shape
    for k, f in enumerate(clip.frames):
        if f.shape != shape:
            raise ValueError(f"thermal clip {clip.source}: frame {k} is {f.shape}, frame 0 "
                             f"{shape}")
    return clip


def reference_boxes(frames: list[np.ndarray], background: int = 0, threshold: float = 40.0,
                    min_area: int = 4) -> dict[int, np.ndarray]:
    """One box (left, top, width, height px) per frame around a single warm animal.

    Each frame and the empty ``background`` frame lose their own median level; the
    difference, smoothed by a 3x3 Gaussian, is thresholded at ``threshold`` counts; the box
    is the bounding rectangle of every 8-connected group of at least ``min_area`` pixels (a
    dim animal may break into pieces). Frames with no such group get no box.
    """
    import cv2

    ref = frames[background].astype(np.float64)
    ref = ref - np.median(ref)
    out: dict[int, np.ndarray] = {}
    for k, f in enumerate(frames):
        if k == background:
            continue
        g = f.astype(np.float64)
        d = cv2.GaussianBlur(g - np.median(g) - ref, (3, 3), 0)
        n, _, st, _ = cv2.connectedComponentsWithStats((d > threshold).astype(np.uint8),
                                                       connectivity=8)
        s = st[1:][st[1:, 4] >= int(min_area)]
        if not len(s):
            continue
        x0, y0 = s[:, 0].min(), s[:, 1].min()
        x1, y1 = (s[:, 0] + s[:, 2]).max(), (s[:, 1] + s[:, 3]).max()
        out[k] = np.array([x0, y0, x1 - x0, y1 - y0], dtype=np.float64)
    return out


def write_reference_mot(boxes: dict[int, np.ndarray], path: str | os.PathLike[str],
                        header: str = "") -> Path:
    """Write :func:`reference_boxes` as a MOTChallenge file (frame = the clip's 0-based frame
    number, id 1), ``header`` lines as ``#`` comments, atomically."""
    from pftrack.io.atomic import atomic_path

    path = Path(path)
    lines = [f"# {h}" for h in header.splitlines()]
    lines += [f"{k},1,{b[0]:.0f},{b[1]:.0f},{b[2]:.0f},{b[3]:.0f},1,-1,-1,-1"
              for k, b in sorted(boxes.items())]
    with atomic_path(path) as tmp:
        Path(tmp).write_text("\n".join(lines) + "\n")
    return path


def simulate_recalibration(clip: ThermalClip, at: int, level_step: float = -33.0,
                           pattern_sigma: float = 6.0, column_sigma: float = 4.0,
                           shading_sigma: float = 15.0, shading_scale_px: float = 6.0,
                           gap_s: float = 1.6, rng: np.random.Generator | None = None,
                           ) -> ThermalClip:
    """A copy of ``clip`` with a flat-field correction from frame ``at`` on.

    From ``at``: every frame's counts move by ``level_step`` plus a new fixed pattern, the same
    in every later frame: per-pixel Gaussian offsets of ``pattern_sigma`` counts, per-column
    ones of ``column_sigma`` (a Lepton's pattern is partly by column) and a smooth shading of
    ``shading_sigma`` counts (Gaussian noise blurred over ``shading_scale_px`` px: the uneven
    warming of the sensor that the correction resets), rounded and clipped to the input's
    integer range; the frame times jump by ``gap_s`` seconds (the shutter's pause). The
    camera's own FFC record is left as it was, so only the picture and the times tell.

    The pause and the level step are those of a real FFC of a Lepton 3.5 trail camera (1.6 s,
    -33 counts). The pattern's sizes are not measured from a camera: they are set so that on
    ``thermal/animal_entry.cptv`` the eigenspace model without recovery flags about 35 of its
    300 blocks a frame after the event, as the same kind of model did after that real FFC.
    """
    if not 0 < int(at) < len(clip.frames):
        raise ValueError(f"simulate_recalibration: at={at} must be inside the clip's "
                         f"{len(clip.frames)} frames")
    rng = rng if rng is not None else np.random.default_rng(0)
    h, w = clip.frames[0].shape
    pattern = rng.normal(0.0, float(pattern_sigma), (h, w)) + \
        rng.normal(0.0, float(column_sigma), (1, w)) + float(level_step)
    if shading_sigma > 0:
        import cv2

        field = cv2.GaussianBlur(rng.normal(0.0, 1.0, (h, w)), (0, 0), float(shading_scale_px))
        pattern += float(shading_sigma) * field / max(float(field.std()), 1e-12)
    frames = list(clip.frames)
    for k in range(int(at), len(frames)):
        f = frames[k]
        g = f.astype(np.float64) + pattern
        if np.issubdtype(f.dtype, np.integer):
            info = np.iinfo(f.dtype)
            g = np.clip(np.rint(g), info.min, info.max)
        frames[k] = g.astype(f.dtype)
    times = clip.times_s.copy()
    times[int(at):] += float(gap_s)
    note = (f"simulated recalibration at frame {at}: level {level_step:+g}, pattern "
            f"{pattern_sigma:g} (pixel) + {column_sigma:g} (column) + {shading_sigma:g} "
            f"(shading) counts, gap {gap_s:g} s")
    return ThermalClip(frames, times, clip.ffc_s.copy(), clip.background.copy(), clip.source,
                       [*clip.notes, note])
