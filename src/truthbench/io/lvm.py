"""Reader for LabVIEW Measurement (``.lvm``) text files, Writer_Version 2.

This module owns the hand-written LVM parser of truthbench (it does not use the
``lvm_read`` package), the :class:`TimeRecord` result, unit conversion to SI
(:func:`to_si`) and the loader of the measured beam impact test that ships with the
package (:func:`ladisk_beam_impact`).

What is read
------------
An LVM file (Writer_Version 2) is

1. the line ``LabVIEW Measurement``;
2. the *file header*: ``key<sep>value`` lines (``Writer_Version``, ``Separator``
   (``Tab`` or ``Comma``), ``Decimal_Separator`` (``.`` or ``,``), ``X_Columns``
   (``No``, ``One`` or ``Multi``), ``Date``, ``Time``, ...), ended by
   ``***End_of_Header***``;
3. the *channel header* of the data segment: one value per channel for ``Samples``,
   ``Date``, ``Time``, ``Y_Unit_Label``, ``X_Dimension``, ``X0``, ``Delta_X``, after a
   ``Channels`` line, ended by a second ``***End_of_Header***``;
4. an optional column-title line starting with ``X_Value`` (the channel names);
5. the data block: one line per sample. With ``X_Columns`` ``No`` or ``One`` a line is
   ``x<sep>y_1<sep>...<sep>y_n`` (the x field is empty for ``No``); with ``Multi`` it is
   ``x_1<sep>y_1<sep>...<sep>x_n<sep>y_n``. One extra trailing comment field is allowed.

The x fields are ignored: the time axis is ``X0 + k * Delta_X``. Only one data segment
is supported (all channels sharing ``Samples``, ``Delta_X`` and ``X0``); a file with a
second segment raises :class:`~truthbench.errors.DataFormatError`.

Units
-----
:func:`read_lvm` returns the values exactly as written in the file, in the units of
``Y_Unit_Label`` (the record says which). :func:`to_si` converts to SI; acceleration in
``g`` is multiplied by the standard gravity ``G_STANDARD_M_S2 = 9.80665`` m/s^2 (ISO
80000-3, CGPM 1901). Note that the notes of the LADISK data set say 9.81; the two differ
by 0.034 %.
"""

from __future__ import annotations

import hashlib
import importlib.resources
import math
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime
from os import PathLike
from pathlib import Path
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from truthbench.errors import DataFormatError
from truthbench.presentation import Presentable, figure_axes

__all__ = [
    "G_STANDARD_M_S2",
    "LADISK_BEAM_IMPACT_SHA256",
    "ImpactRecord",
    "TimeRecord",
    "ladisk_beam_impact",
    "read_lvm",
    "to_si",
]

G_STANDARD_M_S2 = 9.80665
"""Standard acceleration of gravity in m/s^2, used to convert ``g`` to SI."""

LADISK_BEAM_IMPACT_SHA256 = "9f4d997c5aadd2835f62aeb8b3b06d8f67352ea525ba02d50f50be915585d167"
"""sha256 of the shipped ``data/ladisk_beam_impact/acceleration.lvm``."""

_END_OF_HEADER = "***End_of_Header***"
_SEPARATORS = MappingProxyType({"tab": "\t", "comma": ","})

# Known unit labels (matched exactly, after stripping) -> (SI unit label, factor to SI).
_SI_UNITS = MappingProxyType(
    {
        "g": ("m/s^2", G_STANDARD_M_S2),
        "m/s^2": ("m/s^2", 1.0),
        "m/s2": ("m/s^2", 1.0),
        "m/s²": ("m/s^2", 1.0),
        "mm/s^2": ("m/s^2", 1e-3),
        "m/s": ("m/s", 1.0),
        "mm/s": ("m/s", 1e-3),
        "m": ("m", 1.0),
        "mm": ("m", 1e-3),
        "um": ("m", 1e-6),
        "µm": ("m", 1e-6),
        "N": ("N", 1.0),
        "Newton": ("N", 1.0),
        "Newtons": ("N", 1.0),
        "newtons": ("N", 1.0),
        "kN": ("N", 1e3),
        "V": ("V", 1.0),
        "Volt": ("V", 1.0),
        "Volts": ("V", 1.0),
        "volts": ("V", 1.0),
        "mV": ("V", 1e-3),
        "Pa": ("Pa", 1.0),
        "s": ("s", 1.0),
    }
)


