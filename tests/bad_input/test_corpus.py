"""The bad-input corpus: every case is answered by one named error, exit code 2, before
any work.

Each case is a command line run through :func:`truthbench.cli.main` in a fresh folder
holding the files the case needs. For every case the test asserts

* exit code 2 (argparse's own, or ``main``'s answer to a bad input);
* one message on stderr naming what is wrong (``expect``: the key, option or file)
  and no traceback;
* nothing written: the case's folder tree (which also holds the default output folder
  ``results/`` and every place a campaign name such as ``../../x`` could point to) is
  the same before and after, and ``results/`` does not exist.

The cases are generated from tables: campaign files (each a mutation of a small valid
campaign, written as TOML), data files (LVM, UFF, HDF5 mutated from valid ones) and
command-line arguments of every command. A few are also run as real processes
(``python -m truthbench``) to see the stderr a person sees. The count is in the documentation
(docs/reference/bad_input.md).
"""

from __future__ import annotations

import copy
import json
import math
import os
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

from truthbench.cli import main

ROOT = Path(__file__).resolve().parents[2]
QUICKSTART = ROOT / "campaigns" / "quickstart.toml"
SHIPPED_LVM = ROOT / "src" / "truthbench" / "data" / "ladisk_beam_impact" / "acceleration.lvm"
DIR = "{dir}"  # placeholder for the case's folder in argv


# ----------------------------------------------------------------------------- TOML writer


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def to_toml(data: dict) -> str:
    """TOML text of a campaign dict (tables, arrays of tables, inline values)."""
    lines: list[str] = []

    def table(prefix: str, d: dict):
        scalars = {k: v for k, v in d.items() if not isinstance(v, dict)
                   and not (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)
                            and prefix == "")}
        if prefix:
            lines.append(f"[{prefix}]")
        for k, v in scalars.items():
            lines.append(f"{json.dumps(k)} = {_toml_value(v)}")
        for k, v in d.items():
            if isinstance(v, dict):
                table(f"{prefix}.{k}" if prefix else k, v)
            elif k not in scalars:
                for item in v:
                    lines.append(f"[[{k}]]")
                    for kk, vv in item.items():
                        lines.append(f"{json.dumps(kk)} = {_toml_value(vv)}")

    table("", data)
    return "\n".join(lines) + "\n"


def base_campaign() -> dict:
    """The quickstart with short records (a valid campaign that runs in seconds)."""
    d = tomllib.loads(QUICKSTART.read_text())
    d["plant"]["n_elements"] = 8
    for t in d["tests"]:
        t.update(record_s=4.0, averages=4)
    return d


def test_the_writer_round_trips_the_base_campaign():
    d = base_campaign()
    assert tomllib.loads(to_toml(d)) == d
    odd = {"a": {"x": math.inf, "y": [1.0, -math.inf], "s": "../x"}}
    back = tomllib.loads(to_toml(odd))
    assert back["a"]["x"] == math.inf and back["a"]["s"] == "../x"


# ----------------------------------------------------------------------------- the cases


@dataclass(frozen=True)
class Case:
    """One bad input: the command line, the files it needs, what the message names."""

    id: str
    argv: tuple[str, ...]
    files: tuple[tuple[str, bytes | None], ...] = ()  # None: a folder
    expect: str = ""


def _set(d: dict, path: str, value):
    """``d`` with the value at ``path`` ("tests[0].fs_hz", "campaign.name") set; the
    value ``DELETE`` removes the key."""
    d = copy.deepcopy(d)
    node, keys = d, []
    for part in path.split("."):
        name, _, idx = part.partition("[")
        keys.append(name)
        if idx:
            keys.append(int(idx.rstrip("]")))
    for k in keys[:-1]:
        node = node[k]
    if value is DELETE:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return d


DELETE = object()
INF, NAN = math.inf, math.nan


def campaign_case(id_, mutate, expect, command=("run",)):
    """A case: the base campaign changed by ``mutate`` (a dict of path -> value, or a
    function of the dict), run with ``command``."""
    d = base_campaign()
    if callable(mutate):
        d = mutate(d)
    else:
        for path, value in mutate.items():
            d = _set(d, path, value)
    text = to_toml(d).encode()
    return Case(f"campaign-{id_}", (*command, f"{DIR}/c.toml"), (("c.toml", text),), expect)


def _dup_test_names(d):
    d["tests"][1]["name"] = d["tests"][0]["name"]
    return d


def _dup_sensor(d):
    d["sensors"].append(dict(d["sensors"][0]))
    return d


def _dup_actuator(d):
    d["tests"][0]["actuators"] = d["tests"][0]["actuators"] * 2
    return d


def _effect(**entry):
    def mutate(d):
        d.setdefault("truth", {})["effects"] = [entry]
        return d
    return mutate


