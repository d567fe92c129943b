"""Several data files as acquisition systems export them (io.measurements, with
io.uff_frf.read_uff_files): coherence files paired with their FRF sets, excitation levels.

Oracles: files written with pyuff directly (not our writer) in mm and kN, with dataset
164, 2411 points and three load cases, from FRFs and coherences whose SI values we know
and that differ set by set (a coherence paired with the wrong FRF set is off by far more
than round-off).

Tolerances (as in test_uff_frf): ASCII dataset 58 keeps 12 significant digits per part
(5e-12 relative); a unit conversion adds at most 8 ulp.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import pyuff

from truthbench.cli import main
from truthbench.diagnose.candidates import with_node_stations
from truthbench.effects import realise
from truthbench.errors import DataFormatError
from truthbench.io import load_measurements, read_uff, read_uff_files
from truthbench.plants import Actuator, Sensor

from .test_uff_frf import RTOL_ASCII, RTOL_UNITS, assert_parts_close

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "campaigns" / "steel_tube.toml"
LENGTH, FORCE = 1000.0, 1e-3  # file units per metre, per newton (mm, kN)
FREQ = np.arange(1, 21) * 25.0  # 25-500 Hz: exact in the 6 digits of an ASCII axis
# points (UFF node numbers, not the model's) at nodes 0, 6, 12 and 1 of the steel tube
# (24 elements of 0.05 m); responses z, -z, z; references z at points 104 and 102
POINTS = {101: 0.0, 102: 0.3, 103: 0.6, 104: 0.05}
RESP = [(101, 3), (102, -3), (103, 3)]
REF = [(104, 3), (102, 3)]
CASES = (1, 2, 3)


def _model_frf():
    """The steel tube's FRFs (m/s^2 per N) at the points, along each channel's sense."""
    from truthbench.campaign.model_file import load_model

    spec = load_model(MODEL)
    plant = with_node_stations(spec.make_plant())
    node = {p: round(x / 0.05) for p, x in POINTS.items()}
    hw = realise(plant, spec.nominal_parameters(),
                 actuators=[Actuator(f"n{node[p]}", "z") for p, _ in REF],
                 sensors=[Sensor(f"n{node[p]}", "z") for p, _ in RESP])
    sign = np.array([np.sign(d) for _, d in RESP], float)
    return hw.frf(FREQ) * sign[None, :, None]


@pytest.fixture(scope="module")
def truth():
    """SI FRFs and coherences of the three load cases: the model's FRF with 1 % noise
    and a coherence drawn per set."""
    rng = np.random.default_rng(11)
    H0 = _model_frf()
    H, coh = {}, {}
    for lc in CASES:
        noise = rng.standard_normal(H0.shape) + 1j * rng.standard_normal(H0.shape)
        H[lc] = H0 * (1 + 0.01 * noise)
        coh[lc] = rng.uniform(0.5, 0.999, H0.shape)
    return H, coh


def _common(lc, i, j, func_type, x=FREQ):
    return {"type": 58, "func_type": func_type, "load_case_id": lc,
            "rsp_node": RESP[i][0], "rsp_dir": RESP[i][1], "ref_node": REF[j][0],
            "ref_dir": REF[j][1], "rsp_ent_name": f"acc{i}", "ref_ent_name": "shaker",
            "id1": f"{'FRF' if func_type == 4 else 'COH'} {RESP[i][0]}/{REF[j][0]}",
            "abscissa_spacing": 1, "abscissa_spec_data_type": 18,
            "abscissa_axis_units_lab": "Hz", "x": np.array(x, float)}


def frf_file(path, H, cases=CASES, *, coherence=None):
    """FRF sets of ``cases`` in mm/s^2 per kN with 164 and 2411 (pyuff), and their
    coherence sets when ``coherence`` is given."""
    sets = [pyuff.prepare_164(units_code=9, units_description="mm kN", temp_mode=1,
                              length=LENGTH, force=FORCE, temp=1.0, temp_offset=273.15)]
    nums = list(POINTS)
    sets.append(pyuff.prepare_2411(
        node_nums=np.array(nums), def_cs=np.zeros(len(nums), int),
        disp_cs=np.zeros(len(nums), int), color=np.ones(len(nums), int),
        x=np.array([POINTS[n] for n in nums]) * LENGTH, y=np.zeros(len(nums)),
        z=np.zeros(len(nums))))
    for lc in cases:
        for j in range(len(REF)):
            for i in range(len(RESP)):
                sets.append({**_common(lc, i, j, 4), "ordinate_spec_data_type": 12,
                             "ordinate_axis_units_lab": "mm/s^2",
                             "orddenom_spec_data_type": 13, "orddenom_axis_units_lab": "kN",
                             "data": H[lc][:, i, j] * (LENGTH / FORCE)})
                if coherence is not None:
                    sets.append({**_common(lc, i, j, 6), "ordinate_spec_data_type": 0,
                                 "orddenom_spec_data_type": 0,
                                 "data": coherence[lc][:, i, j].copy()})
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


def coh_file(path, coh, keys, **changes):
    """Coherence sets only (pyuff), one per (load case, i, j) of ``keys`` in that order
    (datasets 0, 1, ... of the file); ``changes`` maps such a key to fields that replace
    the set's own."""
    sets = []
    for key in keys:
        s = {**_common(*key, 6), "ordinate_spec_data_type": 0, "orddenom_spec_data_type": 0,
             "ordinate_axis_units_lab": "NONE", "data": coh[key[0]][:, key[1], key[2]].copy()}
        s.update(changes.get(str(key), {}))
        sets.append(s)
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