def _frozen_array(values: np.ndarray, dtype: type = np.float64) -> np.ndarray:
    """Return a read-only copy of ``values``."""
    out = np.array(values, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class TimeRecord(Presentable):
    """Sampled time histories read from a measurement file.

    Table ``"samples"`` (:meth:`to_pandas`): one row per sample, ``time_s`` and one
    column per channel (units in ``DataFrame.attrs["units"]``). Figure ``"channels"``
    (:meth:`plot`): one panel per channel against time.

    Parameters
    ----------
    data : numpy.ndarray, shape (n_channels, n_samples)
        Sample values, one row per channel, in the units of ``units``. Stored as a
        read-only float64 copy.
    dt_s : float
        Sampling interval in s (> 0).
    channel_names : tuple of str, length n_channels
        Channel names (the column titles of the file).
    units : tuple of str, length n_channels
        Unit label of each channel, as written in the file or after :func:`to_si`.
    start_time : datetime.datetime or None
        Wall-clock time of the segment start as written in the file (naive: the file
        does not give a time zone), or None if the file gives no date and time.
    x0_s : float
        Time of the first sample relative to ``start_time`` in s (``X0``).
    source_path : pathlib.Path or None
        The file that was read.
    header : Mapping
        Raw header: ``{"file": {key: value}, "channel": {key: (value per channel)}}``
        with the strings as written (read-only mappings).
    """

    TABLES = ("samples",)
    PLOTS = ("channels",)

    data: np.ndarray
    dt_s: float
    channel_names: tuple[str, ...]
    units: tuple[str, ...]
    start_time: datetime | None = None
    x0_s: float = 0.0
    source_path: Path | None = None
    header: Mapping = field(default_factory=lambda: MappingProxyType({}))

    def __post_init__(self) -> None:
        data = _frozen_array(self.data)
        if data.ndim != 2:
            raise ValueError(
                f"TimeRecord.data must have shape (n_channels, n_samples); got {data.ndim} "
                f"dimension(s), shape {data.shape}"
            )
        n_ch = data.shape[0]
        for name in ("channel_names", "units"):
            value = tuple(getattr(self, name))
            if len(value) != n_ch:
                raise ValueError(
                    f"TimeRecord.{name} must have one entry per channel; expected {n_ch} "
                    f"instead of {len(value)}"
                )
            object.__setattr__(self, name, value)
        if not (math.isfinite(self.dt_s) and self.dt_s > 0):
            raise ValueError(f"TimeRecord.dt_s must be finite and > 0; got {self.dt_s!r}")
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "dt_s", float(self.dt_s))
        object.__setattr__(self, "x0_s", float(self.x0_s))
        if self.source_path is not None:
            object.__setattr__(self, "source_path", Path(self.source_path))
        object.__setattr__(self, "header", _freeze_mapping(self.header))

    @property
    def fs_hz(self) -> float:
        """Sampling frequency in Hz (``1 / dt_s``)."""
        return 1.0 / self.dt_s

    @property
    def n_channels(self) -> int:
        """Number of channels."""
        return int(self.data.shape[0])

    @property
    def n_samples(self) -> int:
        """Number of samples per channel."""
        return int(self.data.shape[1])

    @property
    def time_s(self) -> np.ndarray:
        """Sample times in s, shape (n_samples,): ``x0_s + k * dt_s``."""
        return self.x0_s + np.arange(self.n_samples) * self.dt_s

    def _table_samples(self):
        """One row per sample: ``time_s`` and one column per channel (by name); the
        channels' units in ``attrs["units"]``."""
        import pandas as pd

        df = pd.DataFrame({"time_s": self.time_s,
                           **dict(zip(self.channel_names, self.data, strict=True))})
        df.attrs["units"] = dict(zip(self.channel_names, self.units, strict=True))
        return df

    def _plot_channels(self, ax):
        """One panel per channel against time."""
        n = self.n_channels
        fig, axes = figure_axes(ax, n, sharex=True, figsize=(7, 1.8 * n + 0.8))
        for a, row, name, unit in zip(axes, self.data, self.channel_names, self.units,
                                      strict=False):
            a.plot(self.time_s, row, lw=0.7)
            a.set_ylabel(f"{name} [{unit}]", fontsize="small")
        axes[n - 1].set_xlabel("time [s]")
        fig.tight_layout()
        return fig


