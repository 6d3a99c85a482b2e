"""MOTChallenge CSV and seqinfo.ini reading/writing (pftrack.io.mot)."""

from __future__ import annotations

import numpy as np
import pytest
from pftrack.io.data import data_path
from pftrack.io.mot import (
    CONF,
    MotTable,
    SeqInfo,
    has_world,
    read_mot,
    read_seqinfo,
    write_mot,
    write_seqinfo,
)


@pytest.fixture(scope="module")
def pets_gt() -> np.ndarray:
    return read_mot(data_path("pets09", "gt.txt"))


def test_reads_pets_ground_truth(pets_gt):
    assert pets_gt.shape == (4650, 10) and pets_gt.dtype == np.float64
    assert len(np.unique(pets_gt[:, 1])) == 19
    assert pets_gt[:, 0].min() == 1 and pets_gt[:, 0].max() == 795
    assert int(np.sum(pets_gt[:, CONF] == 0)) == 174
    assert has_world(pets_gt).all()
    # first line: 1,9,499,158,31.03,75.17,1,-4.1554,-7.3591,0
    np.testing.assert_array_equal(pets_gt[0],
                                  [1, 9, 499, 158, 31.03, 75.17, 1, -4.1554, -7.3591, 0])


def test_round_trip_is_exact(tmp_path, pets_gt):
    out = write_mot(tmp_path / "sub" / "gt.txt", pets_gt)
    back = read_mot(out)
    np.testing.assert_array_equal(back, pets_gt)
    assert out.read_text().splitlines()[0] == "1,9,499,158,31.03,75.17,1,-4.1554,-7.3591,0"
    assert not [p for p in out.parent.iterdir() if p.name != "gt.txt"]  # no temp file left


def test_short_rows_are_padded_with_minus_one(tmp_path):
    p = tmp_path / "short.txt"
    p.write_text("1,3,10,20,30,40\n1,4,1,2,3,4,0.9\n\n# comment\n2 3 11 21 30 40 0.8 5 6\n")
    rows = read_mot(p)
    np.testing.assert_array_equal(rows, [[1, 3, 10, 20, 30, 40, -1, -1, -1, -1],
                                         [1, 4, 1, 2, 3, 4, 0.9, -1, -1, -1],
                                         [2, 3, 11, 21, 30, 40, 0.8, 5, 6, -1]])
    assert has_world(rows).tolist() == [False, False, True]


@pytest.mark.parametrize("line, what", [
    ("1,2,3,4,5", "got 5"),
    ("1,2,3,4,5,6,7,8,9,10,11", "got 11"),
    ("1,2,a,4,5,6", "non-numeric"),
    ("1.5,2,3,4,5,6", "integers"),
    ("1,2,3,4,-5,6", "negative"),
    ("1,2,3,nan,5,6", "NaN"),
])
def test_malformed_line_names_file_and_line(tmp_path, line, what):
    p = tmp_path / "bad.txt"
    p.write_text(f"1,1,0,0,10,10,1,-1,-1,-1\n\n{line}\n")
    with pytest.raises(ValueError) as err:
        read_mot(p)
    msg = str(err.value)
    assert str(p) in msg and "line 3" in msg and what in msg


def test_duplicate_id_in_a_frame_is_rejected(tmp_path):
    p = tmp_path / "dup.txt"
    p.write_text("1,1,0,0,10,10\n1,2,0,0,10,10\n2,1,0,0,10,10\n1,2,5,5,10,10\n")
    msg = r"line 4: id 2 appears twice in frame 1 \(first at line 2\)"
    with pytest.raises(ValueError, match=msg):
        read_mot(p)
    assert len(read_mot(p, check_unique=False)) == 4


def test_missing_file_and_bad_array(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothere.txt"):
        read_mot(tmp_path / "nothere.txt")
    target = tmp_path / "out.txt"
    with pytest.raises(ValueError, match="out.txt"):
        write_mot(target, np.array([[1, 1, 0, 0, np.nan, 1]]))
    with pytest.raises(ValueError, match=r"shape \(2, 4\)"):
        write_mot(target, np.zeros((2, 4)))
    assert not target.exists()


def test_mot_table_views(pets_gt):
    t = MotTable(pets_gt[:, :7])  # padded to 10 columns
    assert t.rows.shape == (4650, 10) and not t.rows.flags.writeable
    assert not t.has_world.any()
    one = MotTable(pets_gt).frame(1)
    assert len(one) == int(np.sum(pets_gt[:, 0] == 1)) > 0 and (one.frames == 1).all()
    first = MotTable(pets_gt[:1])
    np.testing.assert_allclose(first.centres_px, [[499 + 31.03 / 2, 158 + 75.17 / 2]])
    np.testing.assert_allclose(first.foot_px, [[499 + 31.03 / 2, 158 + 75.17]])
    np.testing.assert_allclose(first.world_m, [[-4.1554, -7.3591, 0]])
    track9 = MotTable(pets_gt).track(9)
    assert (track9.ids == 9).all() and np.all(np.diff(track9.frames) > 0)


def test_seqinfo_round_trip_keeps_camel_case(tmp_path):
    info = SeqInfo(name="PETS09-S2L1", im_dir="img1", frame_rate=7.0, seq_length=795,
                   im_width=768, im_height=576, im_ext=".jpg")
    p = write_seqinfo(tmp_path / "seqinfo.ini", info)
    text = p.read_text()
    assert "[Sequence]" in text and "imDir=img1" in text and "seqLength=795" in text
    assert read_seqinfo(p) == info


def test_seqinfo_reads_motchallenge_file_and_rejects_bad_ones(tmp_path):
    p = tmp_path / "seqinfo.ini"
    p.write_text("[Sequence]\nname=TUD-Campus\nimDir=img1\nframeRate=25\nseqLength=71\n"
                 "imWidth=640\nimHeight=480\nimExt=.jpg\n")
    info = read_seqinfo(p)
    assert (info.name, info.frame_rate, info.seq_length, info.im_width) == \
        ("TUD-Campus", 25.0, 71, 640)
    p.write_text("[Sequence]\nname=x\nseqLength=many\n")
    with pytest.raises(ValueError, match="seqLength"):
        read_seqinfo(p)
    p.write_text("[Other]\nname=x\n")
    with pytest.raises(ValueError, match=r"no \[Sequence\]"):
        read_seqinfo(p)
    with pytest.raises(FileNotFoundError, match="missing.ini"):
        read_seqinfo(tmp_path / "missing.ini")


def test_empty_tracks_round_trip_as_an_empty_file(tmp_path):
    from pftrack.io.mot import read_mot, write_mot

    p = tmp_path / "tracks.txt"
    write_mot(p, np.zeros((0, 10)))
    assert p.exists() and p.stat().st_size == 0
    assert read_mot(p).shape == (0, 10)
