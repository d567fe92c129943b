"""Identify modal parameters from a data file: load -> FRFs -> identification.

This is a *workflow* module: unlike the numeric rooms (``measure``, ``identify``) it
reads files. It turns each supported file into one or more :class:`FRFData` (FRFs ready
for identification) and runs a registered identifier
(:data:`truthbench.identify.IDENTIFIERS`: ``"plscf"`` or ``"peak"``) on each.

Supported files (chosen by extension through :func:`truthbench.io.load_data`):

``.h5`` / ``.hdf5``
    truthbench results files (:mod:`truthbench.campaign.store`): every test of every
    trial holds its estimated H1 FRF ``H`` (n_freq, n_out, n_in) and ``freq_hz``
    (single-test files written by ``truthbench simulate`` likewise). The
    FRF type follows the output labels (``.acc``, ``.vel``, ``.dis``, ``.str``; strain
    is displacement-type); the default band is the test's excited ``band_hz`` from the
    stored campaign spec. :func:`register_hdf5_reader` (called by :func:`load_frfs`)
    registers :func:`read_results_frfs` as the ``.h5``/``.hdf5`` reader of
    :func:`truthbench.io.load_data` unless another room has registered one already (then
    its :func:`~truthbench.campaign.store.read_results` dictionary is accepted too).
``.uff`` / ``.unv``
    UFF dataset 58. FRF sets (function type 4) are used directly (type from the
    ordinate/denominator data types). Time sets (function type 1) become H1 FRFs: the
    inputs are the channels flagged as force (ordinate data type 13) or, failing that,
    named like an input (``force``, ``hammer``, ``input``, ``excitation``); every other
    channel is an output.
``.lvm``
    LabVIEW Measurement time records: the input is the channel in N (or named like a
    force), the outputs the channels in m/s^2, m/s or m (after
    :func:`truthbench.io.to_si`).

Time records are classified as an *impact* test when the input is a short pulse
(fewer than 2 % of the samples above 10 % of the peak after removing the baseline) and
as *random* otherwise (or as told by ``excitation=``):

* impact: one segment of the whole record; the force baseline (median of the samples
  after the pulse) is removed; the input gets a force window (the pulse plus as much
  again, at least 10 samples) times an exponential window, the outputs the same
  exponential window ``w[k] = decay_to ** (k / (n - 1))``. The exponential window adds
  the decay rate ``sigma_w = -ln(decay_to) fs / (n - 1)`` (1/s) to every pole (see
  :func:`truthbench.measure.get_window`); :func:`correct_exponential_window` moves the
  identified poles back by ``sigma_w``, so the reported damping is that of the
  structure. The default band is where the force auto-spectrum lies within 10 dB of its
  maximum (the usual hammer-test rule), without the 0 Hz line.
* random: H1 with a Hann window over ``n_averages`` non-overlapping segments; the
  default band is where the input auto-spectrum lies within 20 dB of its maximum.

Errors name the file and what was expected: a corrupt or truncated file
(:class:`~truthbench.errors.DataFormatError`, from the readers), no input or no output
channel (``DataFormatError``), a band outside the data (``ValueError``).
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from truthbench.errors import DataFormatError

__all__ = [
    "EULER_BERNOULLI_FREE_FREE_RATIOS",
    "DatasetIdentification",
    "FRFData",
    "IdentifyReport",
    "correct_exponential_window",
    "frfs_from_time",
    "identify_file",
    "identify_frfs",
    "load_frfs",
    "read_results_frfs",
    "register_hdf5_reader",
]

#: Free-free Euler-Bernoulli frequency ratios of bending modes 2 and 3 to mode 1,
#: ``(beta_n L / beta_1 L)^2`` with the roots 4.73004074486, 7.85320462410, 10.9956078380.
EULER_BERNOULLI_FREE_FREE_RATIOS = (
    (7.85320462410 / 4.73004074486) ** 2,
    (10.9956078380 / 4.73004074486) ** 2,
)

#: Lines needed in an identification band.
MIN_BAND_LINES = 8

_EXCITATIONS = ("auto", "impact", "random")
_INPUT_NAME = re.compile(r"force|hammer|input|excitation|shaker", re.IGNORECASE)
_LABEL_QUANTITY = {"acc": "acceleration", "vel": "velocity", "dis": "displacement",
                   "str": "displacement"}
_SI_QUANTITY = {"m/s^2": "acceleration", "m/s": "velocity", "m": "displacement"}
_UFF_FRF_TYPE = {"accelerance": "acceleration", "mobility": "velocity",
                 "receptance": "displacement"}
_POWER = {"displacement": 0, "velocity": 1, "acceleration": 2}


# ------------------------------------------------------------------------ data objects


def _readonly(a: Any, dtype=None) -> np.ndarray:
    out = np.array(a, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class FRFData:
    """FRFs of one test, ready for identification.

    Attributes
    ----------
    name : str
        The test (``"trial 0 / shaker_end"``, ``"uff"``, the file stem, ...).
    freq_hz : ndarray, shape (n_freq,)
        Frequency lines, Hz, increasing.
    H : ndarray, complex, shape (n_freq, n_out, n_in)
        FRF of type ``frf_type`` (output unit per input unit).
    frf_type : {"displacement", "velocity", "acceleration"}
        What the outputs measure (receptance, mobility, accelerance).
    output_labels, input_labels : tuple of str
        One label per output row / input column of ``H``.
    band_hz : (float, float) or None
        The usable band known from the source (excited band, force-spectrum rule), Hz.
    excitation : {"frf", "impact", "random"}
        ``"frf"`` when the file held FRFs, else how the time records were processed.
    window_decay_rad_s : float
        Decay rate ``sigma_w`` (1/s) an exponential window added to every pole; 0 if
        none. :func:`identify_frfs` removes it from the identified poles.
    notes : tuple of str
        What was done to the data (windows, segments, baseline), for the report.
    """

    name: str
    freq_hz: np.ndarray
    H: np.ndarray
    frf_type: str
    output_labels: tuple[str, ...]
    input_labels: tuple[str, ...]
    band_hz: tuple[float, float] | None = None
    excitation: str = "frf"
    window_decay_rad_s: float = 0.0
    notes: tuple[str, ...] = ()

    def __post_init__(self):
        f = _readonly(self.freq_hz, float)
        H = _readonly(self.H, complex)
        if f.ndim != 1 or H.ndim != 3 or H.shape[0] != f.size:
            raise ValueError(
                f"FRFData {self.name!r}: expected freq_hz (n_freq,) and H (n_freq, n_out, "
                f"n_in); got {f.shape} and {H.shape}"
            )
        if self.frf_type not in _POWER:
            raise ValueError(
                f"FRFData {self.name!r}: frf_type must be one of {sorted(_POWER)}; got "
                f"{self.frf_type!r}"
            )
        if len(self.output_labels) != H.shape[1] or len(self.input_labels) != H.shape[2]:
            raise ValueError(
                f"FRFData {self.name!r}: expected {H.shape[1]} output and {H.shape[2]} input "
                f"labels; got {len(self.output_labels)} and {len(self.input_labels)}"
            )
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "H", H)
        object.__setattr__(self, "output_labels", tuple(map(str, self.output_labels)))
        object.__setattr__(self, "input_labels", tuple(map(str, self.input_labels)))
        object.__setattr__(self, "notes", tuple(self.notes))
        if self.band_hz is not None:
            object.__setattr__(self, "band_hz", (float(self.band_hz[0]),
                                                 float(self.band_hz[1])))


@dataclass(frozen=True, eq=False)
class DatasetIdentification:
    """The modal parameters identified from one :class:`FRFData`.

    Attributes
    ----------
    data : FRFData
        What was identified.
    band_hz : (float, float)
        The band used, Hz.
    modal : ModalParameters
        Identified modes, ascending in frequency; damping corrected for the exponential
        window (``data.window_decay_rad_s``).
    damping_ratio_uncorrected : ndarray, shape (n_modes,)
        Damping ratios as identified, before that correction (equal when there was none).
    peak_magnitude : ndarray, shape (n_modes,)
        ``sum |H|`` over all channels at the line nearest each mode: the strength of the
        mode in the data (units of H).
    """

    data: FRFData
    band_hz: tuple[float, float]
    modal: Any
    damping_ratio_uncorrected: np.ndarray
    peak_magnitude: np.ndarray

    @property
    def n_modes(self) -> int:
        return int(self.modal.n_modes)

    def table(self) -> list[dict]:
        """One dict per mode: mode (1-based), freq_hz, damping_ratio,
        damping_ratio_uncorrected, peak_magnitude and, for several outputs, ``shape``
        (real part of the shape scaled to a largest entry of 1, one value per output)."""
        rows = []
        shapes = np.asarray(self.modal.shapes)
        for r in range(self.n_modes):
            row = {
                "mode": r + 1,
                "freq_hz": float(self.modal.freq_hz[r]),
                "damping_ratio": float(self.modal.damping_ratio[r]),
                "damping_ratio_uncorrected": float(self.damping_ratio_uncorrected[r]),
                "peak_magnitude": float(self.peak_magnitude[r]),
            }
            if shapes.shape[0] > 1:
                row["shape"] = [float(v) for v in _real_shape(shapes[:, r])]
            rows.append(row)
        return rows

    def strongest_ratios(self, count: int = 3) -> np.ndarray | None:
        """Frequency ratios to the lowest of the ``count`` strongest modes.

        The ``count`` modes with the largest ``peak_magnitude`` are sorted by
        frequency; returns ``f_k / f_1`` for the 2nd..count-th, shape (count - 1,), or
        None with fewer modes.
        """
        if self.n_modes < count:
            return None
        keep = np.sort(np.argsort(self.peak_magnitude)[::-1][:count])
        f = np.asarray(self.modal.freq_hz)[keep]
        return f[1:] / f[0]


@dataclass(frozen=True, eq=False)
class IdentifyReport:
    """What :func:`identify_file` found in one file.

    Attributes
    ----------
    path : pathlib.Path
    file_format : {"hdf5", "uff", "lvm"}
    method : str
        Registered identifier used (``"plscf"``, ``"peak"``).
    max_order : int
        Highest pLSCF model order (unused by ``"peak"``).
    datasets : tuple of DatasetIdentification
    """

    path: Path
    file_format: str
    method: str
    max_order: int
    datasets: tuple[DatasetIdentification, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict:
        """A JSON-serialisable summary (no FRF arrays)."""
        return {
            "path": str(self.path),
            "file_format": self.file_format,
            "method": self.method,
            "max_order": self.max_order,
            "datasets": [
                {
                    "name": d.data.name,
                    "frf_type": d.data.frf_type,
                    "excitation": d.data.excitation,
                    "band_hz": list(d.band_hz),
                    "window_decay_rad_s": d.data.window_decay_rad_s,
                    "output_labels": list(d.data.output_labels),
                    "input_labels": list(d.data.input_labels),
                    "notes": list(d.data.notes),
                    "modes": d.table(),
                }
                for d in self.datasets
            ],
        }

    def to_pandas(self):
        """One row per (dataset, mode): dataset, mode, freq_hz, damping_ratio,
        damping_ratio_uncorrected, peak_magnitude.

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        rows = [
            {"dataset": d.data.name, **{k: v for k, v in row.items() if k != "shape"}}
            for d in self.datasets
            for row in d.table()
        ]
        columns = ["dataset", "mode", "freq_hz", "damping_ratio",
                   "damping_ratio_uncorrected", "peak_magnitude"]
        return pd.DataFrame(rows, columns=columns)


