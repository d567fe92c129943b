"""The scan for a mode the model lacks against a least-squares fit done directly.

For one trial pole, the best complex residue of each transfer function is a linear least
squares problem; numpy's ``lstsq`` on the weighted basis gives the chi2 drop the scan
computes for every pole of a grid at once. Tests of one line spacing and an exponential
window's decay (``s = sigma + j omega``), and outputs of different powers of s."""

import types

import numpy as np
import pytest

from truthbench.diagnose.adequacy import ZETAS, scan_extra_mode


def _sensor(quantity):
    return types.SimpleNamespace(quantity=quantity)


def _problem(rng):
    tests = tuple(types.SimpleNamespace(
        freq_hz=np.linspace(0.5, 400.0, n), decay_rad_s=decay,
        sensors=(_sensor("acceleration"), _sensor("displacement"), _sensor("velocity")),
        actuators=("a", "b")) for n, decay in ((401, 0.0), (200, 3.0)))
    size = sum(t.freq_hz.size * 6 for t in tests)
    data = rng.standard_normal(size) + 1j * rng.standard_normal(size)
    problem = types.SimpleNamespace(tests=tests, weights=rng.uniform(0.5, 2.0, size),
                                    data=data)
    return problem, types.SimpleNamespace(model=np.zeros(size, complex))


def _direct_drop(problem, current, f_hz, zeta):
    """Sum over the transfer functions of the chi2 drop of the best residue (lstsq)."""
    drop, start = 0.0, 0
    powers = {"displacement": 0, "velocity": 1, "acceleration": 2}
    for t in problem.tests:
        s = 2j * np.pi * t.freq_hz + t.decay_rad_s
        w = 2 * np.pi * f_hz
        shape = (t.freq_hz.size, len(t.sensors), len(t.actuators))
        size = int(np.prod(shape))
        W = problem.weights[start:start + size].reshape(shape)
        r = (W * (problem.data - current.model)[start:start + size].reshape(shape))
        start += size
        for o, x in enumerate(t.sensors):
            b = s ** powers[x.quantity] / (s * s + 2 * zeta * w * s + w * w)
            for i in range(len(t.actuators)):
                A = (W[:, o, i] * b)[:, None]
                c, *_ = np.linalg.lstsq(A, r[:, o, i], rcond=None)
                drop += np.sum(np.abs(r[:, o, i]) ** 2) - np.sum(np.abs(r[:, o, i] - A @ c) ** 2)
    return drop


def test_the_scan_finds_the_pole_a_direct_least_squares_fit_prefers():
    rng = np.random.default_rng(20261127)
    problem, current = _problem(rng)
    grid = np.array([3.0, 57.5, 120.25, 250.0, 399.0])
    f, zeta, drop, per_out = scan_extra_mode(problem, current, grid)
    direct = {(g, z): _direct_drop(problem, current, g, z) for g in grid for z in ZETAS}
    best = max(direct, key=direct.get)
    assert (f, zeta) == best
    # round-off of sums over ~2000 values of data of unit scale
    assert drop == pytest.approx(direct[best], rel=1e-10)
    assert per_out.shape == (3,) and np.all(per_out >= 0)
