"""A ground-plane camera from the people in a video (``pftrack calib people``): person boxes
found over the frames (:func:`detect_people`), each person's lean and silhouette measured in the
moving pixels (:func:`measure_slants`, :func:`measure_silhouettes`), and the fit of
:func:`pftrack.geometry.people.estimate_camera_from_people` on them, in one call
(:func:`estimate_camera_from_video`). The model and the fit are explained in
:mod:`pftrack.geometry.people`."""

from __future__ import annotations

from typing import Any

import numpy as np

from pftrack.geometry.boxes import nms
from pftrack.geometry.people import (
    SLANT_TOP_FRACTION,
    PeopleCameraFit,
    estimate_camera_from_people,
)
from pftrack.geometry.people_boxes import link_boxes, refine_boxes_by_silhouettes

__all__ = [
    "HOG_MARGIN_X",
    "HOG_MARGIN_Y",
    "SILHOUETTE_TOP_FRACTION",
    "detect_people",
    "estimate_camera_from_video",
    "measure_silhouettes",
    "measure_slants",
]

#: OpenCV's default people detector (Dalal and Triggs 2005) was trained on 64 x 128 windows with
#: about 16 px of margin around the person on every side (their paper, sec. 3): its boxes are
#: shrunk by these fractions of the window (left/right 16/64, top/bottom 16/128) to hug the person.
HOG_MARGIN_X = 16.0 / 64.0
HOG_MARGIN_Y = 16.0 / 128.0


def detect_people(video: Any, first: int = 1, last: int | None = None, stride: int = 1, *,
                  host: Any = None, min_score: float = 0.0, upscale: float = 2.0,
                  progress: Any = None) -> tuple[np.ndarray, str]:
    """Person boxes found over a video's frames ``first..last`` (every ``stride``-th).

    The detector: a registered detector named ``hog-people`` when the host has one (built with
    its defaults, no camera), otherwise OpenCV's HOG people detector
    (``cv2.HOGDescriptor_getDefaultPeopleDetector``, ``detectMultiScale`` with an 8 px stride, 8 px
    padding, scale step 1.05) on the frame enlarged ``upscale`` times, whose boxes are shrunk by
    the training margins :data:`HOG_MARGIN_X`, :data:`HOG_MARGIN_Y` and thinned by non-maximum
    suppression (IoU 0.4). Its smallest window holds a person 96 px tall, so without enlarging
    the frame smaller people are missed or reported at the smallest size, which would flatten
    the height-row relation; boxes within 10 % of that floor (``96 / upscale`` px) are dropped
    for the same reason.

    Returns
    -------
    boxes : ndarray, shape (N, 6)
        ``x, y, w, h, frame, score`` (frames numbered from 1 as in MOTChallenge).
    name : str
        Which detector ran.
    """
    import cv2

    from pftrack.workflows.pipeline import iter_frames

    if stride < 1:
        raise ValueError(f"detect_people: stride must be >= 1, got {stride}")
    if not upscale > 0:
        raise ValueError(f"detect_people: upscale must be > 0, got {upscale}")
    floor_px = 1.1 * 128 * (1 - 2 * HOG_MARGIN_Y) / upscale
    det = None
    if host is None:
        from pftrack.host import get_host

        host = get_host()
    if "hog-people" in host.names("detector"):
        from pftrack.contracts.components import RunContext

        det = host.build("detector", "hog-people")
        det.setup(RunContext(host=host))
        name = "hog-people (registered detector)"
    else:
        hog = cv2.HOGDescriptor()
        hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())  # type: ignore[attr-defined]
        name = "OpenCV HOG default people detector"
    out: list[np.ndarray] = []
    for frame in iter_frames(video, first, last):
        if (frame.index - first) % stride:
            continue
        if det is not None:
            d = det.detect(frame)
            boxes, scores = d.boxes_xywh_px, d.scores
        else:
            img = frame.image if upscale == 1 else cv2.resize(
                frame.image, None, fx=upscale, fy=upscale, interpolation=cv2.INTER_LINEAR)
            if img.shape[0] < 128 or img.shape[1] < 64:
                # OpenCV's HOG crashes (segfault) on images smaller than its window
                raise ValueError(f"detect_people: {video}: frames of {frame.size_wh[0]}x"
                                 f"{frame.size_wh[1]} px are smaller than the HOG window "
                                 f"(64x128) even enlarged {upscale:g} times; raise upscale")
            b, s = hog.detectMultiScale(img, winStride=(8, 8), padding=(8, 8), scale=1.05)
            boxes = np.asarray(b, dtype=np.float64).reshape(-1, 4) / upscale
            scores = np.asarray(s, dtype=np.float64).reshape(-1)
            if len(boxes):
                sel = scores >= min_score
                boxes, scores = boxes[sel], scores[sel]
                keep = nms(boxes, scores, 0.4)
                boxes, scores = boxes[keep], scores[keep]
                boxes = np.column_stack([boxes[:, 0] + HOG_MARGIN_X * boxes[:, 2],
                                         boxes[:, 1] + HOG_MARGIN_Y * boxes[:, 3],
                                         boxes[:, 2] * (1 - 2 * HOG_MARGIN_X),
                                         boxes[:, 3] * (1 - 2 * HOG_MARGIN_Y)])
                big = boxes[:, 3] >= floor_px
                boxes, scores = boxes[big], scores[big]
        ok = scores >= min_score
        if ok.any():
            out.append(np.column_stack([boxes[ok], np.full(ok.sum(), frame.index),
                                        scores[ok]]))
        if progress is not None:
            progress(frame.index)
    rows = np.concatenate(out) if out else np.zeros((0, 6))
    return rows, name


