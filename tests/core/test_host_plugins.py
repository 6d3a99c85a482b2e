"""A third-party plugin installed as an ordinary distribution (tests/sample_plugin) is found through
the ``pftrack`` entry-point group, listed by ``pftrack plugins``, builds and runs, and is blocked by
``PFTRACK_DISABLE_PLUGINS`` / ``PFTRACK_DISABLE_PLUGIN_AUTOLOAD`` while the built-ins still load."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

SAMPLE = ROOT / "tests" / "sample_plugin"


@pytest.fixture(scope="module")
def sample_site(tmp_path_factory) -> Path:
    """tests/sample_plugin pip-installed (no deps, no build isolation) into a temporary folder."""
    tmp = tmp_path_factory.mktemp("sample_plugin")
    src = tmp / "src"
    # build from a copy: the build writes egg-info next to the sources
    shutil.copytree(SAMPLE, src, ignore=shutil.ignore_patterns("*.egg-info", "build",
                                                               "__pycache__"))
    site = tmp / "site"
    proc = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation",
         "--no-index", "--quiet", "--target", str(site), str(src)],
        capture_output=True, text=True, check=False)
    assert proc.returncode == 0, (
        "pip could not build tests/sample_plugin; with setuptools < 70.1 the 'wheel' package "
        f"must be installed in the test environment.\n{proc.stdout[-2000:]}{proc.stderr[-2000:]}")
    assert (site / "pftrack_sample" / "__init__.py").is_file()
    return site


def _run(site: Path | None, args: list[str], **env_extra: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items()
           if k not in ("PFTRACK_DISABLE_PLUGINS", "PFTRACK_DISABLE_PLUGIN_AUTOLOAD")}
    if site is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(site), env.get("PYTHONPATH", "")]).rstrip(
            os.pathsep)
    env.update(env_extra)
    proc = subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env,
                          timeout=120, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc


def _listing(site: Path | None, **env) -> dict[str, dict]:
    out = _run(site, ["-m", "pftrack", "plugins", "--json"], **env).stdout
    return {p["name"]: p for p in json.loads(out)["plugins"]}


def test_installed_plugin_is_listed_as_third_party(sample_site):
    plugins = _listing(sample_site)
    s = plugins["sample"]
    assert s["builtin"] is False
    assert s["version"] == "0.3.1"
    assert "pftrack-sample" in s["source"]
    assert s["components"] == {
        "motion": ["sample-drift"], "likelihood": ["sample-box-area", "sample-brightness"],
        "detector": ["sample-bright"], "associator": ["sample-nearest"],
        "scene": ["sample-dots"], "observation": ["sample-square"],
        "tracks": ["sample-seen-twice"], "stage": ["sample-miss-limit"],
        "metric": ["sample-count"], "preset": ["sample-dots"],
        "command": ["sample-write-dots"], "benchmark": ["sample-brightness"],
        "demo": ["sample-dots"], "report": ["sample-boxes"]}
    assert "pftrack_register_commands" in s["hooks"] and len(s["hooks"]) == 14
    assert "error" not in s
    assert all(plugins[n]["builtin"] for n in ("basic", "colour", "world"))
    # third-party plugins are listed after the built-ins
    assert list(plugins).index("sample") > list(plugins).index("world")
    text = _run(sample_site, ["-m", "pftrack", "plugins"]).stdout
    assert "sample 0.3.1 (third-party" in text and "sample-drift" in text
    # its parameters are counted with the built-ins', and its preset is seen to use them
    inv = json.loads(_run(sample_site, ["-m", "pftrack", "plugins", "--params", "--json"]).stdout)
    drift = next(r for r in inv["components"] if r["name"] == "sample-drift")
    assert (drift["plugin"], drift["names"]) == ("sample", ["velocity_px", "sigma_px"])
    assert "sample-dots" in drift["presets"]


_RUN_SAMPLE = r"""
import json
import numpy as np
from pftrack.host import get_host
from pftrack.testing import check_component
from pftrack.builtin.image_box import ImageBoxObservation
from pftrack.engine.tracker import MultiTargetTracker
from pftrack.contracts.components import Frame

