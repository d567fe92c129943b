"""UFF files -> FRFData: FRF and coherence sets (58), units (164), points (2411).

:func:`read_uff` is the ``.uff`` / ``.unv`` reader of :func:`truthbench.io.load_frf`;
:func:`~truthbench.io.write_uff` (:mod:`truthbench.io.uff_write`) writes FRFData for
other tools. Both go through pyuff (the private :mod:`truthbench.io._uff58` holds the
dataset-58 layer and :mod:`truthbench.io._uff_codes` the one table of direction codes,
:data:`DIRECTION_CODES`).

Reading
-------
* **FRF sets** (dataset 58, function type 4) become one :class:`~truthbench.measure.FRFData`
  per load case (record 6, field 4; most files have one), ``H[:, i, j]`` from the set of
  response DOF i and reference DOF j (in order of first appearance). A grid with a
  missing (response, reference) pair is an error naming the pairs; so is a file cut at
  a dataset boundary when its sets carry truthbench's grid size (see *ID lines*).
* **Channels** come from record 6: the node is ``Channel.point``, the direction code
  ``1..6`` is x, y, z, rx, ry, rz and a negative code the negative sense
  (``Channel.sign = -1``), code 0 no direction. The output quantity is the ordinate
  (numerator) specific data type through :func:`truthbench.quantities.by_uff_code`
  (3 strain, 8 displacement, 11 velocity, 12 acceleration), or, for data type 0, the
  quantity whose dimension the unit label has; the reference must be an excitation
  force (denominator data type 13, or 0 with a force unit label), else the file has no
  reference (force) channel and is refused.
* **Units.** A dataset 164 gives the file's unit system: a value of dimension
  (length^L force^F time^T) is divided by ``length_factor^L force_factor^F`` to give
  SI (time is always s, angles rad). Every unit label of a set (ordinate, denominator,
  or an FRF unit such as ``"mm/s^2/kN"`` in the ordinate label) that
  :func:`truthbench.io.units.parse_unit` understands must agree with dataset 164 to
  0.1 % (distinct units differ by factors of at least 1.09), and its record 9-11 unit
  exponents, when not zero, must be the quantity's (L, F); else a
  :class:`~truthbench.errors.DataFormatError` names the file, the set and both units.
  Without a dataset 164 the labels set the units; a set without understood labels is
  taken as SI (said in ``notes``).
* **Coherence**: function type 6 sets of the same load case in the same file, or in a
  separate file (``coherence=path``, which then replaces the file's own), are attached
  to the matching (response, reference) pairs; they must cover the FRF grid exactly.
* **Geometry**: dataset 2411 (or 15) node coordinates, scaled to metres by dataset
  164's length factor, become ``Channel.coordinates_m`` of the channels at those nodes
  (as written: coordinate systems (2420) are not applied, the frame is taken to be
  global). :func:`truthbench.measure.match_points` maps them to model nodes.
* **Time sets** (function type 1), used when the file holds no FRF sets, become H1
  FRFs (:func:`truthbench.io.time_records.frf_from_channels`): the input is the force
  channel (data type 13) or one named like an input.

ID lines (truthbench's convention, free text to other tools): ID 1 the FRFData name,
ID 2 ``"<output label> / <input label>"``, ID 3 ``"grid=<n_out>x<n_in> row=<i> col=<j>"``
(1-based), ID 4 ``"band_hz=<low>,<high>"``, ID 5 ``"n_averages=<n> excitation=<kind>
window_decay_rad_s=<sigma>"``. The reader takes labels, name, band, averages,
excitation and window decay from them when every set of a load case agrees, and checks
the grid size; files of other tools simply lack them.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from os import PathLike
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from truthbench.errors import DataFormatError
from truthbench.io._uff58 import (
    _SAME_ABSCISSA_RTOL,
    _assemble_grid,
    _assemble_time,
    _check_delimiters,
    _common_of,
    _read_sets,
)
from truthbench.io._uff_codes import (
    _FUNC_COHERENCE,
    _FUNC_FRF,
    _FUNC_TIME,
    DIRECTION_CODES,
    direction_label,
    direction_name,
)
from truthbench.io.units import SI, UNIT_SYMBOLS, UnitSystem, parse_unit, quantity_dimension
from truthbench.quantities import RESPONSE_QUANTITIES, by_uff_code, quantity

if TYPE_CHECKING:
    from truthbench.measure.frfdata import FRFData

__all__ = ["DIRECTION_CODES", "direction_label", "read_uff", "read_uff_files"]

#: Relative agreement of a unit label with dataset 164 (distinct units differ by >= 9 %).
UNIT_RTOL = 1e-3
_KEY = re.compile(r"\b(grid|row|col|band_hz|n_averages|excitation|window_decay_rad_s)=(\S+)")


@dataclass(frozen=True)
class _File:
    path: Path
    units: UnitSystem | None
    geometry: Mapping[int, tuple[float, float, float]]
    sets58: list[tuple[int, dict]]
    notes: tuple[str, ...]


def _parse_file(p: Path) -> _File:
    raw = p.read_bytes()
    _check_delimiters(p, raw)
    types, found = _read_sets(p, (58, 164, 2411, 15))
    if not found[58]:
        raise DataFormatError(
            f"{p}: no dataset 58 (function at nodal DOF): the file holds dataset types "
            f"{sorted(set(types))}")
    notes = []
    systems = {}
    for k, d in found[164]:
        try:
            u = UnitSystem(code=int(d["units_code"]), description=str(d["units_description"]),
                           length=float(d["length"]), force=float(d["force"]),
                           temperature=float(d["temp"]),
                           temperature_offset=float(d["temp_offset"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise DataFormatError(f"{p}: dataset {k} (type 164) is not a valid unit system: "
                                  f"{exc}") from None
        systems.setdefault((u.length, u.force), (k, u))
    if len(systems) > 1:
        shown = "; ".join(f"dataset {k}: {u.describe()}" for k, u in systems.values())
        raise DataFormatError(f"{p}: several datasets 164 with different units ({shown}); "
                              f"expected one unit system per file")
    units = next(iter(systems.values()))[1] if systems else None
    if units is None:
        notes.append("no dataset 164: units from the labels, SI where they say nothing")
    elif not units.is_si:
        notes.append(f"dataset 164: {units.describe()}; converted to SI")
    scale = 1.0 if units is None else 1.0 / units.length
    geometry: dict[int, tuple[float, float, float]] = {}
    for t in (2411, 15):
        for k, d in found[t]:
            nums = np.asarray(d["node_nums"], dtype=float)
            if np.any(nums != np.round(nums)) or np.any(nums < 1):
                raise DataFormatError(f"{p}: dataset {k} (type {t}): node numbers must be "
                                      f"positive integers; got {nums[:5].tolist()}")
            xyz = np.column_stack([d["x"], d["y"], d["z"]]).astype(float) * scale
            for n, c in zip(nums.astype(int).tolist(), xyz.tolist(), strict=True):
                c = tuple(float(v) for v in c)
                if geometry.setdefault(n, c) != c:
                    raise DataFormatError(
                        f"{p}: node {n} has two positions, {geometry[n]} and {c} m (dataset "
                        f"{k}, type {t}); expected one per node")
    return _File(p, units, MappingProxyType(geometry), found[58], tuple(notes))


def _unit_text(dim: tuple[int, int, int], units: UnitSystem) -> str:
    """The unit of dimension ``dim`` in ``units``, e.g. ``"mm/s^2"``, ``"kN"``."""

    def symbol(d, factor):
        for name, (s, sd) in UNIT_SYMBOLS.items():
            if sd == d and math.isclose(s * factor, 1.0, rel_tol=UNIT_RTOL) and name.isascii():
                return name
        return f"({1 / factor:g} {'m' if d == (1, 0, 0) else 'N'})"

    parts = [(symbol((1, 0, 0), units.length), dim[0]), (symbol((0, 1, 0), units.force), dim[1]),
             ("s", dim[2])]
    num = " ".join(b if e == 1 else f"{b}^{e}" for b, e in parts if e > 0) or "1"
    den = " ".join(b if e == -1 else f"{b}^{-e}" for b, e in parts if e < 0)
    return num if not den else f"{num}/{den}" if " " not in den else f"{num}/({den})"


def _set_where(d: Mapping, k: int, lc: int) -> str:
    return (f"dataset {k} (load case {lc}, response node {int(d['rsp_node'])} dir "
            f"{int(d['rsp_dir'])}, reference node {int(d['ref_node'])} dir "
            f"{int(d['ref_dir'])})")


def _response_quantity(p, d, k, lc, axis: str, allow_force: bool) -> str | None:
    """Quantity of the ordinate: from its data type, else from its unit label."""
    code = int(d.get(f"{axis}_spec_data_type", 0))
    direction = direction_name(d["rsp_dir"])
    q = by_uff_code(code) if code else None
    if q is not None:
        if q.name == "force" and not allow_force:
            raise DataFormatError(
                f"{p}: {_set_where(d, k, lc)}: the ordinate is an excitation force (data "
                f"type 13); expected a response (acceleration 12, velocity 11, displacement "
                f"8 or strain 3)")
        return q.name
    parsed = parse_unit(str(d.get(f"{axis}_axis_units_lab", "")))
    if parsed is None:
        return None
    names = [*RESPONSE_QUANTITIES, *(("force",) if allow_force else ())]
    matches = [n for n in names if quantity_dimension(n, direction) == parsed[1]]
    return matches[0] if len(matches) == 1 else None


def _is_force_reference(d: Mapping) -> bool:
    code = int(d.get("orddenom_spec_data_type", 0))
    if code:
        return code == quantity("force").uff_code
    parsed = parse_unit(str(d.get("orddenom_axis_units_lab", "")))
    direction = direction_name(d["ref_dir"])
    return parsed is not None and parsed[1] == quantity_dimension("force", direction)


def _axis_factor(p, d, k, lc, axis: str, q: str, direction: str | None,
                 units: UnitSystem | None, frf_dim=None) -> tuple[float, bool]:
    """(factor to SI, understood) of one axis of a set; checks labels and exponents."""
    dim = quantity_dimension(q, direction)
    lab = str(d.get(f"{axis}_axis_units_lab", "")).strip()
    exps = (int(d.get(f"{axis}_len_unit_exp", 0)), int(d.get(f"{axis}_force_unit_exp", 0)))
    where = _set_where(d, k, lc)
    if exps != (0, 0) and exps != dim[:2]:
        raise DataFormatError(
            f"{p}: {where}: the {axis} unit exponents (length {exps[0]}, force {exps[1]}) "
            f"disagree with its quantity {q} (length {dim[0]}, force {dim[1]}); expected "
            f"those or zeros")
    parsed = parse_unit(lab)
    if parsed is not None and parsed[1] not in (dim, frf_dim):
        raise DataFormatError(
            f"{p}: {where}: the {axis} unit {lab!r} is not a unit of {q} (expected "
            f"{_unit_text(dim, units or SI)}, e.g. from dataset 164)")
    if units is not None:
        want = units.to_si(dim)
        if parsed is not None and parsed[1] == dim and not math.isclose(
                parsed[0], want, rel_tol=UNIT_RTOL):
            raise DataFormatError(
                f"{p}: {where}: the {axis} unit {lab!r} disagrees with dataset 164 "
                f"({units.describe()}), whose unit of {q} is {_unit_text(dim, units)!r}; "
                f"expected the labels and dataset 164 to agree")
        return want, True
    if parsed is not None and parsed[1] == dim:
        return parsed[0], True
    return 1.0, False


def _meta(selected) -> tuple[dict[str, str], list[dict[str, str]]]:
    """Keys of truthbench's ID-line convention shared by every set, and those per set."""
    per = []
    for _, d in selected:
        found = {}
        for m in (3, 4, 5):
            for key, value in _KEY.findall(str(d.get(f"id{m}", ""))):
                found[key] = value
        per.append(found)
    shared = {key: value for key, value in per[0].items()
              if key not in ("row", "col") and all(f.get(key) == value for f in per)}
    return shared, per


