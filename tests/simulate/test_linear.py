"""Exact LTI simulation against python-control, scipy.signal and closed forms.

Tolerances: for first-order hold our output agrees with ``control.forced_response``
(which is exact for FOH too, computed by a different route) to better than
``1e-8 * rms(output)`` per channel; measured ~1e-13 for the modal systems and ~1e-10
for the free-free systems, where rounding accumulates in the marginally stable rigid
displacement (the state-space path shows the same difference to forced_response). The
numba and numpy engines agree to within the rounding of the recursion they both evaluate
(``engine_rounding_sigma`` in conftest.py: operation counts, the sizes of the terms and
the recursion's own growth; 6 sigma), whatever the CPU and its vector width.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import control
import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
import scipy.signal

from truthbench.errors import ModelError
from truthbench.simulate import (
    _kernels,
    discretize,
    numba_available,
    prepare_lti,
    simulate_lti,
    simulate_statespace,
)
from truthbench.simulate.excitation import band_limited_random

FOH_TOL = 1e-8
N = 3000

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba not installed")


def _input(sys_, seed=0, n=N):
    rng = np.random.default_rng(seed)
    fs = 1.0 / sys_.dt
    return band_limited_random(n, fs, 1.0, (0.0, 0.4 * fs), rng, sys_.B.shape[1])


def _x0(sys_, seed=1):
    return 0.1 * np.random.default_rng(seed).standard_normal(sys_.A.shape[0])


def _forced(sys_, u, x0=None):
    t = np.arange(u.shape[1]) * sys_.dt
    ss = control.ss(sys_.A, sys_.B, sys_.C, sys_.D)
    return control.forced_response(ss, t, u, X0=0 if x0 is None else x0).y


# ----------------------------------------------------------------------------------
# oracles
# ----------------------------------------------------------------------------------


@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_foh_matches_forced_response(system, rel_err, backend):
    if backend == "numba" and not numba_available():
        pytest.skip("numba not installed")
    u = _input(system)
    x0 = _x0(system)
    y = simulate_lti(system.A, system.B, system.C, system.D, u, system.dt, x0=x0, backend=backend)
    assert y.shape == (system.C.shape[0], N)
    assert rel_err(y, _forced(system, u, x0)) < FOH_TOL


def test_paths_chosen_as_designed(systems):
    paths = {name: prepare_lti(s.A, s.B, s.C, s.D, s.dt).path for name, s in systems.items()}
    assert paths == {
        "three_mode": "modal",
        "random_stable": "modal",
        "free_free": "block",
        "free_free_chain": "block",
        "modal_rigid": "block",
    }
    rec = prepare_lti(*(getattr(systems["free_free"], x) for x in "ABCD"), 1e-3)
    assert rec.n_block == 2 and rec.n_modes == 1  # rigid pair + one flexible pair
    rec = prepare_lti(*(getattr(systems["modal_rigid"], x) for x in "ABCD"), 1e-3)
    assert rec.n_block == 4 and rec.n_modes == 8  # two rigid pairs + eight flexible


@pytest.mark.parametrize("stiff", [False, True])
def test_critically_damped_mode_goes_to_block(rel_err, stiff):
    # a critically damped oscillator has a defective double eigenvalue at -3 != 0; next
    # to stiff modes (up to 1e5 rad/s) it must still not be mistaken for a rigid-body
    # cluster at 0
    rng = np.random.default_rng(8)
    omegas = np.geomspace(10.0, 1e5, 12) if stiff else np.array([10.0])
    flexible = [np.array([[0.0, 1.0], [-(w**2), -0.02 * w]]) for w in omegas]
    a = scipy.linalg.block_diag(np.array([[0.0, 1.0], [-9.0, -6.0]]), *flexible)
    n = a.shape[0]
    b, c = rng.standard_normal((n, 1)), rng.standard_normal((2, n))
    rec = prepare_lti(a, b, c, None, 0.01)
    assert (rec.path, rec.n_block, rec.n_modes) == ("block", 2, omegas.size)
    u = rng.standard_normal((1, 1000))
    ref = control.forced_response(control.ss(a, b, c, 0), np.arange(1000) * 0.01, u).y
    assert rel_err(rec.simulate(u), ref) < FOH_TOL


def test_rigid_body_motion_of_stiff_free_free_chain_is_exact(rel_err):
    # Oracle: momentum. With K 1 = C 1 = 0 (exact in floating point here: integer
    # stiffnesses), the centre of mass obeys x_cm'' = sum(F) / m_total whatever the
    # springs do, and for a piecewise-linear force its samples follow exactly from the
    # double-integrator recursion below. The rigid-body Jordan block is
    # ill-conditioned: forced_response (expm of A) drifts by ~1e-6..1e-4 relative on
    # such stiff models; the block path snaps the numerically-zero cluster to an exact
    # double integrator and stays at rounding level.
    rng = np.random.default_rng(9)
    n_mass = 20
    k = np.zeros((n_mass, n_mass))
    for i in range(n_mass - 1):
        e = np.zeros(n_mass)
        e[i], e[i + 1] = 1.0, -1.0
        k += 1e10 * (1 + i % 3) * np.outer(e, e)
    assert not np.any(k @ np.ones(n_mass))
    mass = 1e-3 * rng.uniform(0.5, 1.5, n_mass)
    m_inv = np.diag(1.0 / mass)
    a = np.block([[np.zeros((n_mass, n_mass)), np.eye(n_mass)], [-m_inv @ k, -m_inv @ k * 1e-6]])
    b = np.vstack([np.zeros((n_mass, 1)), m_inv[:, [0]]])
    c = np.zeros((2, 2 * n_mass))
    c[0, :n_mass] = mass / mass.sum()  # centre of mass
    c[1, :n_mass] = -mass / mass.sum()  # tip relative to the centre of mass
    c[1, n_mass - 1] += 1.0
    dt, n = 2.0**-18, 2**14
    u = rng.standard_normal((1, n))
    y = simulate_lti(a, b, c, None, u, dt)

    f = u[0] / mass.sum()
    x_cm = np.zeros(n)
    v_cm = 0.0
    for j in range(n - 1):
        x_cm[j + 1] = x_cm[j] + dt * v_cm + dt * dt * (f[j] / 3 + f[j + 1] / 6)
        v_cm += dt * (f[j] + f[j + 1]) / 2
    assert rel_err(y[0], x_cm) < 1e-10

    # flexible part, oracle: modal superposition from the symmetric eigenproblem
    # K phi = w^2 M phi (damping C = 1e-6 K is proportional), each mode simulated in its
    # own well-conditioned coordinates by forced_response. The physical-coordinate
    # output cancels ~6 orders of magnitude (flexible rms ~1e-6 of the rigid motion),
    # so every method (forced_response on the physical model included) lands near 1e-8.
    w2, phi = scipy.linalg.eigh(k, np.diag(mass))
    w, phi = np.sqrt(w2[1:]), phi[:, 1:]  # drop the rigid-body mode: no relative motion
    n_f = w.size
    a_m = scipy.linalg.block_diag(*[np.array([[0.0, 1.0], [-(x**2), -1e-6 * x**2]]) for x in w])
    b_m = np.zeros((2 * n_f, 1))
    b_m[1::2, 0] = phi[0]
    c_m = np.zeros((1, 2 * n_f))
    c_m[0, 0::2] = c[1, :n_mass] @ phi
    ref = control.forced_response(control.ss(a_m, b_m, c_m, 0), np.arange(n) * dt, u).y
    assert rel_err(y[1], ref[0]) < 1e-6


@pytest.mark.parametrize("method", ["auto", "state"])
def test_methods_agree_with_forced_response(system, rel_err, method):
    u = _input(system, seed=5)
    y = simulate_lti(system.A, system.B, system.C, system.D, u, system.dt, method=method)
    assert rel_err(y, _forced(system, u)) < FOH_TOL


def test_modal_method_forced(systems, rel_err):
    s = systems["three_mode"]
    u = _input(s)
    y = simulate_lti(s.A, s.B, s.C, s.D, u, s.dt, method="modal")
    assert rel_err(y, _forced(s, u)) < FOH_TOL


def test_zoh_matches_cont2discrete_dlsim(system, rel_err):
    u = _input(system, seed=2)
    x0 = _x0(system)
    ad, bd, cd, dd, _ = scipy.signal.cont2discrete(
        (system.A, system.B, system.C, system.D), system.dt, method="zoh"
    )
    t = np.arange(N) * system.dt
    _, ref, _ = scipy.signal.dlsim((ad, bd, cd, dd, system.dt), u.T, t=t, x0=x0)
    y = simulate_lti(system.A, system.B, system.C, system.D, u, system.dt, x0=x0, hold="zoh")
    assert rel_err(y, ref.T) < FOH_TOL


def test_foh_and_zoh_differ(systems, rel_err):
    s = systems["three_mode"]
    u = _input(s)
    y_foh = simulate_lti(s.A, s.B, s.C, s.D, u, s.dt, hold="foh")
    y_zoh = simulate_lti(s.A, s.B, s.C, s.D, u, s.dt, hold="zoh")
    # the inputs reach 0.4 fs: holding them constant over a step is a real (percent-level)
    # difference, far above rounding
    assert rel_err(y_zoh, y_foh) > 1e-2


def test_free_response_is_matrix_exponential(system, rel_err):
    x0 = _x0(system)
    u = np.zeros((system.B.shape[1], 400))
    y = simulate_lti(system.A, system.B, system.C, system.D, u, system.dt, x0=x0)
    t = np.arange(400) * system.dt
    ref = np.stack([system.C @ scipy.linalg.expm(system.A * tk) @ x0 for tk in t], axis=1)
    assert rel_err(y, ref) < 1e-9


def test_double_integrator_ramp_is_exact():
    # free mass m: q'' = F/m; a ramp force F = a t is exactly piecewise linear, so FOH
    # must give q = a t^3 / (6 m) at every sample; ZOH (staircase force) must not.
    m, slope, dt = 2.0, 3.0, 0.01
    a = np.array([[0.0, 1.0], [0.0, 0.0]])
    b = np.array([[0.0], [1.0 / m]])
    c = np.eye(2)
    t = np.arange(200) * dt
    u = slope * t[np.newaxis, :]
    exact = np.vstack([slope * t**3 / (6 * m), slope * t**2 / (2 * m)])
    for backend in ["numpy"] + (["numba"] if numba_available() else []):
        y = simulate_lti(a, b, c, None, u, dt, backend=backend)
        np.testing.assert_allclose(y, exact, rtol=1e-12, atol=1e-15)
    y_zoh = simulate_lti(a, b, c, None, u, dt, hold="zoh")
    assert np.max(np.abs(y_zoh - exact)) > 1e-3 * np.max(np.abs(exact))


def test_pure_integrator_modal_zero_eigenvalue():
    # a single integrator is diagonalisable with s = 0: the modal path's Taylor branch
    # must reproduce the trapezoidal rule, exact for FOH input
    rec = prepare_lti([[0.0]], [[2.0]], [[1.0]], [[0.0]], 0.1)
    assert rec.path == "modal"
    u = np.sin(np.arange(50) * 0.3)
    y = rec.simulate(u, backend="numpy")
    trap = 2.0 * np.concatenate([[0.0], np.cumsum(0.05 * (u[1:] + u[:-1]))])
    # both are running sums: the recursion adds w0 q_j + w1 q_j+1 (two products, two
    # additions), the oracle 0.05 (u_j + u_j+1) (an addition, a product, the cumsum's
    # addition; the factor 2 is exact). Each rounding is at most u times the running sum
    # plus the step's terms, and the errors add up over the steps (Higham, eq. 4.4)
    unit = np.finfo(float).eps / 2
    step = np.abs(trap[:-1]) + 0.1 * (np.abs(u[1:]) + np.abs(u[:-1]))
    bound = (4 + 3) * unit * np.concatenate([[0.0], np.cumsum(step)])
    assert np.all(np.abs(y[0] - trap) <= bound)
    assert np.max(bound) < 1e-12 * np.max(np.abs(trap))  # a 1e-12 error would show


def test_discretize_against_quadrature(systems):
    s = systems["three_mode"]
    dt = 2e-3
    ad, bd0, bd1 = discretize(s.A, s.B, dt, "foh")
    np.testing.assert_allclose(ad, scipy.linalg.expm(s.A * dt), rtol=1e-12, atol=1e-14)

    def kernel(tau, weight):
        return (scipy.linalg.expm(s.A * (dt - tau)) @ s.B * weight(tau)).ravel()

    ref1, _ = scipy.integrate.quad_vec(
        lambda tau: kernel(tau, lambda x: x / dt), 0, dt, epsabs=1e-16, epsrel=1e-13
    )
    ref0, _ = scipy.integrate.quad_vec(
        lambda tau: kernel(tau, lambda x: 1 - x / dt), 0, dt, epsabs=1e-16, epsrel=1e-13
    )
    np.testing.assert_allclose(bd1.ravel(), ref1, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(bd0.ravel(), ref0, rtol=1e-9, atol=1e-15)
    ad_z, bd_z, bd1_z = discretize(s.A, s.B, dt, "zoh")
    ref = scipy.signal.cont2discrete((s.A, s.B, s.C, s.D), dt, method="zoh")
    np.testing.assert_allclose(ad_z, ref[0], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(bd_z, ref[1], rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(bd0 + bd1, bd_z, rtol=1e-12, atol=1e-16)
    assert not np.any(bd1_z)


def test_statespace_wrapper(systems, rel_err):
    s = systems["random_stable"]
    u = _input(s)
    ss = control.ss(s.A, s.B, s.C, s.D)
    y = simulate_statespace(ss, u, s.dt)
    assert rel_err(y, _forced(s, u)) < FOH_TOL
    with pytest.raises(TypeError, match="sys must be a control.StateSpace"):
        simulate_statespace(control.tf([1], [1, 1]), u[:1], s.dt)
    with pytest.raises(ValueError, match="continuous-time"):
        simulate_statespace(control.ss(0.5, 1, 1, 0, dt=0.1), u[:1], s.dt)


def test_prepared_recursion_reusable_and_readonly(systems, rel_err):
    s = systems["three_mode"]
    rec = prepare_lti(s.A, s.B, s.C, s.D, s.dt)
    for seed in (0, 1):
        u = _input(s, seed=seed)
        assert rel_err(rec.simulate(u), _forced(s, u)) < FOH_TOL
    assert not rec.lam.flags.writeable
    with pytest.raises(AttributeError):
        rec.dt = 1.0  # frozen


def test_inputs_not_modified(systems):
    s = systems["free_free"]
    arrays = [s.A.copy(), s.B.copy(), s.C.copy(), s.D.copy(), _input(s), _x0(s)]
    copies = [x.copy() for x in arrays]
    for x in arrays:
        x.setflags(write=False)  # would raise if anything wrote into them
    simulate_lti(*arrays[:5], s.dt, x0=arrays[5])
    simulate_lti(*arrays[:5], s.dt, x0=arrays[5], method="state", backend="numpy")
    discretize(arrays[0], arrays[1], s.dt)
    for x, c in zip(arrays, copies, strict=True):
        np.testing.assert_array_equal(x, c)


def test_one_dimensional_input_and_column_x0(systems):
    s = systems["three_mode"]
    u = _input(s)
    x0 = _x0(s)
    y1 = simulate_lti(s.A, s.B, s.C, s.D, u[0], s.dt, x0=x0[:, None])
    y2 = simulate_lti(s.A, s.B, s.C, s.D, u, s.dt, x0=x0)
    np.testing.assert_array_equal(y1, y2)


def test_static_and_no_input_systems():
    d = np.array([[2.0, -1.0]])
    u = np.random.default_rng(0).standard_normal((2, 10))
    y = simulate_lti(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), d, u, 0.1)
    np.testing.assert_allclose(y, d @ u)
    # no inputs at all: free response only
    a = np.array([[-1.0, 5.0], [-5.0, -1.0]])
    x0 = np.array([1.0, 0.0])
    t = np.arange(20) * 0.05
    ref = np.stack([scipy.linalg.expm(a * tk) @ x0 for tk in t], axis=1)
    for backend in ["numpy"] + (["numba"] if numba_available() else []):
        y = simulate_lti(
            a, np.zeros((2, 0)), np.eye(2), None, np.zeros((0, 20)), 0.05, x0=x0, backend=backend
        )
        np.testing.assert_allclose(y, ref, rtol=1e-12, atol=1e-14)


def test_numpy_engine_mode_grouping(systems, monkeypatch, rounding):
    # memory-bounded grouping of modes must not change the result beyond the rounding of
    # the output sum (the modal states are the same bits; the rounding model of the
    # whole recursion bounds it)
    s = systems["free_free_chain"]
    u = _input(s)
    rec = prepare_lti(s.A, s.B, s.C, s.D, s.dt)
    y_all = rec.simulate(u, backend="numpy")
    monkeypatch.setattr(_kernels, "_MAX_MODAL_CHUNK", 2 * N)  # two modes per group
    y_grouped = rec.simulate(u, backend="numpy")
    sigma = rounding.sigma(rec, u)
    rounding.check(y_grouped, y_all, sigma)
    rounding.detects(y_all, sigma)


# ----------------------------------------------------------------------------------
# engines
# ----------------------------------------------------------------------------------


@needs_numba
@pytest.mark.parametrize("method", ["auto", "state"])
@pytest.mark.parametrize("hold", ["foh", "zoh"])
def test_numba_equals_numpy(system, method, hold, rounding):
    u = _input(system, seed=7)
    rec = prepare_lti(system.A, system.B, system.C, system.D, system.dt, hold=hold, method=method)
    x0 = _x0(system)
    y_nb = rec.simulate(u, x0=x0, backend="numba")
    y_np = rec.simulate(u, x0=x0, backend="numpy")
    rounding.check(y_nb, y_np, rounding.sigma(rec, u, x0))


@pytest.mark.parametrize("method", ["auto", "state"])
@pytest.mark.parametrize("hold", ["foh", "zoh"])
def test_engine_rounding_bound_catches_a_1e_9_error(system, method, hold, rounding):
    # the bound of test_numba_equals_numpy is no blanket: an error of 1e-9 of the RMS in
    # one sample of any one output, anywhere in the record, is outside it
    u = _input(system, seed=7)
    rec = prepare_lti(system.A, system.B, system.C, system.D, system.dt, hold=hold, method=method)
    x0 = _x0(system)
    y = rec.simulate(u, x0=x0, backend="numpy")
    sigma = rounding.sigma(rec, u, x0)
    rounding.check(y, y, sigma)
    rms = np.sqrt(np.mean(y**2, axis=1))
    for o in range(y.shape[0]):
        for j in (1, N // 2, N - 1):
            bad = y.copy()
            bad[o, j] += 1e-9 * rms[o]
            with pytest.raises(AssertionError, match="sigma of rounding"):
                rounding.check(bad, y, sigma)


@needs_numba
def test_numba_many_outputs_and_inputs(rounding):
    # more than four outputs exercises the kernel's extra output groups
    rng = np.random.default_rng(11)
    n = 10
    a = rng.standard_normal((n, n))
    a -= (np.max(np.linalg.eigvals(a).real) + 0.1) * np.eye(n)
    b, c, d = rng.standard_normal((n, 3)), rng.standard_normal((9, n)), rng.standard_normal((9, 3))
    u = rng.standard_normal((3, 500))
    rec = prepare_lti(a, b, c, d, 0.05)
    y_nb = rec.simulate(u, backend="numba")
    y_np = rec.simulate(u, backend="numpy")
    assert np.array_equal(y_nb, simulate_lti(a, b, c, d, u, 0.05, backend="numba"))
    sigma = rounding.sigma(rec, u)
    rounding.check(y_nb, y_np, sigma)
    rounding.detects(y_np, sigma)


@pytest.mark.slow
def test_works_without_numba():
    code = textwrap.dedent(
        """
        import sys
        sys.modules["numba"] = None  # make "import numba" fail
        import numpy as np
        from truthbench.simulate import numba_available, simulate_lti
        assert not numba_available()
        a = np.array([[0.0, 1.0], [-100.0, -0.2]])
        b = np.array([[0.0], [1.0]])
        u = np.sin(np.arange(100) * 0.1)[None, :]
        y = simulate_lti(a, b, np.eye(2), None, u, 0.01)
        y_np = simulate_lti(a, b, np.eye(2), None, u, 0.01, backend="numpy")
        assert np.array_equal(y, y_np)
        try:
            simulate_lti(a, b, np.eye(2), None, u, 0.01, backend="numba")
        except ImportError as exc:
            assert "numba" in str(exc)
        else:
            raise AssertionError("no ImportError")
        print("ok")
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


