"""Nonlinear elements in a linear system, against oracles nobody here wrote.

* Coulomb friction: the exact free decay of a friction oscillator (amplitude loss
  ``4 F_c / k`` per cycle, rest inside ``|x| <= F_c / k``, then stuck for good), and
  ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-11) restarted at every reversal, stick
  and breakaway and at every sample (the input is linear there), for a forced oscillator,
  a three-mass chain and a free-free chain (rigid-body mode while slipping). Measured
  agreement ~1e-11 of the RMS response; asserted 1e-8 (the brief's target is 1e-4).
* Level dependence (Table 10.1): friction is a constant force, so its
  effect on the FRF shrinks as the excitation grows; hardening cubic stiffness moves the
  resonance up with level; inside a dead band the spring is absent.
* Smooth elements: second-order convergence in ``dt`` against solve_ivp (rtol 1e-12),
  alone and together with stick-slip.
* Zero nonlinear forces reproduce :func:`simulate_lti`, and the interpreted and the
  compiled engine agree, to within the rounding of the recursion they evaluate plus the
  documented event-time accuracy (``nonlinear_engine_bound`` in conftest.py), whatever
  the CPU.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from truthbench.errors import ConvergenceError, ModelError
from truthbench.measure import estimate_frf
from truthbench.simulate import band_limited_random, numba_available, simulate_lti
from truthbench.simulate.nonlinear import (
    LAWS,
    AmplitudeDependentDamping,
    CoulombFriction,
    CubicStiffness,
    DeadBand,
    NonlinearElement,
    NonlinearLaw,
    NonlinearResult,
    prepare_nonlinear,
    simulate_nonlinear,
)

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba not installed")
BACKENDS = ["numpy", pytest.param("numba", marks=needs_numba)]
#: The oracle tests run the interpreted engine: the same source as the compiled one (see
#: test_engines_agree), fast enough for these small systems, and no numba compilation
#: (about 30 s of CPU on a cold cache) in the way.
ENGINE = "numpy"


# ----------------------------------------------------------------------------------
# systems
# ----------------------------------------------------------------------------------


def second_order(m, c, k, b_force):
    """``M q'' + C q' + K q = b u`` in first-order form, state ``[q; q']``."""
    n = m.shape[0]
    mi = np.linalg.inv(m)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-mi @ k, -mi @ c]])
    b = np.vstack([np.zeros((n, b_force.shape[1])), mi @ b_force])
    return a, b


def dof_element(law, m, dof):
    """Element acting at DOF ``dof`` of ``second_order``'s state (force on that mass)."""
    n = m.shape[0]
    e = np.eye(2 * n)
    return NonlinearElement(law, e[dof], e[n + dof],
                            np.r_[np.zeros(n), np.linalg.inv(m)[:, dof]])


def sdof(mass=1.0, freq_hz=5.0, zeta=0.01):
    k = mass * (2 * np.pi * freq_hz) ** 2
    c = 2 * zeta * np.sqrt(k * mass)
    a, b = second_order(np.array([[mass]]), np.array([[c]]), np.array([[k]]),
                        np.array([[1.0]]))
    return a, b, np.eye(2), k


def chain3():
    """Three masses to ground, non-proportional dampers; force at mass 1."""
    m = np.diag([1.0, 2.0, 1.5])
    k = np.array([[2e4, -1e4, 0.0], [-1e4, 3e4, -2e4], [0.0, -2e4, 2e4]])
    c = np.diag([0.5, 0.0, 3.0])
    a, b = second_order(m, c, k, np.array([[1.0], [0.0], [0.0]]))
    return m, a, b, np.eye(6)[[0, 2, 4]]


def free_chain():
    """Free-free chain of three masses (a rigid-body mode); force at mass 3."""
    m = np.diag([2.0, 1.0, 1.0])
    k = np.zeros((3, 3))
    c = np.zeros((3, 3))
    for i in range(2):
        e = np.zeros(3)
        e[i], e[i + 1] = 1.0, -1.0
        k += 4e3 * np.outer(e, e)
        c += 1.0 * np.outer(e, e)
    a, b = second_order(m, c, k, np.array([[0.0], [0.0], [1.0]]))
    return m, a, b, np.eye(6)[[0, 2, 3]]


def rel_err(y, ref):
    rms = np.sqrt(np.mean(ref**2, axis=-1))
    return float(np.max(np.max(np.abs(y - ref), axis=-1) / rms))


# ----------------------------------------------------------------------------------
# the reference: solve_ivp restarted at every sample and at every friction event
# ----------------------------------------------------------------------------------