def all_keys():
    return [(lc, i, j) for lc in CASES for i in range(len(RESP)) for j in range(len(REF))]


def shuffled(seed=5):
    keys = all_keys()
    return [keys[k] for k in np.random.default_rng(seed).permutation(len(keys))]


def check(data, H, coh, cases=CASES):
    """Each FRFData is its load case: SI values, coherence set by set, points, signs."""
    assert len(data) == len(cases)
    for d, lc in zip(data, cases, strict=True):
        assert_parts_close(d.H, H[lc], RTOL_UNITS)
        for i in range(len(RESP)):
            for j in range(len(REF)):
                np.testing.assert_allclose(d.coherence[:, i, j], coh[lc][:, i, j],
                                           rtol=RTOL_ASCII, atol=0)
        assert [c.point for c in d.outputs] == [101, 102, 103]
        assert [c.sign for c in d.outputs] == [1, -1, 1]
        assert [c.point for c in d.inputs] == [104, 102]
        assert d.inputs[0].coordinates_m == pytest.approx((0.05, 0.0, 0.0), rel=4e-16)


# ======================================================================== pairing


def test_a_coherence_file_in_another_order_is_paired_set_by_set(tmp_path, truth):
    H, coh = truth
    frf = frf_file(tmp_path / "frf.uff", H)
    c = coh_file(tmp_path / "coh.uff", coh, shuffled())
    data = load_measurements([frf, c])
    check(data, H, coh)
    assert [d.name for d in data] == [f"frf load case {lc}" for lc in CASES]
    assert all(d.input_rms is None for d in data)
    assert "coherence (function type 6) from coh.uff" in data[0].notes
    # the order of the files does not matter; read_uff_files gives () for the coherence
    again = load_measurements([c, frf])
    for a, b in zip(data, again, strict=True):
        np.testing.assert_array_equal(a.coherence, b.coherence)
    out = read_uff_files([c, frf])
    assert out[0] == () and len(out[1]) == 3


def test_coherence_files_pair_across_several_frf_files(tmp_path, truth):
    H, coh = truth
    a = frf_file(tmp_path / "a.uff", H, cases=(1, 2))
    b = frf_file(tmp_path / "b.uff", H, cases=(3,))
    keys = shuffled(seed=9)
    c1 = coh_file(tmp_path / "c1.uff", coh, keys[:7])
    c2 = coh_file(tmp_path / "c2.unv", coh, keys[7:])
    data = load_measurements([c2, a, c1, b])
    check(data, H, coh)
    assert [d.name for d in data] == ["a load case 1", "a load case 2", "b"]


