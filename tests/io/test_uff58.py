"""Tests of UFF dataset 58 writing and reading (through pyuff).

Tolerances. pyuff writes double-precision ordinates; in ASCII each real and imaginary
part is printed as ``%20.11e`` (12 significant digits), so a part comes back with a
relative error of at most 5e-12 of itself and a complex value with at most
sqrt(2) * 5e-12 ~ 7.1e-12 of its modulus: the ASCII round trips use ``rtol=1e-11,
atol=0``. The abscissa is written as ``%13.5e`` (6 digits) in ASCII, so the ASCII tests
use a frequency axis that is exact in 6 digits and compare it exactly. The binary
("58b") round trips store doubles and are compared exactly.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from truthbench.errors import DataFormatError
from truthbench.io import DIRECTION_CODES, direction_label, load_frf
from truthbench.io._uff58 import (
    NODE_OFFSET,
    UFFData,
    read_uff58,
    write_uff58_frf,
    write_uff58_time,
)

RTOL_ASCII = 1e-11

FRF_META = {
    "resp_nodes": [1, 5, 9],
    "resp_dirs": [3, 3, -2],
    "ref_nodes": [1, 9],
    "ref_dirs": [3, 1],
    "resp_names": ["acc_tip", "acc_mid", "acc_root"],
    "ref_names": ["hammer", "shaker"],
}


def random_frf(n_freq: int, n_out: int = 3, n_in: int = 2, seed: int = 0) -> np.ndarray:
    """Complex FRFs whose magnitudes span 1e-4 .. 1e4 (exercises the exponent field)."""
    rng = np.random.default_rng(seed)
    shape = (n_freq, n_out, n_in)
    scale = 10.0 ** rng.uniform(-4, 4, size=shape)
    return scale * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape))


def delimiter_blocks(text: str) -> list[str]:
    """Split a UFF text into its datasets, each '    -1' ... '    -1' inclusive."""
    lines = text.splitlines(keepends=True)
    blocks, current = [], None
    for line in lines:
        if line.rstrip("\r\n") == "    -1":
            if current is None:
                current = [line]
            else:
                current.append(line)
                blocks.append("".join(current))
                current = None
        elif current is not None:
            current.append(line)
    return blocks


def _match(path: Path, what: str) -> str:
    return re.escape(str(path)) + ".*" + what


@pytest.fixture
def frf_file(tmp_path: Path) -> tuple[Path, np.ndarray, np.ndarray]:
    freq = np.arange(0.0, 1000.5, 0.5)  # df = 0.5 Hz: exact in 6 digits
    H = random_frf(freq.size)
    path = write_uff58_frf(tmp_path / "frf.uff", freq, H, **FRF_META, id_lines=["beam test"])
    return path, freq, H


# --------------------------------------------------------------------------------------
# Round trips
# --------------------------------------------------------------------------------------


def test_frf_round_trip_ascii_3x2(frf_file: tuple[Path, np.ndarray, np.ndarray]) -> None:
    path, freq, H = frf_file
    d = read_uff58(path)
    assert isinstance(d, UFFData)
    assert d.func_type == 4 and not d.is_time and not d.binary
    np.testing.assert_array_equal(d.freq_hz, freq)
    assert d.H.shape == (freq.size, 3, 2) and d.H.dtype == np.complex128
    np.testing.assert_allclose(d.H, H, rtol=RTOL_ASCII, atol=0.0)
    assert np.max(np.abs(d.H - H) / np.abs(H)) > 0.0  # ASCII does round (12 digits)
    np.testing.assert_array_equal(d.resp_nodes, FRF_META["resp_nodes"])
    np.testing.assert_array_equal(d.resp_dirs, FRF_META["resp_dirs"])
    np.testing.assert_array_equal(d.ref_nodes, FRF_META["ref_nodes"])
    np.testing.assert_array_equal(d.ref_dirs, FRF_META["ref_dirs"])
    assert d.resp_names == tuple(FRF_META["resp_names"])
    assert d.ref_names == tuple(FRF_META["ref_names"])
    assert d.frf_type == "accelerance"
    assert d.resp_units == ("m/s^2",) * 3 and d.ref_units == ("N",) * 2
    assert d.abscissa_units == "Hz"
    assert d.id_lines == ("beam test", "NONE", "NONE", "NONE", "NONE")
    assert d.data is None and d.dt_s is None
    assert len(d.sets) == 6 and all("data" not in s for s in d.sets)
    assert {s["ordinate_spec_data_type"] for s in d.sets} == {12}
    assert {s["orddenom_spec_data_type"] for s in d.sets} == {13}
    assert {s["abscissa_spec_data_type"] for s in d.sets} == {18}
    assert {s["ord_data_type"] for s in d.sets} == {6}  # complex double precision


@pytest.mark.parametrize("frf_type", ["mobility", "receptance"])
def test_frf_type_round_trip(tmp_path: Path, frf_type: str) -> None:
    freq = np.arange(1.0, 11.0)
    H = random_frf(freq.size, 1, 1)
    path = write_uff58_frf(
        tmp_path / "f.unv", freq, H, resp_nodes=[2], resp_dirs=[1], ref_nodes=[2],
        ref_dirs=[1], frf_type=frf_type,
    )  # fmt: skip
    d = read_uff58(path)
    assert d.frf_type == frf_type
    assert d.resp_units == ({"mobility": "m/s", "receptance": "m"}[frf_type],)


def test_frf_round_trip_binary_is_exact_for_any_axis(tmp_path: Path) -> None:
    freq = np.fft.rfftfreq(50030, 2e-5)[:300]  # df = 0.9994... Hz: not exact in 6 digits
    H = random_frf(freq.size, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        path = write_uff58_frf(tmp_path / "b.uff", freq, H, **FRF_META, binary=True)
    d = read_uff58(path)
    assert d.binary
    np.testing.assert_array_equal(d.freq_hz, freq)
    np.testing.assert_array_equal(d.H, H)
    np.testing.assert_array_equal(d.ref_nodes, FRF_META["ref_nodes"])


def test_ascii_warns_when_axis_is_not_exact_in_6_digits(tmp_path: Path) -> None:
    freq = np.fft.rfftfreq(50030, 2e-5)[:300]
    H = random_frf(freq.size, 1, 1)
    with pytest.warns(UserWarning, match=r"6 significant digits.*binary=True"):
        path = write_uff58_frf(
            tmp_path / "w.uff", freq, H, resp_nodes=[1], resp_dirs=[3], ref_nodes=[1],
            ref_dirs=[3],
        )  # fmt: skip
    d = read_uff58(path)
    np.testing.assert_allclose(d.freq_hz, freq, rtol=5e-6)  # 6 significant digits


def test_uneven_frequency_axis_round_trip(tmp_path: Path) -> None:
    freq = np.array([1.0, 2.0, 4.0, 8.0, 16.5])
    H = random_frf(freq.size, 1, 1)
    path = write_uff58_frf(
        tmp_path / "u.uff", freq, H, resp_nodes=[1], resp_dirs=[3], ref_nodes=[1], ref_dirs=[3]
    )
    d = read_uff58(path)
    assert d.sets[0]["abscissa_spacing"] == 0
    np.testing.assert_array_equal(d.freq_hz, freq)
    np.testing.assert_allclose(d.H, H, rtol=RTOL_ASCII, atol=0.0)


def test_grid_assembly_does_not_depend_on_set_order(
    frf_file: tuple[Path, np.ndarray, np.ndarray], tmp_path: Path
) -> None:
    path, _, _ = frf_file
    blocks = delimiter_blocks(path.read_text())
    assert len(blocks) == 6
    shuffled = tmp_path / "shuffled.uff"
    shuffled.write_text("".join(blocks[k] for k in [4, 1, 5, 0, 3, 2]))
    a, b = read_uff58(path), read_uff58(shuffled)
    # The order of the DOFs follows their first appearance; compare through the DOFs.
    for i, (rn, rd) in enumerate(zip(a.resp_nodes, a.resp_dirs, strict=True)):
        ib = int(np.flatnonzero((b.resp_nodes == rn) & (b.resp_dirs == rd))[0])
        for j, (fn, fd) in enumerate(zip(a.ref_nodes, a.ref_dirs, strict=True)):
            jb = int(np.flatnonzero((b.ref_nodes == fn) & (b.ref_dirs == fd))[0])
            np.testing.assert_array_equal(b.H[:, ib, jb], a.H[:, i, j])


def test_time_round_trip_ascii(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    data = rng.standard_normal((3, 1001)) * np.array([[1e-3], [1.0], [2e3]])
    path = write_uff58_time(
        tmp_path / "t.uff", data, 2e-5, resp_nodes=[1, 2, 3], resp_dirs=[3, 3, 3],
        quantities=["force", "acceleration", "displacement"], ref_nodes=[1, 1, 1],
        ref_dirs=[3, 3, 3], resp_names=["F", "a2", "u3"], t0_s=0.5,
    )  # fmt: skip
    d = read_uff58(path)
    assert d.is_time and d.func_type == 1
    assert d.data.shape == (3, 1001) and d.H is None and d.freq_hz is None
    np.testing.assert_allclose(d.data, data, rtol=RTOL_ASCII, atol=0.0)
    assert d.dt_s == 2e-5 and d.fs_hz == pytest.approx(5e4)
    assert d.abscissa[0] == 0.5
    np.testing.assert_allclose(d.abscissa, 0.5 + np.arange(1001) * 2e-5, rtol=1e-15)
    assert d.quantities == ("force", "acceleration", "displacement")
    assert d.resp_units == ("N", "m/s^2", "m")
    assert d.resp_names == ("F", "a2", "u3")
    np.testing.assert_array_equal(d.resp_nodes, [1, 2, 3])
    np.testing.assert_array_equal(d.ref_nodes, [1, 1, 1])
    assert d.abscissa_units == "s"


def test_time_round_trip_binary_is_exact(tmp_path: Path) -> None:
    rng = np.random.default_rng(8)
    data = rng.standard_normal((2, 777))
    dt = 1.0 / 51200.0  # not exact in 6 digits
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        path = write_uff58_time(
            tmp_path / "tb.uff", data, dt, resp_nodes=[4, 4], resp_dirs=[1, 2],
            quantities=["velocity", "velocity"], binary=True,
        )  # fmt: skip
    d = read_uff58(path)
    np.testing.assert_array_equal(d.data, data)
    np.testing.assert_array_equal(d.abscissa, np.arange(777) * dt)
    assert d.dt_s == pytest.approx(dt, rel=1e-14)  # mean step of the stored axis
    assert d.quantities == ("velocity", "velocity")


def test_time_ascii_warns_for_inexact_dt(tmp_path: Path) -> None:
    with pytest.warns(UserWarning, match=r"dt_s = .* 6 significant digits"):
        write_uff58_time(
            tmp_path / "w.uff", np.ones((1, 4)), 1.0 / 3.0, resp_nodes=[1], resp_dirs=[1],
            quantities=["acceleration"],
        )  # fmt: skip


def test_writers_do_not_modify_inputs_and_replace_file(tmp_path: Path) -> None:
    freq = np.arange(0.0, 5.0)
    H = random_frf(freq.size, 1, 1)
    freq0, H0 = freq.copy(), H.copy()
    path = tmp_path / "x.uff"
    kw = {"resp_nodes": [1], "resp_dirs": [3], "ref_nodes": [1], "ref_dirs": [3]}
    write_uff58_frf(path, freq, H, **kw)
    write_uff58_frf(path, freq, 2 * H, **kw)  # replaces, does not append
    np.testing.assert_array_equal(freq, freq0)
    np.testing.assert_array_equal(H, H0)
    d = read_uff58(path)
    assert len(d.sets) == 1
    np.testing.assert_allclose(d.H[:, 0, 0], 2 * H[:, 0, 0], rtol=RTOL_ASCII)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.uff"]  # no temporary left


def test_func_type_selection_in_mixed_file(
    frf_file: tuple[Path, np.ndarray, np.ndarray], tmp_path: Path
) -> None:
    path, freq, H = frf_file
    t_path = write_uff58_time(
        tmp_path / "t.uff", np.ones((1, 10)), 1e-3, resp_nodes=[1], resp_dirs=[3],
        quantities=["force"],
    )  # fmt: skip
    mixed = tmp_path / "mixed.uff"
    mixed.write_text(path.read_text() + t_path.read_text())
    with pytest.raises(DataFormatError, match=_match(mixed, r"function types \[1, 4\]")):
        read_uff58(mixed)
    np.testing.assert_allclose(read_uff58(mixed, func_type=4).H, H, rtol=RTOL_ASCII)
    assert read_uff58(mixed, func_type=1).data.shape == (1, 10)
    with pytest.raises(DataFormatError, match=_match(mixed, r"no dataset 58 of function type 6")):
        read_uff58(mixed, func_type=6)


def test_other_datasets_are_skipped(frf_file: tuple[Path, np.ndarray, np.ndarray]) -> None:
    path, _, H = frf_file
    header151 = "    -1\n   151\nmodel\n    -1\n"
    path.write_text(header151 + path.read_text())
    np.testing.assert_allclose(read_uff58(path).H, H, rtol=RTOL_ASCII)


def test_load_frf_dispatches_uff_and_unv(
    frf_file: tuple[Path, np.ndarray, np.ndarray], tmp_path: Path
) -> None:
    path, _, H = frf_file
    unv = tmp_path / "same.UNV"
    unv.write_bytes(path.read_bytes())
    for p in (path, unv):
        np.testing.assert_allclose(load_frf(p)[0].H, H, rtol=RTOL_ASCII)


def test_conventions_are_published() -> None:
    assert NODE_OFFSET == 1
    assert direction_label(3) == "+Z" and direction_label(-1) == "-X"
    assert direction_label(6) == "+RZ" and direction_label(0) == "scalar"
    assert direction_label(9) == "9"  # not a UFF direction: as read
    assert [direction_label(-c) for c in DIRECTION_CODES.values()] == [
        "-X", "-Y", "-Z", "-RX", "-RY", "-RZ"]


# --------------------------------------------------------------------------------------
# Corrupt files
# --------------------------------------------------------------------------------------


def test_truncated_file(frf_file: tuple[Path, np.ndarray, np.ndarray], tmp_path: Path) -> None:
    path, _, _ = frf_file
    raw = path.read_bytes()
    cut = tmp_path / "cut.uff"
    cut.write_bytes(raw[: int(0.6 * len(raw))])
    with pytest.raises(DataFormatError, match=_match(cut, r"truncated or corrupt UFF file")):
        read_uff58(cut)


def test_truncated_binary_file(tmp_path: Path) -> None:
    freq = np.arange(0.0, 64.0)
    path = write_uff58_frf(
        tmp_path / "b.uff", freq, random_frf(freq.size, 1, 1), resp_nodes=[1], resp_dirs=[3],
        ref_nodes=[1], ref_dirs=[3], binary=True,
    )  # fmt: skip
    raw = path.read_bytes()
    path.write_bytes(raw[:-200])
    with pytest.raises(DataFormatError, match=_match(path, r"truncated or corrupt")):
        read_uff58(path)


def test_set_with_missing_values(frf_file: tuple[Path, np.ndarray, np.ndarray]) -> None:
    path, _, _ = frf_file
    lines = path.read_text().splitlines(keepends=True)
    del lines[20]  # a data line of the first set: delimiters intact, values missing
    path.write_text("".join(lines))
    with pytest.raises(
        DataFormatError, match=_match(path, r"dataset 0 .*record 7 says 2001 data values, found")
    ):
        read_uff58(path)


def test_garbage_bytes(tmp_path: Path) -> None:
    path = tmp_path / "garbage.uff"
    path.write_bytes(np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8).tobytes())
    with pytest.raises(DataFormatError, match=_match(path, r"not a UFF file")):
        read_uff58(path)


def test_garbage_between_delimiters(tmp_path: Path) -> None:
    path = tmp_path / "garbage.uff"
    path.write_text("    -1\n    58\nthis is\nnot a\nfunction\n    -1\n")
    with pytest.raises(DataFormatError, match=_match(path, r"dataset 0 \(type 58.*corrupt")):
        read_uff58(path)


def test_empty_file(tmp_path: Path) -> None:
    path = tmp_path / "empty.uff"
    path.write_bytes(b"")
    with pytest.raises(DataFormatError, match=_match(path, r"the file is empty")):
        read_uff58(path)


def test_no_dataset_58(tmp_path: Path) -> None:
    path = tmp_path / "geometry.unv"
    path.write_text("    -1\n   151\nmodel\n    -1\n    -1\n   164\n    1\n    -1\n")
    with pytest.raises(DataFormatError, match=_match(path, r"no dataset 58.*\[151, 164\]")):
        read_uff58(path)


def test_inconsistent_abscissae(tmp_path: Path) -> None:
    kw = {"resp_dirs": [3], "ref_nodes": [1], "ref_dirs": [3]}
    a = write_uff58_frf(
        tmp_path / "a.uff", np.arange(10.0), random_frf(10, 1, 1), resp_nodes=[1], **kw
    )
    b = write_uff58_frf(
        tmp_path / "b.uff", np.arange(1.0, 11.0), random_frf(10, 1, 1), resp_nodes=[2], **kw
    )
    c = write_uff58_frf(
        tmp_path / "c.uff", np.arange(12.0), random_frf(12, 1, 1), resp_nodes=[3], **kw
    )
    ab, ac = tmp_path / "ab.uff", tmp_path / "ac.uff"
    ab.write_text(a.read_text() + b.read_text())
    ac.write_text(a.read_text() + c.read_text())
    with pytest.raises(DataFormatError, match=_match(ab, r"inconsistent abscissae: dataset 1")):
        read_uff58(ab)
    with pytest.raises(DataFormatError, match=_match(ac, r"dataset 1 has 12 points")):
        read_uff58(ac)


def test_repeated_and_missing_pairs(frf_file: tuple[Path, np.ndarray, np.ndarray]) -> None:
    path, _, _ = frf_file
    blocks = delimiter_blocks(path.read_text())
    path.write_text("".join(blocks + blocks[:1]))
    with pytest.raises(DataFormatError, match=_match(path, r"datasets 0 and 6 both hold")):
        read_uff58(path)
    path.write_text("".join(blocks[:-1]))
    with pytest.raises(DataFormatError, match=_match(path, r"do not fill the 3 x 2.*missing")):
        read_uff58(path)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        read_uff58(tmp_path / "nothing.uff")


# --------------------------------------------------------------------------------------
# Writer argument checks
# --------------------------------------------------------------------------------------

GOOD = {"resp_nodes": [1], "resp_dirs": [3], "ref_nodes": [1], "ref_dirs": [3]}


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"H": np.ones((4, 1))}, r"H has the wrong shape; expected \(n_freq, n_out, n_in\)"),
        ({"H": np.full((5, 1, 1), np.nan)}, r"H must be numeric and finite"),
        ({"freq_hz": np.array([0.0, 2.0, 1.0, 3.0, 4.0])}, r"freq_hz must .* increasing"),
        ({"resp_dirs": [7]}, r"resp_dirs must be UFF direction codes in -6..6; got \[7\]"),
        ({"resp_nodes": [1, 2]}, r"resp_nodes must have one entry per output"),
        ({"ref_nodes": [-1]}, r"ref_nodes must be node numbers"),
        ({"resp_nodes": [1.5]}, r"resp_nodes must hold integers"),
        ({"frf_type": "inertance!"}, r"frf_type must be one of"),
        ({"resp_names": ["much_too_long_name"]}, r"resp_names: UFF entity names"),
        ({"id_lines": ["x" * 81]}, r"id_lines\[0\]: expected one ASCII line"),
    ],
)
def test_frf_writer_rejects_bad_arguments(tmp_path: Path, change: dict, match: str) -> None:
    args = {"freq_hz": np.arange(5.0), "H": np.ones((5, 1, 1), complex), **GOOD, **change}
    with pytest.raises(ValueError, match=match):
        write_uff58_frf(tmp_path / "bad.uff", **args)
    assert not (tmp_path / "bad.uff").exists()


def test_frf_writer_rejects_repeated_dofs(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"resp_nodes/resp_dirs: .* repeated: \[\(1, 3\)\]"):
        write_uff58_frf(
            tmp_path / "bad.uff", np.arange(5.0), np.ones((5, 2, 1)), resp_nodes=[1, 1],
            resp_dirs=[3, 3], ref_nodes=[1], ref_dirs=[3],
        )  # fmt: skip


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"data": np.ones(10)}, r"data has the wrong shape"),
        ({"data": np.ones((1, 10)) * 1j}, r"data must be real"),
        ({"dt_s": 0.0}, r"dt_s must be a finite sampling interval > 0"),
        ({"quantities": ["jerk"]}, r"quantities must be in"),
        ({"quantities": "force"}, r"quantities must be a sequence"),
    ],
)
def test_time_writer_rejects_bad_arguments(tmp_path: Path, change: dict, match: str) -> None:
    args = {
        "data": np.ones((1, 10)), "dt_s": 1e-3, "resp_nodes": [1], "resp_dirs": [3],
        "quantities": ["force"], **change,
    }  # fmt: skip
    with pytest.raises(ValueError, match=match):
        write_uff58_time(tmp_path / "bad.uff", **args)


def test_binary_header_states_the_true_byte_count(tmp_path: Path) -> None:
    # Field 6 of the "58b" ID line is the number of binary bytes after the 11 ASCII
    # records (pyuff 2.5.8 writes num_pts * 8; the writer corrects it).
    freq = np.arange(0.0, 37.0)
    path = write_uff58_frf(
        tmp_path / "b.uff", freq, random_frf(freq.size, 1, 1), resp_nodes=[1], resp_dirs=[3],
        ref_nodes=[1], ref_dirs=[3], binary=True,
    )  # fmt: skip
    raw = path.read_bytes()
    lines = raw.split(b"\n", 13)  # delimiter, ID line, 11 records, binary + "    -1\n"
    assert lines[1].startswith(b"    58b")
    n_bytes = int(lines[1][31:43])
    assert raw.endswith(b"    -1\n")
    assert n_bytes == len(lines[13]) - len(b"    -1\n") == 3 * 37 * 8


def test_lost_delimiters_do_not_lose_sets_silently(tmp_path: Path) -> None:
    # pyuff pairs '    -1' lines and would silently skip a set whose delimiters are lost.
    path = write_uff58_time(
        tmp_path / "t.uff", np.ones((3, 8)), 0.5, resp_nodes=[1, 2, 3], resp_dirs=[3, 3, 3],
        quantities=["force"] * 3,
    )  # fmt: skip
    lines = path.read_text().split("\n")
    delim = [i for i, line in enumerate(lines) if line == "    -1"]
    assert len(delim) == 6
    odd = tmp_path / "odd.uff"
    odd.write_text("\n".join(lines[: delim[3]] + lines[delim[3] + 1 :]))
    with pytest.raises(DataFormatError, match=_match(odd, r"found 5 '    -1' delimiters")):
        read_uff58(odd)
    outside = tmp_path / "outside.uff"
    outside.write_text(
        "\n".join(lines[: delim[2]] + lines[delim[2] + 1 : delim[3]] + lines[delim[3] + 1 :])
    )
    with pytest.raises(
        DataFormatError, match=re.escape(f"{outside}, line 17: corrupt UFF file: text outside")
    ):
        read_uff58(outside)


def test_block_without_dataset_number(tmp_path: Path) -> None:
    path = tmp_path / "nonumber.uff"
    path.write_text("    -1\nnot a number\n    -1\n")
    with pytest.raises(DataFormatError, match=_match(path, r"dataset\(s\) \[0\] have no dataset")):
        read_uff58(path)


def test_non_uniform_time_axis(tmp_path: Path) -> None:
    import pyuff

    path = tmp_path / "uneven_time.uff"
    dset = pyuff.prepare_58(
        func_type=1, rsp_node=1, rsp_dir=3, ref_node=0, ref_dir=0, abscissa_spacing=0,
        orddenom_spec_data_type=0, data=np.ones(4), x=np.array([0.0, 1.0, 3.0, 4.0]),
    )  # fmt: skip
    pyuff.UFF(str(path)).write_sets([dset], mode="add")
    with pytest.raises(DataFormatError, match=_match(path, r"time abscissa is not uniformly")):
        read_uff58(path)
