"""The one FRF data type: measured (or simulated) FRFs with what each channel is.

:class:`FRFData` is what every room exchanges FRFs as: the campaign's test records, the
file readers (UFF 58, LVM, our HDF5), identification and diagnosis. A :class:`Channel`
says what one output row or input column of ``H`` is: its quantity and unit (from the
one table, :mod:`truthbench.quantities`), and, where known, the measured point (its
number in the source file, its coordinates) and the direction of the measurement.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from truthbench._validation import check_array, check_choice, check_number, readonly
from truthbench.errors import DataFormatError
from truthbench.measure.leakage import Estimator
from truthbench.presentation import Presentable, figure_axes
from truthbench.quantities import QUANTITIES, convert_outputs, quantity

DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")
"""DOF directions a channel may have (translations along and rotations about x, y, z)."""

EXCITATIONS = ("frf", "impact", "random")


@dataclass(frozen=True)
class Channel:
    """One output row or input column of an FRF matrix.

    Parameters
    ----------
    label : str
        A name unique among the channels of its side (``"mid.z.acc"``, ``"3:+Z"``).
    quantity : str
        A key of :data:`truthbench.quantities.QUANTITIES` ("acceleration", "force", ...).
    direction : str, optional
        x, y, z, rx, ry or rz, or None when unknown.
    sign : {1, -1}
        -1 when the channel measures along the negative direction (UFF ``-3`` = -Z).
    point : int, optional
        The measured point's number in the source (UFF node label), or None.
    coordinates_m : tuple of 3 float, optional
        The point's position, m, in the source's global frame, or None.
    station : str, optional
        The model station the channel sits at, when the source is one of ours.
    """

    label: str
    quantity: str
    direction: str | None = None
    sign: int = 1
    point: int | None = None
    coordinates_m: tuple[float, float, float] | None = None
    station: str | None = None

    def __post_init__(self):
        check_choice("quantity", self.quantity, QUANTITIES, where=f"channel {self.label!r}")
        if self.direction is not None:
            check_choice("direction", self.direction, DIRECTIONS,
                         where=f"channel {self.label!r}")
        check_choice("sign", self.sign, (1, -1), where=f"channel {self.label!r}")
        if self.coordinates_m is not None:
            xyz = tuple(float(v) for v in self.coordinates_m)
            if len(xyz) != 3 or not all(np.isfinite(xyz)):
                raise ValueError(f"channel {self.label!r}: 'coordinates_m' must be three "
                                 f"finite numbers; got {self.coordinates_m!r}")
            object.__setattr__(self, "coordinates_m", xyz)

    @property
    def unit(self) -> str:
        """SI unit of the channel's quantity along its direction."""
        return quantity(self.quantity).unit_for(self.direction)


def match_points(channels: Sequence[Channel], node_coordinates_m, tolerance_m: float, *,
                 where: str = "") -> np.ndarray:
    """The model node each channel's point sits at: the nearest node within a tolerance.

    Parameters
    ----------
    channels : sequence of Channel
        Each with ``coordinates_m`` (e.g. read from UFF dataset 2411).
    node_coordinates_m : array_like, shape (n_nodes, 3)
        The model's node positions, m, in the same frame as the channels' coordinates.
    tolerance_m : float
        Largest accepted distance between a point and its node, m (>= 0).
    where : str
        The file or data set the channels come from, for error messages.

    Returns
    -------
    ndarray of int, shape (n_channels,)
        Index of the nearest node (Euclidean distance) for each channel; of two nodes at
        the same distance the lower index.

    Raises
    ------
    DataFormatError
        A channel without coordinates, or whose point lies farther than ``tolerance_m``
        from every node; the message names the channel, its point number and
        coordinates, the nearest node and its distance.
    ValueError
        Node coordinates not of shape (n_nodes, 3) with n_nodes >= 1, or a negative or
        non-finite tolerance.
    """
    nodes = check_array("node_coordinates_m", node_coordinates_m, shape=(None, 3),
                        where=where or "match_points")
    if nodes.shape[0] == 0:
        raise ValueError(f"{where or 'match_points'}: 'node_coordinates_m' holds no node; "
                         f"expected at least one")
    tol = check_number("tolerance_m", tolerance_m, low=0.0, where=where or "match_points")
    prefix = f"{where}: " if where else ""
    out = np.empty(len(channels), dtype=int)
    for k, ch in enumerate(channels):
        if ch.coordinates_m is None:
            raise DataFormatError(
                f"{prefix}channel {ch.label!r} (point {ch.point}) has no coordinates; "
                f"expected every channel to carry its point's position to match it to a "
                f"model node")
        xyz = np.asarray(ch.coordinates_m)
        dist = np.sqrt(((nodes - xyz) ** 2).sum(axis=1))
        near = int(np.argmin(dist))
        if dist[near] > tol:
            raise DataFormatError(
                f"{prefix}channel {ch.label!r} at point {ch.point} "
                f"({xyz[0]:.6g}, {xyz[1]:.6g}, {xyz[2]:.6g}) m matches no model node "
                f"within {tol:.3g} m: the nearest is node {near} at "
                f"({nodes[near, 0]:.6g}, {nodes[near, 1]:.6g}, {nodes[near, 2]:.6g}) m, "
                f"{dist[near]:.3g} m away")
        out[k] = near
    return out


