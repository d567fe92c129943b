"""Universal File Format (UFF) dataset 58, the private layer under the public UFF
reader and writer (:mod:`truthbench.io.uff_frf`: :func:`~truthbench.io.read_uff`,
:func:`~truthbench.io.write_uff`, which exchange :class:`~truthbench.measure.FRFData`).

This module holds the dataset-58 ("function at nodal DOF") plumbing, built on ``pyuff``:
:func:`write_uff58_frf`, :func:`write_uff58_time` and :func:`read_uff58` returning a
frozen :class:`UFFData` of raw arrays (the tests also use the writers to make files of
other tools' layouts), and the one table of UFF direction codes,
:data:`DIRECTION_CODES`. One dataset 58 holds one function of one response DOF and one
reference DOF; a file of FRFs holds one set per (output, input) pair.

Node and direction convention
-----------------------------
- **Node** = station number + 1. truthbench numbers the stations (measurement and
  excitation points of a plant) from 0; UFF nodes are positive integers, so station
  ``s`` is written as node ``s + 1`` (node 0 means "unused", e.g. the reference of a
  time history). See :data:`NODE_OFFSET`. The writers take node numbers, not
  stations: convert with ``station + NODE_OFFSET``.
- **Direction** (UFF record 6): ``1, 2, 3`` = +X, +Y, +Z translation; ``4, 5, 6`` =
  +X, +Y, +Z rotation; the negative code is the same axis in the minus sense
  (``-3`` = -Z); ``0`` = scalar. See :data:`DIRECTION_CODES` and
  :func:`direction_label`.
- **Layout**: ``H[:, i, j]`` is written as the set with response ``(resp_nodes[i],
  resp_dirs[i])`` and reference ``(ref_nodes[j], ref_dirs[j])``, for j outer and i
  inner. :func:`read_uff58` rebuilds ``H`` of shape (n_freq, n_out, n_in) from the
  (response, reference) DOF pairs found in the file, in order of first appearance, so
  any set order is read back correctly.

FRF types and units
-------------------
The FRF type is stored in records 9 and 10 (ordinate numerator and denominator
specific data types), with axis labels and SI unit labels:

============  ====================  ==========  ============
frf_type      numerator (code)      denom.      units
============  ====================  ==========  ============
accelerance   acceleration (12)     force (13)  m/s^2 / N
mobility      velocity (11)         force (13)  m/s / N
receptance    displacement (8)      force (13)  m / N
============  ====================  ==========  ============

The abscissa is frequency (code 18, ``Hz``) for FRFs and time (code 17, ``s``) for time
histories (function type 1). Time-history channels are ``acceleration``, ``velocity``,
``displacement`` or ``force`` (codes 12, 11, 8, 13; SI units). Values are written as
given: pass SI values. Rotational DOFs use the same labels (the file does not say rad).

Precision
---------
pyuff always writes double-precision ordinates (``ord_data_type`` 4 real, 6 complex).
In ASCII (the default) each real or imaginary part is written as ``%20.11e``: 12
significant digits, so a value comes back with a relative error of at most 5e-12 of
that part. The *abscissa*, however, is single precision by the UFF standard: the
abscissa minimum and increment of an evenly spaced function (or every abscissa value of
an unevenly spaced one) are written as ``%13.5e``, 6 significant digits. A frequency or
time axis that is not exact in 6 digits (e.g. ``df = 50000/50030`` Hz) would come back
shifted by up to 5e-6 relative; the ASCII writers then warn. ``binary=True`` writes the
binary variant "58b" with the abscissa stored per point as a double (uneven spacing):
values and abscissa come back bit-identical.

Errors
------
Reading raises :class:`~truthbench.errors.DataFormatError` naming the file and the set
for an empty, truncated or corrupt file (pyuff's own exceptions are caught and re-raised
with the path), a file without dataset 58, a set whose point count disagrees with its
header, sets with different abscissae, mixed function types, or FRF sets that do not
fill the (output x input) grid exactly once.
"""

from __future__ import annotations

import math
import os
import re
import tempfile
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from truthbench._validation import readonly
from truthbench.errors import DataFormatError
from truthbench.quantities import MOTION_QUANTITIES, quantity

