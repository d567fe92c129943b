"""The identify workflow: FRFData or a data file -> modal parameters.

Oracles: FRFs written analytically from a known modal model (outside the library's own
LSFD model), exact time simulations of known modal systems (impact and random tests),
the window identity ``(h * x) w = (h w) * (x w)`` for ``w = exp(-sigma_w t)`` that makes
the exponential-window correction exact, and the LADISK measured beam record with the
rough numbers of its README (frequencies) and of the brief (damping).
"""

from __future__ import annotations

import importlib.resources
import json
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

from truthbench.errors import DataFormatError
from truthbench.identify import (
    EULER_BERNOULLI_FREE_FREE_RATIOS,
    ModalParameters,
    correct_exponential_window,
    identify_file,
    identify_frfs,
    mac,
)
from truthbench.identify import workflow as identify
from truthbench.io import ladisk_beam_impact
from truthbench.io._uff58 import write_uff58_frf, write_uff58_time
from truthbench.measure import Channel, FRFData, frfs_from_time
from truthbench.simulate import add_sensor_noise, simulate_lti

SHIPPED_LVM = Path(str(importlib.resources.files("truthbench").joinpath(
    "data/ladisk_beam_impact/acceleration.lvm")))

# a known two-mode model: frequencies (Hz), damping ratios, shapes at 3 outputs, input row 0
F_HZ = np.array([20.0, 55.0])
ZETA = np.array([0.01, 0.02])
PHI = np.array([[1.0, 1.0], [0.6, -0.8], [-0.4, 0.5]])


def modal_frf(freq_hz, q=2, phi=PHI, f_hz=F_HZ, zeta=ZETA, inp=0):
    """(j w)^q sum_r phi_r phi_r[inp] / (w_r^2 - w^2 + 2 j zeta_r w_r w), (n, n_out, 1)."""
    w = 2 * np.pi * np.asarray(freq_hz)[:, None]
    wr = 2 * np.pi * f_hz[None, :]
    d = 1.0 / (wr**2 - w**2 + 2j * zeta * wr * w)  # (n, modes)
    H = (d * phi[inp][None, :]) @ phi.T
    return ((1j * w) ** q * H)[:, :, None]


def modal_state_space(f_hz, zeta, phi, inp=0):
    """Acceleration outputs at the rows of phi for a force at row inp (unit modal mass)."""
    w = 2 * np.pi * np.asarray(f_hz)
    m = w.size
    A = np.zeros((2 * m, 2 * m))
    A[:m, m:] = np.eye(m)
    A[m:, :m] = -np.diag(w**2)
    A[m:, m:] = -np.diag(2 * zeta * w)
    B = np.concatenate([np.zeros(m), phi[inp]])[:, None]
    C = phi @ np.hstack([-np.diag(w**2), -np.diag(2 * zeta * w)])
    D = (phi @ phi[inp])[:, None]
    return A, B, C, D


def frfdata(f, H, kinds, name="synthetic", band=None):
    outs = tuple(Channel(f"o{k}", q) for k, q in enumerate(kinds))
    return FRFData(name, f, H, outs, (Channel("f", "force"),), band_hz=band)


# ------------------------------------------------------------------------ the measured beam


@pytest.fixture(scope="module")
def ladisk_id():
    rec = ladisk_beam_impact()
    frf = frfs_from_time(rec.inputs, rec.outputs, rec.fs_hz, inputs=rec.input_names,
                         outputs=rec.output_names, name="ladisk")
    return identify_frfs(frf)


def test_ladisk_first_three_bending_modes(ladisk_id):
    d = ladisk_id
    assert d.data.excitation == "impact"
    top = np.sort(np.argsort(d.peak_magnitude)[::-1][:3])  # the three strongest modes
    f = d.modal.freq_hz[top]
    z = d.modal.damping_ratio[top]
    # measured here: 695.68, 1898.03, 3671.34 Hz; 0.456 %, 0.307 %, 0.197 %
    np.testing.assert_allclose(f, [695.6, 1897.9, 3671.0], rtol=0.005)
    rough = np.array([0.0046, 0.0030, 0.0020])
    assert np.all(z > rough / 2) and np.all(z < rough * 2)
    # the exponential window's sigma_w = ln(100) fs / (n - 1) was removed from each pole
    sigma_w = np.log(100.0) * 50_000.0 / (50030 - 1)
    assert d.data.window_decay_rad_s == pytest.approx(sigma_w, rel=1e-9)
    w = 2 * np.pi * f
    np.testing.assert_allclose(d.damping_ratio_uncorrected[top] - z, sigma_w / w, rtol=1e-3)
    # the residual of the slender-beam model: ratios below Euler-Bernoulli (informational)
    ratios = d.strongest_ratios(3)
    assert np.all(ratios < np.array(EULER_BERNOULLI_FREE_FREE_RATIOS))
    np.testing.assert_allclose(EULER_BERNOULLI_FREE_FREE_RATIOS, [2.757, 5.404], atol=5e-4)