CAMPAIGN_CASES = [
    # the campaign name is a name, never a path
    campaign_case("name-parent-path", {"campaign.name": "../../x"}, "campaign.name"),
    campaign_case("name-absolute", {"campaign.name": "/tmp/truthbench_bad_input_abs"},
                  "campaign.name"),
    campaign_case("name-empty", {"campaign.name": ""}, "campaign.name"),
    campaign_case("name-dot", {"campaign.name": "."}, "campaign.name"),
    campaign_case("name-dotdot", {"campaign.name": ".."}, "campaign.name"),
    campaign_case("name-slash", {"campaign.name": "a/b"}, "campaign.name"),
    campaign_case("name-backslash", {"campaign.name": "a\\b"}, "campaign.name"),
    campaign_case("name-space", {"campaign.name": "my campaign"}, "campaign.name"),
    campaign_case("name-trailing-dot", {"campaign.name": "name."}, "campaign.name"),
    campaign_case("name-too-long", {"campaign.name": "x" * 65}, "campaign.name"),
    campaign_case("name-not-text", {"campaign.name": 123}, "campaign.name"),
    campaign_case("name-missing", {"campaign.name": DELETE}, "campaign.name"),
    # test names become HDF5 groups and files
    campaign_case("test-name-slash", {"tests[0].name": "a/b"}, "tests[0].name"),
    campaign_case("test-name-parent", {"tests[0].name": "../x"}, "tests[0].name"),
    campaign_case("test-name-dot", {"tests[0].name": "."}, "tests[0].name"),
    campaign_case("test-name-dotdot", {"tests[0].name": ".."}, "tests[0].name"),
    campaign_case("test-name-empty", {"tests[0].name": ""}, "tests[0].name"),
    campaign_case("test-name-spaces", {"tests[0].name": " lead"}, "tests[0].name"),
    campaign_case("test-name-newline", {"tests[0].name": "a\nb"}, "tests[0].name"),
    campaign_case("test-name-duplicate", _dup_test_names, "tests"),
    # finite numbers everywhere
    campaign_case("fs-inf", {"tests[0].fs_hz": INF}, "tests[0].fs_hz"),
    campaign_case("record-inf", {"tests[0].record_s": INF}, "tests[0].record_s"),
    campaign_case("record-nan", {"tests[0].record_s": NAN}, "tests[0].record_s"),
    campaign_case("level-inf", {"tests[0].level_rms": INF}, "tests[0].level_rms"),
    campaign_case("noise-inf", {"tests[0].noise_fraction": INF}, "tests[0].noise_fraction"),
    campaign_case("band-inf", {"tests[0].band_hz": [2.0, INF]}, "tests[0].band_hz"),
    campaign_case("band-nan", {"tests[0].band_hz": [NAN, 400.0]}, "tests[0].band_hz"),
    campaign_case("time-h-inf", {"tests[0].time_h": INF}, "tests[0].time_h"),
    campaign_case("E-inf", {"plant.parameters.E_pa": INF}, "plant.parameters.E_pa"),
    campaign_case("E-nan", {"plant.parameters.E_pa": NAN}, "plant.parameters.E_pa"),
    campaign_case("rho-minus-inf", {"plant.parameters.rho_kg_m3": -INF},
                  "plant.parameters.rho_kg_m3"),
    campaign_case("truth-inf", {"truth.relative.E_pa": INF}, "truth.relative.E_pa"),
    campaign_case("tolerance-inf", {"update.tolerance": INF}, "update.tolerance"),
    campaign_case("step-nan", {"update.relative_step": NAN}, "update.relative_step"),
    campaign_case("c-zeta-inf", {"update.c_zeta": INF}, "update.c_zeta"),
    campaign_case("update-band-inf", {"update.band_hz": [10.0, INF]}, "update.band_hz"),
    campaign_case("k-sigma-inf", {"uncertainty": {"k_sigma": INF}}, "uncertainty.k_sigma"),
    campaign_case("node-tolerance-inf", {"plant.node_tolerance_m": INF},
                  "plant.node_tolerance_m"),
    campaign_case("station-inf", {"plant.stations": {"gauge": INF}}, "plant.stations"),
    campaign_case("sensor-x-nan", {"sensors[0]": {"x_m": NAN, "direction": "z"}},
                  "sensors[0].x_m"),
    campaign_case("suspension-inf", {"plant.suspension_x_m": [INF, 1.4]},
                  "plant.suspension_x_m"),
    campaign_case("effect-mean-inf", _effect(name="added_mass", station="mid",
                                             parameters={"mass_kg": INF}), "mass_kg"),
    campaign_case("effect-std-nan", _effect(name="material", parameters={
        "E_rel": {"mean": 0.0, "std": NAN}}), "E_rel"),
    campaign_case("record-huge-integer", {"tests[0].record_s": 10**400}, "tests[0].record_s"),
    # out of range
    campaign_case("elements-zero", {"plant.n_elements": 0}, "plant.n_elements"),
    campaign_case("elements-negative", {"plant.n_elements": -5}, "plant.n_elements"),
    campaign_case("elements-2000", {"plant.n_elements": 2000}, "plant.n_elements"),
    campaign_case("trials-zero", {"campaign.trials": 0}, "campaign.trials"),
    campaign_case("seed-negative", {"campaign.seed": -1}, "campaign.seed"),
    campaign_case("averages-zero", {"tests[0].averages": 0}, "tests[0].averages"),
    campaign_case("averages-too-many", {"tests[0].averages": 1000}, "tests[0].averages"),
    campaign_case("oversample-zero", {"tests[0].oversample": 0}, "tests[0].oversample"),
    campaign_case("oversample-100", {"tests[0].oversample": 100}, "tests[0].oversample"),
    campaign_case("max-order-1", {"identify": {"max_order": 1}}, "identify.max_order"),
    campaign_case("max-order-500", {"identify": {"max_order": 500}}, "identify.max_order"),
    campaign_case("level-zero", {"tests[0].level_rms": 0.0}, "tests[0].level_rms"),
    campaign_case("level-negative", {"tests[0].level_rms": -1.0}, "tests[0].level_rms"),
    campaign_case("fs-zero", {"tests[0].fs_hz": 0.0}, "tests[0].fs_hz"),
    campaign_case("record-zero", {"tests[0].record_s": 0.0}, "tests[0].record_s"),
    campaign_case("band-reversed", {"tests[0].band_hz": [400.0, 2.0]}, "tests[0].band_hz"),
    campaign_case("band-above-nyquist", {"tests[0].band_hz": [2.0, 900.0]},
                  "tests[0].band_hz"),
    campaign_case("noise-negative", {"tests[0].noise_fraction": -0.1},
                  "tests[0].noise_fraction"),
    campaign_case("noise-1e6", {"tests[0].noise_fraction": 1e6}, "tests[0].noise_fraction"),
    campaign_case("truth-below-minus-one", {"truth.relative.E_pa": -1.5},
                  "truth.relative.E_pa"),
    campaign_case("update-band-reversed", {"update.band_hz": [400.0, 10.0]},
                  "update.band_hz"),
    campaign_case("update-band-outside", {"update.band_hz": [600.0, 700.0]},
                  "update.band_hz"),
    campaign_case("update-band-above-tests", {"update.band_hz": [10.0, 450.0]},
                  "key 'update.band_hz': expected a band inside the tests' excited band "
                  "2-400 Hz"),
    campaign_case("level-1e308", {"tests[0].level_rms": 1e308},
                  "key 'tests[0].level_rms': expected a level from 1e-06 to 1e+06 N"),
    campaign_case("uncertainty-band-reversed",
                  {"uncertainty": {"band_hz": [400.0, 10.0]}}, "uncertainty.band_hz"),
    # sizes that cannot work
    campaign_case("record-1e6-s", {"tests[0].record_s": 1e6}, "tests[0].record_s"),
    campaign_case("fs-1e9-hz", {"tests[0].fs_hz": 1e9}, "tests[0].record_s"),
    # structure and references
    campaign_case("no-campaign-table", {"campaign": DELETE}, "campaign"),
    campaign_case("no-tests", {"tests": DELETE}, "tests"),
    campaign_case("empty-tests", {"tests": []}, "tests"),
    campaign_case("empty-sensors", {"sensors": []}, "sensors"),
    campaign_case("unknown-top-key", {"campain": {"name": "x"}}, "campain"),
    campaign_case("unknown-test-key", {"tests[0].levle_rms": 2.0}, "tests[0].levle_rms"),
    campaign_case("averages-text", {"tests[0].averages": "many"}, "tests[0].averages"),
    campaign_case("fs-text", {"tests[0].fs_hz": "fast"}, "tests[0].fs_hz"),
    campaign_case("plant-type", {"plant.type": "bridge"}, "plant.type"),
    campaign_case("section", {"plant.section": "i_beam"}, "plant.section"),
    campaign_case("material", {"plant.material": "unobtainium"}, "plant.material"),
    campaign_case("supports", {"plant.supports": "sand"}, "plant.supports"),
    campaign_case("supports-hub-beam", {"plant.type": "hub_beam", "plant.supports": "foam"},
                  "plant.supports"),
    campaign_case("sensor-station", {"sensors[0].station": "nowhere"}, "sensors[0].station"),
    campaign_case("actuator-station", {"tests[0].actuators": [{"station": "nowhere",
                                                                "direction": "z"}]},
                  "tests[0].actuators[0].station"),
    campaign_case("sensor-duplicated", _dup_sensor, "sensors[4]"),
    campaign_case("actuator-duplicated", _dup_actuator, "tests[0].actuators[1]"),
    campaign_case("direction", {"sensors[0].direction": "w"}, "sensors[0].direction"),
    campaign_case("quantity", {"sensors[0].quantity": "force"}, "sensors[0].quantity"),
    campaign_case("station-and-x", {"sensors[0]": {"station": "mid", "x_m": 0.9,
                                                   "direction": "z"}}, "sensors[0]"),
    campaign_case("x-off-beam", {"sensors[0]": {"x_m": 5.0, "direction": "z"}},
                  "sensors[0].x_m"),
    campaign_case("updater", {"update.method": "magic"}, "update.method"),
    campaign_case("update-parameter", {"update.parameters": ["E_pa", "colour"]},
                  "update.parameters"),
    campaign_case("holdout", {"uncertainty": {"holdout": ["nosuch"]}}, "uncertainty.holdout"),
    campaign_case("effect-name", _effect(name="gremlin"), "gremlin"),
    campaign_case("effect-station", _effect(name="added_mass", station="nowhere",
                                            parameters={"mass_kg": 0.1}), "nowhere"),
    campaign_case("refine-1000", _effect(name="discretization", refine=1000), "refine"),
    campaign_case("refine-zero", _effect(name="discretization", refine=0), "refine"),
    campaign_case("refine-text", _effect(name="discretization", refine="fine"), "refine"),
    campaign_case("refine-fraction", _effect(name="discretization", refine=2.5), "refine"),
    campaign_case("boundary-support", _effect(name="boundary", support=7),
                  "truth.effects[0].support"),
    campaign_case("plant-parameter", {"plant.parameters.colour": 1.0},
                  "plant.parameters.colour"),
    campaign_case("truth-parameter", {"truth.relative.colour": 0.1}, "truth.relative.colour"),
    # the same checks reach every command that reads a campaign
    campaign_case("modes-name-path", {"campaign.name": "../../x"}, "campaign.name",
                  command=("modes",)),
    campaign_case("simulate-fs-inf", {"tests[0].fs_hz": INF}, "tests[0].fs_hz",
                  command=("simulate", "--out", f"{DIR}/out.h5")),
    campaign_case("place-sensors-record-inf", {"tests[0].record_s": INF},
                  "tests[0].record_s", command=("place-sensors",)),
]


