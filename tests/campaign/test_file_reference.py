"""The campaign and model-file reference is read from the schemas: every key a shipped
file uses is in it, the declared settings carry their declarations, and every key
outside [diagnose] says what it is."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import truthbench.campaign as campaign
from truthbench.campaign.spec import parse_campaign
from truthbench.settings import declared
from truthbench.update import UPDATERS

ROOT = Path(__file__).resolve().parents[2]
CAMPAIGNS = sorted((ROOT / "campaigns").glob("*.toml"))


def _keys(data, path=""):
    """(table, key) of every key of a parsed TOML file, arrays of tables included;
    tables of named entries (stations, channels) as ``<label>``."""
    named = {"plant.stations", "diagnose.channels"}
    out = set()
    for k, v in data.items():
        if path:  # the top-level keys are the tables
            out.add((path, k))
        sub = f"{path}.{k}" if path else k
        if isinstance(v, dict) and sub not in named and sub not in (
                "plant.parameters", "truth.relative", "diagnose.map", "diagnose.study.strength",
                "diagnose.input_rms_n"):
            out |= _keys(v, sub)
        elif isinstance(v, dict) and sub in named:
            for entry in v.values():
                if isinstance(entry, dict):
                    out |= _keys(entry, f"{sub}.<label>")
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v) \
                and not sub.endswith("effects"):
            for item in v:
                out |= _keys(item, sub)
    return out


@pytest.mark.parametrize("path", CAMPAIGNS, ids=[p.stem for p in CAMPAIGNS])
def test_every_key_of_the_shipped_campaigns_is_in_the_reference(path):
    rows = {(r.table, r.key) for r in campaign.reference()}
    used = _keys(tomllib.loads(path.read_text()))
    assert used - rows == set()


def test_the_rows_hold_the_declarations_and_every_key_is_described():
    rows = campaign.reference()
    by_key = {(r.table, r.key): r for r in rows}
    for cls in UPDATERS.values():
        for name, s in declared(cls).items():
            r = by_key[("update", name)]
            assert (r.default, r.unit, r.constraint, r.description) == (
                s.default, s.unit, s.constraint_text(), s.description)
    assert by_key[("identify", "max_order")].default == 40
    assert by_key[("tests", "fs_hz")].unit == "Hz" and by_key[("tests", "fs_hz")].required
    assert by_key[("tests", "record_s")].unit == "s"
    assert by_key[("tests", "level_rms")].unit == "N or N m"
    assert by_key[("tests", "averages")].constraint == ">= 1"
    assert by_key[("tests.actuators", "direction")].header == "[[tests.actuators]]"
    assert by_key[("plant.stations.<label>", "x_m")].header == "[plant.stations.<label>]"
    # [diagnose] is described by the diagnosis's own declarations (not yet all)
    silent = [(r.table, r.key) for r in rows if not r.description
              and not r.table.startswith("diagnose")]
    assert silent == []
    assert len({(r.table, r.key) for r in rows}) == len(rows)


def test_the_defaults_are_those_of_a_parsed_campaign():
    """A key left out of a file takes the default the reference states (the tables the
    quickstart leaves out)."""
    spec = parse_campaign(tomllib.loads((ROOT / "campaigns" / "quickstart.toml").read_text()))
    checked = 0
    for r in campaign.reference():
        if r.table in ("identify", "uncertainty", "output", "diagnose", "diagnose.study"):
            table = spec
            for part in r.table.split("."):
                table = getattr(table, part)
            if r.type != "table":
                assert getattr(table, r.key) == r.default, (r.table, r.key)
                checked += 1
    assert checked > 20


def test_the_model_file_reference_has_only_its_tables():
    tables = {r.table.split(".")[0] for r in campaign.reference("model")}
    assert tables == {"campaign", "plant", "update", "diagnose"}
    with pytest.raises(ValueError, match="'kind' must be 'campaign' or 'model'"):
        campaign.reference("toml")
