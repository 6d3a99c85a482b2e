"""The documentation's generated pages (``docs/_ext/pftrack_docs.py``): the configuration
reference covers every key the code accepts, with the code's defaults; the gallery executes every
notebook on the slices its test uses."""

from __future__ import annotations

import inspect
import re
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "docs" / "_ext"))

import pftrack_docs  # noqa: E402


@pytest.fixture(scope="module")
def page() -> str:
    return pftrack_docs.config_reference()


def _rows(page: str, section: str) -> dict[str, list[str]]:
    """``{key: cells}`` of the table rows between heading ``section`` and the next heading of
    the same or a higher level."""
    level = section.split(" ")[0]
    start = page.index(section + "\n")
    end = re.compile(rf"^#{{1,{len(level)}}} ", re.M).search(page, start + len(section))
    out = {}
    for line in page[start:end.start() if end else None].splitlines():
        m = re.match(r"^\| `([^`]+)` \|(.*)\|$", line)
        if m:
            out[m.group(1)] = [c.strip() for c in re.split(r"(?<!\\)\|", m.group(2))]
    return out


def test_the_configuration_reference_names_the_plugins_of_components_only(page):
    """The repository's benchmarks (plugin ``bench``, ``pftrack_bench``) register no
    component: the configuration reference, a product page, does not list them."""
    line = next(ln for ln in page.splitlines() if "this build's:" in ln)
    assert "`basic`, `coast`, `colour`, `network`, `world`" in line
    assert "`bench`" not in line and "pftrack_bench" not in page


def test_every_schema_key_is_on_the_page_with_its_default_and_unit(page):
    from pftrack.host.config import CONFIG_SCHEMA, iter_fields
    from pftrack.workflows.pipeline import CONFIG_KEYS, TRACKER_KEYS

    top = _rows(page, "## Top-level keys")
    assert set(top) == set(CONFIG_KEYS) == {f.name for f in CONFIG_SCHEMA.children}
    tracker = _rows(page, "## `tracker:` keys")
    assert set(tracker) == {f"tracker.{k}" for k in TRACKER_KEYS}
    # cells: type, default, unit, description (with what is allowed)
    assert tracker["tracker.n_particles"][:2] == ["int", "`500`"]
    assert tracker["tracker.n_particles"][3].endswith("Allowed: [1, ∞).")
    assert tracker["tracker.dt"][1:3] == ['`"auto"`', "motion model's time unit (s, or frames)"]
    assert "Allowed: one of `systematic`, `stratified`" in tracker["tracker.resampling"][3]
    assert tracker["tracker.max_misses"][0] == "int or null"
    assert top["state"][3].endswith("Allowed: one of `world`, `image`.")
    assert "a registered {ref}`motion <config-kind-motion>` component" in top["motion"][3]
    detector = _rows(page, "## `detector:` keys")
    assert detector["detector.train.seed"][:2] == ["int", "`0`"]
    # every key of the schema, at any depth, has its row
    rows = {k for line in page.splitlines() for k in re.findall(r"^\| `([\w.]+)` \|", line)}
    paths = {p for p, _ in iter_fields(CONFIG_SCHEMA)}
    assert paths <= rows, paths - rows


def test_every_component_parameter_has_a_row_with_its_default(page):
    from pftrack.host import get_host

    host = get_host()
    n = 0
    for kind in pftrack_docs.COMPONENT_KINDS:
        for name in host.names(kind):
            cls = host.get(kind, name)
            label = f"(config-{kind}-{name})=\n#### `{name}`"
            assert label in page
            rows = _rows(page[page.index(label):], f"#### `{name}`")
            params = {p.name: p.default for p in inspect.signature(cls.__init__).parameters
                      .values() if p.name != "self" and p.kind not in (p.VAR_POSITIONAL,
                                                                      p.VAR_KEYWORD)}
            assert set(params) <= set(rows), (kind, name, set(params) - set(rows))
            for pname, default in params.items():
                n += 1
                if default is inspect.Parameter.empty:
                    assert rows[pname][1] == "required"
                elif isinstance(default, (int, float)) and not isinstance(default, bool):
                    assert rows[pname][1] == f"`{default!r}`", (name, pname, rows[pname])
    assert n > 150  # the built-in plugins declare over 200 parameters


