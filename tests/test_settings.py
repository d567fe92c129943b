"""Settings declared once (truthbench.settings), and the contract that the command line,
the campaign and model files and the Python constructors give every declared setting the
same default and the same rule."""

from __future__ import annotations

import argparse
import inspect
import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from pydantic import BaseModel, ValidationError

from truthbench.campaign.model_file import parse_model
from truthbench.campaign.spec import DiagnoseSpec, IdentifySpec, UpdateSpec, parse_campaign
from truthbench.cli import build_parser, main
from truthbench.cli._args import declared_setting
from truthbench.diagnose import DiagnoseSettings
from truthbench.errors import CampaignError
from truthbench.identify import (
    IDENTIFIERS,
    PLSCFIdentifier,
    identify_file,
    identify_frfs,
    identify_plscf,
    make_identifier,
    peak_picking,
)
from truthbench.settings import (
    Configurable,
    Setting,
    declared,
    merged,
    setting,
    settings_model,
)
from truthbench.update import (
    UPDATERS,
    IterationSettings,
    finite_difference_update,
    make_updater,
    sensitivity_update,
)

ROOT = Path(__file__).resolve().parents[1]
QUICKSTART = tomllib.loads((ROOT / "campaigns" / "quickstart.toml").read_text())

#: Where each configurable class's settings live in the files, and the functions that
#: run it (their keyword defaults must be the class's).
TABLES = {**{cls: ("update", UpdateSpec) for cls in UPDATERS.values()},
          PLSCFIdentifier: ("identify", IdentifySpec),
          DiagnoseSettings: ("diagnose", DiagnoseSpec)}
FUNCTIONS = {"finite_difference": [finite_difference_update],
             "sensitivity": [sensitivity_update],
             "plscf": [identify_plscf, identify_frfs, identify_file],
             "peak": [peak_picking, identify_frfs, identify_file],
             "diagnose": []}
REGISTERED = [*UPDATERS.values(), *IDENTIFIERS.values()]
CLASSES = [*REGISTERED, DiagnoseSettings]
DECLARED = [(cls, name, s) for cls in CLASSES for name, s in declared(cls).items()]
IDS = [f"{cls.__name__}.{name}" for cls, name, _ in DECLARED]