def friction_reference(a, b, c, cv, bf, fc, u, dt, x0=None, rtol=1e-11, atol=1e-15,
                       extra=None):
    """One Coulomb element ``f = -fc sign(v)``, ``v = cv x``, force column ``bf``
    (and optionally a smooth force ``extra(x)`` through the same column).

    Slip: ``x' = A x + B u - fc d bf`` until ``d v`` falls through 0. Stick:
    ``x' = P (A x + B u)``, ``P = I - bf cv / (cv bf)`` (the velocity held at 0 by the
    force ``h = -cv (A x + B u) / (cv bf)``) until ``|h| = fc``; then slip in the
    direction ``-sign(h)``. The input is linear over each sample interval, so each
    interval is integrated on its own (no kinks inside the integrator's steps).
    """
    u = np.atleast_2d(u)
    n = a.shape[0]
    gain = cv @ bf
    proj = np.eye(n) - np.outer(bf, cv) / gain
    x = np.zeros(n) if x0 is None else np.array(x0, float)

    def smooth(s):
        return 0.0 if extra is None else extra(s)

    def hold(s, uu):
        return -(cv @ (a @ s + b @ uu + bf * smooth(s))) / gain

    v = cv @ x
    if v != 0:
        mode = np.sign(v)
    else:
        h = hold(x, u[:, 0])
        mode = 0.0 if abs(h) <= fc else -np.sign(h)
    out = np.zeros((n, u.shape[1]))
    out[:, 0] = x
    for j in range(u.shape[1] - 1):
        t0, t1 = j * dt, (j + 1) * dt
        ua, ub = u[:, j], u[:, j + 1]

        def uf(t, ua=ua, ub=ub, t0=t0):
            return ua + (ub - ua) * ((t - t0) / dt)

        t = t0
        while t < t1:
            if mode != 0:
                def rhs(tt, s, d=mode, uf=uf):
                    return a @ s + b @ uf(tt) + (smooth(s) - fc * d) * bf

                def ev(tt, s, d=mode):
                    return d * (cv @ s)

                ev.terminal, ev.direction = True, -1
                if abs(cv @ x) <= 1e-14 * (1.0 + np.abs(x).max()):
                    # leaving v = 0: a short event-free start
                    tt = min(t + 1e-9 * dt, t1)
                    x = solve_ivp(rhs, (t, tt), x, method="DOP853", rtol=rtol,
                                  atol=atol).y[:, -1]
                    t = tt
                    if t >= t1:
                        break
                sol = solve_ivp(rhs, (t, t1), x, method="DOP853", rtol=rtol, atol=atol,
                                events=ev)
                if sol.status == 1:
                    t, x = sol.t_events[0][0], sol.y_events[0][0]
                    h = hold(x, uf(t))
                    mode = 0.0 if abs(h) <= fc else -np.sign(h)
                else:
                    t, x = t1, sol.y[:, -1]
            else:
                def rhs(tt, s, uf=uf):
                    return proj @ (a @ s + b @ uf(tt) + bf * smooth(s))

                def ev(tt, s, uf=uf):
                    return fc - abs(hold(s, uf(tt)))

                ev.terminal, ev.direction = True, -1
                sol = solve_ivp(rhs, (t, t1), x, method="DOP853", rtol=rtol, atol=atol,
                                events=ev)
                if sol.status == 1:
                    t, x = sol.t_events[0][0], sol.y_events[0][0]
                    mode = -np.sign(hold(x, uf(t)))
                else:
                    t, x = t1, sol.y[:, -1]
        out[:, j + 1] = x
    return c @ out


# ----------------------------------------------------------------------------------
# Coulomb friction
# ----------------------------------------------------------------------------------


@pytest.mark.parametrize("backend", BACKENDS)
def test_coulomb_free_decay_is_the_textbook_solution(backend):
    """Undamped friction oscillator released from x0: each half cycle is a harmonic
    half-wave about +-F_c/k, so the peaks fall by 2 F_c/k per half cycle (4 F_c/k per
    cycle) at the undamped frequency, and the mass stops for good at the first peak
    inside |x| <= F_c/k."""
    a, b, c, k = sdof(zeta=0.0)
    fc, x0 = 2.0, 0.1
    dt, n = 1e-3, 4000
    el = NonlinearElement(CoulombFriction(fc), [1.0, 0.0], [0.0, 1.0], [0.0, 1.0])
    res = simulate_nonlinear(a, b, c, None, np.zeros(n), dt, [el], x0=[x0, 0.0],
                             backend=backend)
    x = res.y[0]
    # analytic: peaks x0 - 2 i Fc/k alternately signed, until inside the stick band
    step = 2 * fc / k
    n_half = int(np.ceil((x0 - fc / k) / step))
    peaks = (x0 - step * np.arange(n_half + 1)) * (-1.0) ** np.arange(n_half + 1)
    t_stop = n_half * np.pi / np.sqrt(k)
    j_stop = int(np.ceil(t_stop / dt))
    found = np.r_[x[0], [x[int(round(i * np.pi / np.sqrt(k) / dt))] for i in
                         range(1, n_half + 1)]]
    # the samples nearest each peak are within (omega dt)^2/2 of it
    assert np.allclose(found, peaks, rtol=0, atol=0.02 * step)
    loss_per_cycle = np.abs(found[:-2:2]) - np.abs(found[2::2])
    assert np.allclose(loss_per_cycle, 4 * fc / k, rtol=0.02)
    # at rest inside the band, exactly where the theory says, and stuck from then on
    assert abs(x[-1]) <= fc / k
    assert x[-1] == pytest.approx(peaks[-1], abs=1e-12)
    assert np.all(res.stuck[0, j_stop + 1:])
    assert not np.any(res.stuck[0, : j_stop - 1])
    assert np.ptp(x[j_stop + 1:]) < 1e-15
    assert np.max(np.abs(res.y[1, j_stop + 1:])) < 1e-15
    assert res.n_stick_events.tolist() == [1]
    assert res.n_reversals.tolist() == [n_half - 1]
    # while stuck the friction force is the spring force it holds
    assert np.allclose(res.f_nl[0, j_stop + 1:], k * x[-1], rtol=1e-12)