def test_ladisk_through_the_lvm_file_gives_the_same_modes(ladisk_id):
    report = identify_file(SHIPPED_LVM)
    assert report.file_format == "lvm" and len(report.datasets) == 1
    d = report.datasets[0]
    assert d.data.input_labels == ("Force (Trigger)",)
    assert d.data.output_labels == ("Acceleration (Trigger)",)
    np.testing.assert_allclose(d.modal.freq_hz, ladisk_id.modal.freq_hz, rtol=1e-9)
    np.testing.assert_allclose(d.modal.damping_ratio, ladisk_id.modal.damping_ratio,
                               rtol=1e-6)
    json.dumps(report.to_dict())  # serialisable


def test_ladisk_peak_picking_agrees():
    report = identify_file(SHIPPED_LVM, method="peak", band_hz=(300, 4500), n_modes=3)
    d = report.datasets[0]
    np.testing.assert_allclose(d.modal.freq_hz, [695.6, 1897.9, 3671.0], rtol=0.005)
    rough = np.array([0.0046, 0.0030, 0.0020])
    assert np.all(d.modal.damping_ratio > rough / 2)
    assert np.all(d.modal.damping_ratio < rough * 2)


# ------------------------------------------------------------------------ FRFData and files


@pytest.fixture(scope="module")
def uff_frf_file(tmp_path_factory):
    f = np.arange(1, 801) * 0.25  # 0.25 .. 200 Hz, exact in 6 digits
    path = tmp_path_factory.mktemp("uff") / "frf.uff"
    write_uff58_frf(path, f, modal_frf(f), resp_nodes=[1, 2, 3], resp_dirs=[3, 3, 3],
                    ref_nodes=[1], ref_dirs=[3], frf_type="accelerance")
    return path


def test_uff_frf_file(uff_frf_file):
    report = identify_file(uff_frf_file, max_order=20)
    assert report.file_format == "uff"
    d = report.datasets[0]
    assert d.data.frf_type == "acceleration" and d.data.excitation == "frf"
    assert d.data.output_labels == ("1:+Z", "2:+Z", "3:+Z")
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=1e-5)
    np.testing.assert_allclose(d.modal.damping_ratio, ZETA, rtol=1e-3)
    assert np.all(np.diag(mac(PHI, d.modal.shapes)) > 0.9999)
    rows = d.table()
    assert [r["mode"] for r in rows] == [1, 2] and len(rows[0]["shape"]) == 3
    np.testing.assert_allclose(rows[1]["shape"], PHI[:, 1] / PHI[0, 1], atol=1e-4)
    frame = report.to_pandas()
    assert list(frame["mode"]) == [1, 2]


def test_uff_frf_file_peak_picking(uff_frf_file):
    d = identify_file(uff_frf_file, method="peak").datasets[0]
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=2e-3)
    np.testing.assert_allclose(d.modal.damping_ratio, ZETA, rtol=0.05)


def test_uff_receptance_file(tmp_path):
    f = np.arange(1, 801) * 0.25
    path = write_uff58_frf(tmp_path / "r.uff", f, modal_frf(f, q=0), resp_nodes=[1, 2, 3],
                           resp_dirs=[3, 3, 3], ref_nodes=[1], ref_dirs=[3],
                           frf_type="receptance")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a known type: no warning
        d = identify_file(path, max_order=20).datasets[0]
    assert d.data.frf_type == "displacement"
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=1e-5)