def test_report_writers_are_listed(page):
    from pftrack.host import get_host

    rows = _rows(page, "### Report writers `report: {writer: NAME}`")
    assert set(rows) == set(get_host().names("report")) and "tracks" in rows
    assert rows["tracks"][0] == "`basic`"


def test_param_declarations_give_type_doc_and_unit():
    from pftrack.host import get_host
    from pftrack_coast.volumes import VolumeEntry, VolumeFootprint

    rows = {r["name"]: r for r in pftrack_docs.component_params(
        get_host().get("tracks", "volumes"))}
    entry = {r["name"]: r for r in pftrack_docs.component_params(VolumeEntry)}
    footprint = {r["name"]: r for r in pftrack_docs.component_params(VolumeFootprint)}
    assert entry["particles"]["default"] == 50 and entry["particles"]["type"] == "int"
    assert entry["particles"]["doc"].startswith("N_m:")
    assert rows["object_size_m"]["unit"] == "m"
    # what a declaration allows is shown as the schema's keys show theirs
    assert rows["v_pi"]["allowed"] == "(0, 1)"
    assert entry["particles"]["allowed"] == "[1, ∞)"
    assert footprint["heading_from"]["allowed"] == "one of `footprint`, `top`"
    assert rows["object_size_m"]["allowed"] == "(0, ∞); length 3"


def test_component_tables_show_what_each_declared_parameter_allows(page):
    rows = _rows(page[page.index("(config-tracks-volumes)="):], "#### `volumes`")
    assert rows["v_pi"][3].endswith("Allowed: (0, 1).")
    assert rows["merge.speed_m"][3].endswith("Allowed: (0, ∞).")
    assert rows["entry.particles"][3].endswith("Allowed: [1, ∞).")
    # a parameter group: its row, then one row per key with its dotted name
    rows = _rows(page[page.index("(config-detector-svm)="):], "#### `svm`")
    assert rows["train"][:3] == ["mapping", "—", "—"] and "`train.C`" in rows["train"][3]
    assert rows["train.C"][:3] == ["float", "`0.01`", "1"]
    assert rows["train.C"][3].endswith("Allowed: (0, ∞).")
    rows = _rows(page[page.index("(config-detector-eigenspace)="):], "#### `eigenspace`")
    assert rows["recalibration.gap_s"][:3] == ["float \\| None", "`null`", "s"]
    rows = _rows(page[page.index("(config-associator-hungarian-iou)="):],
                 "#### `hungarian-iou`")
    assert rows["metric"][3].endswith("Allowed: one of `iou`, `distance`.")


def test_every_preset_key_is_listed_with_its_value(page):
    from pftrack.host import get_host

    host = get_host()
    assert host.names("preset")
    for name in host.names("preset"):
        cfg = yaml.safe_load(Path(host.get("preset", name)).read_text())
        rows = _rows(page, f"### `{name}`")
        leaves = dict(pftrack_docs._leaves(cfg))
        leaves.pop("name"), leaves.pop("description", None)
        assert set(leaves) <= set(rows), (name, set(leaves) - set(rows))
        for key, value in leaves.items():
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                assert rows[key][0] == f"`{value!r}`", (name, key, rows[key])
    # a value that differs from the component's default is shown beside it
    rows = _rows(page, "### `pets09-ground`")
    assert rows["tracker.n_particles"][0] == "`200`"
    assert rows["observation.params.height_m"][1] == "`1.75`"
    # the detector's training settings, under detector.train.params, with the group's defaults
    assert rows["detector.train.params.C"] == ["`0.003`", "`0.01`", "1"]


