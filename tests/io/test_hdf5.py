"""The HDF5 format on its own (no campaign): a test written from plain objects reads back
as the same FRFData, and the plain data of a file are what was written."""

from types import SimpleNamespace

import numpy as np
import pytest

from truthbench.errors import DataFormatError
from truthbench.io import hdf5, load_frf
from truthbench.measure.frfdata import Channel, FRFData
from truthbench.measure.leakage import Estimator

HEAD = {"truthbench_version": "0", "seed": 3, "campaign": "hand",
        "spec_json": '{"tests": [{"name": "b"}, {"name": "a"}]}', "source": "here"}


def _record(name, rng):
    """A test record as the io layer reads it: attributes only, no campaign type."""
    outs = (Channel("mid.z.acc", "acceleration", "z", station="mid",
                    coordinates_m=(0.9, 0.0, 0.0)),
            Channel("hub.rz.vel", "velocity", "rz", sign=-1, point=7))
    ins = (Channel("end.z", "force", "z", station="end"),)
    f = np.arange(5) * 2.0
    H = rng.standard_normal((5, 2, 1)) + 1j * rng.standard_normal((5, 2, 1))
    frf = FRFData(name, f, H, outs, ins, coherence=rng.uniform(size=(5, 2, 1)),
                  n_averages=4, band_hz=(2.0, 6.0), notes=("H1",),
                  estimator=Estimator("hann", 8, 16.0, None), input_rms=(1.5,))
    return SimpleNamespace(name=name, frf=frf, freq_hz=f, H=H, coherence=frf.coherence,
                           u=rng.standard_normal((1, 8)), y=rng.standard_normal((2, 8)),
                           fs_hz=16.0, input_labels=frf.input_labels,
                           output_labels=frf.output_labels, parameters={"E_pa": 7e10},
                           modes=None)


def test_a_test_file_reads_back_as_the_same_frf_data(tmp_path):
    rec = _record("a", np.random.default_rng(0))
    path = hdf5.write_test_file(tmp_path / "t.h5", rec, HEAD, trial=4, injected=["x:y=1"])
    (got,) = load_frf(path)  # the registered reader
    assert got.name == "trial 4 / a"
    for field in ("outputs", "inputs", "n_averages", "band_hz", "excitation", "notes",
                  "estimator", "input_rms", "window_decay_rad_s"):
        assert getattr(got, field) == getattr(rec.frf, field), field
    for field in ("freq_hz", "H", "coherence"):
        np.testing.assert_array_equal(getattr(got, field), getattr(rec.frf, field),
                                      strict=True)
    with hdf5.reading(path) as f:
        attrs = hdf5.read_attrs(f)
        body = hdf5.read_body(f, attrs)
    assert attrs["single_test"] and attrs["spec"]["tests"][0]["name"] == "b"
    assert attrs["injected"] == '["x:y=1"]' and body["nominal"] is None
    (trial,) = body["trials"]
    (test,) = trial["tests"]
    assert trial["trial"] == 4 and test["parameters"] == {"E_pa": 7e10}
    np.testing.assert_array_equal(test["y"], rec.y, strict=True)


def test_a_header_without_its_keys_is_refused(tmp_path):
    rec = _record("a", np.random.default_rng(1))
    with pytest.raises(ValueError, match=r"lacks \['source'\]"):
        hdf5.write_test_file(tmp_path / "t.h5", rec, {k: v for k, v in HEAD.items()
                                                     if k != "source"}, trial=0)


def test_spec_json_that_is_not_json_is_named(tmp_path):
    rec = _record("a", np.random.default_rng(2))
    path = hdf5.write_test_file(tmp_path / "t.h5", rec, {**HEAD, "spec_json": "{"}, trial=0)
    with pytest.raises(DataFormatError, match=r"t.h5: attribute 'spec_json' is not the "
                                              r"campaign as JSON"):
        load_frf(path)