@pytest.mark.parametrize("fc", [5.0, 12.0])
def test_forced_oscillator_matches_event_located_solve_ivp(fc):
    a, b, c, _ = sdof(zeta=0.01)
    fs, n = 200.0, 1200
    u = band_limited_random(n, fs, 10.0, (0.0, 20.0), np.random.default_rng(0))
    el = NonlinearElement(CoulombFriction(fc), [1.0, 0.0], [0.0, 1.0], [0.0, 1.0])
    res = simulate_nonlinear(a, b, c, None, u, 1 / fs, [el], backend=ENGINE)
    ref = friction_reference(a, b, c, np.array([0.0, 1.0]), np.array([0.0, 1.0]), fc, u,
                             1 / fs)
    assert res.n_stick_events[0] > 10 and res.n_reversals[0] > 10
    assert 0.02 < res.stuck.mean() < 0.9
    assert rel_err(res.y, ref) < 1e-8


def test_three_mass_chain_matches_event_located_solve_ivp():
    m, a, b, c = chain3()
    fs, n = 1000.0, 800
    u = band_limited_random(n, fs, 50.0, (0.0, 60.0), np.random.default_rng(3))
    el = dof_element(CoulombFriction(30.0), m, 1)
    res = simulate_nonlinear(a, b, c, None, u, 1 / fs, [el], backend=ENGINE)
    ref = friction_reference(a, b, c, el.velocity_row, el.force_column, 30.0, u, 1 / fs)
    assert res.n_stick_events[0] >= 5
    assert rel_err(res.y, ref) < 1e-8
    # stuck: the element's velocity is zero and its force within F_c
    stuck = res.stuck[0]
    assert np.all(np.abs(res.velocity[0, stuck]) < 1e-12 * np.abs(res.velocity).max())
    assert np.all(np.abs(res.f_nl[0, stuck]) <= 30.0)
    assert np.all(np.abs(res.f_nl[0, ~stuck]) == 30.0)


@pytest.mark.parametrize(("fc", "seed"), [(20.0, 3), (10.0, 4)])
@pytest.mark.slow
def test_two_sign_changes_within_one_step_match_solve_ivp(fc, seed):
    """Sampled at 80 Hz the chain's modes at 21 and 27 Hz make the friction point's
    velocity touch zero and come back within one step (stick and breakaway, or two
    reversals, between two samples): the gate is positive at both ends of such a step.
    Without a look inside the step both cases were missed (errors of 0.2 here)."""
    m, a, b, c = chain3()
    fs, n = 80.0, 400
    u = band_limited_random(n, fs, 50.0, (0.0, 36.0), np.random.default_rng(seed))
    el = dof_element(CoulombFriction(fc), m, 1)
    res = simulate_nonlinear(a, b, c, None, u, 1 / fs, [el], backend=ENGINE)
    ref = friction_reference(a, b, c, el.velocity_row, el.force_column, fc, u, 1 / fs)
    assert res.n_reversals[0] > 100 and res.n_stick_events[0] >= 5
    assert rel_err(res.y, ref) < 1e-8


def test_rigid_body_mode_while_slipping_matches_solve_ivp():
    """Free-free chain with friction of mass 1 to ground: slipping, the system has a
    rigid-body mode (the block path with its matrix exponentials); stuck, it has none."""
    m, a, b, c = free_chain()
    fs, n = 500.0, 700
    u = band_limited_random(n, fs, 20.0, (0.0, 40.0), np.random.default_rng(5))
    el = dof_element(CoulombFriction(6.0), m, 0)
    system = prepare_nonlinear(a, b, c, None, 1 / fs, [el])
    assert system.paths == ("block", "modal")
    res = system.simulate(u, backend=ENGINE)
    ref = friction_reference(a, b, c, el.velocity_row, el.force_column, 6.0, u, 1 / fs)
    assert res.n_stick_events[0] >= 3 and res.n_reversals[0] >= 3
    assert rel_err(res.y, ref) < 1e-8