@dataclass(frozen=True, eq=False)
class ImpactRecord(Presentable):
    """One impact-hammer test: force input and acceleration output, in SI units.

    Table ``"samples"`` and figure ``"channels"``: those of its :class:`TimeRecord`
    (every channel of the file, in SI).

    Parameters
    ----------
    inputs : numpy.ndarray, shape (n_inputs, n_samples)
        Excitation force in N (read-only).
    outputs : numpy.ndarray, shape (n_outputs, n_samples)
        Response acceleration in m/s^2 (read-only).
    dt_s : float
        Sampling interval in s.
    input_names, output_names : tuple of str
        Channel names as written in the source file.
    start_time : datetime.datetime or None
        Start of the recording (naive local time, as written in the file).
    record : TimeRecord
        All channels of the file, converted to SI by :func:`to_si`.
    source : str
        Where the data comes from.
    license : str
        Licence of the data.
    sha256 : str
        sha256 of the file that was read.
    g_m_s2 : float
        The value of g used to convert acceleration from g to m/s^2.
    """

    TABLES = ("samples",)
    PLOTS = ("channels",)

    inputs: np.ndarray
    outputs: np.ndarray
    dt_s: float
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]
    start_time: datetime | None
    record: TimeRecord
    source: str
    license: str
    sha256: str
    g_m_s2: float = G_STANDARD_M_S2
    input_units: tuple[str, ...] = ("N",)
    output_units: tuple[str, ...] = ("m/s^2",)

    def __post_init__(self) -> None:
        object.__setattr__(self, "inputs", _frozen_array(self.inputs))
        object.__setattr__(self, "outputs", _frozen_array(self.outputs))

    @property
    def fs_hz(self) -> float:
        """Sampling frequency in Hz."""
        return 1.0 / self.dt_s

    @property
    def n_samples(self) -> int:
        """Number of samples per channel."""
        return int(self.inputs.shape[1])

    @property
    def time_s(self) -> np.ndarray:
        """Sample times in s, shape (n_samples,)."""
        return self.record.time_s

    @property
    def force_n(self) -> np.ndarray:
        """The (single) hammer force in N, shape (n_samples,)."""
        return self.inputs[0]

    @property
    def acceleration_m_s2(self) -> np.ndarray:
        """The (single) acceleration in m/s^2, shape (n_samples,)."""
        return self.outputs[0]

    def _table_samples(self):
        """The record's samples (:class:`TimeRecord`)."""
        return self.record.to_pandas("samples")

    def _plot_channels(self, ax):
        """The record's channels against time."""
        return self.record.plot("channels", ax)


def _freeze_mapping(mapping: Mapping) -> Mapping:
    """Return a read-only (nested) copy of ``mapping``."""
    return MappingProxyType(
        {k: _freeze_mapping(v) if isinstance(v, Mapping) else v for k, v in mapping.items()}
    )


# --------------------------------------------------------------------------------------
# Parsing
# --------------------------------------------------------------------------------------


