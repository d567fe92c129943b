"""FRF estimators against scipy.signal.csd, scipy.signal.freqz and textbook identities."""

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from truthbench.measure import (
    ESTIMATORS,
    FRFEstimate,
    estimate_frf,
    frf_from_spectra,
    h1,
    h2,
    hv,
    spectral_matrices,
)

FS = 1000.0


# ------------------------------------------------------------------ helpers


def _mode_denominator(fn_hz, zeta, fs=FS):
    """Denominator of a discrete 2nd-order resonance (impulse invariant poles)."""
    wn = 2 * np.pi * fn_hz
    pole = np.exp((-zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)) / fs)
    return np.poly([pole, pole.conj()]).real


def _two_mode_iir():
    """A parallel two-mode IIR (80 Hz and 230 Hz, 2 % damping) like a structural FRF."""
    a1, a2 = _mode_denominator(80.0, 0.02), _mode_denominator(230.0, 0.02)
    b = 1e-2 * np.polyadd(a2, 0.5 * a1)
    return b, np.polymul(a1, a2)


def _filtered(b, a, x, settle=5000):
    """Steady-state response: filter `settle` extra leading samples, then drop them."""
    return scipy.signal.lfilter(b, a, x)[..., settle:]


def _csd(a, b, **kw):
    return scipy.signal.csd(a, b, fs=FS, scaling="density", detrend=False, **kw)[1]


def _csd_matrices(x, y, **kw):
    """Textbook spectral matrices from scipy.signal.csd, index order (f, row, column).

    scipy: csd(a, b) = E[conj(A) B].  Gxx[i, j] = E[X_i X_j*] = csd(x_j, x_i);
    Gyx[o, i] = E[Y_o X_i*] = csd(x_i, y_o);  Gxy[i, o] = csd(y_o, x_i).
    """
    n_in, n_out = x.shape[0], y.shape[0]
    gxx = np.array([[_csd(x[j], x[i], **kw) for j in range(n_in)] for i in range(n_in)])
    gyx = np.array([[_csd(x[i], y[o], **kw) for i in range(n_in)] for o in range(n_out)])
    gxy = np.array([[_csd(y[o], x[i], **kw) for o in range(n_out)] for i in range(n_in)])
    gyy = np.array([[_csd(y[p], y[o], **kw) for p in range(n_out)] for o in range(n_out)])
    return tuple(np.moveaxis(g, -1, 0) for g in (gxx, gyx, gxy, gyy))


def _reference_frf(estimator, x, y, **kw):
    """Reference H1/H2/Hv, one frequency at a time, with explicit (pseudo-)inverses."""
    gxx, gyx, gxy, gyy = _csd_matrices(x, y, **kw)
    n_freq, n_out, n_in = gyx.shape
    h = np.empty((n_freq, n_out, n_in), dtype=complex)
    for k in range(n_freq):
        if estimator == "H1":
            h[k] = gyx[k] @ np.linalg.inv(gxx[k])
        elif estimator == "H2" and n_in == 1:
            h[k] = (np.diag(gyy[k]) / gxy[k][0])[:, np.newaxis]
        elif estimator == "H2":
            h[k] = gyy[k] @ np.linalg.pinv(gxy[k])
        elif estimator == "Hv" and n_in == 1:
            # Shin & Hammond (2008) eq. 9.67, with their Gyx = E[Y* X] = csd(y, x)
            pxx, pyy = gxx[k, 0, 0].real, np.diag(gyy[k]).real
            pxy, pyx = gyx[k, :, 0], gxy[k, 0, :]
            h[k, :, 0] = (pyy - pxx + np.sqrt((pxx - pyy) ** 2 + 4 * np.abs(pxy) ** 2)) / (2 * pyx)
        else:  # Hv, several inputs: smallest eigenvector of the augmented matrix per output
            for o in range(n_out):
                c = np.block(
                    [
                        [gxx[k], gxy[k][:, o : o + 1]],
                        [gyx[k][o : o + 1, :], gyy[k][o : o + 1, o : o + 1]],
                    ]
                )
                _, v = scipy.linalg.eigh(c)
                u = v[:, 0]
                h[k, o, :] = -np.conj(u[:n_in] / u[n_in])
    return h