def measure_slants(video: Any, boxes_xywh: Any, frames: Any, *, warmup: int = 20,
                   min_fill: float = 0.2, top_fraction: float = SLANT_TOP_FRACTION
                   ) -> np.ndarray:
    """The lean of each person in the image, ``du/dv`` of their axis, from moving pixels.

    Upright people lean towards the vertical vanishing point, by a few pixels over their height
    at the image's sides; with the horizon that point gives the focal length, which box heights
    cannot (see :func:`~pftrack.geometry.people.estimate_camera_from_people`'s ``slants``). For
    every box the foreground of OpenCV's MOG2 background subtractor (shadows excluded) is taken
    inside the box, the centroid column of each row of the top ``top_fraction`` of the box (head
    and body; the legs swing) is computed, and a straight line ``u = a + s v`` is fitted to them.

    Parameters
    ----------
    video : path
        The video the boxes come from.
    boxes_xywh : array_like, shape (N, >=4)
        Boxes in pixels.
    frames : array_like, shape (N,)
        Frame of each box (1-based, as MOTChallenge numbers them).
    warmup : int
        Frames the background model learns before the first measurement (streamed from
        ``warmup`` frames before the first box's frame, or from frame 1).
    min_fill : float
        Boxes whose foreground covers less than this fraction are not measured.
    top_fraction : float
        The part of the box, from the top, whose rows are used.

    Returns
    -------
    ndarray, shape (N,)
        ``s = du/dv`` (dimensionless); NaN where it could not be measured.
    """
    import cv2

    from pftrack.workflows.pipeline import iter_frames

    b = np.asarray(boxes_xywh, dtype=np.float64).reshape(-1, np.shape(boxes_xywh)[-1])[:, :4]
    fr = np.asarray(frames, dtype=np.int64).reshape(-1)
    if len(fr) != len(b):
        raise ValueError(f"measure_slants: {len(b)} boxes but {len(fr)} frames")
    out = np.full(len(b), np.nan)
    if not len(b):
        return out
    first, last = int(fr.min()), int(fr.max())
    mog = cv2.createBackgroundSubtractorMOG2(history=200, varThreshold=16, detectShadows=True)
    order = np.argsort(fr, kind="stable")
    starts = np.searchsorted(fr[order], np.arange(first, last + 2))
    for frame in iter_frames(video, max(1, first - warmup), last):
        fg = mog.apply(frame.image) == 255
        if frame.index < first:
            continue
        k = frame.index - first
        H, W = fg.shape
        for i in order[starts[k]:starts[k + 1]]:
            x, y, w, h = b[i]
            x0, y0 = max(round(x), 0), max(round(y), 0)
            x1, y1 = min(round(x + w), W), min(round(y + h), H)
            sub = fg[y0:y1, x0:x1]
            if sub.size == 0 or sub.mean() < min_fill:
                continue
            n_top = int((y1 - y0) * top_fraction)
            cnt = sub[:n_top].sum(axis=1)
            ok = cnt >= 3
            if ok.sum() < max(10, 0.5 * n_top):
                continue
            cols = (sub[:n_top] @ np.arange(x1 - x0, dtype=np.float64))[ok] / cnt[ok]
            rows = np.arange(n_top, dtype=np.float64)[ok]
            rc = rows - rows.mean()
            out[i] = float(rc @ (cols - cols.mean()) / (rc @ rc))
    return out


