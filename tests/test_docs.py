"""The documentation in docs/: its reference tables are generated from the code and
cover every key and effect, its hand-written effect snippets are valid entries, and
.ci/run builds it with warnings as errors."""

import importlib.util
import re
import sys
import tomllib
from pathlib import Path

import pytest

from truthbench.campaign.model_file import ModelSpec
from truthbench.campaign.spec import CampaignSpec
from truthbench.effects import EFFECTS, parse_effect

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


@pytest.fixture(scope="module")
def reference():
    """The docs' Sphinx extension, imported from its file (docs/ is no package)."""
    spec = importlib.util.spec_from_file_location(
        "truthbench_reference", DOCS / "_ext" / "truthbench_reference.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("model", [CampaignSpec, ModelSpec])
def test_every_key_is_in_the_generated_reference(reference, model):
    rows = reference.settings_rows(model, "")
    text = reference.settings_rst(rows, "file")
    seen = {(r.table, r.key) for r in rows}

    def walk(cls, table):
        for key, field in cls.model_fields.items():
            if key in ("source", "ignored"):
                continue
            sub = reference._nested_model(field.annotation)
            name = f"{table}.{key}" if table else key
            if sub is None:
                assert (table, key) in seen, (table, key)
                assert f"``{key}``" in text
                continue
            # a nested table: its own keys, under its name
            walk(sub, next(r for r in rows if r.table.startswith(name)).table)

    walk(model, "")
    update = {r.key: r for r in rows if r.table == "update"}
    assert update["max_iterations"].default == "30"
    assert update["max_iterations"].type == "integer >= 1"
    assert update["band_hz"].unit == "Hz"
    assert update["method"].default == '"finite_difference"'


def test_every_effect_and_parameter_is_in_the_generated_table(reference):
    text = reference.effects_rst()
    for name, cls in EFFECTS.items():
        assert f"* - ``{name}``" in text, name
        for p in cls.params:
            assert f"``{p.name}``" in text, (name, p.name)
    diagnosable = reference.diagnosable_rst()
    for name, cls in EFFECTS.items():
        assert (f"* - ``{name}``" in diagnosable) == (cls.diagnosis is not None), name


def test_every_plant_parameter_is_in_the_generated_table(reference):
    from truthbench.plants import make_plant

    text = reference.plant_parameters_rst()
    for kind in ("free_free_beam", "hub_beam"):
        for name in make_plant(kind).parameters:
            assert f"* - ``{name}``" in text, (kind, name)


def test_the_effect_snippets_are_valid_entries_one_per_effect():
    page = (DOCS / "reference" / "effects.md").read_text()
    block = page.split("```toml\neffects = [", 1)[1].split("```", 1)[0]
    entries = tomllib.loads("effects = [" + block)["effects"]
    assert {e["name"] for e in entries} == set(EFFECTS)
    for k, entry in enumerate(entries):
        parse_effect(entry, f"effects[{k}]", "docs/reference/effects.md")


def test_the_pages_cite_the_chapter_not_the_method_notes():
    pages = [p for p in DOCS.rglob("*.md") if "_build" not in p.parts]
    for page in [*pages, ROOT / "README.md"]:
        assert not re.search(r"METHOD\b", page.read_text()), page


def test_ci_builds_the_docs_with_warnings_as_errors():
    ci = (ROOT / ".ci" / "run").read_text()
    build = next(line for line in ci.splitlines() if "sphinx" in line)
    assert "-W" in build.split() and " docs " in f" {build} "