def test_uff_time_random_test(tmp_path):
    fs, n = 256.0, 8 * 8192
    rng = np.random.default_rng(1)
    u = rng.standard_normal(n)
    y = simulate_lti(*modal_state_space(F_HZ, ZETA, PHI[:2]), u, 1 / fs)
    y = add_sensor_noise(y, 0.01, rng)
    path = write_uff58_time(tmp_path / "time.uff", np.vstack([u, y]), 1 / fs,
                            resp_nodes=[1, 1, 2], resp_dirs=[3, 3, 3],
                            quantities=["force", "acceleration", "acceleration"],
                            resp_names=["shaker", "acc1", "acc2"], binary=True)
    d = identify_file(path).datasets[0]
    assert d.data.excitation == "random" and d.data.input_labels == ("shaker",)
    assert d.data.output_labels == ("acc1", "acc2") and d.data.n_averages == 8
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=2e-3)
    np.testing.assert_allclose(d.modal.damping_ratio, ZETA, rtol=0.1)


def impact_record(fs=2000.0, n=4000, f_hz=50.0, zeta=0.005, baseline=0.3):
    """Half-sine hammer pulse (8 samples) at sample 20 on an SDOF accelerance."""
    u = np.zeros(n)
    u[20:28] = 100.0 * np.sin(np.pi * (np.arange(8) + 0.5) / 8)
    phi = np.array([[1.0]])
    y = simulate_lti(*modal_state_space([f_hz], np.array([zeta]), phi), u, 1 / fs)
    return u + baseline, y[0]


def test_impact_exponential_window_correction(tmp_path):
    fs, n, f_hz, zeta = 2000.0, 4000, 50.0, 0.005
    u, y = impact_record(fs, n, f_hz, zeta)
    path = write_uff58_time(tmp_path / "impact.uff", np.vstack([y, u]), 1 / fs,
                            resp_nodes=[1, 1], resp_dirs=[3, 3],
                            quantities=["acceleration", "force"],
                            resp_names=["acc", "hammer"], binary=True)
    report = identify_file(path, max_order=10)
    d = report.datasets[0]
    assert d.data.excitation == "impact"
    assert any("baseline 0.3 removed" in note for note in d.data.notes)
    sigma_w = np.log(100.0) * fs / (n - 1)
    assert d.data.window_decay_rad_s == pytest.approx(sigma_w)
    assert d.n_modes == 1
    w = 2 * np.pi * f_hz
    assert d.modal.freq_hz[0] == pytest.approx(f_hz, rel=1e-4)
    # uncorrected: structure plus window, (zeta w + sigma_w) / w = 1.23 %; corrected 0.5 %
    assert d.damping_ratio_uncorrected[0] == pytest.approx(zeta + sigma_w / w, rel=0.01)
    assert d.modal.damping_ratio[0] == pytest.approx(zeta, rel=0.02)
    peak = identify_file(path, method="peak", n_modes=1).datasets[0]
    assert peak.modal.damping_ratio[0] == pytest.approx(zeta, rel=0.15)
    # options reach the time-record path: a slower window, a smaller sigma_w
    slow = identify_file(path, max_order=10, decay_to=0.1).datasets[0]
    assert slow.data.window_decay_rad_s == pytest.approx(np.log(10.0) * fs / (n - 1))
    assert slow.modal.damping_ratio[0] == pytest.approx(zeta, rel=0.02)


def test_correct_exponential_window_moves_poles_exactly():
    modal = ModalParameters(freq_hz=[10.0, 30.0], damping_ratio=[0.05, 0.02],
                            shapes=[[1.0, 1.0]])
    out = correct_exponential_window(modal, 2.0)
    s = -np.array([0.05, 0.02]) * 2 * np.pi * np.array([10.0, 30.0])
    wd = 2 * np.pi * np.array([10.0, 30.0]) * np.sqrt(1 - np.array([0.05, 0.02]) ** 2)
    s_new = (s + 2.0) + 1j * wd
    np.testing.assert_allclose(out.freq_hz, np.abs(s_new) / (2 * np.pi), rtol=1e-12)
    np.testing.assert_allclose(out.damping_ratio, -s_new.real / np.abs(s_new), rtol=1e-12)
    assert correct_exponential_window(modal, 0.0) is modal
    with pytest.raises(ValueError, match=r"decay more slowly .* than the window adds"):
        correct_exponential_window(modal, 5.0)


