"""Per-track appearance in the volume tracker: HSV histograms, the swap of two tracks'
output ids when they separate, and the re-identification by appearance."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from pftrack.contracts.components import Frame, RunContext, TrackRecord
from pftrack.geometry.camera import Camera
from pftrack_coast.volumes import VolumeTracks, bhattacharyya, hsv_histogram

RED, BLUE = (0, 0, 200), (200, 0, 0)  # BGR
BOX_A = np.array([100.0, 100.0, 40.0, 100.0])
BOX_B = np.array([300.0, 100.0, 40.0, 100.0])


def _image(colour_a=RED, colour_b=BLUE) -> np.ndarray:
    img = np.full((480, 640, 3), 90, np.uint8)
    for box, colour in ((BOX_A, colour_a), (BOX_B, colour_b)):
        x, y, w, h = box.astype(int)
        img[y:y + h, x:x + w] = colour
    return img


def _record(frame: int, tid: int, xy, box) -> TrackRecord:
    return TrackRecord(frame=frame, id=tid, box_xywh_px=np.asarray(box, float),
                       state=np.zeros(6), position=np.zeros(3), extent=np.zeros(3),
                       confidence=1.0, world_m=np.array([xy[0], xy[1], 0.0]))


def _manager(**kw) -> VolumeTracks:
    cam = Camera.look_at((0.0, -40.0, 20.0), (0.0, 0.0, 0.0), (640, 480), fx=600.0)
    m = VolumeTracks(volumes="near", reid={"appearance": True}, **kw)
    m.reid.min_frames = 3  # (a fixed setting, 5 in a run: fewer frames here)
    m.setup(RunContext(camera=cam))
    m.identities_.shown_ |= {1, 2}
    return m


def test_hsv_histogram_counts_the_colours_of_the_box_centre():
    img = _image()
    h = hsv_histogram(img, BOX_A)
    assert h.shape == (8 * 4 * 4,) and h.sum() == pytest.approx(1.0)
    # pure red: hue 0, saturation 255, value 200 -> bin (0, 3, 3)
    assert h[(0 * 4 + 3) * 4 + 3] == pytest.approx(1.0)
    blue_hue = int(cv2.cvtColor(np.uint8([[BLUE]]), cv2.COLOR_BGR2HSV)[0, 0, 0])  # 120
    assert hsv_histogram(img, BOX_B)[((blue_hue * 8 // 180) * 4 + 3) * 4 + 3] == 1.0
    # a box half on the grey background: only its central 40 % is counted (all red)
    assert hsv_histogram(img, BOX_A + [-20, 0, 40, 0])[15] == pytest.approx(1.0)
    # its central 60 %: 48 px wide of which 40 red, the rest grey (hue 0, saturation 0,
    # value 90 -> bin 1)
    h = hsv_histogram(img, BOX_A + [-20, 0, 40, 0], inner=0.6)
    assert h[15] == pytest.approx(40 / 48) and h[1] == pytest.approx(8 / 48)
    # off the image, too small, not finite: no histogram
    assert hsv_histogram(img, np.array([700.0, 10, 40, 40])) is None
    assert hsv_histogram(img, np.array([10.0, 10, 2, 2])) is None
    assert hsv_histogram(img, np.array([np.nan, 10, 40, 40])) is None


def test_bhattacharyya_distance_values():
    p = np.array([0.5, 0.5, 0.0])
    assert bhattacharyya(p, p) == pytest.approx(0.0, abs=1e-7)
    assert bhattacharyya(p, np.array([0.0, 0.0, 1.0])) == pytest.approx(1.0)
    q = np.array([1.0, 0.0, 0.0])
    assert bhattacharyya(p, q) == pytest.approx(np.sqrt(1.0 - np.sqrt(0.5)))
    assert bhattacharyya(np.stack([p, q]), q) == pytest.approx([np.sqrt(1 - np.sqrt(0.5)), 0])


def _appearance(m: VolumeTracks, frame: Frame, out: list[TrackRecord]) -> None:
    """The reidentifier stage's appearance step on the records ``out`` (the identities'
    histograms, templates, swaps)."""
    m.identities_.appearance_of(frame, {r.id: r.box_xywh_px for r in out},
                                {r.id: r.world_m for r in out}, m.look_, m.tracks_)


def _meet(m: VolumeTracks, exchanged: bool, img_after: np.ndarray) -> list[TrackRecord]:
    """Tracks 1 (on the red person) and 2 (blue) apart for 5 frames, together at frame 6,
    apart at frame 7 -- each on the other's person when ``exchanged``."""
    img = _image()
    for f in range(1, 6):
        _appearance(m, Frame(f, img), [_record(f, 1, (0, 0), BOX_A), _record(f, 2, (5, 0), BOX_B)])
    _appearance(m, Frame(6, img), [_record(6, 1, (0, 0), BOX_A), _record(6, 2, (0.5, 0), BOX_B)])
    a, b = ((5, 0), BOX_B), ((0, 0), BOX_A)
    out = [_record(7, 1, *(a if exchanged else b)), _record(7, 2, *(b if exchanged else a))]
    _appearance(m, Frame(7, img_after), out)
    ids = m.identities_
    ids.reidentify({r.id: (r.frame, r.world_m) for r in out if r.id not in ids.shown_}, 7,
                   m.tracks_)
    for r in out:
        r.id = ids.output_id(r.id)
    return out