@pytest.mark.slow
def test_friction_effect_on_frf_shrinks_with_level():
    """Friction is a constant force: at rising excitation its share of the response
    falls and the H1 estimate approaches the linear FRF (same input, simulate_lti)."""
    a, b, c, _ = sdof(freq_hz=5.0, zeta=0.02)
    fs, n = 100.0, 2**13
    u0 = band_limited_random(n, fs, 1.0, (0.5, 20.0), np.random.default_rng(7))
    el = NonlinearElement(CoulombFriction(1.0), [1.0, 0.0], [0.0, 1.0], [0.0, 1.0])
    system = prepare_nonlinear(a, b, c[:1], None, 1 / fs, [el])
    errors = []
    for level in (2.0, 8.0, 32.0, 128.0, 512.0):
        u = level * u0
        y = system.simulate(u, backend=ENGINE).y
        y_lin = simulate_lti(a, b, c[:1], None, u, 1 / fs)
        est = estimate_frf(u, y, fs, n_averages=4)
        lin = estimate_frf(u, y_lin, fs, n_averages=4)
        peak = np.argmax(np.abs(lin.H[:, 0, 0]))
        errors.append(abs(abs(est.H[peak, 0, 0]) / abs(lin.H[peak, 0, 0]) - 1.0))
    assert all(e1 > e2 for e1, e2 in zip(errors, errors[1:], strict=False)), errors
    assert errors[0] > 0.3 and errors[-1] < 0.02


# ----------------------------------------------------------------------------------
# smooth elements
# ----------------------------------------------------------------------------------


@pytest.mark.slow
def test_cubic_hardening_moves_the_resonance_up_with_level():
    a, b, c, _ = sdof(freq_hz=5.0, zeta=0.02)
    fs, n = 100.0, 2**13
    u0 = band_limited_random(n, fs, 1.0, (0.5, 20.0), np.random.default_rng(8))
    el = NonlinearElement(CubicStiffness(3e4), [1.0, 0.0], [0.0, 1.0], [0.0, 1.0])
    system = prepare_nonlinear(a, b, c[:1], None, 1 / fs, [el])
    peaks = []
    for level in (0.1, 10.0, 20.0, 40.0):
        u = level * u0
        est = estimate_frf(u, system.simulate(u, backend=ENGINE).y, fs, n_averages=4,
                           window="hann")
        band = (est.freq_hz > 1.0) & (est.freq_hz < 15.0)  # inside the excited band
        peaks.append(est.freq_hz[band][np.argmax(np.abs(est.H[band, 0, 0]))])
    assert peaks[0] == pytest.approx(5.0, abs=0.06)  # one line is 0.049 Hz
    assert peaks[-1] > 5.4
    assert all(p1 < p2 for p1, p2 in zip(peaks, peaks[1:], strict=False)), peaks


@pytest.mark.parametrize("backend", BACKENDS)
def test_dead_band_inside_the_gap_is_the_system_without_the_spring(backend, rounding):
    a, b, c, k = sdof(freq_hz=3.0, zeta=0.05)
    fs, n = 200.0, 1500
    u = band_limited_random(n, fs, 1.0, (0.0, 10.0), np.random.default_rng(9))
    y_lin = simulate_lti(a, b, c, None, u, 1 / fs)
    gap = 1.01 * np.abs(y_lin[0]).max()
    el = NonlinearElement(DeadBand(gap, 50 * k), [1.0, 0.0], [0.0, 1.0], [0.0, 1.0])
    res = simulate_nonlinear(a, b, c, None, u, 1 / fs, [el], backend=backend)
    assert np.all(res.f_nl == 0.0)
    sigma, extra = rounding.nonlinear(a, b, [el], u, 1 / fs, res, c)
    rounding.check(res.y, y_lin, sigma, extra=extra)
    rounding.detects(y_lin, sigma, extra)
    # a narrower gap: the contact spring stiffens the response (smaller amplitude)
    narrow = NonlinearElement(DeadBand(0.3 * gap, 50 * k), [1.0, 0.0], [0.0, 1.0],
                              [0.0, 1.0])
    res2 = simulate_nonlinear(a, b, c, None, u, 1 / fs, [narrow], backend=backend)
    assert np.abs(res2.y[0]).max() < 0.9 * np.abs(y_lin[0]).max()
    assert np.any(res2.f_nl != 0.0)