def _noisy_system(rng, n_in, n_out, n=20_000):
    """Random correlated inputs through FIR paths plus output and input noise."""
    w = rng.standard_normal((n_in, n + 200))
    x = w.copy()
    x[1:] += 0.7 * w[:1]
    y = np.zeros((n_out, n + 200))
    for o in range(n_out):
        for i in range(n_in):
            y[o] += scipy.signal.lfilter(rng.standard_normal(4), [1.0, -0.3], x[i])
    x = x[:, 200:] + 0.2 * rng.standard_normal((n_in, n))
    y = y[:, 200:] + 0.3 * rng.standard_normal((n_out, n))
    return x, y


def _assert_rel(actual, desired, rel):
    actual, desired = np.asarray(actual), np.asarray(desired)
    assert actual.shape == desired.shape
    err = np.max(np.abs(actual - desired)) / np.max(np.abs(desired))
    assert err <= rel, f"relative error {err:.3g} > {rel:g}"


# ------------------------------------------------------------------ equal to scipy.signal.csd


@pytest.mark.parametrize("estimator", ["H1", "H2", "Hv"])
@pytest.mark.parametrize(("n_in", "n_out"), [(1, 1), (1, 3), (2, 2), (2, 3)])
def test_estimators_equal_csd_reference(rng, estimator, n_in, n_out):
    x, y = _noisy_system(rng, n_in, n_out)
    kw = dict(window="hann", nperseg=512, noverlap=256)
    est = estimate_frf(x, y, FS, estimator=estimator, **kw)
    ref = _reference_frf(estimator, x, y, **kw)
    # elementwise relative error 1e-10 (the references use explicit inverses)
    np.testing.assert_allclose(est.H, ref, rtol=1e-10, atol=0)
    assert est.estimator == estimator


def test_ordinary_coherence_equals_scipy_coherence(rng):
    x, y = _noisy_system(rng, 2, 2)
    est = h1(x, y, FS, window="hamming", nperseg=400, noverlap=100)
    for o in range(2):
        for i in range(2):
            _, ref = scipy.signal.coherence(
                x[i], y[o], fs=FS, window="hamming", nperseg=400, noverlap=100, detrend=False
            )
            np.testing.assert_allclose(est.coherence[:, o, i], ref, rtol=1e-10, atol=1e-13)


def test_multiple_coherence_equals_bendat_piersol_inverse_formula(rng):
    # Bendat & Piersol (2010) eq. 7.35: gamma^2_{y:x} = 1 - 1 / (Gyy * [G^-1]_yy), G the
    # spectral matrix of (x_1 .. x_q, y)
    x, y = _noisy_system(rng, 2, 3)
    kw = dict(window="hann", nperseg=256, noverlap=0)
    est = h1(x, y, FS, **kw)
    gxx, gyx, gxy, gyy = _csd_matrices(x, y, **kw)
    for o in range(3):
        for k in range(0, est.n_freq, 17):
            g = np.block(
                [
                    [gxx[k], gxy[k][:, o : o + 1]],
                    [gyx[k][o : o + 1, :], gyy[k][o : o + 1, o : o + 1]],
                ]
            )
            ref = 1 - 1 / (gyy[k, o, o].real * np.linalg.inv(g)[-1, -1].real)
            assert est.multiple_coherence[k, o] == pytest.approx(ref, rel=1e-9, abs=1e-12)


def test_single_input_multiple_coherence_is_ordinary_coherence(rng):
    x, y = _noisy_system(rng, 1, 2)
    est = h1(x, y, FS, nperseg=500)
    np.testing.assert_allclose(est.multiple_coherence, est.coherence[:, :, 0], rtol=1e-10)


# ------------------------------------------------------------------ against exact FRFs


def test_h1_phase_sign_pure_delay(rng):
    # y[n] = x[n - 3]  =>  H = exp(-j 2 pi f 3 / fs).  pyFRF issue 14 had the conjugate.
    x = rng.standard_normal(50_003)
    y = _filtered([0, 0, 0, 1.0], [1.0], x, settle=3)
    x = x[3:]
    est = h1(x, y, FS, window="hann", n_averages=25)
    f = est.freq_hz
    exact = np.exp(-2j * np.pi * f * 3 / FS)
    assert np.max(np.abs(est.H[:, 0, 0] - exact)) < 0.01
    # unambiguous direction: the phase decreases with frequency at 1 to 49 lines
    phase = np.unwrap(np.angle(est.H[1:50, 0, 0]))
    np.testing.assert_allclose(phase, -2 * np.pi * f[1:50] * 3 / FS, atol=0.01)