#: Fraction of a silhouette, from its top, whose rows give its lean
#: (:func:`measure_silhouettes`): head and body, not the feet of a long stride.
SILHOUETTE_TOP_FRACTION = 0.85


def _silhouette_run(rows: np.ndarray, centre: int, gap: int) -> tuple[int, int, int]:
    """The run of foreground ``rows`` (sorted) nearest ``centre``, gaps of at most ``gap`` rows
    bridged: ``(first, last, distance of centre from the run)``."""
    cuts = np.flatnonzero(np.diff(rows) > gap)
    starts = rows[np.r_[0, cuts + 1]]
    ends = rows[np.r_[cuts, len(rows) - 1]]
    dist = np.maximum(np.maximum(starts - centre, centre - ends), 0)
    k = int(np.argmin(dist))
    return int(starts[k]), int(ends[k]), int(dist[k])


def measure_silhouettes(video: Any, boxes_xywh: Any, frames: Any, *, warmup: int = 20,
                        min_row_fill: float = 0.2, search_pad: float = 0.3,
                        side_pad: float = 0.5, top_fraction: float = SILHOUETTE_TOP_FRACTION,
                        min_fill: float = 0.2, every: int = 1, scale: float = 1.0
                        ) -> np.ndarray:
    """Each person's silhouette in the moving pixels: its top and bottom rows and its lean.

    A detector's box height is coarse (a scale pyramid quantises it, 20 % steps for
    ``hog-people``) and its errors depend on the person's size, which bends the height-row
    relation the camera is fitted from: on PETS 2009 S2.L1 the horizon came out 50-70 px too
    high and the camera height 12 % too large from ``hog-people`` boxes, 2-30 px and within 10 %
    from their silhouettes (frames 1-200, 201-400, 401-600, 601-795; true focal length).
    The foreground of OpenCV's MOG2 background subtractor (shadows excluded) is taken in the
    middle half of each box's columns, from ``search_pad`` box heights above the box to as much
    below; rows at least ``min_row_fill`` full form runs (gaps up to 6 % of the height bridged)
    and the run through (or within 10 % of the height of) the box's centre row is the person.
    Runs that reach the searched window's top or bottom (a person above or below, or the image
    border) are not measured. The lean is the slope ``du/dv`` of a line fitted to the row
    centroids of the person's foreground over the silhouette's top ``top_fraction``, in the
    box's columns widened by ``side_pad`` of its width on each side (a box cut to the person
    clips a leaning body's centroids towards its middle); the person's foreground there is the
    8-connected component with most pixels in the middle half of the box's columns (another
    person's or noise pixels in the window would pull the centroids towards its middle, which
    also flattens the lean and lengthens the focal length fitted from it).

    Parameters
    ----------
    video : path
        The video the boxes come from.
    boxes_xywh : array_like, shape (N, >=4)
        Boxes in pixels.
    frames : array_like, shape (N,)
        Frame of each box (1-based, as MOTChallenge numbers them).
    warmup : int
        Frames the background model learns before the first measurement.
    min_row_fill : float
        A row belongs to the silhouette when this fraction of the middle columns is foreground.
        Unit: 1.
    search_pad : float
        Rows searched above and below the box, in box heights. Unit: 1.
    side_pad : float
        Columns added on each side for the lean, in box widths. Unit: 1.
    top_fraction : float
        The part of the silhouette, from its top, whose rows give the lean. Unit: 1.
    min_fill : float
        Boxes whose foreground covers less than this fraction are not measured. Unit: 1.
    every : int
        The background model sees every ``every``-th frame from the first box's frame (and the
        warm-up frames at the same spacing); boxes in other frames are not measured. The cost
        is the background model's, per frame it sees: ``every=2`` over 400 frames costs what
        every frame of 200 does and sees more people.
    scale : float
        The background model runs on the frames resized by this factor (its mask is resized
        back, nearest neighbour): its cost, most of this function's, falls with the square.
        Unit: 1.

    Returns
    -------
    ndarray, shape (N, 3)
        ``slant`` (du/dv, dimensionless), ``top`` and ``bottom`` rows of the silhouette (pixels,
        the bottom exclusive: the height is ``bottom - top``); NaN where not measured.
    """
    from pftrack.workflows.pipeline import iter_frames

    b = np.asarray(boxes_xywh, dtype=np.float64).reshape(-1, np.shape(boxes_xywh)[-1])[:, :4]
    fr = np.asarray(frames, dtype=np.int64).reshape(-1)
    if len(fr) != len(b):
        raise ValueError(f"measure_silhouettes: {len(b)} boxes but {len(fr)} frames")
    out = np.full((len(b), 3), np.nan)
    meter = SilhouetteMeter(int(fr.min()) if len(fr) else 1, warmup=warmup,
                            min_row_fill=min_row_fill, search_pad=search_pad,
                            side_pad=side_pad, top_fraction=top_fraction, min_fill=min_fill,
                            every=every, scale=scale)
    if not len(b):
        return out
    first, last = meter.first, int(fr.max())
    order = np.argsort(fr, kind="stable")
    starts = np.searchsorted(fr[order], np.arange(first, last + 2))
    for frame in iter_frames(video, meter.start, last):
        fg = meter.learn(frame.index, frame.image)
        if fg is not None:
            k = frame.index - first
            idx = order[starts[k]:starts[k + 1]]
            out[idx] = meter.measure(fg, b[idx])
    return out