__all__ = [
    "DIRECTION_CODES",
    "FRF_TYPES",
    "NODE_OFFSET",
    "TIME_QUANTITIES",
    "UFFData",
    "direction_label",
    "read_uff58",
    "write_uff58_frf",
    "write_uff58_time",
]

NODE_OFFSET = 1
"""UFF node number of truthbench station ``s`` is ``s + NODE_OFFSET``."""

DIRECTION_CODES = MappingProxyType({"x": 1, "y": 2, "z": 3, "rx": 4, "ry": 5, "rz": 6})
"""Channel direction -> UFF direction code (record 6, fields 7 and 10): translation along
and rotation about X, Y, Z. The negative code is the same axis in the minus sense
(``Channel.sign = -1``); code 0 is a scalar (no direction). The one direction table of
the UFF layers."""

_DIRECTION_NAMES = {v: k for k, v in DIRECTION_CODES.items()}


def direction_name(code: int) -> str | None:
    """The direction (x, y, z, rx, ry, rz) of a UFF direction code, None for 0 or an
    unknown code."""
    return _DIRECTION_NAMES.get(abs(int(code)))


def direction_label(code: int) -> str:
    """A UFF direction code as text: ``"+Z"``, ``"-RX"``, ``"scalar"`` (0); an unknown
    code as its number."""
    code = int(code)
    name = direction_name(code)
    if name is None:
        return "scalar" if code == 0 else str(code)
    return ("-" if code < 0 else "+") + name.upper()

def _axis(name: str) -> tuple[int, str, str]:
    """(UFF specific data type, axis label, SI unit label) of a quantity, from the one
    table :mod:`truthbench.quantities`."""
    q = quantity(name)
    return (q.uff_code, name.capitalize(), q.unit)


_FORCE = _axis("force")
_QUANTITIES = {name: _axis(name) for name in ("acceleration", "velocity", "displacement",
                                              "force")}
TIME_QUANTITIES = MappingProxyType(_QUANTITIES)
"""Time-history quantity -> (UFF specific data type, axis label, SI unit label)."""

FRF_TYPES = MappingProxyType(
    {quantity(q).frf_name: (_axis(q), _FORCE) for q in reversed(MOTION_QUANTITIES)}
)
"""FRF type -> ((numerator code, label, unit), (denominator code, label, unit))."""

_FREQUENCY_AXIS = (18, "Frequency", "Hz")
_TIME_AXIS = (17, "Time", "s")
_FUNC_TIME = 1
_FUNC_FRF = 4
_DELIMITER = b"    -1"
# A delimiter as pyuff recognises one: followed by a line end, the end of the file or
# blanks up to column 80.
_DELIMITER_RE = re.compile(rb"    -1(?=\r|\n|\Z| {74})")
# Relative abscissa error above which the ASCII writers warn.
_ABSCISSA_RTOL = 1e-9
# Relative tolerance for "the same abscissa" across sets of one file.
_SAME_ABSCISSA_RTOL = 1e-9


