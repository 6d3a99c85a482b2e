"""The configuration schema (pftrack.host.config) and its validation."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml
from pftrack.host import get_host
from pftrack.host.config import CONFIG_SCHEMA, ConfigError, Field, iter_fields, validate_config
from pftrack.workflows.pipeline import CONFIG_KEYS, TRACKER_KEYS, load_config


@pytest.fixture(scope="module")
def pets():
    return yaml.safe_load(Path(get_host().get("preset", "pets09-ground")).read_text())


def test_schema_covers_every_key_the_pipeline_reads():
    assert {f.name for f in CONFIG_SCHEMA.children} == CONFIG_KEYS
    assert {f.name for f in CONFIG_SCHEMA.child("tracker").children} == TRACKER_KEYS
    paths = dict(iter_fields())
    assert paths["tracker.n_particles"].default == 500
    assert paths["tracker.n_particles"].range == (1, None)
    assert paths["detector.train.frames"].type == "frames"
    for path, f in paths.items():
        assert isinstance(f, Field) and f.doc, path


@pytest.mark.parametrize("name", ["pets09-ground", "soccer-ground", "pets09-volume",
                                  "coast-volumes"])
def test_presets_are_valid(name):
    cfg = yaml.safe_load(Path(get_host().get("preset", name)).read_text())
    assert validate_config(cfg, source=name) is cfg


@pytest.mark.parametrize(("section", "key", "value", "expect"), [
    ("tracker", "n_particles", "many", r"tracker\.n_particles: expected an integer >= 1"),
    ("tracker", "n_particles", 200.7, r"tracker\.n_particles: .*got 200\.7"),
    ("tracker", "n_particles", True, r"tracker\.n_particles: .*got True"),
    ("tracker", "max_misses", -1, r"tracker\.max_misses: expected an integer >= 0 or null"),
    ("tracker", "ess_threshold", 1.5, r"tracker\.ess_threshold: expected a number in \[0, 1\]"),
    ("tracker", "dt", 0, r"tracker\.dt: expected a number > 0 or 'auto'"),
    ("tracker", "resampling", "sytematic", r"did you mean 'systematic'"),
    ("tracker", "init_spread", float("nan"), r"tracker\.init_spread"),
    ("tracker", "kill_out_of_view", "yes", r"tracker\.kill_out_of_view: expected true or false"),
])
def test_bad_tracker_values_name_the_key_path(pets, section, key, value, expect):
    cfg = copy.deepcopy(pets)
    cfg[section][key] = value
    with pytest.raises(ConfigError, match=r"^config x\.yaml: " + ".*" + expect) as info:
        validate_config(cfg, source="x.yaml")
    assert len(info.value.issues) == 1


def test_component_parameters_checked(pets):
    cfg = copy.deepcopy(pets)
    cfg["observation"]["params"]["heigth_m"] = 1.7
    cfg["tracks"]["params"]["confirm_hits"] = 2.5
    with pytest.raises(ConfigError) as info:
        validate_config(cfg, source="x.yaml")
    msgs = [str(i) for i in info.value.issues]
    assert msgs[0].startswith("observation.params.heigth_m: unknown parameter of observation "
                              "'camera-box'") and "did you mean 'height_m'" in msgs[0]
    assert msgs[1] == ("tracks.params.confirm_hits: tracks 'confirmed' expects an integer >= 1, "
                       "got 2.5")


def test_every_issue_reported_at_once(pets):
    cfg = copy.deepcopy(pets)
    cfg["tracker"]["n_particles"] = 0
    cfg["valid_region_m"] = [5, 1, 0, 1]
    cfg["detector"]["train"]["frames"] = "9:3"
    cfg["report"] = {"writer": 3}
    with pytest.raises(ConfigError) as info:
        validate_config(cfg, source="x.yaml")
    assert sorted(i.path for i in info.value.issues) == [
        "detector.train.frames", "report.writer", "tracker.n_particles", "valid_region_m"]


def test_load_config_validates(tmp_path, pets):
    cfg = copy.deepcopy(pets)
    cfg["tracker"]["n_particles"] = 200.7
    p = tmp_path / "c.yaml"
    p.write_text(yaml.safe_dump(cfg))
    with pytest.raises(ConfigError, match=str(p).replace(".", r"\.") + r": tracker\.n_particles"):
        load_config(str(p))
    cfg["tracker"]["n_particles"] = 200
    p.write_text(yaml.safe_dump(cfg))
    assert load_config(str(p))["tracker"]["n_particles"] == 200


def test_composite_terms_are_checked(pets):
    cfg = copy.deepcopy(pets)
    cfg["likelihood"]["params"]["terms"][1]["likelihood"]["params"]["bnis"] = 16
    cfg["likelihood"]["params"]["terms"][2]["likelihood"]["type"] = 5
    with pytest.raises(ConfigError) as info:
        validate_config(cfg, source="x.yaml")
    msgs = [str(i) for i in info.value.issues]
    assert msgs[0].startswith("likelihood.params.terms[1].likelihood.params.bnis: unknown "
                              "parameter of likelihood 'emd'") and "did you mean 'bins'" in msgs[0]
    assert msgs[1].startswith("likelihood.params.terms[2].likelihood.type: expected a registered "
                              "likelihood name")
