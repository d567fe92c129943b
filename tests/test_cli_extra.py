"""The extra subcommands: study discretization, study damping-smoothing, identify, export.

The commands run through :func:`truthbench.cli.main`, which answers their errors with a
message and exit code 2.
"""

from __future__ import annotations

import importlib.resources
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from truthbench.cli import main

SHIPPED_LVM = Path(str(importlib.resources.files("truthbench").joinpath(
    "data/ladisk_beam_impact/acceleration.lvm")))


def run(argv: list[str]) -> int:
    """Through :func:`truthbench.cli.main`: a command's errors are answered there."""
    return main(argv)


def test_import_is_light_and_help_is_fast():
    # the commands import truthbench.io, which registers its readers (the .h5 one too)
    # and imports numpy; nothing heavier (scipy, h5py, pyuff, matplotlib) may load behind
    # --help, and truthbench's own share stays small.
    code = ("import sys, time; t0 = time.perf_counter(); import numpy; "
            "t1 = time.perf_counter(); import argparse; "
            "import truthbench.cli.study as s, truthbench.cli.identify as i, "
            "truthbench.cli.export as e; "
            "p = argparse.ArgumentParser(); sub = p.add_subparsers(); "
            "s.register(sub); i.register(sub); e.register(sub); "
            "heavy = ('scipy', 'h5py', 'pyuff', 'matplotlib', 'control'); "
            "print(time.perf_counter() - t1, any(m in sys.modules for m in heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[1:] == ["False"]
    assert float(out[0]) < 0.5


def test_help_lists_the_commands(capsys):
    with pytest.raises(SystemExit):
        run(["study", "--help"])
    text = capsys.readouterr().out
    assert "discretization" in text and "damping-smoothing" in text
    with pytest.raises(SystemExit):
        run(["identify", "--help"])
    text = capsys.readouterr().out
    assert "--max-order" in text and "--band LO HI" in text


def test_study_discretization(tmp_path, capsys):
    assert run(["study", "discretization", "--out", str(tmp_path), "--max-elements", "8"]) == 0
    out = capsys.readouterr().out
    assert "exact Euler-Bernoulli: mode 1 46.6177 Hz, mode 2 128.5036 Hz" in out
    assert "freq err %" in out
    frame = pd.read_csv(tmp_path / "discretization.csv")
    assert len(frame) == 16 and frame.n_elements.max() == 8
    assert (tmp_path / "discretization.png").stat().st_size > 10_000


@pytest.mark.slow
def test_study_damping_smoothing(tmp_path, capsys):
    assert run(["study", "damping-smoothing", "--out", str(tmp_path), "--seed", "3",
                "--seeds", "1"]) == 0
    out = capsys.readouterr().out
    assert "exact sampled-system FRF reads zeta" in out and "bartlett" in out
    frame = pd.read_csv(tmp_path / "damping_smoothing.csv")
    assert set(frame.window) == {"bartlett", "hann", "hamming"}
    assert len(frame) == 3 * 2 * 9
    assert (tmp_path / "damping_smoothing.png").stat().st_size > 10_000


def test_identify_lvm_table_and_ratio_line(capsys):
    assert run(["identify", str(SHIPPED_LVM)]) == 0
    out = capsys.readouterr().out
    assert "impact: one segment of 50030 samples" in out
    assert "uncorrected" in out
    rows = [t.split() for t in out.splitlines() if t.strip()[:1].isdigit()]
    freqs = [float(r[1]) for r in rows if len(r) == 4]
    # the bending modes, to a tenth of the 1 Hz line spacing (pLSCF orders 30 and 40
    # agree to 0.08 Hz)
    np.testing.assert_allclose([freqs[0], freqs[1], freqs[3]], [695.68, 1898.03, 3671.37],
                               atol=0.1)
    line = next(t for t in out.splitlines() if t.startswith("frequency ratios"))
    assert "2.757, 5.404" in line
    ratios = [float(v) for v in line.split(":")[1].split("(")[0].split(",")]
    assert 2.7 < ratios[0] < 2.757 and 5.2 < ratios[1] < 5.404


def test_identify_json(capsys):
    assert run(["identify", str(SHIPPED_LVM), "--json", "--method", "peak", "--band", "300",
                "4500", "--modes", "3"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["method"] == "peak" and report["file_format"] == "lvm"
    modes = report["datasets"][0]["modes"]
    np.testing.assert_allclose([m["freq_hz"] for m in modes], [695.6, 1897.9, 3671.0],
                               rtol=0.005)
    assert report["datasets"][0]["band_hz"] == [300.0, 4500.0]


def test_identify_errors_are_messages(tmp_path, capsys):
    assert run(["identify", str(SHIPPED_LVM), "--band", "30000", "40000"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("truthbench identify: error: ")
    assert "acceleration.lvm: band 30000-40000 Hz lies outside the data" in err
    assert run(["identify", str(tmp_path / "missing.uff")]) == 2
    assert "missing.uff: no such data file" in capsys.readouterr().err
    bad = tmp_path / "bad.uff"
    bad.write_text("    -1\n    58\n")
    assert run(["identify", str(bad)]) == 2
    assert "bad.uff: truncated or corrupt UFF file" in capsys.readouterr().err


@pytest.fixture(scope="module")
def results_h5(tmp_path_factory):
    """A small quickstart campaign (4 s records, 4 averages) stored as results.h5."""
    import re

    from truthbench.campaign.runner import run_campaign
    from truthbench.campaign.spec import load_campaign
    from truthbench.campaign.store import write_results

    tmp = tmp_path_factory.mktemp("export")
    root = Path(__file__).resolve().parents[1]
    text = (root / "campaigns" / "quickstart.toml").read_text()
    text = re.sub(r"record_s = [0-9.]+", "record_s = 4.0", text)
    text = re.sub(r"averages = [0-9]+", "averages = 4", text)
    (tmp / "quick.toml").write_text(text)
    return write_results(run_campaign(load_campaign(tmp / "quick.toml")), tmp / "results.h5")


def test_export_writes_uff_and_says_what(results_h5, tmp_path, capsys):
    import h5py
    import pyuff

    out = tmp_path / "quick.uff"
    assert main(["export", str(results_h5), "--out", str(out), "--test", "shaker_quarter",
                 "--trial", "0", "--binary"]) == 0
    text = capsys.readouterr().out
    assert f"-> {out} (binary 58b, exact)" in text
    assert "2411 4 point(s), 58 4 FRF set(s) and 4 coherence set(s) in 1 load case(s)" in text
    assert "point   2  quarter          (0.45, 0, 0) m" in text
    assert "load case 1: trial 0 / shaker_quarter: 4 output(s) x 1 input(s) ['quarter.z']" \
        in text
    sets = pyuff.UFF(str(out)).read_sets()
    frf = [s for s in sets if s["type"] == 58 and s["func_type"] == 4]
    with h5py.File(results_h5) as f:
        H = f["trials/0000/tests/shaker_quarter/H"][()]
    # outputs end_a, quarter, mid, end_b are points 1..4 (sorted along the beam)
    for s in frf:
        assert s["ref_node"] == 2 and s["ref_dir"] == 3
        np.testing.assert_array_equal(s["data"], H[:, s["rsp_node"] - 1, 0])
    assert sorted(s["rsp_node"] for s in frf) == [1, 2, 3, 4]


def test_export_then_identify(results_h5, tmp_path, capsys):
    out = tmp_path / "all.unv"
    assert main(["export", str(results_h5), "--out", str(out)]) == 0
    assert "in 2 load case(s)" in capsys.readouterr().out
    assert main(["identify", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [d["name"] for d in report["datasets"]] == ["trial 0 / shaker_end",
                                                       "trial 0 / shaker_quarter"]
    assert report["datasets"][0]["band_hz"] == [2.0, 400.0]
    assert report["datasets"][0]["n_averages"] == 4


def test_export_errors_are_messages(results_h5, tmp_path, capsys):
    assert main(["export", str(results_h5), "--out", str(tmp_path / "x.uff"), "--test",
                 "nope"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("truthbench export: error: ")
    assert "results.h5: no test ['nope'] in the file" in err
    assert main(["export", str(tmp_path / "missing.h5"), "--out", str(tmp_path / "x.uff")]) == 2
    assert "missing.h5: no such data file" in capsys.readouterr().err
    assert not (tmp_path / "x.uff").exists()


def test_a_uff_without_band_identifies_like_the_results_file(results_h5, tmp_path, capsys):
    """A UFF from another tool records no excited band: the band comes from the
    coherence, and the modes and shapes are those of the results file (which knows its
    band), not a fit of the noise outside the excited band."""
    import re

    from truthbench.identify import mac

    out = tmp_path / "all.uff"
    assert main(["export", str(results_h5), "--out", str(out)]) == 0
    capsys.readouterr()
    foreign = tmp_path / "foreign.uff"
    foreign.write_text(re.sub(r"band_hz=\S+", "NONE", out.read_text()))
    assert "band_hz" not in foreign.read_text()
    reports = {}
    for path in (results_h5, foreign):
        assert main(["identify", str(path), "--json"]) == 0
        reports[path] = json.loads(capsys.readouterr().out)["datasets"]
    for ours, theirs in zip(reports[results_h5], reports[foreign], strict=True):
        assert ours["band_rule"] == "the data's excited band"
        assert theirs["band_rule"].startswith("the lines whose coherence reaches")
        lo, hi = theirs["band_hz"]
        assert 2.0 <= lo < 10.0 and 390.0 < hi <= 402.0  # the excited band, 2-400 Hz
        f1 = [m["freq_hz"] for m in ours["modes"]]
        f2 = [m["freq_hz"] for m in theirs["modes"]]
        np.testing.assert_allclose(f2, f1, rtol=1e-3)
        s1 = np.array([m["shape"] for m in ours["modes"]]).T
        s2 = np.array([m["shape"] for m in theirs["modes"]]).T
        assert np.all(np.diag(mac(s1, s2)) > 0.999)


def test_json_is_strict(capsys):
    """No NaN or Infinity tokens: a rigid-body mode's damping is null."""
    root = Path(__file__).resolve().parents[1]

    def refuse(token):
        raise AssertionError(f"non-standard JSON token {token}")

    assert main(["modes", str(root / "campaigns" / "quickstart.toml"), "--json",
                 "--count", "6"]) == 0
    tables = json.loads(capsys.readouterr().out, parse_constant=refuse)
    assert tables["nominal"][0]["damping_ratio"] is None
    assert main(["identify", str(SHIPPED_LVM), "--json"]) == 0
    json.loads(capsys.readouterr().out, parse_constant=refuse)


def test_every_help_shows_defaults_and_an_example(capsys):
    from truthbench.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if hasattr(a, "choices") and a.choices)
    commands = dict(sub.choices)
    study = next(a for a in commands["study"]._actions if hasattr(a, "choices") and a.choices)
    commands.update({f"study {k}": v for k, v in study.choices.items()})
    assert set(commands) >= {"run", "report", "simulate", "identify", "export", "study",
                             "place-sensors", "modes", "study discretization",
                             "study damping-smoothing"}
    for name, p in commands.items():
        text = p.format_help()
        assert "example" in text and "truthbench " in text.split("example")[-1], name
        # every option with a default shows it (unless its help says it in words)
        for action in p._actions:
            if (action.option_strings and action.dest != "help"
                    and action.default not in (None, False)
                    and "default" not in (action.help or "").lower()):
                assert f"(default: {action.default})" in " ".join(text.split()), (name,
                                                                                  action.dest)