def _decode(raw: bytes) -> str:
    """Decode file bytes: UTF-8 if valid, else Windows-1252 (LabVIEW's usual code page)."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("cp1252", errors="replace")


def _show(text: str, limit: int = 60) -> str:
    """Short printable representation of a field or line for error messages."""
    return repr(text if len(text) <= limit else text[:limit] + "...")


class _Lines:
    """The lines of the file with 1-based line numbers, for error messages."""

    def __init__(self, path: str, text: str) -> None:
        self.path = path
        self.lines = [line.removesuffix("\r") for line in text.split("\n")]
        self.ends_with_newline = text.endswith("\n")

    def error(self, lineno: int | None, what: str) -> DataFormatError:
        where = f"{self.path}" if lineno is None else f"{self.path}, line {lineno}"
        return DataFormatError(f"{where}: {what}")


_BINARY = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f\ufffd]")


def _check_text(src: _Lines) -> None:
    """An LVM file is text: a control character (other than tab and line ends) or a
    byte that is not text in UTF-8 or Windows-1252 means the file is corrupt (binary
    data written into it, a disk or transfer error); say where, before any row count
    could call it truncated."""
    for lineno, line in enumerate(src.lines, start=1):
        m = _BINARY.search(line)
        if m:
            raise src.error(
                lineno,
                f"binary data in a text file: character {m.group()!r} at column "
                f"{m.start() + 1}; expected LabVIEW Measurement text (the file is "
                f"corrupt: written over or damaged in transfer)",
            )


def _split(line: str, sep: str) -> list[str]:
    """Split a header line into fields and drop empty trailing fields."""
    fields = line.split(sep)
    while fields and not fields[-1].strip():
        fields.pop()
    return [f.strip() for f in fields]


def _find_separator(src: _Lines) -> str:
    """Find the field separator from the ``Separator`` line of the file header."""
    for lineno, line in enumerate(src.lines, start=1):
        if line.startswith(_END_OF_HEADER):
            break
        if line.startswith("Separator") and len(line) > len("Separator"):
            sep = line[len("Separator")]
            value = line[len("Separator") + 1 :].split(sep)[0].strip()
            expected = _SEPARATORS.get(value.lower())
            if expected is None or expected != sep:
                raise src.error(
                    lineno,
                    f"field 'Separator': expected 'Tab' or 'Comma' (written after that "
                    f"separator), got {_show(line)}",
                )
            return sep
    return "\t"  # Writer_Version 2 default when the key is absent


def _read_block(src: _Lines, start: int, sep: str, which: str) -> tuple[dict, dict, int]:
    """Read ``key<sep>values`` lines from 0-based index ``start`` up to End_of_Header.

    Returns the values per key, the 1-based line number per key and the index of the
    line after ``***End_of_Header***``.
    """
    values: dict[str, list[str]] = {}
    where: dict[str, int] = {}
    i = start
    while i < len(src.lines):
        fields = _split(src.lines[i], sep)
        if fields and fields[0] == _END_OF_HEADER:
            return values, where, i + 1
        if fields and fields[0]:
            values[fields[0]] = fields[1:]
            where[fields[0]] = i + 1
        i += 1
    raise src.error(
        None,
        f"missing '{_END_OF_HEADER}' that ends the {which}: expected it after line "
        f"{start + 1}, read to the end of the file (line {len(src.lines)}); is this a "
        f"complete LabVIEW Measurement file?",
    )


def _number(src: _Lines, text: str, decimal: str, lineno: int | None, what: str) -> float:
    """Parse a header number written with the file's decimal separator."""
    try:
        return float(text.replace(",", ".") if decimal == "," else text)
    except ValueError:
        raise src.error(
            lineno, f"field {what}: expected a number (decimal {decimal!r}), got {_show(text)}"
        ) from None


def _per_channel(
    src: _Lines, values: dict, where: dict, key: str, n_channels: int, required: bool
) -> tuple[str, ...] | None:
    """The ``n_channels`` values of a channel-header key, or None if absent and optional."""
    if key not in values:
        if required:
            raise src.error(
                None,
                f"channel header has no '{key}' line: expected '{key}' with one value per "
                f"channel ({n_channels})",
            )
        return None
    vals = values[key]
    if len(vals) < n_channels or any(not v for v in vals[:n_channels]):
        raise src.error(
            where[key],
            f"field '{key}': expected {n_channels} value(s) (Channels = {n_channels}), "
            f"got {len(vals)}: {vals!r}",
        )
    return tuple(vals[:n_channels])


def _parse_time(
    src: _Lines, date: str | None, time: str | None, lineno: int | None
) -> datetime | None:
    """Combine LVM ``Date`` (YYYY/MM/DD) and ``Time`` (HH:MM:SS.fraction) fields."""
    if not date or not time:
        return None
    m_date = re.fullmatch(r"(\d{4})/(\d{1,2})/(\d{1,2})", date)
    m_time = re.fullmatch(r"(\d{1,2}):(\d{1,2}):(\d{1,2})(?:[.,](\d*))?", time)
    if m_date is None or m_time is None:
        raise src.error(
            lineno,
            f"fields 'Date'/'Time': expected 'YYYY/MM/DD' and 'HH:MM:SS.ffff', got "
            f"{date!r} and {time!r}",
        )
    frac = (m_time.group(4) or "0")[:6].ljust(6, "0")
    try:
        return datetime(
            int(m_date.group(1)), int(m_date.group(2)), int(m_date.group(3)),
            int(m_time.group(1)), int(m_time.group(2)), int(m_time.group(3)), int(frac),
        )  # fmt: skip
    except ValueError as exc:
        raise src.error(
            lineno, f"fields 'Date'/'Time': not a valid date and time ({date!r} {time!r}): {exc}"
        ) from None


class _FileHeader(NamedTuple):
    values: dict[str, str]  # key -> first value
    where: dict[str, int]  # key -> 1-based line number
    sep: str
    decimal: str
    x_columns: str  # "No", "One" or "Multi"
    next_index: int  # 0-based index of the line after ***End_of_Header***


