"""Time records -> H1 FRFs: impact and random tests, with their default bands.

:func:`frfs_from_time` turns sampled input (force) and output records into one
:class:`~truthbench.measure.frfdata.FRFData`. It knows nothing about files: the io room
reads a file, decides which channel is the input (:mod:`truthbench.io.time_records`) and
calls it.

A record is an *impact* test when every input is a short pulse (fewer than 2 % of the
samples above 10 % of the peak after removing the baseline) and a *random* test
otherwise (or as told by ``excitation=``):

* impact: one segment of the whole record; the force baseline (median of the samples
  after the pulse) is removed; the input gets a force window (the pulse plus as much
  again, at least 10 samples) times an exponential window, the outputs the same
  exponential window ``w[k] = decay_to ** (k / (n - 1))``. The exponential window adds
  the decay rate ``sigma_w = -ln(decay_to) fs / (n - 1)`` (1/s) to every pole (see
  :func:`truthbench.measure.get_window`); the result carries it as
  ``window_decay_rad_s`` so identification can move the poles back
  (:func:`truthbench.identify.correct_exponential_window`). The default band is where
  the force auto-spectrum lies within 10 dB of its maximum (the usual hammer-test
  rule), without the 0 Hz line. One segment: ``n_averages = 1`` and no coherence.
* random: H1 with a window (Hann by default) over ``n_averages`` non-overlapping
  segments, mean removed per segment; the default band is where the input
  auto-spectrum lies within 20 dB of its maximum. The ordinary coherence is kept.

Either way the result carries the excitation level, ``input_rms``: the RMS of each
input over the whole record about its baseline (impact) or its mean (random), so a
force transducer's offset is no excitation. With the default band it is what
amplitude-dependent effects (friction) are judged by.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from truthbench._validation import check_choice, check_number
from truthbench.errors import DataFormatError
from truthbench.measure.frfdata import Channel, FRFData

__all__ = ["EXCITATION_RULES", "find_pulse", "frfs_from_time"]

EXCITATION_RULES = ("auto", "impact", "random")
"""What :func:`frfs_from_time` may be told about the excitation."""

#: Force-spectrum level (dB below its maximum) that bounds the default band.
IMPACT_BAND_DB = 10.0
RANDOM_BAND_DB = 20.0


def find_pulse(x) -> tuple[int, int, float] | None:
    """Locate an impact pulse in one force record.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Force, any unit.

    Returns
    -------
    (first, last, baseline) or None
        Sample indices of the first and last sample above 5 % of the peak (after
        removing the median) and the baseline (median of the samples after the pulse,
        or of the whole record when fewer than 10 samples follow); None when more than
        2 % of the samples exceed 10 % of the peak (not a short pulse) or the record is
        constant.
    """
    x = np.asarray(x, dtype=float)
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


def _band_from_autospectrum(f: np.ndarray, gxx: np.ndarray, db: float) -> tuple[float, float]:
    """Lowest and highest positive line where ``gxx`` is within ``db`` of its maximum."""
    pos = f > 0
    level = gxx[pos].max() * 10 ** (-db / 10)
    ok = np.flatnonzero(pos & (gxx >= level))
    return float(f[ok[0]]), float(f[ok[-1]])


def _rms(x: np.ndarray) -> tuple[float, ...]:
    """RMS of each row of ``x`` (n_rows, n_samples) over its samples."""
    return tuple(float(v) for v in np.sqrt(np.mean(x**2, axis=1)))


def _channels(side: str, given, n: int, kind: str, where: str) -> tuple[Channel, ...]:
    prefix = "out" if side == "output" else "in"
    if given is None:
        return tuple(Channel(f"{prefix}{k}", kind) for k in range(n))
    given = tuple(given)
    if len(given) != n:
        raise ValueError(f"{where}: expected {n} {side} channel(s) (one per {side} record); "
                         f"got {len(given)}")
    out = tuple(c if isinstance(c, Channel) else Channel(str(c), kind) for c in given)
    if side == "input":
        bad = [c.label for c in out if c.quantity != "force"]
        if bad:
            raise ValueError(f"{where}: input channel(s) {bad} do not measure a force; "
                             f"expected force inputs (an FRF is response per force)")
    return out


def frfs_from_time(
    x,
    y,
    fs_hz: float,
    *,
    outputs: Sequence[Channel | str] | None = None,
    inputs: Sequence[Channel | str] | None = None,
    output_quantity: str = "acceleration",
    name: str = "time record",
    source: str = "",
    excitation: str = "auto",
    decay_to: float = 0.01,
    force_width: int | None = None,
    n_averages: int = 8,
    window: str = "hann",
) -> FRFData:
    """H1 FRFs from input and output time histories (impact or random test).

    Parameters
    ----------
    x : array_like, shape (n_in, n_samples) or (n_samples,)
        Input (force) records, N (N m for a moment).
    y : array_like, shape (n_out, n_samples) or (n_samples,)
        Response records in SI units (m/s^2, m/s, m, ...).
    fs_hz : float
        Sampling frequency, Hz.
    outputs, inputs : sequence of Channel or str, optional
        What each output row / input row is. A string is a label: the channel gets
        ``output_quantity`` (outputs) or ``"force"`` (inputs). Default labels ``out0``,
        ``in0``, ...
    output_quantity : str
        Quantity of outputs given as labels (a key of
        :data:`truthbench.quantities.QUANTITIES`).
    name : str
        Name of the resulting :class:`FRFData`.
    source : str
        Where the records come from (a file), for error messages; default ``name``.
    excitation : {"auto", "impact", "random"}
        ``"auto"``: impact if every input is a short pulse (see the module notes).
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
        ``H`` (n_freq, n_out, n_in) with ``freq_hz`` from 0 to ``fs_hz / 2``;
        ``band_hz`` from the input auto-spectrum (10 dB rule for impact, 20 dB for
        random); for impact ``window_decay_rad_s = -ln(decay_to) fs / (n - 1)`` and
        ``n_averages = 1``; for random the coherence and ``n_averages``; ``input_rms``
        (n_in,) the RMS of each input over the record about its baseline (impact) or mean
        (random), in the input's unit (N).

    Raises
    ------
    DataFormatError
        Records of different lengths, an impact test with several inputs, or
        ``excitation="impact"`` when an input holds no pulse.
    ValueError
        Unknown ``excitation``, bad window parameters, channels that do not fit.
    """
    from truthbench.measure import estimate_frf, get_window

    where = source or name
    check_choice("excitation", excitation, EXCITATION_RULES, where=where)
    fs_hz = check_number("fs_hz", fs_hz, low=0, low_open=True, where=where)
    x = np.atleast_2d(np.asarray(x, float))
    y = np.atleast_2d(np.asarray(y, float))
    if x.shape[1] != y.shape[1]:
        raise DataFormatError(
            f"{where}: input and output records differ in length ({x.shape[1]} and "
            f"{y.shape[1]} samples); expected equal lengths"
        )
    n = x.shape[1]
    ins = _channels("input", inputs, x.shape[0], "force", where)
    outs = _channels("output", outputs, y.shape[0], output_quantity, where)
    labels_in = tuple(c.label for c in ins)
    pulses = [find_pulse(row) for row in x]
    impact = all(p is not None for p in pulses) if excitation == "auto" else (
        excitation == "impact")
    if impact:
        if x.shape[0] != 1:
            raise DataFormatError(
                f"{where}: impact test with {x.shape[0]} force channels {labels_in}; "
                f"expected one hammer (an H1 from one record needs one input)"
            )
        if pulses[0] is None:
            raise DataFormatError(
                f"{where}: excitation='impact' but input {labels_in[0]!r} holds no short "
                f"pulse (more than 2 % of the samples above 10 % of the peak)"
            )
        first, last, base = pulses[0]
        width = force_width if force_width is not None else min(
            n, last + 1 + max(10, last - first + 1))
        w_exp = get_window("exponential", n, decay_to=decay_to)
        w_in = w_exp * get_window("force", n, force_width=width)
        est = estimate_frf(x - base, y, fs_hz, window=w_exp, input_window=w_in, nperseg=n)
        sigma_w = -math.log(decay_to) * fs_hz / (n - 1)
        gxx = np.abs(np.fft.rfft((x[0] - base) * w_in)) ** 2
        band = _band_from_autospectrum(est.freq_hz, gxx, IMPACT_BAND_DB)
        notes = (
            f"impact: one segment of {n} samples (df {est.df_hz:.4g} Hz)",
            f"force baseline {base:.4g} removed; force window {width} samples "
            f"(pulse at samples {first}-{last})",
            f"exponential window to {decay_to:g}: sigma_w {sigma_w:.4g} 1/s removed from "
            f"the identified poles",
            f"default band: force spectrum within {IMPACT_BAND_DB:g} dB of its maximum, "
            f"{band[0]:.4g}-{band[1]:.4g} Hz",
        )
        return FRFData(name=name, freq_hz=est.freq_hz, H=est.H, outputs=outs, inputs=ins,
                       n_averages=1, band_hz=band, excitation="impact",
                       window_decay_rad_s=sigma_w, notes=notes, input_rms=_rms(x - base))
    n_avg = check_number("n_averages", n_averages, low=1, integer=True, where=where)
    nper = n // n_avg
    est = estimate_frf(x, y, fs_hz, window=window, nperseg=nper, n_averages=n_avg,
                       detrend="constant")
    seg = x[:, : nper * n_avg].reshape(x.shape[0], n_avg, nper)
    w = get_window(window, nper)
    seg = (seg - seg.mean(axis=-1, keepdims=True)) * w
    gxx = (np.abs(np.fft.rfft(seg, axis=-1)) ** 2).mean(axis=(0, 1))
    band = _band_from_autospectrum(est.freq_hz, gxx, RANDOM_BAND_DB)
    notes = (
        f"random: H1, {window} window, {est.n_averages} segments of {nper} samples "
        f"(df {est.df_hz:.4g} Hz)",
        f"default band: input spectrum within {RANDOM_BAND_DB:g} dB of its maximum, "
        f"{band[0]:.4g}-{band[1]:.4g} Hz",
    )
    return FRFData(name=name, freq_hz=est.freq_hz, H=est.H, outputs=outs, inputs=ins,
                   coherence=est.coherence, n_averages=est.n_averages, band_hz=band,
                   excitation="random", notes=notes,
                   input_rms=_rms(x - x.mean(axis=1, keepdims=True)))