def _number(p, lc, key, text, kind):
    try:
        value = kind(text)
    except ValueError:
        raise DataFormatError(f"{p}: load case {lc}: ID line value {key}={text!r} is not "
                              f"{'an integer' if kind is int else 'a number'}") from None
    return value


def _labels_from_id2(selected, rows, cols, n_out, n_in):
    outs: dict[int, str] = {}
    ins: dict[int, str] = {}
    for (_, d), i, j in zip(selected, rows, cols, strict=True):
        parts = str(d.get("id2", "")).split(" / ")
        if len(parts) != 2 or not all(x.strip() for x in parts):
            return None
        if outs.setdefault(i, parts[0].strip()) != parts[0].strip():
            return None
        if ins.setdefault(j, parts[1].strip()) != parts[1].strip():
            return None
    out_labels = [outs[i] for i in range(n_out)]
    in_labels = [ins[j] for j in range(n_in)]
    if len(set(out_labels)) != n_out or len(set(in_labels)) != n_in:
        return None
    return out_labels, in_labels


def _group(sets: list[tuple[int, dict]], func_type: int) -> dict[int, list[tuple[int, dict]]]:
    groups: dict[int, list[tuple[int, dict]]] = {}
    for k, d in sets:
        if int(d["func_type"]) == func_type:
            groups.setdefault(int(d.get("load_case_id", 0)), []).append((k, d))
    return groups


