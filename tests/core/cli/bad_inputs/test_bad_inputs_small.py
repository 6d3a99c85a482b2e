"""Catalogue: the smaller rough edges of bad input. Each stops with a one-line message that names
the option, file or plugin at fault: ``--frames`` that is empty, zero-based, backwards or not
an integer; a ground-truth file with no row; a folder given as a MOT file; a negative
``--seed`` on every command that takes one; ``detector train --out`` with a name its detector
cannot write (before training); a composite likelihood's term, or a likelihood, that breaks the
contract (NaN, integer log-likelihoods) reported as its plugin's fault."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from pftrack.contracts.components import Likelihood
from pftrack.io.frames import parse_frames
from pftrack.workflows.pipeline import run_pipeline

from ._catalogue import CONFIG, assert_untouched, one_line, snapshot
from .test_bad_inputs_plugins import _Registers


@pytest.mark.parametrize("frames, words", [
    ("", "--frames is empty"),
    ("   ", "--frames is empty"),
    ((0, 5), "--frames (0, 5): need 1 <= A <= B"),
    ((5, 2), "--frames (5, 2): need 1 <= A <= B"),
    ((1.7, 3), "a pair of integers (A, B), got (1.7, 3)"),
    (("2", "4"), "a pair of integers (A, B), got ('2', '4')"),
    ((1, 2, 3), "a pair of integers (A, B), got (1, 2, 3)"),
    ("0:4", "--frames '0:4': need 1 <= A <= B"),
    ("9:3", "--frames '9:3': need 1 <= A <= B"),
    ("a:b", "--frames must look like A:B"),
])
def test_parse_frames_rejects_what_is_not_a_frame_range(frames, words):
    with pytest.raises(ValueError) as info:
        parse_frames(frames)
    assert words in str(info.value)


def test_parse_frames_reads_the_ranges_it_documents():
    assert parse_frames(None) == (1, None)
    assert parse_frames("3") == (3, 3)
    assert parse_frames("2:") == (2, None)
    assert parse_frames(":7") == (1, 7)
    assert parse_frames("4:9") == (4, 9)
    assert parse_frames((np.int64(2), 5)) == (2, 5)
    assert parse_frames((3, None)) == (3, None)
    with pytest.raises(ValueError, match=r"^field 'frames' is empty"):
        parse_frames("", option="field 'frames'")


def test_empty_frames_option_stops_the_run(work, cli):
    before = snapshot(work.dir)
    r = cli("run", work.config, "--video", work.video, "--out", work.out, "--frames", "",
            "--quiet")
    assert r.rc == 2 and "--frames is empty" in one_line(r.err)
    # pftrack track says so before it estimates a camera from the detections
    r = cli("track", work.video, "--out", work.out, "--detections", work.gt, "--frames", "",
            "--quiet")
    assert r.rc == 2 and "--frames is empty" in one_line(r.err)
    assert_untouched(before, work.dir)


def test_empty_ground_truth_is_an_error_naming_the_file(work, cli):
    empty = work.dir / "empty_gt.txt"
    empty.write_text("# a comment and a blank line\n\n")
    before = snapshot(work.dir)
    r = cli("run", work.config, "--video", work.video, "--out", work.out, "--gt", empty,
            "--quiet")
    assert r.rc == 2
    assert f"ground truth {empty}: no rows" in one_line(r.err)
    assert_untouched(before, work.dir)
    r = cli("eval", empty, work.gt)
    assert r.rc == 2 and f"ground truth {empty}: no rows" in one_line(r.err)
    # an empty tracks file is a result (a run that tracked nothing): scored, FN only
    none = work.dir / "no_tracks.txt"
    none.write_text("")
    r = cli("eval", work.gt, none, "--json")
    assert r.rc == 0 and '"FN": 24' in r.out


def test_ground_truth_with_nothing_in_the_frames_is_scored_with_a_warning(work):
    with pytest.warns(UserWarning, match=r"--gt .*gt.txt: no ground-truth row in frames "
                                         r"30..40: the metrics count only the tracks' false "
                                         r"positives"):
        with pytest.raises(ValueError, match="has 24 frames"):  # then the video is too short
            run_pipeline(work.config, video=work.video, gt=work.gt, frames="30:40",
                         progress=False, report=False)


def test_a_folder_given_as_a_mot_file_is_called_a_folder(work, cli):
    from pftrack.io.mot import read_mot

    with pytest.raises(IsADirectoryError, match=f"MOT file {work.dir}: is a folder"):
        read_mot(work.dir)
    r = cli("eval", work.dir, work.gt)
    assert r.rc == 2 and f"ground truth {work.dir}: is a folder" in one_line(r.err)
    r = cli("eval", work.gt, work.dir)
    assert r.rc == 2 and f"tracks {work.dir}: is a folder" in one_line(r.err)
    missing = work.dir / "missing.txt"
    r = cli("eval", work.gt, missing)
    assert r.rc == 2 and f"tracks not found: {missing}" in one_line(r.err)


@pytest.mark.parametrize("command", [
    ("run", "CONFIG", "--video", "VIDEO", "--out", "OUT"),
    ("track", "VIDEO", "--out", "OUT"),
    ("detector", "train", "--video", "VIDEO", "--gt", "GT", "--out", "OUT/m.npz"),
    ("calib", "people", "--boxes", "GT"),
])
def test_negative_seed_names_the_option(work, cli, command):
    args = [{"CONFIG": work.config, "VIDEO": work.video, "OUT": work.out, "GT": work.gt,
             "OUT/m.npz": work.out / "m.npz"}.get(a, a) for a in command]
    for bad, words in (("-1", "expected a random seed, an integer >= 0, got -1"),
                       ("x", "expected a random seed, an integer >= 0, got 'x'")):
        r = cli(*args, "--seed", bad)
        assert r.rc == 2
        assert f"argument --seed: {words}" in r.err.strip().splitlines()[-1]


@pytest.mark.parametrize("command, option, bad", [
    (("calib", "people", "--boxes", "GT"), "--stride", "0"),
    (("calib", "people", "--boxes", "GT"), "--bootstrap", "-1"),
    (("batch", "GT", "--out", "OUT"), "--workers", "0"),
    (("batch", "GT", "--out", "OUT"), "--retries", "-2"),
    (("render", "overlay", "--video", "VIDEO", "--tracks", "GT", "--out", "OUT/o.png"),
     "--frame", "0"),
])
def test_integer_options_name_themselves(work, cli, command, option, bad):
    args = [{"VIDEO": work.video, "OUT": work.out, "GT": work.gt,
             "OUT/o.png": work.out / "o.png"}.get(a, a) for a in command]
    r = cli(*args, option, bad)
    assert r.rc == 2 and f"argument {option}: expected an integer" in r.err


def test_library_seed_is_checked_and_named(work):
    with pytest.raises(ValueError, match=r"^seed -1: not a random seed \(an integer >= 0\)"):
        run_pipeline(work.config, video=work.video, frames="1:2", seed=-1, progress=False,
                     report=False)


def test_detector_out_name_is_checked_before_training(work, cli, monkeypatch):
    from pftrack_world.detector import SVMDetector

    def no_training(self, *a, **k):
        raise AssertionError("training started")

    monkeypatch.setattr(SVMDetector, "fit", no_training)
    before = snapshot(work.dir)
    r = cli("detector", "train", "--video", work.video, "--gt", work.gt, "--frames", "1:5",
            "--out", work.dir / "x.txt", "--quiet")
    assert r.rc == 2
    assert (f"--out {work.dir / 'x.txt'}: detector 'svm' writes .npz models; give a file name "
            "ending in .npz") in one_line(r.err)
    assert_untouched(before, work.dir)


# -- plugins that break the likelihood contract -----------------------------------------------


class _NaNTerm(Likelihood):
    """NaN for every box."""

    def __init__(self) -> None:
        pass

    def log_likelihood(self, boxes_xywh_px, target):
        return np.full(len(boxes_xywh_px), np.nan)


class _IntegerLikelihood(Likelihood):
    """Integer zeros: the right shape, the wrong dtype."""

    def __init__(self) -> None:
        pass

    def log_likelihood(self, boxes_xywh_px, target):
        return np.zeros(len(boxes_xywh_px), dtype=np.int64)


_NaNTerm.__module__ = _IntegerLikelihood.__module__ = "broken_plugin.likelihoods"


def _with_likelihood(work, likelihood) -> object:
    cfg = yaml.safe_load(CONFIG)
    cfg["likelihood"] = likelihood
    p = work.dir / "broken.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


@pytest.mark.parametrize("mix", ["sum", "product"])
def test_composite_term_returning_nan_stops_the_run_naming_its_plugin(work, cli, plugin_host,
                                                                      mix):
    plugin_host(("broken", _Registers("l", [("nan-term", _NaNTerm, False)])))
    cfg = _with_likelihood(work, {"type": "composite", "params": {"mix": mix, "terms": [
        {"likelihood": {"type": "gaussian", "params": {"sigma_px": 4.0}}, "weight": 1.0},
        {"likelihood": "nan-term", "weight": 0.5}]}})
    before = snapshot(work.dir)
    r = cli("run", cfg, "--video", work.video, "--out", work.out, "--quiet")
    assert r.rc == 1
    line = one_line(r.err)
    assert line.startswith("pftrack run: plugin error")
    assert ("composite term likelihood 'nan-term' of plugin 'broken' (_NaNTerm from "
            "broken_plugin.likelihoods) returned 40 NaN or +inf log-likelihood(s) of 40") in line
    assert_untouched(before, work.dir)


def test_integer_log_likelihoods_are_the_plugins_fault(work, cli, plugin_host):
    plugin_host(("broken", _Registers("l", [("int-lik", _IntegerLikelihood, False)])))
    cfg = _with_likelihood(work, {"type": "int-lik", "params": {}})
    r = cli("run", cfg, "--video", work.video, "--out", work.out, "--quiet")
    assert r.rc == 1
    line = one_line(r.err)
    assert line.startswith("pftrack run: plugin error")
    assert "internal error" not in line
    assert ("likelihood 'int-lik' of plugin 'broken' (_IntegerLikelihood from "
            "broken_plugin.likelihoods) returned log-likelihoods of dtype int64, expected "
            "floating point") in line
    # the same integers as a composite's term
    cfg = _with_likelihood(work, {"type": "composite", "params": {"terms": [
        {"likelihood": "int-lik", "weight": 1.0}]}})
    r = cli("run", cfg, "--video", work.video, "--out", work.out, "--quiet")
    assert r.rc == 1
    assert ("composite term likelihood 'int-lik' of plugin 'broken' (_IntegerLikelihood from "
            "broken_plugin.likelihoods) returned log-likelihoods of dtype int64"
            ) in one_line(r.err)


# -- a camera that cannot see the ground -------------------------------------------------------


def test_scale_plan_errors_name_the_camera_file_and_the_image_sizes(tmp_path):
    from pftrack.geometry.formats import load_camera, save_camera
    from pftrack.geometry.people import camera_from_parameters
    from pftrack_world.detector import scale_plan

    down = tmp_path / "down.yaml"
    save_camera(camera_from_parameters(800.0, 20.0, 0.0, 5.0, (768, 576)), down)
    cam = load_camera(down)
    # frames of another size than the camera's, people far smaller than the heights searched
    with pytest.raises(ValueError) as info:
        scale_plan(80, 96, 88, (384, 288), camera=cam, min_height_px=400, max_height_px=800)
    msg = str(info.value)
    assert msg.startswith(f"scale_plan: camera {down} (calibrated for 768x576 images) on "
                          "384x288 frames: people 1.75 m tall would be ")
    assert "outside the searched 400-800 px (min_height_px, max_height_px" in msg
    assert "check that the camera belongs to this video" in msg
    up = tmp_path / "up.yaml"
    save_camera(camera_from_parameters(800.0, -40.0, 0.0, 5.0, (768, 576)), up)
    with pytest.raises(ValueError, match=rf"^scale_plan: camera {up} \(calibrated for 768x576 "
                                         r"images\) on 768x576 frames: no image row sees the "
                                         r"ground"):
        scale_plan(80, 96, 88, (768, 576), camera=load_camera(up))
    with pytest.raises(ValueError, match=r"^scale_plan on 768x576 frames: empty height range "
                                         r"\[50, 20\] px \(min_height_px > max_height_px\)"):
        scale_plan(80, 96, 88, (768, 576), min_height_px=50, max_height_px=20)


def _seed_options(parser, path=()):
    """``(command path, option, type)`` of every seed option under ``parser``."""
    import argparse

    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _seed_options(sub, (*path, name))
        elif any(s == "--seed" or s.endswith("-seed") for s in action.option_strings):
            yield " ".join(path), action.option_strings[0], action.type


def test_every_seed_option_of_every_command_refuses_a_negative_seed(cli):
    from pftrack.cli import _args, build_parser

    found = list(_seed_options(build_parser()))
    commands = {c for c, _, _ in found}
    # the core's commands and the built-in plugins' benchmarks and demos
    assert {"run", "track", "detector train", "calib people", "bench colour",
            "demo"} <= commands, commands
    assert [f for f in found if f[2] is not _args.seed] == []
    r = cli("bench", "colour", "--scene-seed", "-1")
    assert r.rc == 2 and ("argument --scene-seed: expected a random seed, an integer >= 0, got "
                          "-1") in r.err