@pytest.mark.parametrize("window", ["hann", "bartlett"])
def test_h1_matches_freqz_of_iir_away_from_resonances(rng, window):
    b, a = _two_mode_iir()
    x = rng.standard_normal(2**20 + 5000)
    y = _filtered(b, a, x)
    x = x[5000:]
    est = h1(x, y, FS, window=window, nperseg=4096)  # 256 averages, df = 0.24 Hz
    f = est.freq_hz
    exact = scipy.signal.freqz(b, a, worN=f, fs=FS)[1]
    # away from resonances: more than 3 half-power bandwidths (2 zeta fn) from each
    away = np.ones(f.size, dtype=bool)
    for fn in (80.0, 230.0):
        away &= np.abs(f - fn) > 3 * 2 * 0.02 * fn
    away[[0, -1]] = False
    ratio = est.H[away, 0, 0] / exact[away]
    assert np.max(np.abs(np.abs(ratio) - 1)) < 0.01  # magnitude within 1 %
    assert np.max(np.abs(np.angle(ratio))) < 0.01  # phase within 0.01 rad
    # near the peaks H1 is biased low (leakage), which is what the bias test quantifies
    k80 = np.argmin(np.abs(f - 80.0))
    assert np.abs(est.H[k80, 0, 0]) < np.abs(exact[k80])


def test_multiple_input_h1_recovers_two_input_system_with_correlated_inputs(rng):
    n = 2**17
    w = rng.standard_normal((2, n + 100))
    x = np.vstack([w[0], 0.8 * w[0] + 0.6 * scipy.signal.lfilter([1.0], [1.0, -0.5], w[1])])
    paths = {  # (output, input): FIR taps
        (0, 0): [1.0, 0.5, 0.25],
        (0, 1): [0.0, -0.7, 0.2],
        (1, 0): [0.3, 0.0, 0.0, 0.4],
        (1, 1): [1.2, -0.4],
    }
    y = np.zeros((2, n + 100))
    for (o, i), taps in paths.items():
        y[o] += scipy.signal.lfilter(taps, [1.0], x[i])
    x, y = x[:, 100:], y[:, 100:]
    est = h1(x, y, FS, window="hann", nperseg=1024)
    for (o, i), taps in paths.items():
        exact = scipy.signal.freqz(taps, [1.0], worN=est.freq_hz, fs=FS)[1]
        assert np.max(np.abs(est.H[:, o, i] - exact)) < 0.01 * np.max(np.abs(exact)), (o, i)
    np.testing.assert_array_less(0.999, est.multiple_coherence)
    # with correlated inputs, one input at a time is wrong: Gyx / Gxx per pair
    naive = h1(x[0], y[0], FS, window="hann", nperseg=1024).H[:, 0, 0]
    exact00 = scipy.signal.freqz(paths[0, 0], [1.0], worN=est.freq_hz, fs=FS)[1]
    assert np.max(np.abs(naive - exact00)) > 0.3
    # and the ordinary coherence of one pair is not 1 although the system is noise free
    assert np.min(est.coherence[:, 0, 0]) < 0.9


def test_h2_and_hv_recover_square_two_input_system(rng):
    n = 2**16
    x = rng.standard_normal((2, n + 50))
    x[1] += 0.5 * x[0]
    y = np.vstack(
        [
            scipy.signal.lfilter([1.0, 0.4], [1.0], x[0])
            + scipy.signal.lfilter([0.5], [1.0], x[1]),
            scipy.signal.lfilter([0.0, 0.8], [1.0], x[0])
            - scipy.signal.lfilter([1.0, -0.3], [1.0], x[1]),
        ]
    )[:, 50:]
    x = x[:, 50:]
    f = np.fft.rfftfreq(512, 1 / FS)
    exact = np.empty((f.size, 2, 2), dtype=complex)
    exact[:, 0, 0] = scipy.signal.freqz([1.0, 0.4], [1.0], worN=f, fs=FS)[1]
    exact[:, 0, 1] = 0.5
    exact[:, 1, 0] = scipy.signal.freqz([0.0, 0.8], [1.0], worN=f, fs=FS)[1]
    exact[:, 1, 1] = -scipy.signal.freqz([1.0, -0.3], [1.0], worN=f, fs=FS)[1]
    for estimator in ESTIMATORS:
        est = estimate_frf(x, y, FS, estimator=estimator, window="hann", nperseg=512)
        assert np.max(np.abs(est.H - exact)) < 0.01, estimator


# ------------------------------------------------------------------ coherence and noise