#: Round-off a coherence |Gxy|^2 / (Gxx Gyy) computed in double precision can carry past
#: 0 or 1 (a few hundred eps for sums of up to 10^4 averages); values within it are clipped.
COHERENCE_ROUNDOFF = 1e-12

_CohKey = tuple[int, int, int, int, int]
"""(response node, response dir, reference node, reference dir, load case)."""


def _ids(d: Mapping) -> _CohKey:
    """The ids that pair a coherence set with its FRF set."""
    return (int(d["rsp_node"]), int(d["rsp_dir"]), int(d["ref_node"]), int(d["ref_dir"]),
            int(d.get("load_case_id", 0)))


def _frf_ids(f: _File) -> set[_CohKey]:
    return {_ids(d) for _, d in f.sets58 if int(d["func_type"]) == _FUNC_FRF}


@dataclass(frozen=True, eq=False)
class _Coherence:
    """One coherence set (dataset 58, function type 6) and the file it is in."""

    file: _File
    k: int
    d: dict

    @property
    def load_case(self) -> int:
        return int(self.d.get("load_case_id", 0))

    @property
    def key(self) -> _CohKey:
        return _ids(self.d)

    @property
    def where(self) -> str:
        return f"{self.file.path}: {_set_where(self.d, self.k, self.load_case)}"