class _ChannelHeader(NamedTuple):
    raw: dict[str, list[str]]
    where: dict[str, int]
    n_channels: int
    n_samples: int
    dt_s: float
    x0_s: float
    units: tuple[str, ...]
    start_time: datetime | None
    next_index: int


def _file_header(src: _Lines) -> _FileHeader:
    """Check the first line and read the file header (first header block)."""
    first = src.lines[0].strip().split("\t")[0].split(",")[0].strip()
    if first != "LabVIEW Measurement":
        raise src.error(
            1, f"expected 'LabVIEW Measurement' (an LVM file), got {_show(src.lines[0])}"
        )
    sep = _find_separator(src)
    raw, where, i = _read_block(src, 1, sep, "file header (first header block)")
    values = {k: (v[0] if v else "") for k, v in raw.items()}
    version = values.get("Writer_Version")
    if version is None:
        raise src.error(None, "file header has no 'Writer_Version' line: expected version 2")
    if _number(src, version, ".", where["Writer_Version"], "'Writer_Version'") != 2.0:
        raise src.error(
            where["Writer_Version"],
            f"field 'Writer_Version': expected 2 (only LVM Writer_Version 2 is supported), "
            f"got {version!r}",
        )
    decimal = values.get("Decimal_Separator", ".")
    if "Decimal_Separator" in values and not decimal:
        # An empty value: with Comma separators, "Decimal_Separator,," means ','.
        line = src.lines[where["Decimal_Separator"] - 1].strip()
        decimal = "," if sep == "," and line.startswith("Decimal_Separator,,") else decimal
    if decimal not in (".", ","):
        raise src.error(
            where.get("Decimal_Separator"),
            f"field 'Decimal_Separator': expected '.' or ',', got {decimal!r}",
        )
    if decimal == "," and sep == ",":
        raise src.error(
            where.get("Decimal_Separator"),
            "field 'Decimal_Separator': ',' cannot be used with 'Separator Comma' (the "
            "numbers could not be split); expected '.' with Comma separators",
        )
    x_columns = (values.get("X_Columns", "One") or "One").capitalize()
    if x_columns not in ("No", "One", "Multi"):
        raise src.error(
            where.get("X_Columns"),
            f"field 'X_Columns': expected 'No', 'One' or 'Multi', got {x_columns!r}",
        )
    return _FileHeader(values, where, sep, decimal, x_columns, i)


def _channel_header(src: _Lines, fh: _FileHeader) -> _ChannelHeader:
    """Read the channel header (second header block) of the data segment."""
    sep, decimal, i = fh.sep, fh.decimal, fh.next_index
    while i < len(src.lines) and not "".join(_split(src.lines[i], sep)):
        i += 1  # blank separator lines between the header blocks
    if i >= len(src.lines):
        raise src.error(
            None,
            "no channel header after the file header: expected a second header block "
            f"(Channels, Samples, Delta_X, ...) ending with '{_END_OF_HEADER}'",
        )
    raw, where, i = _read_block(src, i, sep, "channel header (second header block)")
    if not raw.get("Channels"):
        raise src.error(None, "channel header has no 'Channels' line: expected the channel count")
    n_text = raw["Channels"][0]
    if not n_text.isdigit() or int(n_text) < 1:
        raise src.error(
            where["Channels"], f"field 'Channels': expected a positive integer, got {n_text!r}"
        )
    n_ch = int(n_text)

    samples_txt = _per_channel(src, raw, where, "Samples", n_ch, True)
    if not all(t.isdigit() for t in samples_txt):
        raise src.error(
            where["Samples"], f"field 'Samples': expected integers, got {samples_txt!r}"
        )
    if len(set(samples_txt)) != 1:
        raise src.error(
            where["Samples"],
            f"field 'Samples': expected the same count for every channel (channels of "
            f"different length are not supported), got {samples_txt!r}",
        )
    dx_txt = _per_channel(src, raw, where, "Delta_X", n_ch, True)
    dx = [_number(src, t, decimal, where["Delta_X"], "'Delta_X'") for t in dx_txt]
    if not all(math.isfinite(v) and v > 0 for v in dx) or len(set(dx)) != 1:
        raise src.error(
            where["Delta_X"],
            f"field 'Delta_X': expected one positive sampling interval shared by all "
            f"channels, got {dx_txt!r}",
        )
    x0_txt = _per_channel(src, raw, where, "X0", n_ch, False) or ("0",) * n_ch
    x0 = [_number(src, t, decimal, where.get("X0"), "'X0'") for t in x0_txt]
    if len(set(x0)) != 1 or not math.isfinite(x0[0]):
        raise src.error(
            where.get("X0"),
            f"field 'X0': expected the same finite start for every channel, got {x0_txt!r}",
        )
    units = _per_channel(src, raw, where, "Y_Unit_Label", n_ch, False) or ("",) * n_ch
    dates = _per_channel(src, raw, where, "Date", n_ch, False)
    times = _per_channel(src, raw, where, "Time", n_ch, False)
    if dates and times:
        start_time = _parse_time(src, dates[0], times[0], where.get("Time"))
    else:
        start_time = _parse_time(
            src, fh.values.get("Date"), fh.values.get("Time"), fh.where.get("Time")
        )
    return _ChannelHeader(raw, where, n_ch, int(samples_txt[0]), dx[0], x0[0], units, start_time, i)