def channels_from_labels(labels: Sequence[str], quantities: Sequence[str]) -> tuple[Channel, ...]:
    """Channels with only a label and a quantity each."""
    return tuple(Channel(str(lab), q) for lab, q in zip(labels, quantities, strict=True))


@dataclass(frozen=True, eq=False)
class FRFData(Presentable):
    """FRFs of one test, with their channels.

    Table ``"frf"`` (:meth:`to_pandas`): one row per (line, output, input). Figure
    ``"frf"`` (:meth:`plot`): magnitude, phase and coherence.

    Attributes
    ----------
    name : str
        The test (``"shaker_end"``, ``"trial 0 / shaker_end"``, a file stem, ...).
    freq_hz : ndarray, shape (n_freq,)
        Frequency lines, Hz, increasing.
    H : ndarray, complex, shape (n_freq, n_out, n_in)
        Output unit per input unit (``outputs[i].unit`` / ``inputs[j].unit``).
    outputs, inputs : tuple of Channel
        One per row / column of ``H``.
    coherence : ndarray, shape (n_freq, n_out, n_in), optional
        Ordinary coherence in [0, 1], or None when the source has none.
    n_averages : int, optional
        Segments averaged in the estimate (the H1 variance scales with 1 / n_averages),
        or None when unknown; the estimator's ``averages`` when it has them (given both,
        they must agree).
    band_hz : (float, float), optional
        The usable band known from the source (excited band, force-spectrum rule), Hz.
    excitation : {"frf", "impact", "random"}
        ``"frf"`` when the source held FRFs; else how time records were processed.
    window_decay_rad_s : float
        Decay rate (1/s) an exponential window added to every pole; 0 if none.
    estimator : Estimator, optional
        How the averaged estimate was made (window, segment, averages, rate, overlap),
        when known: a model is compared with the data through it
        (:mod:`truthbench.measure.leakage`). Its ``averages`` and ``n_averages`` are one
        number: a missing one is filled from the other.
    input_rms : tuple of float, optional
        The RMS of each input over the record (N or N m), when known: the excitation
        level, which amplitude-dependent effects (friction) depend on.
    notes : tuple of str
        What was done to the data (windows, segments, conversions).

    Arrays are read-only copies; the object is immutable.
    """

    TABLES = ("frf",)
    PLOTS = ("frf",)

    name: str
    freq_hz: np.ndarray
    H: np.ndarray
    outputs: tuple[Channel, ...]
    inputs: tuple[Channel, ...]
    coherence: np.ndarray | None = None
    n_averages: int | None = None
    band_hz: tuple[float, float] | None = None
    excitation: str = "frf"
    window_decay_rad_s: float = 0.0
    notes: tuple[str, ...] = field(default_factory=tuple)
    estimator: Estimator | None = None
    input_rms: tuple[float, ...] | None = None

    def __post_init__(self):
        where = f"FRFData {self.name!r}"
        f = readonly(self.freq_hz, float)
        H = readonly(self.H, complex)
        if f.ndim != 1 or H.ndim != 3 or H.shape[0] != f.size:
            raise ValueError(f"{where}: expected freq_hz (n_freq,) and H (n_freq, n_out, "
                             f"n_in); got {f.shape} and {H.shape}")
        outputs, inputs = tuple(self.outputs), tuple(self.inputs)
        if len(outputs) != H.shape[1] or len(inputs) != H.shape[2]:
            raise ValueError(f"{where}: expected {H.shape[1]} output and {H.shape[2]} input "
                             f"channels; got {len(outputs)} and {len(inputs)}")
        for side, chans in (("output", outputs), ("input", inputs)):
            bad = [c for c in chans if not isinstance(c, Channel)]
            if bad:
                raise ValueError(f"{where}: {side}s must be Channel objects; got "
                                 f"{type(bad[0]).__name__}")
            labels = [c.label for c in chans]
            dup = sorted({x for x in labels if labels.count(x) > 1})
            if dup:
                raise ValueError(f"{where}: {side} labels must be unique; {dup} repeat")
        if any(quantity(c.quantity).power is None for c in outputs):
            raise ValueError(f"{where}: an output channel measures a force; outputs are "
                             f"responses")
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "H", H)
        object.__setattr__(self, "outputs", outputs)
        object.__setattr__(self, "inputs", inputs)
        if self.coherence is not None:
            g = readonly(self.coherence, float)
            if g.shape != H.shape:
                raise ValueError(f"{where}: coherence must have H's shape {H.shape}; got "
                                 f"{g.shape}")
            object.__setattr__(self, "coherence", g)
        if self.n_averages is not None:
            n = int(self.n_averages)
            if n != self.n_averages or n < 1:
                raise ValueError(f"{where}: 'n_averages' must be a positive integer; got "
                                 f"{self.n_averages!r}")
            object.__setattr__(self, "n_averages", n)
        if self.estimator is not None:
            if not isinstance(self.estimator, Estimator):
                raise ValueError(f"{where}: 'estimator' must be an Estimator; got "
                                 f"{type(self.estimator).__name__}")
            known = self.estimator.averages
            if known is None and self.n_averages is not None:
                object.__setattr__(self, "estimator",
                                   replace(self.estimator, averages=self.n_averages))
            elif self.n_averages is None:
                object.__setattr__(self, "n_averages", known)
            elif known != self.n_averages:
                raise ValueError(f"{where}: 'n_averages' ({self.n_averages}) and the "
                                 f"estimator's averages ({known}) must agree")
        check_choice("excitation", self.excitation, EXCITATIONS, where=where)
        if self.input_rms is not None:
            rms = tuple(float(v) for v in self.input_rms)
            if len(rms) != len(inputs) or not all(np.isfinite(rms)):
                raise ValueError(f"{where}: input_rms must hold one finite value per input "
                                 f"({len(inputs)}); got {self.input_rms!r}")
            object.__setattr__(self, "input_rms", rms)
        object.__setattr__(self, "notes", tuple(self.notes))
        if self.band_hz is not None:
            lo, hi = (float(v) for v in self.band_hz)
            if not lo < hi:
                raise ValueError(f"{where}: band_hz must be (low, high) with low < high; got "
                                 f"{self.band_hz!r}")
            object.__setattr__(self, "band_hz", (lo, hi))

    # -- views -----------------------------------------------------------------------
    @property
    def n_freq(self) -> int:
        return self.H.shape[0]

    @property
    def output_labels(self) -> tuple[str, ...]:
        return tuple(c.label for c in self.outputs)

    @property
    def input_labels(self) -> tuple[str, ...]:
        return tuple(c.label for c in self.inputs)

    @property
    def output_quantities(self) -> tuple[str, ...]:
        return tuple(c.quantity for c in self.outputs)

    @property
    def frf_type(self) -> str:
        """The outputs' common quantity ("acceleration", ...), or "mixed"."""
        kinds = set(self.output_quantities)
        return kinds.pop() if len(kinds) == 1 else "mixed"

    def lines(self, mask) -> FRFData:
        """The same data at the lines where ``mask`` (n_freq,) is true."""
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != self.freq_hz.shape:
            raise ValueError(f"FRFData {self.name!r}: mask must have shape "
                             f"{self.freq_hz.shape}; got {mask.shape}")
        return replace(self, freq_hz=self.freq_hz[mask], H=self.H[mask],
                       coherence=None if self.coherence is None else self.coherence[mask])

    def as_quantity(self, target: str) -> FRFData:
        """Every output brought to one response quantity: row i times ``(j omega)^(p_target
        - p_i)`` (:func:`~truthbench.quantities.convert_outputs`). Strain rows count as
        displacement-type (power 0) and are relabelled too. The 0 Hz line is dropped
        when a row is divided by j omega."""
        kinds = self.output_quantities
        if set(kinds) <= {target}:
            return self
        p = quantity(target).power
        data = (self.lines(self.freq_hz > 0) if any(quantity(k).power > p for k in kinds)
                else self)
        H = convert_outputs(data.freq_hz, data.H, kinds, target)
        return replace(data, H=H, outputs=tuple(replace(c, quantity=target)
                                                for c in data.outputs),
                       notes=data.notes + (f"outputs converted to {target} (times "
                                           f"(j omega)^k)",))

    def _table_frf(self):
        """Long table: one row per (line, output, input) with magnitude, phase and
        coherence: columns freq_hz, output, input, real, imag, magnitude, phase_rad,
        coherence (NaN when the data carry none), unit."""
        import pandas as pd

        n_f, n_o, n_i = self.H.shape
        fi, oi, ii = np.meshgrid(np.arange(n_f), np.arange(n_o), np.arange(n_i),
                                 indexing="ij")
        h = self.H.ravel()
        coh = (self.coherence.ravel() if self.coherence is not None
               else np.full(h.size, np.nan))
        units = [f"{o.unit}/{i.unit}" for o in self.outputs for i in self.inputs]
        return pd.DataFrame({
            "freq_hz": self.freq_hz[fi.ravel()],
            "output": np.array(self.output_labels, dtype=object)[oi.ravel()],
            "input": np.array(self.input_labels, dtype=object)[ii.ravel()],
            "real": h.real, "imag": h.imag, "magnitude": np.abs(h),
            "phase_rad": np.angle(h), "coherence": coh,
            "unit": np.array(units, dtype=object)[(oi * n_i + ii).ravel()],
        })

    def _plot_frf(self, ax, *, inputs: Sequence[int] | None = None,
                  outputs: Sequence[int] | None = None):
        """Magnitude (log), phase and, when present, coherence against frequency; options
        ``inputs``, ``outputs``: the columns and rows drawn (default all)."""
        units = sorted({f"{o.unit}/{i.unit}" for o in self.outputs for i in self.inputs})
        return plot_frf(self.freq_hz, self.H, self.coherence, self.output_labels,
                        self.input_labels, ", ".join(units), self.name, ax,
                        inputs=inputs, outputs=outputs)


