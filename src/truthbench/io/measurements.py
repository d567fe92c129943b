"""Measured data as acquisition systems export it: several files -> one tuple of FRFData.

:func:`load_measurements` reads the DATA of ``truthbench diagnose``: every file with the
reader :func:`~truthbench.io.load_frf` would use, with two things a file alone cannot
give.

* **Coherence files.** A UFF file holding only coherence sets (dataset 58, function type
  6) is paired set by set with the FRF sets of the other UFF files by response node and
  direction, reference node and direction and load case
  (:func:`~truthbench.io.read_uff_files`). It gives no data set of its own.
* **Excitation levels** (``input_rms_n``). Amplitude-dependent effects (Coulomb
  friction) are judged by each test's input level, which UFF FRF sets do not carry. The
  mapping gives a data set, by name, the RMS of each input over its record
  (``FRFData.input_rms``, N, or N m for a moment) and, when the file states no
  excitation band, the band of its lines (``FRFData.band_hz``).

**Data-set names** are what the readers give: a UFF load case is named by its sets' ID
line 1 when they all carry the same one (and other load cases of the file do not), else
``"<file stem> load case <n>"`` (n the load case, record 6 field 4) when the file holds
several load cases, else ``"<file stem>"``; an LVM record or a UFF file of time sets by
its file stem; a test of our HDF5 files ``"trial <k> / <test>"``. When two files give
one name, each such data set is renamed ``"<name> (<path as given>)"``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from numbers import Real
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

from truthbench._validation import check_number
from truthbench.errors import DataFormatError
from truthbench.io.registry import _option_names, _reader_for, load_frf
from truthbench.io.uff_frf import read_uff, read_uff_files

if TYPE_CHECKING:
    from truthbench.measure.frfdata import FRFData

__all__ = ["load_measurements"]


def load_measurements(
    paths: str | PathLike | Sequence[str | PathLike],
    *,
    input_rms_n: Mapping[str, float | Sequence[float]] | None = None,
    levels_from: str = "input_rms_n",
    **options: Any,
) -> tuple[FRFData, ...]:
    """Read measured data files, pair coherence files and set excitation levels.

    Parameters
    ----------
    paths : str, os.PathLike or sequence of them
        Data files in any order: UFF (FRF, time or coherence-only files), LVM, our HDF5;
        each at most once.
    input_rms_n : mapping of str -> float or sequence of float, optional
        Data-set name (module notes) -> the RMS of its input(s) over the record, N (N m
        for a moment): one number for every input, or one per input in the data set's
        input order. It replaces what the file states; a data set without a stated
        excitation band gets the band of its lines.
    levels_from : str
        Where ``input_rms_n`` comes from, for messages (the CLI passes the model file
        and key).
    **options
        Given to every reader that takes them (``excitation=``, ``n_averages=``, ...
        for time records; ``trials=``, ``tests=`` for ``.h5``); not ``coherence=``
        (give the coherence file among ``paths``).

    Returns
    -------
    tuple of FRFData
        The data sets of the files in the order of ``paths``, in SI units.

    Raises
    ------
    FileNotFoundError
        A file that does not exist.
    ValueError
        No path, ``coherence=``, an option no reader of the files takes, a level that
        is not a finite number > 0.
    truthbench.errors.DataFormatError
        A file given twice; what the readers raise (the file and set named); a coherence
        set that pairs with no FRF set, with two, or on other lines, two coherence sets
        of one FRF pair, coherence outside [0, 1]; an ``input_rms_n`` name that names
        no data set (the key, the names given and the data sets' names) or whose values
        do not fit its inputs.
    """
    items = [paths] if isinstance(paths, str | PathLike) else list(paths)
    if not items:
        raise ValueError("load_measurements: no data file given; expected at least one path")
    ps = [Path(p) for p in items]
    seen: dict[Path, Path] = {}
    for p in ps:
        first = seen.setdefault(p.resolve(), p)
        if first is not p:
            raise DataFormatError(f"{p}: given twice (also as {first}); expected each data "
                                  f"file once")
    if "coherence" in options:
        raise ValueError("load_measurements: takes no option 'coherence': give the coherence "
                         "file among the paths (its sets are paired with the FRF sets by "
                         "node, direction and load case)")
    readers = [_reader_for(p)[1] for p in ps]
    takes = {id(r): _option_names(r) for r in readers}  # None: takes any
    for name in options:
        if not any(n is None or name in n for n in takes.values()):
            shown = {p.suffix.lower(): takes[id(r)] for p, r in zip(ps, readers, strict=True)}
            raise ValueError(f"load_measurements: no reader of the files given takes option "
                             f"{name!r}; they take {shown}")

    def own(reader):
        names = takes[id(reader)]
        return {k: v for k, v in options.items() if names is None or k in names}

    uff = [k for k, r in enumerate(readers) if r is read_uff]
    read = dict(zip(uff, read_uff_files([ps[k] for k in uff], **own(read_uff)), strict=True)
                ) if uff else {}
    sources: list[tuple[Path, FRFData]] = []
    for k, (p, reader) in enumerate(zip(ps, readers, strict=True)):
        found = read[k] if k in read else load_frf(p, **own(reader))
        sources += [(p, d) for d in found]
    count: dict[str, int] = {}
    for _, d in sources:
        count[d.name] = count.get(d.name, 0) + 1
    data = [d if count[d.name] == 1 else replace(d, name=f"{d.name} ({p})")
            for p, d in sources]
    return tuple(_with_levels(data, input_rms_n or {}, levels_from))


def _with_levels(data: list[FRFData], levels: Mapping, where: str) -> list[FRFData]:
    """``data`` with the input levels of ``levels`` (see :func:`load_measurements`)."""
    names = [d.name for d in data]
    unknown = [key for key in levels if key not in names]
    if unknown:
        raise DataFormatError(
            f"{where}: {unknown[0]!r} names no data set: the names given are "
            f"{list(levels)}, the data sets are {names}; expected data-set names")
    out = list(data)
    for key, value in levels.items():
        k = names.index(key)
        d = out[k]
        what = f"{where} {key!r}"
        values = [value] * len(d.inputs) if isinstance(value, Real) else list(value)
        if len(values) != len(d.inputs):
            raise DataFormatError(
                f"{what}: {len(values)} level(s) {values} for data set {key!r} of "
                f"{len(d.inputs)} input(s) {list(d.input_labels)}; expected one number "
                f"for every input or one per input")
        rms = tuple(check_number("input RMS", v, low=0, low_open=True, where=what)
                    for v in values)
        notes = [f"input RMS {', '.join(f'{v:.6g}' for v in rms)} from {where}"]
        band = d.band_hz
        if band is None and d.freq_hz.size >= 2:
            band = (float(d.freq_hz[0]), float(d.freq_hz[-1]))
            notes.append(f"excitation band: its lines, {band[0]:g}-{band[1]:g} Hz (the "
                         f"source states none)")
        out[k] = replace(d, input_rms=rms, band_hz=band, notes=(*d.notes, *notes))
    return out