@dataclass(frozen=True, eq=False)
class UFFData:
    """The dataset-58 functions of one UFF file, assembled into arrays.

    Function type 1 (time response) is laid out as channels; every other function type
    (FRF = 4, coherence, spectra, ...) is laid out as an (output x input) grid.

    Parameters
    ----------
    path : pathlib.Path
        The file that was read.
    func_type : int
        UFF function type of the sets (1 time response, 4 FRF, ...).
    abscissa : numpy.ndarray, shape (n,)
        Abscissa as stored: frequency in Hz (grid layout) or time in s (time layout).
    freq_hz : numpy.ndarray or None, shape (n_freq,)
        Grid layout: the frequencies in Hz (same array as ``abscissa``). None for time.
    H : numpy.ndarray or None, shape (n_freq, n_out, n_in)
        Grid layout: ``H[:, i, j]`` is the function of response DOF i and reference DOF
        j (the FRF for type 4, complex). None for time histories.
    data : numpy.ndarray or None, shape (n_channels, n_samples)
        Time layout: one row per set, in file order. None for the grid layout.
    dt_s : float or None
        Time layout: sampling interval in s. None for the grid layout.
    resp_nodes, resp_dirs : numpy.ndarray of int, shape (n_out,) or (n_channels,)
        Response node and direction code of each output (grid) or channel (time).
    ref_nodes, ref_dirs : numpy.ndarray of int, shape (n_in,) or (n_channels,)
        Reference node and direction code of each input (grid) or channel (time).
    resp_names, ref_names : tuple of str
        Response and reference entity names (record 6), same lengths as the nodes.
    resp_units, ref_units : tuple of str
        Ordinate numerator unit label per output / channel and denominator unit label
        per input / channel (``"NONE"`` when unused, e.g. for time histories).
    abscissa_units : str
        Abscissa unit label (``"Hz"``, ``"s"``) of the first set.
    frf_type : str or None
        ``"accelerance"``, ``"mobility"`` or ``"receptance"`` when every set of an FRF
        file has the matching numerator/denominator data types, else None.
    quantities : tuple of str or None
        Time layout: ``"acceleration"``, ``"velocity"``, ``"displacement"``, ``"force"``
        or ``"unknown"`` per channel, from the ordinate data type. None for the grid.
    id_lines : tuple of str
        The five ID lines (record 1-5) of the first set.
    binary : bool
        True if the sets are binary ("58b").
    sets : tuple of Mapping
        Read-only header fields of every dataset-58 set read (pyuff's keys, without
        ``x`` and ``data``), in file order.
    """

    path: Path
    func_type: int
    abscissa: np.ndarray
    resp_nodes: np.ndarray
    resp_dirs: np.ndarray
    ref_nodes: np.ndarray
    ref_dirs: np.ndarray
    resp_names: tuple[str, ...]
    ref_names: tuple[str, ...]
    resp_units: tuple[str, ...]
    ref_units: tuple[str, ...]
    abscissa_units: str
    id_lines: tuple[str, ...]
    binary: bool
    sets: tuple[Mapping[str, Any], ...]
    freq_hz: np.ndarray | None = None
    H: np.ndarray | None = None
    data: np.ndarray | None = None
    dt_s: float | None = None
    frf_type: str | None = None
    quantities: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        for name in ("abscissa", "freq_hz", "H", "data"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, readonly(value))
        for name in ("resp_nodes", "resp_dirs", "ref_nodes", "ref_dirs"):
            object.__setattr__(self, name, readonly(getattr(self, name), np.int64))
        if self.freq_hz is not None:
            object.__setattr__(self, "freq_hz", self.abscissa)

    @property
    def is_time(self) -> bool:
        """True for time histories (function type 1, channel layout)."""
        return self.func_type == _FUNC_TIME

    @property
    def fs_hz(self) -> float | None:
        """Sampling frequency in Hz for time histories, else None."""
        return None if self.dt_s is None else 1.0 / self.dt_s


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


# --------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------


def _check_delimiters(path: Path, raw: bytes) -> None:
    """Check the outline of a UFF file before pyuff reads it."""
    if not raw.strip():
        raise DataFormatError(
            f"{path}: the file is empty ({len(raw)} bytes): expected UFF datasets delimited "
            f"by '    -1' lines"
        )
    if _DELIMITER not in raw:
        head = raw[:60].decode("ascii", errors="replace")
        raise DataFormatError(
            f"{path}: not a UFF file: expected datasets delimited by '    -1' lines, found "
            f"none (file starts with {head!r})"
        )
    tail = raw.rstrip(b" \r\n")
    if not tail.endswith(_DELIMITER):
        last = tail.rsplit(b"\n", 1)[-1][-80:].decode("ascii", errors="replace")
        raise DataFormatError(
            f"{path}: truncated or corrupt UFF file: expected the last line to be the "
            f"closing '    -1' delimiter, got {last!r} ({len(raw)} bytes)"
        )
    # pyuff pairs delimiters (1st-2nd, 3rd-4th, ...), drops an odd one out and skips
    # whatever lies between pairs: check both, or a lost delimiter would lose a set.
    starts = [m.start() for m in _DELIMITER_RE.finditer(raw)]
    if len(starts) % 2:
        raise DataFormatError(
            f"{path}: corrupt UFF file: found {len(starts)} '    -1' delimiters; expected an "
            f"even number (an opening and a closing one per dataset)"
        )
    closing_to_opening = [(starts[k] + 6, starts[k + 1]) for k in range(1, len(starts) - 1, 2)]
    for begin, end in [(0, starts[0]), *closing_to_opening]:
        gap = raw[begin:end]
        if gap.strip():
            line = raw.count(b"\n", 0, begin + len(gap) - len(gap.lstrip()))
            raise DataFormatError(
                f"{path}, line {line + 1}: corrupt UFF file: text outside any dataset; "
                f"expected a '    -1' delimiter to open a dataset there"
            )