def _hdf5_bytes() -> bytes:
    """A small valid HDF5 file that is not a campaign (a results file given by mistake)."""
    import io

    import h5py

    buf = io.BytesIO()
    with h5py.File(buf, "w") as f:
        f.create_dataset("x", data=[1.0, 2.0])
    return buf.getvalue()


def _camp_file(name, data, expect, command=("run",)):
    return Case(f"file-{name}", (*command, f"{DIR}/c.toml"), (("c.toml", data),), expect)


FILE_CASES = [
    _camp_file("latin1", b'[campaign]\nname = "caf\xe9"\n', "not UTF-8"),
    _camp_file("utf16", '[campaign]\nname = "x"\n'.encode("utf-16"), "not UTF-8"),
    _camp_file("hdf5", None, "HDF5"),  # filled in below
    _camp_file("png", b"\x89PNG\r\n\x1a\n" + bytes(32), "PNG"),
    _camp_file("zip", b"PK\x03\x04" + bytes(32), "zip"),
    _camp_file("empty", b"", "required"),
    _camp_file("not-toml", b"[campaign\nname = \n", "not valid TOML"),
    _camp_file("json", json.dumps(base_campaign()).encode(), "not valid TOML"),
    Case("file-directory", ("run", f"{DIR}/c.toml"), (("c.toml", None),), "directory"),
    Case("file-missing", ("run", f"{DIR}/none.toml"), (), "not found"),
    Case("file-results-h5", ("run", f"{DIR}/results.h5"), (("results.h5", None),), "HDF5"),
]
FILE_CASES = [Case(c.id, c.argv, (("c.toml", _hdf5_bytes()),), c.expect)
              if c.id == "file-hdf5" else c for c in FILE_CASES]