h = get_host()
m = h.build("motion", {"type": "sample-drift", "params": {"velocity_px": [2.0, -1.0],
                                                          "sigma_px": 0.0}})
s = np.array([[10.0, 20.0], [0.0, 0.0]])
moved = m.predict(s, 0.5, np.random.default_rng(0))
lik = h.build("likelihood", {"type": "sample-box-area", "params": {"area_px": 400.0}})
ll = lik.log_likelihood(np.array([[0, 0, 20, 20], [0, 0, 30, 20.0]]), None)
tr = MultiTargetTracker(h.build("motion", "sample-drift"), lik, ImageBoxObservation(20, 20),
                        n_particles=50, rng=np.random.default_rng(1), kill_out_of_view=False)
img = np.zeros((100, 100, 3), np.uint8)
tr.add_target(Frame(1, img), np.array([50.0, 50.0]))
recs = [tr.step(Frame(k, img)) for k in range(2, 6)]
fails = [str(r) for cls in (type(m), type(lik)) for r in check_component(cls, host=h)
         if r.status == "fail"]
print(json.dumps({"moved": moved.tolist(), "ll": ll.tolist(), "n_records": sum(map(len, recs)),
                  "x_last": float(recs[-1][0].position[0]), "config": m.to_config(),
                  "fails": fails}))
"""


def test_installed_plugin_builds_runs_and_conforms(sample_site):
    r = json.loads(_run(sample_site, ["-c", _RUN_SAMPLE]).stdout)
    assert r["moved"] == [[11.0, 19.5], [1.0, -0.5]]  # + velocity * dt, no noise
    assert r["ll"] == [0.0, -2.0]  # -((600 - 400) / 100)^2 / 2
    assert r["n_records"] == 4
    assert 50.0 + 4 * 1.0 - 3.0 < r["x_last"] < 50.0 + 4 * 1.0 + 3.0  # drifts 1 px per frame
    assert r["config"] == {"type": "sample-drift",
                           "params": {"velocity_px": [2.0, -1.0], "sigma_px": 0.0}}
    assert r["fails"] == []


_RUN_SAMPLE_STAGE = r"""
import json
import numpy as np
from pftrack.contracts.components import Detections
from pftrack.host import get_host
from pftrack.testing import check_component
from pftrack.engine.tracker import MultiTargetTracker

h = get_host()
scene = h.build("scene", {"type": "sample-dots", "params": {"n_frames": 12}})
det = h.build("detector", "sample-bright")


def per_frame(stages):
    tracks = h.build("tracks", {"type": "stages", "params": {"stages": stages}})
    tr = MultiTargetTracker(h.build("motion", {"type": "sample-drift",
                                               "params": {"velocity_px": [0.0, 0.5]}}),
                            h.build("likelihood", "sample-box-area"),
                            h.build("observation", "sample-square"), tracks=tracks,
                            associator=h.build("associator", "sample-nearest"),
                            detection_driven=True, kill_out_of_view=False, n_particles=50,
                            rng=np.random.default_rng(0))
    # the dots are detected in frames 1-4 only
    return [len(tr.step(f, det.detect(f) if f.index <= 4 else Detections.empty()))
            for f in scene.frames()]


births = {"type": "unmatched-births", "params": {"min_score": 0.0}}
stage = {"type": "sample-miss-limit", "params": {"max_unmatched": 2}}
print(json.dumps({"without": per_frame([births]), "with": per_frame([births, stage]),
                  "fails": [str(r) for r in check_component(h.get("stage", "sample-miss-limit"),
                                                            host=h) if r.status == "fail"]}))