def _cli_actions():
    """(command, action) of every option of every command."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return [(name, a) for name, child in sub.choices.items() for a in child._actions]


def test_every_registered_class_declares_its_settings():
    assert set(FUNCTIONS) == set(UPDATERS) | set(IDENTIFIERS) | {"diagnose"}
    for cls in REGISTERED:
        assert issubclass(cls, Configurable) and declared(cls), cls
        for f in inspect.signature(cls).parameters.values():  # only settings in __init__
            assert f.kind is f.KEYWORD_ONLY and f.name in declared(cls), (cls, f.name)


@pytest.mark.parametrize(("cls", "name", "s"), DECLARED, ids=IDS)
def test_the_same_default_everywhere(cls, name, s):
    """Python constructor, keyword defaults of the functions that run the method, the
    campaign file, the model file and the command line give the declared default."""
    assert getattr(cls(), name) == s.default
    for func in FUNCTIONS[cls.name]:
        params = inspect.signature(func).parameters
        if name in params:
            assert params[name].default == s.default, (func.__name__, name)
    if cls in TABLES:
        table, model = TABLES[cls]
        assert model.model_fields[name].default == s.default
        spec = parse_campaign(QUICKSTART)
        assert getattr(getattr(spec, table), name) == s.default
        if table in ("update", "diagnose"):
            model_spec = parse_model({"plant": QUICKSTART["plant"]})
            assert getattr(getattr(model_spec, table), name) == s.default
        if table == "update":
            # the table reaches the updater: its default, or the file's value
            assert getattr(make_updater(cls.name, spec.update.model_dump()), name) == s.default
        if table == "diagnose":  # what the command passes to diagnose()
            assert getattr(DiagnoseSettings(**model_spec.diagnose.settings()), name) \
                == s.default
    for command, action in _cli_actions():
        if getattr(action, "setting", None) == f"{cls.__module__}:{cls.__name__}.{name}":
            # not given, the option is None, which the library reads as the default
            assert action.default is None, (command, action.dest)
            assert getattr(cls.from_settings({name: None}), name) == s.default


def test_every_cli_option_named_like_a_declared_setting_is_the_declared_one():
    """No command declares its own default for a setting a class declares."""
    names = {name for _, name, _ in DECLARED}
    for command, action in _cli_actions():
        target = getattr(action, "setting", None)
        if target is not None:
            assert declared_setting(target) is not None
        elif action.dest in names:
            pytest.fail(f"truthbench {command} {action.option_strings}: a declared setting "
                        f"given its own default; use cli._args.setting_option")
    flags = {a.option_strings[0]: a for c, a in _cli_actions() if c == "identify"
             and a.option_strings}
    assert flags["--max-order"].setting.endswith("PLSCFIdentifier.max_order")
    assert flags["--modes"].setting.endswith("PeakIdentifier.n_modes")
    flags = {a.option_strings[0]: a for c, a in _cli_actions() if c == "diagnose"
             and a.option_strings}
    assert flags["--max-effects"].setting.endswith("DiagnoseSettings.max_effects")


def test_the_identify_command_uses_the_declared_max_order(tmp_path, capsys):
    """End to end: without --max-order the command identifies at the declared order."""
    from truthbench.io import write_uff
    from truthbench.measure import FRFData
    from truthbench.measure.frfdata import Channel

    f = np.arange(1.0, 200.0, 0.5)
    s = 2j * np.pi * f
    w = 2 * np.pi * 60.0
    H = (1.0 / (s**2 + 2 * 0.01 * w * s + w**2))[:, None, None]
    data = FRFData("one", f, H, (Channel("y", "displacement", "z"),),
                   (Channel("u", "force", "z"),))
    path = write_uff(tmp_path / "one.uff", [data])
    assert main(["identify", str(path), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["max_order"] == PLSCFIdentifier().max_order == IdentifySpec().max_order
    np.testing.assert_allclose(report["datasets"][0]["modes"][0]["freq_hz"], 60.0, rtol=1e-4)


@pytest.mark.parametrize(("key", "value", "rule"), [
    ("tolerance", 0.0, "> 0"), ("mac_min", 1.5, "<= 1"), ("max_iterations", 0, ">= 1"),
    ("scheme", "backward", "'central', 'forward'"), ("rcond", 1.0, "< 1")])
def test_the_same_rule_from_python_and_the_campaign_file(key, value, rule):
    cls = next(c for c in UPDATERS.values() if key in declared(c))
    with pytest.raises(ValueError, match=f"{cls.__name__}: '{key}' must be .*{rule}"):
        cls(**{key: value})
    bad = {**QUICKSTART, "update": {**QUICKSTART["update"], key: value}}
    with pytest.raises(CampaignError, match=f"key 'update.{key}': expected .*{rule}; got"):
        parse_campaign(bad, "bad.toml")


def test_update_settings_reach_every_updater():
    """[update] tolerance (and every shared setting) reaches both updaters: the
    sensitivity updater used to stop at its own 1e-8."""
    spec = parse_campaign({**QUICKSTART, "update": {
        **QUICKSTART["update"], "tolerance": 1e-9, "max_step": 0.25, "mac_min": 0.7}})
    for name in UPDATERS:
        updater = make_updater(name, spec.update.model_dump())
        assert updater.tolerance == 1e-9 and updater.max_step == 0.25
    assert make_updater("sensitivity", spec.update.model_dump()).mac_min == 0.7
    assert set(declared(IterationSettings)) <= set(declared(UPDATERS["sensitivity"]))


def test_identify_max_order_reaches_the_identifier():
    spec = parse_campaign({**QUICKSTART, "identify": {"max_order": 12}})
    assert make_identifier("plscf", spec.identify.model_dump()).max_order == 12
    with pytest.raises(CampaignError, match="key 'identify.max_order': expected an integer "
                                            ">= 2 and <= 200; got 201"):
        parse_campaign({**QUICKSTART, "identify": {"max_order": 201}})


# ---------------------------------------------------------------- the declaration type


@dataclass(frozen=True, kw_only=True)
class _Example(Configurable):
    count: int = setting(3, "how many", low=1)
    rate_hz: float = setting(100.0, "a rate", unit="Hz", low=0, low_open=True)
    band_hz: tuple[float, float] | None = setting(None, "a band", kind="band", unit="Hz")
    mode: str = setting("a", "which", choices=("a", "b"))
    flag: bool = setting(True, "on or off")
    extra: dict = field(default_factory=dict)  # an ordinary field, not a setting


class _Table(BaseModel):
    model_config = {"extra": "forbid"}
    enabled: bool = True


def test_setting_checks_and_normalises():
    e = _Example(count=2, rate_hz=5, band_hz=[1, 2])
    assert e.rate_hz == 5.0 and isinstance(e.rate_hz, float) and e.band_hz == (1.0, 2.0)
    assert e.settings() == {"count": 2, "rate_hz": 5.0, "band_hz": (1.0, 2.0), "mode": "a",
                            "flag": True}
    for bad, message in [({"count": 0}, "'count' must be an integer >= 1; got 0"),
                         ({"count": 2.5}, "'count' must be an integer; got 2.5"),
                         ({"rate_hz": float("nan")}, "'rate_hz' must be a finite number"),
                         ({"band_hz": (3, 2)}, r"'band_hz' must be a band \[low, high\] in "
                                               r"Hz with 0 <= low < high"),
                         ({"mode": "c"}, "'mode' must be one of 'a', 'b'; got 'c'"),
                         ({"flag": 1}, "'flag' must be true or false; got 1")]:
        with pytest.raises(ValueError, match=f"_Example: {message}"):
            _Example(**bad)
    assert _Example.from_settings({"count": 4, "rate_hz": None, "other": 1}).count == 4
    with pytest.raises(ValueError, match="give 'kind'"):
        Setting(None, "unset without a kind")
    with pytest.raises(ValueError, match="Setting: 'default' must be an integer >= 1"):
        Setting(0, "a default outside its own rule", low=1)


def test_constraint_and_type_text():
    s = declared(_Example)
    assert s["count"].constraint_text() == ">= 1" and s["count"].type_text() == "integer"
    assert s["rate_hz"].constraint_text() == "> 0"
    assert s["mode"].constraint_text() == "one of 'a', 'b'"
    assert s["band_hz"].type_text() == "[low, high] or unset"


def test_settings_model_has_the_declared_defaults_and_rules():
    model = settings_model("ExampleTable", [_Example], base=_Table, exclude=["flag"])
    assert list(model.model_fields) == ["enabled", "count", "rate_hz", "band_hz", "mode"]
    table = model()
    assert (table.count, table.rate_hz, table.band_hz, table.mode) == (3, 100.0, None, "a")
    assert model.model_fields["rate_hz"].json_schema_extra == {"unit": "Hz",
                                                               "constraint": "> 0"}
    assert model.model_fields["count"].description == "how many"
    for bad in ({"count": 0}, {"rate_hz": 0.0}, {"rate_hz": float("inf")}, {"mode": "c"},
                {"band_hz": [5.0, 1.0]}, {"flag": False}, {"other": 1}):
        with pytest.raises(ValidationError):
            model(**bad)
    assert model(band_hz=[1, 2]).band_hz == (1.0, 2.0)


def test_two_classes_may_share_a_setting_only_as_one_declaration():
    @dataclass(frozen=True, kw_only=True)
    class Other(Configurable):
        count: int = setting(4, "how many", low=1)

    @dataclass(frozen=True, kw_only=True)
    class Same(Configurable):
        count: int = declared(_Example)["count"].default

    with pytest.raises(TypeError, match="'count' is declared differently by _Example"):
        merged([_Example, Other])
    assert list(merged([_Example, Same])) == list(declared(_Example))  # Same declares none