def test_an_frf_without_coherence_keeps_none(tmp_path, truth):
    H, coh = truth
    a = frf_file(tmp_path / "a.uff", H, cases=(1, 2))
    b = frf_file(tmp_path / "b.uff", H, cases=(3,))
    c = coh_file(tmp_path / "c.uff", coh, [k for k in shuffled() if k[0] != 3])
    data = load_measurements([a, b, c])
    check(data[:2], H, coh, cases=(1, 2))
    assert data[2].coherence is None
    # and a file's own coherence sets pair with its own FRF sets
    own = frf_file(tmp_path / "own.uff", H, coherence=coh)
    check(load_measurements([own]), H, coh)


def test_load_cases_that_share_an_id_line_1_get_their_load_case_in_the_name(tmp_path,
                                                                            truth):
    H, _ = truth
    path = tmp_path / "same.uff"
    sets = [pyuff.prepare_164(units_code=9, units_description="mm kN", temp_mode=1,
                              length=LENGTH, force=FORCE, temp=1.0, temp_offset=273.15)]
    for lc in (1, 2):
        for j in range(len(REF)):
            for i in range(len(RESP)):
                sets.append({**_common(lc, i, j, 4), "id1": "run", "ordinate_spec_data_type": 12,
                             "orddenom_spec_data_type": 13,
                             "data": H[lc][:, i, j] * (LENGTH / FORCE)})
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    assert [d.name for d in read_uff(path)] == ["run load case 1", "run load case 2"]


# ======================================================================== bad pairs


def _match(path, rest):
    return re.escape(str(path)) + rest


def test_a_coherence_set_on_other_lines_names_both_files_the_set_and_both_grids(tmp_path,
                                                                              truth):
    H, coh = truth
    frf = frf_file(tmp_path / "frf.uff", H)
    keys = all_keys()
    bad = coh_file(tmp_path / "coh.uff", coh, keys,
                   **{str(keys[4]): {"x": FREQ * 2, "id1": "COH shifted"}})
    with pytest.raises(DataFormatError, match=_match(
            bad, r": dataset 4 \(load case 1, response node 103 dir 3, reference node 104 "
                 r"dir 3\): the coherence set spans 20 lines 50-1000 Hz, step 50 Hz, the FRF "
                 r"sets of " + re.escape(str(frf)) + r" 20 lines 25-500 Hz, step 25 Hz; "
                 r"expected the same lines")):
        load_measurements([frf, bad])


def test_a_coherence_set_of_no_frf_pair_is_named(tmp_path, truth):
    H, coh = truth
    frf = frf_file(tmp_path / "frf.uff", H, cases=(1, 2))
    c = coh_file(tmp_path / "coh.uff", coh, [(3, 1, 1), *all_keys()[:12]])
    with pytest.raises(DataFormatError, match=_match(
            c, r": dataset 0 \(load case 3, response node 102 dir -3, reference node 102 "
               r"dir 3\): this coherence set pairs with no FRF set of "
               + re.escape(str(frf)))):
        read_uff_files([frf, c])
    # an unknown node, in the one-file reader as well
    odd = coh_file(tmp_path / "odd.uff", coh, all_keys()[:6],
                   **{str((1, 2, 1)): {"rsp_node": 999}})
    with pytest.raises(DataFormatError, match=_match(odd, r": dataset 5 \(load case 1, "
                                                          r"response node 999 dir 3")):
        read_uff(frf_file(tmp_path / "one.uff", H, cases=(1,)), coherence=odd)


def test_an_frf_pair_with_two_coherence_sets_is_named(tmp_path, truth):
    H, coh = truth
    frf = frf_file(tmp_path / "frf.uff", H)
    c1 = coh_file(tmp_path / "c1.uff", coh, all_keys())
    c2 = coh_file(tmp_path / "c2.uff", coh, [(2, 1, 0)])
    with pytest.raises(DataFormatError, match=_match(
            c2, r": dataset 0 \(load case 2, response node 102 dir -3, reference node 104 "
                r"dir 3\): a second coherence set of this FRF pair \(the first is "
                + re.escape(str(c1)) + r": dataset 8\)")):
        load_measurements([frf, c1, c2])
    own = frf_file(tmp_path / "own.uff", H, coherence=coh)
    with pytest.raises(DataFormatError, match=_match(
            own, r": dataset \d+ \(load case 2, response node 102 dir -3, reference node "
                 r"104 dir 3\): this FRF pair has a second coherence set in "
                 + re.escape(str(c2)) + r" \(dataset 0\)")):
        load_measurements([own, c2])