def test_coherence_is_one_for_noise_free_linear_data(rng):
    x = rng.standard_normal(2**16)
    y = scipy.signal.lfilter([1.0, 0.6, -0.3], [1.0], x)
    est = h1(x, y, FS, window="hann", nperseg=1024)
    # leakage alone keeps it a hair below 1 where |H| is smallest (near Nyquist)
    assert np.median(est.coherence) > 0.9999
    assert np.min(est.coherence) > 0.995


def test_coherence_drops_with_output_noise_as_theory_predicts(rng):
    # y = h * x + n, x and n white: gamma^2 = S / (S + N) = |H|^2 / (|H|^2 + sigma_n^2)
    taps, sigma_n, n_avg, nperseg = [1.0, 0.6, -0.3], 0.5, 400, 256
    x = rng.standard_normal(n_avg * nperseg + 10)
    y = scipy.signal.lfilter(taps, [1.0], x)[10:] + sigma_n * rng.standard_normal(n_avg * nperseg)
    x = x[10:]
    est = h1(x, y, FS, window="hann", nperseg=nperseg)
    h2_exact = np.abs(scipy.signal.freqz(taps, [1.0], worN=est.freq_hz, fs=FS)[1]) ** 2
    theory = h2_exact / (h2_exact + sigma_n**2)
    assert theory.min() < 0.3 and theory.max() > 0.8  # the test spans a useful range
    measured = est.coherence[:, 0, 0]
    # random error (Bendat & Piersol eq. 9.73): sd = sqrt(2) (1 - g2) sqrt(g2) / sqrt(n_d)
    sd = np.sqrt(2) * (1 - theory) * np.sqrt(theory) / np.sqrt(n_avg)
    inner = slice(1, -1)  # 0 Hz and Nyquist have half the degrees of freedom
    z = (measured[inner] - theory[inner]) / sd[inner]
    # 127 lines: |z| < 5 everywhere (p ~ 1e-4 to fail by chance); no systematic bias (the
    # mean of z has sd 1 / sqrt(127) = 0.09); and the scatter is the predicted one
    assert np.max(np.abs(z)) < 5
    assert abs(np.mean(z)) < 0.4
    assert 0.7 < np.std(z) < 1.3


def test_h1_over_h2_is_the_coherence_and_hv_lies_between(rng):
    x, y = _noisy_system(rng, 1, 2)
    kw = dict(window="hann", nperseg=256)
    s = spectral_matrices(x, y, FS, **kw)
    e1, e2, ev = (frf_from_spectra(s, name) for name in ("H1", "H2", "Hv"))
    np.testing.assert_allclose(e1.H / e2.H, e1.coherence, rtol=1e-10)  # H1/H2 = gamma^2
    assert np.all(np.abs(e1.H) <= np.abs(ev.H) * (1 + 1e-12))
    assert np.all(np.abs(ev.H) <= np.abs(e2.H) * (1 + 1e-12))


def test_h1_resists_output_noise_and_h2_resists_input_noise(rng):
    n, taps = 2**18, [1.0, 0.6, -0.3]
    u = rng.standard_normal(n + 10)
    v = scipy.signal.lfilter(taps, [1.0], u)[10:]
    u = u[10:]
    f = np.fft.rfftfreq(256, 1 / FS)
    exact = np.abs(scipy.signal.freqz(taps, [1.0], worN=f, fs=FS)[1])
    kw = dict(window="hann", nperseg=256)
    # output noise: H1 unbiased, H2 biased up by 1 / gamma^2
    y_noisy = v + 0.5 * rng.standard_normal(n)
    b1 = np.median(np.abs(h1(u, y_noisy, FS, **kw).H[:, 0, 0]) / exact)
    b2 = np.median(np.abs(h2(u, y_noisy, FS, **kw).H[:, 0, 0]) / exact)
    assert b1 == pytest.approx(1.0, abs=0.01) and b2 > 1.1
    # input noise: H2 unbiased, H1 biased down by gamma^2
    x_noisy = u + 0.5 * rng.standard_normal(n)
    b1 = np.median(np.abs(h1(x_noisy, v, FS, **kw).H[:, 0, 0]) / exact)
    b2 = np.median(np.abs(h2(x_noisy, v, FS, **kw).H[:, 0, 0]) / exact)
    assert b2 == pytest.approx(1.0, abs=0.01) and b1 < 0.9
    # equal noise on both (same variance): Hv unbiased; H1 low, H2 high
    bv = np.median(
        np.abs(
            hv(u + 0.3 * rng.standard_normal(n), v + 0.3 * rng.standard_normal(n), FS, **kw).H[
                :, 0, 0
            ]
        )
        / exact
    )
    assert bv == pytest.approx(1.0, abs=0.02)