def _coherence_sets(files) -> dict[_CohKey, _Coherence]:
    """The coherence sets of ``files`` by their ids (UFF 58 record 6 and load case).

    Raises
    ------
    DataFormatError
        Two sets with the same ids: one FRF pair would get two coherences.
    """
    pool: dict[_CohKey, _Coherence] = {}
    for f in files:
        for k, d in f.sets58:
            if int(d["func_type"]) != _FUNC_COHERENCE:
                continue
            c = _Coherence(f, k, d)
            other = pool.setdefault(c.key, c)
            if other is not c:
                raise DataFormatError(
                    f"{c.where}: a second coherence set of this FRF pair (the first is "
                    f"{other.file.path}: dataset {other.k}); expected one coherence set per "
                    f"FRF pair")
    return pool


def _coherence_values(c: _Coherence, frf_file: _File, freq: np.ndarray) -> np.ndarray:
    """The checked values (n_freq,) of one coherence set on the FRF lines ``freq``."""
    x = np.asarray(c.d["x"], dtype=np.float64)
    scale = max(float(np.max(np.abs(freq))), 1.0)
    if x.shape != freq.shape or np.max(np.abs(x - freq)) > _SAME_ABSCISSA_RTOL * scale:
        def grid(v):
            step = f", step {v[1] - v[0]:g} Hz" if v.size > 1 else ""
            return f"{v.size} lines {v[0]:g}-{v[-1]:g} Hz{step}"

        raise DataFormatError(
            f"{c.where}: the coherence set spans {grid(x)}, the FRF sets of "
            f"{frf_file.path} {grid(freq)}; expected the same lines")
    values = np.asarray(c.d["data"])
    if np.iscomplexobj(values):
        if np.any(values.imag != 0):
            raise DataFormatError(f"{c.where}: complex coherence values; expected real ones "
                                  f"(function type 6)")
        values = values.real
    values = np.asarray(values, dtype=np.float64)
    bad = ~((values >= -COHERENCE_ROUNDOFF) & (values <= 1 + COHERENCE_ROUNDOFF))
    if bad.any():
        n = int(np.argmax(bad))
        raise DataFormatError(
            f"{c.where}: coherence {float(values[n])!r} at {freq[n]:g} Hz "
            f"({int(bad.sum())} value(s) outside [0, 1]); expected an ordinary coherence in "
            f"[0, 1]")
    return np.clip(values, 0.0, 1.0)


def _coherence_grid(frf_file: _File, lc: int, grid, pool: Mapping[_CohKey, _Coherence]):
    """The coherence (n_freq, n_out, n_in) of load case ``lc`` from ``pool`` (None when
    no FRF pair has one) and the sets it took."""
    rk = list(zip(grid.resp_nodes.tolist(), grid.resp_dirs.tolist(), strict=True))
    fk = list(zip(grid.ref_nodes.tolist(), grid.ref_dirs.tolist(), strict=True))
    found = {(i, j): pool.get((*r, *f, lc)) for i, r in enumerate(rk) for j, f in enumerate(fk)}
    used = [c for c in found.values() if c is not None]
    if not used:
        return None, []
    missing = [f"resp {rk[i]} / ref {fk[j]}" for (i, j), c in found.items() if c is None]
    if missing:
        files = ", ".join(dict.fromkeys(str(c.file.path) for c in used))
        raise DataFormatError(
            f"{files}: load case {lc}: the coherence sets leave out the (node, dir) pairs "
            f"{missing[:6]}{' ...' if len(missing) > 6 else ''} of the FRF sets of "
            f"{frf_file.path}; expected one coherence set per FRF pair")
    coh = np.empty(grid.H.shape)
    for (i, j), c in found.items():
        coh[:, i, j] = _coherence_values(c, frf_file, grid.freq_hz)
    return coh, used


