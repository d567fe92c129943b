"""Tests of load_data (dispatch on the file extension) and the register_reader hook."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import truthbench.io.registry as registry
from truthbench.errors import DataFormatError
from truthbench.io import (
    TimeRecord,
    load_data,
    read_lvm,
    read_uff58,
    register_reader,
    registered_extensions,
    write_uff58_time,
)


@pytest.fixture
def private_registry(monkeypatch: pytest.MonkeyPatch) -> None:
    """Register test readers in a copy of the registry, restored after the test."""
    monkeypatch.setattr(registry, "_READERS", dict(registry._READERS))


def test_builtin_readers_are_registered() -> None:
    assert registered_extensions() == (".lvm", ".uff", ".unv")
    assert registry._READERS[".lvm"] is read_lvm
    assert registry._READERS[".uff"] is read_uff58 and registry._READERS[".unv"] is read_uff58


def test_load_data_reads_lvm_and_passes_kwargs(tmp_path: Path) -> None:
    text = (
        "LabVIEW Measurement\t\nWriter_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
        "X_Columns\tNo\n***End_of_Header***\t\n\t\nChannels\t1\t\nSamples\t3\t\n"
        "Y_Unit_Label\tN\t\nX0\t0\t\nDelta_X\t0.5\t\n***End_of_Header***\t\t\n"
        "X_Value\tF\tComment\n\t1.0\n\t2.0\n"
    )
    path = tmp_path / "short.LVM"
    path.write_text(text)
    with pytest.raises(DataFormatError, match="says 3 rows, read 2"):
        load_data(path)
    with pytest.warns(UserWarning, match="kept 2 complete rows"):
        rec = load_data(path, allow_truncated=True)
    assert isinstance(rec, TimeRecord)
    np.testing.assert_array_equal(rec.data, [[1.0, 2.0]])


def test_load_data_reads_uff(tmp_path: Path) -> None:
    path = write_uff58_time(
        tmp_path / "t.uff", np.ones((1, 4)), 0.5, resp_nodes=[1], resp_dirs=[3],
        quantities=["force"],
    )  # fmt: skip
    assert load_data(path, func_type=1).data.shape == (1, 4)


def test_unknown_extension_names_it_and_the_supported_ones(tmp_path: Path) -> None:
    path = tmp_path / "data.csv"
    with pytest.raises(
        DataFormatError,
        match=re.escape(str(path))
        + r".*unknown file extension '\.csv'; expected one of: \.lvm, \.uff, \.unv",
    ):
        load_data(path)
    with pytest.raises(DataFormatError, match=r"unknown file extension '\(none\)'"):
        load_data(tmp_path / "noext")


@pytest.mark.parametrize("ext", [".h5", ".hdf5", ".H5"])
def test_hdf5_is_reserved_until_registered(tmp_path: Path, ext: str) -> None:
    with pytest.raises(
        DataFormatError, match=r"no reader registered yet for '\.h.*register_reader"
    ):
        load_data(tmp_path / f"results{ext}")


@pytest.mark.usefixtures("private_registry")
def test_register_reader_hook(tmp_path: Path) -> None:
    calls = []

    def fake_h5(path: Path, **kwargs: object) -> str:
        calls.append((path, kwargs))
        return "hdf5 result"

    register_reader("H5", fake_h5)  # no dot, upper case: normalized to ".h5"
    assert ".h5" in registered_extensions()
    assert load_data(tmp_path / "r.h5", group="/trial_0") == "hdf5 result"
    assert calls == [(tmp_path / "r.h5", {"group": "/trial_0"})]
    register_reader(".h5", fake_h5)  # same function again: allowed
    with pytest.raises(ValueError, match=r"reader for '\.h5' is already registered"):
        register_reader(".h5", lambda p: p)
    register_reader(".h5", str, replace=True)
    assert load_data(tmp_path / "r.h5") == str(tmp_path / "r.h5")


@pytest.mark.usefixtures("private_registry")
def test_register_reader_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match=r"ext must be a file extension"):
        register_reader("", read_lvm)
    with pytest.raises(ValueError, match=r"ext must be a file extension"):
        register_reader("a/b", read_lvm)
    with pytest.raises(TypeError, match=r"func for '\.xyz' must be callable"):
        register_reader(".xyz", "not callable")  # type: ignore[arg-type]
