"""Universal File Format (UFF) dataset 58, the private layer under the public UFF
reader and writer (:mod:`truthbench.io.uff_frf`: :func:`~truthbench.io.read_uff`;
:mod:`truthbench.io.uff_write`: :func:`~truthbench.io.write_uff`; they exchange
:class:`~truthbench.measure.FRFData`).

This module holds the dataset-58 ("function at nodal DOF") plumbing, built on ``pyuff``:
:func:`read_uff58` returning a frozen :class:`UFFData` of raw arrays, and, from
:mod:`truthbench.io._uff58_write`, :func:`write_uff58_frf` and :func:`write_uff58_time`
(the tests also use the writers to make files of other tools' layouts); the one table
of UFF direction codes, :data:`DIRECTION_CODES`, and the other codes are in
:mod:`truthbench.io._uff_codes`. One dataset 58 holds one function of one response DOF
and one reference DOF; a file of FRFs holds one set per (output, input) pair.

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
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from truthbench._validation import readonly
from truthbench.errors import DataFormatError
from truthbench.io._uff58_write import write_uff58_frf, write_uff58_time
from truthbench.io._uff_codes import (
    _DELIMITER,
    _FUNC_FRF,
    _FUNC_TIME,
    DIRECTION_CODES,
    FRF_TYPES,
    NODE_OFFSET,
    TIME_QUANTITIES,
    direction_label,
)

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

# A delimiter as pyuff recognises one: followed by a line end, the end of the file or
# blanks up to column 80.
_DELIMITER_RE = re.compile(rb"    -1(?=\r|\n|\Z| {74})")
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
