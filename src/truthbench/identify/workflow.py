"""Identify modal parameters from FRFData or from a data file.

:func:`identify_frfs` runs a registered identifier (:data:`truthbench.identify.IDENTIFIERS`:
``"plscf"`` or ``"peak"``) on one :class:`~truthbench.measure.FRFData` over a band, drops
the lines it cannot use (0 Hz, non-finite values) and undoes the damping an exponential
window added (:func:`correct_exponential_window`). :func:`identify_file` reads any file
:func:`truthbench.io.load_frf` reads (``.h5``/``.hdf5`` results and ``simulate`` files,
``.uff``/``.unv``, ``.lvm``) and identifies every FRFData in it.

FRF types. The identifiers take displacement, velocity or acceleration FRFs; strain
outputs count as displacement-type, and FRFData whose outputs measure several
quantities are brought to displacement-equivalent FRFs first
(:meth:`~truthbench.measure.FRFData.as_quantity`; the 0 Hz line is dropped).

Default band (:func:`default_band`), the first rule that applies:

1. the data's own ``band_hz``: the excited band of a campaign test, or the
   force-spectrum rule of a time record (impact: force spectrum within 10 dB of its
   maximum; random: within 20 dB), its edges clipped to the lines above 0 Hz;
2. with coherence (a UFF file from another tool, which records no band): the span of
   the lines where the coherence shows the input, from the first to the last line whose
   largest coherence over the channels is at least ``max(0.5, gamma2_null)``. 0.5 means
   as much coherent as incoherent output power; ``gamma2_null = 1 - (0.01 / (n_lines
   n_channels))^(1 / (n_d - 1))`` is the coherence that uncorrelated records reach on
   any line of any channel with probability at most 1 % in all (the coherence of
   independent records over ``n_d`` averages exceeds ``g`` with probability ``(1 -
   g)^(n_d - 1)``), so noise outside the excited band does not stretch the band
   (0.87 for 8 averages, 4097 lines, 4 channels). Without a known number of averages
   only the 0.5 rule applies;
3. otherwise every line above 0 Hz (the table says so: give ``--band``).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from truthbench._validation import readonly
from truthbench.identify.modal import ModalParameters, modal_from_poles, poles_from_modal
from truthbench.identify.peak import PeakIdentifier
from truthbench.identify.plscf import PLSCFIdentifier
from truthbench.identify.registry import Identifier, make_identifier
from truthbench.measure.frfdata import FRFData
from truthbench.presentation import Presentable, figure_axes
from truthbench.quantities import MOTION_QUANTITIES

__all__ = [
    "EULER_BERNOULLI_FREE_FREE_RATIOS",
    "MIN_BAND_LINES",
    "DatasetIdentification",
    "IdentifyReport",
    "coherence_threshold",
    "correct_exponential_window",
    "default_band",
    "identify_file",
    "identify_frfs",
]

#: Free-free Euler-Bernoulli frequency ratios of bending modes 2 and 3 to mode 1,
#: ``(beta_n L / beta_1 L)^2`` with the roots 4.73004074486, 7.85320462410, 10.9956078380.
EULER_BERNOULLI_FREE_FREE_RATIOS = (
    (7.85320462410 / 4.73004074486) ** 2,
    (10.9956078380 / 4.73004074486) ** 2,
)

#: Lines needed in an identification band.
MIN_BAND_LINES = 8

#: Coherence at which the coherent output power equals the incoherent (noise) power.
COHERENT_POWER_EQUALS_NOISE = 0.5

#: Family-wise probability that uncorrelated records reach the coherence threshold on
#: any line of any channel (the band's false-alarm rate).
COHERENCE_FALSE_ALARM = 0.01


@dataclass(frozen=True, eq=False)
class DatasetIdentification(Presentable):
    """The modal parameters identified from one :class:`FRFData`.

    Table ``"modes"`` (:meth:`to_pandas`): one row per mode (:meth:`table` without the
    shapes). Figure ``"frf"`` (:meth:`plot`): ``sum |H|`` over the channels in the band
    with the identified frequencies marked.

    Attributes
    ----------
    data : FRFData
        What was identified (after any conversion to one FRF type).
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
    band_rule : str
        Where ``band_hz`` came from (see :func:`default_band`).
    """

    TABLES = ("modes",)
    PLOTS = ("frf",)

    data: FRFData
    band_hz: tuple[float, float]
    modal: ModalParameters
    damping_ratio_uncorrected: np.ndarray
    peak_magnitude: np.ndarray
    band_rule: str = ""

    @property
    def n_modes(self) -> int:
        return int(self.modal.n_modes)

    def table(self) -> list[dict]:
        """One dict per mode: mode (1-based), freq_hz, damping_ratio,
        damping_ratio_uncorrected, peak_magnitude and, for several outputs, ``shape``
        (real part of the shape scaled to a largest entry of 1, one value per output)."""
        rows = []
        shapes = self.modal.aligned_shapes().real
        for r in range(self.n_modes):
            row = {
                "mode": r + 1,
                "freq_hz": float(self.modal.freq_hz[r]),
                "damping_ratio": float(self.modal.damping_ratio[r]),
                "damping_ratio_uncorrected": float(self.damping_ratio_uncorrected[r]),
                "peak_magnitude": float(self.peak_magnitude[r]),
            }
            if shapes.shape[0] > 1:
                row["shape"] = [float(v) for v in shapes[:, r]]
            rows.append(row)
        return rows

    def _table_modes(self):
        """One row per mode: mode (1-based), freq_hz, damping_ratio,
        damping_ratio_uncorrected, peak_magnitude."""
        import pandas as pd

        return pd.DataFrame([{k: v for k, v in row.items() if k != "shape"}
                             for row in self.table()], columns=_MODE_COLUMNS)

    def _plot_frf(self, ax):
        """``sum |H|`` over the channels against frequency inside the band, the
        identified frequencies marked."""
        fig, (ax,) = figure_axes(ax, figsize=(7, 3.5))
        self._draw(ax)
        fig.tight_layout()
        return fig

    def _draw(self, ax) -> None:
        f, H = self.data.freq_hz, self.data.H
        inside = (f >= self.band_hz[0]) & (f <= self.band_hz[1])
        ax.semilogy(f[inside], np.abs(H[inside]).reshape(int(inside.sum()), -1).sum(axis=1),
                    lw=0.8, color="0.3")
        for fr in self.modal.freq_hz:
            ax.axvline(fr, color="tab:red", lw=0.6, ls="--")
        ax.set_title(f"{self.data.name}: {self.n_modes} modes", fontsize="medium")
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel(f"sum |H| ({self.data.frf_type})")

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
class IdentifyReport(Presentable):
    """What :func:`identify_file` found in one file.

    Table ``"modes"`` (:meth:`to_pandas`): one row per (dataset, mode). Figure ``"frf"``
    (:meth:`plot`): one panel per dataset (:class:`DatasetIdentification`).

    Attributes
    ----------
    path : pathlib.Path
    file_format : str
        ``"hdf5"``, ``"uff"``, ``"lvm"`` (else the extension without its dot).
    method : str
        Registered identifier used (``"plscf"``, ``"peak"``).
    max_order : int
        Highest pLSCF model order (unused by ``"peak"``).
    datasets : tuple of DatasetIdentification
    """

    TABLES = ("modes",)
    PLOTS = ("frf",)

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
                    "band_rule": d.band_rule,
                    "window_decay_rad_s": d.data.window_decay_rad_s,
                    "n_averages": d.data.n_averages,
                    "output_labels": list(d.data.output_labels),
                    "input_labels": list(d.data.input_labels),
                    "notes": list(d.data.notes),
                    "modes": d.table(),
                }
                for d in self.datasets
            ],
        }

    def _table_modes(self):
        """One row per (dataset, mode): dataset, mode, freq_hz, damping_ratio,
        damping_ratio_uncorrected, peak_magnitude."""
        import pandas as pd

        rows = [{"dataset": d.data.name, **{k: v for k, v in row.items() if k != "shape"}}
                for d in self.datasets for row in d.table()]
        return pd.DataFrame(rows, columns=["dataset", *_MODE_COLUMNS])

    def _plot_frf(self, ax):
        """One panel per dataset: ``sum |H|`` with the identified frequencies."""
        n = max(len(self.datasets), 1)
        fig, axes = figure_axes(ax, n, figsize=(7, 2.8 * n))
        for d, a in zip(self.datasets, axes, strict=False):
            d._draw(a)
        fig.tight_layout()
        return fig


_MODE_COLUMNS = ["mode", "freq_hz", "damping_ratio", "damping_ratio_uncorrected",
                 "peak_magnitude"]


def correct_exponential_window(modal: ModalParameters, sigma_w_rad_s: float) -> ModalParameters:
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
        and labels unchanged); ``modal`` itself when ``sigma_w_rad_s`` is 0.

    Raises
    ------
    ValueError
        If a corrected damping ratio would be negative (the mode decays more slowly than
        the window: the window, not the structure, set its apparent damping).
    """
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