def test_two_tracks_that_exchanged_people_while_together_swap_their_ids():
    m = _manager()
    out = _meet(m, exchanged=True, img_after=_image())
    # engine track 1 now sees blue: it is output as 2, and track 2 (on red) as 1
    assert {r.id: tuple(r.world_m[:2]) for r in out} == {2: (5.0, 0.0), 1: (0.0, 0.0)}
    assert m.identities_.alias_ == {1: 2, 2: 1}
    assert [e["event"] for e in m.events_] == ["swapped"]
    # the templates follow the people: track 1's template is now the blue one
    assert bhattacharyya(m.identities_.templates_[1][0], hsv_histogram(_image(), BOX_B)) < 0.05


def test_no_swap_when_the_tracks_kept_their_people_or_colours_do_not_tell():
    m = _manager()
    out = _meet(m, exchanged=False, img_after=_image())
    assert sorted(r.id for r in out) == [1, 2] and m.identities_.alias_ == {} and m.events_ == []
    # both people dressed alike: positions alone, no swap
    m = _manager()
    grey = _image(RED, RED)
    for f in range(1, 6):
        _appearance(m, Frame(f, grey), [_record(f, 1, (0, 0), BOX_A),
                                       _record(f, 2, (5, 0), BOX_B)])
    _appearance(m, Frame(6, grey), [_record(6, 1, (0, 0), BOX_A), _record(6, 2, (0.5, 0), BOX_B)])
    _appearance(m, Frame(7, grey), [_record(7, 1, (5, 0), BOX_B), _record(7, 2, (0, 0), BOX_A)])
    assert m.identities_.alias_ == {} and m.events_ == []


def test_appearance_is_off_by_default_and_its_fixed_settings_are_no_options():
    assert VolumeTracks().reid.appearance is False
    with pytest.raises(ValueError, match="unknown parameter 'reid.rate'"):
        VolumeTracks(volumes="near", reid={"rate": 0.2})


@pytest.mark.parametrize("bins", [(8, 4, 4), (16, 8, 8), (5, 3, 7)])
def test_hsv_histogram_tables_give_the_bin_formula(bins):
    """The bin indices from the lookup tables are the formula's, for any bins (8-bit and
    16-bit tables), on every hue, saturation and value."""
    import cv2

    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (120, 160, 3), dtype=np.uint8)
    box = np.array([10.0, 5.0, 140.0, 110.0])
    h = hsv_histogram(img, box, inner=1.0, bins=bins)
    x0, x1, y0, y1 = 10, 150, int(5 + 0.05 * 110), int(5 + 0.95 * 110)
    hsv = cv2.cvtColor(np.ascontiguousarray(img[y0:y1, x0:x1]), cv2.COLOR_BGR2HSV)
    hsv = hsv.reshape(-1, 3).astype(np.intp)
    nh, ns, nv = bins
    assert set(np.unique(hsv[:, 0])) == set(range(180))  # every hue met
    idx = (np.minimum(hsv[:, 0] * nh // 180, nh - 1) * ns + hsv[:, 1] * ns // 256) * nv \
        + hsv[:, 2] * nv // 256
    want = np.bincount(idx, minlength=nh * ns * nv).astype(np.float64)
    assert h.tobytes() == (want / want.sum()).tobytes()