def _real_shape(v: np.ndarray) -> np.ndarray:
    """Rotate a complex shape so its largest entry is real positive; return the real
    part scaled to a largest magnitude of 1."""
    v = np.asarray(v, dtype=complex)
    k = int(np.argmax(np.abs(v)))
    if abs(v[k]) == 0:
        return np.zeros(v.size)
    return (v / v[k]).real


# ------------------------------------------------------------------------ readers


def _band_from_spec(spec: Mapping, test: str) -> tuple[float, float] | None:
    for t in spec.get("tests", []) if isinstance(spec, Mapping) else []:
        if t.get("name") == test and t.get("band_hz") is not None:
            lo, hi = t["band_hz"]
            return float(lo), float(hi)
    return None


def _quantity_from_labels(path: Path, test: str, labels: Sequence[str]) -> str:
    kinds = set()
    for label in labels:
        key = str(label).rsplit(".", 1)[-1]
        if key not in _LABEL_QUANTITY:
            raise DataFormatError(
                f"{path}: test {test!r}: output label {label!r} does not end in one of "
                f"{sorted('.' + k for k in _LABEL_QUANTITY)}; cannot tell the FRF type"
            )
        kinds.add(_LABEL_QUANTITY[key])
    return kinds.pop() if len(kinds) == 1 else "mixed"