def test_identify_frfs_uses_the_data_band_and_drops_0_hz():
    f = np.arange(0, 1025) * 0.125  # 0 .. 128 Hz
    H = modal_frf(f, q=0)
    H[f > 100] = 1e6 * (1 + 1j)  # junk outside the excited band must not be used
    d = identify_frfs(frfdata(f, H, ["displacement"] * 3, band=(5.0, 100.0)), max_order=20)
    assert d.band_hz == (5.0, 100.0)
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=1e-5)
    np.testing.assert_allclose(d.modal.damping_ratio, ZETA, rtol=1e-3)
    assert d.modal.output_labels == ("o0", "o1", "o2")
    # without a band: every line above 0 Hz
    clean = identify_frfs(frfdata(f, modal_frf(f, q=0), ["displacement"] * 3), max_order=20)
    assert clean.band_hz == (0.125, 128.0)
    np.testing.assert_allclose(clean.modal.freq_hz, F_HZ, rtol=1e-5)


def _coherent_in(f, lo, hi, n_avg, n_ch, rng):
    """Coherence 0.999 inside [lo, hi]; outside, the coherence of uncorrelated records
    over ``n_avg`` averages (Beta(1, n_avg - 1))."""
    g = rng.beta(1.0, n_avg - 1.0, size=(f.size, n_ch, 1))
    g[(f >= lo) & (f <= hi)] = 0.999
    return g


def test_default_band_from_the_coherence():
    """A file without an excited band (a UFF from another tool): the lines where the
    coherence shows the input, not every line; outside them the H1 is noise."""
    rng = np.random.default_rng(5)
    f = np.arange(0, 1601) * 0.125  # 0 .. 200 Hz
    H = modal_frf(f, q=2)
    out = (f < 8.0) | (f > 120.0)
    H[out] = 1e3 * (rng.standard_normal(H[out].shape) + 1j * rng.standard_normal(H[out].shape))
    g = _coherent_in(f, 8.0, 120.0, 8, 3, rng)
    outs = tuple(Channel(f"o{k}", "acceleration") for k in range(3))
    data = FRFData("nb", f, H, outs, (Channel("f", "force"),), coherence=g, n_averages=8)
    assert data.band_hz is None
    # the threshold: max(0.5, 1 - (0.01 / (lines x channels))^(1 / (n_d - 1)))
    level = 1 - (0.01 / (1600 * 3)) ** (1 / 7)
    assert identify.coherence_threshold(8, 1600, 3) == pytest.approx(level, rel=1e-12)
    assert identify.coherence_threshold(None, 1600, 3) == 0.5
    assert identify.coherence_threshold(1, 1600, 3) == 0.5
    lo, hi, rule = identify.default_band(data)
    assert (lo, hi) == (8.0, 120.0) and "coherence reaches" in rule
    d = identify_frfs(data, max_order=20)
    assert d.band_hz == (8.0, 120.0) and d.band_rule == rule
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=1e-5)
    shapes = np.real(np.asarray(d.modal.shapes))
    assert np.all(np.diag(mac(shapes, PHI)) > 0.9999)
    # every line above 0 Hz (the rule before) fits the noise and loses the shapes
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # it may find nothing stable at all
        every = identify_frfs(data, max_order=20, band_hz=(0.125, 200.0))
    assert every.n_modes != 2 or np.min(np.diag(mac(np.real(np.asarray(
        every.modal.shapes)), PHI))) < 0.99


def test_default_band_rules_in_order():
    f = np.arange(0, 801) * 0.25
    H = modal_frf(f, q=0)
    rng = np.random.default_rng(0)
    g = _coherent_in(f, 10.0, 150.0, 4, 3, rng)
    outs = tuple(Channel(f"o{k}", "displacement") for k in range(3))
    ins = (Channel("f", "force"),)
    # 1. the data's own band wins over its coherence
    d = FRFData("a", f, H, outs, ins, coherence=g, n_averages=4, band_hz=(5.0, 100.0))
    assert identify.default_band(d) == (5.0, 100.0, "the data's excited band")
    # 2. the coherence, with the averages unknown: 0.5
    d = FRFData("b", f, H, outs, ins, coherence=g)
    lo, hi, rule = identify.default_band(d)
    assert lo <= 10.0 and hi >= 150.0 and "averages unknown" in rule
    # 3. neither: every line above 0 Hz, and the rule says to give a band
    d = FRFData("c", f, H, outs, ins)
    lo, hi, rule = identify.default_band(d)
    assert (lo, hi) == (0.25, 200.0) and "--band" in rule
    report = identify_frfs(d, max_order=20).band_rule
    assert report == rule


