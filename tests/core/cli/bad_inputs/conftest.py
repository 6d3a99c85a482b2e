"""Fixtures of the bad-input catalogue (helpers in ``_catalogue``)."""

from __future__ import annotations

import types
from dataclasses import dataclass

import pftrack.host as host_mod
import pytest
from pftrack.cli import main

from ._catalogue import CONFIG, gt_text, write_video


@dataclass
class Outcome:
    rc: int
    out: str
    err: str


@pytest.fixture
def cli(capsys):
    """``cli(*args) -> Outcome``: ``pftrack.cli.main`` in-process (argparse's SystemExit turned
    into its code)."""

    def call(*args: object) -> Outcome:
        capsys.readouterr()
        try:
            rc = main([str(a) for a in args])
        except SystemExit as exc:
            rc = int(exc.code or 0)
        c = capsys.readouterr()
        return Outcome(rc, c.out, c.err)

    return call


@pytest.fixture(scope="session")
def inputs(tmp_path_factory) -> types.SimpleNamespace:
    """The tiny synthetic inputs (read only: tests that change them copy them first)."""
    d = tmp_path_factory.mktemp("inputs")
    ns = types.SimpleNamespace(dir=d)
    ns.video = write_video(d / "clip.avi")
    ns.config = d / "tiny.yaml"
    ns.config.write_text(CONFIG)
    ns.gt = d / "gt.txt"
    ns.gt.write_text(gt_text())
    return ns


@pytest.fixture
def work(tmp_path, inputs) -> types.SimpleNamespace:
    """A fresh folder with a previous run's outputs in ``out/`` (to prove they survive)."""
    ns = types.SimpleNamespace(dir=tmp_path, video=inputs.video, config=inputs.config,
                               gt=inputs.gt)
    ns.out = tmp_path / "out"
    (ns.out / "report").mkdir(parents=True)
    (ns.out / "tracks.txt").write_text("1,1,1,1,5,5,1,-1,-1,-1\n")
    (ns.out / "metrics.json").write_text('{"MOTA": 0.5}\n')
    (ns.out / "report" / "overlay_000001.png").write_bytes(b"old picture")
    return ns


@pytest.fixture
def plugin_host(monkeypatch):
    """``plugin_host(name, module)``: make the process-wide host one with an extra in-process
    plugin (as if installed), restored afterwards."""

    def install(*plugins: tuple[str, object]) -> host_mod.Host:
        h = host_mod.Host(plugins=plugins)
        monkeypatch.setattr(host_mod, "_HOST", h)
        return h

    yield install


