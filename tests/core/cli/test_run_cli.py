"""``pftrack run``, ``pftrack presets`` and ``pftrack detector``: the user path of the soccer paper
on PETS 2009 (train the detector, then track on the ground plane)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from pftrack.cli import main
from pftrack.io.data import data_dir

PETS = data_dir() / "pets09"


def test_presets_lists_shows_and_jsons(capsys):
    assert main(["presets"]) == 0
    out = capsys.readouterr().out
    assert "pets09-ground" in out and "[world]" in out
    assert main(["presets", "--json"]) == 0
    items = json.loads(capsys.readouterr().out)["presets"]
    pets = next(i for i in items if i["name"] == "pets09-ground")
    assert pets["plugin"] == "world" and pets["path"].endswith("pets09-ground.yaml")
    assert main(["presets", "--show", "pets09-ground"]) == 0
    assert yaml.safe_load(capsys.readouterr().out)["name"] == "pets09-ground"


def test_run_errors_name_what_is_wrong(tmp_path, capsys):
    rc = main(["run", "no-such-preset", "--video", str(PETS / "vtest.avi"),
               "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and "no-such-preset" in err and "pets09-ground" in err
    rc = main(["run", "pets09-ground", "--video", str(tmp_path / "none.avi"),
               "--out", str(tmp_path / "o")])
    assert rc == 2 and "none.avi not found" in capsys.readouterr().err
    rc = main(["run", "pets09-ground", "--video", str(PETS / "vtest.avi"), "--out",
               str(tmp_path / "o"), "--frames", "9:3"])
    assert rc == 2 and "--frames" in capsys.readouterr().err
    # a world configuration without a camera
    rc = main(["run", "pets09-ground", "--video", str(PETS / "vtest.avi"), "--out",
               str(tmp_path / "o"), "--frames", "1:2"])
    assert rc == 2 and "--camera" in capsys.readouterr().err
    (tmp_path / "bad.npz").write_text("x")
    assert main(["detector", "info", str(tmp_path / "bad.npz")]) == 2
    assert "bad.npz" in capsys.readouterr().err
    assert not (tmp_path / "o" / "tracks.txt").exists()


@pytest.mark.slow
def test_train_then_run_from_the_command_line(tmp_path, capsys):
    model = tmp_path / "svm.npz"
    rc = main(["detector", "train", "--video", str(PETS / "vtest.avi"), "--gt",
               str(PETS / "gt.txt"), "--frames", "1:100", "--out", str(model), "--camera",
               str(PETS / "View_001.xml"), "--quiet"])
    assert rc == 0 and model.is_file()
    assert main(["detector", "info", str(model)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["feature"] == "hog" and info["window_wh"] == [48, 96]
    assert info["info"]["n_frames"] == 100
    # a YAML config file (the preset with fewer particles) instead of a preset name
    from pathlib import Path

    from pftrack.host import get_host

    preset = yaml.safe_load(Path(get_host().get("preset", "pets09-ground")).read_text())
    preset["tracker"]["n_particles"] = 100
    cfg = tmp_path / "mine.yaml"
    cfg.write_text(yaml.safe_dump(preset))
    out = tmp_path / "run"
    rc = main(["run", str(cfg), "--video", str(PETS / "vtest.avi"), "--camera",
               str(PETS / "View_001.xml"), "--detector-model", str(model), "--frames",
               "401:430", "--gt", str(PETS / "gt.txt"), "--out", str(out), "--seed", "1"])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["frames"] == 30 and summary["MOTA"] > 0.4
    rows = np.loadtxt(out / "tracks.txt", delimiter=",")
    assert rows.shape[1] == 10 and rows[:, 0].min() >= 401 and rows[:, 0].max() <= 430
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["MOTA"] == pytest.approx(summary["MOTA"])
    # first, middle and last frames (the "5 s later" one lies beyond this slice)
    assert sorted(p.name for p in (out / "report").glob("overlay_*.png")) == [
        "overlay_000401.png", "overlay_000415.png", "overlay_000430.png"]
    # no temporary files left behind by the atomic writes
    assert not [p for p in out.rglob(".*tmp*")]