def test_no_mode_in_the_band_is_an_empty_result():
    f = np.arange(0, 1025) * 0.125
    flat = np.ones((f.size, 1, 1), complex)  # no resonance at all
    with pytest.warns(UserWarning, match="no pole is stable"):
        d = identify_frfs(frfdata(f, flat, ["acceleration"]), max_order=10)
    assert d.n_modes == 0 and d.peak_magnitude.shape == (0,) and d.table() == []


def test_mixed_and_strain_outputs_become_displacement_equivalent():
    f = np.arange(0, 1025) * 0.125
    H = np.concatenate([modal_frf(f, q=2)[:, :1], modal_frf(f, q=0)[:, 1:2]], axis=1)
    d = identify_frfs(frfdata(f, H, ["acceleration", "strain"], band=(5.0, 100.0)),
                      max_order=20)
    assert d.data.frf_type == "displacement" and d.data.freq_hz[0] > 0
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=1e-5)
    np.testing.assert_allclose(d.modal.damping_ratio, ZETA, rtol=1e-3)
    strain = identify_frfs(frfdata(f, modal_frf(f, q=0), ["strain"] * 3, band=(5.0, 100.0)),
                           max_order=20)
    assert strain.data.frf_type == "displacement"
    np.testing.assert_allclose(strain.modal.freq_hz, F_HZ, rtol=1e-5)


def write_results_h5(path, outputs, H, f, band=(5.0, 100.0), single_test_of_trial=None):
    """A results file (or, with single_test_of_trial=k, the single-test file of
    'truthbench simulate') holding FRFs ``H`` of one test, written by the store itself.
    Output labels are ``station.direction.qty`` on a hand-made plant with stations a, b
    and the hub-less root."""
    from truthbench.campaign.plan import CampaignPlan
    from truthbench.campaign.results import CampaignResult, TestRecord, TrialResult
    from truthbench.campaign.spec import parse_campaign
    from truthbench.campaign.store import write_results, write_test_record
    from truthbench.measure.frfdata import FRFData

    qty = {"acc": "acceleration", "str": "strain"}
    sensors = [{"station": lab.split(".")[0], "direction": lab.split(".")[1],
                "quantity": qty[lab.split(".")[2]]} for lab in outputs]
    spec = parse_campaign({
        "campaign": {"name": "hand", "seed": 1},
        "plant": {"type": "free_free_beam", "n_elements": 4,
                  "stations": {"a": 0.0, "b": 0.5, "root": 0.25}},
        "sensors": sensors,
        "tests": [{"name": "t1", "band_hz": list(band), "fs_hz": 256.0, "record_s": 8.0,
                   "averages": 1, "actuators": [{"station": "a", "direction": "z"}]}],
        "update": {"method": "none"}, "identify": {"enabled": False}})
    test = CampaignPlan.compile(spec).tests[0]
    outs, ins = test.outputs, test.inputs
    frf = FRFData("t1", f, H, outs, ins, band_hz=band)
    empty = np.zeros((0, 0))
    record = TestRecord("t1", frf, empty, empty, 256.0, {})
    if single_test_of_trial is not None:
        return write_test_record(record, path, spec=spec, seed=1, trial=single_test_of_trial)
    trial = TrialResult(0, (record,), {})
    return write_results(CampaignResult(spec, 1, "0.1.0", spec.nominal_parameters(),
                                        (trial,)), path)


def test_results_file_uses_the_stored_band(tmp_path):
    f = np.arange(0, 1025) * 0.125  # 0 .. 128 Hz
    H = modal_frf(f)[:, :2]
    H[f > 100] = 1e6 * (1 + 1j)  # junk outside the excited band must not be used
    H[-5:] = np.nan  # H1 is NaN where the input spectrum is singular (outside the band)
    path = write_results_h5(tmp_path / "r.h5", ["a.z.acc", "b.z.acc"], H, f)
    report = identify_file(path, max_order=20)
    assert report.file_format == "hdf5"
    d = report.datasets[0]
    assert d.data.name == "trial 0 / t1" and d.band_hz == (5.0, 100.0)
    assert [c.station for c in d.data.outputs] == ["a", "b"]
    assert d.data.outputs[1].coordinates_m == (0.9, 0.0, 0.0)  # b at half of 1.8 m
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=1e-5)
    np.testing.assert_allclose(d.modal.damping_ratio, ZETA, rtol=1e-3)