def test_parameters_section_and_units():
    doc = """Summary.

    Parameters
    ----------
    width_px, height_px : float
        Box size.
    sigma : float
        Noise, metres.
    bins : int

    Attributes
    ----------
    scores_ : ndarray
        Not a parameter.
    """
    got = pftrack_docs.parameters_section(doc)
    assert got == {"width_px": ("float", "Box size."), "height_px": ("float", "Box size."),
                   "sigma": ("float", "Noise, metres."), "bins": ("int", "")}
    assert pftrack_docs.unit_of("width_px", "Box size.") == "px"
    assert pftrack_docs.unit_of("sigma", "Noise, metres.") == "m"
    assert pftrack_docs.unit_of("speed", "Speed in m/s.") == "m/s"
    assert pftrack_docs.unit_of("bins", "Bins per channel.") == ""


def test_docstring_markdown_sections_literals_and_roles():
    md = pftrack_docs.docstring_markdown("pftrack.geometry.volumes", "World frame conventions")
    assert md.startswith("## World frame conventions\n")
    assert "## Volumes YAML" in md and "```yaml\nvolumes:\n  - name: near" in md
    assert "{func}`~pftrack.geometry.volumes.load_volumes`" in md and ":func:" not in md


def test_gallery_runs_every_notebook_as_its_test_does():
    names = sorted(p.name for p in (ROOT / "notebooks").glob("*.ipynb"))
    assert sorted(pftrack_docs.NOTEBOOKS) == names
    for name, (env, where) in pftrack_docs.NOTEBOOKS.items():
        tests = [p.read_text() for p in (ROOT / "tests" / "notebooks").glob("test_notebooks_*.py")
                 if name in p.read_text()]
        assert len(tests) == 1, name
        setenv = dict(re.findall(r'setenv\("(PFTRACK_NB_\w+)", "([^"]*)"\)', tests[0]))
        assert env == setenv, name
        # the tests that use conftest's execute_notebook run in the repository root
        assert where == ("root" if "execute_notebook(" in tests[0] else "tmp"), name


def test_api_pages_cover_the_public_modules(tmp_path):
    mods = pftrack_docs.write_api_pages(tmp_path)
    assert "pftrack.workflows.pipeline" in mods and "pftrack_coast.volumes" in mods
    assert not [m for m in mods if m.startswith("pftrack.cli.") or "._" in m]
    text = (tmp_path / "pftrack.engine.tracker.md").read_text()
    assert ".. automodule:: pftrack.engine.tracker" in text
    # the benchmarks are not the product's API: pages of their own, under their own heading
    assert not [m for m in mods if m.startswith("pftrack_bench")]
    bench = pftrack_docs.write_api_pages(tmp_path / "bench", bases=("benchmarks",))
    assert "pftrack_bench.protocol" in bench and "pftrack_bench.pets09_ground" in bench
    assert all(m.startswith("pftrack_bench") for m in bench)
    index = (ROOT / "docs" / "api" / "index.md").read_text()
    assert "_modules/pftrack_*" in index and "_benchmarks/*" in index
    heading = index.index("## Benchmarks (not part of the product)")
    assert heading > index.index("_modules/pftrack_*")


def test_image_plane_example_builds_without_a_camera_and_tracks_in_pixels(tmp_path):
    from pftrack.io.data import data_dir
    from pftrack.workflows.pipeline import build_engine, load_config, run_pipeline

    example = ROOT / "docs" / "examples" / "image-plane.yaml"
    cfg = load_config(example)  # validated against the schema
    assert cfg["state"] == "image"
    engine = build_engine(cfg, camera=None)
    assert type(engine.observation).__name__ == "ImageBoxObservation"
    pets = data_dir() / "pets09"
    if not (pets / "vtest.avi").is_file():
        pytest.skip("PETS 2009 data not found (set PFTRACK_DATA)")
    res = run_pipeline(example, video=pets / "vtest.avi", frames="201:260", out_dir=tmp_path,
                       report=False, progress=False)
    rows = res.rows
    assert len(rows) > 0 and set(rows[:, 0].astype(int)) <= set(range(201, 261))
    assert (rows[:, 7:10] == -1).all()  # no camera: no world position