def coherence_threshold(n_averages: int | None, n_lines: int, n_channels: int) -> float:
    """The coherence a line needs to count as excited (module notes, rule 2).

    ``max(0.5, 1 - (0.01 / (n_lines n_channels))^(1 / (n_averages - 1)))``; 0.5 when the
    number of averages is unknown or 1.
    """
    if n_averages is None or n_averages < 2:
        return COHERENT_POWER_EQUALS_NOISE
    null = 1.0 - (COHERENCE_FALSE_ALARM / (n_lines * n_channels)) ** (1.0 / (n_averages - 1))
    return max(COHERENT_POWER_EQUALS_NOISE, null)


def default_band(data: FRFData) -> tuple[float, float, str]:
    """The identification band of ``data`` when none is given (module notes).

    Returns
    -------
    (low_hz, high_hz, rule) : (float, float, str)
        The band and, in words, the rule that gave it.

    Raises
    ------
    ValueError
        ``data`` has no line above 0 Hz.
    """
    f = data.freq_hz
    positive = f[f > 0]
    if positive.size == 0:
        raise ValueError(f"{data.name!r} has no frequency line above 0 Hz")
    if data.band_hz is not None:
        lo, hi = data.band_hz
        lo, hi = max(lo, float(positive[0])), min(hi, float(f[-1]))
        return lo, hi, "the data's excited band"
    if data.coherence is not None:
        g = np.asarray(data.coherence).reshape(f.size, -1)
        with np.errstate(invalid="ignore"):
            best = np.nanmax(np.where(np.isfinite(g), g, -np.inf), axis=1)
        level = coherence_threshold(data.n_averages, int(positive.size), g.shape[1])
        hit = np.flatnonzero((f > 0) & (best >= level))
        if hit.size:
            avg = (f"{data.n_averages} averages" if data.n_averages
                   else "averages unknown")
            return float(f[hit[0]]), float(f[hit[-1]]), (
                f"the lines whose coherence reaches {level:.3g} ({avg}, {positive.size} "
                f"lines, {g.shape[1]} channels)")
    return float(positive[0]), float(f[-1]), (
        "every line above 0 Hz: the data record no excited band and no coherence; give "
        "a band (--band LO HI) if the excitation covered less")