def _frf_group(f: _File, lc: int, selected, pool: Mapping[_CohKey, _Coherence],
               several: bool) -> FRFData:
    """The FRFData of load case ``lc`` of ``f``, with its coherence sets from ``pool``."""
    from truthbench.measure.frfdata import Channel, FRFData

    p = f.path
    label = f" (load case {lc})" if several else ""
    common = _common_of(p, selected, _FUNC_FRF, what=f"the FRF sets of load case {lc}")
    grid = _assemble_grid(p, selected, common, label=label)
    n_freq, n_out, n_in = grid.H.shape
    rk = list(zip(grid.resp_nodes.tolist(), grid.resp_dirs.tolist(), strict=True))
    fk = list(zip(grid.ref_nodes.tolist(), grid.ref_dirs.tolist(), strict=True))
    rows = [rk.index((int(d["rsp_node"]), int(d["rsp_dir"]))) for _, d in selected]
    cols = [fk.index((int(d["ref_node"]), int(d["ref_dir"]))) for _, d in selected]
    shared, per = _meta(selected)
    if "grid" in shared:
        m = re.fullmatch(r"(\d+)x(\d+)", shared["grid"])
        if m is None:
            raise DataFormatError(f"{p}: load case {lc}: ID line 3 says grid="
                                  f"{shared['grid']!r}; expected <n_out>x<n_in>")
        want = (int(m.group(1)), int(m.group(2)))
        if want != (n_out, n_in):
            present = {(_number(p, lc, "row", q.get("row", "0"), int),
                        _number(p, lc, "col", q.get("col", "0"), int)) for q in per}
            missing = [f"row {i} / col {j}" for j in range(1, want[1] + 1)
                       for i in range(1, want[0] + 1) if (i, j) not in present]
            raise DataFormatError(
                f"{p}: load case {lc}: the FRF sets say they form a {want[0]} x {want[1]} "
                f"(response x reference) grid (ID line 3), the file holds {n_out} x {n_in}: "
                f"missing pairs {missing[:6]}{' ...' if len(missing) > 6 else ''} (a file cut "
                f"at a dataset boundary?); expected every pair")
    # quantities per row, force per column, unit factors per set
    q_row: dict[int, str] = {}
    factor = np.ones((n_out, n_in))
    assumed = False
    for (k, d), i, j in zip(selected, rows, cols, strict=True):
        where = _set_where(d, k, lc)
        if not _is_force_reference(d):
            raise DataFormatError(
                f"{p}: {where}: no reference (force) channel: the denominator is of data "
                f"type {int(d.get('orddenom_spec_data_type', 0))} with unit "
                f"{str(d.get('orddenom_axis_units_lab', '')).strip()!r}; expected an "
                f"excitation force (data type 13, unit N)")
        q = _response_quantity(p, d, k, lc, "ordinate", allow_force=False)
        if q is None:
            raise DataFormatError(
                f"{p}: {where}: cannot tell what the response measures: ordinate data "
                f"type {int(d.get('ordinate_spec_data_type', 0))}, unit "
                f"{str(d.get('ordinate_axis_units_lab', '')).strip()!r}; expected "
                f"acceleration (12), velocity (11), displacement (8) or strain (3)")
        if q_row.setdefault(i, q) != q:
            raise DataFormatError(
                f"{p}: {where}: the response measures {q} here and {q_row[i]} in another "
                f"set of the same response DOF; expected one quantity per response")
        rdir = direction_name(d["rsp_dir"])
        fdir = direction_name(d["ref_dir"])
        num_dim = quantity_dimension(q, rdir)
        den_dim = quantity_dimension("force", fdir)
        frf_dim = tuple(a - b for a, b in zip(num_dim, den_dim, strict=True))
        lab = parse_unit(str(d.get("ordinate_axis_units_lab", "")))
        if lab is not None and lab[1] == frf_dim and frf_dim != num_dim:
            # the whole FRF unit in the ordinate label (e.g. "mm/s^2/kN"): check the
            # exponents and the denominator label, then the FRF unit against 164
            _axis_factor(p, d, k, lc, "ordinate", q, rdir, f.units, frf_dim)
            _axis_factor(p, d, k, lc, "orddenom", "force", fdir, f.units)
            if f.units is None:
                factor[i, j] = lab[0]
                continue
            want = f.units.to_si(num_dim) / f.units.to_si(den_dim)
            if not math.isclose(lab[0], want, rel_tol=UNIT_RTOL):
                raise DataFormatError(
                    f"{p}: {where}: the ordinate unit "
                    f"{str(d.get('ordinate_axis_units_lab', '')).strip()!r} disagrees with "
                    f"dataset 164 ({f.units.describe()}), whose FRF unit is "
                    f"{_unit_text(frf_dim, f.units)!r}; expected them to agree")
            factor[i, j] = want
        else:
            fn, ok_n = _axis_factor(p, d, k, lc, "ordinate", q, rdir, f.units)
            fd, ok_d = _axis_factor(p, d, k, lc, "orddenom", "force", fdir, f.units)
            factor[i, j] = fn / fd
            assumed |= not (ok_n and ok_d)
    bad = np.argwhere(~np.isfinite(grid.H))
    if bad.size:  # pyuff reads 'nan' and 'inf' as numbers; no FRF line can use them
        k_, i_, j_ = (int(v) for v in bad[0])
        raise DataFormatError(
            f"{p}: load case {lc}: the FRF set of response {rk[i_][0]}:{rk[i_][1]} and "
            f"reference {fk[j_][0]}:{fk[j_][1]} holds a non-finite value at "
            f"{grid.freq_hz[k_]:g} Hz ({bad.shape[0]} non-finite value(s) in the load "
            f"case); expected finite numbers")
    H = grid.H * factor[None, :, :]
    # coherence
    coh, used = _coherence_grid(f, lc, grid, pool)
    # channels
    labels = _labels_from_id2(selected, rows, cols, n_out, n_in)
    ours = "grid" in shared

    def channel(node, code, q, lab, ent):
        direction = direction_name(code)
        return Channel(
            lab or f"{node}:{direction_label(code)}", q, direction,
            sign=-1 if code < 0 else 1, point=node if node > 0 else None,
            coordinates_m=f.geometry.get(node),
            station=ent if ours and ent and ent != "NONE" else None)

    outputs = [channel(n, c, q_row[i], labels[0][i] if labels else None, grid.resp_names[i])
               for i, (n, c) in enumerate(rk)]
    inputs = [channel(n, c, "force", labels[1][j] if labels else None, grid.ref_names[j])
              for j, (n, c) in enumerate(fk)]
    # what our ID lines say
    name = str(selected[0][1].get("id1", "")).strip()
    same_name = all(str(d.get("id1", "")).strip() == name for _, d in selected)
    if not same_name or not name or name == "NONE":
        name = p.stem + (f" load case {lc}" if several else "")
    band = n_avg = None
    excitation, decay = "frf", 0.0
    if "band_hz" in shared:
        lo, _, hi = shared["band_hz"].partition(",")
        band = (_number(p, lc, "band_hz", lo, float), _number(p, lc, "band_hz", hi, float))
    if shared.get("n_averages", "none") != "none":
        n_avg = _number(p, lc, "n_averages", shared["n_averages"], int)
    if shared.get("excitation") in ("frf", "impact", "random"):
        excitation = shared["excitation"]
    if "window_decay_rad_s" in shared:
        decay = _number(p, lc, "window_decay_rad_s", shared["window_decay_rad_s"], float)
    notes = [f"{n_out * n_in} FRF sets (dataset 58, function type 4) of load case {lc} read "
             f"from {p.name}", *f.notes]
    if assumed:
        notes.append("some unit labels say nothing: those sets taken as SI")
    if used:
        names = ", ".join(dict.fromkeys(c.file.path.name for c in used))
        notes.append(f"coherence (function type 6) from {names}")
    missing_xyz = sorted({n for n, _ in (*rk, *fk) if n > 0 and n not in f.geometry})
    if f.geometry and missing_xyz:
        notes.append(f"points {missing_xyz} have no coordinates in the file")
    return FRFData(name=name, freq_hz=grid.freq_hz, H=H, outputs=outputs, inputs=inputs,
                   coherence=coh, n_averages=n_avg, band_hz=band, excitation=excitation,
                   window_decay_rad_s=decay, notes=tuple(notes))