# ------------------------------------------------------------------ impact windows


def _impact_record(rng, n=4096):
    b = [1e-3]
    a = _mode_denominator(120.0, 0.03)
    x = np.zeros(n)
    # a short decaying hammer pulse (strictly decreasing taps: no spectral zero)
    x[:5] = [1.0, 0.8, 0.5, 0.2, 0.05]
    y = scipy.signal.lfilter(b, a, x)
    return b, a, x, y


def test_exponential_window_equals_frf_of_exponentially_damped_system(rng):
    # w[k] = q**k on input and output: y_w = (q**k h) * x_w, so H1 = freqz(b q**k, a q**k)
    b, a, x, y = _impact_record(rng)
    n, decay = x.size, 1e-3
    est = h1(x, y, FS, window=("exponential", decay))
    q = decay ** (1 / (n - 1))
    damped = scipy.signal.freqz(
        np.asarray(b) * q ** np.arange(len(b)), a * q ** np.arange(len(a)), worN=est.freq_hz, fs=FS
    )[1]
    _assert_rel(est.H[:, 0, 0], damped, 1e-9)
    # the added decay rate is -ln(decay) fs / (n - 1), as get_window documents
    sigma_w = -np.log(decay) * FS / (n - 1)
    pole = np.roots(a)[0]
    assert np.abs(np.roots(a * q ** np.arange(3))).max() == pytest.approx(
        np.abs(pole) * np.exp(-sigma_w / FS), rel=1e-12
    )


def test_force_window_on_input_removes_noise_after_the_pulse(rng):
    b, a, x, y = _impact_record(rng)
    x_noisy = x + np.r_[np.zeros(10), 0.01 * rng.standard_normal(x.size - 10)]
    exact = scipy.signal.freqz(b, a, worN=np.fft.rfftfreq(x.size, 1 / FS), fs=FS)[1]
    with_force = h1(x_noisy, y, FS, window="rectangular", input_window=("force", 10))
    without = h1(x_noisy, y, FS, window="rectangular")
    assert "input: force(force_width=10)" in with_force.window
    _assert_rel(with_force.H[:, 0, 0], exact, 1e-10)
    assert np.max(np.abs(without.H[:, 0, 0] - exact)) / np.max(np.abs(exact)) > 1e-2


# ------------------------------------------------------------------ the registry contract


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_estimator_contract(rng, name):
    """Every registered estimator: shapes, sign, noise-free recovery, settings, purity."""
    entry = ESTIMATORS[name]
    assert entry.name == name and entry.summary
    x = rng.standard_normal((2, 2**15 + 4))
    y = np.vstack(
        [
            scipy.signal.lfilter([0, 1.0], [1.0], x[0]) + 0.5 * x[1],  # delay: phase sign
            scipy.signal.lfilter([0.2, 0.3], [1.0], x[0]) - x[1],
            x[0] + x[1],
        ]
    )
    x, y = x[:, 4:], y[:, 4:]
    x0, y0 = x.copy(), y.copy()
    est = estimate_frf(x, y, FS, estimator=name.lower(), window="hann", nperseg=512)
    assert isinstance(est, FRFEstimate)
    assert est.estimator == name
    assert est.H.shape == (257, 3, 2) and est.H.dtype == np.complex128
    assert est.coherence.shape == (257, 3, 2) and est.multiple_coherence.shape == (257, 3)
    np.testing.assert_allclose(est.freq_hz, np.fft.rfftfreq(512, 1 / FS))
    delay = np.exp(-2j * np.pi * est.freq_hz / FS)
    assert np.max(np.abs(est.H[:, 0, 0] - delay)) < 0.01
    assert np.max(np.abs(est.H[:, 2, :] - 1.0)) < 0.01
    assert (est.nperseg, est.noverlap, est.n_averages, est.fs_hz) == (512, 0, 64, FS)
    assert est.window == "hann" and est.detrend == "none"
    np.testing.assert_array_equal(x, x0)
    np.testing.assert_array_equal(y, y0)
    # SISO form works for every estimator and gives the same first path
    siso = estimate_frf(x[0], x[0] * 2.0, FS, estimator=name, nperseg=256)
    assert siso.H.shape == (129, 1, 1)
    np.testing.assert_allclose(siso.H, 2.0, rtol=1e-10)