_GEOMETRY_TYPES = (2411, 15)


def _read_sets(path: Path, wanted: Sequence[int]
               ) -> tuple[list[int], dict[int, list[tuple[int, dict]]]]:
    """Read the datasets of the ``wanted`` types with pyuff: the type of every dataset in
    the file, and type -> [(index, dict)] for the wanted ones.

    Every dataset-58 set is checked for its point count; geometry sets (2411, 15) for
    whole node records. Other dataset types are indexed but not read.
    """
    import pyuff

    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
    except Exception as exc:  # pyuff raises bare Exception
        raise DataFormatError(f"{path}: pyuff could not index the UFF datasets: {exc}") from exc
    if not types:
        raise DataFormatError(
            f"{path}: no complete UFF dataset found: expected '    -1' / number / ... / "
            f"'    -1' blocks"
        )
    unknown = [k for k, t in enumerate(types) if t <= 0]
    if unknown:
        raise DataFormatError(
            f"{path}: corrupt UFF file: dataset(s) {unknown} have no dataset number on the "
            f"line after their opening '    -1' (a delimiter is probably missing or extra)"
        )
    out: dict[int, list[tuple[int, dict]]] = {t: [] for t in wanted}
    for k, t in enumerate(types):
        if t not in out:
            continue
        try:
            dset = uff.read_sets(k)
        except Exception as exc:
            root = exc
            while root.__context__ is not None:  # pyuff re-raises bare Exceptions
                root = root.__context__
            what = ("11 header records of dataset 58 followed by the data values" if t == 58
                    else f"the records of dataset {t}")
            raise DataFormatError(
                f"{path}: dataset {k} (type {t}, set {k + 1} of {len(types)}) is corrupt: "
                f"pyuff could not parse it ({exc} <- {type(root).__name__}: {root}); "
                f"expected {what}"
            ) from exc
        if t == 58:
            n_pts = int(dset.get("num_pts", -1))
            n_read = len(dset["data"])
            if n_pts != n_read:
                raise DataFormatError(
                    f"{path}: dataset {k} (type 58): record 7 says {n_pts} data values, "
                    f"found {n_read}; the set is truncated or corrupt"
                )
            if n_read < 1:
                raise DataFormatError(f"{path}: dataset {k} (type 58) holds no data values")
        elif t in _GEOMETRY_TYPES:
            sizes = {len(dset.get(key, ())) for key in ("node_nums", "x", "y", "z")}
            if len(sizes) != 1:
                raise DataFormatError(
                    f"{path}: dataset {k} (type {t}) is truncated or corrupt: its node "
                    f"records are incomplete (node numbers and x, y, z of different "
                    f"counts {sorted(sizes)}); expected 7 values per node"
                )
        out[t].append((k, dset))
    return types, out


def _read_pyuff_sets(path: Path) -> list[tuple[int, dict]]:
    """Read every dataset 58 of ``path`` with pyuff: (index in file, dict) pairs."""
    types, found = _read_sets(path, (58,))
    if not found[58]:
        raise DataFormatError(
            f"{path}: no dataset 58 (function at nodal DOF): the file holds dataset types "
            f"{sorted(set(types))}"
        )
    return found[58]


def _header_only(dset: Mapping) -> Mapping:
    return MappingProxyType({k: v for k, v in dset.items() if k not in ("x", "data")})


def _code_name(table: Mapping, code: int) -> str:
    for name, (c, _, _) in table.items():
        if c == code:
            return name
    return "unknown"


