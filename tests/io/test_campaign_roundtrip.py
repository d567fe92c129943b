"""A campaign's FRFs exported to UFF and read back: by pyuff directly and by load_frf.

A small campaign (quickstart with 4 s records and 4 averages) is run and stored; its
FRFs are loaded from the results file (the campaign store's reader) and written with
write_uff (what ``truthbench export`` does). The file is read back

* by pyuff (``UFF(path).read_sets()``, not our reader): every FRF and coherence set is
  found by geometry alone (its response and reference node -> 2411 coordinates -> the
  plant's nearest node -> DOF ``n<node>.<dir>``, the label the model uses) and compared
  with the FRFs in the HDF5 file (read with h5py);
* by :func:`truthbench.io.load_frf`, whose channels' coordinates map to the same DOFs.

Tolerances: ASCII keeps 12 significant digits per real and imaginary part (relative
5e-12 of the part); binary is exact. Frequencies (1 Hz steps) and coordinates (17
digits) are exact.
"""

from __future__ import annotations

import re
from pathlib import Path

import h5py
import numpy as np
import pytest
import pyuff

from truthbench.campaign.runner import run_campaign
from truthbench.campaign.spec import load_campaign
from truthbench.campaign.store import write_results
from truthbench.errors import DataFormatError
from truthbench.io import load_frf, write_uff
from truthbench.measure import match_points

ROOT = Path(__file__).resolve().parents[2]
RTOL_ASCII = 5e-12
DIRS = {1: "x", 2: "y", 3: "z", 4: "rx", 5: "ry", 6: "rz"}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("campaign")
    text = (ROOT / "campaigns" / "quickstart.toml").read_text()
    text = re.sub(r"record_s = [0-9.]+", "record_s = 4.0", text)
    text = re.sub(r"averages = [0-9]+", "averages = 4", text)
    toml = tmp / "quick.toml"
    toml.write_text(text)
    spec = load_campaign(toml)
    result = run_campaign(spec)
    h5 = write_results(result, tmp / "results.h5")
    plant = spec.make_plant()
    params = spec.nominal_parameters()
    x = plant.node_x_m(params)
    nodes_xyz = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    return spec, h5, plant, params, nodes_xyz


def stored(h5):
    """test -> (freq_hz, H, coherence, output DOF stations/directions, input ones)."""
    out = {}
    with h5py.File(h5, "r") as f:
        for name, t in f["trials/0000/tests"].items():
            outs = [str(v.decode() if isinstance(v, bytes) else v).split(".")
                    for v in t.attrs["output_labels"]]
            ins = [str(v.decode() if isinstance(v, bytes) else v).split(".")
                   for v in t.attrs["input_labels"]]
            out[name] = (t["freq_hz"][()], t["H"][()], t["coherence"][()], outs, ins)
    return out


def dof_of(plant, station, direction):
    return f"n{plant.station_node(station)}.{direction}"


