"""Time records from files -> FRFData: which channel is the input, what each measures.

The io room decides what the channels of a time record are; the H1 estimate itself is
:func:`truthbench.measure.frfs_from_time` (impact and random rules, default bands).

* The inputs are the channels that measure a force (unit N after :func:`to_si`, or UFF
  ordinate data type 13) or, failing that, the channels named like an input
  (``force``, ``hammer``, ``input``, ``excitation``, ``shaker``); every other channel
  is an output.
* An output's quantity is the one whose SI unit its unit is, in the one table
  :mod:`truthbench.quantities` (``m/s^2`` acceleration, ``m/s`` velocity, ``m``
  displacement, ``m/m`` strain); outputs of several quantities give an FRFData of
  mixed type.

:func:`read_lvm_frf` is the ``.lvm`` reader of :func:`truthbench.io.load_frf`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from truthbench.errors import DataFormatError
from truthbench.io.lvm import TimeRecord, read_lvm, to_si
from truthbench.quantities import QUANTITIES

if TYPE_CHECKING:
    from truthbench.measure.frfdata import FRFData

__all__ = ["frf_from_channels", "frf_from_record", "quantity_of_si_unit", "read_lvm_frf"]

INPUT_NAME = re.compile(r"force|hammer|input|excitation|shaker", re.IGNORECASE)
"""Channel names taken for inputs when no channel says it measures a force."""


def quantity_of_si_unit(unit: str) -> str | None:
    """The quantity whose SI translation unit is ``unit`` (``"m/s^2"`` ->
    ``"acceleration"``), from :data:`truthbench.quantities.QUANTITIES`; None if none."""
    for q in QUANTITIES.values():
        if q.unit == unit.strip():
            return q.name
    return None


def frf_from_channels(
    source: str,
    data,
    dt_s: float,
    names: Sequence[str],
    quantities: Sequence[str | None],
    *,
    units: Sequence[str] | None = None,
    details: Sequence[dict[str, Any]] | None = None,
    name: str | None = None,
    excitation: str = "auto",
    decay_to: float = 0.01,
    force_width: int | None = None,
    n_averages: int = 8,
    window: str = "hann",
) -> FRFData:
    """H1 FRFs of a time record whose channels are described one by one.

    Parameters
    ----------
    source : str
        The file, for error messages.
    data : array_like, shape (n_channels, n_samples)
        Samples in SI units.
    dt_s : float
        Sampling interval, s.
    names : sequence of str, length n_channels
        Channel names (unique); they become the channel labels.
    quantities : sequence of (str or None), length n_channels
        What each channel measures (a key of :data:`truthbench.quantities.QUANTITIES`),
        None when the source does not say.
    units : sequence of str, optional
        The channels' units as written, for error messages.
    details : sequence of dict, optional
        Further :class:`~truthbench.measure.Channel` fields per channel (``direction``,
        ``sign``, ``point``, ``coordinates_m``).
    name : str, optional
        Name of the FRFData (default: the file stem of ``source``).
    excitation, decay_to, force_width, n_averages, window
        See :func:`truthbench.measure.frfs_from_time`.

    Returns
    -------
    FRFData

    Raises
    ------
    DataFormatError
        No input channel, no output channel, or an output of unknown quantity; the
        message names the file and the channels.
    """
    from truthbench.measure import Channel, frfs_from_time

    names = [str(n) for n in names]
    details = list(details) if details is not None else [{} for _ in names]
    units = list(units) if units is not None else [None] * len(names)
    rows_in = [k for k, q in enumerate(quantities) if q == "force"]
    if not rows_in:
        rows_in = [k for k, n in enumerate(names) if INPUT_NAME.search(n)]
    if not rows_in:
        shown = [f"{n} ({u})" if u else n for n, u in zip(names, units, strict=True)]
        raise DataFormatError(
            f"{source}: no input channel among {shown}: expected a force channel (unit "
            f"N/Newtons/kN, UFF data type 13) or one named like 'force', 'hammer', "
            f"'input' or 'excitation'"
        )
    rows_out = [k for k in range(len(names)) if k not in rows_in]
    if not rows_out:
        raise DataFormatError(
            f"{source}: only input channel(s) {[names[k] for k in rows_in]}; expected at "
            f"least one response channel"
        )
    for k in rows_out:
        q = quantities[k]
        if q is None or QUANTITIES[q].power is None:
            raise DataFormatError(
                f"{source}: output channel {names[k]!r} has unit {units[k]!r}; expected "
                f"acceleration (g, m/s^2), velocity (m/s), displacement (m) or strain (m/m)"
            )
    outputs = [Channel(names[k], quantities[k], **details[k]) for k in rows_out]
    inputs = [Channel(names[k], "force", **details[k]) for k in rows_in]
    data = np.asarray(data, float)
    return frfs_from_time(
        data[rows_in], data[rows_out], 1.0 / dt_s, outputs=outputs, inputs=inputs,
        name=name or Path(source).stem, source=source, excitation=excitation,
        decay_to=decay_to, force_width=force_width, n_averages=n_averages, window=window)


def frf_from_record(record: TimeRecord, *, source: str | None = None, **options) -> FRFData:
    """H1 FRFs of a :class:`TimeRecord` (e.g. from :func:`read_lvm`).

    Parameters
    ----------
    record : TimeRecord
        Channels in any units :func:`to_si` knows.
    source : str, optional
        For error messages (default: the record's file).
    **options
        ``excitation``, ``decay_to``, ``force_width``, ``n_averages``, ``window``,
        ``name`` (see :func:`frf_from_channels`).

    Returns
    -------
    FRFData

    Raises
    ------
    DataFormatError
        A unit :func:`to_si` does not know, no input or output channel.
    """
    source = source or str(record.source_path or "time record")
    try:
        rec = to_si(record)
    except ValueError as exc:
        raise DataFormatError(f"{source}: {exc}") from None
    quantities = [quantity_of_si_unit(u) for u in rec.units]
    return frf_from_channels(source, rec.data, rec.dt_s, rec.channel_names, quantities,
                             units=record.units, **options)


def read_lvm_frf(
    path: str | PathLike,
    *,
    allow_truncated: bool = False,
    excitation: str = "auto",
    decay_to: float = 0.01,
    force_width: int | None = None,
    n_averages: int = 8,
    window: str = "hann",
) -> tuple[FRFData, ...]:
    """Read a LabVIEW ``.lvm`` record and estimate its H1 FRFs (the ``.lvm`` reader).

    Parameters
    ----------
    path : str or os.PathLike
    allow_truncated : bool
        See :func:`read_lvm`.
    excitation, decay_to, force_width, n_averages, window
        See :func:`truthbench.measure.frfs_from_time`.

    Returns
    -------
    tuple of one FRFData
        Named after the file stem; channels labelled with the column titles.

    Raises
    ------
    DataFormatError
        A corrupt or truncated file, an unknown unit, no input or output channel.
    """
    p = Path(path)
    record = read_lvm(p, allow_truncated=allow_truncated)
    return (frf_from_record(record, source=str(p), excitation=excitation,
                            decay_to=decay_to, force_width=force_width,
                            n_averages=n_averages, window=window),)