def test_single_test_file_of_truthbench_simulate(tmp_path):
    f = np.arange(0, 1025) * 0.125
    path = write_results_h5(tmp_path / "one.h5", ["a.z.acc", "b.z.acc"], modal_frf(f)[:, :2],
                            f, single_test_of_trial=2)
    d = identify_file(path, max_order=20).datasets[0]
    assert d.data.name == "trial 2 / t1" and d.band_hz == (5.0, 100.0)
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=1e-5)


def test_non_finite_lines_in_the_band_are_left_out_with_a_warning(tmp_path):
    f = np.arange(0, 1025) * 0.125
    H = modal_frf(f)[:, :2]
    H[400:403] = np.nan  # 50.0 .. 50.25 Hz
    path = write_results_h5(tmp_path / "nan.h5", ["a.z.acc", "b.z.acc"], H, f)
    with pytest.warns(UserWarning, match=r"nan\.h5: 3 line\(s\) of 'trial 0 / t1' in the "
                                         r"band 5-100 Hz hold non-finite FRF values"):
        d = identify_file(path, max_order=20).datasets[0]
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=1e-5)


def test_results_file_with_mixed_outputs(tmp_path):
    f = np.arange(0, 1025) * 0.125
    H = np.concatenate([modal_frf(f, q=2)[:, :1], modal_frf(f, q=0)[:, 1:2]], axis=1)
    path = write_results_h5(tmp_path / "m.hdf5", ["a.z.acc", "root.y.str"], H, f)
    d = identify_file(path, max_order=20).datasets[0]
    assert d.data.frf_type == "displacement" and d.data.freq_hz[0] > 0
    np.testing.assert_allclose(d.modal.freq_hz, F_HZ, rtol=1e-5)
    np.testing.assert_allclose(d.modal.damping_ratio, ZETA, rtol=1e-3)


# ------------------------------------------------------------------------ bad input


def test_corrupt_uff(uff_frf_file, tmp_path):
    cut = tmp_path / "cut.uff"
    cut.write_bytes(uff_frf_file.read_bytes()[:-300])
    with pytest.raises(DataFormatError, match=r"cut\.uff: truncated or corrupt UFF file"):
        identify_file(cut)


def test_band_outside_the_data(uff_frf_file):
    with pytest.raises(ValueError, match=r"frf\.uff: band 300-400 Hz lies outside the data "
                                         r"of 'frf', which spans 0\.25-200 Hz"):
        identify_file(uff_frf_file, band_hz=(300, 400))
    with pytest.raises(ValueError, match=r"band 10-10\.5 Hz holds 3 frequency lines"):
        identify_file(uff_frf_file, band_hz=(10, 10.5))
    with pytest.raises(ValueError, match=r"band must satisfy 0 <= low < high"):
        identify_file(uff_frf_file, band_hz=(50, 20))
    with pytest.raises(ValueError, match=r"band must be two frequencies"):
        identify_file(uff_frf_file, band_hz=50)


def test_other_bad_input(tmp_path, uff_frf_file):
    with pytest.raises(FileNotFoundError, match="nothere.lvm: no such data file"):
        identify_file(tmp_path / "nothere.lvm")
    other = tmp_path / "data.txt"
    other.write_text("1 2 3\n")
    with pytest.raises(DataFormatError, match=r"data\.txt: unknown file extension '\.txt'"):
        identify_file(other)
    not_results = tmp_path / "x.h5"
    with h5py.File(not_results, "w") as h:
        h.attrs["format"] = "something else"
    with pytest.raises(DataFormatError, match=r"x\.h5: not a truthbench results file"):
        identify_file(not_results)
    with pytest.raises(ValueError,
                       match=r"unknown identifier 'circle'; expected one of \['peak', 'plscf'\]"):
        identify_file(uff_frf_file, method="circle")
    with pytest.raises(ValueError, match="'max_order' must be an integer >= 2 and <= 200"):
        identify_file(uff_frf_file, max_order=1)
    with pytest.raises(ValueError, match=r"x\.h5: the \.h5 reader .* takes no option\(s\) "
                                         r"\['decay_to'\]"):
        identify_file(not_results, decay_to=0.1)
