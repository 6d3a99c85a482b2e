"""Every benchmark declares its protocol once (``PROTOCOL`` in its module), its JSON carries it,
and a benchmark with a frame split refuses figures on the frames that chose its settings unless
``--part tune`` asks for them (one helper, :mod:`pftrack_bench.protocol`)."""

from __future__ import annotations

import argparse
import importlib
import types

import pftrack_bench
import pytest
from pftrack.contracts.extensions import Benchmark
from pftrack.host import Host
from pftrack_bench.protocol import (
    REPORT_PART,
    TUNE_PART,
    Protocol,
    add_part_argument,
    benchmark,
    checked_frames,
    part_frames,
)

SPLIT = Protocol(data="d", chosen_on="frames 1-200", reported_on="frames 201-795",
                 chosen_frames={"": (1, 200)}, reported_frames={"": (201, 795)})


def _host() -> Host:
    return Host(load_entry_points=False, plugins=[("bench", pftrack_bench)])


def _parser(name: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser()
    _host().get("benchmark", name).add_arguments(parser)
    return parser


def test_every_benchmark_declares_its_protocol_and_is_registered():
    host = _host()
    listed = host.listing()["plugins"][0]["components"]["benchmark"]
    assert listed == list(pftrack_bench.BENCHMARKS)
    declared = pftrack_bench.protocols()
    for name, module in pftrack_bench.BENCHMARKS.items():
        proto = importlib.import_module(f"pftrack_bench.{module}").PROTOCOL
        assert isinstance(proto, Protocol), name
        assert declared[name] == {"data": proto.data, "chosen_on": proto.chosen_on,
                                  "reported_on": proto.reported_on}
        assert all(len(v) > 10 for v in declared[name].values()), name
        assert isinstance(host.get("benchmark", name), Benchmark)
    split = {n for n, m in pftrack_bench.BENCHMARKS.items()
             if importlib.import_module(f"pftrack_bench.{m}").PROTOCOL.has_split}
    assert split == {"pets09-ground", "fresh-video", "own-detections", "people-colour",
                     "detectors"}


def test_the_split_is_the_one_the_benchmark_runs_on():
    from pftrack_bench import detectors, own_detections

    for video, spec in own_detections.VIDEOS.items():
        assert own_detections.PROTOCOL.chosen_frames[video] == spec.tune
        assert own_detections.PROTOCOL.reported_frames[video] == spec.report
    for video, (tune, report) in detectors.SPLITS.items():
        assert detectors.PROTOCOL.chosen_frames[video] == tune
        assert detectors.PROTOCOL.reported_frames[video] == report


def test_part_frames_refuses_the_frames_that_chose_the_settings():
    assert part_frames("b", SPLIT, REPORT_PART) == (201, 795)
    assert part_frames("b", SPLIT, TUNE_PART) == (1, 200)
    assert part_frames("b", SPLIT, REPORT_PART, "300:400") == (300, 400)
    assert part_frames("b", SPLIT, REPORT_PART, "700:") == (700, 795)
    assert part_frames("b", SPLIT, TUNE_PART, (1, 60)) == (1, 60)
    with pytest.raises(ValueError, match=r"^b: frames 1:40 are not inside its report part "
                                         r"\(201:795\); the tune part is 1:200; .*--part tune"):
        part_frames("b", SPLIT, REPORT_PART, "1:40")
    with pytest.raises(ValueError, match="not inside its report part"):
        part_frames("b", SPLIT, REPORT_PART, "190:210")  # straddles the two parts
    with pytest.raises(ValueError, match=r"not inside its tune part \(1:200\)"):
        part_frames("b", SPLIT, TUNE_PART, "201:240")
    with pytest.raises(ValueError, match="--part must be one of report, tune"):
        part_frames("b", SPLIT, "all")
    with pytest.raises(ValueError, match="no frame split for v"):
        part_frames("b", SPLIT, REPORT_PART, video="v")


def test_a_protocol_with_overlapping_parts_is_refused():
    with pytest.raises(ValueError, match="must be non-empty and apart, got 1:200 and 200:795"):
        Protocol("d", "c", "r", chosen_frames={"": (1, 200)}, reported_frames={"": (200, 795)})
    with pytest.raises(ValueError, match="must name the same videos"):
        Protocol("d", "c", "r", chosen_frames={"a": (1, 2)}, reported_frames={"b": (3, 4)})


def test_the_json_carries_the_protocol_and_the_part():
    seen = []

    def run(args):
        seen.append(checked_frames("toy", SPLIT, args))
        return {"MOTA": 0.5, "protocol": {"videos": ["v"]}}

    module = types.ModuleType("toy", "A toy benchmark.")
    module.run = run
    module.add_arguments = lambda p: (add_part_argument(p, SPLIT),
                                      p.add_argument("--frames", default=None))
    module.PROTOCOL = SPLIT
    bench = benchmark(module)
    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    r = bench.run(parser.parse_args([]))
    assert seen == ["201:795"] and r["part"] == "report" and r["MOTA"] == 0.5
    # the benchmark's own protocol details stay beside the declared words
    assert r["protocol"] == {"videos": ["v"], **SPLIT.as_dict()}
    r = bench.run(parser.parse_args(["--part", "tune", "--frames", "1:50"]))
    assert seen[-1] == "1:50" and r["part"] == "tune"
    with pytest.raises(ValueError, match="only with --part tune"):
        bench.run(parser.parse_args(["--frames", "1:50"]))
    del module.PROTOCOL
    with pytest.raises(TypeError, match="toy declares no PROTOCOL"):
        benchmark(module)


@pytest.mark.parametrize(("name", "frames", "report"), [
    ("pets09-ground", "1:100", "401:795"), ("fresh-video", "150:250", "201:795"),
    ("people-colour", "1:40", "201:795")])
def test_split_benchmarks_refuse_tuning_frames_before_reading_any_data(name, frames, report,
                                                                      monkeypatch):
    monkeypatch.setenv("PFTRACK_DATA", "/nonexistent")  # the refusal comes first
    bench = _host().get("benchmark", name)
    parser = _parser(name)
    with pytest.raises(ValueError, match=rf"^{name}: frames .* not inside its report part "
                                         rf"\({report}\).*only with --part tune"):
        bench.run(parser.parse_args(["--frames", frames, "--quiet"]))
    assert "--part" in parser.format_help()


def test_pets09_ground_refuses_a_detector_trained_on_reported_frames(monkeypatch):
    monkeypatch.setenv("PFTRACK_DATA", "/nonexistent")
    bench = _host().get("benchmark", "pets09-ground")
    args = _parser("pets09-ground").parse_args(["--train-frames", "1:500", "--quiet"])
    with pytest.raises(ValueError, match=r"frames 1:500 are not inside its tune part \(1:400\)"):
        bench.run(args)