def _resolve_band(data: FRFData, band_hz, source: str) -> tuple[float, float, str]:
    f = data.freq_hz
    if band_hz is None:
        try:
            lo, hi, rule = default_band(data)
        except ValueError as exc:
            raise ValueError(f"{source}: {exc}") from None
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
        rule = "given"
    n_lines = int(np.count_nonzero((f >= lo) & (f <= hi)))
    if n_lines < MIN_BAND_LINES:
        raise ValueError(
            f"{source}: band {lo:g}-{hi:g} Hz holds {n_lines} frequency lines of "
            f"{data.name!r} (df {f[1] - f[0]:g} Hz); expected at least {MIN_BAND_LINES}"
        )
    return lo, hi, rule


def _one_type(data: FRFData) -> FRFData:
    """``data`` with outputs of one motion quantity (strain as displacement; mixed
    quantities as displacement-equivalent)."""
    if data.frf_type in MOTION_QUANTITIES:
        return data
    return data.as_quantity("displacement")


def identify_frfs(
    data: FRFData,
    *,
    method: str = "plscf",
    max_order: int | None = PLSCFIdentifier.max_order,
    band_hz: tuple[float, float] | None = None,
    n_modes: int | None = PeakIdentifier.n_modes,
    source: str = "",
) -> DatasetIdentification:
    """Identify modal parameters from one :class:`FRFData`.

    Parameters
    ----------
    data : FRFData
    method : {"plscf", "peak"}
        A registered identifier (:data:`truthbench.identify.IDENTIFIERS`).
    max_order : int, optional
        Highest pLSCF order (:class:`~truthbench.identify.PLSCFIdentifier`; None: its
        default).
    band_hz : (float, float), optional
        Band in Hz; must lie inside the data. Default: :func:`default_band` (the data's
        excited band, else its coherent lines, else every line above 0 Hz).
    n_modes : int, optional
        Peak picking: keep the ``n_modes`` most prominent peaks.
    source : str
        Name of the file, for error messages.

    Returns
    -------
    DatasetIdentification
        Modes ascending in frequency, damping corrected for an exponential window,
        shapes labelled with the output labels.

    Raises
    ------
    ValueError
        Unknown method, a bad setting, band outside the data or with too few usable
        lines.
    """
    identifier = make_identifier(method, {"max_order": max_order, "n_modes": n_modes})
    return _identify(data, identifier, band_hz, source)


