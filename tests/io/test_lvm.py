"""Tests of the LVM reader and the shipped LADISK beam impact test.

The shipped file is checked against its published sha256, against the statements of the
data README (written by someone else) and against an independent parse with
``numpy.loadtxt`` following the README's "by hand" recipe.
"""

from __future__ import annotations

import hashlib
import importlib.resources
import io
import re
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest

from truthbench.errors import DataFormatError
from truthbench.io import (
    G_STANDARD_M_S2,
    LADISK_BEAM_IMPACT_SHA256,
    ImpactRecord,
    TimeRecord,
    ladisk_beam_impact,
    read_lvm,
    to_si,
)

DATA_DIR = importlib.resources.files("truthbench").joinpath("data/ladisk_beam_impact")


@pytest.fixture(scope="module")
def shipped_path() -> Path:
    path = Path(str(DATA_DIR.joinpath("acceleration.lvm")))
    assert path.is_file()
    return path


@pytest.fixture(scope="module")
def shipped(shipped_path: Path) -> TimeRecord:
    return read_lvm(shipped_path)


@pytest.fixture(scope="module")
def impact() -> ImpactRecord:
    return ladisk_beam_impact()


# --------------------------------------------------------------------------------------
# The shipped file
# --------------------------------------------------------------------------------------


def test_shipped_file_matches_published_sha256(shipped_path: Path) -> None:
    digest = hashlib.sha256(shipped_path.read_bytes()).hexdigest()
    assert digest == LADISK_BEAM_IMPACT_SHA256
    readme = DATA_DIR.joinpath("README.md").read_text(encoding="utf-8")
    assert f"sha256: {digest}" in readme
    licence = DATA_DIR.joinpath("LICENSE.ladisk-MIT.txt").read_text(encoding="utf-8")
    assert "Copyright (c) 2018 - 2019 Ladisk" in licence


def test_shipped_file_shape_header_and_units(shipped: TimeRecord, shipped_path: Path) -> None:
    assert shipped.data.shape == (2, 50030)
    assert shipped.n_channels == 2 and shipped.n_samples == 50030
    assert shipped.dt_s == 2e-5
    assert shipped.fs_hz == pytest.approx(50_000.0, rel=1e-12)
    assert shipped.x0_s == 0.0
    assert shipped.time_s[-1] == pytest.approx(50029 * 2e-5)
    assert shipped.channel_names == ("Acceleration (Trigger)", "Force (Trigger)")
    assert shipped.units == ("g", "Newtons")
    assert shipped.start_time == datetime(2018, 12, 17, 10, 18, 21, 109129)
    assert shipped.source_path == shipped_path
    assert shipped.header["file"]["Decimal_Separator"] == ","
    assert shipped.header["file"]["Separator"] == "Tab"
    assert shipped.header["channel"]["Samples"] == ("50030", "50030")
    assert shipped.header["channel"]["Delta_X"] == ("2,000000E-5", "2,000000E-5")


def test_shipped_file_agrees_with_independent_loadtxt_parse(
    shipped: TimeRecord, shipped_path: Path
) -> None:
    # The README's recipe: skip past the second End_of_Header and the title line, split
    # on tabs, replace ',' with '.', read columns 1 and 2.
    text = shipped_path.read_text(encoding="utf-8")
    body = text.split("***End_of_Header***")[2].split("\n", 2)[2]
    ref = np.loadtxt(io.StringIO(body.replace(",", ".")), delimiter="\t", usecols=(1, 2))
    np.testing.assert_array_equal(shipped.data, ref.T)
    np.testing.assert_array_equal(shipped.data[:, 0], [-0.007387, 0.232147])
    np.testing.assert_array_equal(shipped.data[:, -1], [-0.009162, 0.298803])


def test_shipped_force_pulse_matches_readme(shipped: TimeRecord) -> None:
    force = shipped.data[1]
    # README: "peak force about 196 N"; "the force pulse begins at about sample 31 and
    # lasts about 0.2 ms".
    assert force.max() == pytest.approx(195.605522, abs=1e-9)
    assert int(np.argmax(force)) == 36  # 0-based: the peak is 5 samples after the onset
    above = np.flatnonzero(force[:1000] > 0.05 * force.max())
    assert above[0] == 30  # 0-based index 30 = sample 31 counted from 1
    assert np.all(np.diff(above) == 1)  # one pulse
    assert (above[-1] - above[0] + 1) * shipped.dt_s == pytest.approx(0.22e-3)


