"""Tests of load_frf (dispatch on the file extension) and the register_reader hook."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import truthbench.io.registry as registry
from truthbench.errors import DataFormatError
from truthbench.io import (
    load_frf,
    read_frf,
    read_lvm,
    read_lvm_frf,
    read_uff,
    register_reader,
    registered_extensions,
)
from truthbench.io._uff58 import write_uff58_time
from truthbench.measure import Channel, FRFData

LVM = (
    "LabVIEW Measurement\t\nWriter_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
    "X_Columns\tNo\n***End_of_Header***\t\n\t\nChannels\t2\t\t\nSamples\t{n}\t{n}\t\n"
    "Y_Unit_Label\tN\tm/s^2\t\nX0\t0\t0\t\nDelta_X\t0.01\t0.01\t\n"
    "***End_of_Header***\t\t\t\nX_Value\tF\tA\tComment\n{rows}"
)


@pytest.fixture
def private_registry(monkeypatch: pytest.MonkeyPatch) -> None:
    """Register test readers in a copy of the registry, restored after the test."""
    monkeypatch.setattr(registry, "_READERS", dict(registry._READERS))


def test_the_io_readers_are_registered_at_import() -> None:
    assert registered_extensions() == (".h5", ".hdf5", ".lvm", ".uff", ".unv")
    assert registry._READERS[".lvm"] is read_lvm_frf
    assert registry._READERS[".uff"] is read_uff and registry._READERS[".unv"] is read_uff
    assert registry._READERS[".h5"] is read_frf and registry._READERS[".hdf5"] is read_frf


def test_importing_io_registers_every_reader_and_stays_light() -> None:
    """io registers its readers, .h5/.hdf5 included, when it is imported (no
    registration at call time, nothing imported for its side effect); importing io or
    truthbench loads neither scipy nor h5py."""
    code = ("import sys, truthbench.io as io; print(io.registered_extensions()); "
            "print('scipy' in sys.modules, 'h5py' in sys.modules, "
            "'truthbench.campaign' in sys.modules); import truthbench; "
            "print(truthbench.load_frf is io.load_frf)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert out == ["('.h5', '.hdf5', '.lvm', '.uff', '.unv')", "False False False", "True"]


def test_io_does_not_import_campaign() -> None:
    """No module of io imports the campaign room (module- or function-level): the HDF5
    format is given what it needs as plain data."""
    import ast

    for path in Path(registry.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            assert not any(n.startswith("truthbench.campaign") for n in names), path.name


def test_load_frf_reads_lvm_and_passes_options(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    data = rng.standard_normal((2, 64))
    rows = "".join(f"\t{a:.6e}\t{b:.6e}\n" for a, b in data.T)
    path = tmp_path / "short.LVM"
    path.write_text(LVM.format(n=64, rows=rows))
    (frf,) = load_frf(path, n_averages=4)
    assert isinstance(frf, FRFData) and frf.n_averages == 4 and frf.excitation == "random"
    assert frf.input_labels == ("F",) and frf.output_labels == ("A",)
    cut = tmp_path / "cut.lvm"
    cut.write_text(LVM.format(n=65, rows=rows))
    with pytest.raises(DataFormatError, match="says 65 rows, read 64"):
        load_frf(cut)
    with pytest.warns(UserWarning, match="kept 64 complete rows"):
        load_frf(cut, allow_truncated=True, n_averages=2)


def test_load_frf_reads_uff_time_sets(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    path = write_uff58_time(
        tmp_path / "t.uff", rng.standard_normal((2, 64)), 0.5, resp_nodes=[1, 2],
        resp_dirs=[3, 3], quantities=["force", "acceleration"],
    )  # fmt: skip
    (frf,) = load_frf(path, n_averages=2)
    assert frf.H.shape == (17, 1, 1) and frf.inputs[0].quantity == "force"


def test_an_option_the_reader_does_not_take_is_named(tmp_path: Path) -> None:
    path = write_uff58_time(tmp_path / "t.uff", np.ones((1, 4)), 0.5, resp_nodes=[1],
                            resp_dirs=[3], quantities=["force"])
    with pytest.raises(ValueError, match=r"t\.uff: the \.uff reader .*read_uff\) takes no "
                                         r"option\(s\) \['averages'\]; it takes \['coherence'"):
        load_frf(path, averages=3)


def test_missing_file_and_unknown_extension(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"nothere\.uff: no such data file"):
        load_frf(tmp_path / "nothere.uff")
    path = tmp_path / "data.csv"
    path.write_text("1,2\n")
    with pytest.raises(
        DataFormatError,
        match=re.escape(str(path))
        + r".*unknown file extension '\.csv'; expected one of: \.h5, \.hdf5, \.lvm, \.uff",
    ):
        load_frf(path)
    noext = tmp_path / "noext"
    noext.write_text("")
    with pytest.raises(DataFormatError, match=r"unknown file extension '\(none\)'"):
        load_frf(noext)


@pytest.mark.usefixtures("private_registry")
def test_an_unregistered_extension_lists_the_registered_ones(tmp_path: Path) -> None:
    registry._READERS.pop(".hdf5")
    path = tmp_path / "results.hdf5"
    path.write_bytes(b"")
    with pytest.raises(DataFormatError, match=r"unknown file extension '\.hdf5'; expected "
                                              r"one of: \.h5, \.lvm, \.uff, \.unv$"):
        load_frf(path)


@pytest.mark.usefixtures("private_registry")
def test_register_reader_hook(tmp_path: Path) -> None:
    calls = []
    frf = FRFData("x", [1.0, 2.0], np.ones((2, 1, 1)), (Channel("a", "acceleration"),),
                  (Channel("f", "force"),))

    def fake(path: Path, *, group: str = "/") -> tuple[FRFData, ...]:
        calls.append((path, group))
        return (frf,)

    path = tmp_path / "r.xyz"
    path.write_bytes(b"")
    register_reader("XYZ", fake)  # no dot, upper case: normalized to ".xyz"
    assert ".xyz" in registered_extensions()
    assert load_frf(path, group="/trial_0") == (frf,)
    assert calls == [(path, "/trial_0")]
    register_reader(".xyz", fake)  # same function again: allowed
    with pytest.raises(ValueError, match=r"reader for '\.xyz' is already registered"):
        register_reader(".xyz", lambda p: p)
    register_reader(".xyz", lambda p: "not FRFData", replace=True)
    with pytest.raises(DataFormatError, match=r"r\.xyz: the \.xyz reader .* returned str; "
                                              r"expected a non-empty tuple of FRFData"):
        load_frf(path)
    register_reader(".xyz", lambda p: (), replace=True)
    with pytest.raises(DataFormatError, match=r"returned nothing \(an empty sequence\)"):
        load_frf(path)
    register_reader(".xyz", lambda p: (frf, 3), replace=True)
    with pytest.raises(DataFormatError, match=r"returned a sequence holding int"):
        load_frf(path)


@pytest.mark.usefixtures("private_registry")
def test_register_reader_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match=r"ext must be a file extension"):
        register_reader("", read_lvm)
    with pytest.raises(ValueError, match=r"ext must be a file extension"):
        register_reader("a/b", read_lvm)
    with pytest.raises(TypeError, match=r"func for '\.xyz' must be callable"):
        register_reader(".xyz", "not callable")  # type: ignore[arg-type]


def test_a_directory_is_not_a_data_file(tmp_path):
    for name in ("x.lvm", "x.uff", "x.h5"):
        (tmp_path / name).mkdir()
        with pytest.raises(DataFormatError, match=re.escape(str(tmp_path / name))
                           + ": is a directory; expected a data file"):
            load_frf(tmp_path / name)