def test_thin_functions_equal_estimate_frf(rng):
    x, y = _noisy_system(rng, 1, 2, n=5000)
    for fn, name in [(h1, "H1"), (h2, "H2"), (hv, "Hv")]:
        a = fn(x, y, FS, window="hamming", nperseg=500, noverlap=250)
        b = estimate_frf(x, y, FS, estimator=name, window="hamming", nperseg=500, noverlap=250)
        np.testing.assert_array_equal(a.H, b.H)


def test_settings_chosen_are_reported(rng):
    x = rng.standard_normal(2**20)
    est = h1(x, x, FS, n_averages=10)
    assert (est.nperseg, est.noverlap, est.n_averages) == (104857, 0, 10)
    est = h1(x, x, FS, n_averages=10, nperseg="fast")
    assert (est.nperseg, est.n_averages) == (103680, 10)
    assert est.df_hz == pytest.approx(FS / 103680)


def test_the_estimate_describes_itself_as_an_estimator(rng):
    """to_estimator: the window, segment, averages, rate and overlap the estimate
    reports, as the leakage model's Estimator (no hand conversion of nperseg)."""
    x = rng.standard_normal(4000)
    est = h1(x, x, FS, window="hann", nperseg=500, noverlap=250)
    e = est.to_estimator()
    assert (e.window, e.segment_samples, e.fs_hz, e.averages, e.overlap_samples,
            e.period_samples) == ("hann", 500, FS, est.n_averages, 250, None)
    assert est.to_estimator(period_samples=1000).period_samples == 1000
    impact = h1(x, x, FS, window=("exponential", 0.1), nperseg=4000)
    with pytest.raises(ValueError, match=r"the window 'exponential\(decay_to=0.1\)' is not "
                                         r"one of rectangular"):
        impact.to_estimator()


def test_singular_input_matrix_warns_and_gives_nan(rng):
    x = rng.standard_normal(4096)
    xx = np.vstack([x, np.zeros_like(x)])  # second input never excited
    with pytest.warns(RuntimeWarning, match=r"Gxx is singular at 65 of 65 frequency lines"):
        est = h1(xx, x, FS, nperseg=128)
    assert np.all(np.isnan(est.H))


# ------------------------------------------------------------------ the result object


def test_frf_estimate_is_immutable_and_exports_to_pandas(rng):
    x, y = _noisy_system(rng, 2, 3, n=4000)
    est = h1(x, y, FS, nperseg=200)
    with pytest.raises(ValueError, match="read-only"):
        est.H[0, 0, 0] = 0.0
    with pytest.raises(AttributeError):
        est.estimator = "H2"
    frame = est.to_pandas()
    assert len(frame) == est.n_freq * 3 * 2
    assert list(frame.columns) == [
        "freq_hz",
        "output",
        "input",
        "H",
        "magnitude",
        "phase_rad",
        "coherence",
        "multiple_coherence",
    ]
    row = frame[(frame.output == 2) & (frame.input == 1)].iloc[7]
    assert row.H == est.H[7, 2, 1] and row.freq_hz == est.freq_hz[7]
    assert row.multiple_coherence == est.multiple_coherence[7, 2]
    assert frame.attrs["estimator"] == "H1" and frame.attrs["nperseg"] == 200
    assert (est.n_freq, est.n_outputs, est.n_inputs) == (101, 3, 2)


def test_frf_estimate_validates_shapes():
    f = np.arange(4.0)
    h = np.zeros((4, 2, 1), dtype=complex)
    kw = dict(estimator="H1", window="hann", nperseg=6, noverlap=0, n_averages=1, fs_hz=6.0)
    FRFEstimate(f, h, np.zeros((4, 2, 1)), None, **kw)  # multiple coherence optional
    with pytest.raises(ValueError, match=r"'H' must have shape \(n_freq, n_out, n_in\) = \(4"):
        FRFEstimate(f, h[:3], np.zeros((3, 2, 1)), None, **kw)
    with pytest.raises(ValueError, match=r"'coherence' must have the shape of H"):
        FRFEstimate(f, h, np.zeros((4, 1, 1)), None, **kw)
    with pytest.raises(ValueError, match=r"'multiple_coherence' must have shape"):
        FRFEstimate(f, h, np.zeros((4, 2, 1)), np.zeros((4, 3)), **kw)
