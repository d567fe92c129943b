"""Writing UFF dataset 58 through pyuff: :func:`write_uff58_frf` (FRFs, function type
4) and :func:`write_uff58_time` (time histories, function type 1), the checks of their
arguments, and the set and file plumbing :mod:`truthbench.io.uff_write` builds on
(``_base_set``, ``_write_sets``, ``_plan_abscissa``); the layout, precision and
conventions are those of :mod:`truthbench.io._uff58`.
"""

from __future__ import annotations

import math
import os
import tempfile
import warnings
from collections.abc import Sequence
from os import PathLike
from pathlib import Path

import numpy as np

from truthbench.io._uff_codes import (
    _DELIMITER,
    _FREQUENCY_AXIS,
    _FUNC_FRF,
    _FUNC_TIME,
    _TIME_AXIS,
    FRF_TYPES,
    NODE_OFFSET,
    TIME_QUANTITIES,
    direction_name,
)

__all__ = ["write_uff58_frf", "write_uff58_time"]

# Relative abscissa error above which the ASCII writers warn.
_ABSCISSA_RTOL = 1e-9


# --------------------------------------------------------------------------------------
# Validation of writer arguments
# --------------------------------------------------------------------------------------


def _int_vector(name: str, values: Sequence[int] | np.ndarray, n: int, what: str) -> list[int]:
    arr = np.asarray(values)
    if arr.ndim != 1 or arr.shape[0] != n:
        raise ValueError(
            f"{name} must have one entry per {what}; expected shape ({n},) instead of {arr.shape}"
        )
    if arr.size and not (
        np.issubdtype(arr.dtype, np.integer)
        or (np.issubdtype(arr.dtype, np.floating) and np.all(arr == np.round(arr)))
    ):
        raise ValueError(f"{name} must hold integers; got {arr.tolist()!r}")
    return [int(v) for v in arr]


def _nodes(name: str, values, n: int, what: str) -> list[int]:
    nodes = _int_vector(name, values, n, what)
    bad = [v for v in nodes if not 0 <= v <= 2_147_483_647]
    if bad:
        raise ValueError(
            f"{name} must be node numbers in 0..2147483647 (station + {NODE_OFFSET}); got {bad!r}"
        )
    return nodes


def _dirs(name: str, values, n: int, what: str) -> list[int]:
    dirs = _int_vector(name, values, n, what)
    bad = [v for v in dirs if v != 0 and direction_name(v) is None]
    if bad:
        raise ValueError(f"{name} must be UFF direction codes in -6..6; got {bad!r}")
    return dirs


def _names(name: str, values: Sequence[str] | None, n: int, what: str) -> list[str]:
    if values is None:
        return ["NONE"] * n
    if isinstance(values, str) or len(values) != n:
        raise ValueError(
            f"{name} must be a sequence of one string per {what}; expected {n} names, "
            f"got {values!r}"
        )
    out = []
    for v in values:
        if not isinstance(v, str) or not v or v != v.strip() or len(v) > 10 or not v.isascii():
            raise ValueError(
                f"{name}: UFF entity names are 1 to 10 ASCII characters without leading "
                f"or trailing blanks; got {v!r}"
            )
        out.append(v)
    return out


def _id_lines(id_lines: Sequence[str]) -> list[str]:
    if isinstance(id_lines, str):
        id_lines = (id_lines,)
    lines = list(id_lines)
    if len(lines) > 5:
        raise ValueError(f"id_lines: UFF 58 has 5 ID lines; got {len(lines)}")
    out = []
    for k, line in enumerate(lines):
        if not isinstance(line, str) or len(line) > 80 or "\n" in line or not line.isascii():
            raise ValueError(
                f"id_lines[{k}]: expected one ASCII line of at most 80 characters; got {line!r}"
            )
        out.append(line.strip() or "NONE")
    return out + ["NONE"] * (5 - len(out))


