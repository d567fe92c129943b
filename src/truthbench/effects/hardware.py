"""The hardware: a plant with its realised effects and instrumentation, as FRFs and time.

A :class:`Hardware` is what a test runs on: the plant (mesh, element physics), its
parameters, the structural additions the effects made (joints, masses, dashpots, sag),
the appended dynamics (actuator and sensor filters, a delay), the measurement chain
(gain, offset, noise, unmeasured disturbances), nonlinear elements and closed loops, and
the test's actuators and sensors. It answers two questions, exactly:

* :meth:`Hardware.frf`: the FRF from the recorded inputs (commanded forces) to the
  recorded outputs, ``G(s) = g * D(s) * F_out(s) * [H_cl(s)] * F_in(s)`` with the
  structure's FRF ``H`` (modal superposition, complex modes when the damping is not
  proportional), the loops closed around it, actuator dynamics ``F_in`` per input,
  sensor dynamics ``F_out`` per output, the delay ``D = exp(-s tau)`` and the gain
  ``g``. Nonlinear elements are left out: the FRF is that of the linear part.
* :meth:`Hardware.simulate`: recorded outputs for a recorded periodic input, either its
  exact periodic steady state line by line (linear hardware) or exact first-order-hold
  time stepping at an oversampled rate (always for nonlinear hardware), then gain,
  offset and sensor noise.

Nothing here knows about campaigns, trials or test indices: :func:`realise` builds the
hardware from a plant, parameters and effects with chosen values.

Simulation detail. The recorded force is taken as the samples of a periodic,
band-limited force (its DFT interpolation). ``method = "periodic"`` gives the response's
exact periodic steady state, ``Y_k = G(j omega_k) U_k`` at every DFT line: no hold error
and no transient. ``method = "time"`` drives the structure at ``oversample`` times the
rate through an exact first-order-hold simulation; a piecewise-linear force has the
baseband spectrum of its samples times ``sinc^2(f / fs_fine)``, so the drive is
pre-emphasised by the inverse of that factor to make its baseband equal the recorded
force. What remains is the images of the hold near multiples of the fine rate, which
alias back at a relative level of about ``(f / fs_fine)^2`` (2e-4 at f = fs/10 with 8
times oversampling). A warm-up of whole periods of the periodic input precedes the
record, long enough for the slowest decaying pole to fall by 1e-6 (at least
``min_warm_up`` samples, at most four records, see :func:`warm_up_samples`), so that
the start-up transient does not leak into the FRFs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from truthbench.errors import ModelError
from truthbench.fe.assembly import DIRECTIONS
from truthbench.model import StructuralModel, modal_system
from truthbench.plants.base import Actuator, Plant, Sensor, StructuralAdditions
from truthbench.simulate import add_sensor_noise, band_limited_random, simulate_lti
from truthbench.simulate.nonlinear import simulate_nonlinear
from truthbench.simulate.nonlinear_elements import NonlinearElement

SIMULATION_METHODS = ("periodic", "time")


@dataclass(frozen=True)
class Filter:
    """A continuous transfer function ``num(s) / den(s)`` (coefficients, highest power
    first) applied to one input (actuator dynamics) or output (sensor dynamics); index
    None applies it to all."""

    num: tuple[float, ...]
    den: tuple[float, ...]
    index: int | None = None

    def response(self, s: np.ndarray) -> np.ndarray:
        """``num(s) / den(s)`` at complex frequencies ``s`` (rad/s)."""
        return np.polyval(self.num, s) / np.polyval(self.den, s)


def _filter_gains(filters: Sequence[Filter], s: np.ndarray, n: int) -> np.ndarray:
    """Product of the filters per channel, shape (n, len(s)), complex."""
    out = np.ones((n, len(s)), dtype=complex)
    for flt in filters:
        rows = slice(None) if flt.index is None else slice(flt.index, flt.index + 1)
        out[rows] = out[rows] * flt.response(s)
    return out


def apply_filters(x: np.ndarray, fs_hz: float, filters: Sequence[Filter],
                  delay_s: float = 0.0) -> np.ndarray:
    """Filters (and a delay) applied to periodic records in the frequency domain: exact
    for periodic band-limited signals (the delay is a pure linear phase).

    Parameters
    ----------
    x : ndarray, shape (n_channels, n_samples)
    fs_hz : float
    filters : sequence of Filter
    delay_s : float

    Returns
    -------
    ndarray, shape (n_channels, n_samples)
        ``x`` itself when there is nothing to apply, else a new array.
    """
    if not filters and delay_s == 0.0:
        return x
    n = x.shape[1]
    s = 2j * np.pi * np.fft.rfftfreq(n, 1.0 / fs_hz)
    X = np.fft.rfft(x, axis=1)
    for flt in filters:
        rows = slice(None) if flt.index is None else slice(flt.index, flt.index + 1)
        X[rows] = X[rows] * flt.response(s)
    if delay_s:
        X = X * np.exp(-s * delay_s)
    return np.fft.irfft(X, n, axis=1)


def warm_up_samples(A: np.ndarray, minimum: int, fs_hz: float, n: int,
                    decay: float = 1e-6) -> int:
    """Samples of periodic warm-up before the record: long enough for the slowest
    decaying (non-rigid) pole of ``A`` to fall by ``decay``, at least ``minimum``, at
    most four records of ``n`` samples. Rigid-body (zero) poles do not decay and are
    left out."""
    lam = np.linalg.eigvals(A)
    rates = -lam.real[np.abs(lam) > 1e-9 * max(np.abs(lam).max(), 1e-300)]
    rates = rates[rates > 0]
    if rates.size == 0:
        return minimum
    t = np.log(1.0 / decay) / rates.min()
    return int(min(max(minimum, np.ceil(t * fs_hz / 1.0)), 4 * n))


def upsample_periodic(x: np.ndarray, factor: int) -> np.ndarray:
    """The periodic band-limited (DFT) interpolation of ``x`` at ``factor`` times the
    rate, shape (n_channels, n * factor); a Nyquist line of an even-length record is
    split between the two signs so that the result stays real and passes the samples."""
    if factor == 1:
        return x
    n = x.shape[1]
    X = np.fft.rfft(x, axis=1)
    if n % 2 == 0:
        X[:, -1] *= 0.5
    Xf = np.zeros((x.shape[0], n * factor // 2 + 1), dtype=complex)
    Xf[:, : X.shape[1]] = X
    return np.fft.irfft(Xf * factor, n * factor, axis=1)


@dataclass(frozen=True)
class Hardware:
    """A plant with its realised effects and a test's instrumentation.

    Attributes
    ----------
    plant : Plant
        The plant (its mesh and element physics may differ from a model's).
    parameters : dict
        Plant parameters, units in the names.
    actuators : tuple of Actuator
        Recorded inputs (force or moment at a station and direction).
    sensors : tuple of Sensor
        Recorded outputs.
    additions : StructuralAdditions
        Joints, lumped masses and dashpots, element stiffness loss, sag angles.
    input_filters, output_filters : tuple of Filter
        Actuator and sensor dynamics (indices into ``actuators`` / ``sensors``).
    output_terms, input_terms : tuple of (channel, direction, weight)
        Further DOFs a channel reads or drives at its own station, with weights (m/rad
        for a rotation read by a translation sensor, m for a moment from a force): a
        sensor's output row and an actuator's input column are their unit DOF plus
        these (:mod:`truthbench.effects.mounting`).
    delay_s : float
        Time delay between the recorded inputs and the recorded outputs, s.
    noise_fraction : float
        Sensor noise standard deviation over the signal's, per channel.
    bias_offset, bias_gain : float
        Recorded output = gain * output + offset (offset in the output's unit).
    disturbances : tuple of (station, direction, rms)
        Unmeasured band-limited random forces (process noise), N or N m RMS.
    nonlinear : tuple of (station, direction, law)
        Grounded nonlinear elements (laws of :mod:`truthbench.simulate.nonlinear_elements`).
    loops : tuple of Loop
        Feedback loops closed around the structure (:mod:`truthbench.effects.loop`),
        indices into ``sensors`` and ``actuators``.
    effects : dict
        Realised parameter values of every effect, by effect label (the record).
    reduced : bool
        Solve only what the channels' FRFs need (a prediction's speed-up, the same FRFs
        to round-off): the modes of the blocks of DOFs the channels are coupled to
        (:attr:`modes`), and physical dashpots of low rank added to the modal solution
        by the Woodbury identity instead of complex modes (:func:`truthbench.model.frf`).
    """

    plant: Plant
    parameters: Mapping[str, float]
    actuators: tuple[Actuator, ...] = ()
    sensors: tuple[Sensor, ...] = ()
    additions: StructuralAdditions = StructuralAdditions()
    input_filters: tuple[Filter, ...] = ()
    output_filters: tuple[Filter, ...] = ()
    output_terms: tuple[tuple[int, str, float], ...] = ()
    input_terms: tuple[tuple[int, str, float], ...] = ()
    delay_s: float = 0.0
    noise_fraction: float = 0.0
    bias_offset: float = 0.0
    bias_gain: float = 1.0
    disturbances: tuple[tuple[str, str, float], ...] = ()
    nonlinear: tuple = ()
    loops: tuple = ()
    effects: Mapping[str, Mapping] = field(default_factory=dict)
    reduced: bool = False

    def __post_init__(self):
        object.__setattr__(self, "actuators", tuple(self.actuators))
        object.__setattr__(self, "sensors", tuple(self.sensors))
        n_out, n_in = len(self.sensors), len(self.actuators)
        for loop in self.loops:
            if not (0 <= loop.output < n_out and 0 <= loop.input < n_in):
                raise ModelError(f"closed_loop: output {loop.output} / input {loop.input} "
                                 f"outside the test's {n_out} sensors / {n_in} actuators")
        for side, filters, n in (("actuator", self.input_filters, n_in),
                                 ("sensor", self.output_filters, n_out)):
            for flt in filters:
                if flt.index is not None and not 0 <= flt.index < n:
                    raise ModelError(f"{side} dynamics on channel {flt.index}: the test has "
                                     f"{n} {side}s")
        for side, terms, n in (("actuator", self.input_terms, n_in),
                               ("sensor", self.output_terms, n_out)):
            for k, direction, _ in terms:
                if not 0 <= k < n or direction not in DIRECTIONS:
                    raise ModelError(f"{side} term ({k}, {direction!r}): expected a channel "
                                     f"0..{n - 1} and a direction of {DIRECTIONS}")
        if self.loops and self.nonlinear:
            raise ModelError("a closed loop together with a nonlinear effect is not "
                             "supported yet; remove one of them")

    # ---- the structure -----------------------------------------------------------
    @property
    def disturbers(self) -> tuple[Actuator, ...]:
        """The disturbances' force inputs (after the actuators in :attr:`model`)."""
        return tuple(Actuator(st, d) for st, d, _ in self.disturbances)

    @cached_property
    def model(self) -> StructuralModel:
        """The structural model: inputs = actuators then disturbers, outputs = sensors
        (with the channels' further weighted DOFs, :attr:`output_terms` and
        :attr:`input_terms`)."""
        model = self.plant.build(self.parameters, self.actuators + self.disturbers,
                                 self.sensors, self.additions)
        if not (self.output_terms or self.input_terms):
            return model
        labels = {label: i for i, label in enumerate(model.dof_labels)}

        def dof(channel, direction):
            label = f"n{self.plant.station_node(channel.station)}.{direction}"
            if label not in labels:
                raise ModelError(f"channel {channel.label!r} reads or drives {direction!r} "
                                 f"at its station, which is clamped in {self.plant.kind}")
            return labels[label]

        B, C = model.B.copy(), model.C_out.copy()
        for k, direction, weight in self.input_terms:
            B[dof(self.actuators[k], direction), k] += weight
        for k, direction, weight in self.output_terms:
            C[k, dof(self.sensors[k], direction)] += weight
        return replace(model, B=B, C_out=C)

    @cached_property
    def modes(self):
        """The model's modes: all of them, or (:attr:`reduced`) those of the
        blocks of DOFs coupled to the channels (:func:`~truthbench.model.
        solve_block_modes`: the same FRFs between the channels, and between any DOFs of
        those blocks, at a fraction of the cost for a beam measured in one plane)."""
        if not self.reduced:
            return self.model.modes()
        from truthbench.model import solve_block_modes

        m = self.model
        dofs = np.flatnonzero(np.any(m.B != 0, axis=1) | np.any(m.C_out != 0, axis=0))
        return solve_block_modes(m.M, m.K, dofs, m.C if m.C.nnz else None)

    def with_channels(self, actuators: Sequence[Actuator], sensors: Sequence[Sensor]
                      ) -> Hardware:
        """The same hardware instrumented with other actuators and sensors (loops and
        channel-indexed filters refer to the new channels)."""
        return replace(self, actuators=tuple(actuators), sensors=tuple(sensors))

    def structural_frf(self, freq_hz, *, decay_rad_s: float = 0.0,
                       mode_tolerance: float = 0.0) -> np.ndarray:
        """FRF of the structure with its loops closed, from every force input
        (actuators, then disturbers) to every sensor, before appended dynamics and the
        measurement chain (at ``s = decay_rad_s + j omega``; ``mode_tolerance`` see
        :func:`truthbench.model.frf`).

        Returns
        -------
        ndarray, complex, shape (n_freq, n_out, n_act + n_dist)
        """
        f = np.asarray(freq_hz, dtype=float)
        H = self.model.frf(f, modes=self.modes, decay_rad_s=decay_rad_s,
                           mode_tolerance=mode_tolerance, low_rank_damping=self.reduced)
        for loop in self.loops:
            H = loop.close(H, f, decay_rad_s=decay_rad_s)
        return H

    def frf(self, freq_hz, *, decay_rad_s: float = 0.0, mode_tolerance: float = 0.0
            ) -> np.ndarray:
        """The exact FRF from the recorded inputs to the recorded outputs.

        Parameters
        ----------
        freq_hz : array_like, shape (n_freq,)
            Hz.
        decay_rad_s : float, optional
            Evaluate at ``s = decay_rad_s + j omega``: the FRF of the impulse response
            times ``exp(-decay_rad_s t)``, which is what exponentially windowed impact
            data measure (1/s).
        mode_tolerance : float, optional
            Leave out modes the channels barely see (:func:`truthbench.model.frf`).

        Returns
        -------
        ndarray, complex, shape (n_freq, n_out, n_in)
            Output unit per N (N m for a moment input).
        """
        f = np.asarray(freq_hz, dtype=float)
        H = self.structural_frf(f, decay_rad_s=decay_rad_s, mode_tolerance=mode_tolerance
                                )[:, :, : len(self.actuators)]
        out, into = self.chain_gains(f, decay_rad_s=decay_rad_s)
        if out is not None:
            H = H * out[:, :, None]
        if into is not None:
            H = H * into[:, None, :]
        return H

    def chain_gains(self, freq_hz, *, decay_rad_s: float = 0.0
                    ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """What the hardware does to the structure's FRF outside its loops: per output
        channel (output filters, the measurement gain and the delay) and per input
        channel (input filters), so that ``frf = out[:, :, None] * structural_frf *
        into[:, None, :]``.

        Returns
        -------
        out : ndarray, complex, shape (n_freq, n_out), or None
            None when it is 1 (no output filter, gain or delay).
        into : ndarray, complex, shape (n_freq, n_in), or None
            None when it is 1 (no input filter).
        """
        f = np.asarray(freq_hz, dtype=float)
        s = 2j * np.pi * f + decay_rad_s if decay_rad_s else 2j * np.pi * f
        out = into = None
        if self.input_filters:
            into = _filter_gains(self.input_filters, s, len(self.actuators)).T
        if self.output_filters:
            out = _filter_gains(self.output_filters, s, len(self.sensors)).T
        if self.bias_gain != 1.0 or self.delay_s != 0.0:
            common = (self.bias_gain * np.exp(-s * self.delay_s))[:, None]
            out = common if out is None else out * common
            if out.shape[1] != len(self.sensors):
                out = np.broadcast_to(out, (f.size, len(self.sensors)))
        return out, into

    # ---- time histories ----------------------------------------------------------
    def simulate(self, u, fs_hz: float, *, rng: np.random.Generator | None = None,
                 method: str = "periodic", oversample: int = 8, min_warm_up: int = 0,
                 band_hz: tuple[float, float] | None = None,
                 noise_fraction: float = 0.0) -> np.ndarray:
        """Recorded outputs for the recorded inputs ``u``.

        Parameters
        ----------
        u : array_like, shape (n_in, n_samples)
            Recorded inputs (commanded forces, N, or moments, N m), one period of a
            periodic signal sampled at ``fs_hz``.
        fs_hz : float
            Sampling rate, Hz.
        rng : numpy.random.Generator, optional
            Draws the disturbances and the sensor noise; needed when the hardware (or
            ``noise_fraction``) has any.
        method : {"periodic", "time"}
            Exact periodic steady state, or first-order-hold time stepping at
            ``oversample`` times the rate (see the module docstring). Nonlinear hardware
            is always time-stepped.
        oversample : int
            Internal rate factor of the time path.
        min_warm_up : int
            Least number of warm-up samples of the time path (e.g. one FRF segment).
        band_hz : (float, float), optional
            Band of the disturbances; default the band the input excites.
        noise_fraction : float
            Further sensor noise (the test's own), combined with the hardware's as
            ``hypot``.

        Returns
        -------
        y : ndarray, shape (n_out, n_samples)
            Through the structure, sensor dynamics, delay, gain and offset, then noise.
        """
        if method not in SIMULATION_METHODS:
            raise ValueError(f"method must be one of {SIMULATION_METHODS}; got {method!r}")
        u = np.atleast_2d(np.asarray(u, dtype=float))
        n_act = len(self.actuators)
        if u.shape[0] != n_act:
            raise ValueError(f"u has {u.shape[0]} rows; the hardware has {n_act} actuators")
        noise = float(np.hypot(noise_fraction, self.noise_fraction))
        if rng is None and (self.disturbances or noise > 0):
            raise ValueError("simulate needs 'rng' for this hardware's disturbances and "
                             "sensor noise; got None")
        n = u.shape[1]
        periodic = method == "periodic" and not self.nonlinear
        R = 1 if periodic else int(oversample)
        fine_fs = fs_hz * R
        f = np.fft.rfftfreq(n * R, 1.0 / fine_fs)
        F = np.fft.rfft(upsample_periodic(u, R), axis=1)
        if self.input_filters:  # actuator dynamics
            F = F * _filter_gains(self.input_filters, 2j * np.pi * f, n_act)
        if self.disturbances:
            band = band_hz if band_hz is not None else _excited_band(f, F)
            rms = [r for _, _, r in self.disturbances]
            dist = band_limited_random(n * R, fine_fs, rms, tuple(band), rng,
                                       n_inputs=len(rms))
            F = np.vstack([F, np.fft.rfft(dist, axis=1)])
        if periodic:
            y_fine = self._steady_state(f, F, n)
        else:
            y_fine = self._time_steps(f, F, n, R, fine_fs, min_warm_up)
        y_fine = apply_filters(y_fine, fine_fs, self.output_filters, self.delay_s)
        y = y_fine[:, ::R]
        y = self.bias_gain * y + self.bias_offset
        if noise > 0:
            y = add_sensor_noise(y, noise, rng)
        return y

    def _steady_state(self, f, F, n):
        # excited lines (the force is band-limited; rounding leaves ~1e-16 elsewhere);
        # no static (0 Hz) force: a free body would drift away under it
        excited = np.any(np.abs(F) > 1e-12 * np.abs(F).max(), axis=0) & (f > 0)
        Y = np.zeros((len(self.sensors), len(f)), dtype=complex)
        H = self.structural_frf(f[excited])  # (n_exc, n_out, n_in)
        Y[:, excited] = np.einsum("foi,if->of", H, F[:, excited])
        return np.fft.irfft(Y, n, axis=1)

    def _time_steps(self, f, F, n, R, fine_fs, min_warm_up):
        A, B, C, D = modal_system(self.model, self.modes)
        if self.loops:
            import control

            sys_ = control.ss(A, B, C, D)
            for loop in self.loops:
                sys_ = control.feedback(sys_, loop.statespace(len(self.sensors), B.shape[1]))
            A, B, C, D = (np.asarray(m) for m in (sys_.A, sys_.B, sys_.C, sys_.D))
        drive = np.fft.irfft(F / np.sinc(f / fine_fs) ** 2, n * R, axis=1)
        warm = warm_up_samples(A, min_warm_up, fine_fs, n) * R
        reps = -(-warm // (n * R))  # whole periods of the periodic drive before the record
        drive = np.concatenate([np.tile(drive, (1, reps))[:, -warm:], drive], axis=1)
        if self.nonlinear:
            elements = self._nonlinear_elements(A.shape[0] // 2)
            return simulate_nonlinear(A, B, C, D, drive, 1.0 / fine_fs, elements).y[:, warm:]
        return simulate_lti(A, B, C, D, drive, 1.0 / fine_fs)[:, warm:]

    def _nonlinear_elements(self, m: int) -> list[NonlinearElement]:
        """The nonlinear laws as elements of the modal system (state [eta; eta'])."""
        model, modes = self.model, self.modes
        acc = np.array([q == "acceleration" for q in model.quantities])
        Cm = model.C_out @ modes.shapes
        out = []
        for station, direction, law in self.nonlinear:
            label = f"n{self.plant.station_node(station)}.{direction}"
            if label not in model.dof_labels:
                raise ModelError(f"nonlinear effect at {station}/{direction}: that DOF is "
                                 f"clamped")
            phi = modes.shapes[model.dof_labels.index(label), :m]
            out.append(NonlinearElement.modal(law, phi, np.where(acc, Cm @ phi, 0.0)))
        return out


def _excited_band(f: np.ndarray, F: np.ndarray) -> tuple[float, float]:
    on = np.flatnonzero(np.any(np.abs(F) > 1e-12 * np.abs(F).max(), axis=0) & (f > 0))
    if on.size == 0:
        raise ValueError("the input excites no line above 0 Hz; cannot place the "
                         "disturbances in its band (pass band_hz)")
    return float(f[on[0]]), float(f[on[-1]])
