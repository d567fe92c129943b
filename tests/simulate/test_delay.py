"""Exact time delays against closed forms and an exact LTI model.

* A multisine evaluated at ``t - tau`` is the oracle for :func:`delay_signal`.
* The FRF test: a periodic band-limited input through a known LTI system started on
  its periodic steady state, the output delayed by a fractional number of samples; H1
  with the rectangular window and segments of exactly one period has no leakage and, the
  data being noise-free, equals the system's FRF at every excited line. The reference is
  the exact discrete-time equivalent of the simulation (first-order hold,
  ``C (zI - Ad)^-1 (Bd0 + z Bd1) + D`` at ``z = exp(j omega dt)``), so the phase
  difference must be ``-omega tau`` to rounding; the brief's tolerance is 1e-3 rad.

"To rounding" is a bound derived from the operations, not a number seen on one CPU:
:func:`_multisine_rounding` and :func:`_fft_delay_rounding` for the multisine oracle,
:func:`_frf_rounding` for the FRF test.
"""

from __future__ import annotations

import numpy as np
import pytest

from truthbench.measure import estimate_frf
from truthbench.simulate import band_limited_random, discretize, prepare_lti, simulate_lti
from truthbench.simulate.delay import delay_frf, delay_signal, fractional_delay_fir

FS = 1000.0
U = np.finfo(float).eps / 2  # unit roundoff


def multisine(freqs_hz, amps, phases, t):
    return np.sum(amps[:, None] * np.cos(2 * np.pi * freqs_hz[:, None] * t + phases[:, None]),
                  axis=0)


def _multisine_rounding(freqs_hz, amps, phases, t):
    """Bound of the rounding of :func:`multisine` at the times ``t`` (first order in u).

    The argument ``2 pi f t + p`` of line ``i`` takes five roundings (``2 pi``, ``* f``,
    ``* t``, ``+ p``, and ``t`` itself when it is ``t - tau``), each at most
    ``u |theta_i|``; ``cos`` adds one more ulp; summing the lines adds at most
    ``n_lines u`` times the sum of the amplitudes (Higham, eq. 4.4).
    """
    theta = np.abs(2 * np.pi * freqs_hz[:, None] * t) + np.abs(phases)[:, None]
    return U * np.sum(np.abs(amps)[:, None] * (5 * theta + 1 + freqs_hz.size), axis=0)


def _fft_delay_rounding(x, tau, n):
    """Bound of the rounding of ``delay_signal(x, tau)`` itself (FFT method), any sample.

    rfft and irfft each err by at most ``log2(n) eta ||x||_2`` in the 2-norm, with
    ``eta = u + gamma_4 (sqrt(2) + u)`` for twiddle factors correct to ``u`` (Higham,
    Accuracy and Stability of Numerical Algorithms, 2nd ed., Thm 24.2); the phase
    factors ``exp(-j 2 pi f tau)`` are correct to ``u (2 |2 pi f tau| + 1)`` each. A
    sample's error is at most the 2-norm of the error.
    """
    eta = U + 4 * U * (np.sqrt(2) + U)
    phase = U * (2 * np.pi * 0.5 * FS * abs(tau) * 2 + 1)
    return (2 * np.log2(n) * eta + phase) * np.linalg.norm(x)


def _frf_rounding(ad, z, sim_error, y_dft):
    """Relative rounding bound, per line, of the H1 estimate of the FRF test against its
    discrete-time model (first order in u).

    * The model ``C (z I - Ad)^-1 (Bd0 + z Bd1)``: LAPACK's solve is backward stable with
      ``|dM| <= 3 n u |M|`` (growth factor ~1 here), a forward error of at most
      ``3 n u cond(M)`` relative; the simulation realises ``exp(A dt)`` apart from
      ``discretize`` (modes against Van Loan), each within ``(2 n + 4) u ||Ad||``, which
      moves the model by ``||(z I - Ad)^-1|| ||dAd||`` relative. Both doubled (two sides).
    * The simulated record: its rounding ``sim_error`` (an absolute bound per sample,
      already carried through the delay) summed over a segment bounds the error of each
      DFT line, relative to ``|Y_k|``.
    """
    n = ad.shape[0]
    out = []
    for k, zk in enumerate(z):
        m = zk * np.eye(n) - ad
        resolvent = np.linalg.norm(np.linalg.inv(m), 2)
        model = 2 * (3 * n * U * np.linalg.cond(m)
                     + (2 * n + 4) * U * np.linalg.norm(ad, 2) * resolvent)
        out.append(model + sim_error / abs(y_dft[k]))
    return np.array(out)


