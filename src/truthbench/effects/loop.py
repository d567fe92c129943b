"""Control system (Table 10.1): a known compensator closed around the plant.

The loop feeds one structural output of the test (index into its sensors, before any
sensor dynamics) back to one of its inputs (index into its actuators) through
``K(s) = gain`` or, with ``bandwidth_hz > 0``, ``K(s) = gain * wc / (s + wc)``, with
negative feedback: ``u = r - K y_s``. The recorded input is the reference ``r`` (the
commanded force or torque), so the measured FRF is the closed-loop one. The time path
closes the loop with ``control.feedback``; the periodic path uses the exact closed-loop
FRF of the same interconnection.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from truthbench.effects.base import Effect, EffectParam, register_effect


@dataclass(frozen=True)
class Loop:
    """One feedback loop: output index, input index, gain, first-order bandwidth (Hz, 0 =
    static gain)."""

    output: int
    input: int
    gain: float
    bandwidth_hz: float = 0.0

    def response(self, s: np.ndarray) -> np.ndarray:
        """K(s) at complex frequencies s."""
        if self.bandwidth_hz <= 0:
            return np.full(s.shape, self.gain, dtype=complex)
        wc = 2 * np.pi * self.bandwidth_hz
        return self.gain * wc / (s + wc)

    def statespace(self, n_out: int, n_in: int):
        """The compensator as a ``control`` system from all outputs to all inputs."""
        import control

        if self.bandwidth_hz <= 0:
            K = np.zeros((n_in, n_out))
            K[self.input, self.output] = self.gain
            return control.ss(np.zeros((0, 0)), np.zeros((0, n_out)), np.zeros((n_in, 0)), K)
        wc = 2 * np.pi * self.bandwidth_hz
        B = np.zeros((1, n_out))
        B[0, self.output] = wc
        C = np.zeros((n_in, 1))
        C[self.input, 0] = self.gain
        return control.ss([[-wc]], B, C, np.zeros((n_in, n_out)))

    def close(self, H: np.ndarray, freq_hz: np.ndarray, *, decay_rad_s: float = 0.0
              ) -> np.ndarray:
        """Closed-loop FRF from the open-loop one, shape (n_freq, n_out, n_in): with
        ``g = H[:, :, input]`` the rank-one update ``H - k g H[:, output, :] /
        (1 + k g_output)`` (Sherman-Morrison for ``(I + H E k S)^-1 H``), at
        ``s = decay_rad_s + j omega``."""
        k = self.response(2j * np.pi * np.asarray(freq_hz) + decay_rad_s)
        g = H[:, :, self.input]
        row = H[:, self.output, :]
        den = 1.0 + k * g[:, self.output]
        return H - (k / den)[:, None, None] * g[:, :, None] * row[:, None, :]


@register_effect
class ClosedLoop(Effect):
    name: ClassVar[str] = "closed_loop"
    target: ClassVar[str] = "loop"
    default_scope: ClassVar[str] = "test"
    description: ClassVar[str] = ("a compensator from one output to one input, negative "
                                  "feedback (e.g. hub rate feedback to the torque motor)")
    params: ClassVar = (EffectParam("gain", 0.0, "loop gain (input unit per output unit)"),
                        EffectParam("bandwidth_hz", 0.0, "first-order roll-off, Hz (0: a "
                                    "static gain)", 0.0))
    options: ClassVar = {"output": 0, "input": 0}
    per_test_channels: ClassVar[bool] = True

    def contribute(self, values, options, setup):
        out, inp = int(options["output"]), int(options["input"])
        setup.loops.append(Loop(out, inp, values["gain"], values["bandwidth_hz"]))