def _titles(src: _Lines, i: int, fh: _FileHeader, n_ch: int) -> tuple[tuple[str, ...], int]:
    """Channel names from the ``X_Value ...`` title line at index ``i`` (if present)."""
    n_fields = 2 * n_ch if fh.x_columns == "Multi" else n_ch + 1
    if i >= len(src.lines) or src.lines[i].split(fh.sep)[0].strip() != "X_Value":
        return tuple(f"channel {k}" for k in range(n_ch)), i
    titles = [t.strip() for t in src.lines[i].split(fh.sep)]
    if titles and titles[-1] == "Comment":
        titles = titles[:-1]
    while titles and not titles[-1]:
        titles.pop()
    if len(titles) != n_fields:
        raise src.error(
            i + 1,
            f"column titles: expected {n_fields} columns before 'Comment' (X_Columns "
            f"{fh.x_columns!r}, Channels = {n_ch}), got {len(titles)}: {titles!r}",
        )
    return tuple(titles[c] for c in _y_columns(fh.x_columns, n_ch)), i + 1


def _y_columns(x_columns: str, n_ch: int) -> list[int]:
    """0-based field index of each channel's values in a data line."""
    return list(range(1, 2 * n_ch, 2)) if x_columns == "Multi" else list(range(1, n_ch + 1))


def _data_rows(
    src: _Lines, first: int, ch: _ChannelHeader, allow_truncated: bool
) -> tuple[int, int]:
    """Delimit the data block: (first, end) 0-based line indices; check the row count."""
    end = len(src.lines)
    while end > first and not src.lines[end - 1].strip():
        end -= 1
    for k in range(first, end):
        line = src.lines[k]
        head = line.split("\t")[0].split(",")[0].strip()
        if head in ("Channels", _END_OF_HEADER, "LabVIEW Measurement"):
            raise src.error(
                k + 1,
                f"a second data segment starts here ({head!r}); expected {ch.n_samples} "
                f"data rows of one segment: multi-segment LVM files are not supported",
            )
        if not line.strip():
            raise src.error(
                k + 1, f"empty line inside the data block (rows start at line {first + 1})"
            )
    n_rows = end - first
    samples_line = ch.where["Samples"]
    if n_rows > ch.n_samples:
        raise src.error(
            first + ch.n_samples + 1,
            f"too many data rows: 'Samples' (line {samples_line}) says {ch.n_samples}, the "
            f"data block (from line {first + 1}) has {n_rows}",
        )
    if n_rows < ch.n_samples:
        if not allow_truncated:
            raise src.error(
                None,
                f"truncated data: 'Samples' (line {samples_line}) says {ch.n_samples} rows, "
                f"read {n_rows} (lines {first + 1}-{end}): the file ends early (a "
                f"recording that stopped, or a copy that was cut); expected "
                f"{ch.n_samples} rows. In Python, "
                f"truthbench.io.read_lvm(path, allow_truncated=True) keeps the complete rows",
            )
        if not src.ends_with_newline and n_rows > 0:
            end -= 1  # the last line was cut while being written: drop it
            n_rows -= 1
        warnings.warn(
            f"{src.path}: truncated data: 'Samples' (line {samples_line}) says "
            f"{ch.n_samples} rows, kept {n_rows} complete rows",
            stacklevel=4,
        )
    return first, end


