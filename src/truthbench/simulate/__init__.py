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

__all__ = [
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