def test_cli_reference_has_every_command_and_its_options():
    from pftrack.cli import build_parser

    page = pftrack_docs.cli_reference()
    commands = pftrack_docs._subparsers(build_parser())
    assert {"run", "eval", "calib", "batch", "bench"} <= set(commands)
    for name, parser in commands.items():
        assert f"(cli-pftrack-{name})=\n## `pftrack {name}`" in page
        for sub in pftrack_docs._subparsers(parser):
            assert f"### `pftrack {name} {sub}`" in page
    run = page[page.index("## `pftrack run`"):]
    assert "--detector-model MODEL" in run and "--camera CAMERA" in run


def test_thumbnails_are_each_notebooks_first_picture(tmp_path, monkeypatch):
    import base64

    nbformat = pytest.importorskip("nbformat")
    first, second = b"\x89PNG first", b"\x89PNG second"
    monkeypatch.setattr(pftrack_docs, "NOTEBOOKS", {"a.ipynb": ({}, "root"),
                                                    "b.ipynb": ({}, "root")})
    a = nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell("# A"),
                                        nbformat.v4.new_code_cell("x", outputs=[
        nbformat.v4.new_output("display_data", data={
            "image/png": base64.b64encode(data).decode(), "text/plain": "<Figure>"})
        for data in (first, second)])])
    nbformat.write(a, tmp_path / "a.ipynb")
    nbformat.write(nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("1")]),
                   tmp_path / "b.ipynb")
    thumbs = pftrack_docs.write_thumbnails(tmp_path)
    assert thumbs["a.ipynb"].read_bytes() == first
    blank = thumbs["b.ipynb"].read_bytes()
    assert blank.startswith(b"\x89PNG") and len(blank) < 100


def _all_component_rows():
    """``(kind, name, row)`` of every parameter of every component the built-in plugins
    register (a third-party plugin installed beside them may state no units)."""
    from pftrack.host import get_host

    host = get_host()
    builtin = {n for n, info in host.plugins.items() if info.builtin}
    assert {"basic", "coast", "colour", "world"} <= builtin
    for kind in pftrack_docs.COMPONENT_KINDS:
        for name in host.names(kind):
            if host.registry.get(kind, name).plugin not in builtin:
                continue
            for r in pftrack_docs.component_params(host.get(kind, name)):
                yield kind, name, r


def test_every_numeric_component_parameter_states_its_unit(page):
    numeric, missing, wrong = 0, [], []
    for kind, name, r in _all_component_rows():
        if r["numeric"]:
            numeric += 1
            if r["unit_source"] != "stated":  # a guess from the name or the text is not enough
                missing.append(f"{kind}.{name}.{r['name']}")
        elif r["unit"]:
            wrong.append(f"{kind}.{name}.{r['name']} ({r['unit']})")  # a name or flag
        assert "Unit:" not in r["doc"], (name, r["name"])  # the sentence moves to the column
        label = f"(config-{kind}-{name})=\n#### `{name}`"
        cells = _rows(page[page.index(label):], f"#### `{name}`")[r["name"]]
        assert cells[2] == (r["unit"] or "—"), (name, r["name"], cells)
    assert not missing, f"numeric parameters without a stated unit: {missing}"
    assert not wrong, f"non-numeric parameters with a unit: {wrong}"
    assert numeric > 170  # 237 parameters, about 190 of them numbers
    # the legend says what the units and the dash mean
    legend = page[page.index("## Components"):page.index("(config-kind-observation)=")]
    for word in ("`px`", "`1`", "`count`", "`state units (m or px)`", "`—`: not a quantity"):
        assert word in legend


