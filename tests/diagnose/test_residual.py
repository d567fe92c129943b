"""The residual's signatures: the matched delay against exact delays."""

import numpy as np
import pytest

from truthbench.diagnose.residual import matched_delay


@pytest.mark.parametrize("tau", [0.3e-3, 1.7e-3, 12.0e-3, 40.0e-3])
def test_the_matched_delay_finds_a_delay_of_many_cycles(tau):
    """``D = M exp(-j omega tau)`` on 1-Hz lines to 1 kHz with a resonant ``M`` and
    several channels: the delay is found from no prior estimate (``tau0 = 0``) up to 40
    samples at 1 kHz (25 rad at the top line, far beyond a first-order estimate from
    zero), to a small fraction of the profile's grid step (an eighth of the top line's
    period), which the parabola through the best three samples refines."""
    f = np.arange(2.0, 1001.0)
    s = 2j * np.pi * f
    modes = np.array([55.0, 150.0, 295.0, 488.0, 729.0])
    M = np.stack([np.sum(c / (s[:, None] ** 2 + 2 * 0.01 * (2 * np.pi * modes) * s[:, None]
                                 + (2 * np.pi * modes) ** 2), axis=1)
                  for c in ([1, -1, 1, -1, 1], [1, 1, 1, 1, 1], [0.5, -1, 2, 1, -1])], axis=1)
    D = M * np.exp(-s * tau)[:, None]
    w = 1.0 / (0.02 * np.abs(D))
    freq = np.broadcast_to(f[:, None], D.shape)
    step = 1.0 / (8 * f.max())
    assert matched_delay(freq.ravel(), D.ravel(), M.ravel(), w.ravel(), 0.0) == \
        pytest.approx(tau, abs=0.05 * step)