def _smooth_reference(a, b, laws, u_coarse, dt_coarse, t_end, x0):
    """solve_ivp (rtol 1e-12) of the SDOF with the smooth laws, the input interpolated
    linearly between the coarse samples (the same continuous input for every dt)."""
    t_c = dt_coarse * np.arange(u_coarse.size)

    def rhs(t, s):
        f = sum(float(law.force(s[0], s[1])) for law in laws)
        return a @ s + b[:, 0] * np.interp(t, t_c, u_coarse) + np.array([0.0, f])

    sol = solve_ivp(rhs, (0.0, t_end), x0, method="DOP853", rtol=1e-12, atol=1e-14,
                    t_eval=t_c[t_c <= t_end + 1e-12], max_step=dt_coarse / 4)
    return sol.y[0]


@pytest.mark.slow
def test_smooth_elements_converge_at_second_order_in_dt():
    a, b, c, _ = sdof(freq_hz=4.0, zeta=0.02)
    laws = [CubicStiffness(3e4), AmplitudeDependentDamping(20.0)]
    fs0, n0 = 100.0, 201
    t = np.arange(n0) / fs0
    u0 = 30.0 * np.sin(2 * np.pi * 3.0 * t) + 20.0 * np.sin(2 * np.pi * 7.0 * t)
    x0 = [0.05, 0.0]
    ref = _smooth_reference(a, b, laws, u0, 1 / fs0, t[-1], x0)
    errors = []
    for refine in (1, 2, 4, 8):
        tf = np.arange((n0 - 1) * refine + 1) / (fs0 * refine)
        uf = np.interp(tf, t, u0)
        els = [NonlinearElement(law, [1.0, 0.0], [0.0, 1.0], [0.0, 1.0]) for law in laws]
        y = simulate_nonlinear(a, b, c[:1], None, uf, 1 / (fs0 * refine), els, x0=x0,
                               backend=ENGINE).y[0]
        errors.append(np.max(np.abs(y[::refine] - ref)) / np.sqrt(np.mean(ref**2)))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 1.8), (errors, orders)
    assert errors[-1] < 1e-4


def test_friction_with_a_cubic_spring_converges_at_second_order():
    """Stick-slip and a smooth element together: the friction events stay exact, the
    cubic force's linear-in-time treatment gives the second-order error."""
    a, b, c, _ = sdof(freq_hz=3.0, zeta=0.02)
    k3, fc = 2e4, 6.0
    fs0, n0 = 100.0, 301
    t = np.arange(n0) / fs0
    u0 = 15.0 * np.sin(2 * np.pi * 2.0 * t) + 8.0 * np.sin(2 * np.pi * 5.3 * t)
    ref = friction_reference(a, b, c, np.array([0.0, 1.0]), np.array([0.0, 1.0]), fc, u0,
                             1 / fs0, rtol=1e-12, extra=lambda s: -k3 * s[0] ** 3)
    errors = []
    for refine in (1, 2, 4):
        uf = np.interp(np.arange((n0 - 1) * refine + 1) / (fs0 * refine), t, u0)
        els = [NonlinearElement(CoulombFriction(fc), [1.0, 0.0], [0.0, 1.0], [0.0, 1.0]),
               NonlinearElement(CubicStiffness(k3), [1.0, 0.0], [0.0, 1.0], [0.0, 1.0])]
        res = simulate_nonlinear(a, b, c, None, uf, 1 / (fs0 * refine), els, backend=ENGINE)
        assert res.n_stick_events[0] >= 3
        errors.append(rel_err(res.y[:, ::refine], ref))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 1.8), (errors, orders)


# ----------------------------------------------------------------------------------
# the linear limit and the engines
# ----------------------------------------------------------------------------------


@pytest.mark.parametrize("backend", BACKENDS)
def test_zero_nonlinear_forces_reproduce_simulate_lti(backend, rounding):
    m, a, b, c = chain3()
    fs, n = 1000.0, 1500
    u = band_limited_random(n, fs, 50.0, (0.0, 60.0), np.random.default_rng(4))
    x0 = 1e-3 * np.random.default_rng(1).standard_normal(6)
    els = [
        dof_element(CoulombFriction(0.0), m, 1),
        dof_element(CubicStiffness(0.0), m, 2),
        dof_element(AmplitudeDependentDamping(0.0), m, 0),
        dof_element(DeadBand(0.0, 0.0), m, 0),
    ]
    y_lin = simulate_lti(a, b, c, None, u, 1 / fs, x0=x0)
    res = simulate_nonlinear(a, b, c, None, u, 1 / fs, els, x0=x0, backend=backend)
    # two realisations of one exact recursion (the nonlinear engine's regimes, the linear
    # engine's modes): they differ by rounding; F_c = 0 makes the event-time term zero
    sigma, extra = rounding.nonlinear(a, b, els, u, 1 / fs, res, c, x0=x0)
    rounding.check(res.y, y_lin, sigma, extra=extra)
    rounding.detects(y_lin, sigma, extra)
    assert res.n_reversals[0] > 10  # zero friction still locates every reversal
    bare = simulate_nonlinear(a, b, c, None, u, 1 / fs, [], x0=x0, backend=backend)
    sigma, extra = rounding.nonlinear(a, b, [], u, 1 / fs, bare, c, x0=x0)
    rounding.check(bare.y, y_lin, sigma, extra=extra)