def test_units_read_from_the_code_are_the_right_ones():
    rows = {f"{k}.{n}.{r['name']}": r for k, n, r in _all_component_rows()}
    expected = {
        "detector.mog2.min_area_px": "px²",  # an area, whatever the suffix says
        "detector.mog2.history": "frames",
        "likelihood.composite.exclusion_m": "state units (m or px)",  # state units, not metres
        "associator.greedy-score.sigma_det": "track heights",
        "likelihood.detection.sigma": "detection heights",
        "tracks.confirmed.confirm_hits": "count",
        "tracks.confirmed.confirm_window": "frames",
        "motion.constant-velocity-3d.position_noise": "state units per √dt",
        "scene.soccer.fps": "frames/s",
        "scene.walkers.noise_sigma": "grey levels",
        "likelihood.bhattacharyya.bins": "count",
        "likelihood.ncc.min_valid": "1",
    }
    assert {k: rows[k]["unit"] for k in expected} == expected
    # seeds and state indices are numbers but not quantities: stated "none", shown as a dash
    for key in ("scene.walkers.seed", "observation.camera-box.position_dims"):
        assert rows[key]["unit_source"] == "stated" and rows[key]["unit"] == ""


def test_parameters_that_had_no_description_have_one(page):
    rows = {f"{k}.{n}.{r['name']}": r for k, n, r in _all_component_rows()}
    for key in ("likelihood.emd.colour_space", "associator.greedy-iou.metric",
                "associator.greedy-iou.min_iou", "scene.soccer.volume"):
        assert len(rows[key]["doc"].split()) >= 5, (key, rows[key]["doc"])
    assert rows["associator.greedy-iou.min_iou"]["unit"] == "1"
    assert "`emd`" in page and "| `colour_space` | str | `\"bgr\"` | — | Colour space" in page


def test_preset_keys_show_their_unit(page):
    from pftrack.host import get_host

    host = get_host()
    rows = _rows(page, "### `pets09-ground`")
    assert rows["tracker.n_particles"][2] == "particles per target"  # a schema key's unit
    assert rows["observation.params.height_m"][2] == "m"  # a component parameter's
    n = 0
    for name in host.names("preset"):
        cfg = yaml.safe_load(Path(host.get("preset", name)).read_text())
        rows = _rows(page, f"### `{name}`")
        for key in ("observation", "motion", "likelihood", "detector", "associator", "tracks"):
            spec = cfg.get(key)
            if not isinstance(spec, dict) or "type" not in spec:
                continue
            comp = {r["name"]: r for r in pftrack_docs.component_params(
                host.get(key, spec["type"]))}
            for pname, value in (spec.get("params") or {}).items():
                if f"{key}.params.{pname}" not in rows:  # a list of mappings: its leaves
                    assert isinstance(value, (list, dict)), (name, key, pname)
                    continue
                n += 1
                assert rows[f"{key}.params.{pname}"][2] == (comp[pname]["unit"] or "—"), \
                    (name, key, pname)
    assert n > 50


def test_param_unit_reaches_the_docstring_and_the_reference():
    from pftrack.contracts.components import Likelihood, Param

    class _Units(Likelihood):
        """A test likelihood.

        {params}
        """

        sigma: float = Param(2.0, "Noise standard deviation.", unit="px")
        seed: int = Param(0, "Random seed.", unit="none")
        tag: str = Param("a", "A name.")
        ratio: float = Param(0.5, "A fraction. Unit: 1.")  # the docstring route works here too

        def log_likelihood(self, boxes_xywh_px, target):
            return np.zeros(len(boxes_xywh_px))

    assert "    Noise standard deviation. Unit: px.\n" in _Units.__doc__
    assert Param(1.0, "x", unit="m").unit == "m" and Param(1.0, "x").unit is None
    rows = {r["name"]: r for r in pftrack_docs.component_params(_Units)}
    assert (rows["sigma"]["unit"], rows["sigma"]["unit_source"]) == ("px", "stated")
    assert rows["sigma"]["doc"] == "Noise standard deviation."
    assert (rows["seed"]["unit"], rows["seed"]["unit_source"], rows["seed"]["numeric"]) == \
        ("", "stated", True)
    assert (rows["tag"]["unit"], rows["tag"]["unit_source"], rows["tag"]["numeric"]) == \
        ("", "", False)
    assert (rows["ratio"]["unit"], rows["ratio"]["doc"]) == ("1", "A fraction.")
    assert pftrack_docs.stated_unit("Speed of a walker. Unit: m/s.") == ("m/s",
                                                                         "Speed of a walker.")
    assert pftrack_docs.stated_unit("Speed of a walker, m/s.") == (None,
                                                                   "Speed of a walker, m/s.")
    assert pftrack_docs.is_numeric("(int, int)", None)
    assert pftrack_docs.is_numeric("", (0.1, 0.2)) and not pftrack_docs.is_numeric("bool", True)
    assert not pftrack_docs.is_numeric('{"cuboid", "point"}', "point")
    assert pftrack_docs.is_numeric("(fx0, fy0, fx1, fy1) floats or None", None)