def _random_multisine(rng, n_lines, f_max, n=None):
    if n is None:  # off-bin frequencies
        freqs = rng.uniform(1.0, f_max, n_lines)
    else:  # on the DFT lines of an n-sample record
        freqs = rng.choice(np.arange(1, int(f_max * n / FS)), n_lines, replace=False) * FS / n
    return freqs, rng.standard_normal(n_lines), rng.uniform(0, 2 * np.pi, n_lines)


@pytest.mark.parametrize("tau_samples", [0.0, 0.37, 3.0, 12.81, -5.5])
def test_fft_delay_of_a_periodic_band_limited_record_is_exact(tau_samples):
    n = 2048
    t = np.arange(n) / FS
    f, a, p = _random_multisine(np.random.default_rng(1), 25, 0.45 * FS, n)
    x = multisine(f, a, p, t)
    tau = tau_samples / FS
    out = delay_signal(x, tau, FS)
    # the oracle's own rounding at t - tau; that of x, carried by the delay (a linear
    # operator: at most its l1 gain, the sum of |kernel|); and the delay's own rounding
    gain = np.abs(delay_signal(np.eye(n)[0], tau, FS)).sum()
    bound = (_multisine_rounding(f, a, p, t - tau)
             + gain * np.max(_multisine_rounding(f, a, p, t)) + _fft_delay_rounding(x, tau, n))
    assert np.all(np.abs(out - multisine(f, a, p, t - tau)) <= bound)
    assert np.max(bound) < 1e-9 * np.abs(a).sum()  # an error of 1e-9 would show


def test_per_channel_delays_and_inputs_untouched():
    n = 1024
    t = np.arange(n) / FS
    f, a, p = _random_multisine(np.random.default_rng(2), 10, 0.3 * FS, n)
    x = np.vstack([multisine(f, a, p, t)] * 3)
    x_copy = x.copy()
    taus = np.array([0.0, 1.5e-3, -2.25e-3])
    out = delay_signal(x, taus, FS)
    assert np.array_equal(x, x_copy)
    for ch in range(3):
        assert np.allclose(out[ch], multisine(f, a, p, t - taus[ch]), atol=1e-11)


@pytest.mark.filterwarnings("ignore:The input spectral matrix Gxx is singular")
def test_delayed_output_gives_h1_phase_minus_omega_tau(rounding):
    # a lightly damped two-mode system (modes ~ 8 and 31 Hz), force in, displacement out
    m = np.diag([1.0, 0.5])
    k = np.array([[6e3, -4e3], [-4e3, 1.2e4]])
    c = 0.002 * k + 0.1 * m
    mi = np.linalg.inv(m)
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-mi @ k, -mi @ c]])
    b = np.vstack([np.zeros((2, 1)), mi[:, :1]])
    cc = np.eye(4)[[1]]
    dt, n = 1.0 / FS, 2000
    u1 = band_limited_random(n, FS, 1.0, (1.0, 100.0), np.random.default_rng(3),
                             method="random_phase")
    # the periodic steady state: x0 = (I - Ad^n)^-1 (zero-state response over one period)
    ad, bd0, bd1 = discretize(a, b, dt)
    x = np.zeros(4)
    up = np.r_[u1[0], u1[0, 0]]
    for j in range(n):
        x = ad @ x + bd0[:, 0] * up[j] + bd1[:, 0] * up[j + 1]
    x0 = np.linalg.solve(np.eye(4) - np.linalg.matrix_power(ad, n), x)
    u = np.tile(u1, 3)
    y = simulate_lti(a, b, cc, None, u, dt, x0=x0)
    # the rounding of the simulation (6 sigma of the model of conftest.py, which counts
    # two engines: a bound for one). It is periodic to that rounding, which the
    # to-rounding FRF checks below need and check.
    sim = 6 * rounding.sigma(prepare_lti(a, b, cc, None, dt), u, x0)
    tau = 3.37 * dt
    y_delayed = delay_signal(y, tau, FS)
    est = estimate_frf(u, y_delayed, FS, window="rectangular", nperseg=n)
    assert est.n_averages == 3
    f = est.freq_hz
    z = np.exp(2j * np.pi * f * dt)
    model = np.array([(cc @ np.linalg.solve(zi * np.eye(4) - ad, bd0 + zi * bd1))[0, 0]
                      for zi in z])
    lines = (f >= 1.0) & (f <= 100.0)
    h1 = est.H[lines, 0, 0]
    dphase = np.angle(h1 / model[lines])
    expected = np.angle(np.exp(-2j * np.pi * f[lines] * tau))
    phase_error = np.abs(np.angle(np.exp(1j * (dphase - expected))))
    assert np.max(phase_error) < 1e-3  # the brief's tolerance
    # to rounding: the simulation's error through the delay (l1 gain of its kernel) and
    # a segment's DFT, the model's conditioning (_frf_rounding), the delay's own rounding
    # and that of the estimate's few operations per line
    gain = np.abs(delay_signal(np.eye(n)[0], tau, FS)).sum()
    seg = max(np.sum(sim[0, s : s + n]) for s in range(0, 3 * n, n))
    y_dft = np.fft.rfft(y_delayed[0, :n])[lines]
    rel = _frf_rounding(ad, z[lines], gain * seg, y_dft)
    rel += _fft_delay_rounding(y[0, :n], tau, n) / np.abs(y_dft) + 16 * U
    assert np.all(phase_error <= rel)
    assert np.all(np.abs(np.abs(h1) / np.abs(model[lines]) - 1) <= rel)
    # and delay_frf of the model is the same thing
    assert np.all(np.abs(delay_frf(model[lines], f[lines], tau) - h1) <= rel * np.abs(h1))
    assert np.max(rel) < 1e-7  # an error of 1e-7 (relative, or rad) would show anywhere