# ----------------------------------------------------------------------------------
# errors
# ----------------------------------------------------------------------------------


def _good(systems):
    s = systems["three_mode"]
    return dict(A=s.A, B=s.B, C=s.C, D=s.D, u=np.zeros((1, 10)), dt=s.dt)


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        (
            dict(u=np.zeros((2, 10))),
            ValueError,
            r"input u has the wrong number of rows; expected 1 .* instead of 2",
        ),
        (dict(u=np.zeros((1, 10, 1))), ValueError, r"input u must have shape"),
        (
            dict(u=np.array([[0.0, np.nan, 1.0]])),
            ValueError,
            r"input u must be finite; got a non-finite value at row 0, sample 1",
        ),
        (dict(u=np.array([[0.0, np.inf]])), ValueError, r"input u must be finite"),
        (dict(u=np.zeros((1, 0))), ValueError, r"at least one sample"),
        (dict(u=np.zeros((1, 3), complex)), ValueError, r"input u must be real"),
        (dict(dt=0.0), ValueError, r"dt must be a positive finite time step in s; got 0.0"),
        (dict(dt=-1e-3), ValueError, r"dt must be a positive finite"),
        (dict(dt=np.nan), ValueError, r"dt must be a positive finite"),
        (dict(dt="fast"), ValueError, r"dt must be a positive finite"),
        (dict(A=np.zeros((6, 5))), ModelError, r"matrix A must be square; got shape \(6, 5\)"),
        (dict(A=np.zeros(6)), ModelError, r"matrix A must be 2-D"),
        (
            dict(B=np.zeros((5, 1))),
            ModelError,
            r"matrix B has the wrong number of rows; expected 6 instead of 5",
        ),
        (
            dict(C=np.zeros((2, 4))),
            ModelError,
            r"matrix C has the wrong number of columns; expected 6 instead of 4",
        ),
        (
            dict(D=np.zeros((3, 1))),
            ModelError,
            r"matrix D has the wrong number of rows; expected 2 instead of 3",
        ),
        (
            dict(D=np.zeros((2, 2))),
            ModelError,
            r"matrix D has the wrong number of columns; expected 1 instead of 2",
        ),
        (dict(A=np.full((6, 6), np.nan)), ModelError, r"matrix A contains non-finite"),
        (dict(A=np.eye(6) * 1j), ModelError, r"matrix A must be real"),
    ],
)
def test_errors(systems, change, error, match):
    args = {**_good(systems), **change}
    with pytest.raises(error, match=match):
        simulate_lti(args["A"], args["B"], args["C"], args["D"], args["u"], args["dt"])