def _dof_pairs_unique(name: str, nodes: list[int], dirs: list[int]) -> None:
    pairs = list(zip(nodes, dirs, strict=True))
    dup = sorted({p for p in pairs if pairs.count(p) > 1})
    if dup:
        raise ValueError(f"{name}: each (node, direction) may appear once; repeated: {dup!r}")


def _e13(value: float) -> float:
    """``value`` as it reads back from a UFF ``E13.5`` field (6 significant digits)."""
    return float(f"{value:13.5e}")


def _abscissa_as_read(x: np.ndarray, even: bool) -> np.ndarray:
    """The abscissa an ASCII UFF 58 reader gets back (E13.5 fields)."""
    if even:
        return _e13(x[0]) + np.arange(x.size) * _e13(x[1] - x[0])
    return np.array([_e13(v) for v in x])


def _plan_abscissa(x: np.ndarray, binary: bool, name: str) -> int:
    """Choose the abscissa spacing flag (1 even, 0 uneven) and warn on ASCII rounding."""
    if binary:
        return 0  # per-point double abscissa: exact
    step = np.diff(x)
    even = bool(np.allclose(step, step[0], rtol=1e-9, atol=0.0))
    back = _abscissa_as_read(x, even)
    scale = float(np.max(np.abs(x))) or 1.0
    err = float(np.max(np.abs(back - x)))
    if err > _ABSCISSA_RTOL * scale:
        warnings.warn(
            f"{name} is stored with 6 significant digits in ASCII UFF 58 (E13.5, as the "
            f"standard says); it will read back with a maximum error of {err:.3g} "
            f"(largest value {scale:.6g}). Pass binary=True to store it exactly.",
            stacklevel=3,
        )
    return int(even)


# --------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------


def _fix_binary_byte_counts(path: str, dsets: list[dict], start: int = 0) -> None:
    """Write the true byte count into field 6 of every "58b" ID line pyuff wrote.

    pyuff 2.5.8 writes ``num_pts * 8`` there whatever the layout, but the binary block
    of an unevenly spaced set holds ``2 * num_pts`` (real) or ``3 * num_pts`` (complex)
    doubles. pyuff itself ignores the field; other readers use it. The file layout is
    walked with the known sizes and checked on the way.
    """
    raw = bytearray(Path(path).read_bytes())
    pos = start
    for dset in dsets:
        n_bytes = 8 * len(dset["data"]) * (3 if np.iscomplexobj(dset["data"]) else 2)
        id_line = raw.index(b"\n", pos) + 1  # after the opening "    -1" line
        data_start = id_line
        for _ in range(12):  # the ID line and the 11 ASCII records
            data_start = raw.index(b"\n", data_start) + 1
        data_end = data_start + n_bytes
        if (
            raw[pos:id_line].rstrip(b"\r\n") != _DELIMITER
            or not raw[id_line:].startswith(b"    58b")
            or raw[data_end : data_end + 6] != _DELIMITER
        ):
            raise RuntimeError(f"{path}: unexpected layout of pyuff's binary dataset 58b")
        raw[id_line + 31 : id_line + 43] = b"%12i" % n_bytes
        pos = raw.index(b"\n", data_end) + 1
    Path(path).write_bytes(bytes(raw))


def _write_sets(path: str | PathLike, dsets: list[dict], binary: bool,
                header_sets: Sequence[dict] = ()) -> Path:
    """Write dataset dicts to ``path`` (replacing it) through a temporary file: the
    ``header_sets`` (151, 164, 2411, ...) first, then the dataset-58 sets ``dsets``."""
    import pyuff

    target = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=target.name + ".", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        with warnings.catch_warnings():
            # pyuff's binary writer leaves a reopened handle to the garbage collector.
            warnings.simplefilter("ignore", ResourceWarning)
            # Always 'add' to the fresh empty file: pyuff's 'overwrite' mode truncates the
            # header of a first binary set.
            if header_sets:
                pyuff.UFF(tmp).write_sets(list(header_sets), mode="add")
            start = Path(tmp).stat().st_size
            pyuff.UFF(tmp).write_sets(dsets, mode="add")
        if binary:
            _fix_binary_byte_counts(tmp, dsets, start)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return target