def _frfs_from_results_dict(path: Path, data: Mapping) -> tuple[FRFData, ...]:
    """FRFData of every stored test from a :func:`read_results` dictionary."""
    spec = data.get("attrs", {}).get("spec", {})
    if "trials" in data:
        groups = [(int(k), g.get("tests", {})) for k, g in sorted(data["trials"].items())
                  if k != "attrs"]
    else:  # a single-test file written by 'truthbench simulate'
        groups = [(int(data.get("attrs", {}).get("trial", 0)), data.get("tests", {}))]
    out = []
    for trial, tests in groups:
        for test, t in tests.items():
            if test == "attrs" or "H" not in t or "freq_hz" not in t:
                continue
            attrs = t.get("attrs", {})
            outputs = list(attrs.get("output_labels", []))
            inputs = list(attrs.get("input_labels", []))
            H = np.asarray(t["H"])
            if not outputs:
                outputs = [f"out{k}" for k in range(H.shape[1])]
            if not inputs:
                inputs = [f"in{k}" for k in range(H.shape[2])]
            kind = _quantity_from_labels(path, test, outputs)
            f = np.asarray(t["freq_hz"], float)
            notes = [f"H1 as stored by the campaign runner (fs {attrs.get('fs_hz')} Hz)"]
            if kind == "mixed":
                H, f = _to_displacement(f, H, [
                    _LABEL_QUANTITY[str(o).rsplit(".", 1)[-1]] for o in outputs])
                kind = "displacement"
                notes.append("mixed output quantities: converted to displacement-"
                             "equivalent FRFs (divided by (j w)^q), 0 Hz line dropped")
            out.append(FRFData(
                name=f"trial {trial} / {test}",
                freq_hz=f,
                H=H,
                frf_type=kind,
                output_labels=tuple(outputs),
                input_labels=tuple(inputs),
                band_hz=_band_from_spec(spec, test),
                excitation="frf",
                notes=tuple(notes),
            ))
    if not out:
        raise DataFormatError(
            f"{path}: the results file holds no test with stored FRFs (trials/*/tests/*/H "
            f"or tests/*/H, and freq_hz); expected at least one"
        )
    return tuple(out)


