"""The wheel works anywhere: built from this checkout, installed into a fresh virtual environment
outside the repository and run from a temporary folder, it lists its plugins and presets, runs
the demo, and a top view with a volume it ships (package data found through
``importlib.resources``, no path into a repository). It holds no benchmark: the repository's
benchmarks (``benchmarks/``, ``pftrack_bench``) are a wheel of their own, installed beside it as
a third-party plugin would be, and a short soccer benchmark runs through it.

The fresh environment borrows the test environment's third-party dependencies (a ``.pth`` file
naming a folder of links to them, pftrack's own entries left out) so that the test needs no
network and stays within minutes; pftrack itself comes only from the wheel.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT

pytestmark = pytest.mark.slow

_OWN = ("pftrack", "__editable__", "_pftrack", "pftrack_")


def _run(cmd: list[str], cwd: Path, env: dict[str, str], timeout: int = 300) -> str:
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout, check=False)
    assert proc.returncode == 0, f"{' '.join(cmd)} failed:\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


def _dependency_links(dest: Path) -> Path:
    """A folder of links to the running environment's site-packages entries, without pftrack's
    own (its editable install, dist-info, plugin packages)."""
    site = Path(sysconfig.get_paths()["purelib"])
    dest.mkdir()
    for entry in site.iterdir():
        if entry.name.lower().startswith(_OWN) or entry.suffix == ".pth":
            continue
        (dest / entry.name).symlink_to(entry)
    return dest


@pytest.fixture(scope="module")
def wheel_env(tmp_path_factory):
    base = tmp_path_factory.mktemp("wheel")
    # built from a copy of what the wheel is made of, so the checkout gets no build/ folder
    src = base / "src"
    for part in ("toolkit", "plugins"):
        shutil.copytree(ROOT / part, src / part,
                        ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    for part in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / part, src / part)
    dist = base / "dist"
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
          "-w", str(dist), str(src)], cwd=base, env=dict(os.environ))
    (wheel,) = dist.glob("pftrack-*.whl")
    shutil.copytree(ROOT / "benchmarks", src / "benchmarks",
                    ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
          "-w", str(base / "bench-dist"), str(src / "benchmarks")], cwd=base,
         env=dict(os.environ))
    (bench_wheel,) = (base / "bench-dist").glob("pftrack_bench-*.whl")
    venv = base / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], cwd=base,
         env=dict(os.environ))
    vpy = venv / "bin" / "python"
    vsite = Path(_run([str(vpy), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                      cwd=base, env=dict(os.environ)).strip())
    deps = _dependency_links(base / "deps")
    (vsite / "_pftrack_test_deps.pth").write_text(f"{deps}\n")
    _run([sys.executable, "-m", "pip", "--python", str(vpy), "install", "--no-deps", "-q",
          str(wheel), str(bench_wheel)], cwd=base, env=dict(os.environ))
    work = base / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PFTRACK_DATA")}
    env.update(VTK_DEFAULT_OPENGL_WINDOW="vtkEGLRenderWindow", PYVISTA_OFF_SCREEN="true",
               PFTRACK_DATA=str(base / "no-data"))
    return {"wheel": wheel, "bench_wheel": bench_wheel, "cli": str(venv / "bin" / "pftrack"),
            "py": str(vpy), "cwd": work, "env": env}


def test_wheel_holds_the_plugins_data(wheel_env):
    names = set(zipfile.ZipFile(wheel_env["wheel"]).namelist())
    for f in ("pftrack_world/data/soccer_camera.yaml", "pftrack_world/data/volumes.yaml",
              "pftrack_world/presets/soccer-ground.yaml", "pftrack_coast/data/coast_camera.yaml",
              "pftrack_coast/data/pets09_walkway.yaml", "pftrack/py.typed"):
        assert f in names, f


def test_wheel_holds_no_benchmark(wheel_env):
    names = zipfile.ZipFile(wheel_env["wheel"]).namelist()
    assert not [n for n in names if n.startswith("pftrack_bench") or "/bench_" in n], names
    entry_points = next(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    text = zipfile.ZipFile(wheel_env["wheel"]).read(entry_points).decode()
    assert "pftrack_bench" not in text
    bench = zipfile.ZipFile(wheel_env["bench_wheel"])
    assert "pftrack_bench/pets09_ground.py" in bench.namelist()


def test_wheel_imports_from_its_own_install(wheel_env):
    out = _run([wheel_env["py"], "-c", "import pftrack, pftrack_world; "
                "print(pftrack.__file__); print(pftrack_world.__file__)"],
               cwd=wheel_env["cwd"], env=wheel_env["env"])
    for line in out.split():
        assert str(ROOT) not in line and "site-packages" in line, out


def test_wheel_plugins_and_presets(wheel_env):
    cli, cwd, env = wheel_env["cli"], wheel_env["cwd"], wheel_env["env"]
    plugins = json.loads(_run([cli, "plugins", "--json"], cwd=cwd, env=env))["plugins"]
    by_name = {p["name"]: p for p in plugins}
    assert {"basic", "colour", "world", "coast"} <= set(by_name)
    # the benchmarks come from their own distribution, a third-party plugin to pftrack
    assert by_name["bench"]["builtin"] is False
    assert "soccer" in by_name["bench"]["components"]["benchmark"]
    assert not [p for n, p in by_name.items() if n != "bench"
                and p.get("components", {}).get("benchmark")]
    assert not [p for p in plugins if p.get("error")], plugins
    assert by_name["world"]["components"]["volumes"] == ["world"]
    assert by_name["coast"]["components"]["volumes"] == ["pets09-walkway"]
    presets = json.loads(_run([cli, "presets", "--json"], cwd=cwd, env=env))
    text = json.dumps(presets)
    for name in ("pets09-ground", "soccer-ground", "pets09-volume", "coast-volumes"):
        assert name in text


def test_wheel_demo(wheel_env):
    cli, cwd, env = wheel_env["cli"], wheel_env["cwd"], wheel_env["env"]
    _run([cli, "demo", "--out", "demo"], cwd=cwd, env=env)
    tracks = np.loadtxt(cwd / "demo" / "tracks.csv", delimiter=",", ndmin=2)
    # the walkers scene: three targets over 180 frames
    assert len(np.unique(tracks[:, 1])) == 3 and tracks[:, 0].max() == 180
    for png in ("overlays.png", "trajectories.png"):
        assert (cwd / "demo" / png).stat().st_size > 1000


def test_wheel_soccer_bench_and_topview_with_a_shipped_volume(wheel_env):
    cli, cwd, env = wheel_env["cli"], wheel_env["cwd"], wheel_env["env"]
    res = json.loads(_run([cli, "bench", "soccer", "--duration-s", "2", "--out-tracks",
                           "soccer.txt", "--quiet", "--json"], cwd=cwd, env=env))
    assert res["frames"] == 50 and res["MOTA_world"] > 0.5, res
    tracks = np.loadtxt(cwd / "soccer.txt", delimiter=",", ndmin=2)
    # world x, y on the 105 x 68 m pitch of the shipped volume (origin at a corner)
    assert (tracks[:, 7] > -5).all() and (tracks[:, 7] < 110).all()
    _run([cli, "render", "topview", "soccer.txt", "--volume", "pitch_corner", "--out",
          "top.png"], cwd=cwd, env=env)
    _run([cli, "render", "topview", "soccer.txt", "--volume", "walkway", "--out",
          "walkway.png"], cwd=cwd, env=env)
    import cv2

    for png in ("top.png", "walkway.png"):
        img = cv2.imread(str(cwd / png))
        assert img is not None and img.shape[:2] == (768, 1024)
        assert img.reshape(-1, 3).std(axis=0).max() > 5  # a drawing, not a blank canvas
