"""FRFData -> UFF files: :func:`write_uff` (datasets 151, 164, 2411 and 58) and the rule
that numbers the channels' points, :func:`number_points` (:class:`PointNumbers`); the
reader of such files, and the ID lines the writer puts on every set, are in
:mod:`truthbench.io.uff_frf`.

Writing
-------
:func:`write_uff` writes a dataset 151 (header), a 164 (SI: factors 1), a 2411 with the
channels' points and coordinates, one dataset 58 FRF set (function type 4) per
(output, input) pair, j outer and i inner, and (``coherence=True``) one coherence set
(function type 6) per pair. Each FRFData is its own load case (1, 2, ...). Data type
codes, unit labels and unit exponents follow the channels' quantities
(:mod:`truthbench.quantities`); the entity names are the channels' stations when they
are valid UFF names (1-10 ASCII characters).

**Node numbering** (:func:`number_points`): if every channel has a point number and
the numbers and coordinates agree one to one, those numbers are kept (a file read and
written again keeps its points). Otherwise the distinct coordinates of all channels,
sorted by (x, y, z), are numbered 1, 2, ...; then channels without coordinates get one
number per distinct station, then per distinct label, in order of appearance. Channels
at the same coordinates share a point (a driving point: sensor and actuator at one
station). Only points with coordinates are written to 2411.

Precision: ASCII keeps 12 significant digits per real or imaginary part (and per
coherence value) and 6 for the frequency axis (the writer warns when the axis is not
exact in 6 digits); 2411 coordinates keep 17 digits; ``binary=True`` ("58b") stores
doubles: exact.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np

from truthbench.io._uff58_write import _base_set, _plan_abscissa, _write_sets
from truthbench.io._uff_codes import (
    _COHERENCE_AXIS,
    _FREQUENCY_AXIS,
    _FUNC_COHERENCE,
    _FUNC_FRF,
    DIRECTION_CODES,
)
from truthbench.io.units import quantity_dimension
from truthbench.quantities import quantity

if TYPE_CHECKING:
    from truthbench.measure.frfdata import Channel, FRFData

__all__ = ["PointNumbers", "number_points", "write_uff"]


# ======================================================================== points


@dataclass(frozen=True)
class PointNumbers:
    """UFF point (node) numbers of the channels of several FRFData (:func:`number_points`).

    Attributes
    ----------
    coordinates_m : Mapping[int, tuple of 3 float or None]
        Point number -> coordinates, m (None for a point known only by station or label).
    names : Mapping[int, str]
        Point number -> the stations (or labels) at it, joined by ``"/"``.
    outputs, inputs : tuple of tuple of int
        Per FRFData, the point of each output / input channel.
    """

    coordinates_m: Mapping[int, tuple[float, float, float] | None]
    names: Mapping[int, str]
    outputs: tuple[tuple[int, ...], ...]
    inputs: tuple[tuple[int, ...], ...]


def _as_sequence(frfs) -> tuple[FRFData, ...]:
    from truthbench.measure.frfdata import FRFData

    items = (frfs,) if isinstance(frfs, FRFData) else tuple(frfs)
    if not items:
        raise ValueError("expected an FRFData or a non-empty sequence of FRFData; got none")
    bad = [type(d).__name__ for d in items if not isinstance(d, FRFData)]
    if bad:
        raise ValueError(f"expected FRFData objects; got {bad[0]}")
    return items


def number_points(frfs) -> PointNumbers:
    """Number the points of the channels of one or several FRFData (module notes).

    Parameters
    ----------
    frfs : FRFData or sequence of FRFData

    Returns
    -------
    PointNumbers
    """
    frfs = _as_sequence(frfs)
    chans = [ch for d in frfs for ch in (*d.outputs, *d.inputs)]

    def name_of(ch: Channel) -> str:
        return ch.station or ch.label

    # keep the channels' own point numbers when they name the points one to one
    by_point: dict[int, tuple | None] = {}
    kept = all(ch.point is not None and 0 < ch.point <= 2_147_483_647 for ch in chans)
    if kept:
        for ch in chans:
            if by_point.setdefault(ch.point, ch.coordinates_m) != ch.coordinates_m:
                kept = False
                break
    coords = [c for c in by_point.values() if c is not None]
    if kept and len(set(coords)) == len(coords):
        number = {id(ch): ch.point for ch in chans}
    else:
        keys: dict[tuple, int] = {}
        for key in sorted({ch.coordinates_m for ch in chans if ch.coordinates_m is not None}):
            keys[("xyz", key)] = len(keys) + 1
        for ch in chans:
            if ch.coordinates_m is None and ch.station is not None:
                keys.setdefault(("station", ch.station), len(keys) + 1)
        for ch in chans:
            if ch.coordinates_m is None and ch.station is None:
                keys.setdefault(("label", ch.label), len(keys) + 1)

        def key_of(ch):
            if ch.coordinates_m is not None:
                return ("xyz", ch.coordinates_m)
            return ("station", ch.station) if ch.station is not None else ("label", ch.label)

        number = {id(ch): keys[key_of(ch)] for ch in chans}
    coordinates: dict[int, tuple | None] = {}
    names: dict[int, list[str]] = {}
    for ch in chans:
        n = number[id(ch)]
        coordinates.setdefault(n, ch.coordinates_m)
        if name_of(ch) not in names.setdefault(n, []):
            names[n].append(name_of(ch))
    order = sorted(coordinates)
    return PointNumbers(
        coordinates_m=MappingProxyType({n: coordinates[n] for n in order}),
        names=MappingProxyType({n: "/".join(names[n]) for n in order}),
        outputs=tuple(tuple(number[id(c)] for c in d.outputs) for d in frfs),
        inputs=tuple(tuple(number[id(c)] for c in d.inputs) for d in frfs),
    )


# ======================================================================== writing


def _ascii(text: str, limit: int) -> str:
    text = "".join(c if c.isascii() and c.isprintable() else "?" for c in str(text)).strip()
    return text[:limit] or "NONE"


def _entity(ch: Channel) -> str:
    s = ch.station
    ok = s is not None and 0 < len(s) <= 10 and s.isascii() and s == s.strip() and " " not in s
    return s if ok else "NONE"


def _code(ch: Channel) -> int:
    return 0 if ch.direction is None else DIRECTION_CODES[ch.direction] * ch.sign


def _id_lines_for(d: FRFData, i: int, j: int) -> list[str]:
    out, inp = d.outputs[i], d.inputs[j]
    pair = f"{out.label} / {inp.label}"
    ok = (" / " not in out.label and " / " not in inp.label and len(pair) <= 80
          and pair.isascii() and "\n" not in pair)
    lines = [
        _ascii(d.name, 80),
        pair if ok else "NONE",
        f"grid={len(d.outputs)}x{len(d.inputs)} row={i + 1} col={j + 1}",
        "NONE" if d.band_hz is None else f"band_hz={d.band_hz[0]!r},{d.band_hz[1]!r}",
        (f"n_averages={d.n_averages if d.n_averages is not None else 'none'} "
         f"excitation={d.excitation} window_decay_rad_s={d.window_decay_rad_s!r}"),
    ]
    return [line if len(line) <= 80 else "NONE" for line in lines]


def _set_58(d: FRFData, i: int, j: int, *, func_type: int, func_id: int, load_case: int,
            points: PointNumbers, k: int, spacing: int, binary: bool) -> dict:
    out, inp = d.outputs[i], d.inputs[j]
    if func_type == _FUNC_FRF:
        q = quantity(out.quantity)
        ordinate = (q.uff_code, out.quantity.capitalize(), out.unit)
        denominator = (quantity("force").uff_code, "Force", inp.unit)
        y = np.array(d.H[:, i, j], dtype=np.complex128)
        exps = (quantity_dimension(out.quantity, out.direction),
                quantity_dimension("force", inp.direction))
    else:
        ordinate, denominator = _COHERENCE_AXIS, None
        y = np.array(d.coherence[:, i, j], dtype=np.float64)
        exps = ((0, 0, 0), (0, 0, 0))
    dset = _base_set(
        func_type=func_type, func_id=func_id, id_lines=_id_lines_for(d, i, j),
        x=np.array(d.freq_hz, dtype=np.float64), y=y, spacing=spacing, binary=binary,
        rsp=(_entity(out), points.outputs[k][i], _code(out)),
        ref=(_entity(inp), points.inputs[k][j], _code(inp)),
        abscissa=_FREQUENCY_AXIS, ordinate=ordinate, denominator=denominator)
    dset["load_case_id"] = load_case
    dset["ordinate_len_unit_exp"], dset["ordinate_force_unit_exp"] = exps[0][:2]
    dset["orddenom_len_unit_exp"], dset["orddenom_force_unit_exp"] = exps[1][:2]
    return dset


def _check_writable(d: FRFData, k: int) -> None:
    for what, arr in (("H", d.H), ("coherence", d.coherence)):
        if arr is None:
            continue
        bad = ~np.isfinite(arr).reshape(arr.shape[0], -1).all(axis=1)
        if bad.any():
            raise ValueError(
                f"write_uff: FRFData {k} ({d.name!r}): {what} holds non-finite values at "
                f"{int(bad.sum())} line(s) (first at {d.freq_hz[bad][0]:g} Hz); UFF cannot "
                f"store them: expected finite values (drop those lines with "
                f"FRFData.lines(mask))")
    if d.freq_hz.size < 2 or np.any(np.diff(d.freq_hz) <= 0):
        raise ValueError(f"write_uff: FRFData {k} ({d.name!r}): expected at least 2 "
                         f"strictly increasing frequency lines; got {d.freq_hz.size}")


def write_uff(path: str | PathLike, frfs, *, binary: bool = False,
              coherence: bool = True) -> Path:
    """Write FRFData as UFF: 151, 164 (SI), 2411 points, 58 FRF and coherence sets.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (``.uff`` or ``.unv``); replaced if it exists, through a temporary
        file in the same folder (a failed write leaves no partial file).
    frfs : FRFData or sequence of FRFData
        Each becomes one load case (1, 2, ...), with ``n_out * n_in`` FRF sets; values in
        SI units of the channels' quantities.
    binary : bool
        False: ASCII, 12 significant digits per part, frequency axis with 6 (warns if
        that changes it). True: binary "58b", exact doubles.
    coherence : bool
        Also write each FRFData's coherence (if it has one) as function-type-6 sets.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        Not FRFData, non-finite values, fewer than 2 frequency lines, or two channels of
        one side on the same point and direction (the message names them).
    """
    from truthbench._version import __version__

    frfs = _as_sequence(frfs)
    for k, d in enumerate(frfs):
        _check_writable(d, k)
    points = number_points(frfs)
    for k, d in enumerate(frfs):
        for side, chans, pts in (("output", d.outputs, points.outputs[k]),
                                 ("input", d.inputs, points.inputs[k])):
            seen: dict[tuple[int, int], str] = {}
            for ch, p in zip(chans, pts, strict=True):
                other = seen.setdefault((p, _code(ch)), ch.label)
                if other != ch.label:
                    raise ValueError(
                        f"write_uff: FRFData {k} ({d.name!r}): {side} channels {other!r} and "
                        f"{ch.label!r} are both at point {p} direction code {_code(ch)}; "
                        f"expected one channel per point and direction")
    header = [
        {"type": 151, "model_name": _ascii(frfs[0].name if len(frfs) == 1
                                           else f"{len(frfs)} FRF data sets", 80),
         "description": "FRFs (58, function type 4), coherence (type 6), SI units",
         "db_app": "truthbench", "program": f"truthbench {__version__}"},
        {"type": 164, "units_code": 1, "units_description": "SI", "temp_mode": 2,
         "length": 1.0, "force": 1.0, "temp": 1.0, "temp_offset": 273.15},
    ]
    located = [(n, xyz) for n, xyz in points.coordinates_m.items() if xyz is not None]
    if located:
        header.append({
            "type": 2411,
            "node_nums": np.array([n for n, _ in located], dtype=np.int64),
            "def_cs": np.ones(len(located), dtype=np.int64),
            "disp_cs": np.ones(len(located), dtype=np.int64),
            "color": np.ones(len(located), dtype=np.int64),
            "x": np.array([xyz[0] for _, xyz in located]),
            "y": np.array([xyz[1] for _, xyz in located]),
            "z": np.array([xyz[2] for _, xyz in located]),
        })
    dsets = []
    for k, d in enumerate(frfs):
        spacing = _plan_abscissa(d.freq_hz, binary, f"FRFData {d.name!r}: freq_hz")
        kinds = [_FUNC_FRF] + ([_FUNC_COHERENCE] if coherence and d.coherence is not None
                               else [])
        for func_type in kinds:
            for j in range(len(d.inputs)):
                for i in range(len(d.outputs)):
                    dsets.append(_set_58(d, i, j, func_type=func_type, func_id=len(dsets) + 1,
                                         load_case=k + 1, points=points, k=k,
                                         spacing=spacing, binary=binary))
    return _write_sets(path, dsets, binary, header_sets=header)