def _base_set(
    *,
    func_type: int,
    func_id: int,
    id_lines: list[str],
    x: np.ndarray,
    y: np.ndarray,
    spacing: int,
    binary: bool,
    rsp: tuple[str, int, int],
    ref: tuple[str, int, int],
    abscissa: tuple[int, str, str],
    ordinate: tuple[int, str, str],
    denominator: tuple[int, str, str] | None,
) -> dict:
    import pyuff

    dset = pyuff.prepare_58(
        binary=int(binary),
        id1=id_lines[0], id2=id_lines[1], id3=id_lines[2], id4=id_lines[3], id5=id_lines[4],
        func_type=func_type,
        ver_num=0,
        load_case_id=0,
        rsp_ent_name=rsp[0], rsp_node=rsp[1], rsp_dir=rsp[2],
        ref_ent_name=ref[0], ref_node=ref[1], ref_dir=ref[2],
        abscissa_spacing=spacing,
        abscissa_spec_data_type=abscissa[0],
        abscissa_axis_units_lab=abscissa[2],
        ordinate_spec_data_type=ordinate[0],
        ordinate_axis_units_lab=ordinate[2],
        orddenom_spec_data_type=0 if denominator is None else denominator[0],
        orddenom_axis_units_lab="NONE" if denominator is None else denominator[2],
        z_axis_spec_data_type=0,
        data=y,
        x=x,
    )  # fmt: skip
    # Fields prepare_58 does not take (pyuff's writer reads them from the dict).
    dset["func_id"] = func_id
    dset["abscissa_axis_lab"] = abscissa[1]
    dset["ordinate_axis_lab"] = ordinate[1]
    dset["orddenom_axis_lab"] = "NONE" if denominator is None else denominator[1]
    return dset