def _common_of(p: Path, selected: list[tuple[int, dict]], func_type: int,
               what: str = "") -> dict[str, Any]:
    """Fields shared by a selection of sets, after checking they share one abscissa."""
    k0, d0 = selected[0]
    x0 = np.asarray(d0["x"], dtype=np.float64)
    scale = float(np.max(np.abs(x0))) or 1.0
    what = what or f"every set of function type {func_type}"
    for k, d in selected[1:]:
        x = np.asarray(d["x"], dtype=np.float64)
        if x.shape != x0.shape:
            raise DataFormatError(
                f"{p}: inconsistent abscissae: dataset {k} has {x.size} points, dataset "
                f"{k0} has {x0.size}; expected {what} to share one abscissa"
            )
        err = float(np.max(np.abs(x - x0)))
        if err > _SAME_ABSCISSA_RTOL * scale:
            raise DataFormatError(
                f"{p}: inconsistent abscissae: dataset {k} differs from dataset {k0} by up "
                f"to {err:.6g} (first values {x[:2].tolist()} vs {x0[:2].tolist()}); "
                f"expected {what} to share one abscissa"
            )
    return {
        "path": p,
        "func_type": int(func_type),
        "abscissa": x0,
        "abscissa_units": str(d0.get("abscissa_axis_units_lab", "")),
        "id_lines": tuple(str(d0.get(f"id{m}", "")) for m in range(1, 6)),
        "binary": bool(d0.get("binary", 0)),
        "sets": tuple(_header_only(d) for _, d in selected),
    }


def read_uff58(path: str | PathLike, *, func_type: int | None = None) -> UFFData:
    """Read the dataset-58 functions of a UFF file into arrays.

    Parameters
    ----------
    path : str or os.PathLike
        ``.uff`` / ``.unv`` file, ASCII or binary (58b), possibly with other datasets
        (they are skipped).
    func_type : int, optional
        Read only the sets of this UFF function type (1 time response, 4 FRF, 6
        coherence, ...). If omitted, all dataset-58 sets must share one type.

    Returns
    -------
    UFFData
        For function type 1: ``data`` (n_channels, n_samples) in file order and
        ``dt_s``. For other types: ``freq_hz`` (n_freq,) and ``H`` (n_freq, n_out,
        n_in) assembled from the sets by (response node/dir, reference node/dir), in
        order of first appearance. Node/direction arrays, names, units, FRF type and
        the raw headers as metadata.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    truthbench.errors.DataFormatError
        For an empty, truncated or corrupt file, no dataset 58 (of ``func_type``),
        mixed function types, sets with different abscissae, a non-uniform time axis,
        or FRF sets that repeat a (response, reference) pair or leave one out.
    """
    p = Path(path)
    raw = p.read_bytes()
    _check_delimiters(p, raw)
    found = _read_pyuff_sets(p)
    types = sorted({int(d["func_type"]) for _, d in found})
    if func_type is None:
        if len(types) > 1:
            raise DataFormatError(
                f"{p}: the dataset-58 sets have function types {types}; expected one type "
                f"(pass func_type= to choose one)"
            )
        func_type = types[0]
    selected = [(k, d) for k, d in found if int(d["func_type"]) == func_type]
    if not selected:
        raise DataFormatError(
            f"{p}: no dataset 58 of function type {func_type}; the file holds types {types}"
        )

    common = _common_of(p, selected, func_type)
    if func_type == _FUNC_TIME:
        return _assemble_time(p, selected, common)
    return _assemble_grid(p, selected, common)


def _assemble_time(p: Path, selected: list[tuple[int, dict]], common: dict) -> UFFData:
    x = common["abscissa"]
    d0 = selected[0][1]
    if int(d0.get("abscissa_spacing", 0)) == 1:
        dt = float(d0["abscissa_inc"])
    else:
        dt = float((x[-1] - x[0]) / (x.size - 1)) if x.size > 1 else float("nan")
    # Uniform up to the 6-digit rounding of an ASCII abscissa (5e-6 of each value).
    dev = np.abs(x - (x[0] + np.arange(x.size) * dt)) if math.isfinite(dt) else np.inf
    if not (math.isfinite(dt) and dt > 0) or np.max(dev) > 1e-5 * np.max(np.abs(x)):
        steps = np.diff(x)
        raise DataFormatError(
            f"{p}: dataset {selected[0][0]}: time abscissa is not uniformly spaced "
            f"(steps from {steps.min() if steps.size else 'n/a'} to "
            f"{steps.max() if steps.size else 'n/a'} s); expected a constant dt_s > 0"
        )
    if any(np.iscomplexobj(d["data"]) for _, d in selected):
        raise DataFormatError(
            f"{p}: time-response sets (function type 1) hold complex values; expected real"
        )
    data = np.array([np.asarray(d["data"]) for _, d in selected], dtype=np.float64)
    return UFFData(
        **common,
        data=data,
        dt_s=dt,
        resp_nodes=[int(d["rsp_node"]) for _, d in selected],
        resp_dirs=[int(d["rsp_dir"]) for _, d in selected],
        ref_nodes=[int(d["ref_node"]) for _, d in selected],
        ref_dirs=[int(d["ref_dir"]) for _, d in selected],
        resp_names=tuple(str(d.get("rsp_ent_name", "")) for _, d in selected),
        ref_names=tuple(str(d.get("ref_ent_name", "")) for _, d in selected),
        resp_units=tuple(str(d.get("ordinate_axis_units_lab", "")) for _, d in selected),
        ref_units=tuple(str(d.get("orddenom_axis_units_lab", "")) for _, d in selected),
        quantities=tuple(
            _code_name(TIME_QUANTITIES, int(d.get("ordinate_spec_data_type", 0)))
            for _, d in selected
        ),
    )


