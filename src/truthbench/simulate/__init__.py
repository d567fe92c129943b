"""Time simulation of test campaigns: excitation signals, sensor noise, linear systems.

This room owns

* :mod:`~truthbench.simulate.excitation`: band-limited random, periodic chirp, sine;
* :mod:`~truthbench.simulate.noise`: white Gaussian sensor noise at a set ratio;
* :mod:`~truthbench.simulate.linear`: exact sampled (first- or zero-order hold)
  simulation of continuous LTI systems (modal fast path, numba optional) and the exact
  discretisation that nonlinear/delay time stepping can reuse.

Everything is a pure function of its arguments (randomness only via an explicit
``numpy.random.Generator``); inputs are never modified. SI units throughout.
"""

from .delay import delay_frf, delay_signal, fractional_delay_fir
from .excitation import band_limited_random, periodic_chirp, sine
from .linear import (
    LtiRecursion,
    discretize,
    numba_available,
    prepare_lti,
    simulate_lti,
    simulate_statespace,
)
from .noise import add_sensor_noise, noise_to_signal_ratio
from .nonlinear import NonlinearResult, prepare_nonlinear, simulate_nonlinear
from .nonlinear_elements import (
    AmplitudeDependentDamping,
    CoulombFriction,
    CubicStiffness,
    DeadBand,
    NonlinearElement,
)

__all__ = [
    "AmplitudeDependentDamping",
    "CoulombFriction",
    "CubicStiffness",
    "DeadBand",
    "NonlinearElement",
    "NonlinearResult",
    "delay_frf",
    "delay_signal",
    "fractional_delay_fir",
    "prepare_nonlinear",
    "simulate_nonlinear",
    "LtiRecursion",
    "add_sensor_noise",
    "band_limited_random",
    "discretize",
    "noise_to_signal_ratio",
    "numba_available",
    "periodic_chirp",
    "prepare_lti",
    "simulate_lti",
    "simulate_statespace",
    "sine",
]