class SilhouetteMeter:
    """:func:`measure_silhouettes`, one frame at a time, for a pass over the video that
    decodes the frames anyway (a detection pass): its background model learns the frames
    ``start, start + every, ...`` (:meth:`learn`, in order; :meth:`sees` says which) and
    :meth:`measure` measures boxes in a frame's foreground. The arithmetic is
    :func:`measure_silhouettes`' (its parameters; ``first`` is the first frame with a box).
    """

    def __init__(self, first: int, *, warmup: int = 20, min_row_fill: float = 0.2,
                 search_pad: float = 0.3, side_pad: float = 0.5,
                 top_fraction: float = SILHOUETTE_TOP_FRACTION, min_fill: float = 0.2,
                 every: int = 1, scale: float = 1.0) -> None:
        import cv2

        if int(every) < 1:
            raise ValueError(f"measure_silhouettes: every must be >= 1, got {every}")
        if not 0 < scale <= 1:
            raise ValueError(f"measure_silhouettes: scale must be in (0, 1], got {scale}")
        self.first, self.every, self.scale = int(first), int(every), float(scale)
        self.min_row_fill, self.search_pad, self.side_pad = min_row_fill, search_pad, side_pad
        self.top_fraction, self.min_fill = top_fraction, min_fill
        #: the first frame the background model learns (``warmup`` of its frames before
        #: ``first``, from frame 1)
        self.start = max(1, self.first - int(warmup) * self.every)
        self.mog = cv2.createBackgroundSubtractorMOG2(history=200, varThreshold=16,
                                                      detectShadows=True)

    def sees(self, index: int) -> bool:
        """Whether the background model learns frame ``index`` (from :attr:`start`, every
        ``every``-th frame counted from ``first``)."""
        return index >= self.start and (index - self.first) % self.every == 0

    @staticmethod
    def model_input(image: np.ndarray, scale: float) -> np.ndarray:
        """The background model's input for a BGR ``image``: resized by ``scale``."""
        import cv2

        if scale == 1:
            return image
        return cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)

    def learn(self, index: int, image: np.ndarray | None,
              small: np.ndarray | None = None) -> np.ndarray | None:
        """The background model learns frame ``index`` (BGR ``image``, or its
        :meth:`model_input` ``small`` when kept from earlier); its foreground (bool, the
        image's size) from ``first`` on, else None (also for a frame it does not see)."""
        import cv2

        if not self.sees(index):
            return None
        if small is None:
            small = self.model_input(image, self.scale)  # type: ignore[arg-type]
        fg_small = self.mog.apply(small)
        if index < self.first or image is None:
            return None
        if self.scale == 1:
            return fg_small == 255
        return cv2.resize(fg_small, image.shape[1::-1], interpolation=cv2.INTER_NEAREST) == 255

    def measure(self, fg: np.ndarray, boxes_xywh: np.ndarray) -> np.ndarray:
        """Each box's (K, >=4, px) silhouette in the foreground ``fg``: ``slant``, ``top``,
        ``bottom`` (K, 3) as :func:`measure_silhouettes` returns them; NaN where not
        measured."""
        import cv2

        search_pad, side_pad = self.search_pad, self.side_pad
        min_fill, min_row_fill, top_fraction = self.min_fill, self.min_row_fill, self.top_fraction
        b = np.asarray(boxes_xywh, dtype=np.float64).reshape(-1, np.shape(boxes_xywh)[-1])
        out = np.full((len(b), 3), np.nan)
        H, W = fg.shape
        for i in range(len(b)):
            x, y, w, h = b[i, :4]
            xa, xb = max(round(x + 0.25 * w), 0), min(round(x + 0.75 * w), W)
            ya, yb = max(round(y - search_pad * h), 0), min(round(y + (1 + search_pad) * h), H)
            if xb - xa < 3 or yb - ya < 10:
                continue
            win = fg[ya:yb, xa:xb]
            if win.mean() < min_fill * h / (yb - ya):
                continue
            rows = np.flatnonzero(win.mean(axis=1) >= min_row_fill)
            if len(rows) < 5:
                continue
            r0, r1, dist = _silhouette_run(rows, round(y + 0.5 * h) - ya, max(2, int(0.06 * h)))
            if dist > 0.1 * h or r0 == 0 or r1 == yb - ya - 1:
                continue
            top, bottom = ya + r0, ya + r1 + 1
            out[i, 1:] = top, bottom
            x0, x1 = max(round(x - side_pad * w), 0), min(round(x + (1 + side_pad) * w), W)
            sub = np.ascontiguousarray(fg[top:top + int(top_fraction * (bottom - top)), x0:x1],
                                       dtype=np.uint8)
            if sub.shape[0] < 10 or sub.shape[1] < 3:
                continue  # (OpenCV's labelling crashes on an empty image)
            n_lab, lab = cv2.connectedComponents(sub, connectivity=8)
            mid = np.bincount(lab[:, xa - x0:xb - x0].ravel(), minlength=n_lab)
            mid[0] = 0
            if n_lab < 2 or not mid.any():
                continue
            sub = (lab == int(np.argmax(mid))).astype(np.float64)
            cnt = sub.sum(axis=1)
            ok = cnt >= 3
            if ok.sum() < max(10, 0.5 * len(cnt)):
                continue
            cols = (sub @ np.arange(x1 - x0, dtype=np.float64))[ok] / cnt[ok]
            rr = np.flatnonzero(ok).astype(np.float64)
            rc = rr - rr.mean()
            out[i, 0] = float(rc @ (cols - cols.mean()) / (rc @ rc))
        return out