def test_shipped_accelerance_peaks_match_readme_below_5khz(impact: ImpactRecord) -> None:
    # README: strongest accelerance peaks 695.6, 1897.9 and 3671 Hz (one record,
    # rectangular window). True for the band below 5 kHz; checked to one bin (1 Hz).
    n = impact.n_samples
    freq = np.fft.rfftfreq(n, impact.dt_s)
    H = np.fft.rfft(impact.outputs[0]) / np.fft.rfft(impact.inputs[0])
    band = (freq > 100.0) & (freq < 5000.0)
    mag = np.abs(H[band])
    is_peak = (mag[1:-1] > mag[:-2]) & (mag[1:-1] > mag[2:])
    idx = np.flatnonzero(is_peak) + 1
    top3 = np.sort(freq[band][idx[np.argsort(mag[idx])[-3:]]])
    np.testing.assert_allclose(top3, [695.6, 1897.9, 3671.0], atol=1.0)


def test_ladisk_beam_impact_is_si_and_consistent(impact: ImpactRecord, shipped: TimeRecord) -> None:
    assert G_STANDARD_M_S2 == 9.80665
    assert impact.inputs.shape == (1, 50030) and impact.outputs.shape == (1, 50030)
    np.testing.assert_array_equal(impact.force_n, shipped.data[1])
    np.testing.assert_array_equal(impact.acceleration_m_s2, shipped.data[0] * 9.80665)
    assert impact.input_units == ("N",) and impact.output_units == ("m/s^2",)
    assert impact.input_names == ("Force (Trigger)",)
    assert impact.output_names == ("Acceleration (Trigger)",)
    assert impact.record.units == ("m/s^2", "N")
    assert impact.dt_s == 2e-5 and impact.fs_hz == pytest.approx(5e4)
    assert impact.start_time == shipped.start_time
    assert impact.sha256 == LADISK_BEAM_IMPACT_SHA256
    assert "ladisk" in impact.source.lower() and impact.license.startswith("MIT")
    assert impact.time_s.shape == (50030,)


