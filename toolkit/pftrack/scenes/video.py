"""A generic scene that streams a video file, with optional MOTChallenge ground truth.

Frames are numbered as the ground truth counts them: MOTChallenge frame ``N`` is the video's
frame ``N - 1`` counted from 0 (``index_offset=1``, the MOTChallenge convention, checked on
PETS 2009 S2.L1 by overlaying the boxes). A slice ``[first, last]`` of ground-truth frame numbers
can be streamed; decoding starts at the video's beginning and skips (grabs without retrieving)
the frames before ``first``, because seeking in AVI/MP4 files is not frame-exact with every codec.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from pftrack.contracts.components import Frame, Param, Scene

__all__ = ["VideoScene", "write_test_clip"]


class VideoScene(Scene):
    """Stream a video file as :class:`~pftrack.contracts.components.Frame` objects.

    {params}

    Notes
    -----
    ``frames()`` never holds more than one decoded frame; call it again to stream again.
    """

    path: str | os.PathLike[str] = Param(
        doc="The video file (anything OpenCV's ``VideoCapture`` decodes).")
    gt_path: str | os.PathLike[str] | None = Param(
        None, "A MOTChallenge ground-truth file for it.")
    first: int = Param(
        1, "First frame to stream, in ground-truth numbering (default 1: the video's first "
        "frame).", unit="frames")
    last: int | None = Param(
        None, "Last frame to stream (inclusive); None: to the end.", unit="frames")
    index_offset: int = Param(
        1, "Ground-truth frame number of the video's frame 0 (MOTChallenge: 1).", unit="frames")
    frame_rate: float | None = Param(
        None, "Frames per second; None: read from the file (25 if the file does not say).",
        unit="frames/s", low=0.0, low_open=True)

    @classmethod
    def _conformance_example(cls) -> VideoScene:
        """A 4-frame 64 x 48 MJPG video with ground truth, written once per process to the
        temporary folder (for :mod:`pftrack.testing`)."""
        import tempfile

        folder = Path(tempfile.gettempdir()) / f"pftrack-video-scene-{os.getpid()}"
        video, gt = folder / "clip.avi", folder / "gt.txt"
        if not (video.is_file() and gt.is_file()):
            write_test_clip(video, gt)
        return cls(path=str(video), gt_path=str(gt))

    def _open(self):
        import cv2

        p = Path(os.fspath(self.path))
        if not p.is_file():
            raise FileNotFoundError(f"video scene: video file {p} not found")
        cap = cv2.VideoCapture(str(p))
        if not cap.isOpened():
            raise ValueError(f"video scene: OpenCV cannot open {p}")
        return cap

    def _check_relations(self) -> None:
        if self.last is not None and self.last < self.first:
            raise ValueError(f"video scene: last ({self.last}) is before first ({self.first})")

    @property
    def fps(self) -> float:
        if self.frame_rate is not None:
            return float(self.frame_rate)
        import cv2

        cap = self._open()
        try:
            f = float(cap.get(cv2.CAP_PROP_FPS))
        finally:
            cap.release()
        return f if f > 0 else 25.0

    @property
    def frame_count(self) -> int:
        """Frames in the file, as the container reports it."""
        import cv2

        cap = self._open()
        try:
            return int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        finally:
            cap.release()

    @property
    def size_wh(self) -> tuple[int, int]:
        """Frame size (width, height) px, as the container reports it."""
        import cv2

        cap = self._open()
        try:
            return int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        finally:
            cap.release()

    def frames(self) -> Iterator[Frame]:
        """The frames, numbered from the decoder's position
        (:class:`pftrack.scenes.source.FrameSource`); the last stream's gaps and short read are
        in ``frame_report_``."""
        from pftrack.scenes.source import FrameSource

        fps = self.fps
        self._open().release()  # the errors of this scene, naming the file
        source = FrameSource(self.path, self.first, self.last, int(self.index_offset))
        self.frame_report_ = source.report
        yield from source.frames(fps)
        self.frame_report_ = source.report

    def ground_truth(self) -> np.ndarray | None:
        """The ground-truth rows of the streamed frames, (M, 10), or None without ``gt_path``."""
        if self.gt_path is None:
            return None
        from pftrack.io.mot import read_mot

        p = Path(os.fspath(self.gt_path))
        if not p.is_file():
            raise FileNotFoundError(f"video scene: ground-truth file {p} not found")
        rows = read_mot(p)
        keep = rows[:, 0] >= self.first
        if self.last is not None:
            keep &= rows[:, 0] <= self.last
        return rows[keep]


def write_test_clip(video_path: str | os.PathLike[str], gt_path: str | os.PathLike[str],
                    n_frames: int = 4, size_wh: tuple[int, int] = (64, 48)) -> None:
    """Write a tiny MJPG clip of a white square moving right on grey, and its MOT ground truth
    (id 1, 10 x 10 px box), atomically. For tests and the conformance kit."""
    import cv2

    from pftrack.io.atomic import atomic_path, atomic_write_text

    w, h = size_wh
    rows = []
    with atomic_path(video_path) as tmp:
        out = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (w, h))  # type: ignore[attr-defined]
        if not out.isOpened():
            raise ValueError(f"OpenCV cannot write an MJPG video to {video_path}")
        try:
            for k in range(n_frames):
                img = np.full((h, w, 3), 90, np.uint8)
                x = 4 + 6 * k
                img[19:29, x:x + 10] = 255
                out.write(img)
                rows.append(f"{k + 1},1,{x},19,10,10,1,-1,-1,-1")
        finally:
            out.release()
    atomic_write_text(gt_path, "\n".join(rows) + "\n")