def test_config_reference_split_keeps_every_section_once(page):
    """The reference's three pages hold every section of the whole page exactly once, each
    page's headings start at level 2 (under its title) and never skip a level."""
    parts = pftrack_docs.split_config_reference(page)
    assert set(parts) == {"keys", "components", "presets"}
    labels = re.findall(r"^\(([\w-]+)\)=$", page, re.M)
    assert len(labels) > 50
    for label in labels:
        assert sum(f"({label})=\n" in text for text in parts.values()) == 1, label
    assert "(config-tracker)=" in parts["keys"]
    assert "(config-kind-likelihood)=" in parts["components"]
    assert "(preset-pets09-ground)=" in parts["presets"]
    for name, text in parts.items():
        outside = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)  # YAML comments aside
        levels = [len(h) for h in re.findall(r"^(#+) ", outside, re.M)]
        assert levels and levels[0] == 2 and min(levels) == 2, name
        assert all(b - a <= 1 for a, b in zip(levels, levels[1:])), name
    # the rows are the whole page's: a component's table moved, unchanged
    assert _rows(page, "#### `volumes`") == _rows(parts["components"], "### `volumes`")


def test_results_page_renders_the_latest_file_of_each_benchmark(tmp_path):
    import json

    import pftrack_results

    def write(name, date, mota):
        doc = {"benchmark": "pets09-ground", "args": ["--no-ablation"],
               "commit": {"sha": "a" * 40, "dirty": False}, "date": date,
               "machine": {"logical_cores": 2, "processor": "x86_64",
                           "load_1min_before": 0.5, "load_1min_after": 1.0},
               "protocol": {"chosen_on": "frames 1-400", "reported_on": "frames 401-795"},
               "result": {"MOTA": mota, "IDF1": 0.8, "goals": {"MOTA": True}}}
        (tmp_path / name).write_text(json.dumps(doc))

    write("pets09-ground-1.json", "2026-01-01T00:00:00Z", 0.25)
    write("pets09-ground-2.json", "2026-02-01T00:00:00Z", 0.75)
    text = pftrack_results.results_page(tmp_path)
    assert "| MOTA (IoU 0.5) | 0.75 |" in text and "0.25" not in text
    assert "`pftrack bench pets09-ground --json --no-ablation`" in text
    assert "**chosen on**: frames 1-400" in text and "pets09-ground-2.json" in text
    (tmp_path / "bad.json").write_text(json.dumps({"benchmark": "x"}))
    with pytest.raises(ValueError, match="bad.json has no 'commit'"):
        pftrack_results.load_results(tmp_path)