def test_results_are_frozen_and_read_only(impact: ImpactRecord, shipped: TimeRecord) -> None:
    with pytest.raises(ValueError, match="read-only"):
        shipped.data[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        impact.inputs[0, 0] = 1.0
    with pytest.raises(AttributeError):
        shipped.dt_s = 1.0  # type: ignore[misc]
    with pytest.raises(TypeError):
        shipped.header["file"]["Operator"] = "x"  # type: ignore[index]


# --------------------------------------------------------------------------------------
# Synthetic files
# --------------------------------------------------------------------------------------


def lvm_text(
    *,
    sep: str = ",",
    decimal: str = ".",
    x_columns: str = "No",
    samples: int | None = None,
    rows: list[list[float]] | None = None,
    units: tuple[str, str] = ("m/s^2", "N"),
    names: tuple[str, str] = ("acc", "force"),
    delta_x: str = "1.0E-3",
    x0: str = "0.0000000000000000E+0",
    writer_version: str = "2",
    newline: str = "\n",
) -> str:
    """A 2-channel Writer_Version 2 LVM file as LabVIEW lays it out."""
    if rows is None:
        rows = [[0.5 * k, -1.25 * k + 0.125] for k in range(5)]
    n = len(rows) if samples is None else samples
    sep_name = {"\t": "Tab", ",": "Comma"}[sep]

    def num(v: float) -> str:
        return f"{v:.6f}".replace(".", decimal)

    def line(*fields: str) -> str:
        return sep.join(fields)

    head = [
        line("LabVIEW Measurement", ""),
        line("Writer_Version", writer_version),
        line("Reader_Version", "2"),
        line("Separator", sep_name),
        line("Decimal_Separator", decimal),
        line("Multi_Headings", "Yes"),
        line("X_Columns", x_columns),
        line("Time_Pref", "Absolute"),
        line("Operator", "test"),
        line("Date", "2024/03/05"),
        line("Time", f"14:15:16{decimal}25"),
        line("***End_of_Header***", ""),
        line("", ""),
        line("Channels", "2", "", ""),
        line("Samples", str(n), str(n), ""),
        line("Date", "2024/03/05", "2024/03/05", ""),
        line("Time", f"14:15:16{decimal}25", f"14:15:16{decimal}25", ""),
        line("Y_Unit_Label", *units, ""),
        line("X_Dimension", "Time", "Time", ""),
        line("X0", x0.replace(".", decimal), x0.replace(".", decimal), ""),
        line("Delta_X", delta_x.replace(".", decimal), delta_x.replace(".", decimal), ""),
        line("***End_of_Header***", "", "", ""),
    ]
    dx = float(delta_x)
    if x_columns == "Multi":
        head.append(line("X_Value", names[0], "X_Value", names[1], "Comment"))
        body = [line(num(k * dx), num(r[0]), num(k * dx), num(r[1])) for k, r in enumerate(rows)]
    else:
        head.append(line("X_Value", *names, "Comment"))
        xcol = (lambda k: "") if x_columns == "No" else (lambda k: num(k * dx))
        body = [line(xcol(k), *(num(v) for v in r)) for k, r in enumerate(rows)]
    return newline.join(head + body) + newline


def write(tmp_path: Path, text: str, name: str = "test.lvm") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8"))
    return path


def test_synthetic_comma_separator_point_decimal(tmp_path: Path) -> None:
    rows = [[0.5 * k, -1.25 * k + 0.125] for k in range(7)]
    path = write(tmp_path, lvm_text(sep=",", decimal=".", rows=rows))
    rec = read_lvm(path)
    np.testing.assert_array_equal(rec.data, np.array(rows).T)
    assert rec.dt_s == 1e-3 and rec.fs_hz == pytest.approx(1000.0)
    assert rec.channel_names == ("acc", "force")
    assert rec.units == ("m/s^2", "N")
    assert rec.start_time == datetime(2024, 3, 5, 14, 15, 16, 250000)
    assert rec.header["file"]["Separator"] == "Comma"


@pytest.mark.parametrize("x_columns", ["No", "One", "Multi"])
@pytest.mark.parametrize(("sep", "decimal"), [("\t", ","), ("\t", "."), (",", ".")])
def test_synthetic_layouts(tmp_path: Path, x_columns: str, sep: str, decimal: str) -> None:
    rows = [[1.5, -2.0], [3.25, 4.0], [-0.125, 1e3]]
    path = write(tmp_path, lvm_text(sep=sep, decimal=decimal, x_columns=x_columns, rows=rows))
    rec = read_lvm(path)
    np.testing.assert_array_equal(rec.data, np.array(rows).T)
    assert rec.channel_names == ("acc", "force")


def test_crlf_line_ends_and_x0(tmp_path: Path) -> None:
    path = write(tmp_path, lvm_text(newline="\r\n", x0="2.5E-1"))
    rec = read_lvm(path)
    assert rec.data.shape == (2, 5)
    assert rec.x0_s == 0.25 and rec.time_s[0] == 0.25


def test_to_si_converts_g_and_leaves_input_unchanged(tmp_path: Path) -> None:
    path = write(tmp_path, lvm_text(units=("g", "kN")))
    rec = read_lvm(path)
    before = rec.data.copy()
    si = to_si(rec)
    np.testing.assert_array_equal(si.data[0], before[0] * 9.80665)
    np.testing.assert_array_equal(si.data[1], before[1] * 1e3)
    assert si.units == ("m/s^2", "N")
    np.testing.assert_array_equal(rec.data, before)
    assert rec.units == ("g", "kN")


def test_to_si_unknown_unit_names_channel(tmp_path: Path) -> None:
    rec = read_lvm(write(tmp_path, lvm_text(units=("furlong", "N"))))
    with pytest.raises(ValueError, match=r"channel 'acc' has unit 'furlong'"):
        to_si(rec)


# --------------------------------------------------------------------------------------
# Error paths: each message names the file
# --------------------------------------------------------------------------------------


def _match(path: Path, what: str) -> str:
    return re.escape(str(path)) + ".*" + what


def test_truncated_raises_with_counts(tmp_path: Path) -> None:
    path = write(tmp_path, lvm_text(samples=8))  # 5 rows written, 8 declared
    with pytest.raises(DataFormatError, match=_match(path, r"says 8 rows, read 5")):
        read_lvm(path)


def test_truncated_allowed_keeps_complete_rows(tmp_path: Path) -> None:
    rows = [[float(k), 2.0 * k] for k in range(5)]
    path = write(tmp_path, lvm_text(samples=8, rows=rows))
    with pytest.warns(UserWarning, match=r"says 8 rows, kept 5 complete rows"):
        rec = read_lvm(path, allow_truncated=True)
    np.testing.assert_array_equal(rec.data, np.array(rows).T)


def test_truncated_mid_line_drops_partial_last_row(tmp_path: Path) -> None:
    rows = [[float(k) + 0.123456, 2.0 * k + 0.654321] for k in range(5)]
    text = lvm_text(samples=8, rows=rows)
    path = write(tmp_path, text[:-5])  # cut inside the last number, no line end
    with pytest.raises(DataFormatError, match=_match(path, "truncated data")):
        read_lvm(path)
    with pytest.warns(UserWarning, match="kept 4 complete rows"):
        rec = read_lvm(path, allow_truncated=True)
    np.testing.assert_array_equal(rec.data, np.array(rows[:4]).T)


def test_too_many_rows(tmp_path: Path) -> None:
    path = write(tmp_path, lvm_text(samples=3))
    with pytest.raises(DataFormatError, match=_match(path, r"line 27: too many data rows")):
        read_lvm(path)


def test_missing_end_of_header(tmp_path: Path) -> None:
    text = lvm_text().replace("***End_of_Header***", "***End_of_Heder***")
    path = write(tmp_path, text)
    with pytest.raises(DataFormatError, match=_match(path, r"missing '\*\*\*End_of_Header")):
        read_lvm(path)


def test_missing_channel_header_end(tmp_path: Path) -> None:
    text = lvm_text()
    head, rest = text.split("***End_of_Header***", 1)
    path = write(tmp_path, head + "***End_of_Header***" + rest.replace("***End_of_Header***", ""))
    with pytest.raises(DataFormatError, match=_match(path, r"channel header \(second header")):
        read_lvm(path)


def test_headerless_file(tmp_path: Path) -> None:
    path = write(tmp_path, "0.1,0.2\n0.3,0.4\n")
    with pytest.raises(DataFormatError, match=_match(path, r"line 1: expected 'LabVIEW Meas")):
        read_lvm(path)


def test_non_numeric_names_line_and_value(tmp_path: Path) -> None:
    text = lvm_text().replace("2.000000", "2.0x0000")  # row k=4, first channel
    path = write(tmp_path, text)
    with pytest.raises(
        DataFormatError, match=_match(path, r"line 28: non-numeric value .*'acc'.*'2.0x0000'")
    ):
        read_lvm(path)


def test_empty_field_is_non_numeric(tmp_path: Path) -> None:
    lines = lvm_text().split("\n")
    lines[24] = ",,1.0"  # second data row: empty acceleration
    path = write(tmp_path, "\n".join(lines))
    with pytest.raises(DataFormatError, match=_match(path, r"line 25: non-numeric .*got ''")):
        read_lvm(path)


def test_column_count_mismatch(tmp_path: Path) -> None:
    lines = lvm_text().split("\n")
    lines[25] = ",1.0,2.0,3.0,4.0"
    path = write(tmp_path, "\n".join(lines))
    with pytest.raises(DataFormatError, match=_match(path, r"line 26: column count: expected 3")):
        read_lvm(path)


def test_empty_file(tmp_path: Path) -> None:
    path = write(tmp_path, "")
    with pytest.raises(DataFormatError, match=_match(path, r"the file is empty \(0 bytes\)")):
        read_lvm(path)


def test_writer_version_1_rejected(tmp_path: Path) -> None:
    path = write(tmp_path, lvm_text(writer_version="1"))
    with pytest.raises(DataFormatError, match=_match(path, r"line 2: field 'Writer_Version'")):
        read_lvm(path)


def test_bad_header_number(tmp_path: Path) -> None:
    path = write(tmp_path, lvm_text(delta_x="1.0E-3").replace("1.0E-3", "fast"))
    with pytest.raises(DataFormatError, match=_match(path, r"line 21: field 'Delta_X'")):
        read_lvm(path)


def test_channels_with_different_samples(tmp_path: Path) -> None:
    text = lvm_text().replace("Samples,5,5", "Samples,5,4")
    path = write(tmp_path, text)
    with pytest.raises(DataFormatError, match=_match(path, r"line 15: field 'Samples'")):
        read_lvm(path)


def test_comma_decimal_with_comma_separator_rejected(tmp_path: Path) -> None:
    text = lvm_text(sep=",", decimal=".").replace("Decimal_Separator,.", "Decimal_Separator,,")
    path = write(tmp_path, text)
    with pytest.raises(DataFormatError, match=_match(path, r"line 5: field 'Decimal_Sep")):
        read_lvm(path)


def test_second_segment_rejected(tmp_path: Path) -> None:
    text = lvm_text()
    second = text.split("***End_of_Header***", 1)[1].split("\n", 2)[2]  # channel header on
    path = write(tmp_path, text + second)
    with pytest.raises(DataFormatError, match=_match(path, r"line 29: a second data segment")):
        read_lvm(path)


def test_missing_file() -> None:
    with pytest.raises(FileNotFoundError):
        read_lvm("/nonexistent/nothing.lvm")


@pytest.mark.parametrize(
    ("lineno", "new_line", "match"),
    [
        (4, "Separator,Semicolon", r"line 4: field 'Separator': expected 'Tab' or 'Comma'"),
        (2, "Writer_Versio,2", r"file header has no 'Writer_Version' line"),
        (5, "Decimal_Separator,;", r"line 5: field 'Decimal_Separator': expected '.' or ','"),
        (7, "X_Columns,Two", r"line 7: field 'X_Columns': expected 'No', 'One' or 'Multi'"),
        (14, "Channels,two,,", r"line 14: field 'Channels': expected a positive integer"),
        (14, "Chanels,2,,", r"channel header has no 'Channels' line"),
        (15, "Samples,5,,", r"line 15: field 'Samples': expected 2 value\(s\)"),
        (15, "Samples,5.0,5.0,", r"line 15: field 'Samples': expected integers"),
        (21, "Delta_Y,1.0E-3,1.0E-3,", r"channel header has no 'Delta_X' line"),
        (21, "Delta_X,1.0E-3,2.0E-3,", r"line 21: field 'Delta_X': expected one positive"),
        (21, "Delta_X,-1.0E-3,-1.0E-3,", r"line 21: field 'Delta_X': expected one positive"),
        (20, "X0,0,1,", r"line 20: field 'X0': expected the same finite start"),
        (17, "Time,14h15,14h15,", r"line 17: fields 'Date'/'Time': expected 'YYYY/MM/DD'"),
        (16, "Date,2024/02/30,2024/02/30,", r"line 17: fields 'Date'/'Time': not a valid"),
        (23, "X_Value,acc,Comment", r"line 23: column titles: expected 3 columns"),
        (26, "", r"line 26: empty line inside the data block"),
    ],
)
def test_malformed_header_and_layout(
    tmp_path: Path, lineno: int, new_line: str, match: str
) -> None:
    lines = lvm_text().split("\n")
    lines[lineno - 1] = new_line
    path = write(tmp_path, "\n".join(lines))
    with pytest.raises(DataFormatError, match=_match(path, match)):
        read_lvm(path)


def test_file_ending_after_the_file_header(tmp_path: Path) -> None:
    path = write(tmp_path, "\n".join(lvm_text().split("\n")[:13]) + "\n")
    with pytest.raises(DataFormatError, match=_match(path, r"no channel header after the")):
        read_lvm(path)


def test_ladisk_beam_impact_checks_sha256(monkeypatch: pytest.MonkeyPatch) -> None:
    import truthbench.io.lvm as lvm

    monkeypatch.setattr(lvm, "LADISK_BEAM_IMPACT_SHA256", "0" * 64)
    with pytest.raises(DataFormatError, match=r"acceleration\.lvm: sha256 mismatch: expected 0+"):
        lvm.ladisk_beam_impact()


def test_time_record_validates_its_fields() -> None:
    with pytest.raises(ValueError, match=r"shape \(n_channels, n_samples\); got 1 dimension"):
        TimeRecord(data=np.ones(3), dt_s=1.0, channel_names=("a",), units=("N",))
    with pytest.raises(ValueError, match=r"channel_names must have one entry per channel"):
        TimeRecord(data=np.ones((2, 3)), dt_s=1.0, channel_names=("a",), units=("N", "N"))
    with pytest.raises(ValueError, match=r"dt_s must be finite and > 0; got 0.0"):
        TimeRecord(data=np.ones((1, 3)), dt_s=0.0, channel_names=("a",), units=("N",))
    source = np.ones((1, 3))
    rec = TimeRecord(data=source, dt_s=0.5, channel_names=["a"], units=["N"])
    source[0, 0] = 7.0  # the record holds a copy
    assert rec.data[0, 0] == 1.0 and rec.channel_names == ("a",)


def test_non_finite_values_and_binary_data_are_named(tmp_path):
    """NaN or Inf in a channel (a dropped or overranged sample) and bytes that are not
    text (the file written over) are refused with the line and channel, not read on
    into an FRF or called a truncation."""
    rows = [[0.5 * k, -1.25 * k + 0.125] for k in range(5)]
    text = lvm_text(rows=rows)
    nan = write(tmp_path, text.replace("-2.375000", "NaN"))
    with pytest.raises(DataFormatError, match=_match(nan, r"line \d+: non-finite value in "
                                                          r"column 3 \(channel 'force'\): "
                                                          r"expected a finite number, got "
                                                          r"'NaN'")):
        read_lvm(nan)
    junk = tmp_path / "junk.lvm"
    junk.write_bytes(text.encode().replace(b"1.500000", b"1.5\x00\x07\n\x01"))
    with pytest.raises(DataFormatError, match=_match(junk, r"line \d+: binary data in a text "
                                                           r"file: character '\\x00'")):
        read_lvm(junk)