"""


def test_installed_plugin_stage_ends_tracks_in_the_lifecycle(sample_site):
    """A third-party lifecycle stage, listed among built-in stages in a configuration, ends the
    tracks it decides to end, and passes the conformance kit."""
    r = json.loads(_run(sample_site, ["-c", _RUN_SAMPLE_STAGE]).stdout)
    # two dots, each a track from frame 1; without the stage they are never ended (no
    # max_misses); with it each ends in its third frame without a detection (frame 7)
    assert r["without"] == [2] * 12
    assert r["with"] == [2] * 6 + [0] * 6
    assert r["fails"] == []


def test_a_paper_arrives_as_a_plugin_without_editing_pftrack(sample_site, tmp_path):
    """Every piece the sample plugin registers runs through the ``pftrack`` command line: its
    command writes its scene as a video, its preset tracks it with its own observation model,
    detector, associator, motion model, likelihood and track manager, ``pftrack eval`` reports
    its metric, ``pftrack bench`` runs its
    benchmark and ``pftrack demo NAME`` its demo."""
    data = tmp_path / "dots"
    _run(sample_site, ["-m", "pftrack", "sample-write-dots", "--out", str(data),
                       "--frames", "40"])
    assert (data / "dots.avi").is_file() and (data / "gt.txt").is_file()
    out = tmp_path / "run"
    proc = _run(sample_site, ["-m", "pftrack", "run", "sample-dots", "--video",
                              str(data / "dots.avi"), "--gt", str(data / "gt.txt"), "--out",
                              str(out), "--seed", "3"])
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["MOTA"] > 0.9 and metrics["IDSW"] == 0, proc.stdout
    assert metrics["num_tracker_ids"] == 2
    # its report writer drew the report (the frames kept: the first, the middle and the last;
    # the 51st lies beyond these 40)
    assert sorted(p.name for p in (out / "report").iterdir()) == [
        "boxes_000001.png", "boxes_000020.png", "boxes_000040.png"]
    ev = json.loads(_run(sample_site, ["-m", "pftrack", "eval", str(data / "gt.txt"),
                                       str(out / "tracks.txt"), "--json"]).stdout)
    sample = ev["plugin_metrics"]["sample-count"]
    assert sample["ids"] == 2.0 and 0.9 < sample["rows_ratio"] <= 1.0
    assert abs(ev["MOTA"] - metrics["MOTA"]) < 1e-12
    bench = json.loads(_run(sample_site, ["-m", "pftrack", "bench", "sample-brightness",
                                          "--boxes", "500", "--json"]).stdout)
    assert bench["boxes"] == 500 and bench["seconds"] > 0
    _run(sample_site, ["-m", "pftrack", "demo", "sample-dots", "--out", str(tmp_path / "demo"),
                       "--frames", "5"])
    assert (tmp_path / "demo" / "gt.txt").read_text().count("\n") == 10
    # the built-in default demo is still the one ``pftrack demo`` runs without a name
    code = ("from pftrack.cli.demo import _default; from pftrack.host import get_host; "
            "print(_default({e.name: e.obj for e in get_host().registry.entries('demo')}))")
    assert _run(sample_site, ["-c", code]).stdout.strip() == "walkers"


def test_disable_plugins_env_blocks_it(sample_site):
    plugins = _listing(sample_site, PFTRACK_DISABLE_PLUGINS="sample")
    assert "sample" not in plugins
    assert {"basic", "colour", "world"} <= set(plugins)


def test_disable_autoload_blocks_third_party_but_loads_builtins(sample_site):
    plugins = _listing(sample_site, PFTRACK_DISABLE_PLUGIN_AUTOLOAD="1")
    assert "sample" not in plugins
    assert {"basic", "colour", "world"} <= set(plugins)
    assert "random-walk" in plugins["basic"]["components"]["motion"]


def test_not_installed_means_not_listed():
    assert "sample" not in _listing(None)