def write_uff58_frf(
    path: str | PathLike,
    freq_hz: np.ndarray,
    H: np.ndarray,
    *,
    resp_nodes: Sequence[int],
    resp_dirs: Sequence[int],
    ref_nodes: Sequence[int],
    ref_dirs: Sequence[int],
    frf_type: str = "accelerance",
    resp_names: Sequence[str] | None = None,
    ref_names: Sequence[str] | None = None,
    id_lines: Sequence[str] = (),
    binary: bool = False,
) -> Path:
    """Write FRFs as UFF dataset 58 (function type 4), one set per (output, input).

    Parameters
    ----------
    path : str or os.PathLike
        Output file (``.uff`` or ``.unv``); replaced if it exists. Written through a
        temporary file in the same folder, so a failed write leaves no partial file.
    freq_hz : numpy.ndarray, shape (n_freq,)
        Frequencies in Hz, finite and strictly increasing, n_freq >= 2.
    H : numpy.ndarray, shape (n_freq, n_out, n_in)
        FRFs in SI units of ``frf_type`` (e.g. (m/s^2)/N for accelerance), finite.
    resp_nodes, resp_dirs : sequence of int, length n_out
        Response node (station + 1) and direction code (1..3 = +X,+Y,+Z, 4..6
        rotations, negative = minus sense) of each output.
    ref_nodes, ref_dirs : sequence of int, length n_in
        Reference (excitation) node and direction code of each input.
    frf_type : {"accelerance", "mobility", "receptance"}, default "accelerance"
        Written as the ordinate numerator/denominator data types and unit labels.
    resp_names, ref_names : sequence of str, optional
        Entity names (1-10 ASCII characters) per output / input; "NONE" if omitted.
    id_lines : sequence of str, optional
        Up to 5 ID lines (at most 80 characters each); missing ones are "NONE".
    binary : bool, default False
        False: ASCII (12 significant digits for H, 6 for the frequency axis; warns if
        ``freq_hz`` is not exact in 6 digits). True: binary "58b", exact doubles.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        If an argument has the wrong shape, type or range; the message names it.
    """
    f = np.array(freq_hz, dtype=np.float64, copy=True)
    if f.ndim != 1 or f.size < 2 or not np.all(np.isfinite(f)) or np.any(np.diff(f) <= 0):
        raise ValueError(
            "freq_hz must be a 1-D array of at least 2 finite, strictly increasing "
            f"frequencies in Hz; got shape {f.shape}"
        )
    Harr = np.array(H, copy=True)
    if Harr.ndim != 3 or Harr.shape[0] != f.size:
        raise ValueError(
            f"H has the wrong shape; expected (n_freq, n_out, n_in) with n_freq = "
            f"len(freq_hz) = {f.size} instead of {Harr.shape}"
        )
    if not np.issubdtype(Harr.dtype, np.number) or not np.all(np.isfinite(Harr)):
        raise ValueError("H must be numeric and finite (pyuff would write NaN/inf as 0)")
    Harr = Harr.astype(np.complex128)
    _, n_out, n_in = Harr.shape
    if frf_type not in FRF_TYPES:
        raise ValueError(f"frf_type must be one of {sorted(FRF_TYPES)}; got {frf_type!r}")
    rn = _nodes("resp_nodes", resp_nodes, n_out, "output (H.shape[1])")
    rd = _dirs("resp_dirs", resp_dirs, n_out, "output (H.shape[1])")
    fn = _nodes("ref_nodes", ref_nodes, n_in, "input (H.shape[2])")
    fd = _dirs("ref_dirs", ref_dirs, n_in, "input (H.shape[2])")
    _dof_pairs_unique("resp_nodes/resp_dirs", rn, rd)
    _dof_pairs_unique("ref_nodes/ref_dirs", fn, fd)
    rnames = _names("resp_names", resp_names, n_out, "output")
    fnames = _names("ref_names", ref_names, n_in, "input")
    ids = _id_lines(id_lines)
    spacing = _plan_abscissa(f, binary, "freq_hz")
    numerator, denominator = FRF_TYPES[frf_type]

    dsets = []
    for j in range(n_in):
        for i in range(n_out):
            dsets.append(
                _base_set(
                    func_type=_FUNC_FRF,
                    func_id=len(dsets) + 1,
                    id_lines=ids,
                    x=f.copy(),
                    y=Harr[:, i, j].copy(),
                    spacing=spacing,
                    binary=binary,
                    rsp=(rnames[i], rn[i], rd[i]),
                    ref=(fnames[j], fn[j], fd[j]),
                    abscissa=_FREQUENCY_AXIS,
                    ordinate=numerator,
                    denominator=denominator,
                )
            )
    return _write_sets(path, dsets, binary)