def read_results_frfs(path: str | PathLike) -> tuple[FRFData, ...]:
    """Read the stored FRFs of a truthbench results file (the ``.h5`` reader).

    Parameters
    ----------
    path : str or os.PathLike
        A results file written by :func:`truthbench.campaign.store.write_results`.

    Returns
    -------
    tuple of FRFData
        One per (trial, test), named ``"trial <k> / <test>"``, with the test's excited
        band (from the stored spec) as ``band_hz``.

    Raises
    ------
    DataFormatError
        Missing file, not HDF5, not a results file, no stored FRF, unknown output labels.
    """
    from truthbench.campaign.store import read_results

    p = Path(path)
    return _frfs_from_results_dict(p, read_results(p))


def register_hdf5_reader() -> None:
    """Register :func:`read_results_frfs` for ``.h5`` and ``.hdf5`` in :mod:`truthbench.io`.

    Idempotent; an extension that already has a reader (e.g. the campaign room's
    :func:`~truthbench.campaign.store.read_results`) is left alone, and
    :func:`load_frfs` accepts what that reader returns too. :func:`load_frfs` calls this
    before reading, so importing this module changes no global state.
    """
    from truthbench.io import register_reader, registered_extensions

    for ext in (".h5", ".hdf5"):
        if ext not in registered_extensions():
            register_reader(ext, read_results_frfs)


def _to_displacement(f: np.ndarray, H: np.ndarray, kinds: Sequence[str]):
    """Divide each output row by ``(j w)^q``; drop the 0 Hz line."""
    keep = f > 0
    f = f[keep]
    jw = 1j * 2 * np.pi * f
    q = np.array([_POWER[k] for k in kinds])
    return H[keep] / (jw[:, None] ** q[None, :])[:, :, None], f


def _input_rows(names: Sequence[str], is_force: Sequence[bool]) -> list[int]:
    rows = [k for k, flag in enumerate(is_force) if flag]
    if not rows:
        rows = [k for k, n in enumerate(names) if _INPUT_NAME.search(str(n))]
    return rows


def _frfs_from_uff(path: Path, uff, **options) -> tuple[FRFData, ...]:
    if not uff.is_time:
        if uff.func_type != 4:
            raise DataFormatError(
                f"{path}: dataset 58 function type {uff.func_type}; expected FRFs (type 4) "
                f"or time responses (type 1)"
            )
        kind = _UFF_FRF_TYPE.get(uff.frf_type or "")
        notes = ["FRF sets read from the file"]
        if kind is None:
            warnings.warn(
                f"{path}: the FRF sets do not say accelerance, mobility or receptance "
                f"(ordinate/denominator data types); treating them as receptance",
                stacklevel=3,
            )
            kind = "displacement"
            notes.append("FRF type unknown: treated as receptance")
        outs = tuple(f"{n}:{d}" for n, d in zip(uff.resp_nodes, uff.resp_dirs, strict=True))
        ins = tuple(f"{n}:{d}" for n, d in zip(uff.ref_nodes, uff.ref_dirs, strict=True))
        return (FRFData(name=path.stem, freq_hz=uff.freq_hz, H=uff.H, frf_type=kind,
                        output_labels=outs, input_labels=ins, excitation="frf",
                        notes=tuple(notes)),)
    names = [n if n and n != "NONE" else f"{node}:{d}" for n, node, d in
             zip(uff.resp_names, uff.resp_nodes, uff.resp_dirs, strict=True)]
    rows_in = _input_rows(names, [q == "force" for q in uff.quantities])
    if not rows_in:
        raise DataFormatError(
            f"{path}: no input channel among the time sets {names}: expected a channel "
            f"flagged as force (ordinate data type 13) or named like 'force', 'hammer', "
            f"'input' or 'excitation'"
        )
    rows_out = [k for k in range(len(names)) if k not in rows_in]
    kinds = [uff.quantities[k] for k in rows_out]
    return (_time_to_frfdata(path, uff.data, uff.dt_s, names, rows_in, rows_out, kinds,
                             **options),)