@pytest.mark.parametrize("binary", [False, True])
def test_pyuff_reads_the_stored_frfs_back_by_geometry(campaign, tmp_path, binary):
    spec, h5, plant, params, nodes_xyz = campaign
    path = write_uff(tmp_path / "export.uff", load_frf(h5), binary=binary)
    sets = pyuff.UFF(str(path)).read_sets()
    geometry = [s for s in sets if s["type"] == 2411]
    assert len(geometry) == 1 and any(s["type"] == 164 for s in sets)
    g = geometry[0]
    xyz_of = {int(n): np.array([g["x"][k], g["y"][k], g["z"][k]])
              for k, n in enumerate(g["node_nums"])}
    model_dofs = set(plant.build(params).dof_labels)

    def dof(node, code):
        near = int(np.argmin(np.linalg.norm(nodes_xyz - xyz_of[int(node)], axis=1)))
        assert np.linalg.norm(nodes_xyz[near] - xyz_of[int(node)]) == 0.0  # exact
        label = f"n{near}.{DIRS[abs(int(code))]}"
        assert label in model_dofs
        return label

    data = stored(h5)
    by_dofs = {}
    for name, (_, _, _, outs, ins) in data.items():
        for j, (st_in, d_in) in enumerate(ins):
            for i, (st_out, d_out, _) in enumerate(outs):
                key = (dof_of(plant, st_out, d_out), dof_of(plant, st_in, d_in))
                by_dofs[key] = (name, i, j)
    seen = {4: [], 6: []}
    for s in (s for s in sets if s["type"] == 58):
        name, i, j = by_dofs[(dof(s["rsp_node"], s["rsp_dir"]), dof(s["ref_node"],
                                                                    s["ref_dir"]))]
        f, H, coh, _, _ = data[name]
        np.testing.assert_array_equal(s["x"], f)
        want = H[:, i, j] if s["func_type"] == 4 else coh[:, i, j]
        if binary:
            np.testing.assert_array_equal(s["data"], want)
        else:
            for part in (np.real, np.imag):
                a, d = part(s["data"]), part(want)
                assert np.all(np.abs(a - d) <= RTOL_ASCII * np.abs(d))
        seen[s["func_type"]].append((name, i, j))
    # every stored FRF and coherence value once, nothing else
    assert sorted(seen[4]) == sorted(seen[6]) == sorted(by_dofs.values())


@pytest.mark.parametrize("binary", [False, True])
def test_load_frf_reads_the_stored_frfs_back(campaign, tmp_path, binary):
    spec, h5, plant, params, nodes_xyz = campaign
    original = load_frf(h5)
    path = write_uff(tmp_path / "export.unv", original, binary=binary)
    back = load_frf(path)
    data = stored(h5)
    assert [d.name for d in back] == [f"trial 0 / {t.name}" for t in spec.tests]
    for d in back:
        f, H, coh, outs, ins = data[d.name.split(" / ")[1]]
        np.testing.assert_array_equal(d.freq_hz, f)
        if binary:
            np.testing.assert_array_equal(d.H, H)
            np.testing.assert_array_equal(d.coherence, coh)
        else:
            np.testing.assert_allclose(d.H.real, H.real, rtol=RTOL_ASCII, atol=0)
            np.testing.assert_allclose(d.H.imag, H.imag, rtol=RTOL_ASCII, atol=0)
            np.testing.assert_allclose(d.coherence, coh, rtol=RTOL_ASCII, atol=0)
        assert d.output_labels == tuple(".".join(o) for o in outs)
        nodes = match_points((*d.outputs, *d.inputs), nodes_xyz, 1e-9, where=str(path))
        got = [f"n{n}.{c.direction}" for n, c in zip(nodes, (*d.outputs, *d.inputs),
                                                      strict=True)]
        want = [dof_of(plant, st, dr) for st, dr, *_ in (*outs, *ins)]
        assert got == want
        assert d.band_hz == tuple(spec.tests[0].band_hz) and d.n_averages == 4


def test_the_store_reader_gives_channels_at_the_stations(campaign):
    spec, h5, plant, params, nodes_xyz = campaign
    frfs = load_frf(h5, tests="shaker_quarter")
    assert [d.name for d in frfs] == ["trial 0 / shaker_quarter"]
    d = frfs[0]
    assert d.inputs[0].station == "quarter" and d.inputs[0].quantity == "force"
    x = plant.node_x_m(params)
    assert d.inputs[0].coordinates_m == (x[plant.station_node("quarter")], 0.0, 0.0)
    assert [c.station for c in d.outputs] == [s.station for s in spec.sensors]
    with pytest.raises(DataFormatError, match=r"results\.h5: no test \['nope'\] in the file; it "
                                        r"holds tests \['shaker_end', 'shaker_quarter'\]"):
        load_frf(h5, tests=["nope"])
    with pytest.raises(DataFormatError, match=r"results\.h5: no trial \[5\] in the file"):
        load_frf(h5, trials=5)
