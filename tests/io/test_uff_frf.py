"""FRFData <-> UFF (io.uff_frf): write_uff / read_uff, units (164), points (2411).

Oracles: files written with pyuff directly (not our writer) in non-SI unit systems from
FRFs whose SI values we know; pyuff reading our files; the arithmetic of the formats.

Tolerances. ASCII dataset 58 writes each real and imaginary part as ``%20.11e``: 12
significant digits, a relative error of at most 5e-12 of that part. A unit conversion
adds a few roundings (the file value times the factor, the factor itself): at most 8 ulp
more, so parts are compared with ``rtol = 5e-12 + 8 eps``. Coherence values are written
the same way (5e-12). Dataset 2411 writes coordinates as ``%25.16e`` (17 digits: exact);
converted from mm or inch they pick up 2 roundings (4 eps). Binary ("58b") is exact.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
import pyuff

from truthbench.errors import DataFormatError
from truthbench.io import load_frf, number_points, read_uff, write_uff
from truthbench.io._uff58 import write_uff58_time
from truthbench.measure import Channel, FRFData, estimate_frf, match_points
from truthbench.plants import make_plant
from truthbench.simulate import simulate_lti

EPS = np.finfo(float).eps
RTOL_ASCII = 5e-12
RTOL_UNITS = 5e-12 + 8 * EPS


def assert_parts_close(actual, desired, rtol):
    """Real and imaginary parts each within ``rtol`` of themselves."""
    actual, desired = np.asarray(actual), np.asarray(desired)
    for part in (np.real, np.imag):
        a, d = part(actual), part(desired)
        assert np.all(np.abs(a - d) <= rtol * np.abs(d)), np.max(np.abs(a - d) / np.abs(d))


def synthetic(name="t", n_freq=64, seed=0, coherence=True, **kw):
    rng = np.random.default_rng(seed)
    f = np.arange(n_freq) * 0.5
    outs = (Channel("tip.z.acc", "acceleration", "z", station="tip",
                    coordinates_m=(1.8, 0.0, 0.0)),
            Channel("mid.y.vel", "velocity", "y", sign=-1, station="mid",
                    coordinates_m=(0.9, 0.0, 0.0)),
            Channel("root.rz.dis", "displacement", "rz", station="root",
                    coordinates_m=(0.0, 0.0, 0.0)),
            Channel("root.y.str", "strain", "y", station="root", coordinates_m=(0.0, 0, 0)))
    ins = (Channel("tip.z", "force", "z", station="tip", coordinates_m=(1.8, 0.0, 0.0)),
           Channel("root.rx", "force", "rx", station="root", coordinates_m=(0.0, 0.0, 0.0)))
    shape = (n_freq, len(outs), len(ins))
    H = 10.0 ** rng.uniform(-4, 4, shape) * (rng.standard_normal(shape)
                                               + 1j * rng.standard_normal(shape))
    coh = rng.uniform(0, 1, shape) if coherence else None
    return FRFData(name, f, H, outs, ins, coherence=coh, **kw)


# ======================================================================== our round trip


@pytest.mark.parametrize("binary", [False, True])
def test_write_read_round_trip(tmp_path, binary):
    a = synthetic("trial 0 / one", n_averages=8, band_hz=(2.0, 30.0))
    b = synthetic("trial 1 / two", seed=1, coherence=False, excitation="impact",
                  window_decay_rad_s=9.210340371976184)
    path = write_uff(tmp_path / "rt.uff", [a, b], binary=binary)
    back = read_uff(path)
    assert len(back) == 2
    for want, got in zip((a, b), back, strict=True):
        assert got.name == want.name
        np.testing.assert_array_equal(got.freq_hz, want.freq_hz)  # 0.5 Hz steps: exact
        if binary:
            np.testing.assert_array_equal(got.H, want.H)
        else:
            assert_parts_close(got.H, want.H, RTOL_ASCII)
        assert got.output_labels == want.output_labels
        assert got.input_labels == want.input_labels
        for g, w in zip((*got.outputs, *got.inputs), (*want.outputs, *want.inputs),
                        strict=True):
            assert (g.quantity, g.direction, g.sign, g.station, g.coordinates_m) == (
                w.quantity, w.direction, w.sign, w.station, w.coordinates_m)
        assert (got.band_hz, got.n_averages, got.excitation, got.window_decay_rad_s) == (
            want.band_hz, want.n_averages, want.excitation, want.window_decay_rad_s)
    if binary:
        np.testing.assert_array_equal(back[0].coherence, a.coherence)
    else:
        np.testing.assert_allclose(back[0].coherence, a.coherence, rtol=RTOL_ASCII, atol=0)
    assert back[1].coherence is None
    # the point numbering rule: distinct coordinates sorted by (x, y, z) -> 1, 2, 3
    assert [c.point for c in back[0].outputs] == [3, 2, 1, 1]
    assert [c.point for c in back[0].inputs] == [3, 1]


def test_pyuff_reads_what_we_write(tmp_path):
    d = synthetic("check")
    path = write_uff(tmp_path / "p.uff", d)
    sets = pyuff.UFF(str(path)).read_sets()
    assert [s["type"] for s in sets[:3]] == [151, 164, 2411]
    assert sets[1]["units_code"] == 1 and sets[1]["length"] == sets[1]["force"] == 1.0
    np.testing.assert_array_equal(sets[2]["node_nums"], [1, 2, 3])
    np.testing.assert_array_equal(sets[2]["x"], [0.0, 0.9, 1.8])
    frf = [s for s in sets if s["type"] == 58 and s["func_type"] == 4]
    coh = [s for s in sets if s["type"] == 58 and s["func_type"] == 6]
    assert len(frf) == len(coh) == 8
    code = {"x": 1, "y": 2, "z": 3, "rx": 4, "ry": 5, "rz": 6}
    points = number_points(d)
    for s in frf:
        i = [k for k, c in enumerate(d.outputs)
             if (points.outputs[0][k], code[c.direction] * c.sign) == (s["rsp_node"],
                                                                       s["rsp_dir"])]
        j = [k for k, c in enumerate(d.inputs)
             if (points.inputs[0][k], code[c.direction]) == (s["ref_node"], s["ref_dir"])]
        assert len(i) == len(j) == 1
        assert_parts_close(s["data"], d.H[:, i[0], j[0]], RTOL_ASCII)
        assert s["ordinate_spec_data_type"] == {"acceleration": 12, "velocity": 11,
                                                "displacement": 8, "strain": 3}[
                                                    d.outputs[i[0]].quantity]
        assert s["orddenom_spec_data_type"] == 13
        assert s["ordinate_axis_units_lab"] == d.outputs[i[0]].unit
        assert s["orddenom_axis_units_lab"] == d.inputs[j[0]].unit  # N or N m


def test_point_numbers_read_from_a_file_are_kept(tmp_path):
    d = synthetic("p")
    first = read_uff(write_uff(tmp_path / "a.uff", d))[0]
    renumbered = FRFData(first.name, first.freq_hz, first.H,
                         tuple(_with_point(c, 10 * c.point) for c in first.outputs),
                         tuple(_with_point(c, 10 * c.point) for c in first.inputs))
    again = read_uff(write_uff(tmp_path / "b.uff", renumbered))[0]
    assert [c.point for c in again.outputs] == [30, 20, 10, 10]
    # without points: channels without coordinates numbered by station, then label
    bare = FRFData("b", d.freq_hz, d.H[:, :2, :1],
                   (Channel("a", "acceleration", "z", station="s1"),
                    Channel("b", "acceleration", "z")),
                   (Channel("f", "force", "z", station="s1"),))
    pts = number_points(bare)
    assert pts.outputs == ((1, 2),) and pts.inputs == ((1,),)
    assert dict(pts.coordinates_m) == {1: None, 2: None}


def test_other_function_types_are_left_out_with_a_note(tmp_path):
    path = write_uff(tmp_path / "f.uff", synthetic("n", coherence=False))
    t = write_uff58_time(tmp_path / "t.uff", np.ones((1, 4)), 0.5, resp_nodes=[9],
                         resp_dirs=[3], quantities=["force"])
    path.write_bytes(path.read_bytes() + t.read_bytes())
    (d,) = read_uff(path)
    assert "dataset-58 sets of function type(s) [1] left out" in " ".join(d.notes)


def _with_point(c, p):
    from dataclasses import replace

    return replace(c, point=p)


def test_writer_refuses_what_uff_cannot_hold(tmp_path):
    d = synthetic("bad")
    H = d.H.copy()
    H[3, 0, 0] = np.nan
    with pytest.raises(ValueError, match=r"write_uff: FRFData 0 \('nan'\): H holds non-finite "
                                         r"values at 1 line\(s\) \(first at 1\.5 Hz\)"):
        write_uff(tmp_path / "x.uff", FRFData("nan", d.freq_hz, H, d.outputs, d.inputs))
    twin = (Channel("a", "acceleration", "z", coordinates_m=(0, 0, 0)),
            Channel("b", "acceleration", "z", coordinates_m=(0, 0, 0)))
    with pytest.raises(ValueError, match=r"output channels 'a' and 'b' are both at point 1 "
                                         r"direction code 3"):
        write_uff(tmp_path / "x.uff", FRFData("t", d.freq_hz, d.H[:, :2, :1], twin,
                                              d.inputs[:1]))
    with pytest.raises(ValueError, match="expected FRFData objects; got int"):
        write_uff(tmp_path / "x.uff", [1])
    assert not list(tmp_path.glob("x.uff*"))  # nothing half-written


# ======================================================================== foreign files

BEAM = make_plant("free_free_beam", n_elements=20)
PARAMS = BEAM.resolve({"L_m": 1.8})
NODE_XYZ = np.column_stack([BEAM.node_x_m(PARAMS), np.zeros(21), np.zeros(21)])
# points of the foreign file (numbers not the model's): at nodes 0, 10, 20, 0.4 mm off
POINTS = {101: (NODE_XYZ[0, 0], 0.0004, 0.0), 205: (NODE_XYZ[10, 0] + 0.0004, 0.0, 0.0),
          309: (NODE_XYZ[20, 0], 0.0, -0.0004)}
RESP = [(101, 3), (205, 3), (309, -3)]
REF = [(101, 3)]
UNIT_SYSTEMS = {
    # code, description, length and force units per SI unit, labels
    "mm_kN": (9, "mm kN", 1000.0, 1e-3, "mm/s^2", "kN"),
    "inch_lbf": (7, "IN", 1 / 0.0254, 1 / 4.4482216152605, "in/s^2", "lbf"),
}


@pytest.fixture(scope="module")
def measured():
    """H1 and coherence (SI) of a 2-mode structure from 20 Bartlett averages."""
    f_hz, zeta = np.array([12.0, 31.0]), np.array([0.02, 0.015])
    phi = np.array([[1.0, 1.0], [0.7, -0.6], [-0.5, 0.9]])
    w = 2 * np.pi * f_hz
    m = 2
    A = np.zeros((4, 4))
    A[:m, m:] = np.eye(m)
    A[m:, :m] = -np.diag(w**2)
    A[m:, m:] = -np.diag(2 * zeta * w)
    B = np.concatenate([np.zeros(m), phi[0]])[:, None]
    C = phi @ np.hstack([-np.diag(w**2), -np.diag(2 * zeta * w)])
    D = (phi @ phi[0])[:, None]
    fs, nper = 128.0, 512
    rng = np.random.default_rng(7)
    u = rng.standard_normal(20 * nper)
    y = simulate_lti(A, B, C, D, u, 1 / fs) + 0.05 * rng.standard_normal((3, 20 * nper))
    return estimate_frf(u, y, fs, window="bartlett", n_averages=20)


def pyuff_file(path, est, system, *, frf_sets=None, coherence=True, labels=None,
               denominator=13, exps=None, geometry=True, units=True):
    """A UFF file written with pyuff directly, in the units of ``system``."""
    code, desc, length, force, acc_lab, force_lab = system
    labels = labels or (acc_lab, force_lab)
    sets = []
    if units:
        sets.append(pyuff.prepare_164(units_code=code, units_description=desc, temp_mode=1,
                                      length=float(length), force=float(force), temp=1.0,
                                      temp_offset=273.15))
    if geometry:
        nums = list(POINTS)
        xyz = np.array([POINTS[n] for n in nums]) * length
        sets.append(pyuff.prepare_2411(node_nums=np.array(nums), def_cs=np.zeros(3, int),
                                       disp_cs=np.zeros(3, int), color=np.ones(3, int),
                                       x=xyz[:, 0], y=xyz[:, 1], z=xyz[:, 2]))
    scale = length / force  # (m/s^2)/N -> (file length/s^2)/(file force)
    pairs = frf_sets if frf_sets is not None else [(i, 0) for i in range(3)]
    for func_type, values in ((4, est.H * scale), (6, est.coherence)):
        if func_type == 6 and not coherence:
            continue
        for i, j in pairs:
            ds = {"type": 58, "func_type": func_type, "rsp_node": RESP[i][0],
                  "rsp_dir": RESP[i][1], "ref_node": REF[j][0], "ref_dir": REF[j][1],
                  "rsp_ent_name": f"acc{i}", "ref_ent_name": "hammer", "id1": "FRF",
                  "abscissa_spacing": 1, "abscissa_spec_data_type": 18,
                  "abscissa_axis_units_lab": "Hz",
                  "orddenom_spec_data_type": 0,
                  "x": est.freq_hz.copy(), "data": values[:, i, min(j, 0)].copy()}
            if func_type == 4:
                ds.update({"ordinate_spec_data_type": 12, "ordinate_axis_units_lab": labels[0],
                           "orddenom_spec_data_type": denominator,
                           "orddenom_axis_units_lab": labels[1]})
                if exps is not None:
                    ds.update({"ordinate_len_unit_exp": exps[0],
                               "ordinate_force_unit_exp": exps[1]})
            sets.append(ds)
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


@pytest.mark.parametrize("system", sorted(UNIT_SYSTEMS))
def test_foreign_non_si_file_is_read_in_si_and_mapped_to_the_model(tmp_path, measured,
                                                                   system):
    path = pyuff_file(tmp_path / f"{system}.uff", measured, UNIT_SYSTEMS[system])
    (d,) = load_frf(path)
    assert d.H.shape == (measured.freq_hz.size, 3, 1)
    np.testing.assert_allclose(d.freq_hz, measured.freq_hz, rtol=0, atol=0)  # 0.25 Hz steps
    assert_parts_close(d.H, measured.H, RTOL_UNITS)
    np.testing.assert_allclose(d.coherence, measured.coherence, rtol=RTOL_ASCII, atol=0)
    assert [c.point for c in d.outputs] == [101, 205, 309] and d.inputs[0].point == 101
    assert [c.sign for c in d.outputs] == [1, 1, -1]
    assert d.output_labels == ("101:+Z", "205:+Z", "309:-Z") and d.frf_type == "acceleration"
    for c in (*d.outputs, *d.inputs):
        np.testing.assert_allclose(c.coordinates_m, POINTS[c.point], rtol=4 * EPS, atol=0)
    assert any("converted to SI" in n for n in d.notes)
    nodes = match_points((*d.outputs, *d.inputs), NODE_XYZ, 0.001, where=str(path))
    assert nodes.tolist() == [0, 10, 20, 0]
    dofs = [f"n{n}.{c.direction}" for n, c in zip(nodes, (*d.outputs, *d.inputs),
                                                   strict=True)]
    assert set(dofs) <= set(BEAM.build(PARAMS).dof_labels)


def test_coherence_in_a_separate_file(tmp_path, measured):
    system = UNIT_SYSTEMS["mm_kN"]
    frf = pyuff_file(tmp_path / "frf.uff", measured, system, coherence=False)
    (bare,) = read_uff(frf)
    assert bare.coherence is None
    coh = tmp_path / "coh.uff"
    pyuff.UFF(str(coh)).write_sets([
        {"type": 58, "func_type": 6, "rsp_node": RESP[i][0], "rsp_dir": RESP[i][1],
         "ref_node": 101, "ref_dir": 3, "abscissa_spacing": 1, "orddenom_spec_data_type": 0,
         "x": measured.freq_hz.copy(), "data": measured.coherence[:, i, 0].copy()}
        for i in (2, 0, 1)], mode="add")
    (d,) = load_frf(frf, coherence=coh)
    np.testing.assert_allclose(d.coherence, measured.coherence, rtol=RTOL_ASCII, atol=0)
    short = tmp_path / "short.uff"
    pyuff.UFF(str(short)).write_sets([
        {"type": 58, "func_type": 6, "rsp_node": 101, "rsp_dir": 3, "ref_node": 101,
         "ref_dir": 3, "abscissa_spacing": 1, "orddenom_spec_data_type": 0,
         "x": measured.freq_hz.copy(), "data": measured.coherence[:, 0, 0].copy()}],
        mode="add")
    with pytest.raises(DataFormatError, match=re.escape(str(short)) + r": load case 0: the "
                       r"coherence sets leave out the \(node, dir\) pairs \['resp \(205, 3\) / "
                       r"ref \(101, 3\)', 'resp \(309, -3\) / ref \(101, 3\)'\]"):
        read_uff(frf, coherence=short)


def test_without_164_the_labels_set_the_units(tmp_path, measured):
    path = pyuff_file(tmp_path / "lab.uff", measured, UNIT_SYSTEMS["mm_kN"], units=False,
                      geometry=False)
    (d,) = read_uff(path)
    assert_parts_close(d.H, measured.H, RTOL_UNITS)
    assert d.outputs[0].coordinates_m is None
    # an FRF unit in the ordinate label, denominator label too
    both = pyuff_file(tmp_path / "frfunit.uff", measured, UNIT_SYSTEMS["mm_kN"],
                      labels=("mm/s^2/kN", "kN"))
    assert_parts_close(read_uff(both)[0].H, measured.H, RTOL_UNITS)


# ======================================================================== errors


def test_units_that_disagree_with_164(tmp_path, measured):
    path = pyuff_file(tmp_path / "mix.uff", measured, UNIT_SYSTEMS["mm_kN"],
                      labels=("m/s^2", "kN"))
    with pytest.raises(DataFormatError, match=re.escape(str(path)) + r": dataset 2 \(load "
                       r"case 0, response node 101 dir 3, reference node 101 dir 3\): the "
                       r"ordinate unit 'm/s\^2' disagrees with dataset 164 \(code 9 .*'mm kN'"
                       r".*\), whose unit of acceleration is 'mm/s\^2'"):
        load_frf(path)
    force = pyuff_file(tmp_path / "force.uff", measured, UNIT_SYSTEMS["inch_lbf"],
                       labels=("in/s^2", "N"))
    with pytest.raises(DataFormatError, match=r"force\.uff: dataset 2 .* the orddenom unit "
                                              r"'N' disagrees with dataset 164 .* whose unit "
                                              r"of force is 'lbf'"):
        load_frf(force)
    exps = pyuff_file(tmp_path / "exps.uff", measured, UNIT_SYSTEMS["mm_kN"], exps=(0, 1))
    with pytest.raises(DataFormatError, match=r"exps\.uff: dataset 2 .* the ordinate unit "
                                              r"exponents \(length 0, force 1\) disagree with "
                                              r"its quantity acceleration \(length 1, force 0\)"):
        load_frf(exps)
    wrong = pyuff_file(tmp_path / "kind.uff", measured, UNIT_SYSTEMS["mm_kN"],
                       labels=("mm/s", "kN"))
    with pytest.raises(DataFormatError, match=r"kind\.uff: .* the ordinate unit 'mm/s' is "
                                              r"not a unit of acceleration"):
        load_frf(wrong)


def test_a_grid_with_missing_pairs(tmp_path, measured):
    # a 3 x 1 grid plus one set of a second reference: 2 pairs of that column missing
    global REF
    saved = REF
    REF = [(101, 3), (309, 3)]
    try:
        path = pyuff_file(tmp_path / "holes.uff", measured, UNIT_SYSTEMS["mm_kN"],
                          frf_sets=[(0, 0), (1, 0), (2, 0), (1, 1)], coherence=False)
    finally:
        REF = saved
    with pytest.raises(DataFormatError, match=re.escape(str(path)) + r": the sets do not "
                       r"fill the 3 x 2 \(response x reference\) grid: missing \(node, dir\) "
                       r"pairs \['resp \(101, 3\) / ref \(309, 3\)', 'resp \(309, -3\) / ref "
                       r"\(309, 3\)'\]"):
        load_frf(path)


def test_our_file_cut_at_a_dataset_boundary(tmp_path):
    d = synthetic("cut", coherence=False)
    d = FRFData(d.name, d.freq_hz, d.H[:, :, :1], d.outputs, d.inputs[:1])  # 4 x 1
    text = write_uff(tmp_path / "whole.uff", d).read_text()
    blocks = re.findall(r"    -1\n.*?\n    -1\n", text, flags=re.S)
    assert len(blocks) == 3 + 4  # 151, 164, 2411, four FRF sets
    cut = tmp_path / "cut.uff"
    cut.write_text("".join(blocks[:5]))  # ends cleanly after the second FRF set
    with pytest.raises(DataFormatError, match=re.escape(str(cut)) + r": load case 1: the FRF "
                       r"sets say they form a 4 x 1 \(response x reference\) grid \(ID line "
                       r"3\), the file holds 2 x 1: missing pairs \['row 3 / col 1', 'row 4 / "
                       r"col 1'\]"):
        load_frf(cut)


def test_no_reference_force_channel(tmp_path, measured):
    path = pyuff_file(tmp_path / "trans.uff", measured, UNIT_SYSTEMS["mm_kN"],
                      labels=("mm/s^2", "mm/s^2"), denominator=12)
    with pytest.raises(DataFormatError, match=re.escape(str(path)) + r": dataset 2 .*: no "
                       r"reference \(force\) channel: the denominator is of data type 12 with "
                       r"unit 'mm/s\^2'; expected an excitation force"):
        load_frf(path)


def test_a_corrupt_or_truncated_file(tmp_path):
    path = write_uff(tmp_path / "ok.uff", synthetic("c"))
    raw = path.read_bytes()
    cut = tmp_path / "cut.uff"
    cut.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(DataFormatError, match=re.escape(str(cut)) + r": truncated or corrupt "
                                                                    r"UFF file"):
        load_frf(cut)
    text = raw.decode()
    start = text.index("  2411")
    line_end = text.index("\n", text.index("\n", start) + 1)  # the first node's number line
    broken = tmp_path / "geom.uff"
    broken.write_text(text[:line_end + 1] + text[text.index("\n", line_end + 1) + 1:])
    with pytest.raises(DataFormatError, match=r"geom\.uff: dataset 2 \(type 2411\) is "
                                              r"truncated or corrupt"):
        load_frf(broken)
    garbage = tmp_path / "garbage.uff"
    garbage.write_text("    -1\n    58\nnot a header\n    -1\n")
    with pytest.raises(DataFormatError, match=r"garbage\.uff: dataset 0 \(type 58, set 1 of "
                                              r"1\) is corrupt"):
        load_frf(garbage)


def test_a_point_that_matches_no_node(tmp_path, measured):
    global POINTS
    saved = POINTS
    POINTS = {**POINTS, 205: (0.5, 0.0, 0.0)}  # nodes every 0.09 m: 0.04 m from 0.54 m
    try:
        path = pyuff_file(tmp_path / "off.uff", measured, UNIT_SYSTEMS["mm_kN"])
    finally:
        POINTS = saved
    (d,) = load_frf(path)
    with pytest.raises(DataFormatError, match=re.escape(str(path)) + r": channel '205:\+Z' at "
                       r"point 205 \(0\.5, 0, 0\) m matches no model node within 0\.001 m: the "
                       r"nearest is node 6 at \(0\.54, 0, 0\) m, 0\.04 m away"):
        match_points(d.outputs, NODE_XYZ, 0.001, where=str(path))


def test_several_unit_systems_and_no_frf_sets(tmp_path, measured):
    a = pyuff_file(tmp_path / "a.uff", measured, UNIT_SYSTEMS["mm_kN"])
    two = tmp_path / "two.uff"
    pyuff.UFF(str(two)).write_sets([pyuff.prepare_164(
        units_code=1, units_description="SI", temp_mode=1, length=1.0, force=1.0, temp=1.0,
        temp_offset=273.15)], mode="add")
    two.write_bytes(two.read_bytes() + a.read_bytes())
    with pytest.raises(DataFormatError, match=r"two\.uff: several datasets 164 with different "
                                              r"units"):
        load_frf(two)
    spectra = tmp_path / "spectra.uff"
    pyuff.UFF(str(spectra)).write_sets([
        {"type": 58, "func_type": 2, "rsp_node": 1, "rsp_dir": 3, "ref_node": 1, "ref_dir": 3,
         "abscissa_spacing": 1, "orddenom_spec_data_type": 0, "x": np.arange(4.0),
         "data": np.ones(4)}], mode="add")
    with pytest.raises(DataFormatError, match=r"spectra\.uff: the dataset-58 sets are of "
                                              r"function type\(s\) \[2\]; expected FRFs"):
        load_frf(spectra)


def test_time_sets_in_a_non_si_file(tmp_path):
    fs, n = 256.0, 4096
    rng = np.random.default_rng(5)
    force_n = rng.standard_normal(n)
    acc = np.convolve(force_n, np.exp(-np.arange(64) / 9.0) * np.cos(np.arange(64)))[:n]
    length, force = 1000.0, 1e-3  # mm, kN
    sets = [pyuff.prepare_164(units_code=9, units_description="mm kN", temp_mode=1,
                              length=length, force=force, temp=1.0, temp_offset=273.15)]
    for node, q, lab, values in ((1, 13, "kN", force_n * force), (2, 12, "mm/s^2",
                                                                  acc * length)):
        sets.append({"type": 58, "func_type": 1, "rsp_node": node, "rsp_dir": 3,
                     "ref_node": 0, "ref_dir": 0, "abscissa_spacing": 1, "binary": 1,
                     "ordinate_spec_data_type": q, "ordinate_axis_units_lab": lab,
                     "orddenom_spec_data_type": 0,
                     "x": np.arange(n) / fs, "data": values})
    path = tmp_path / "time.uff"
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    (d,) = load_frf(path, n_averages=8)
    assert d.input_labels == ("1:+Z",) and d.output_labels == ("2:+Z",)
    assert d.excitation == "random" and d.n_averages == 8
    est = estimate_frf(force_n, acc, fs, window="hann", n_averages=8, detrend="constant")
    # binary doubles; two unit conversions per channel: a few ulp, bounded by 8 eps
    assert_parts_close(d.H[1:], est.H[1:], 1e-12)


def test_non_finite_values_in_a_foreign_file(tmp_path):
    """pyuff reads 'nan' and 'inf' as numbers: the reader refuses them, naming the set
    and the line, instead of passing them on (write_uff never writes them)."""
    d = synthetic("nf", coherence=False)
    lines = write_uff(tmp_path / "ok.uff", d).read_text().split("\n")
    i = next(k for k, t in enumerate(lines) if t.strip() == "58") + 13  # a data record
    lines[i] = "nan".rjust(20) + lines[i][20:]
    bad = tmp_path / "nan.uff"
    bad.write_text("\n".join(lines))
    with pytest.raises(DataFormatError, match=re.escape(str(bad)) + r": load case 1: the FRF "
                       r"set of response .* holds a non-finite value at [0-9.]+ Hz"):
        load_frf(bad)