def _time_frf(f: _File, selected, options) -> FRFData:
    from truthbench.io.time_records import frf_from_channels

    p = f.path
    common = _common_of(p, selected, _FUNC_TIME)
    rec = _assemble_time(p, selected, common)
    names, quantities, units, details = [], [], [], []
    data = np.array(rec.data, dtype=float)
    for c, (k, d) in enumerate(selected):
        node, code = int(d["rsp_node"]), int(d["rsp_dir"])
        direction = direction_name(code)
        q = _response_quantity(p, d, k, 0, "ordinate", allow_force=True)
        if q is not None:
            fac, _ = _axis_factor(p, d, k, int(d.get("load_case_id", 0)), "ordinate", q,
                                  direction, f.units)
            data[c] *= fac
        ent = str(d.get("rsp_ent_name", "")).strip()
        names.append(ent if ent and ent != "NONE" else f"{node}:{direction_label(code)}")
        quantities.append(q)
        units.append(str(d.get("ordinate_axis_units_lab", "")).strip())
        details.append({"direction": direction, "sign": -1 if code < 0 else 1,
                        "point": node if node > 0 else None,
                        "coordinates_m": f.geometry.get(node)})
    if len(set(names)) != len(names):
        names = [f"{n}#{c}" for c, n in enumerate(names)]
    return frf_from_channels(str(p), data, rec.dt_s, names, quantities, units=units,
                             details=details, name=p.stem, **options)