def _data_values(
    src: _Lines, first: int, end: int, fh: _FileHeader, names: tuple[str, ...]
) -> np.ndarray:
    """Parse data lines ``first:end`` into an array of shape (n_rows, n_channels)."""
    n_ch = len(names)
    y_cols = _y_columns(fh.x_columns, n_ch)
    n_fields = 2 * n_ch if fh.x_columns == "Multi" else n_ch + 1
    rows = src.lines[first:end]
    if fh.decimal == ",":
        rows = [r.replace(",", ".") for r in rows]
    split_rows = [r.split(fh.sep) for r in rows]
    for k, fields in enumerate(split_rows):
        if len(fields) not in (n_fields, n_fields + 1):
            raise src.error(
                first + k + 1,
                f"column count: expected {n_fields} fields (X_Columns {fh.x_columns!r}, "
                f"Channels = {n_ch}; one more for a comment), got {len(fields)}: "
                f"{_show(src.lines[first + k])}",
            )
    table = [[fields[c] for c in y_cols] for fields in split_rows]
    try:
        values = np.array(table, dtype=np.str_).astype(np.float64).reshape(len(rows), n_ch)
    except ValueError:
        pass
    else:
        bad = np.argwhere(~np.isfinite(values))
        if bad.size:  # NaN or Inf: a dropped or overranged sample, no FRF can use it
            k, c = (int(v) for v in bad[0])
            raise src.error(
                first + k + 1,
                f"non-finite value in column {y_cols[c] + 1} (channel {names[c]!r}): "
                f"expected a finite number, got "
                f"{_show(src.lines[first + k].split(fh.sep)[y_cols[c]])} "
                f"({int(np.count_nonzero(~np.isfinite(values[:, c])))} such value(s) in "
                f"that channel)",
            )
        return values
    for k, row in enumerate(table):  # slow path: find the first bad field
        for c, text in enumerate(row):
            try:
                float(text)
            except ValueError:
                raise src.error(
                    first + k + 1,
                    f"non-numeric value in column {y_cols[c] + 1} (channel {names[c]!r}): "
                    f"expected a number with decimal separator {fh.decimal!r}, got "
                    f"{_show(src.lines[first + k].split(fh.sep)[y_cols[c]])}",
                ) from None
    raise src.error(None, "data block could not be converted to numbers")  # pragma: no cover


def _parse_lvm(raw: bytes, path: str, allow_truncated: bool) -> TimeRecord:
    """Parse the bytes of an LVM file (the engine behind :func:`read_lvm`)."""
    if not raw.strip():
        raise DataFormatError(
            f"{path}: the file is empty ({len(raw)} bytes): expected a LabVIEW Measurement "
            f"file starting with 'LabVIEW Measurement'"
        )
    src = _Lines(path, _decode(raw))
    _check_text(src)
    fh = _file_header(src)
    ch = _channel_header(src, fh)
    names, first = _titles(src, ch.next_index, fh, ch.n_channels)
    first, end = _data_rows(src, first, ch, allow_truncated)
    values = _data_values(src, first, end, fh, names)
    return TimeRecord(
        data=values.T,
        dt_s=ch.dt_s,
        channel_names=names,
        units=ch.units,
        start_time=ch.start_time,
        x0_s=ch.x0_s,
        source_path=Path(path),
        header={
            "file": dict(fh.values),
            "channel": {k: tuple(v) for k, v in ch.raw.items()},
        },
    )


def read_lvm(path: str | PathLike, *, allow_truncated: bool = False) -> TimeRecord:
    """Read a LabVIEW Measurement (``.lvm``) file, Writer_Version 2.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.lvm`` file.
    allow_truncated : bool, default False
        If False, a data block with fewer rows than ``Samples`` raises. If True, the
        complete rows are kept (a last line without a line end is taken to be cut and
        is dropped) and a ``UserWarning`` says how many rows were kept.

    Returns
    -------
    TimeRecord
        ``data`` of shape (n_channels, n_samples) in the file's units (``units`` holds
        the ``Y_Unit_Label`` of each channel; use :func:`to_si` for SI), ``dt_s`` from
        ``Delta_X``, channel names from the column titles, ``start_time`` from the
        channel header's ``Date``/``Time`` and the raw header strings.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    truthbench.errors.DataFormatError
        If the file is empty, is not an LVM file, lacks a ``***End_of_Header***``, has a
        malformed header field, a row with the wrong number of columns, a non-numeric
        value, more rows than ``Samples`` or (unless ``allow_truncated``) fewer. The
        message names the file and, where there is one, the line.
    """
    p = Path(path)
    raw = p.read_bytes()
    return _parse_lvm(raw, str(p), allow_truncated)


