"""Catalogue: bad run configurations. Each case runs ``pftrack run BAD.yaml`` into a folder that
holds a previous run's outputs and asserts exit 2, a one-line message naming the file and the key
path at fault, and that nothing on disk changed (the configuration is checked before any frame).
"""

from __future__ import annotations

import copy

import pytest
import yaml

from ._catalogue import CONFIG, assert_untouched, one_line, snapshot

BASE = yaml.safe_load(CONFIG)


def _set(cfg: dict, path: str, value: object) -> dict:
    keys = path.split(".")
    d = cfg
    for k in keys[:-1]:
        d = d.setdefault(k, {})
    d[keys[-1]] = value
    return cfg


def _del(cfg: dict, path: str) -> dict:
    keys = path.split(".")
    d = cfg
    for k in keys[:-1]:
        d = d[k]
    del d[keys[-1]]
    return cfg


# (case id, mutation, text the message must contain besides the file name)
CASES = [
    ("n_particles-word", lambda c: _set(c, "tracker.n_particles", "many"),
     "tracker.n_particles: expected an integer >= 1"),
    ("n_particles-float", lambda c: _set(c, "tracker.n_particles", 200.7),
     "tracker.n_particles: expected an integer >= 1 (particles per target), got 200.7"),
    ("n_particles-bool", lambda c: _set(c, "tracker.n_particles", True),
     "tracker.n_particles: expected an integer >= 1 (particles per target), got True"),
    ("n_particles-zero", lambda c: _set(c, "tracker.n_particles", 0), "got 0"),
    ("n_particles-negative", lambda c: _set(c, "tracker.n_particles", -5), "got -5"),
    ("n_particles-null", lambda c: _set(c, "tracker.n_particles", None),
     "tracker.n_particles: expected an integer >= 1 (particles per target), got null"),
    ("n_particles-list", lambda c: _set(c, "tracker.n_particles", [100]), "got [100]"),
    ("max_misses-negative", lambda c: _set(c, "tracker.max_misses", -1),
     "tracker.max_misses: expected an integer >= 0 or null (frames), got -1"),
    ("max_misses-float", lambda c: _set(c, "tracker.max_misses", 2.5), "tracker.max_misses"),
    ("ess-above-one", lambda c: _set(c, "tracker.ess_threshold", 1.5),
     "tracker.ess_threshold: expected a number in [0, 1]"),
    ("ess-negative", lambda c: _set(c, "tracker.ess_threshold", -0.1), "tracker.ess_threshold"),
    ("ess-string", lambda c: _set(c, "tracker.ess_threshold", "half"), "tracker.ess_threshold"),
    ("dt-zero", lambda c: _set(c, "tracker.dt", 0), "tracker.dt: expected a number > 0"),
    ("dt-negative", lambda c: _set(c, "tracker.dt", -0.04), "tracker.dt"),
    ("dt-word", lambda c: _set(c, "tracker.dt", "fast"), "tracker.dt"),
    ("dt-inf", lambda c: _set(c, "tracker.dt", float("inf")), "tracker.dt"),
    ("init_spread-nan", lambda c: _set(c, "tracker.init_spread", float("nan")),
     "tracker.init_spread"),
    ("init_spread-negative", lambda c: _set(c, "tracker.init_spread", -1.0),
     "tracker.init_spread"),
    ("init_spread-list-of-words", lambda c: _set(c, "tracker.init_spread", ["a", "b"]),
     "tracker.init_spread"),
    ("recover_spread-word", lambda c: _set(c, "tracker.recover_spread", "wide"),
     "tracker.recover_spread"),
    ("resampling-typo", lambda c: _set(c, "tracker.resampling", "sytematic"),
     "did you mean 'systematic'"),
    ("resampling-number", lambda c: _set(c, "tracker.resampling", 3), "tracker.resampling"),
    ("kill_out_of_view-string", lambda c: _set(c, "tracker.kill_out_of_view", "yes"),
     "tracker.kill_out_of_view: expected true or false"),
    ("target_size-negative", lambda c: _set(c, "tracker.target_size", -1), "tracker.target_size"),
    ("min_log_likelihood-word", lambda c: _set(c, "tracker.min_log_likelihood", "low"),
     "tracker.min_log_likelihood"),
    ("tracker-unknown-option", lambda c: _set(c, "tracker.n_particle", 10),
     "tracker.n_particle: unknown key (known: n_particles,"),
    ("tracker-not-mapping", lambda c: _set(c, "tracker", [1, 2]), "tracker: expected a mapping"),
    ("top-level-typo", lambda c: _set(c, "trackr", {}), "trackr: unknown key (known: name,"),
    ("state-unknown", lambda c: _set(c, "state", "sky"),
     "state: expected one of 'world', 'image', got 'sky'"),
    ("motion-missing", lambda c: _del(c, "motion"), "motion: missing (required)"),
    ("likelihood-missing", lambda c: _del(c, "likelihood"), "likelihood: missing (required)"),
    ("motion-param-typo", lambda c: _set(c, "motion.params", {"sigma_xp": 2.0}),
     "motion.params.sigma_xp: unknown parameter of motion 'random-walk'"),
    ("likelihood-param-typo", lambda c: _set(c, "likelihood.params", {"sigam_px": 4.0}),
     "did you mean 'sigma_px'"),
    ("likelihood-param-type", lambda c: _set(c, "likelihood.params.sigma_px", "wide"),
     "likelihood.params.sigma_px: likelihood 'gaussian' expects a number > 0 (px), got 'wide'"),
    ("likelihood-param-range", lambda c: _set(c, "likelihood.params.sigma_px", -2.0),
     "likelihood.params.sigma_px: likelihood 'gaussian' expects a number > 0 (px), got -2.0"),
    ("likelihood-param-nan", lambda c: _set(c, "likelihood.params.sigma_px", float("nan")),
     "likelihood.params.sigma_px"),
    ("detector-param-typo", lambda c: _set(c, "detector.params.min_area", 30),
     "detector.params.min_area: unknown parameter of detector 'mog2'"),
    ("detector-param-int-as-float", lambda c: _set(c, "detector.params.min_area_px", 30.5),
     "detector.params.min_area_px: detector 'mog2' expects an integer >= 0 (px²), got 30.5"),
    ("detector-param-bool-as-string", lambda c: _set(c, "detector.params.detect_shadows", "no"),
     "detector.params.detect_shadows: detector 'mog2' expects true or false"),
    ("detector-detect-string", lambda c: _set(c, "detector.detect", "maybe"), "detector.detect"),
    ("detector-train-frames", lambda c: _set(c, "detector.train", {"frames": "9:3"}),
     "detector.train.frames"),
    ("detector-train-seed", lambda c: _set(c, "detector.train", {"seed": -1}),
     "detector.train.seed"),
    ("detector-unknown-key", lambda c: _set(c, "detector.trian", {}), "detector.trian"),
    ("associator-param-typo", lambda c: _set(c, "associator.params.min_iuo", 0.1),
     "did you mean 'min_iou'"),
    ("tracks-param-typo", lambda c: _set(c, "tracks.params.min_scor", 0.1),
     "tracks.params.min_scor: unknown parameter of tracks 'births'"),
    ("observation-param-typo", lambda c: _set(c, "observation.params.size_form_box", True),
     "observation.params.size_form_box"),
    ("component-extra-key", lambda c: _set(c, "motion.sigma_px", 2.0),
     "motion: unknown keys ['sigma_px'] beside type and params"),
    ("component-params-list", lambda c: _set(c, "motion.params", [1, 2]),
     "motion.params: expected a mapping"),
    ("component-type-number", lambda c: _set(c, "motion.type", 7), "motion.type"),
    ("component-not-spec", lambda c: _set(c, "likelihood", 5), "likelihood: expected"),
    ("births-and-tracks", lambda c: _set(c, "births", {"min_score": 0.1}),
     "'tracks' or the legacy 'births', not both"),
    ("valid-region-short", lambda c: _set(c, "valid_region_m", [0, 1, 2]), "valid_region_m"),
    ("valid-region-reversed", lambda c: _set(c, "valid_region_m", [5, 1, 0, 1]),
     "valid_region_m: expected [x0, x1, y0, y1] with x0 < x1"),
    ("valid-region-words", lambda c: _set(c, "valid_region_m", ["a", 1, 0, 1]),
     "valid_region_m"),
    ("report-writer-number", lambda c: _set(c, "report", {"writer": 3}), "report"),
    ("name-not-string", lambda c: _set(c, "name", ["x"]), "name: expected a string"),
]