@needs_numba
def test_engines_agree(rounding):
    m, a, b, c = chain3()
    fs, n = 1000.0, 1500
    u = band_limited_random(n, fs, 50.0, (0.0, 60.0), np.random.default_rng(2))
    els = [dof_element(CoulombFriction(20.0), m, 1), dof_element(CubicStiffness(1e8), m, 2),
           dof_element(AmplitudeDependentDamping(5.0), m, 0)]
    system = prepare_nonlinear(a, b, c, None, 1 / fs, els)
    r1 = system.simulate(u, backend="numpy")
    r2 = system.simulate(u, backend="numba")
    assert r1.n_stick_events[0] > 0
    sigma, extra = rounding.nonlinear(a, b, els, u, 1 / fs, r1, c)
    rounding.check(r2.y, r1.y, sigma, extra=extra)
    rounding.detects(r1.y, sigma, extra)
    assert np.array_equal(r1.stuck, r2.stuck)
    assert np.array_equal(r1.n_reversals, r2.n_reversals)


@needs_numba
def test_engines_agree_with_a_single_friction_element(rounding):
    """One friction element and nothing else takes the lean per-step path of the
    compiled loop (gate and records straight from the element's row)."""
    m, a, b, c = chain3()
    fs, n = 1000.0, 1500
    u = band_limited_random(n, fs, 50.0, (0.0, 60.0), np.random.default_rng(3))
    els = [dof_element(CoulombFriction(30.0), m, 1)]
    system = prepare_nonlinear(a, b, c, None, 1 / fs, els)
    r1 = system.simulate(u, backend="numpy")
    r2 = system.simulate(u, backend="numba")
    assert r1.n_stick_events[0] >= 5
    sigma, extra = rounding.nonlinear(a, b, els, u, 1 / fs, r1, c)
    rounding.check(r2.y, r1.y, sigma, extra=extra)
    rounding.detects(r1.y, sigma, extra)
    assert np.array_equal(r1.stuck, r2.stuck)
    assert np.array_equal(r1.n_reversals, r2.n_reversals)
    cv, bf = els[0].velocity_row[None], els[0].force_column
    sigma, extra = rounding.nonlinear(a, b, els, u, 1 / fs, r1, cv)
    rounding.check(r2.velocity, r1.velocity, sigma, extra=extra)
    rounding.detects(r1.velocity, sigma, extra)
    # slipping, the force is -F_c sign(v): no arithmetic, the same bits
    stuck = r1.stuck[0]
    assert np.array_equal(r2.f_nl[0, ~stuck], r1.f_nl[0, ~stuck])
    # stuck, it is the holding force -(c_v b)^-1 c_v (A x + B u): an output of the state
    rows, feed = -(cv @ a) / (cv @ bf), -np.hstack([cv @ b, [[0.0]]]) / (cv @ bf)
    sigma, extra = rounding.nonlinear(a, b, els, u, 1 / fs, r1, rows, feed)
    rounding.check(r2.f_nl[:, stuck], r1.f_nl[:, stuck], sigma[:, stuck], extra=extra)
    rounding.detects(r1.f_nl, sigma, extra)


@pytest.mark.parametrize("which", ["modes", "block"])
def test_exponential_fallback_matches_the_step_tables(monkeypatch, which, rounding):
    """Within a step the state is propagated from tables on a grid of the step plus a
    Taylor step; modes too stiff for the grid and large or stiff dense blocks use
    exponentials instead. Forcing that fallback everywhere gives the same response."""
    from truthbench.simulate import nonlinear as nl

    if which == "modes":
        a, b, c, _ = sdof(zeta=0.01)
        fs, n = 200.0, 1200
        u = band_limited_random(n, fs, 10.0, (0.0, 20.0), np.random.default_rng(0))
        el = NonlinearElement(CoulombFriction(5.0), [1.0, 0.0], [0.0, 1.0], [0.0, 1.0])
    else:
        m, a, b, c = free_chain()
        fs, n = 500.0, 700
        u = band_limited_random(n, fs, 20.0, (0.0, 40.0), np.random.default_rng(5))
        el = dof_element(CoulombFriction(6.0), m, 0)
    tables = prepare_nonlinear(a, b, c, None, 1 / fs, [el])
    assert all(tables._arrays["dims"][:, 1] == tables._arrays["dims"][:, 0])  # all tabulated
    monkeypatch.setattr(nl, "_X_TABLE", 0.0)
    exps = prepare_nonlinear(a, b, c, None, 1 / fs, [el])
    dims = exps._arrays["dims"]
    assert np.all(dims[:, 3] == 0)  # no block tabulated
    if which == "modes":
        assert dims[0, 1] == 0  # slipping: no mode tabulated (a stuck s = 0 would be)
    else:
        assert tables.paths == ("block", "modal") and dims[0, 2] > 0
    r1 = tables.simulate(u, backend=ENGINE)
    r2 = exps.simulate(u, backend=ENGINE)
    assert r1.n_stick_events[0] >= 3 and r1.n_reversals[0] >= 3
    # both exact (the Taylor remainder of the tables is below 1e-18): rounding and event
    # times only
    sigma, extra = rounding.nonlinear(a, b, [el], u, 1 / fs, r1, c)
    rounding.check(r2.y, r1.y, sigma, extra=extra)
    rounding.detects(r1.y, sigma, extra)
    assert np.array_equal(r1.stuck, r2.stuck)