def write_uff58_time(
    path: str | PathLike,
    data: np.ndarray,
    dt_s: float,
    *,
    resp_nodes: Sequence[int],
    resp_dirs: Sequence[int],
    quantities: Sequence[str],
    ref_nodes: Sequence[int] | None = None,
    ref_dirs: Sequence[int] | None = None,
    resp_names: Sequence[str] | None = None,
    t0_s: float = 0.0,
    id_lines: Sequence[str] = (),
    binary: bool = False,
) -> Path:
    """Write time histories as UFF dataset 58 (function type 1), one set per channel.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (``.uff`` or ``.unv``); replaced if it exists.
    data : numpy.ndarray, shape (n_channels, n_samples)
        Real, finite samples in SI units, n_samples >= 2.
    dt_s : float
        Sampling interval in s (> 0).
    resp_nodes, resp_dirs : sequence of int, length n_channels
        Node (station + 1) and direction code of each channel.
    quantities : sequence of str, length n_channels
        ``"acceleration"`` (m/s^2), ``"velocity"`` (m/s), ``"displacement"`` (m) or
        ``"force"`` (N) per channel; sets the ordinate data type and unit label.
    ref_nodes, ref_dirs : sequence of int, length n_channels, optional
        Reference DOF per channel (e.g. the excitation); 0 (unused) if omitted.
    resp_names : sequence of str, optional
        Entity name (1-10 ASCII characters) per channel; "NONE" if omitted.
    t0_s : float, default 0.0
        Time of the first sample in s.
    id_lines : sequence of str, optional
        Up to 5 ID lines (at most 80 characters each).
    binary : bool, default False
        False: ASCII (12 significant digits for the samples, 6 for ``t0_s`` and
        ``dt_s``; warns if they are not exact in 6 digits). True: binary, exact.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        If an argument has the wrong shape, type or range; the message names it.
    """
    y = np.array(data, copy=True)
    if y.ndim != 2 or y.shape[1] < 2:
        raise ValueError(
            f"data has the wrong shape; expected (n_channels, n_samples) with n_samples "
            f">= 2 instead of {y.shape}"
        )
    if not np.issubdtype(y.dtype, np.number) or np.iscomplexobj(y):
        raise ValueError(f"data must be real numbers; got dtype {y.dtype}")
    if not np.all(np.isfinite(y)):
        raise ValueError("data must be finite (pyuff would write NaN/inf as 0)")
    y = y.astype(np.float64)
    if not (math.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"dt_s must be a finite sampling interval > 0 in s; got {dt_s!r}")
    if not math.isfinite(t0_s):
        raise ValueError(f"t0_s must be finite; got {t0_s!r}")
    n_ch, n_samples = y.shape
    rn = _nodes("resp_nodes", resp_nodes, n_ch, "channel (data.shape[0])")
    rd = _dirs("resp_dirs", resp_dirs, n_ch, "channel (data.shape[0])")
    fn = _nodes("ref_nodes", [0] * n_ch if ref_nodes is None else ref_nodes, n_ch, "channel")
    fd = _dirs("ref_dirs", [0] * n_ch if ref_dirs is None else ref_dirs, n_ch, "channel")
    if isinstance(quantities, str) or len(quantities) != n_ch:
        raise ValueError(
            f"quantities must be a sequence of one name per channel; expected {n_ch}, got "
            f"{quantities!r}"
        )
    bad = [q for q in quantities if q not in TIME_QUANTITIES]
    if bad:
        raise ValueError(f"quantities must be in {sorted(TIME_QUANTITIES)}; got {bad!r}")
    rnames = _names("resp_names", resp_names, n_ch, "channel")
    ids = _id_lines(id_lines)
    t = float(t0_s) + np.arange(n_samples) * float(dt_s)
    if binary:
        spacing = 0
    else:
        spacing = 1
        t0_back, dt_back = _e13(t[0]), _e13(t[1] - t[0])  # what pyuff writes and reads
        if t0_back != t[0] or not math.isclose(dt_back, dt_s, rel_tol=1e-12):
            warnings.warn(
                f"t0_s = {t0_s!r} and dt_s = {dt_s!r} are stored with 6 significant digits "
                f"in ASCII UFF 58 (E13.5) and will read back as {t0_back!r} and "
                f"{dt_back!r}. Pass binary=True to store them exactly.",
                stacklevel=2,
            )
    dsets = [
        _base_set(
            func_type=_FUNC_TIME,
            func_id=k + 1,
            id_lines=ids,
            x=t.copy(),
            y=y[k].copy(),
            spacing=spacing,
            binary=binary,
            rsp=(rnames[k], rn[k], rd[k]),
            ref=("NONE", fn[k], fd[k]),
            abscissa=_TIME_AXIS,
            ordinate=TIME_QUANTITIES[quantities[k]],
            denominator=None,
        )
        for k in range(n_ch)
    ]
    return _write_sets(path, dsets, binary)