def _kinds(f: _File) -> set[int]:
    return {int(d["func_type"]) for _, d in f.sets58}


def _is_coherence_file(f: _File) -> bool:
    """Coherence sets and neither FRF nor time sets: the coherence an acquisition system
    exported in a file of its own."""
    kinds = _kinds(f)
    return _FUNC_COHERENCE in kinds and not kinds & {_FUNC_FRF, _FUNC_TIME}


def _check_pairs(pool: Mapping[_CohKey, _Coherence], frf_files) -> None:
    """Every coherence set of ``pool`` has the ids of an FRF set in exactly one of
    ``frf_files``."""
    ids = [(f, _frf_ids(f)) for f in frf_files]
    unpaired = []
    for key, c in pool.items():
        hits = [f.path for f, keys in ids if key in keys]
        if len(hits) > 1:
            raise DataFormatError(
                f"{c.where}: this coherence set pairs with FRF sets of both {hits[0]} and "
                f"{hits[1]} (same nodes, directions and load case); expected one: give such "
                f"files separately (read_uff(frf, coherence=coh))")
        if not hits:
            unpaired.append(c)
    if unpaired:
        c = min(unpaired, key=lambda c: (str(c.file.path), c.k))
        more = f" ({len(unpaired) - 1} more such set(s))" if len(unpaired) > 1 else ""
        raise DataFormatError(
            f"{c.where}: this coherence set pairs with no FRF set of "
            f"{', '.join(str(f.path) for f in frf_files) or 'the files given'}{more}; "
            f"expected the response node and direction, reference node and direction and "
            f"load case of an FRF set")


def _read_parsed(f: _File, pool: Mapping[_CohKey, _Coherence], options: Mapping[str, Any]
                 ) -> tuple[FRFData, ...]:
    """The FRFData of a parsed file (module notes), with the coherence sets of
    ``pool``."""
    p = f.path
    frf_groups = _group(f.sets58, _FUNC_FRF)
    if not frf_groups:
        time_sets = [(k, d) for k, d in f.sets58 if int(d["func_type"]) == _FUNC_TIME]
        if not time_sets:
            if _is_coherence_file(f):
                raise DataFormatError(
                    f"{p}: holds only coherence sets (dataset 58, function type 6); give "
                    f"it with the file of its FRF sets (truthbench diagnose frf.uff "
                    f"coh.uff, truthbench.io.load_measurements, or read_uff(frf, "
                    f"coherence=...))")
            raise DataFormatError(
                f"{p}: the dataset-58 sets are of function type(s) {sorted(_kinds(f))}; "
                f"expected FRFs (type 4) or time responses (type 1)")
        return (_time_frf(f, time_sets, options),)
    other = sorted(_kinds(f) - {_FUNC_FRF, _FUNC_COHERENCE})
    if other:
        f = replace(f, notes=(*f.notes, f"dataset-58 sets of function type(s) {other} left "
                                        f"out (FRF sets read)"))
    several = len(frf_groups) > 1
    out = [(lc, _frf_group(f, lc, sel, pool, several)) for lc, sel in frf_groups.items()]
    # load cases whose sets carry one ID line 1: keep their names apart
    count: dict[str, int] = {}
    for _, d in out:
        count[d.name] = count.get(d.name, 0) + 1
    return tuple(d if count[d.name] == 1 else replace(d, name=f"{d.name} load case {lc}")
                 for lc, d in out)


def _time_options(excitation, decay_to, force_width, n_averages, window) -> dict[str, Any]:
    return {"excitation": excitation, "decay_to": decay_to, "force_width": force_width,
            "n_averages": n_averages, "window": window}


