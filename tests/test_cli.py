"""The command line: run, report, modes; fast --help; errors as messages, not tracebacks."""

import json
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from truthbench.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _small_campaign(tmp_path):
    text = (ROOT / "campaigns" / "quickstart.toml").read_text()
    text = text.replace("record_s = 64.0", "record_s = 4.0").replace("averages = 8",
                                                                     "averages = 4")
    path = tmp_path / "small.toml"
    path.write_text(text)
    assert tomllib.loads(text)["tests"][0]["record_s"] == 4.0
    return path


@pytest.mark.slow
def test_run_and_report(tmp_path, capsys, monkeypatch):
    camp = _small_campaign(tmp_path)
    out = tmp_path / "out"
    # the trials stream to the store and the report is written from results.h5 (memory
    # does not grow with the trial count); the store's folder is gone once gathered
    assert main(["run", str(camp), "--out", str(out), "--seed", "3"]) == 0
    assert not (out / "trials").exists()
    printed = capsys.readouterr().out
    lines = printed.splitlines()
    listed = [line.strip() for line in lines[lines.index(next(
        x for x in lines if x.endswith("outputs:"))) + 1:]]
    assert listed[:3] == [str(out / "report.html"), str(out / "report.md"),
                          str(out / "results.h5")]
    assert "E_pa" in printed and "error after [%]" in printed and "GPa" in printed
    report = (out / "report.md").read_text()
    assert "| E_pa | GPa |" in report and "error before [%]" in report
    for name in ("frf_shaker_end.png", "frf_shaker_quarter.png", "poles.png"):
        assert (out / name).stat().st_size > 10_000
    assert "data:image/png;base64," in (out / "report.html").read_text()
    (out / "report.md").unlink()
    (out / "report.html").unlink()
    assert main(["report", str(out / "results.h5"), "--out", str(tmp_path / "again")]) == 0
    again = (tmp_path / "again" / "report.md").read_text()
    assert (tmp_path / "again" / "report.html").exists()

    def body(text):  # all but the time the results were written and the stage times
        return [line for line in text.splitlines() if not line.startswith("- truthbench")
                and not line.startswith(("| simulate", "| frf |", "| identify", "| bound",
                                         "| update", "| score"))]

    assert body(again) == body(report)


def test_report_of_a_missing_or_foreign_file(tmp_path, capsys):
    assert main(["report", str(tmp_path / "none.h5")]) == 2
    assert "none.h5: results file not found" in capsys.readouterr().err
    (tmp_path / "x.h5").write_bytes(b"junk")
    assert main(["report", str(tmp_path / "x.h5")]) == 2
    assert "x.h5: cannot be read as HDF5" in capsys.readouterr().err


def test_modes_json(capsys):
    assert main(["modes", str(ROOT / "campaigns" / "quickstart.toml"), "--json",
                 "--count", "10"]) == 0
    tables = json.loads(capsys.readouterr().out)
    nom, tru = tables["nominal"], tables["truth"]
    assert len(nom) == 10
    i = [row["shape"] for row in nom].index("bending y, 2 nodes")
    # truth E +4 %, rho -3 %: lateral bending (no suspension springs in y) scales exactly
    # by sqrt(1.04 / 0.97)
    ratio = tru[i]["freq_hz"] / nom[i]["freq_hz"]
    assert abs(ratio - (1.04 / 0.97) ** 0.5) < 1e-9


def test_bad_campaign_is_a_message(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[campaign]\nname = "x"\n')
    assert main(["modes", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "bad.toml" in err and "'plant' is required" in err


def test_help_is_fast_and_lazy():
    code = ("import sys, time; t = time.perf_counter(); "
            "import truthbench.cli as c; c.build_parser(); "
            "print(time.perf_counter() - t, 'control' in sys.modules, 'scipy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[1:] == ["False", "False"]  # no heavy import behind --help


def test_simulate_with_injected_effects(tmp_path, capsys):
    from truthbench.io.hdf5 import read_results

    camp = _small_campaign(tmp_path)
    out = tmp_path / "one.h5"
    assert main(["simulate", str(camp), "--test", "1", "--out", str(out), "--inject",
                 "time_delay:delay_s=0.002", "--inject",
                 "joint:station=mid,stiffness_loss=0.2"]) == 0
    assert "effect.time_delay.delay_s = 0.002" in capsys.readouterr().out
    data = read_results(out)
    t = data["tests"]["shaker_quarter"]
    params = t["parameters"]["attrs"]
    assert params["effect.joint.station"] == "mid"
    assert params["effect.joint.stiffness_loss"] == 0.2
    assert t["y"].shape == (4, 4096) and t["H"].shape[1:] == (4, 1)
    assert json.loads(data["attrs"]["injected"]) == ["time_delay:delay_s=0.002",
                                                    "joint:station=mid,stiffness_loss=0.2"]
    assert main(["report", str(out)]) == 0  # the single-test file has a report too
    md = (tmp_path / "report.md").read_text()
    assert "`joint:station=mid,stiffness_loss=0.2`" in md
    assert (tmp_path / "frf_shaker_quarter.png").exists()


def test_simulate_bad_input(tmp_path, capsys):
    camp = _small_campaign(tmp_path)
    out = str(tmp_path / "x.h5")
    assert main(["simulate", str(camp), "--out", out, "--inject", "time_delay:delta=2"]) == 2
    assert "no parameter 'delta'" in capsys.readouterr().err
    assert main(["simulate", str(camp), "--out", out, "--inject", "gremlin:x=1"]) == 2
    assert "unknown effect 'gremlin'" in capsys.readouterr().err
    assert main(["simulate", str(camp), "--out", out, "--test", "5"]) == 2
    assert "argument --test: expected a test index 0..1" in capsys.readouterr().err


def test_place_sensors(capsys):
    assert main(["place-sensors", str(ROOT / "campaigns" / "hub_beam.toml"), "--count",
                 "3"]) == 0
    out = capsys.readouterr().out
    assert "greedy D-optimal choice of 3" in out
    # in-plane bending: the ranked candidates are y translations, the tip region first
    ranked = [line.split()[1] for line in out.splitlines()[3:6]]
    assert all(lab.endswith(".y") for lab in ranked) and ranked[0] == "n20.y"


def test_report_html_is_self_contained(tmp_path):
    from truthbench.report.html import markdown_to_html

    (tmp_path / "f.png").write_bytes(b"\x89PNG fake")
    page = markdown_to_html("# T\n\ntext `x`\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\n- item\n\n"
                            "![fig](f.png)\n", tmp_path)
    assert "<h1>T</h1>" in page and "<code>x</code>" in page
    assert "<td>1</td><td>2</td>" in page and "<li>item</li>" in page
    assert "data:image/png;base64," in page and "f.png" not in page.split("base64,")[1]


@pytest.mark.slow
def test_place_sensors_scores_layouts(tmp_path, capsys):
    camp = _small_campaign(tmp_path)
    assert main(["place-sensors", str(camp), "--count", "3", "--score", "--trials", "1"]) == 0
    out = capsys.readouterr().out
    assert "Monte Carlo score: 1 trial(s) per layout" in out
    rows = [line.split() for line in out.splitlines() if line.split()[:1] in (["campaign"],
                                                                              ["proposed"])]
    assert [r[0] for r in rows] == ["campaign", "proposed"]
    assert "E_pa RMS error [%]" in out