def _frfs_from_lvm(path: Path, record, **options) -> tuple[FRFData, ...]:
    from truthbench.io import to_si

    try:
        rec = to_si(record)
    except ValueError as exc:
        raise DataFormatError(f"{path}: {exc}") from None
    names = list(rec.channel_names)
    rows_in = _input_rows(names, [u == "N" for u in rec.units])
    if not rows_in:
        raise DataFormatError(
            f"{path}: no input channel among {list(zip(names, record.units, strict=True))}: "
            f"expected a force channel (unit N/Newtons/kN) or one named like 'force', "
            f"'hammer', 'input' or 'excitation'"
        )
    rows_out = [k for k in range(len(names)) if k not in rows_in]
    kinds = []
    for k in rows_out:
        kind = _SI_QUANTITY.get(rec.units[k])
        if kind is None:
            raise DataFormatError(
                f"{path}: output channel {names[k]!r} has unit {record.units[k]!r}; "
                f"expected acceleration (g, m/s^2), velocity (m/s) or displacement (m)"
            )
        kinds.append(kind)
    return (_time_to_frfdata(path, rec.data, rec.dt_s, names, rows_in, rows_out, kinds,
                             **options),)


def _time_to_frfdata(path, data, dt_s, names, rows_in, rows_out, kinds, **options):
    if not rows_out:
        raise DataFormatError(
            f"{path}: only input channel(s) {[names[k] for k in rows_in]}; expected at least "
            f"one response channel"
        )
    unknown = [names[k] for k, q in zip(rows_out, kinds, strict=True) if q not in _POWER]
    if unknown:
        raise DataFormatError(
            f"{path}: response channel(s) {unknown} are not acceleration, velocity or "
            f"displacement; expected one of those quantities"
        )
    if len(set(kinds)) > 1:
        raise DataFormatError(
            f"{path}: response channels of different quantities {sorted(set(kinds))}; "
            f"expected one quantity for all outputs"
        )
    data = np.asarray(data, float)
    return frfs_from_time(
        data[rows_in], data[rows_out], 1.0 / dt_s,
        frf_type=kinds[0],
        input_labels=tuple(names[k] for k in rows_in),
        output_labels=tuple(names[k] for k in rows_out),
        name=Path(path).stem,
        **options,
    )


# ------------------------------------------------------------------------ time -> FRF


def _pulse(x: np.ndarray) -> tuple[int, int, float] | None:
    """``(first, last, baseline)`` of an impact pulse in ``x`` (n,), or None."""
    base = float(np.median(x))
    a = np.abs(x - base)
    peak = float(a.max())
    if peak == 0:
        return None
    above = np.flatnonzero(a > 0.1 * peak)
    if above.size > 0.02 * x.size:
        return None
    hit = np.flatnonzero(a > 0.05 * peak)
    first, last = int(hit[0]), int(hit[-1])
    tail = x[min(x.size - 1, last + max(10, last - first + 1)):]
    if tail.size >= 10:
        base = float(np.median(tail))
    return first, last, base


def _band_from_autospectrum(f: np.ndarray, gxx: np.ndarray, db: float):
    """Lowest and highest positive line where ``gxx`` is within ``db`` of its maximum."""
    pos = f > 0
    level = gxx[pos].max() * 10 ** (-db / 10)
    ok = np.flatnonzero(pos & (gxx >= level))
    return float(f[ok[0]]), float(f[ok[-1]])


