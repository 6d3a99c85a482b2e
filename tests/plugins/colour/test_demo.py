"""``pftrack demo --out DIR``: the README's first command writes tracks, metrics and pictures."""

from __future__ import annotations

import json

import cv2
import numpy as np
from pftrack.cli import main
from pftrack.io.mot import read_mot


def test_demo_writes_tracks_metrics_and_pictures(tmp_path, capsys):
    out = tmp_path / "demo"
    rc = main(["demo", "--out", str(out), "--frames", "40", "--particles", "150"])
    assert rc == 0
    printed = capsys.readouterr().out
    for name in ("tracks.csv", "tracks_bhattacharyya-bg.csv", "metrics.json", "overlays.png",
                 "trajectories.png", "error_curve.png"):
        assert (out / name).is_file(), name
        assert str(out / name) in printed
    rows = read_mot(out / "tracks.csv")
    assert sorted(np.unique(rows[:, 1]).astype(int)) == [1, 2, 3]
    assert len(rows) == 3 * 40
    metrics = json.loads((out / "metrics.json").read_text())
    ce = metrics["methods"]["cross-entropy-bg"]
    assert set(ce["cumulative_error_px"]) == {"blue", "red", "purple"}
    assert max(ce["mean_error_px"].values()) < 3.0
    assert ce["MOTA"] > 0.9 and ce["IDF1"] > 0.9
    assert metrics["scene"]["frames"] == 40
    for name, shape in (("overlays.png", (964, 1444)), ("trajectories.png", (480, 720))):
        img = cv2.imread(str(out / name))
        assert img is not None and img.shape[:2] == shape, name
        assert img.std() > 20  # not blank
    curve = cv2.imread(str(out / "error_curve.png"))
    assert curve.shape[1] == 760 and curve.shape[0] > 600
    # no temporary files left behind
    assert not [p for p in out.iterdir() if p.name.startswith(".")]


def test_demo_without_baseline_and_bad_arguments(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path / "d"), "--frames", "5", "--no-baseline"]) == 0
    assert not (tmp_path / "d" / "tracks_bhattacharyya-bg.csv").exists()
    assert main(["demo", "--out", str(tmp_path / "e"), "--frames", "0"]) == 2
    assert "--frames" in capsys.readouterr().err
