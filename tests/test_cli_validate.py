"""``truthbench validate``: a campaign checked without running it."""

import tomllib
from pathlib import Path

from truthbench.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _write(tmp_path, edit):
    text = (ROOT / "campaigns" / "quickstart.toml").read_text()
    d = tomllib.loads(text)
    text = edit(text)
    path = tmp_path / "c.toml"
    path.write_text(text)
    return path, d


def test_quickstart_passes_with_its_estimates(capsys):
    assert main(["validate", str(ROOT / "campaigns" / "quickstart.toml"),
                 "--trials", "1000"]) == 0
    out = capsys.readouterr().out
    assert "ok   identifiable at the nominal model: ['E_pa', 'rho_kg_m3']" in out
    assert "ok   m r > p: 8 SISO transfer functions" in out
    assert "disk: about 2006 MB for 1000 trial(s)" in out  # 2.0 MB per stored trial
    assert "time: about" in out and "FAIL" not in out


def test_thickness_beside_E_and_rho_is_not_identifiable(tmp_path, capsys):
    path, _ = _write(tmp_path, lambda t: t.replace(
        'parameters = ["E_pa", "rho_kg_m3"]', 'parameters = ["E_pa", "rho_kg_m3", "t_m"]'))
    assert main(["validate", str(path)]) == 1
    out = capsys.readouterr().out
    assert "FAIL identifiability at the nominal model: parameters cannot be separated" in out
    assert "t_m" in out


def test_update_band_outside_the_tests_fails(tmp_path, capsys):
    path, _ = _write(tmp_path, lambda t: t.replace("band_hz = [10.0, 400.0]",
                                                   "band_hz = [450.0, 500.0]"))
    # refused when the file is read (every command validates the same way): exit 2
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "key 'update.band_hz'" in err and "450-500 Hz" in err
    assert "the tests' excited band 2-400 Hz" in err and "reaches above it" in err


def test_a_bad_campaign_file_is_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[campaign]\nname = "x"\n')
    assert main(["validate", str(bad)]) == 2
    assert "bad.toml" in capsys.readouterr().err