def frfs_from_time(
    x,
    y,
    fs_hz: float,
    *,
    frf_type: str,
    input_labels: Sequence[str] | None = None,
    output_labels: Sequence[str] | None = None,
    name: str = "time record",
    excitation: str = "auto",
    decay_to: float = 0.01,
    force_width: int | None = None,
    n_averages: int = 8,
    window: str = "hann",
) -> FRFData:
    """H1 FRFs from input and output time histories (impact or random test).

    Parameters
    ----------
    x : array_like, shape (n_in, n_samples)
        Input (force) records, N.
    y : array_like, shape (n_out, n_samples)
        Response records (acceleration m/s^2, velocity m/s or displacement m).
    fs_hz : float
        Sampling frequency, Hz.
    frf_type : {"displacement", "velocity", "acceleration"}
        What ``y`` measures.
    input_labels, output_labels : sequence of str, optional
    name : str
        Name of the resulting :class:`FRFData`.
    excitation : {"auto", "impact", "random"}
        ``"auto"``: impact if every input is a short pulse (see module notes).
    decay_to : float
        Impact only: last value of the exponential window, ``0 < decay_to < 1``.
    force_width : int, optional
        Impact only: force-window length in samples (default: the pulse end plus the
        pulse duration again, at least 10 samples more).
    n_averages : int
        Random only: non-overlapping segments averaged.
    window : str
        Random only: segment window name (:func:`truthbench.measure.get_window`).

    Returns
    -------
    FRFData
        With ``band_hz`` from the input auto-spectrum (10 dB rule for impact, 20 dB for
        random) and, for impact, ``window_decay_rad_s = -ln(decay_to) fs / (n - 1)``.

    Raises
    ------
    DataFormatError
        Records of different lengths, an impact test with several inputs, or
        ``excitation="impact"`` when an input holds no pulse.
    ValueError
        Unknown ``excitation``; bad window parameters.
    """
    from truthbench.measure import estimate_frf, get_window

    if excitation not in _EXCITATIONS:
        raise ValueError(f"excitation must be one of {_EXCITATIONS}; got {excitation!r}")
    x = np.atleast_2d(np.asarray(x, float))
    y = np.atleast_2d(np.asarray(y, float))
    if x.shape[1] != y.shape[1]:
        raise DataFormatError(
            f"{name}: input and output records differ in length ({x.shape[1]} and "
            f"{y.shape[1]} samples); expected equal lengths"
        )
    n = x.shape[1]
    inputs = tuple(input_labels or (f"in{k}" for k in range(x.shape[0])))
    outputs = tuple(output_labels or (f"out{k}" for k in range(y.shape[0])))
    pulses = [_pulse(row) for row in x]
    impact = all(p is not None for p in pulses) if excitation == "auto" else (
        excitation == "impact")
    if impact:
        if x.shape[0] != 1:
            raise DataFormatError(
                f"{name}: impact test with {x.shape[0]} force channels {inputs}; expected "
                f"one hammer (an H1 from one record needs one input)"
            )
        if pulses[0] is None:
            raise DataFormatError(
                f"{name}: excitation='impact' but input {inputs[0]!r} holds no short pulse "
                f"(more than 2 % of the samples above 10 % of the peak)"
            )
        first, last, base = pulses[0]
        width = force_width if force_width is not None else min(
            n, last + 1 + max(10, last - first + 1))
        w_exp = get_window("exponential", n, decay_to=decay_to)
        w_in = w_exp * get_window("force", n, force_width=width)
        est = estimate_frf(x - base, y, fs_hz, window=w_exp, input_window=w_in, nperseg=n)
        sigma_w = -math.log(decay_to) * fs_hz / (n - 1)
        gxx = np.abs(np.fft.rfft((x[0] - base) * w_in)) ** 2
        band = _band_from_autospectrum(est.freq_hz, gxx, 10.0)
        notes = (
            f"impact: one segment of {n} samples (df {est.df_hz:.4g} Hz)",
            f"force baseline {base:.4g} removed; force window {width} samples "
            f"(pulse at samples {first}-{last})",
            f"exponential window to {decay_to:g}: sigma_w {sigma_w:.4g} 1/s removed from "
            f"the identified poles",
            f"default band: force spectrum within 10 dB of its maximum, "
            f"{band[0]:.4g}-{band[1]:.4g} Hz",
        )
        return FRFData(name=name, freq_hz=est.freq_hz, H=est.H, frf_type=frf_type,
                       output_labels=outputs, input_labels=inputs, band_hz=band,
                       excitation="impact", window_decay_rad_s=sigma_w, notes=notes)
    nper = n // int(n_averages)
    est = estimate_frf(x, y, fs_hz, window=window, nperseg=nper, n_averages=int(n_averages),
                       detrend="constant")
    seg = x[:, : nper * int(n_averages)].reshape(x.shape[0], int(n_averages), nper)
    w = get_window(window, nper)
    seg = (seg - seg.mean(axis=-1, keepdims=True)) * w
    gxx = (np.abs(np.fft.rfft(seg, axis=-1)) ** 2).mean(axis=(0, 1))
    band = _band_from_autospectrum(est.freq_hz, gxx, 20.0)
    notes = (
        f"random: H1, {window} window, {est.n_averages} segments of {nper} samples "
        f"(df {est.df_hz:.4g} Hz)",
        f"default band: input spectrum within 20 dB of its maximum, "
        f"{band[0]:.4g}-{band[1]:.4g} Hz",
    )
    return FRFData(name=name, freq_hz=est.freq_hz, H=est.H, frf_type=frf_type,
                   output_labels=outputs, input_labels=inputs, band_hz=band,
                   excitation="random", notes=notes)


# ------------------------------------------------------------------------ identification


def correct_exponential_window(modal, sigma_w_rad_s: float):
    """Undo the damping an exponential window added: move every pole right by sigma_w.

    The window multiplies the impulse response by ``exp(-sigma_w t)``, so each pole
    ``s = -zeta w_n + j w_d`` was identified as ``s - sigma_w``; the corrected pole is
    ``s + sigma_w`` and ``w_n = |s|``, ``zeta = -Re(s) / |s|``.

    Parameters
    ----------
    modal : ModalParameters
        As identified from windowed data.
    sigma_w_rad_s : float
        Window decay rate, 1/s (``-ln(decay_to) fs / (n - 1)``).

    Returns
    -------
    ModalParameters
        A new object with corrected frequencies and damping ratios (shapes, participation
        and labels unchanged).

    Raises
    ------
    ValueError
        If a corrected damping ratio would be negative (the mode decays more slowly than
        the window: the window, not the structure, set its apparent damping).
    """
    from truthbench.identify import ModalParameters, modal_from_poles, poles_from_modal

    if sigma_w_rad_s == 0 or modal.n_modes == 0:
        return modal
    s = poles_from_modal(modal.freq_hz, modal.damping_ratio) + sigma_w_rad_s
    f, z = modal_from_poles(s)
    if np.any(s.real > 0):
        bad = np.asarray(modal.freq_hz)[s.real > 0]
        raise ValueError(
            f"correct_exponential_window: the modes at {np.round(bad, 3).tolist()} Hz decay "
            f"more slowly ({-np.max(s.real - sigma_w_rad_s):.4g} 1/s) than the window adds "
            f"({sigma_w_rad_s:.4g} 1/s); expected every identified decay rate above sigma_w"
        )
    return ModalParameters(freq_hz=f, damping_ratio=z, shapes=modal.shapes,
                           participation=modal.participation,
                           output_labels=modal.output_labels)


