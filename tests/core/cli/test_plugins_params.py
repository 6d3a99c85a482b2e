"""``pftrack plugins --params``: every registered component's declared parameters counted, with
the shipped presets that use it."""

from __future__ import annotations

import json

import pytest
from pftrack.cli import main
from pftrack.cli.plugins import parameter_inventory
from pftrack.contracts.components import Group
from pftrack.host import get_host


@pytest.fixture(scope="module")
def inventory() -> dict:
    return parameter_inventory(get_host())


def test_counts_are_the_declarations(inventory):
    host = get_host()
    rows = {(r["kind"], r["name"]): r for r in inventory["components"]}
    cloud = rows[("associator", "cloud")]
    cls = host.get("associator", "cloud")
    assert cloud["parameters"] == len(cls.declared_params()) == len(cloud["names"])
    assert cloud["names"] == list(cls.declared_params())
    # a group counts once among the parameters, as its members among the leaves
    vol = rows[("tracks", "volumes")]
    params = host.get("tracks", "volumes").declared_params()
    groups = [p for p in params.values() if isinstance(p, Group)]
    assert groups and vol["parameters"] == len(params)
    assert vol["leaves"] == len(params) - len(groups) + sum(
        len(g.group.declared_params()) for g in groups)
    assert inventory["parameters"] == sum(r["parameters"] for r in inventory["components"])
    assert inventory["leaves"] == sum(r["leaves"] for r in inventory["components"])
    assert inventory["classes"] == len(inventory["components"])
    # each class once, however many names it is registered under
    assert len({r["class"] for r in inventory["components"]}) == inventory["classes"]


def test_presets_that_use_each_component(inventory):
    rows = {(r["kind"], r["name"]): r for r in inventory["components"]}
    assert rows[("associator", "cloud")]["presets"] == ["people-image"]
    assert "pets09-volume" in rows[("tracks", "volumes")]["presets"]
    # a likelihood named only inside a composite's terms counts as used
    assert rows[("likelihood", "ncc")]["presets"] == ["people-ground", "pets09-ground"]
    assert rows[("associator", "hungarian-iou")]["presets"] == []
    # no registered component takes more than 15 parameters
    assert max(r["parameters"] for r in inventory["components"]) <= 15


def test_the_command_prints_the_table_and_the_totals(capsys, inventory):
    assert main(["plugins", "--params"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:4] == ["kind", "component", "params", "leaves"]
    assert out[-1] == (f"{inventory['classes']} component classes, {inventory['parameters']} "
                       f"parameters ({inventory['leaves']} counting each group's members)")
    assert any(line.split()[:4] == ["associator", "cloud", "7", "11"] for line in out)
    assert main(["plugins", "--params", "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == inventory