def read_uff(
    path: str | PathLike,
    *,
    coherence: str | PathLike | None = None,
    excitation: str = "auto",
    decay_to: float = 0.01,
    force_width: int | None = None,
    n_averages: int = 8,
    window: str = "hann",
) -> tuple[FRFData, ...]:
    """Read a UFF file into FRFData (the ``.uff`` / ``.unv`` reader; module notes).

    Parameters
    ----------
    path : str or os.PathLike
        ASCII or binary UFF with dataset 58 FRF sets (function type 4) or, failing
        those, time sets (type 1); optionally 164 units, 2411/15 points, coherence sets.
    coherence : str or os.PathLike, optional
        A separate UFF file with the coherence sets (function type 6); they replace the
        file's own. :func:`read_uff_files` pairs coherence files with several FRF files.
    excitation, decay_to, force_width, n_averages, window
        Time sets only: see :func:`truthbench.measure.frfs_from_time`.

    Returns
    -------
    tuple of FRFData
        One per load case of FRF sets (in SI units, with coherence and coordinates when
        the file has them), or one from the time sets.

    Raises
    ------
    FileNotFoundError
        If a file does not exist.
    DataFormatError
        Corrupt or truncated file, a grid with missing pairs, no reference (force)
        channel, units that disagree with dataset 164, coherence that does not fit the
        FRFs (other lines, a pair left out, a set of no FRF pair, two sets of one pair,
        values outside [0, 1]), no FRF or time sets; the message names the file and the
        set.
    """
    f = _parse_file(Path(path))
    coh_files = [f] if coherence is None else [_parse_file(Path(coherence))]
    if coherence is not None and _FUNC_COHERENCE not in _kinds(coh_files[0]):
        raise DataFormatError(
            f"{coh_files[0].path}: no coherence sets (dataset 58, function type 6): the "
            f"sets are of function type(s) {sorted(_kinds(coh_files[0]))}; expected the "
            f"coherence of the FRF sets of {f.path}")
    if coherence is not None and _FUNC_FRF not in _kinds(f):
        raise DataFormatError(f"{f.path}: holds no FRF sets (function type 4) to pair the "
                              f"coherence of {coh_files[0].path} with")
    pool = _coherence_sets(coh_files)
    if _FUNC_FRF in _kinds(f):
        _check_pairs(pool, [f])
    return _read_parsed(f, pool, _time_options(excitation, decay_to, force_width, n_averages,
                                               window))


def read_uff_files(
    paths,
    *,
    excitation: str = "auto",
    decay_to: float = 0.01,
    force_width: int | None = None,
    n_averages: int = 8,
    window: str = "hann",
) -> tuple[tuple[FRFData, ...], ...]:
    """Read several UFF files, pairing coherence files with the FRF sets of the others.

    A file whose dataset-58 sets are coherence (function type 6) and neither FRFs (4)
    nor time responses (1) is a *coherence file*, as many acquisition systems export
    it. Each of its sets goes to the FRF set with the same response node and
    direction, reference node and direction (record 6) and load case (record 6, field
    4), in whichever other file that is. A file's own coherence sets pair with its own
    FRF sets. An FRF load case without coherence keeps none.

    Parameters
    ----------
    paths : sequence of str or os.PathLike
        UFF files (``.uff`` / ``.unv``), FRF, time and coherence files in any order.
    excitation, decay_to, force_width, n_averages, window
        Time sets only: see :func:`truthbench.measure.frfs_from_time`.

    Returns
    -------
    tuple of tuple of FRFData
        Per path, what :func:`read_uff` gives for it; ``()`` for a coherence file.

    Raises
    ------
    FileNotFoundError
        If a file does not exist.
    DataFormatError
        What :func:`read_uff` raises, and: a coherence set that pairs with no FRF set or
        with FRF sets of two files, two coherence sets of one FRF pair (both named), a
        coherence set on other lines than its FRF set (both files, the set and both
        grids), values outside [0, 1], an FRF load case whose coherence leaves out
        pairs; only coherence files.
    """
    files = [_parse_file(Path(p)) for p in paths]
    shared = _coherence_sets(f for f in files if _is_coherence_file(f))
    frf_files = [f for f in files if _FUNC_FRF in _kinds(f)]
    if shared and not frf_files:
        first = next(iter(shared.values()))
        raise DataFormatError(
            f"{first.file.path}: holds only coherence sets (dataset 58, function type 6) "
            f"and no other file given holds FRF sets (function type 4) to pair them with")
    _check_pairs(shared, frf_files)
    options = _time_options(excitation, decay_to, force_width, n_averages, window)
    out = []
    for f in files:
        if _is_coherence_file(f):
            out.append(())
            continue
        own = _coherence_sets([f])
        both = sorted(own.keys() & shared.keys(), key=lambda key: own[key].k)
        if both:
            c, other = own[both[0]], shared[both[0]]
            raise DataFormatError(
                f"{c.where}: this FRF pair has a second coherence set in {other.file.path} "
                f"(dataset {other.k}); expected one coherence set per FRF pair")
        if _FUNC_FRF in _kinds(f):
            _check_pairs(own, [f])
        out.append(_read_parsed(f, {**shared, **own}, options))
    return tuple(out)