def estimate_camera_from_video(video: Any, boxes: Any = None, first: int = 1,
                               last: int | None = None, stride: int = 4,
                               person_height_m: float = 1.7,
                               rng: np.random.Generator | int | None = None, *,
                               lean: bool = True, silhouettes: bool | None = None,
                               silhouette_every: int = 1, silhouette_scale: float = 1.0,
                               min_score: float = 0.0, host: Any = None,
                               silhouettes_measured: np.ndarray | None = None,
                               **fit_kw: Any) -> tuple[PeopleCameraFit, np.ndarray, str]:
    """A camera from a video alone: people detected (or given), their lean measured, the fit.

    What ``pftrack calib people`` does, for callers such as a one-command tracker.

    Parameters
    ----------
    video : path
        The video.
    boxes : array_like, shape (N, >=5), optional
        ``x, y, w, h, frame[, score]`` person boxes (frames from 1); None: detect them with
        :func:`detect_people` over frames ``first..last`` every ``stride``-th frame.
    first, last, stride : int
        Frames to detect in (``last`` None: to the end).
    person_height_m : float
        Mean person height, metres.
    rng : numpy.random.Generator or int or None
        As for :func:`~pftrack.geometry.people.estimate_camera_from_people`.
    lean : bool
        Use the people's lean for the focal length; skipped when ``focal_px`` is given in
        ``fit_kw``.
    silhouettes : bool, optional
        Measure each person's silhouette in the moving pixels (:func:`measure_silhouettes`, one
        pass over the frames) and fit the camera from the silhouettes' top and bottom rows where
        they agree with the box
        (:func:`~pftrack.geometry.people_boxes.refine_boxes_by_silhouettes`), the lean from the
        silhouette too, and resample people (:func:`~pftrack.geometry.people_boxes.link_boxes`) in
        the bootstrap; False: the boxes as given, the lean from :func:`measure_slants`. Default:
        True for boxes a detector finds here (coarse heights), False for given boxes (a user's
        clicks or ground truth hug the person already; pass True for another detector's boxes).
    silhouette_every : int
        :func:`measure_silhouettes`' ``every``: the background model sees every so many
        frames, and only boxes in those frames are measured.
    silhouette_scale : float
        :func:`measure_silhouettes`' ``scale``.
    silhouettes_measured : ndarray, shape (N, 3), optional
        The silhouettes of ``boxes`` measured already (:func:`measure_silhouettes`' output for
        them with ``silhouette_every`` and ``silhouette_scale``, e.g. by a
        :class:`SilhouetteMeter` fed during a detection pass): its pass over the video is not
        made again.
    min_score : float
        Detections scoring below are dropped (detection only).
    host : pftrack.host.Host, optional
        Where to look for a registered ``hog-people`` detector.
    **fit_kw
        Passed to :func:`~pftrack.geometry.people.estimate_camera_from_people` (``focal_px``,
        ``n_bootstrap``, ...).

    Returns
    -------
    fit : PeopleCameraFit
    rows : ndarray, shape (N, 6)
        The boxes used as input: ``x, y, w, h, frame, score``.
    source : str
        Where the boxes came from.
    """
    from pftrack.scenes.video import VideoScene

    frame = next(iter(VideoScene(str(video), first=first, last=first).frames()), None)
    if frame is None:
        raise ValueError(f"estimate_camera_from_video: {video}: no frame {first} could be read")
    size = frame.size_wh
    if boxes is None:
        rows, name = detect_people(video, first, last, stride, host=host, min_score=min_score)
        source = f"{name} over frames {first}..{last or 'end'} every {stride}"
    else:
        b = np.asarray(boxes, dtype=np.float64)
        if b.ndim != 2 or b.shape[1] < 5:
            raise ValueError(f"estimate_camera_from_video: boxes must have shape (N, >=5) "
                             f"(x, y, w, h, frame[, score]), got {b.shape}")
        rows = np.column_stack([b[:, :5], b[:, 5] if b.shape[1] > 5 else np.ones(len(b))])
        source = f"{len(rows)} given boxes"
    if len(rows) == 0:
        raise ValueError(f"estimate_camera_from_video: no person boxes from {source}; lower "
                         "min_score, widen the frames or give boxes")
    slants = None
    fit_boxes = rows[:, :4]
    if silhouettes is None:
        silhouettes = boxes is None
    use_lean = lean and fit_kw.get("focal_px") is None
    if np.all(rows[:, 4] >= 1):
        if silhouettes:
            if silhouettes_measured is not None:
                sil = np.asarray(silhouettes_measured, dtype=np.float64)
                if sil.shape != (len(rows), 3):
                    raise ValueError(f"estimate_camera_from_video: silhouettes_measured has "
                                     f"shape {sil.shape}, not ({len(rows)}, 3) for the boxes")
            else:
                sil = measure_silhouettes(video, rows[:, :4], rows[:, 4],
                                          every=silhouette_every, scale=silhouette_scale)
            fit_boxes, refined = refine_boxes_by_silhouettes(rows[:, :4], sil)
            slants = sil[:, 0] if use_lean else None
            source += f"; {int(refined.sum())} of {len(rows)} boxes' rows from silhouettes"
        elif use_lean:
            slants = measure_slants(video, rows[:, :4], rows[:, 4])
    if silhouettes and slants is not None:
        # boxes of every k-th frame (--stride, every) link across k frames
        step = np.diff(np.unique(rows[:, 4]))
        gap = max(int(silhouette_every), int(np.median(step)) if len(step) else 1)
        fit_kw.setdefault("groups", link_boxes(rows[:, :4], rows[:, 4], max_gap=gap))
        fit_kw.setdefault("slant_top_fraction", SILHOUETTE_TOP_FRACTION)
    fit = estimate_camera_from_people(fit_boxes, size, person_height_m, rng, slants=slants,
                                      **fit_kw)
    return fit, rows, source
