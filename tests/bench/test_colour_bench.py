"""``pftrack bench colour`` and ``pftrack bench pets09-colour`` on short runs: structure and
sanity of the numbers they report."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pftrack.cli import main
from pftrack.io.data import data_dir


def test_colour_bench_small(tmp_path, capsys):
    out = tmp_path / "colour.json"
    rc = main(["bench", "colour", "--samples", "40,80", "--targets", "1,3", "--frames", "20",
               "--json", "--out", str(out), "--quiet"])
    assert rc == 0
    printed = json.loads(capsys.readouterr().out)
    result = json.loads(out.read_text())
    assert printed == result
    rows = result["rows"]
    assert len(rows) == 4 * 2 * 2
    names = {"bhattacharyya", "bhattacharyya-bg", "cross-entropy", "cross-entropy-bg"}
    assert {r["likelihood"] for r in rows} == names
    for r in rows:
        assert r["frames"] == 20
        assert r["seconds_per_frame"] > 0
        assert r["frames_per_second"] == pytest.approx(1 / r["seconds_per_frame"])
        expected = ["blue"] if r["targets"] == 1 else ["blue", "red", "purple"]
        assert sorted(r["cumulative_error_px"]) == sorted(expected)
        assert all(0 <= v < 20 * 10 for v in r["cumulative_error_px"].values())
    assert len(result["ratios"]) == 2 * 2 * 2
    assert "rendered" in result["setup"]["timing"]


def test_colour_bench_slow_frames_and_table(capsys):
    rc = main(["bench", "colour", "--samples", "5000", "--targets", "1", "--frames", "12",
               "--likelihoods", "bhattacharyya,cross-entropy", "--slow-frames", "4", "--quiet"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "N = 5000 samples" in text and "bhattacharyya / cross-entropy" in text
    lines = [ln for ln in text.splitlines() if ln.strip().startswith("bhattacharyya ")]
    assert lines and lines[0].split()[2] == "4"  # the slow baseline ran 4 frames


def test_colour_bad_arguments(capsys):
    assert main(["bench", "colour", "--likelihoods", "nope", "--quiet"]) == 2
    assert "nope" in capsys.readouterr().err


def test_pets09_colour_bench_slice(tmp_path, capsys):
    if not (data_dir() / "pets09" / "vtest.avi").is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    rc = main(["bench", "pets09-colour", "--frames", "1:12", "--methods",
               "cross-entropy-bg,csrt", "--json", "--quiet"])
    assert rc == 0
    result = json.loads(capsys.readouterr().out)
    assert result["setup"]["frames"] == [1, 12] and result["setup"]["persons"] == 3
    assert [r["method"] for r in result["rows"]] == ["cross-entropy-bg", "csrt"]
    for r in result["rows"]:
        for k in ("mean_center_error_px", "success_rate", "updates_per_second",
                  "frames_per_second", "MOTA", "IDF1", "HOTA"):
            assert np.isfinite(r[k]), k
        assert 0 <= r["success_rate"] <= 1
        assert r["updates_per_second"] > r["frames_per_second"] > 0
        # 3 people tracked through 12 frames from their true boxes: close to the truth
        assert r["mean_center_error_px"] < 15
        assert r["success_rate"] > 0.7


def test_pets09_bad_frames(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["bench", "pets09-colour", "--frames", "9:3"])
    assert exc.value.code == 2
    assert "9:3" in capsys.readouterr().err
