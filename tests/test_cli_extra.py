"""The extra subcommands: study discretization, study damping-smoothing, identify.

The commands are registered on a parser built here the way ``truthbench.cli`` builds its
own, so the tests do not depend on the wiring in cli.py.
"""

from __future__ import annotations

import argparse
import importlib.resources
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from truthbench.cli import identify, study


def register(sub):
    study.register(sub)
    identify.register(sub)

SHIPPED_LVM = Path(str(importlib.resources.files("truthbench").joinpath(
    "data/ladisk_beam_impact/acceleration.lvm")))


@pytest.fixture(autouse=True)
def _private_io_registry(monkeypatch):
    """identify_file registers the .h5 reader; keep that out of the other tests."""
    import truthbench.io.registry as registry

    monkeypatch.setattr(registry, "_READERS", dict(registry._READERS))


def run(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="truthbench")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.func(args)


def test_import_is_light_and_help_is_fast():
    code = ("import sys, time; t = time.perf_counter(); import argparse; "
            "import truthbench.cli.study as s, truthbench.cli.identify as i; "
            "p = argparse.ArgumentParser(); sub = p.add_subparsers(); "
            "s.register(sub); i.register(sub); "
            "print(time.perf_counter() - t, 'numpy' in sys.modules, 'scipy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[1:] == ["False", "False"]
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
    assert "695.6" in out and "1898.0" in out and "3671.3" in out
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