def to_si(record: TimeRecord) -> TimeRecord:
    """Convert every channel of a record to SI units.

    Parameters
    ----------
    record : TimeRecord
        Record whose ``units`` are known labels (matched exactly): ``g`` (-> m/s^2,
        times 9.80665), ``m/s^2``, ``mm/s^2``, ``m/s``, ``mm/s``, ``m``, ``mm``, ``um``,
        ``N`` / ``Newton(s)``, ``kN``, ``V`` / ``Volt(s)``, ``mV``, ``Pa``, ``s``.

    Returns
    -------
    TimeRecord
        A new record with data scaled to SI and ``units`` set to the SI labels
        (``m/s^2``, ``m/s``, ``m``, ``N``, ``V``, ``Pa``, ``s``). The input is unchanged.

    Raises
    ------
    ValueError
        If a channel's unit label is not known; the message names the channel.
    """
    factors = []
    si_units = []
    for name, unit in zip(record.channel_names, record.units, strict=True):
        entry = _SI_UNITS.get(unit.strip())
        if entry is None:
            raise ValueError(
                f"to_si: channel {name!r} has unit {unit!r}; expected one of {sorted(_SI_UNITS)}"
            )
        si_units.append(entry[0])
        factors.append(entry[1])
    data = record.data * np.asarray(factors)[:, None]
    return TimeRecord(
        data=data,
        dt_s=record.dt_s,
        channel_names=record.channel_names,
        units=tuple(si_units),
        start_time=record.start_time,
        x0_s=record.x0_s,
        source_path=record.source_path,
        header=record.header,
    )


def ladisk_beam_impact() -> ImpactRecord:
    """Load the measured impact-hammer test on a free-free steel beam shipped with truthbench.

    The file is ``truthbench/data/ladisk_beam_impact/acceleration.lvm``, copied byte for
    byte from github.com/ladisk/ImageBasedModalAnalysisTutorial (LADISK, University of
    Ljubljana; MIT licence, "Copyright (c) 2018 - 2019 Ladisk"; see the README.md and
    LICENSE.ladisk-MIT.txt next to it). Its sha256 is checked on every load.

    Returns
    -------
    ImpactRecord
        ``inputs``: hammer force in N, shape (1, 50030); ``outputs``: acceleration in
        m/s^2 (file values in g times 9.80665), shape (1, 50030); ``dt_s = 2e-5``
        (fs = 50 kHz); ``record``: both channels in SI, in file order
        (acceleration, force).

    Raises
    ------
    truthbench.errors.DataFormatError
        If the shipped file does not have the expected sha256 (it was changed), or
        does not hold the channels 'Force (Trigger)' and 'Acceleration (Trigger)'.
    """
    ref = importlib.resources.files("truthbench").joinpath(
        "data/ladisk_beam_impact/acceleration.lvm"
    )
    with importlib.resources.as_file(ref) as path:
        raw = Path(path).read_bytes()
        digest = hashlib.sha256(raw).hexdigest()
        if digest != LADISK_BEAM_IMPACT_SHA256:
            raise DataFormatError(
                f"{path}: sha256 mismatch: expected {LADISK_BEAM_IMPACT_SHA256} (the file "
                f"as published by LADISK), got {digest}; the shipped data file was changed"
            )
        raw_record = _parse_lvm(raw, str(path), allow_truncated=False)
    record = to_si(raw_record)
    try:
        i_force = record.channel_names.index("Force (Trigger)")
        i_acc = record.channel_names.index("Acceleration (Trigger)")
    except ValueError:
        raise DataFormatError(
            f"{record.source_path}: column titles: expected 'Acceleration (Trigger)' and "
            f"'Force (Trigger)', got {record.channel_names!r}"
        ) from None
    return ImpactRecord(
        inputs=record.data[[i_force]],
        outputs=record.data[[i_acc]],
        dt_s=record.dt_s,
        input_names=(record.channel_names[i_force],),
        output_names=(record.channel_names[i_acc],),
        start_time=record.start_time,
        record=record,
        source=(
            "LADISK (University of Ljubljana), github.com/ladisk/ImageBasedModalAnalysisTutorial"
            ", data/acceleration.lvm, commit 79bdda521d30f219305720827de0dc8ce15de8b7"
        ),
        license="MIT, Copyright (c) 2018 - 2019 Ladisk",
        sha256=digest,
    )