FILE_CASES = [Case(c.id, c.argv, (("results.h5", _hdf5_bytes()),), c.expect)
              if c.id == "file-results-h5" else c for c in FILE_CASES]


# ----------------------------------------------------------------------------- data files


def _lvm_lines() -> list[str]:
    return SHIPPED_LVM.read_bytes().decode("utf-8").split("\n")


def _lvm(mutate) -> bytes:
    lines = _lvm_lines()
    first = next(i for i, t in enumerate(lines) if t.startswith("X_Value")) + 1
    return mutate(lines, first).encode("utf-8") if callable(mutate) else mutate


def _nan_force(lines, first):
    fields = lines[first + 100].split("\t")
    fields[2] = "NaN"
    lines[first + 100] = "\t".join(fields)
    return "\n".join(lines)


def _nan_acc(lines, first):
    fields = lines[first + 100].split("\t")
    fields[1] = "NaN"
    lines[first + 100] = "\t".join(fields)
    return "\n".join(lines)


def _inf_force(lines, first):
    fields = lines[first + 36].split("\t")
    fields[2] = "Inf"
    lines[first + 36] = "\t".join(fields)
    return "\n".join(lines)


def _random_bytes(lines, first):
    text = "\n".join(lines)
    mid = len(text) // 2
    return text[:mid] + "\x00\x13\x7f garbage \x01\x02" + text[mid:]


def _random_lines(lines, first):
    import random

    rng = random.Random(7)
    junk = "".join(chr(rng.randrange(256)) for _ in range(400))  # newlines included
    text = "\n".join(lines)
    mid = len(text) // 3
    return text[:mid] + junk + text[mid:]


def _cut_rows(lines, first):
    return "\n".join(lines[: first + 1000]) + "\n"


def _text_in_row(lines, first):
    lines[first + 5] = "\tabc\t0,1"
    return "\n".join(lines)


def _no_header_end(lines, first):
    return "\n".join(t for t in lines if not t.startswith("***End_of_Header***"))


def _force_only(lines, first):
    out = []
    for t in lines:
        f = t.split("\t")
        if len(f) >= 3 and (t.startswith("\t") or t.startswith("X_Value")):
            f = [f[0], f[2]] + f[3:]
        elif t.startswith(("Samples", "Y_Unit_Label", "X_Dimension", "X0", "Delta_X", "Date",
                           "Time")) and len(f) >= 4:
            f = [f[0], f[2]] + f[3:]
        elif t.startswith("Channels"):
            f = ["Channels", "1"] + f[2:]
        out.append("\t".join(f))
    return "\n".join(out)


