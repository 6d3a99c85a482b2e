"""One frame source that knows its true frame numbers.

:class:`FrameSource` streams a video with OpenCV and numbers every frame from the decoder's own
position (``CAP_PROP_POS_FRAMES`` after the frame was read), not from a counter of successful
reads: when damaged data makes the decoder skip frames, the frames after the damage keep their
true numbers and the skip is recorded as a gap. What was delivered is summed up in
:class:`FrameReport` (requested range, frames delivered, gaps, a short read: the stream ended
before the requested last frame, or before the frame count the container announces), so that a
run can say so and score only the frames it actually tracked.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

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
    renumbered: int = 0  # delivered frames whose number :meth:`FrameSource.verify` corrected

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
    def missing(self) -> int:
        return sum(n for _, n in self.gaps)

    def problems(self) -> list[str]:
        """One sentence per problem (empty when every requested frame came, in order)."""
        out = []
        if self.renumbered:
            out.append(f"video {self.path}: {self.renumbered} frame(s) after damaged data were "
                       "renumbered from the file's index (the decoder's count was off)")
        if self.gaps:
            spans = ", ".join(f"{a}-{a + n - 1}" if n > 1 else f"{a}"
                              for a, n in self.gaps[:5])
            more = f" and {len(self.gaps) - 5} more" if len(self.gaps) > 5 else ""
            out.append(f"video {self.path}: the decoder skipped {self.missing} frame(s) "
                       f"(frames {spans}{more}); later frames keep their true numbers")
        if self.short:
            got = self.indices[-1] if self.indices else None
            out.append(f"video {self.path}: short read: frames {self.first}.." 
                       f"{self.expected_last} expected, the stream ended "
                       + (f"after frame {got}" if got is not None else "before the first one")
                       + (f" (the file announces {self.frame_count} frames)"
                          if self.frame_count else ""))
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
        self._thumbs: list[np.ndarray] = []
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
                self._thumbs.append(_thumb(image))
                yield Frame(index=index, image=image, time_s=k / fps)
        finally:
            cap.release()

    def verify(self, tolerance: float = 0.5, max_seeks: int = 400) -> dict[int, int | None]:
        """Check the delivered frames' numbers against the container's index, after streaming.

        OpenCV's position counts decoded frames: frames lost in damaged data are not counted, so
        every later frame would carry a number too small. Seeking (``CAP_PROP_POS_FRAMES``) goes
        through the container's index and lands on the true frame: the last delivered frame is
        compared with the frame a seek to its number gives (a 32 x 24 grey thumbnail, mean
        absolute difference <= ``tolerance`` grey levels); on a mismatch the first misnumbered
        frame is found by bisection and the shift by trying the numbers the lost frames allow.

        Returns
        -------
        dict
            Delivered number -> true number, for the frames whose number changes; ``None`` for
            frames whose true number could not be established (damaged frames next to a gap).
            Empty when every number was right. Gaps found are added to :attr:`report`.
        """
        import cv2

        rep = self.report
        n = len(rep.indices)
        if n == 0:
            return {}
        cap = self.open()
        seeks = [0]

        def match(i: int, shift: int) -> bool:
            if seeks[0] >= max_seeks:
                raise _TooManySeeks
            seeks[0] += 1
            k = rep.indices[i] - self.index_offset + shift
            if rep.frame_count and k >= rep.frame_count:
                return False
            cap.set(cv2.CAP_PROP_POS_FRAMES, k)
            ok, image = cap.read()
            return bool(ok) and float(np.abs(_thumb(image) - self._thumbs[i]).mean()) <= tolerance

        mapping: dict[int, int | None] = {}
        try:
            shift, i0 = 0, 0
            spare = (rep.frame_count - (rep.indices[-1] - self.index_offset + 1)
                     if rep.frame_count else 0)
            while i0 < n and not match(n - 1, shift):
                lo, hi = i0, n - 1  # first i in [lo, hi] that does not match
                while lo < hi:
                    mid = (lo + hi) // 2
                    if match(mid, shift):
                        lo = mid + 1
                    else:
                        hi = mid
                found = None
                for j in range(lo, min(lo + 6, n)):
                    for s in range(shift + 1, shift + max(spare, 0) + 1):
                        if match(j, s):
                            found = (j, s)
                            break
                    if found:
                        break
                if found is None:
                    for i in range(lo, n):
                        mapping[rep.indices[i]] = None
                    rep.gaps.append((rep.indices[lo], 0))
                    break
                j, s = found
                for i in range(lo, j):
                    mapping[rep.indices[i]] = None
                rep.gaps.append((rep.indices[lo] + shift, s - shift + (j - lo)))
                spare -= s - shift
                shift, i0 = s, j
                for i in range(j, n):
                    mapping[rep.indices[i]] = rep.indices[i] + shift
        except _TooManySeeks:
            for i in range(n):
                mapping.setdefault(rep.indices[i], None)
        finally:
            cap.release()
        if mapping:
            rep.indices = [mapping.get(i, i) for i in rep.indices if mapping.get(i, i) is not None]
            rep.renumbered = len(mapping)
        return mapping


class _TooManySeeks(Exception):
    pass


def _thumb(image: np.ndarray) -> np.ndarray:
    import cv2

    grey = image if image.ndim == 2 else cv2.cvtColor(image[..., :3], cv2.COLOR_BGR2GRAY)
    return cv2.resize(grey, (32, 24), interpolation=cv2.INTER_AREA).astype(np.float32)