def test_a_figure_in_prose_is_read_from_the_latest_result(tmp_path):
    """``{result}`NAME:KEY[:FORMAT]`` reads the latest file of a benchmark (or of one of its
    recorded variants); a missing benchmark or key is an error naming what is missing."""
    import json

    import pftrack_results

    def write(file, date, variant, rows):
        doc = {"benchmark": "colour", "args": [], "commit": {"sha": "b" * 40},
               "date": date, "machine": {"logical_cores": 2}, "protocol": {},
               "result": {"rows": rows, "speed": {"ratio": 3.25}}}
        if variant:
            doc["variant"] = variant
        (tmp_path / file).write_text(json.dumps(doc))

    rows = [{"likelihood": "a", "samples": 500, "fps": 1234.5},
            {"likelihood": "b", "samples": 500, "fps": 99.0}]
    write("colour-1.json", "2026-01-01T00:00:00Z", None, rows)
    write("colour-2.json", "2026-02-01T00:00:00Z", None, rows[:1])
    write("colour@fast-1.json", "2026-03-01T00:00:00Z", "fast", [{"likelihood": "a",
                                                                   "samples": 500, "fps": 7.0}])
    fig = pftrack_results.figure
    table = {"t": [{"method": "a (C_d=5, tuned)", "v": 1.5}, {"method": "a", "v": 2}]}
    assert pftrack_results.value_at(table, "t[method=a (C_d=5, tuned)].v") == 1.5
    assert pftrack_results.value_at(table, "t[method=a].v") == 2
    assert pftrack_results.value_at({"t": [{"x": [4, 5]}]}, "t[0].x[1]") == 5
    assert pftrack_results.value_at({"t": [1]}, "t[3]") is None
    assert fig("colour:speed.ratio", tmp_path) == "3.25"
    assert fig("colour:rows[likelihood=a,samples=500].fps:,.0f", tmp_path) == "1,234"
    assert fig("colour@fast:rows[likelihood=a].fps:.1f", tmp_path) == "7.0"
    with pytest.raises(ValueError, match="no number at 'rows\\[likelihood=b\\].fps'"):
        fig("colour:rows[likelihood=b].fps", tmp_path)  # only in the older file
    with pytest.raises(ValueError, match="no result of benchmark 'soccer'"):
        fig("soccer:MOTA", tmp_path)
    with pytest.raises(ValueError, match="NAME:KEY"):
        fig("colour", tmp_path)
    page = pftrack_results.results_page(tmp_path)
    assert "(results-colour-fast)=" in page and "## `colour@fast`" in page


def test_committed_results_come_from_a_recorded_run():
    """Every committed result file was written by the recorder: a known benchmark, a commit,
    a date, a machine and the protocol its benchmark declares (``PROTOCOL`` in its module)."""
    import pftrack_results
    from pftrack_bench import protocols

    declared = protocols()
    docs = pftrack_results.load_results()
    assert docs, "results/ holds no result file"
    for name, doc in docs.items():
        assert re.fullmatch(r"[0-9a-f]{40}", doc["commit"]["sha"]), name
        assert doc["protocol"] == declared[doc["benchmark"]], name
        assert doc["machine"]["logical_cores"] >= 1
        # the recorder timed the run, or it wrapped a file the benchmark wrote (and says so)
        assert doc["wall_s"] > 0 if not doc.get("wrapped") else doc["wall_s"] is None
        for key, _ in pftrack_results.HEADLINE.get(doc["benchmark"], []):
            value = pftrack_results.value_at(doc["result"], key)
            assert isinstance(value, (int, float)) and not isinstance(value, bool), (name, key)


def test_a_recorded_protocol_is_the_one_the_result_carries():
    """The recorder takes the protocol from the benchmark's JSON (its declared words, the
    details a benchmark adds there itself left in the result), and refuses a result without
    one."""
    import pftrack_results

    words = {"data": "d", "chosen_on": "frames 1-10", "reported_on": "frames 11-20"}
    result = {"MOTA": 0.5, "protocol": {**words, "videos": {"v": [1, 10]}}}
    assert pftrack_results.protocol_of("x", result) == words
    with pytest.raises(ValueError, match="benchmark 'x' carries no protocol"):
        pftrack_results.protocol_of("x", {"MOTA": 0.5})
    with pytest.raises(ValueError, match="carries no protocol"):
        pftrack_results.protocol_of("x", {"protocol": {"data": "d"}})


def test_readme_headlines_are_the_latest_results():
    """Each headline figure of the README is followed by ``<!-- NAME:KEY[:FORMAT] -->`` and
    equals that figure of the latest committed result (the README is read on GitHub, where
    the docs' ``{result}`` role does not run)."""
    import pftrack_results

    text = (ROOT / "README.md").read_text()
    cited = re.findall(r"([-\d.,%]+)(?:\*\*)?(?:\s+[a-z ]+?)?(?:\*\*)?<!-- ([^>]+?) -->", text)
    assert len(cited) >= 5, cited
    for shown, spec in cited:
        assert pftrack_results.figure(spec) == shown, (spec, shown)