def _unit(lines, first):
    return "\n".join(t.replace("\tg\tNewtons", "\tfurlong\tNewtons") for t in lines)


def _all_nan_force(lines, first):
    out = list(lines)
    for k in range(first, len(out)):
        f = out[k].split("\t")
        if len(f) >= 3:
            f[2] = "NaN"
            out[k] = "\t".join(f)
    return "\n".join(out)


def _data_case(id_, name, content, expect, command=("identify",), extra=()):
    return Case(f"data-{id_}", (*command, f"{DIR}/{name}", *extra), ((name, content),), expect)


def _uff_text() -> bytes:
    """A valid UFF (151, 164, 2411, 58) of two FRFs, written by truthbench."""
    import numpy as np

    from truthbench.io import write_uff
    from truthbench.measure import Channel, FRFData

    f = np.arange(0, 201) * 0.5
    w = 2 * np.pi * f
    h = 1.0 / ((2 * np.pi * 20) ** 2 - w**2 + 2j * 0.02 * (2 * np.pi * 20) * w)
    H = np.stack([h, 0.5 * h], axis=1)[:, :, None] * (-(w**2))[:, None, None]
    outs = (Channel("a", "acceleration", direction="z", point=1, coordinates_m=(0, 0, 0)),
            Channel("b", "acceleration", direction="z", point=2, coordinates_m=(1, 0, 0)))
    ins = (Channel("f", "force", direction="z", point=1, coordinates_m=(0, 0, 0)),)
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "x.uff"
        write_uff(path, (FRFData("t", f, H, outs, ins, band_hz=(1.0, 90.0)),))
        return path.read_bytes()


def _uff_cut_at_boundary() -> bytes:
    """Our file ending cleanly after its first FRF set (the second is missing)."""
    import re

    blocks = re.findall(r"    -1\n.*?\n    -1\n", _uff_text().decode(), flags=re.S)
    assert len(blocks) == 3 + 2  # 151, 164, 2411, two FRF sets
    return "".join(blocks[:4]).encode()


def _uff_no_frf() -> bytes:
    """Our file cut after its geometry: no FRF set at all."""
    import re

    blocks = re.findall(r"    -1\n.*?\n    -1\n", _uff_text().decode(), flags=re.S)
    return "".join(blocks[:3]).encode()


def _uff_bad_value(text_value: str) -> bytes:
    """Our file with one FRF value replaced (fixed-width fields)."""
    lines = _uff_text().decode().split("\n")
    i = next(k for k, t in enumerate(lines) if t.strip() == "58") + 13
    lines[i] = text_value.rjust(20) + lines[i][20:]
    return "\n".join(lines).encode()