def test_a_coherence_set_that_pairs_with_two_frf_files_is_named(tmp_path, truth):
    H, coh = truth
    a = frf_file(tmp_path / "a.uff", H, cases=(1,))
    b = frf_file(tmp_path / "b.uff", H, cases=(1,))
    c = coh_file(tmp_path / "c.uff", coh, all_keys()[:6])
    with pytest.raises(DataFormatError, match=_match(c, r": dataset \d+ .* pairs with FRF sets "
                                                        r"of both ") + re.escape(str(a))):
        load_measurements([a, b, c])


@pytest.mark.parametrize("value", [1.2, -0.1, "nan"])
def test_coherence_outside_0_1_is_an_error(tmp_path, truth, value):
    H, coh = truth
    frf = frf_file(tmp_path / "frf.uff", H)
    data = coh[2][:, 0, 1].copy()
    data[3] = 0.123456789 if value == "nan" else value
    c = coh_file(tmp_path / "c.uff", coh, all_keys(), **{str((2, 0, 1)): {"data": data}})
    if value == "nan":  # pyuff writes NaN as 0: put it in the text
        text = c.read_text()
        assert text.count("1.23456789000e-01") == 1
        c.write_text(text.replace("1.23456789000e-01", "              nan"))
    with pytest.raises(DataFormatError, match=_match(
            c, r": dataset 7 \(load case 2, response node 101 dir 3, reference node 102 dir "
               r"3\): coherence " + re.escape(repr(float(value))) + r" at 100 Hz \(1 value\(s\) "
               r"outside \[0, 1\]\); expected an ordinary coherence in \[0, 1\]")):
        load_measurements([frf, c])


def test_a_coherence_file_that_leaves_out_pairs_of_a_load_case(tmp_path, truth):
    H, coh = truth
    frf = frf_file(tmp_path / "frf.uff", H, cases=(1,))
    c = coh_file(tmp_path / "c.uff", coh, all_keys()[:5])
    with pytest.raises(DataFormatError, match=_match(
            c, r": load case 1: the coherence sets leave out the \(node, dir\) pairs "
               r"\['resp \(103, 3\) / ref \(102, 3\)'\] of the FRF sets of ")):
        load_measurements([frf, c])


def test_a_coherence_file_alone(tmp_path, truth):
    _, coh = truth
    c = coh_file(tmp_path / "c.uff", coh, all_keys())
    with pytest.raises(DataFormatError, match=_match(c, r": holds only coherence sets")):
        load_measurements([c])
    with pytest.raises(DataFormatError, match=_match(c, r": holds only coherence sets .*give "
                                                        r"it with the file of its FRF sets")):
        read_uff(c)


def test_a_file_given_twice_and_options(tmp_path, truth):
    H, _ = truth
    frf = frf_file(tmp_path / "frf.uff", H)
    with pytest.raises(DataFormatError, match=r"given twice"):
        load_measurements([frf, tmp_path / "." / "frf.uff"])
    with pytest.raises(ValueError, match=r"takes no option 'coherence'"):
        load_measurements([frf], coherence=frf)
    with pytest.raises(ValueError, match=r"no reader of the files given takes option 'trials'"):
        load_measurements([frf], trials=[0])
    with pytest.raises(ValueError, match="no data file given"):
        load_measurements([])


# ======================================================================== levels


def test_input_levels_by_data_set_name(tmp_path, truth):
    H, coh = truth
    frf = frf_file(tmp_path / "frf.uff", H)
    c = coh_file(tmp_path / "coh.uff", coh, shuffled())
    levels = {"frf load case 1": 0.5, "frf load case 2": [1.0, 1.5], "frf load case 3": 4}
    data = load_measurements([frf, c], input_rms_n=levels)
    assert [d.input_rms for d in data] == [(0.5, 0.5), (1.0, 1.5), (4.0, 4.0)]
    assert all(d.band_hz == (25.0, 500.0) for d in data)  # the file states none: its lines
    assert "input RMS 1, 1.5 from input_rms_n" in data[1].notes
    with pytest.raises(DataFormatError, match=re.escape(
            "m.toml: key 'diagnose.input_rms_n': 'frf' names no data set: the names given "
            "are ['frf'], the data sets are ['frf load case 1', 'frf load case 2', "
            "'frf load case 3']; expected data-set names")):
        load_measurements([frf, c], input_rms_n={"frf": 1.0},
                          levels_from="m.toml: key 'diagnose.input_rms_n'")
    with pytest.raises(DataFormatError, match=re.escape(
            "input_rms_n 'frf load case 2': 3 level(s) [1.0, 2.0, 3.0] for data set "
            "'frf load case 2' of 2 input(s) ['104:+Z', '102:+Z']; expected one number")):
        load_measurements([frf], input_rms_n={"frf load case 2": [1.0, 2.0, 3.0]})
    with pytest.raises(ValueError, match=r"'input RMS' must be a finite number > 0; got -1"):
        load_measurements([frf], input_rms_n={"frf load case 2": -1})


