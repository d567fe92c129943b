"""Time records from files -> FRFData: channel roles and quantities, and the errors.

Oracle: records written here (LVM text, UFF time sets through pyuff) whose H1 is checked
against measure.frfs_from_time on the same samples in SI units (the io layer must only
choose channels and convert units: the same numbers, bit for bit).
"""

from __future__ import annotations

import importlib.resources
from pathlib import Path

import numpy as np
import pytest

from truthbench.errors import DataFormatError
from truthbench.io import (
    G_STANDARD_M_S2,
    frf_from_record,
    load_frf,
    read_lvm,
    read_lvm_frf,
)
from truthbench.io._uff58 import write_uff58_time
from truthbench.measure import frfs_from_time

SHIPPED_LVM = Path(str(importlib.resources.files("truthbench").joinpath(
    "data/ladisk_beam_impact/acceleration.lvm")))


def write_lvm(path: Path, names, units, data, dt_s, samples=None):
    n_ch, n = data.shape
    lines = ["LabVIEW Measurement\t", "Writer_Version\t2", "Reader_Version\t2",
             "Separator\tTab", "Decimal_Separator\t.", "Multi_Headings\tYes",
             "X_Columns\tNo", "Time_Pref\tAbsolute", "Date\t2024/01/02",
             "Time\t10:00:00.0", "***End_of_Header***\t", "\t",
             "Channels\t" + str(n_ch) + "\t" * n_ch,
             "Samples\t" + "\t".join([str(samples or n)] * n_ch) + "\t",
             "Date\t" + "\t".join(["2024/01/02"] * n_ch) + "\t",
             "Time\t" + "\t".join(["10:00:00.0"] * n_ch) + "\t",
             "Y_Unit_Label\t" + "\t".join(units) + "\t",
             "X_Dimension\t" + "\t".join(["Time"] * n_ch) + "\t",
             "X0\t" + "\t".join(["0.0000000000000000E+0"] * n_ch) + "\t",
             "Delta_X\t" + "\t".join([f"{dt_s:.6E}"] * n_ch) + "\t",
             "***End_of_Header***\t" + "\t" * n_ch,
             "X_Value\t" + "\t".join(names) + "\tComment"]
    lines += ["\t" + "\t".join(f"{v:.10e}" for v in row) for row in data.T]
    path.write_text("\n".join(lines) + "\n")
    return path


def impact(n=400):
    u = np.zeros(n)
    u[20:28] = 100.0 * np.sin(np.pi * (np.arange(8) + 0.5) / 8)
    y = np.convolve(u, np.exp(-np.arange(100) / 20.0) * np.sin(0.4 * np.arange(100)))[:n]
    return u, y


def test_lvm_in_g_and_velocity_gives_mixed_si_frfs(tmp_path):
    rng = np.random.default_rng(2)
    data = rng.standard_normal((3, 512))
    path = write_lvm(tmp_path / "r.lvm", ["acc", "vel", "shaker"], ["g", "mm/s", "N"],
                     data, 1e-3)
    (d,) = read_lvm_frf(path, n_averages=4)
    assert d.name == "r" and d.input_labels == ("shaker",)
    assert [c.quantity for c in d.outputs] == ["acceleration", "velocity"]
    assert d.frf_type == "mixed" and d.n_averages == 4
    raw = read_lvm(path).data  # the values as written in the file (10 digits)
    si = np.vstack([raw[0] * G_STANDARD_M_S2, raw[1] * 1e-3])
    ref = frfs_from_time(raw[2], si, 1000.0, n_averages=4)
    np.testing.assert_array_equal(d.H, ref.H)
    assert load_frf(path, n_averages=4)[0].band_hz == ref.band_hz


def test_the_shipped_lvm_is_an_impact_test():
    (d,) = load_frf(SHIPPED_LVM)
    assert d.excitation == "impact" and d.input_labels == ("Force (Trigger)",)
    assert d.frf_type == "acceleration" and d.n_averages == 1


def test_a_channel_named_like_an_input_is_the_input(tmp_path):
    u, y = impact()
    rec = read_lvm(write_lvm(tmp_path / "v.lvm", ["acc", "Hammer"], ["m/s^2", "V"],
                             np.vstack([y, u]), 1e-3))
    d = frf_from_record(rec)
    assert d.input_labels == ("Hammer",) and d.excitation == "impact"