def _uff_cut_mid() -> bytes:
    raw = _uff_text()
    return raw[: len(raw) * 2 // 3]


def _coh_uff(*, lines: float = 1.0, value: float = 0.9, load_case: int = 1) -> bytes:
    """Coherence sets only (function type 6, written with pyuff) of the two FRF pairs of
    :func:`_uff_text` (points 1 and 2 / point 1, +z, load case 1), as acquisition
    systems export them."""
    import tempfile

    import numpy as np
    import pyuff

    f = np.arange(0, 201) * 0.5 * lines
    sets = [{"type": 58, "func_type": 6, "rsp_node": node, "rsp_dir": 3, "ref_node": 1,
             "ref_dir": 3, "load_case_id": load_case, "abscissa_spacing": 1,
             "orddenom_spec_data_type": 0, "x": f, "data": np.full(f.size, value)}
            for node in (2, 1)]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "c.uff"
        pyuff.UFF(str(path)).write_sets(sets, mode="add")
        return path.read_bytes()


def _model(levels: str | None = None) -> bytes:
    """The steel tube as a model file, with ``[diagnose] input_rms_n = { levels }``."""
    text = (ROOT / "campaigns" / "steel_tube.toml").read_text()
    if levels is not None:
        text += f"\n[diagnose]\ninput_rms_n = {{ {levels} }}\n"
    return text.encode()


def _diagnose_case(id_, data, files, expect, levels=None):
    argv = ("diagnose", *(f"{DIR}/{name}" for name in data), "--model", f"{DIR}/m.toml")
    return Case(f"data-diagnose-{id_}", argv, (*files, ("m.toml", _model(levels))), expect)


FRF_OK = ("x.uff", _uff_text())
DIAGNOSE_CASES = [
    _diagnose_case("coherence-other-lines", ["x.uff", "c.uff"],
                   [FRF_OK, ("c.uff", _coh_uff(lines=2.0))], "expected the same lines"),
    _diagnose_case("coherence-of-no-frf", ["x.uff", "c.uff"],
                   [FRF_OK, ("c.uff", _coh_uff(load_case=2))], "pairs with no FRF set"),
    _diagnose_case("coherence-twice", ["c.uff", "x.uff", "d.uff"],
                   [FRF_OK, ("c.uff", _coh_uff()), ("d.uff", _coh_uff())],
                   "a second coherence set of this FRF pair"),
    _diagnose_case("coherence-above-1", ["x.uff", "c.uff"],
                   [FRF_OK, ("c.uff", _coh_uff(value=1.5))], "outside [0, 1]"),
    _diagnose_case("coherence-alone", ["c.uff"], [("c.uff", _coh_uff())],
                   "holds only coherence sets"),
    _diagnose_case("file-twice", ["x.uff", "x.uff"], [FRF_OK], "given twice"),
    _diagnose_case("levels-unknown-name", ["x.uff"], [FRF_OK], "'nope' names no data set",
                   levels='"nope" = 1.0'),
    _diagnose_case("levels-per-input", ["x.uff"], [FRF_OK], "expected one number for every "
                   "input or one per input", levels='"t" = [1.0, 2.0]'),
    _diagnose_case("levels-negative", ["x.uff"], [FRF_OK], "key 'diagnose.input_rms_n'",
                   levels='"t" = -1.0'),
    _data_case("uff-coherence-only", "c.uff", _coh_uff(), "holds only coherence sets"),
]

DATA_CASES = [
    _data_case("lvm-nan-force", "x.lvm", _lvm(_nan_force), "non-finite value"),
    _data_case("lvm-nan-acc", "x.lvm", _lvm(_nan_acc), "Acceleration (Trigger)"),
    _data_case("lvm-inf-force", "x.lvm", _lvm(_inf_force), "Force (Trigger)"),
    _data_case("lvm-all-nan-force", "x.lvm", _lvm(_all_nan_force), "non-finite value"),
    _data_case("lvm-random-bytes", "x.lvm", _lvm(_random_bytes), "binary data"),
    _data_case("lvm-random-bytes-with-newlines", "x.lvm", _lvm(_random_lines), "binary data"),
    _data_case("lvm-cut-rows", "x.lvm", _lvm(_cut_rows), "the file ends early"),
    _data_case("lvm-text-in-row", "x.lvm", _lvm(_text_in_row), "non-numeric"),
    _data_case("lvm-no-header-end", "x.lvm", _lvm(_no_header_end), "End_of_Header"),
    _data_case("lvm-force-only", "x.lvm", _lvm(_force_only), "response channel"),
    _data_case("lvm-unknown-unit", "x.lvm", _lvm(_unit), "furlong"),
    _data_case("lvm-empty", "x.lvm", b"", "empty"),
    _data_case("lvm-not-lvm", "x.lvm", b"time,acc\n0,1\n", "LabVIEW"),
    _data_case("lvm-binary", "x.lvm", bytes(range(256)) * 4, "x.lvm"),
    Case("data-lvm-directory", ("identify", f"{DIR}/x.lvm"), (("x.lvm", None),),
         "directory"),
    _data_case("uff-cut-at-boundary", "x.uff", _uff_cut_at_boundary(), "missing pairs"),
    _data_case("uff-no-frf", "x.uff", _uff_no_frf(), "no dataset 58"),
    _data_case("uff-cut-mid", "x.uff", _uff_cut_mid(), "x.uff"),
    _data_case("uff-garbage", "x.uff", b"    -1\n    58\nnot a dataset\n", "x.uff"),
    _data_case("uff-text-value", "x.uff", _uff_bad_value("abcdefgh"), "corrupt"),
    _data_case("uff-nan-value", "x.uff", _uff_bad_value("nan"), "non-finite value"),
    _data_case("uff-inf-value", "x.uff", _uff_bad_value("inf"), "non-finite value"),
    _data_case("uff-empty", "x.uff", b"", "x.uff"),
    _data_case("uff-binary", "x.uff", bytes(range(256)) * 8, "x.uff"),
    Case("data-uff-directory", ("identify", f"{DIR}/x.uff"), (("x.uff", None),),
         "directory"),
    _data_case("h5-text", "x.h5", b"this is not HDF5\n", "x.h5"),
    _data_case("h5-empty", "x.h5", b"", "x.h5"),
    _data_case("h5-foreign", "x.h5", _hdf5_bytes(), "x.h5"),
    Case("data-h5-directory", ("identify", f"{DIR}/x.h5"), (("x.h5", None),), "directory"),
    _data_case("unknown-extension", "x.csv", b"f,H\n1,2\n", ".csv"),
    Case("data-missing", ("identify", f"{DIR}/none.uff"), (), "none.uff"),
    _data_case("export-h5-text", "x.h5", b"not HDF5", "x.h5", command=("export",),
               extra=("--out", f"{DIR}/o.uff")),
    _data_case("export-foreign-h5", "x.h5", _hdf5_bytes(), "x.h5", command=("export",),
               extra=("--out", f"{DIR}/o.uff")),
    _data_case("export-lvm-nan", "x.lvm", _lvm(_nan_force), "non-finite", command=("export",),
               extra=("--out", f"{DIR}/o.uff")),
]


# ----------------------------------------------------------------------------- arguments


def _camp() -> tuple[tuple[str, bytes], ...]:
    return (("c.toml", to_toml(base_campaign()).encode()),)


def _arg_case(id_, argv, expect, files=None):
    return Case(f"arg-{id_}", tuple(argv), _camp() if files is None else files, expect)


C = f"{DIR}/c.toml"
LVM_OK = (("r.lvm", SHIPPED_LVM.read_bytes()),)
ARG_CASES = [
    _arg_case("run-trials-0", ["run", C, "--trials", "0"], "--trials"),
    _arg_case("run-trials-neg", ["run", C, "--trials", "-3"], "--trials"),
    _arg_case("run-trials-text", ["run", C, "--trials", "many"], "--trials"),
    _arg_case("run-jobs-0", ["run", C, "--jobs", "0"], "--jobs"),
    _arg_case("run-jobs-text", ["run", C, "--jobs", "two"], "--jobs"),
    _arg_case("run-seed-neg", ["run", C, "--seed", "-1"], "--seed"),
    _arg_case("run-seed-float", ["run", C, "--seed", "1.5"], "--seed"),
    _arg_case("run-abbreviated", ["run", C, "--trial", "2"], "--trial"),
    _arg_case("run-no-campaign", ["run"], "campaign"),
    _arg_case("unknown-command", ["frobnicate"], "frobnicate"),
    _arg_case("simulate-trial-neg", ["simulate", C, "--out", f"{DIR}/o.h5", "--trial", "-1"],
              "--trial"),
    _arg_case("simulate-test-neg", ["simulate", C, "--out", f"{DIR}/o.h5", "--test", "-1"],
              "--test"),
    _arg_case("simulate-test-99", ["simulate", C, "--out", f"{DIR}/o.h5", "--test", "99"],
              "--test"),
    _arg_case("simulate-seed-neg", ["simulate", C, "--out", f"{DIR}/o.h5", "--seed", "-2"],
              "--seed"),
    _arg_case("simulate-out-uff", ["simulate", C, "--out", f"{DIR}/o.uff"], "export"),
    _arg_case("simulate-out-none", ["simulate", C, "--out", f"{DIR}/o"], "--out"),
    _arg_case("simulate-out-dir", ["simulate", C, "--out", f"{DIR}/d.h5"], "directory",
              files=_camp() + (("d.h5", None),)),
    _arg_case("simulate-out-under-file", ["simulate", C, "--out", f"{DIR}/c.toml/o.h5"],
              "c.toml"),
    _arg_case("simulate-no-out", ["simulate", C], "--out"),
    _arg_case("inject-not-number", ["simulate", C, "--out", f"{DIR}/o.h5", "--inject",
                                    "time_delay:delay_s=abc"], "must be a number"),
    _arg_case("inject-inf", ["simulate", C, "--out", f"{DIR}/o.h5", "--inject",
                             "time_delay:delay_s=inf"], "delay_s"),
    _arg_case("inject-unknown-effect", ["simulate", C, "--out", f"{DIR}/o.h5", "--inject",
                                        "gremlin:x=1"], "gremlin"),
    _arg_case("inject-unknown-parameter", ["simulate", C, "--out", f"{DIR}/o.h5", "--inject",
                                           "time_delay:delta=2"], "delta"),
    _arg_case("inject-no-equals", ["simulate", C, "--out", f"{DIR}/o.h5", "--inject",
                                   "time_delay:0.002"], "param=value"),
    _arg_case("inject-station", ["simulate", C, "--out", f"{DIR}/o.h5", "--inject",
                                 "joint:station=nowhere,stiffness_loss=0.3"], "nowhere"),
    _arg_case("inject-refine-huge", ["simulate", C, "--out", f"{DIR}/o.h5", "--inject",
                                     "discretization:refine=1000"], "refine"),
    _arg_case("inject-missing-option", ["simulate", C, "--out", f"{DIR}/o.h5", "--inject",
                                        "added_mass:mass_kg=0.1"], "station"),
    _arg_case("identify-order-0", ["identify", f"{DIR}/r.lvm", "--max-order", "0"],
              "--max-order", LVM_OK),
    _arg_case("identify-order-1", ["identify", f"{DIR}/r.lvm", "--max-order", "1"],
              "--max-order", LVM_OK),
    _arg_case("identify-order-huge", ["identify", f"{DIR}/r.lvm", "--max-order", "100000"],
              "--max-order", LVM_OK),
    _arg_case("identify-band-reversed", ["identify", f"{DIR}/r.lvm", "--band", "500", "100"],
              "--band", LVM_OK),
    _arg_case("identify-band-nan", ["identify", f"{DIR}/r.lvm", "--band", "nan", "100"],
              "--band", LVM_OK),
    _arg_case("identify-band-negative", ["identify", f"{DIR}/r.lvm", "--band", "-1", "100"],
              "--band", LVM_OK),
    _arg_case("identify-band-outside", ["identify", f"{DIR}/r.lvm", "--band", "30000",
                                        "40000"], "outside the data", LVM_OK),
    _arg_case("identify-band-one-value", ["identify", f"{DIR}/r.lvm", "--band", "100"],
              "--band", LVM_OK),
    _arg_case("identify-modes-0", ["identify", f"{DIR}/r.lvm", "--modes", "0"], "--modes",
              LVM_OK),
    _arg_case("identify-method", ["identify", f"{DIR}/r.lvm", "--method", "magic"],
              "--method", LVM_OK),
    _arg_case("export-out-h5", ["export", f"{DIR}/r.lvm", "--out", f"{DIR}/o.h5"], "--out",
              LVM_OK),
    _arg_case("export-out-dir", ["export", f"{DIR}/r.lvm", "--out", f"{DIR}/d.uff"],
              "directory", LVM_OK + (("d.uff", None),)),
    _arg_case("export-trial-neg", ["export", f"{DIR}/r.lvm", "--out", f"{DIR}/o.uff",
                                   "--trial", "-1"], "--trial", LVM_OK),
    _arg_case("export-no-out", ["export", f"{DIR}/r.lvm"], "--out", LVM_OK),
    _arg_case("study-elements-0", ["study", "discretization", "--max-elements", "0", "--out",
                                   f"{DIR}/s"], "--max-elements"),
    _arg_case("study-elements-huge", ["study", "discretization", "--max-elements", "5000",
                                      "--out", f"{DIR}/s"], "--max-elements"),
    _arg_case("study-elements-text", ["study", "discretization", "--max-elements", "ten",
                                      "--out", f"{DIR}/s"], "--max-elements"),
    _arg_case("study-out-file", ["study", "discretization", "--out", f"{DIR}/c.toml"],
              "--out"),
    _arg_case("study-seeds-0", ["study", "damping-smoothing", "--seeds", "0", "--out",
                                f"{DIR}/s"], "--seeds"),
    _arg_case("study-seeds-huge", ["study", "damping-smoothing", "--seeds", "10000000",
                                   "--out", f"{DIR}/s"], "--seeds"),
    _arg_case("study-seed-neg", ["study", "damping-smoothing", "--seed", "-1", "--out",
                                 f"{DIR}/s"], "--seed"),
    _arg_case("study-unknown", ["study", "everything"], "everything"),
    _arg_case("place-count-0", ["place-sensors", C, "--count", "0"], "--count"),
    _arg_case("place-count-huge", ["place-sensors", C, "--count", "100000"], "--count"),
    _arg_case("place-trials-0", ["place-sensors", C, "--score", "--trials", "0"], "--trials"),
    _arg_case("place-jobs-0", ["place-sensors", C, "--score", "--jobs", "0"], "--jobs"),
    _arg_case("modes-count-0", ["modes", C, "--count", "0"], "--count"),
    _arg_case("modes-count-neg", ["modes", C, "--count", "-2"], "--count"),
    _arg_case("modes-count-text", ["modes", C, "--count", "all"], "--count"),
]

CASES = CAMPAIGN_CASES + FILE_CASES + DATA_CASES + DIAGNOSE_CASES + ARG_CASES


# ----------------------------------------------------------------------------- the checks


def _tree(root: Path) -> dict[str, tuple[int, int] | None]:
    """Every file (size, mtime) and folder (None) under ``root``."""
    out: dict[str, tuple[int, int] | None] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for d in dirnames:
            out[os.path.relpath(os.path.join(dirpath, d), root)] = None
        for f in filenames:
            st = os.stat(os.path.join(dirpath, f))
            out[os.path.relpath(os.path.join(dirpath, f), root)] = (st.st_size, st.st_mtime_ns)
    return out


def _prepare(case: Case, tmp_path: Path) -> tuple[Path, list[str]]:
    # the case runs two folders down, so a name like "../../x" would still land inside
    # tmp_path, where the snapshot sees it
    where = tmp_path / "a" / "b" / "case"
    where.mkdir(parents=True)
    for name, content in case.files:
        p = where / name
        if content is None:
            p.mkdir()
        else:
            p.write_bytes(content)
    return where, [a.replace(DIR, str(where)) for a in case.argv]


def call(argv: list[str]) -> int:
    """``main(argv)``'s exit code (argparse exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_is_a_named_error_with_nothing_written(case, tmp_path, monkeypatch, capsys):
    where, argv = _prepare(case, tmp_path)
    monkeypatch.chdir(where)
    before = _tree(tmp_path)
    code = call(argv)
    err = capsys.readouterr().err
    assert code == 2, f"exit code {code}; stderr: {err}"
    assert "Traceback" not in err
    assert f"truthbench {argv[0]}: error: " in err or err.startswith("usage: truthbench"), err
    assert case.expect in err, f"{case.expect!r} not in {err!r}"
    assert _tree(tmp_path) == before, "something was written"
    assert not (where / "results").exists()
    assert not Path("/tmp/truthbench_bad_input_abs").exists()


def test_the_corpus_is_large_and_every_case_distinct():
    ids = [c.id for c in CASES]
    assert len(ids) == len(set(ids))
    assert len(CASES) >= 100
    page = (ROOT / "docs" / "reference" / "bad_input.md").read_text()
    assert f"{len(CASES)} bad inputs" in page  # the count the documentation states


PROCESS_CASES = ["campaign-name-parent-path", "campaign-record-inf", "file-latin1",
                 "file-results-h5", "arg-run-jobs-0", "data-lvm-nan-force",
                 "data-lvm-directory", "arg-simulate-out-uff"]


@pytest.mark.slow
@pytest.mark.parametrize("case_id", PROCESS_CASES)
def test_a_real_process_prints_no_traceback(case_id, tmp_path):
    case = next(c for c in CASES if c.id == case_id)
    where, argv = _prepare(case, tmp_path)
    before = _tree(tmp_path)
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep
               + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "truthbench", *argv], cwd=where,
                          capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert case.expect in proc.stderr
    assert proc.stdout == ""
    assert _tree(tmp_path) == before
