"""One frame source that knows which frames it delivered.

:class:`FrameSource` streams a video with OpenCV and numbers every frame from the decoder's
position (``CAP_PROP_POS_FRAMES`` after the frame was read); where a backend's position jumps,
the skip is recorded as a gap. What was delivered is summed up in :class:`FrameReport`
(requested range, frames delivered, gaps, a short read: the stream ended before the requested
last frame, or before the frame count the container announces), so that a run can say so and
score only the frames it actually tracked.

Frames lost in damaged data: OpenCV 4.14's FFmpeg backend (and PyAV 18, measured) numbers frames
by counting decoded ones: its position, ``CAP_PROP_POS_MSEC``, ``CAP_PROP_PTS`` and seeking
all count, so a damaged stretch inside a file leaves no jump to see and every later frame would
be numbered too small. For AVI files the ``idx1`` index says where every frame's chunk is: the
chunks not found intact there are the damaged frames (:func:`avi_intact_frames`), the decoder
drops them, and the frames after them get their true numbers; the count of frames decoded to
the end of the file confirms it (:attr:`FrameReport.index_verified`). Measured on PETS 2009
S2.L1 with 300 KB of random bytes from the middle: frames 400-432 damaged, 762 of 795 decoded,
the 363 frames from 420 on each numbered as the intact video's frame it looks most like (within
+-40) in 356 cases, none off by 33. Where the count disagrees, or a file without index (MP4, a
truncated AVI) decodes fewer frames than it announces, the report says that the numbers after
the first loss cannot be trusted (:attr:`FrameReport.numbers_trusted` False).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from pftrack.contracts.components import Frame

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
    index_damaged: list[int] = field(default_factory=list)  # damaged chunks in the AVI index
    index_verified: bool | None = None  # the decoder dropped exactly those (counted to the end)

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
            self.ended_at <= self.frame_count and not self.index_damaged

    @property
    def numbers_trusted(self) -> bool:
        """Whether the delivered frames' numbers are certain."""
        if self.index_damaged:
            return bool(self.index_verified)
        return not self.lost_inside

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
            text = (f"video {self.path}: {self.missing} frame(s) missing (frames "
                    f"{spans}{more})")
            if self.index_damaged and self.index_verified:
                text += ": damaged in the file (its AVI index); later frames keep their numbers"
            elif self.index_damaged:
                text += (": damaged in the file (its AVI index), but the decoder lost a different "
                         "number of frames, so frame numbers after the first loss cannot be "
                         "trusted")
            else:
                text += ": skipped by the decoder; later frames keep their numbers"
            out.append(text)
        if self.short:
            got = self.indices[-1] if self.indices else None
            text = (f"video {self.path}: short read: frames {self.first}..{self.expected_last} "
                    "expected, the stream ended "
                    + (f"after frame {got}" if got is not None else "before the first one"))
            if self.index_damaged and not self.index_verified and not self.gaps:
                text += (f"; the file's AVI index shows {len(self.index_damaged)} damaged "
                         f"frame(s) from frame {self.index_damaged[0]} on and the decoder did "
                         "not deliver the rest, so frame numbers after the first damaged frame "
                         "cannot be trusted")
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
        """The frames with their true numbers; gaps and a short read are recorded in
        :attr:`report`.

        Numbers come from the file's AVI index when it shows damaged frame chunks (the decoder
        drops those; the count of frames decoded to the end of the file confirms it), else from
        the decoder's position.
        """
        import cv2

        if fps is None:
            fps, count = self.probe()
        else:
            count = self.probe()[1]
        rep = self.report = FrameReport(str(self.path), self.first, self.last, count)
        intact = avi_intact_frames(self.path)
        numbers: list[int] | None = None
        if intact is not None and not all(intact):
            numbers = [k for k, ok in enumerate(intact) if ok]
            rep.index_damaged = [k + self.index_offset for k, ok in enumerate(intact) if not ok]
        cap = self.open()
        expected = 0  # the video frame (from 0) the decoder should deliver next
        d = 0  # frames the decoder delivered so far
        at_end = False
        try:
            while True:
                if self.last is not None and expected + self.index_offset > self.last:
                    break
                ok = cap.grab()
                if not ok:
                    rep.ended_at = expected + self.index_offset
                    at_end = True
                    break
                if numbers is not None:
                    k = numbers[d] if d < len(numbers) else \
                        (numbers[-1] if numbers else -1) + 1 + d - len(numbers)
                else:
                    pos = cap.get(cv2.CAP_PROP_POS_FRAMES)
                    k = round(pos) - 1 if pos >= 1 else expected  # NaN compares False
                k = max(k, expected)  # a backend whose position lags: trust the count
                d += 1
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
            if numbers is not None:
                # confirm: the decoder dropped exactly the damaged chunks (count to the end)
                if not at_end:
                    while cap.grab():
                        d += 1
                rep.index_verified = d == len(numbers)
        finally:
            cap.release()


def avi_intact_frames(path: str | os.PathLike[str]) -> list[bool] | None:
    """Per frame of an AVI file's video stream, whether its chunk is intact where the file's
    ``idx1`` index says it is (the chunk id and size found at the indexed offset).

    Returns None for files that are not AVI with an ``idx1`` index (MP4, OpenDML, a truncated
    file whose index is lost). Reads 8 bytes per frame.
    """
    import struct
    from collections import Counter

    try:
        fh = open(path, "rb")  # noqa: SIM115 - closed below
    except OSError:
        return None
    with fh:
        head = fh.read(12)
        if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"AVI ":
            return None
        fh.seek(0, 2)
        end = fh.tell()
        pos, movi, idx = 12, None, None
        while pos + 8 <= end:
            fh.seek(pos)
            h = fh.read(12)
            cid, size = h[:4], struct.unpack("<I", h[4:8])[0]
            if cid == b"LIST" and h[8:12] == b"movi":
                movi = pos + 8
            elif cid == b"idx1":
                idx = (pos + 8, size)
            pos += 8 + size + (size & 1)
        if movi is None or idx is None or idx[0] + idx[1] > end:
            return None
        fh.seek(idx[0])
        data = fh.read(idx[1])
        entries = [struct.unpack_from("<4sIII", data, 16 * i) for i in range(len(data) // 16)]
        video = [e for e in entries if e[0][2:] in (b"dc", b"db")]
        if not video:
            return None
        stream = Counter(e[0][:2] for e in video).most_common(1)[0][0]
        video = [e for e in video if e[0][:2] == stream]
        base = movi  # offsets count from the 'movi' fourcc, or (some writers) from the file start
        fh.seek(movi + video[0][2])
        if fh.read(4) != video[0][0]:
            base = 0
        out = []
        for cid, _flags, off, size in video:
            fh.seek(base + off)
            h = fh.read(8)
            out.append(len(h) == 8 and h[:4] == cid and struct.unpack("<I", h[4:])[0] == size)
        return out