def test_two_friction_elements_and_a_force_feedthrough():
    """Two friction elements (four regimes). The last output is the acceleration of
    mass 2, which sees its friction force directly (``D_nl``): it must equal
    ``A[4] x + B[4] u + f_1 / m_2`` at every sample, and vanish while mass 2 is stuck
    (the holding force is exactly what keeps it at rest)."""
    m, a, b, _ = chain3()
    fs, n = 1000.0, 1000
    u = band_limited_random(n, fs, 60.0, (0.0, 60.0), np.random.default_rng(6))
    mi = np.linalg.inv(m)
    c = np.vstack([np.eye(6), a[4:5]])
    d = np.vstack([np.zeros((6, 1)), b[4:5]])
    els = []
    for dof, fc in ((1, 15.0), (2, 30.0)):
        el = dof_element(CoulombFriction(fc), m, dof)
        els.append(dataclasses.replace(el, output_column=np.r_[np.zeros(6), mi[1, dof]]))
    system = prepare_nonlinear(a, b, c, d, 1 / fs, els)
    assert system.n_regimes == 4
    res = system.simulate(u, backend=ENGINE)
    assert np.all(res.n_stick_events > 0)
    assert np.any(res.stuck[0, 100:] & res.stuck[1, 100:])  # both stuck at once
    acc = a[4] @ res.y[:6] + b[4, 0] * u[0] + mi[1, 1] * res.f_nl[0]
    scale = np.abs(res.y[6]).max()
    assert np.allclose(res.y[6], acc, rtol=0, atol=1e-10 * scale)
    assert np.all(np.abs(res.y[6, res.stuck[0]]) < 1e-9 * scale)
    assert np.all(np.abs(res.y[4, res.stuck[0]]) < 1e-12 * np.abs(res.y[4]).max())
    assert np.all(np.abs(res.y[5, res.stuck[1]]) < 1e-12 * np.abs(res.y[5]).max())
    for e, fc in enumerate((15.0, 30.0)):
        assert np.all(np.abs(res.f_nl[e, res.stuck[e]]) <= fc)
        assert np.allclose(np.abs(res.f_nl[e, ~res.stuck[e]]), fc)


# ----------------------------------------------------------------------------------
# the element registry and the API
# ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(LAWS))
def test_every_law_follows_the_protocol(name):
    cls = LAWS[name]
    fields = [f.name for f in dataclasses.fields(cls)]
    law = cls(*([1.0] * len(fields)))
    assert isinstance(law, NonlinearLaw)
    assert law.name == name
    assert dataclasses.is_dataclass(law)
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(law, fields[0], 2.0)
    p = law.params()
    assert len(p) == 2 and all(isinstance(v, float) for v in p)
    d = np.linspace(-2, 2, 7)
    f = law.force(d, d[::-1])
    assert f.shape == d.shape and np.all(np.isfinite(f))
    # every law opposes its own displacement or velocity (passive)
    assert np.all(f * (d if law.name in ("cubic_stiffness", "dead_band") else d[::-1]) <= 0)
    assert len({c.kind for c in LAWS.values()}) == len(LAWS)


def test_modal_element_layout():
    phi = np.array([0.3, -0.7, 0.2])
    el = NonlinearElement.modal(CoulombFriction(1.0), phi, output_column=[1.0, 2.0])
    assert np.array_equal(el.displacement_row, np.r_[phi, 0, 0, 0])
    assert np.array_equal(el.velocity_row, np.r_[0, 0, 0, phi])
    assert np.array_equal(el.force_column, np.r_[0, 0, 0, phi])
    assert not el.force_column.flags.writeable


def test_result_is_read_only_and_inputs_are_untouched():
    a, b, c, _ = sdof()
    u = band_limited_random(300, 100.0, 10.0, (0.0, 20.0), np.random.default_rng(0))
    u_copy, a_copy = u.copy(), a.copy()
    rows = np.array([1.0, 0.0])
    el = NonlinearElement(CoulombFriction(3.0), rows, [0.0, 1.0], [0.0, 1.0])
    res = simulate_nonlinear(a, b, c, None, u, 0.01, [el], backend=ENGINE)
    assert isinstance(res, NonlinearResult)
    assert np.array_equal(u, u_copy) and np.array_equal(a, a_copy)
    assert rows.flags.writeable and rows[0] == 1.0
    for arr in (res.y, res.f_nl, res.stuck, res.velocity):
        assert not arr.flags.writeable
    assert res.t_s[1] == pytest.approx(0.01)