def _resolve_band(data: FRFData, band_hz, source: str) -> tuple[float, float]:
    f = data.freq_hz
    positive = f[f > 0]
    if band_hz is None:
        if data.band_hz is not None:
            lo, hi = data.band_hz
            lo, hi = max(lo, float(positive[0])), min(hi, float(f[-1]))
        else:
            lo, hi = float(positive[0]), float(f[-1])
    else:
        try:
            lo, hi = (float(v) for v in band_hz)
        except (TypeError, ValueError):
            raise ValueError(
                f"{source}: band must be two frequencies (low, high) in Hz; got {band_hz!r}"
            ) from None
        if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
            raise ValueError(f"{source}: band must satisfy 0 <= low < high; got ({lo}, {hi}) Hz")
        if lo < f[0] or hi > f[-1]:
            raise ValueError(
                f"{source}: band {lo:g}-{hi:g} Hz lies outside the data of {data.name!r}, "
                f"which spans {f[0]:g}-{f[-1]:g} Hz; expected a band inside it"
            )
    n_lines = int(np.count_nonzero((f >= lo) & (f <= hi)))
    if n_lines < MIN_BAND_LINES:
        raise ValueError(
            f"{source}: band {lo:g}-{hi:g} Hz holds {n_lines} frequency lines of "
            f"{data.name!r} (df {f[1] - f[0]:g} Hz); expected at least {MIN_BAND_LINES}"
        )
    return lo, hi


#: Options each registered identifier takes from :func:`identify_frfs`.
_METHOD_OPTIONS: dict[str, Callable[[int, int | None], dict]] = {
    "plscf": lambda max_order, n_modes: {"max_order": max_order},
    "peak": lambda max_order, n_modes: {"n_modes": n_modes},
}


def identify_frfs(
    data: FRFData,
    *,
    method: str = "plscf",
    max_order: int = 30,
    band_hz: tuple[float, float] | None = None,
    n_modes: int | None = None,
    source: str = "",
) -> DatasetIdentification:
    """Identify modal parameters from one :class:`FRFData`.

    Parameters
    ----------
    data : FRFData
    method : {"plscf", "peak"}
        A registered identifier (:data:`truthbench.identify.IDENTIFIERS`).
    max_order : int
        Highest pLSCF order.
    band_hz : (float, float), optional
        Band in Hz; must lie inside the data. Default: ``data.band_hz`` (or every line
        above 0 Hz).
    n_modes : int, optional
        Peak picking: keep the ``n_modes`` most prominent peaks.
    source : str
        Name of the file, for error messages.

    Returns
    -------
    DatasetIdentification
        Modes ascending in frequency, damping corrected for an exponential window.

    Raises
    ------
    ValueError
        Unknown method, band outside the data or with too few lines.
    """
    from truthbench.identify import ModalParameters, get_identifier

    if method not in _METHOD_OPTIONS:
        get_identifier(method)  # raises with the list of registered names
        raise ValueError(f"identify_frfs has no options for method {method!r}; expected "
                         f"one of {sorted(_METHOD_OPTIONS)}")
    identifier = get_identifier(method)
    band = _resolve_band(data, band_hz, source or data.name)
    f, H = data.freq_hz, data.H
    # the band's lines above 0 Hz (residual terms of velocity/displacement FRFs diverge
    # at 0 Hz) with finite values (H1 is NaN where the input spectrum is singular)
    keep = (f > 0) & (f >= band[0]) & (f <= band[1])
    finite = np.isfinite(H).reshape(f.size, -1).all(axis=1)
    if np.any(keep & ~finite):
        warnings.warn(
            f"{source or data.name}: {int(np.count_nonzero(keep & ~finite))} line(s) of "
            f"{data.name!r} in the band {band[0]:g}-{band[1]:g} Hz hold non-finite FRF "
            f"values (e.g. a singular input spectrum); they are left out",
            stacklevel=2,
        )
    keep &= finite
    if np.count_nonzero(keep) < MIN_BAND_LINES:
        raise ValueError(
            f"{source or data.name}: band {band[0]:g}-{band[1]:g} Hz holds "
            f"{int(np.count_nonzero(keep))} usable (finite, above 0 Hz) lines of "
            f"{data.name!r}; expected at least {MIN_BAND_LINES}"
        )
    raw = identifier(f[keep], H[keep], frf_type=data.frf_type, freq_range_hz=band,
                     **_METHOD_OPTIONS[method](max_order, n_modes))
    order = np.argsort(raw.freq_hz)
    labelled = ModalParameters(
        freq_hz=raw.freq_hz[order], damping_ratio=raw.damping_ratio[order],
        shapes=raw.shapes[:, order],
        participation=None if raw.participation is None else raw.participation[order],
        output_labels=data.output_labels)
    modal = correct_exponential_window(labelled, data.window_decay_rad_s)
    idx = np.searchsorted(f, modal.freq_hz).clip(1, f.size - 1)
    idx = np.where(np.abs(f[idx - 1] - modal.freq_hz) < np.abs(f[idx] - modal.freq_hz),
                   idx - 1, idx)
    strength = np.abs(H[idx]).reshape(idx.size, -1).sum(axis=1)
    return DatasetIdentification(
        data=data, band_hz=band, modal=modal,
        damping_ratio_uncorrected=_readonly(labelled.damping_ratio),
        peak_magnitude=_readonly(strength))