def _identify(data: FRFData, identifier: Identifier, band_hz, source: str
              ) -> DatasetIdentification:
    data = _one_type(data)
    where = source or data.name
    *band, rule = _resolve_band(data, band_hz, where)
    band = tuple(band)
    f, H = data.freq_hz, data.H
    # the band's lines above 0 Hz (residual terms of velocity/displacement FRFs diverge
    # at 0 Hz) with finite values (H1 is NaN where the input spectrum is singular)
    keep = (f > 0) & (f >= band[0]) & (f <= band[1])
    finite = np.isfinite(H).reshape(f.size, -1).all(axis=1)
    if np.any(keep & ~finite):
        warnings.warn(
            f"{where}: {int(np.count_nonzero(keep & ~finite))} line(s) of "
            f"{data.name!r} in the band {band[0]:g}-{band[1]:g} Hz hold non-finite FRF "
            f"values (e.g. a singular input spectrum); they are left out",
            stacklevel=3,
        )
    keep &= finite
    if np.count_nonzero(keep) < MIN_BAND_LINES:
        raise ValueError(
            f"{where}: band {band[0]:g}-{band[1]:g} Hz holds "
            f"{int(np.count_nonzero(keep))} usable (finite, above 0 Hz) lines of "
            f"{data.name!r}; expected at least {MIN_BAND_LINES}"
        )
    raw = identifier(f[keep], H[keep], frf_type=data.frf_type, freq_range_hz=band)
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
    strength = np.abs(H[idx]).reshape(idx.size, -1).sum(axis=1) if idx.size else np.zeros(0)
    return DatasetIdentification(
        data=data, band_hz=band, modal=modal,
        damping_ratio_uncorrected=readonly(labelled.damping_ratio),
        peak_magnitude=readonly(strength), band_rule=rule)


_FORMATS = {".h5": "hdf5", ".hdf5": "hdf5", ".uff": "uff", ".unv": "uff", ".lvm": "lvm"}


def identify_file(
    path: str | PathLike,
    *,
    method: str = "plscf",
    max_order: int | None = PLSCFIdentifier.max_order,
    band_hz: tuple[float, float] | None = None,
    n_modes: int | None = PeakIdentifier.n_modes,
    **read_options: Any,
) -> IdentifyReport:
    """Load a data file (:func:`truthbench.io.load_frf`) and identify every FRFData in it.

    Parameters
    ----------
    path : str or os.PathLike
        Results or ``simulate`` file (``.h5``), UFF (``.uff``/``.unv``) or LVM
        (``.lvm``).
    method : {"plscf", "peak"}
        Registered identifier.
    max_order : int, optional
        Highest pLSCF order (:class:`~truthbench.identify.PLSCFIdentifier`; None: its
        default).
    band_hz : (float, float), optional
        Identification band, Hz, inside the data (default: per dataset, see the module
        notes).
    n_modes : int, optional
        Peak picking: number of peaks kept.
    **read_options
        Passed to the file's reader: for time records ``excitation``, ``decay_to``,
        ``force_width``, ``n_averages``, ``window``
        (:func:`truthbench.measure.frfs_from_time`); ``coherence`` for UFF;
        ``trials``, ``tests`` for results files.

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
        Band outside the data, unknown method, bad options (e.g. an option the file's
        reader does not take).
    """
    from truthbench.io import load_frf

    identifier = make_identifier(method, {"max_order": max_order, "n_modes": n_modes})
    p = Path(path)
    frfs = load_frf(p, **read_options)
    results = tuple(_identify(d, identifier, band_hz, str(p)) for d in frfs)
    fmt = _FORMATS.get(p.suffix.lower(), p.suffix.lower().lstrip("."))
    order = PLSCFIdentifier.max_order if max_order is None else max_order
    return IdentifyReport(path=p, file_format=fmt, method=method,
                          max_order=identifier.settings().get("max_order", order),
                          datasets=results)
