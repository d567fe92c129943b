"""Measured FRFs brought to the model: channels at nodes, lines, signs and noise.

Each :class:`~truthbench.measure.frfdata.FRFData` channel is placed on the model:

0. an entry of ``channel_map`` for its label (the model file's ``[diagnose.channels]``)
   sets its direction, sign, and station or position first: files that say neither where
   nor in which direction a channel measures (LabVIEW records) are placed this way;
1. a channel that names a station the plant has (our own files) sits there;
2. else an explicit map entry for its point number (``point_map``: point -> x along the
   beam, m) places it;
3. else its coordinates (m, in the model's frame: x along the beam from its first end,
   z vertical) go to the nearest node, which must lie within ``tolerance_m``; a point
   farther than that from every node is an error naming the point, its coordinates, the
   nearest node and the distance.

A channel's direction must be known (x, y, z, rx, ry, rz); a negative sense (UFF
``-Z``) flips the sign of its rows or columns, so the data compared with the model are
all in the positive directions. Strain channels are not placed by coordinates (a strain
gauge has no model DOF); they must name a station.

The noise of each FRF value comes from its coherence and number of averages (Bendat and
Piersol, Random Data, 9.3): the random error of an H1 estimate has, per real and
imaginary part, the standard deviation ``|H| sqrt((1 - g2) / (2 n_d g2))`` with ``g2``
the coherence and ``n_d`` the averages, for many averages. With few, two corrections of
order ``1 / n_d`` matter, both ``n_d / (n_d - 1)`` on the variance: the estimated
coherence is biased high, ``E[1 - g2_est] = (1 - g2) (n_d - 1) / n_d`` (Carter, Knapp
and Nuttall, IEEE Trans. Audio Electroacoust. 21, 1973), and the estimate has ``n_d -
1`` degrees of freedom, not ``n_d``. Without them the noise is underestimated by a
factor ``(n_d / (n_d - 1))^2`` in variance: 1.78 for 4 averages, 1.31 for 8, which the
reduced chi2 of the true model on simulated data shows (tests/diagnose/test_data.py).
Data without coherence (one impact) get weights ``1 / (|H| + m)``, ``m`` the channel
pair's median ``|H|``: relative where the response is large, absolute near antiresonances
(where an output's noise does not vanish with the response, and pure relative weights
let a few antiresonance lines pull the fit away); the diagnosis then estimates the
common noise scale from the residual.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from truthbench._validation import readonly
from truthbench.errors import DataFormatError
from truthbench.measure.frfdata import Channel, FRFData
from truthbench.plants.base import Actuator, Plant, Sensor

COHERENCE_FLOOR = 1e-4
"""Least relative noise of an FRF value: coherence is clipped at ``1 - COHERENCE_FLOOR``
(a noise-free estimate still varies by leakage from segment to segment)."""


@dataclass(frozen=True, eq=False)
class MeasuredTest:
    """One test's data on the model.

    Attributes
    ----------
    frf : FRFData
        The data as read.
    actuators, sensors : tuple of Actuator, Sensor
        Its inputs and outputs at the model's stations.
    lines : ndarray of bool, shape (n_freq,)
        The lines compared with the model.
    H : ndarray, complex, shape (n_lines, n_out, n_in)
        The data at those lines, every channel in its positive direction.
    sigma : ndarray, shape (n_lines, n_out, n_in)
        Standard deviation of the real and of the imaginary part of each value (same unit
        as ``H``), or relative weights (``noise = "relative"``).
    noise : {"coherence", "relative"}
        Where ``sigma`` came from (``"relative"``: ``|H|`` plus the channel pair's
        median ``|H|``, up to a common scale).
    """

    frf: FRFData
    actuators: tuple[Actuator, ...]
    sensors: tuple[Sensor, ...]
    lines: np.ndarray
    H: np.ndarray
    sigma: np.ndarray
    noise: str

    @property
    def name(self) -> str:
        return self.frf.name

    @property
    def freq_hz(self) -> np.ndarray:
        """The compared lines, Hz."""
        return self.frf.freq_hz[self.lines]

    @property
    def n_pairs(self) -> int:
        return len(self.actuators) * len(self.sensors)


def h1_sigma(H: np.ndarray, coherence: np.ndarray | None, n_averages: int | None
             ) -> tuple[np.ndarray, str]:
    """Standard deviation of the real (and of the imaginary) part of H1 values.

    Returns
    -------
    sigma : ndarray, H's shape
    noise : {"coherence", "relative"}
    """
    mag = np.abs(H)
    floor = 1e-12 * max(float(mag.max()), 1e-300)
    if coherence is None or n_averages is None or n_averages < 2:
        # a relative error where the response is large, an absolute one (the channel
        # pair's median level) near antiresonances, where the noise of a measurement does
        # not vanish with the response
        level = np.median(mag, axis=0, keepdims=True) if mag.shape[0] else mag
        return np.maximum(mag + level, floor), "relative"
    g2 = np.clip(coherence, COHERENCE_FLOOR, 1.0 - COHERENCE_FLOOR)
    n = float(n_averages)
    # the coherence estimate's bias and the estimate's n - 1 degrees of freedom
    few = n / (n - 1.0)
    return np.maximum(mag * few * np.sqrt((1.0 - g2) / (2.0 * n * g2)), floor), \
        "coherence"


def _xyz(v) -> str:
    return "(" + ", ".join(f"{float(x):.6g}" for x in v) + ")"


def _place(ch: Channel, plant: Plant, xyz: np.ndarray, tolerance_m: float,
           point_map: Mapping[int, float], source: str) -> tuple[str, int | None]:
    """(station, node or None) of one channel."""
    if ch.station is not None and ch.station in plant.station_fractions():
        return ch.station, None
    if ch.point is not None and ch.point in point_map:
        target = np.array([float(point_map[ch.point]), 0.0, 0.0])
        how = f"point {ch.point} mapped to x = {target[0]:g} m"
    elif ch.coordinates_m is not None:
        target = np.asarray(ch.coordinates_m, dtype=float)
        how = (f"point {ch.point} at {_xyz(target)} m" if ch.point is not None
               else f"coordinates {_xyz(target)} m")
    else:
        raise DataFormatError(
            f"{source}: channel {ch.label!r} has no station, no coordinates and no map "
            f"entry; give its point's position in the model file ([diagnose.map] "
            f"{ch.point if ch.point is not None else '<point>'} = x_m)")
    dist = np.linalg.norm(xyz - target, axis=1)
    node = int(np.argmin(dist))
    if dist[node] > tolerance_m:
        raise DataFormatError(
            f"{source}: channel {ch.label!r} ({how}) matches no node of the model within "
            f"{tolerance_m:g} m: the nearest is node {node} at {_xyz(xyz[node])} m, "
            f"{dist[node]:.4g} m away. Check "
            f"the coordinates' frame and units, refine the mesh, or map the point")
    return f"n{node}", node


def map_channels(data: Sequence[FRFData], channel_map: Mapping[str, Mapping]
                 ) -> tuple[FRFData, ...]:
    """The data with the channels named in ``channel_map`` placed as it says.

    Parameters
    ----------
    data : sequence of FRFData
    channel_map : mapping of str -> mapping
        Channel label -> any of ``direction`` (x, y, z, rx, ry, rz), ``sign`` (1 or -1),
        ``x_m`` (position along the beam from its first end, m) and ``station`` (a
        station of the model).

    Raises
    ------
    DataFormatError
        A label that is no channel of the data, or an entry with unknown keys.
    """
    labels = {c.label for d in data for c in (*d.outputs, *d.inputs)}
    unknown = sorted(set(channel_map) - labels)
    if unknown:
        raise DataFormatError(f"channel map: {unknown} are no channel of the data; its "
                              f"channels are {sorted(labels)}")
    keys = {"direction", "sign", "x_m", "station"}
    for label, entry in channel_map.items():
        bad = sorted(set(entry) - keys)
        if bad:
            raise DataFormatError(f"channel map entry {label!r}: unknown keys {bad}; "
                                  f"expected some of {sorted(keys)}")

    def one(ch: Channel) -> Channel:
        e = channel_map.get(ch.label)
        if e is None:
            return ch
        return replace(ch, direction=e.get("direction", ch.direction),
                       sign=int(e.get("sign", ch.sign)),
                       coordinates_m=(float(e["x_m"]), 0.0, 0.0) if "x_m" in e
                       else ch.coordinates_m,
                       station=e.get("station", ch.station),
                       point=None if "x_m" in e or "station" in e else ch.point)

    return tuple(replace(d, outputs=tuple(map(one, d.outputs)),
                         inputs=tuple(map(one, d.inputs))) if channel_map else d
                 for d in data)


def prepare(data: Sequence[FRFData], plant: Plant, nominal: Mapping[str, float], *,
            band_hz: tuple[float, float] | None = None, tolerance_m: float = 1e-3,
            point_map: Mapping[int, float] | None = None,
            channel_map: Mapping[str, Mapping] | None = None
            ) -> tuple[Plant, tuple[MeasuredTest, ...]]:
    """Place every test's channels on the model and choose its lines.

    Parameters
    ----------
    data : sequence of FRFData
    plant : Plant
        The model's plant.
    nominal : mapping
        Nominal plant parameters (for node positions).
    band_hz : (float, float), optional
        Lines compared: inside this band and the data's own band (when known), above 0 Hz,
        finite.
    tolerance_m : float
        Largest distance of a measured point from its node, m.
    point_map : mapping of int -> float, optional
        Point number -> x along the beam, m.
    channel_map : mapping of str -> mapping, optional
        Channel label -> direction, sign, x_m or station (:func:`map_channels`).

    Returns
    -------
    plant : Plant
        The plant with a station ``n<k>`` at every node a channel was placed on.
    tests : tuple of MeasuredTest

    Raises
    ------
    DataFormatError
        A channel without direction or position, a point matching no node, no input
        channel, no line left in the band.
    """
    if not data:
        raise DataFormatError("no data to diagnose: expected at least one FRF data set")
    point_map = dict(point_map or {})
    data = map_channels(data, channel_map or {})
    xyz = plant.node_coordinates_m(plant.resolve(nominal))
    stations = dict(plant.stations)
    placed = []
    for frf in data:
        src = f"data set {frf.name!r}"
        if not frf.inputs:
            raise DataFormatError(f"{src}: no input (reference, force) channel; the "
                                  f"diagnosis compares FRFs per input")
        chans = []
        for side, channels in (("output", frf.outputs), ("input", frf.inputs)):
            out = []
            for ch in channels:
                if ch.direction is None:
                    raise DataFormatError(f"{src}: {side} channel {ch.label!r} has no "
                                          f"direction; expected x, y, z, rx, ry or rz")
                if ch.quantity == "strain" and (ch.station is None
                                                or ch.station not in plant.station_fractions()):
                    raise DataFormatError(f"{src}: strain channel {ch.label!r} must name a "
                                          f"station of the model")
                station, node = _place(ch, plant, xyz, tolerance_m, point_map, src)
                if node is not None:
                    stations[station] = node / plant.n_elements
                out.append(station)
            chans.append(out)
        placed.append(chans)
    plant = replace(plant, stations=stations)
    tests = []
    for frf, (outs, ins) in zip(data, placed, strict=True):
        sensors = tuple(Sensor(st, c.direction, c.quantity) for st, c in
                        zip(outs, frf.outputs, strict=True))
        actuators = tuple(Actuator(st, c.direction) for st, c in
                          zip(ins, frf.inputs, strict=True))
        f = frf.freq_hz
        lines = (f > 0) & np.all(np.isfinite(frf.H), axis=(1, 2))
        for band in (band_hz, frf.band_hz):
            if band is not None:
                lines &= (f >= band[0]) & (f <= band[1])
        if not lines.any():
            raise DataFormatError(
                f"data set {frf.name!r}: no line left to compare: its lines span "
                f"{f.min():g}-{f.max():g} Hz, its own band is {frf.band_hz}, the "
                f"diagnosis band {band_hz}")
        s_out = np.array([c.sign for c in frf.outputs], dtype=float)
        s_in = np.array([c.sign for c in frf.inputs], dtype=float)
        H = frf.H[lines] * s_out[None, :, None] * s_in[None, None, :]
        coh = None if frf.coherence is None else frf.coherence[lines]
        sigma, noise = h1_sigma(H, coh, frf.n_averages)
        tests.append(MeasuredTest(frf, actuators, sensors, readonly(lines), readonly(H),
                                  readonly(sigma), noise))
    return plant, tuple(tests)