@pytest.mark.parametrize(("mutate", "expect"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_configuration(work, cli, mutate, expect):
    cfg = mutate(copy.deepcopy(BASE))
    bad = work.dir / "bad.yaml"
    bad.write_text(yaml.safe_dump(cfg))
    before = snapshot(work.dir)
    r = cli("run", bad, "--video", work.video, "--out", work.out, "--quiet")
    assert r.rc == 2
    line = one_line(r.err)
    assert line.startswith("pftrack run: error: config ") and str(bad) in line
    assert expect in line
    assert_untouched(before, work.dir)


@pytest.mark.parametrize(("text", "expect"), [
    ("tracker: [unclosed\n", "not valid YAML"),
    ("- a\n- b\n", "expected a mapping at the top level"),
    ("", "expected a mapping at the top level"),
    ("\x00\x01binary", "not valid YAML"),
], ids=["unclosed", "list", "empty", "binary"])
def test_unreadable_configuration(work, cli, text, expect):
    bad = work.dir / "bad.yaml"
    bad.write_text(text)
    before = snapshot(work.dir)
    r = cli("run", bad, "--video", work.video, "--out", work.out, "--quiet")
    assert r.rc == 2
    line = one_line(r.err)
    assert str(bad) in line and expect in line
    assert_untouched(before, work.dir)


def test_unknown_preset_lists_the_presets(work, cli):
    before = snapshot(work.dir)
    r = cli("run", "pets09-grond", "--video", work.video, "--out", work.out)
    assert r.rc == 2
    line = one_line(r.err)
    assert "pets09-grond: no such file and no preset" in line and "pets09-ground" in line
    assert_untouched(before, work.dir)


def test_unregistered_component_names_the_known_ones(work, cli):
    cfg = _set(copy.deepcopy(BASE), "motion.type", "random-wlak")
    bad = work.dir / "bad.yaml"
    bad.write_text(yaml.safe_dump(cfg))
    before = snapshot(work.dir)
    r = cli("run", bad, "--video", work.video, "--out", work.out, "--quiet")
    assert r.rc == 2
    line = one_line(r.err)
    assert "no motion named 'random-wlak'" in line and "random-walk" in line
    assert_untouched(before, work.dir)


def test_every_problem_reported_at_once(work, cli):
    cfg = copy.deepcopy(BASE)
    _set(cfg, "tracker.n_particles", 200.7)
    _set(cfg, "tracker.max_misses", -1)
    _set(cfg, "likelihood.params.sigam_px", 4.0)
    bad = work.dir / "bad.yaml"
    bad.write_text(yaml.safe_dump(cfg))
    r = cli("run", bad, "--video", work.video, "--out", work.out, "--quiet")
    line = one_line(r.err)
    assert r.rc == 2
    for key in ("tracker.n_particles", "tracker.max_misses", "likelihood.params.sigam_px"):
        assert key in line


@pytest.mark.parametrize("preset", ["pets09-ground", "soccer-ground", "pets09-volume",
                                    "coast-volumes"])
def test_presets_pass_the_schema(preset):
    from pftrack.workflows.pipeline import load_config

    assert load_config(preset)["name"] == preset


def test_detector_train_checks_the_configuration(work, cli):
    cfg = _set(copy.deepcopy(BASE), "detector.params.min_area_px", "big")
    bad = work.dir / "bad.yaml"
    bad.write_text(yaml.safe_dump(cfg))
    before = snapshot(work.dir)
    r = cli("detector", "train", "--config", bad, "--video", work.video, "--gt", work.gt,
            "--frames", "1:5", "--out", work.dir / "m.npz", "--quiet")
    assert r.rc == 2 and "detector.params.min_area_px" in one_line(r.err)
    assert_untouched(before, work.dir)
