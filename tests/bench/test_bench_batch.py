"""``pftrack bench batch`` on a tiny case: the two commands (``pftrack batch --workers 1`` and
``--workers 2``, each a new process) and the in-process runs give the same tracks, and the
figures are what the docstring defines (the speed-up itself is a benchmark figure, not asserted)."""

from __future__ import annotations

import argparse
import json

import pytest
from pftrack.host import get_host
from pftrack.io.data import data_dir

PETS = data_dir() / "pets09"


@pytest.mark.slow
@pytest.mark.skipif(not (PETS / "gt.txt").is_file(), reason="PETS 2009 not found")
def test_batch_bench_times_both_commands_and_keeps_the_old_figures(tmp_path):
    pytest.importorskip("distributed")
    from pftrack.workflows.pipeline import load_config, train_detector

    model = tmp_path / "svm60.npz"
    train_detector(PETS / "vtest.avi", PETS / "gt.txt", "1:60", out=model,
                   cfg=load_config("pets09-ground"), seed=0)
    bench = get_host().get("benchmark", "batch")
    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    r = bench.run(parser.parse_args(["--jobs", "2", "--frames-per-job", "4", "--repeats", "1",
                                     "--model", str(model), "--quiet"]))
    json.dumps(r)
    assert r["jobs"] == 2 and r["workers"] == 2 and r["identical_to_serial"] is True
    assert r["frames"] == ["396:399", "400:403"]
    assert r["speedup"] == pytest.approx(r["serial_s"] / r["parallel_s"])
    assert r["in_process_speedup"] == pytest.approx(
        r["in_process_serial_s"] / r["in_process_parallel_s"])
    # the commands pay an interpreter, imports and compilation that the in-process serial run
    # (after its untimed warm-up job) does not
    assert r["serial_s"] > r["in_process_serial_s"]
    assert r["warm_speedup"] == pytest.approx(r["in_process_serial_s"] / r["warm_parallel_s"])
    assert set(r["goals"]) == {"speedup", "overhead_per_job_s"}
    assert r["goals"]["speedup"]["value"] == r["speedup"]
    assert "in_process_speedup" in bench.format_table(r)