def test_truncated_lvm(tmp_path):
    u, y = impact()
    path = write_lvm(tmp_path / "cut.lvm", ["Acceleration", "Force"], ["m/s^2", "N"],
                     np.vstack([y, u]), 1 / 2000.0, samples=500)
    with pytest.raises(DataFormatError, match=r"cut\.lvm: truncated data: 'Samples'"):
        load_frf(path)


def test_lvm_without_input_channel(tmp_path):
    y = np.random.default_rng(0).standard_normal((2, 100))
    path = write_lvm(tmp_path / "noin.lvm", ["acc1", "acc2"], ["m/s^2", "g"], y, 1e-3)
    with pytest.raises(DataFormatError, match=r"noin\.lvm: no input channel among \['acc1 "
                                              r"\(m/s\^2\)', 'acc2 \(g\)'\]: expected a force "
                                              r"channel"):
        load_frf(path)


def test_lvm_without_output_channel(tmp_path):
    u, _ = impact()
    path = write_lvm(tmp_path / "onlyf.lvm", ["Force"], ["N"], u[None], 1e-3)
    with pytest.raises(DataFormatError, match=r"onlyf\.lvm: only input channel\(s\) "
                                              r"\['Force'\]; expected at least one response"):
        load_frf(path)


def test_lvm_output_of_unknown_quantity(tmp_path):
    u, y = impact()
    path = write_lvm(tmp_path / "volt.lvm", ["Force", "Strain"], ["N", "V"],
                     np.vstack([u, y]), 1e-3)
    with pytest.raises(DataFormatError, match=r"volt\.lvm: output channel 'Strain' has unit "
                                              r"'V'; expected acceleration"):
        load_frf(path)
    odd = write_lvm(tmp_path / "odd.lvm", ["Force", "x"], ["N", "furlong"],
                    np.vstack([u, y]), 1e-3)
    with pytest.raises(DataFormatError, match=r"odd\.lvm: to_si: channel 'x' has unit "
                                              r"'furlong'"):
        load_frf(odd)


def test_uff_time_without_input_channel(tmp_path):
    y = np.random.default_rng(0).standard_normal((2, 64))
    path = write_uff58_time(tmp_path / "noin.uff", y, 0.01, resp_nodes=[1, 2],
                            resp_dirs=[3, 3], quantities=["acceleration"] * 2,
                            resp_names=["acc1", "acc2"])
    with pytest.raises(DataFormatError, match=r"noin\.uff: no input channel among \['acc1 "
                                              r"\(m/s\^2\)', 'acc2 \(m/s\^2\)'\]"):
        load_frf(path)


def test_the_input_level_of_a_uff_time_file_in_kn_is_its_rms_in_newtons(tmp_path):
    """UFF time sets written with pyuff in mm and kN (dataset 164): the force's RMS about
    its mean, in N, is the input level; the FRF's band is the excited one."""
    import pyuff

    fs, n = 512.0, 4096
    k = np.arange(n)
    force_n = 2.0 * np.sin(2 * np.pi * 40 * k / n) + 1.0 * np.sin(2 * np.pi * 97 * k / n + 1)
    acc = np.convolve(force_n, np.exp(-np.arange(60) / 8.0) * np.cos(0.7 * np.arange(60)))[:n]
    sets = [pyuff.prepare_164(units_code=9, units_description="mm kN", temp_mode=1,
                              length=1000.0, force=1e-3, temp=1.0, temp_offset=273.15)]
    for node, code, lab, values in ((1, 13, "kN", force_n * 1e-3 + 0.02),
                                    (2, 12, "mm/s^2", acc * 1e3)):
        sets.append({"type": 58, "func_type": 1, "rsp_node": node, "rsp_dir": 3,
                     "ref_node": 0, "ref_dir": 0, "abscissa_spacing": 1,
                     "abscissa_spec_data_type": 17, "abscissa_axis_units_lab": "s",
                     "ordinate_spec_data_type": code, "ordinate_axis_units_lab": lab,
                     "orddenom_spec_data_type": 0, "x": k / fs, "data": values})
    path = tmp_path / "time_kN.uff"
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    (d,) = load_frf(path, n_averages=4)
    # 12 significant digits per value in the file: each sample off by at most 5e-12 of
    # its size (offset included), so the RMS by at most that over the RMS
    rms = np.sqrt((2.0**2 + 1.0**2) / 2)
    bound = 5e-12 * np.max(np.abs(force_n * 1e-3 + 0.02)) * 1e3 / rms
    assert d.input_rms == pytest.approx((rms,), rel=bound)
    assert d.band_hz[0] <= 40 * fs / n and d.band_hz[1] >= 97 * fs / n
