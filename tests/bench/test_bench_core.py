"""``pftrack bench core`` runs at small N and reports every figure (no timing assertions)."""

from __future__ import annotations

import argparse
import json

import pytest
from pftrack.cli import main
from pftrack_bench import core as core


def _args(**kw) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    core.add_arguments(p)
    ns = p.parse_args([])
    for k, v in kw.items():
        setattr(ns, k, v)
    return ns


def test_run_reports_every_key_with_stonesoup():
    r = core.run(_args(particles=[200, 1000], repeats=2))
    assert [row["particles"] for row in r["rows"]] == [200, 1000]
    for row in r["rows"]:
        assert {"particles", "step_s", "stonesoup_step_s", "speedup_vs_stonesoup",
                "resample_systematic_s"} <= set(row)
        assert row["step_s"] > 0 and row["stonesoup_step_s"] > 0
        assert row["resample_systematic_s"] > 0
        assert row["speedup_vs_stonesoup"] == pytest.approx(
            row["stonesoup_step_s"] / row["step_s"])
    assert r["goals"]["speedup_1k"]["value"] == r["rows"][1]["speedup_vs_stonesoup"]
    assert r["environment"]["stonesoup"]
    assert "1000" in core.format_table(r) and "goal speedup_1k" in core.format_table(r)


def test_run_without_stonesoup_and_with_one_blas_thread():
    r = core.run(_args(particles=[300], repeats=1, no_stonesoup=True, blas_threads=1))
    (row,) = r["rows"]
    assert "stonesoup_step_s" not in row and row["step_s"] > 0
    assert r["goals"] == {}
    with pytest.raises(ValueError, match="--particles"):
        core.run(_args(particles=[0]))
    with pytest.raises(ValueError, match="--repeats"):
        core.run(_args(particles=[10], repeats=0))


def test_cli_prints_and_writes_json(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert main(["bench", "core", "--json", "--particles", "256", "--repeats", "1",
                 "--out", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out)
    saved = json.loads(out.read_text())
    assert printed["rows"][0]["particles"] == 256 == saved["rows"][0]["particles"]
    assert set(saved["rows"][0]) >= {"step_s", "stonesoup_step_s", "speedup_vs_stonesoup",
                                     "resample_systematic_s"}