def test_one_name_from_two_files_is_kept_apart_by_the_path(tmp_path, truth):
    H, _ = truth
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = frf_file(tmp_path / "a" / "run.uff", H, cases=(1,))
    b = frf_file(tmp_path / "b" / "run.uff", H, cases=(2,))
    data = load_measurements([a, b], input_rms_n={f"run ({b})": 2.0})
    assert [d.name for d in data] == [f"run ({a})", f"run ({b})"]
    assert data[0].input_rms is None and data[1].input_rms == (2.0, 2.0)


# ======================================================================== the command


def _diagnose_json(capsys, *argv):
    code = main(["diagnose", *map(str, argv), "--json", "--max-effects", "1"])
    out = capsys.readouterr()
    assert code == 0, out.err
    return json.loads(out.out)


def _model_with_levels(tmp_path, levels: str):
    model = tmp_path / "m.toml"
    shutil.copy(MODEL, model)
    with model.open("a") as fh:
        fh.write(f"\n[diagnose]\ninput_rms_n = {{ {levels} }}\n")
    return model


def test_the_command_accepts_the_coherence_file(tmp_path, truth, capsys):
    H, coh = truth
    frf = frf_file(tmp_path / "frf.uff", H)
    c = coh_file(tmp_path / "coh.uff", coh, shuffled())
    d = _diagnose_json(capsys, frf, c, "--model", MODEL, "--candidate", "time_delay")
    assert d["settings"]["candidates"] == ["time_delay"]
    # the model's FRFs with 1 % noise: nothing missing
    assert d["found"] == []
    # a level for a name that matches no data set: exit 2, the key and names named
    model = _model_with_levels(tmp_path, '"frf load case 9" = 1.0')
    assert main(["diagnose", str(frf), str(c), "--model", str(model)]) == 2
    err = capsys.readouterr().err
    assert (f"{model}: key 'diagnose.input_rms_n': 'frf load case 9' names no data set: the "
            f"names given are ['frf load case 9'], the data sets are ['frf load case 1', "
            f"'frf load case 2', 'frf load case 3']") in err


def test_the_command_tries_friction_with_the_model_files_levels(tmp_path, truth, capsys):
    """Friction is tried only when every test's level is known, and the result says why
    it was not. (The model explains these data within their noise, so the search stops
    before screening anything: what is checked is the catalogue.)"""
    H, coh = truth
    frf = frf_file(tmp_path / "frf.uff", H)
    c = coh_file(tmp_path / "coh.uff", coh, shuffled())
    d = _diagnose_json(capsys, frf, c, "--model", MODEL, "--candidate", "coulomb_friction")
    (skipped,) = d["not_tried"]
    assert skipped["effect"] == "coulomb_friction"
    assert "input level of test(s) ['frf load case 1', 'frf load case 2', 'frf load " \
           "case 3'] is not known" in skipped["reason"] and "input_rms_n" in skipped["reason"]
    model = _model_with_levels(tmp_path, '"frf load case 1" = 0.5, "frf load case 2" = 1.0')
    d = _diagnose_json(capsys, frf, c, "--model", model, "--candidate", "coulomb_friction")
    assert "['frf load case 3'] is not known" in d["not_tried"][0]["reason"]
    model = _model_with_levels(tmp_path, '"frf load case 1" = 0.5, "frf load case 2" = 1.0, '
                                         '"frf load case 3" = [2.0, 2.5]')
    d = _diagnose_json(capsys, frf, c, "--model", model, "--candidate", "coulomb_friction")
    assert d["not_tried"] == []
