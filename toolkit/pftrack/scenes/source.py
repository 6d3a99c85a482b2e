"""One frame source that knows which frames it delivered.

:class:`FrameSource` streams a video with OpenCV and numbers every frame from the decoder's
position (``CAP_PROP_POS_FRAMES`` after the frame was read); where a backend's position jumps,
the skip is recorded as a gap. What was delivered is summed up in :class:`FrameReport`
(requested range, frames delivered, gaps, a short read: the stream ended before the requested
last frame, or before the frame count the container announces), so that a run can say so and
score only the frames it actually tracked.

Limitation, measured: with OpenCV 4.14's FFmpeg backend the position, ``CAP_PROP_POS_MSEC`` and
``CAP_PROP_PTS`` all count decoded frames, so frames lost in damaged data inside an AVI/MP4
(MJPG, MPEG-4, XVID; PETS 2009 with 300 KB overwritten: 762 of 795 frames decoded) leave no
jump to see, and seeking lands by the same count. What is certain is that fewer frames were
decoded than the file announces: that is reported (:attr:`FrameReport.lost_inside`) as
"truncated or damaged, numbers after the first loss cannot be trusted", and a run with ground
truth marks its metrics ``frame_numbers_verified: false``.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from pftrack.components import Frame

__all__ = ["FrameReport", "FrameSource"]


@dataclass
class FrameReport:
    """What a :class:`FrameSource` delivered (frame numbers in ground-truth numbering).

    Attributes
    ----------
    path : str
    first, last : int, int or None
        The requested range (inclusive; ``last`` None: to the end).
    frame_count : int
        Frames the container announces (0: unknown).
    indices : list of int
        Frame numbers delivered, in order.
    gaps : list of (int, int)
        ``(first missing frame, number missing)`` for every skip of the decoder inside the
        requested range.
    """

    path: str
    first: int
    last: int | None
    frame_count: int = 0
    indices: list[int] = field(default_factory=list)
    gaps: list[tuple[int, int]] = field(default_factory=list)
    ended_at: int | None = None  # the first frame number the decoder could not deliver

    @property
    def n_delivered(self) -> int:
        return len(self.indices)

    @property
    def expected_last(self) -> int | None:
        """The last frame the range and the container's frame count promise (None: unknown)."""
        if self.last is not None:
            return self.last
        return self.frame_count if self.frame_count > 0 else None

    @property
    def short(self) -> bool:
        """The stream ended before the requested (or announced) last frame."""
        end = self.expected_last
        got = self.indices[-1] if self.indices else self.first - 1
        return end is not None and got < end

    @property
    def lost_inside(self) -> bool:
        """Fewer frames decoded than the container announces, the stream having run to its
        end: frames are missing at the end (truncation) or inside (damage); OpenCV cannot
        tell which."""
        return bool(self.frame_count) and self.ended_at is not None and \
            self.ended_at <= self.frame_count

    @property
    def missing(self) -> int:
        return sum(n for _, n in self.gaps)

    def problems(self) -> list[str]:
        """One sentence per problem (empty when every requested frame came, in order)."""
        out = []
        if self.gaps:
            spans = ", ".join(f"{a}-{a + n - 1}" if n > 1 else f"{a}"
                              for a, n in self.gaps[:5])
            more = f" and {len(self.gaps) - 5} more" if len(self.gaps) > 5 else ""
            out.append(f"video {self.path}: the decoder skipped {self.missing} frame(s) "
                       f"(frames {spans}{more}); later frames keep their true numbers")
        if self.short:
            got = self.indices[-1] if self.indices else None
            text = (f"video {self.path}: short read: frames {self.first}..{self.expected_last} "
                    "expected, the stream ended "
                    + (f"after frame {got}" if got is not None else "before the first one"))
            if self.lost_inside:
                text += (f"; the file announces {self.frame_count} frames: it is truncated, or "
                         "frames were lost in damaged data, and then the frames after the damage "
                         "carry numbers too small (OpenCV counts decoded frames), so frame "
                         "numbers and scores after the first loss cannot be trusted")
            out.append(text)
        return out


class FrameSource:
    """Stream frames ``first..last`` of a video with their true numbers.

    Parameters
    ----------
    path : path
        The video (anything OpenCV decodes).
    first, last : int, int or None
        Ground-truth numbering, inclusive (``last`` None: to the end).
    index_offset : int
        Ground-truth number of the video's frame 0 (MOTChallenge: 1).

    Attributes
    ----------
    report : FrameReport
        Filled while streaming; complete when the iteration ends.
    """

    def __init__(self, path: str | os.PathLike[str], first: int = 1, last: int | None = None,
                 index_offset: int = 1) -> None:
        self.path = Path(os.fspath(path))
        self.first = int(first)
        self.last = None if last is None else int(last)
        self.index_offset = int(index_offset)
        self.report = FrameReport(str(self.path), self.first, self.last)

    def open(self):
        """An opened ``cv2.VideoCapture`` (errors name the file)."""
        import cv2

        if not self.path.is_file():
            raise FileNotFoundError(f"video {self.path} not found")
        cap = cv2.VideoCapture(str(self.path))
        if not cap.isOpened():
            cap.release()
            raise ValueError(f"video {self.path}: OpenCV cannot decode it (not a video, or a "
                             "codec it lacks)")
        return cap

    def probe(self) -> tuple[float, int]:
        """``(fps, frame count)`` as the container announces them (fps 25, count 0 when it does
        not say)."""
        import cv2

        cap = self.open()
        try:
            fps = float(cap.get(cv2.CAP_PROP_FPS))
            count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        finally:
            cap.release()
        return (fps if 0 < fps < 1e4 else 25.0), max(count, 0)

    def frames(self, fps: float | None = None) -> Iterator[Frame]:
        """The frames, each numbered from the decoder's position; gaps and a short read are
        recorded in :attr:`report`."""
        import cv2

        if fps is None:
            fps, count = self.probe()
        else:
            count = self.probe()[1]
        rep = self.report = FrameReport(str(self.path), self.first, self.last, count)
        cap = self.open()
        expected = 0  # the video frame (from 0) the decoder should deliver next
        try:
            while True:
                if self.last is not None and expected + self.index_offset > self.last:
                    break
                ok = cap.grab()
                if not ok:
                    rep.ended_at = expected + self.index_offset
                    break
                pos = cap.get(cv2.CAP_PROP_POS_FRAMES)
                k = round(pos) - 1 if pos >= 1 else expected  # NaN compares False
                k = max(k, expected)  # a backend whose position lags: trust the count
                index = k + self.index_offset
                if self.last is not None and index > self.last:
                    gap_start = max(expected + self.index_offset, self.first)
                    if self.last >= gap_start:
                        rep.gaps.append((gap_start, self.last - gap_start + 1))
                    break
                if k > expected:
                    a = max(expected + self.index_offset, self.first)
                    if index > a:
                        rep.gaps.append((a, index - a))
                expected = k + 1
                if index < self.first:
                    continue
                ok, image = cap.retrieve()
                if not ok or image is None:
                    rep.gaps.append((index, 1))
                    continue
                rep.indices.append(index)
                yield Frame(index=index, image=image, time_s=k / fps)
        finally:
            cap.release()