@pytest.mark.parametrize("tau_samples", [0.0, 0.25, 0.5, 7.93, -3.4])
def test_fir_delay_of_a_non_periodic_record(tau_samples):
    n = 3000
    t = np.arange(n) / FS
    f, a, p = _random_multisine(np.random.default_rng(4), 30, 0.4 * FS)
    x = multisine(f, a, p, t)
    tau = tau_samples / FS
    out = delay_signal(x, tau, FS, method="fir")
    ref = multisine(f, a, p, t - tau)
    edge = 32 + int(np.ceil(abs(tau_samples)))
    err = np.max(np.abs(out - ref)[edge:-edge]) / np.abs(a).sum()
    assert err < 5e-8


def test_fir_error_bound_of_the_module_docstring():
    """|H(f) - exp(-j 2 pi f tau)| < 5e-8 up to 0.4 fs for fractional delays 0..1."""
    taps = 64
    f = np.linspace(0.0, 0.4, 801)
    k = np.arange(taps)
    worst = 0.0
    for mu in np.linspace(0.0, 1.0, 41):
        h = fractional_delay_fir(mu)
        resp = np.exp(-2j * np.pi * np.outer(f, k)) @ h
        ideal = np.exp(-2j * np.pi * f * (taps // 2 - 1 + mu))
        worst = max(worst, float(np.max(np.abs(resp - ideal))))
    assert worst < 5e-8


def test_delay_frf_per_output():
    rng = np.random.default_rng(5)
    h = rng.standard_normal((50, 3, 2)) + 1j * rng.standard_normal((50, 3, 2))
    f = np.linspace(0.0, 200.0, 50)
    taus = np.array([[0.0], [1e-3], [2.5e-3]])
    out = delay_frf(h, f, taus)
    assert out.shape == h.shape
    for o in range(3):
        assert np.allclose(out[:, o], h[:, o] * np.exp(-2j * np.pi * f * taus[o, 0])[:, None])
    assert np.allclose(np.abs(out), np.abs(h))


def test_bad_arguments_name_the_parameter():
    x = np.zeros((2, 64))
    with pytest.raises(ValueError, match="fs_hz must be a positive sampling frequency"):
        delay_signal(x, 0.001, 0.0)
    with pytest.raises(ValueError, match="y must be real"):
        delay_signal(x + 1j, 0.001, FS)
    with pytest.raises(ValueError, match="y must be finite"):
        delay_signal(np.full(8, np.nan), 0.001, FS)
    with pytest.raises(ValueError, match=r"delay_s of shape \(3,\) does not broadcast"):
        delay_signal(x, [0.0, 1.0, 2.0], FS)
    with pytest.raises(ValueError, match="delay_s must be finite"):
        delay_signal(x, np.inf, FS)
    with pytest.raises(ValueError, match="method must be 'fft' or 'fir'"):
        delay_signal(x, 0.001, FS, method="pade")
    with pytest.raises(ValueError, match="n_taps must be an even integer"):
        delay_signal(x, 0.001, FS, method="fir", fir_taps=33)
    with pytest.raises(ValueError, match=r"freq_hz must have shape \(4,\)"):
        delay_frf(np.ones((4, 2, 1)), np.arange(5.0), 0.001)
    with pytest.raises(ValueError, match=r"delay_s of shape \(3,\) does not broadcast"):
        delay_frf(np.ones((4, 2, 1)), np.arange(4.0), np.zeros(3))