def test_option_errors(systems):
    g = _good(systems)
    base = (g["A"], g["B"], g["C"], g["D"], g["u"], g["dt"])
    with pytest.raises(ValueError, match=r"hold must be 'foh' or 'zoh'; got 'linear'"):
        simulate_lti(*base, hold="linear")
    with pytest.raises(ValueError, match=r"method must be one of .*; got 'exact'"):
        simulate_lti(*base, method="exact")
    with pytest.raises(ValueError, match=r"backend must be one of .*; got 'gpu'"):
        simulate_lti(*base, backend="gpu")
    with pytest.raises(ValueError, match=r"initial state x0 must have shape \(6,\); got"):
        simulate_lti(*base, x0=np.zeros(5))
    with pytest.raises(ValueError, match=r"initial state x0 must be finite"):
        simulate_lti(*base, x0=np.full(6, np.inf))
    with pytest.raises(ModelError, match=r"matrix A must be square"):
        discretize(np.zeros((2, 3)), np.zeros((2, 1)), 0.1)
    with pytest.raises(ModelError, match=r"matrix B has the wrong number of rows; expected 2"):
        discretize(np.zeros((2, 2)), np.zeros((3, 1)), 0.1)
    with pytest.raises(ValueError, match=r"hold must be"):
        discretize(np.zeros((2, 2)), np.zeros((2, 1)), 0.1, hold="cubic")


def test_modal_method_refuses_defective_a(systems):
    s = systems["free_free"]
    with pytest.raises(ValueError, match=r"method='modal' needs a diagonalisable A"):
        prepare_lti(s.A, s.B, s.C, s.D, s.dt, method="modal")