def _assemble_grid(p: Path, selected: list[tuple[int, dict]], common: dict,
                   label: str = "") -> UFFData:
    resp: dict[tuple[int, int], int] = {}
    ref: dict[tuple[int, int], int] = {}
    resp_meta: list[dict] = []
    ref_meta: list[dict] = []
    where: dict[tuple[int, int], int] = {}  # (i, j) -> position in ``selected``
    for pos, (k, d) in enumerate(selected):
        r = (int(d["rsp_node"]), int(d["rsp_dir"]))
        f = (int(d["ref_node"]), int(d["ref_dir"]))
        if r not in resp:
            resp[r] = len(resp)
            resp_meta.append(d)
        if f not in ref:
            ref[f] = len(ref)
            ref_meta.append(d)
        key = (resp[r], ref[f])
        if key in where:
            raise DataFormatError(
                f"{p}{label}: datasets {selected[where[key]][0]} and {k} both hold "
                f"response node {r[0]} dir {r[1]} / reference node {f[0]} dir {f[1]}; "
                f"expected each (response, reference) pair once"
            )
        where[key] = pos
    n_out, n_in = len(resp), len(ref)
    if len(where) != n_out * n_in:
        rkeys, fkeys = list(resp), list(ref)
        missing = [
            f"resp {rkeys[i]} / ref {fkeys[j]}"
            for i in range(n_out)
            for j in range(n_in)
            if (i, j) not in where
        ]
        raise DataFormatError(
            f"{p}{label}: the sets do not fill the {n_out} x {n_in} (response x reference) "
            f"grid: "
            f"missing (node, dir) pairs {missing[:6]}{' ...' if len(missing) > 6 else ''}; "
            f"expected one set per pair"
        )
    values = [np.asarray(d["data"]) for _, d in selected]
    is_complex = any(np.iscomplexobj(v) for v in values) or common["func_type"] == _FUNC_FRF
    H = np.zeros((common["abscissa"].size, n_out, n_in), complex if is_complex else float)
    for (i, j), pos in where.items():
        H[:, i, j] = values[pos]

    frf_type = None
    if common["func_type"] == _FUNC_FRF:
        codes = {
            (int(d.get("ordinate_spec_data_type", 0)), int(d.get("orddenom_spec_data_type", 0)))
            for _, d in selected
        }
        for name, (num, den) in FRF_TYPES.items():
            if codes == {(num[0], den[0])}:
                frf_type = name
    return UFFData(
        **common,
        freq_hz=common["abscissa"],
        H=H,
        frf_type=frf_type,
        resp_nodes=[r[0] for r in resp],
        resp_dirs=[r[1] for r in resp],
        ref_nodes=[f[0] for f in ref],
        ref_dirs=[f[1] for f in ref],
        resp_names=tuple(str(d.get("rsp_ent_name", "")) for d in resp_meta),
        ref_names=tuple(str(d.get("ref_ent_name", "")) for d in ref_meta),
        resp_units=tuple(str(d.get("ordinate_axis_units_lab", "")) for d in resp_meta),
        ref_units=tuple(str(d.get("orddenom_axis_units_lab", "")) for d in ref_meta),
    )