def test_bad_laws_name_the_parameter():
    with pytest.raises(ValueError, match=r"CoulombFriction\.force_n must be >= 0"):
        CoulombFriction(-1.0)
    with pytest.raises(ValueError, match=r"DeadBand\.gap_m must be >= 0"):
        DeadBand(-0.1, 10.0)
    with pytest.raises(ValueError, match=r"DeadBand\.stiffness_n_m must be finite"):
        DeadBand(0.1, np.inf)
    with pytest.raises(ValueError, match=r"AmplitudeDependentDamping\.c2_n_s2_m2"):
        AmplitudeDependentDamping("a lot")
    with pytest.raises(ValueError, match=r"CubicStiffness\.k3_n_m3 must be finite"):
        CubicStiffness(np.nan)
    with pytest.raises(TypeError, match="NonlinearElement.law must be one of"):
        NonlinearElement("friction", [1.0], [1.0], [1.0])


def test_bad_elements_name_the_parameter():
    a, b, c, _ = sdof()
    u = np.zeros(10)
    good = dict(displacement_row=[1.0, 0.0], velocity_row=[0.0, 1.0], force_column=[0.0, 1.0])
    with pytest.raises(ModelError, match=r"elements\[0\]\.velocity_row has the wrong shape; "
                                         r"expected \(2,\)"):
        simulate_nonlinear(a, b, c, None, u, 0.01,
                           [NonlinearElement(CoulombFriction(1.0), **{**good,
                                                                     "velocity_row": [0, 1, 0]})])
    with pytest.raises(ModelError, match=r"displacement_row must be a 1-D vector"):
        NonlinearElement(CoulombFriction(1.0), **{**good, "displacement_row": np.eye(2)})
    with pytest.raises(ModelError, match=r"elements\[1\]\.output_column has the wrong shape"):
        simulate_nonlinear(a, b, c, None, u, 0.01, [
            NonlinearElement(CubicStiffness(1.0), **good),
            NonlinearElement(CubicStiffness(1.0), **good, output_column=[1.0]),
        ])
    with pytest.raises(ModelError, match=r"velocity_row @ force_column > 0"):
        simulate_nonlinear(a, b, c, None, u, 0.01, [
            NonlinearElement(CoulombFriction(1.0), **{**good, "force_column": [0.0, -1.0]})])
    with pytest.raises(ModelError, match="cannot all stick at once"):
        el = NonlinearElement(CoulombFriction(1.0), **good)
        prepare_nonlinear(a, b, c, None, 0.01, [el, el])
    with pytest.raises(TypeError, match=r"elements\[0\] must be a NonlinearElement"):
        simulate_nonlinear(a, b, c, None, u, 0.01, [CoulombFriction(1.0)])
    el = NonlinearElement(CoulombFriction(1.0), **good)
    with pytest.raises(ValueError, match="backend must be one of"):
        simulate_nonlinear(a, b, c, None, u, 0.01, [el], backend="fortran")
    with pytest.raises(ValueError, match="input u has the wrong number of rows"):
        simulate_nonlinear(a, b, c, None, np.zeros((2, 10)), 0.01, [el])
    with pytest.raises(ValueError, match="dt must be a positive"):
        simulate_nonlinear(a, b, c, None, u, -0.01, [el])
    with pytest.raises(ValueError, match="max_events_per_step must be a positive integer"):
        prepare_nonlinear(a, b, c, None, 0.01, [el]).simulate(u, max_events_per_step=0)


def test_event_limit_raises_convergence_error():
    """Two identical friction oscillators released together reverse in the same step:
    two events in one step; a limit of one per step is reported with the sample."""
    a1, b1, _, _ = sdof(zeta=0.0)
    a = np.kron(np.eye(2), a1)
    b = np.vstack([b1, b1])
    e = np.eye(4)
    els = [NonlinearElement(CoulombFriction(2.0), e[2 * i], e[2 * i + 1], e[2 * i + 1])
           for i in range(2)]
    system = prepare_nonlinear(a, b, e[[0, 2]], None, 1.3e-3, els)
    res = system.simulate(np.zeros(400), x0=[0.1, 0.0, 0.1, 0.0], backend=ENGINE)
    assert np.allclose(res.y[0], res.y[1], rtol=0, atol=1e-12) and res.n_reversals[0] > 0
    with pytest.raises(ConvergenceError, match=r"max_events_per_step=1 .* sample \d+"):
        system.simulate(np.zeros(400), x0=[0.1, 0.0, 0.1, 0.0], max_events_per_step=1,
                        backend=ENGINE)