def plot_frf(freq_hz, H, coherence, output_labels, input_labels, unit: str, title: str,
             ax=None, *, inputs: Sequence[int] | None = None,
             outputs: Sequence[int] | None = None):
    """Magnitude (log), phase (degrees) and, when ``coherence`` is given, coherence of
    FRFs ``H`` (n_freq, n_out, n_in) against ``freq_hz`` (Hz), one line per (output,
    input) of ``outputs`` x ``inputs`` (default all), on 2 or 3 stacked axes (``ax``: the
    caller's, or a new figure).

    Returns
    -------
    matplotlib.figure.Figure
    """
    rows = 3 if coherence is not None else 2
    fig, ax = figure_axes(ax, rows, sharex=True, figsize=(7, 2.2 * rows + 1))
    for i in (range(H.shape[2]) if inputs is None else inputs):
        for o in (range(H.shape[1]) if outputs is None else outputs):
            ax[0].semilogy(freq_hz, np.abs(H[:, o, i]),
                           label=f"{output_labels[o]} / {input_labels[i]}")
            ax[1].plot(freq_hz, np.degrees(np.angle(H[:, o, i])))
            if rows == 3:
                ax[2].plot(freq_hz, coherence[:, o, i])
    ax[0].set_ylabel(f"|H| [{unit}]")
    ax[1].set_ylabel("phase [deg]")
    if rows == 3:
        ax[2].set_ylabel("coherence [-]")
        ax[2].set_ylim(0, 1.05)
    ax[rows - 1].set_xlabel("frequency [Hz]")
    ax[0].set_title(title)
    ax[0].legend(fontsize="small")
    fig.tight_layout()
    return fig