_FORMATS = {".h5": "hdf5", ".hdf5": "hdf5", ".uff": "uff", ".unv": "uff", ".lvm": "lvm"}


def load_frfs(path: str | PathLike, **options) -> tuple[str, tuple[FRFData, ...]]:
    """Read a data file and turn it into FRFs.

    Parameters
    ----------
    path : str or os.PathLike
        ``.h5``/``.hdf5``, ``.uff``/``.unv`` or ``.lvm`` file.
    **options
        For time records: ``excitation``, ``decay_to``, ``force_width``,
        ``n_averages``, ``window`` (see :func:`frfs_from_time`).

    Returns
    -------
    file_format : {"hdf5", "uff", "lvm"}
    frfs : tuple of FRFData

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    DataFormatError
        Unknown extension, corrupt or truncated file, no input/output channel.
    """
    from truthbench.io import TimeRecord, UFFData, load_data

    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{p}: no such data file")
    register_hdf5_reader()
    loaded = load_data(p)
    fmt = _FORMATS.get(p.suffix.lower(), p.suffix.lower().lstrip("."))
    if isinstance(loaded, UFFData):
        return fmt, _frfs_from_uff(p, loaded, **options)
    if isinstance(loaded, TimeRecord):
        return fmt, _frfs_from_lvm(p, loaded, **options)
    if isinstance(loaded, Mapping) and ("trials" in loaded or "tests" in loaded):
        # what the campaign room's read_results returns
        return fmt, _frfs_from_results_dict(p, loaded)
    if isinstance(loaded, tuple) and all(isinstance(d, FRFData) for d in loaded):
        return fmt, loaded
    raise DataFormatError(
        f"{p}: the reader for {p.suffix!r} returned {type(loaded).__name__}; expected a "
        f"results file, UFF 58 data or a time record"
    )


def identify_file(
    path: str | PathLike,
    *,
    method: str = "plscf",
    max_order: int = 30,
    band_hz: tuple[float, float] | None = None,
    n_modes: int | None = None,
    excitation: str = "auto",
    decay_to: float = 0.01,
    force_width: int | None = None,
    n_averages: int = 8,
    window: str = "hann",
) -> IdentifyReport:
    """Load a data file, estimate FRFs where needed, identify modal parameters.

    Parameters
    ----------
    path : str or os.PathLike
        truthbench results (``.h5``), UFF 58 (``.uff``/``.unv``) or LVM (``.lvm``).
    method : {"plscf", "peak"}
        Registered identifier.
    max_order : int
        Highest pLSCF order (``>= 2``).
    band_hz : (float, float), optional
        Identification band, Hz, inside the data (default: per dataset, see module
        notes).
    n_modes : int, optional
        Peak picking: number of peaks kept.
    excitation, decay_to, force_width, n_averages, window
        Time records only: see :func:`frfs_from_time`.

    Returns
    -------
    IdentifyReport

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    DataFormatError
        Corrupt or truncated file, unknown extension, no input or output channel.
    ValueError
        Band outside the data, unknown method, bad options.
    """
    if not isinstance(max_order, int | np.integer) or max_order < 2:
        raise ValueError(f"max_order must be an integer >= 2; got {max_order!r}")
    p = Path(path)
    fmt, frfs = load_frfs(p, excitation=excitation, decay_to=decay_to,
                          force_width=force_width, n_averages=n_averages, window=window)
    results = tuple(
        identify_frfs(d, method=method, max_order=int(max_order), band_hz=band_hz,
                      n_modes=n_modes, source=str(p))
        for d in frfs
    )
    return IdentifyReport(path=p, file_format=fmt, method=method, max_order=int(max_order),
                          datasets=results)
