"""Finite-difference FRF updating (Eq. 10.12-10.21)."""

import numpy as np
import pytest

from truthbench.errors import IdentifiabilityError
from truthbench.plants import Actuator, Sensor, make_plant
from truthbench.update import finite_difference_update, sensitivity_matrix

FREQ = np.linspace(5.0, 400.0, 300)


def _predictor(plant, actuators, sensors):
    def predict(theta):
        return plant.build(theta, actuators, sensors).frf(FREQ)
    return predict


def test_linear_problem_matches_numpy_lstsq():
    """For G linear in the relative parameters the iteration (in log-parameters)
    converges to the weighted least-squares solution; compare with numpy.linalg.lstsq."""
    rng = np.random.default_rng(0)
    X = rng.normal(size=(50, 3)) + 1j * rng.normal(size=(50, 3))
    theta0 = {"a": 2.0, "b": -1.0, "c": 0.5}
    names = ("a", "b", "c")

    def predict(th):
        p = np.array([th[n] / theta0[n] - 1 for n in names])
        return X @ p

    target = np.array([0.1, -0.2, 0.05])
    data = X @ target + 0.01 * rng.normal(size=50)
    w = rng.uniform(0.5, 2.0, size=50)
    res = finite_difference_update(predict, data, theta0, names, n_pairs=4, weights=w,
                                   scheme="forward", tolerance=1e-10, max_iterations=30)
    A = np.vstack([(X * w[:, None]).real, (X * w[:, None]).imag])
    b = np.concatenate([(w * data).real, (w * data).imag])
    expected = np.linalg.lstsq(A, b, rcond=None)[0]
    got = np.array([res.values[i] / theta0[n] - 1 for i, n in enumerate(names)])
    np.testing.assert_allclose(got, expected, rtol=1e-8, atol=1e-12)


@pytest.mark.slow
def test_recovers_E_and_rho_from_exact_truth_frfs():
    plant = make_plant("free_free_beam", n_elements=12)
    acts, sens = [Actuator("end_a", "z")], [Sensor("end_a", "z"), Sensor("mid", "z"),
                                            Sensor("end_b", "z")]
    predict = _predictor(plant, acts, sens)
    nominal = plant.resolve()
    truth = {**nominal, "E_pa": nominal["E_pa"] * 1.04, "rho_kg_m3": nominal["rho_kg_m3"] * 0.97}
    res = finite_difference_update(predict, predict(truth), nominal, ["E_pa", "rho_kg_m3"],
                                   n_pairs=3)
    assert res.converged
    np.testing.assert_allclose(res.values, [truth["E_pa"], truth["rho_kg_m3"]], rtol=1e-6)
    assert res.cost_history[-1] < 1e-12 * res.cost_history[0]
    assert res.singular_values.shape == (2,) and res.condition_number >= 1


def test_thickness_beside_E_and_rho_is_reported_unidentifiable():
    plant = make_plant("free_free_beam", n_elements=8)
    acts, sens = [Actuator("end_a", "z")], [Sensor("end_a", "z"), Sensor("mid", "z"),
                                            Sensor("end_b", "z"), Sensor("quarter", "z")]
    predict = _predictor(plant, acts, sens)
    nominal = plant.resolve()
    with pytest.raises(IdentifiabilityError, match=r"cannot be separated.*t_m"):
        finite_difference_update(predict, predict(nominal), nominal,
                                 ["E_pa", "rho_kg_m3", "t_m"], n_pairs=4)


def test_finite_difference_orders():
    """Central differences converge as h^2 and forward differences as h against a
    fine-step reference (error ratio about 4 and 2 per doubling of the step)."""
    plant = make_plant("free_free_beam", n_elements=8)
    predict = _predictor(plant, [Actuator("end_a", "z")], [Sensor("mid", "z")])
    nominal = plant.resolve()
    ref, _ = sensitivity_matrix(predict, nominal, ["E_pa"], relative_step=1e-6)

    def err(h, scheme):
        S, _ = sensitivity_matrix(predict, nominal, ["E_pa"], relative_step=h, scheme=scheme)
        return np.linalg.norm(S - ref)

    assert err(2e-3, "central") / err(1e-3, "central") == pytest.approx(4.0, rel=0.1)
    assert err(2e-3, "forward") / err(1e-3, "forward") == pytest.approx(2.0, rel=0.1)


def test_m_r_not_greater_than_p_raises():
    with pytest.raises(IdentifiabilityError, match=r"m r = 2 for p = 2"):
        finite_difference_update(lambda th: np.zeros(3), np.zeros(3), {"a": 1.0, "b": 1.0},
                                 ["a", "b"], n_pairs=2)


def test_bad_arguments():
    with pytest.raises(ValueError, match="not model parameters"):
        finite_difference_update(lambda th: np.zeros(3), np.zeros(3), {"a": 1.0}, ["z"],
                                 n_pairs=3)
    with pytest.raises(ValueError, match="weights must have"):
        finite_difference_update(lambda th: np.zeros(3), np.zeros(3), {"a": 1.0}, ["a"],
                                 n_pairs=3, weights=np.ones(2))


def test_additive_parameter_starts_at_zero():
    """A pure delay tau on a known FRF, updated additively from tau = 0 (a relative
    update cannot leave 0): recovered to 1e-9 s, with the column scaled per unit of the
    additive scale (one radian at the top of the band)."""
    f = np.linspace(1.0, 100.0, 200)
    G = 1.0 / (1 + 1j * f / 30.0)

    def predict(theta):
        return theta["gain"] * G * np.exp(-2j * np.pi * f * theta["delay_s"])

    data = predict({"gain": 1.2, "delay_s": 0.0012})
    scale = 1 / (2 * np.pi * 100.0)
    res = finite_difference_update(predict, data, {"gain": 1.0, "delay_s": 0.0},
                                   ["gain", "delay_s"], n_pairs=3,
                                   additive={"delay_s": scale}, tolerance=1e-12)
    assert res.converged
    assert res.as_dict()["delay_s"] == pytest.approx(0.0012, abs=1e-9)
    assert res.as_dict()["gain"] == pytest.approx(1.2, rel=1e-9)
    S, _ = sensitivity_matrix(predict, {"gain": 1.0, "delay_s": 0.0}, ["delay_s"],
                              additive={"delay_s": scale})
    np.testing.assert_allclose(S[:, 0], -2j * np.pi * f * scale * G, rtol=1e-6)
    with pytest.raises(ValueError, match="non-zero starting values.*delay_s.*additive"):
        finite_difference_update(predict, data, {"gain": 1.0, "delay_s": 0.0},
                                 ["gain", "delay_s"], n_pairs=3)
    with pytest.raises(ValueError, match="additive scales must be positive"):
        finite_difference_update(predict, data, {"gain": 1.0, "delay_s": 0.0},
                                 ["gain", "delay_s"], n_pairs=3, additive={"delay_s": -1})


# ---- the structured secant (quasi-Newton) step and the start ---------------------------
def _exponential_problem(y3):
    """Dennis and Schnabel's large-residual example (Numerical Methods for Unconstrained
    Optimization, Example 10.2.4): ``exp(k t)`` fitted to ``y = (2, 4, y3)`` at
    ``t = (1, 2, 3)``; the residual at the minimum grows as ``y3`` leaves 8, and with it
    the Hessian term that Gauss-Newton leaves out. Returns predict (with its analytic
    Jacobian), the data and scipy's minimum of ``log k`` (the update's variable)."""
    from scipy.optimize import least_squares

    t = np.array([1.0, 2.0, 3.0])
    data = np.array([2.0, 4.0, y3])

    def predict(th):
        return np.exp(t * th["k"])

    predict.jacobian = lambda th, names, additive=None: (
        t * th["k"] * np.exp(t * th["k"]))[:, None]
    ref = least_squares(lambda x: data - np.exp(t * 0.7 * np.exp(x[0])), [0.0],
                        jac=lambda x: -(t * 0.7 * np.exp(x[0])
                                        * np.exp(t * 0.7 * np.exp(x[0])))[:, None],
                        method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return predict, data, float(ref.x[0])


def test_secant_curvature_satisfies_the_secant_equation():
    """The updated curvature term T is symmetric and maps the step to
    ``y# = (A_old - A)^T b`` (Dennis-Gay-Welsch), whatever T was; a step along which the
    gradient does not grow (s^T y <= 0) drops it."""
    from truthbench.update.finite_difference import secant_curvature

    rng = np.random.default_rng(3)
    A_old, A = rng.normal(size=(40, 3)), rng.normal(size=(40, 3))
    b_old, b = rng.normal(size=40), rng.normal(size=40)
    T0 = rng.normal(size=(3, 3))
    T0 = T0 + T0.T
    g_old, g = A_old.T @ b_old, A.T @ b
    y = g_old - g
    step = y + 0.1 * rng.normal(size=3)  # s^T y > 0
    assert step @ y > 0
    T = secant_curvature(T0, step, g_old, g, A_old.T @ b)
    # O(1) numbers through a few dozen operations: rounding about 1e-15
    np.testing.assert_allclose(T, T.T, rtol=0, atol=1e-13)
    np.testing.assert_allclose(T @ step, (A_old - A).T @ b, rtol=1e-12, atol=1e-12)
    assert not np.any(secant_curvature(T0, -y, g_old, g, A_old.T @ b))


def test_large_residual_converges_to_scipy_minimum_faster_than_gauss_newton(monkeypatch):
    """y3 = 0: Gauss-Newton converges linearly at |1 - H / (A^T A)| = 0.27 at the
    minimum; with the secant's curvature the same minimum (scipy's least_squares) is
    reached in fewer iterations. The cost comparisons resolve log k to about
    sqrt(2 eps J / H) = 4e-8 (J = 10.2 the cost at the minimum, H = 2.5 its second
    derivative in log k), far inside the 1e-6 asserted."""
    import truthbench.update.finite_difference as fd

    predict, data, x_ref = _exponential_problem(0.0)
    kw = dict(n_pairs=None, tolerance=1e-10, max_iterations=100)
    qn = finite_difference_update(predict, data, {"k": 0.7}, ["k"], **kw)
    monkeypatch.setattr(fd, "secant_curvature", lambda T, *args: np.zeros_like(T))
    gn = finite_difference_update(predict, data, {"k": 0.7}, ["k"], **kw)
    for res in (qn, gn):
        assert res.converged
        assert np.log(res.values[0] / 0.7) == pytest.approx(x_ref, abs=1e-6)
    # at 0.27 per iteration, from 0.1 to 1e-10 takes log(1e-9) / log(0.27) = 16
    # iterations (the first steps, from 1.4 away, are cut to the 0.5 trust region)
    assert gn.n_iterations >= int(np.log(1e-9) / np.log(0.271))
    assert qn.n_iterations <= gn.n_iterations - 4


def test_start_is_used_when_it_fits_better():
    """``start`` at the minimum: history[0] stays theta0 (``initial``), history[1] is the
    start and the iteration ends there; a start that fits worse than theta0 is not
    used; a non-positive start of a relative parameter is refused."""
    predict, data, x_ref = _exponential_problem(3.0)
    k_min = 0.7 * np.exp(x_ref)
    res = finite_difference_update(predict, data, {"k": 0.7}, ["k"], n_pairs=None,
                                   start={"k": k_min})
    assert res.converged and res.initial[0] == 0.7 and res.history[1, 0] == k_min
    assert res.n_iterations <= 3
    assert res.values[0] == pytest.approx(k_min, rel=1e-6)
    plain = finite_difference_update(predict, data, {"k": 0.7}, ["k"], n_pairs=None)
    worse = finite_difference_update(predict, data, {"k": 0.7}, ["k"], n_pairs=None,
                                     start={"k": 5.0})
    np.testing.assert_array_equal(worse.history, plain.history)
    with pytest.raises(ValueError, match="start values"):
        finite_difference_update(predict, data, {"k": 0.7}, ["k"], n_pairs=None,
                                 start={"k": -1.0})


def test_triangular_factor_from_the_normal_equations_matches_householder_qr():
    """R and Q^T b of the stacked real and imaginary parts: from the normal equations
    for a well-conditioned matrix (R^T R = A^T A and the least-squares solution
    R^-1 Q^T b agree with numpy's QR and lstsq to cond^2 eps, cond = 20 here), and by
    the QR itself for one whose scaled condition exceeds NORMAL_COND_MAX."""
    from truthbench.update.finite_difference import (
        NORMAL_COND_MAX,
        _stack,
        _triangular_factor,
    )

    rng = np.random.default_rng(7)
    Sw = rng.normal(size=(5000, 3)) + 1j * rng.normal(size=(5000, 3))
    Sw[:, 1] = 1e6 * (Sw[:, 1] + 0.9 * Sw[:, 0])  # very different column norms
    r = rng.normal(size=5000) + 1j * rng.normal(size=5000)
    A, b = _stack(Sw), _stack(r)
    R, Qb = _triangular_factor(Sw, r)
    scaled = A / np.linalg.norm(A, axis=0)
    cond = np.linalg.cond(scaled)
    assert cond < 20
    tol = 10 * cond**2 * np.finfo(float).eps
    np.testing.assert_allclose(R.T @ R, A.T @ A, rtol=tol,
                               atol=tol * np.abs(A.T @ A).max())
    # the solutions in the scaled variables (each column's norm times its entry)
    norms = np.linalg.norm(A, axis=0)
    x_ref = np.linalg.lstsq(A, b, rcond=None)[0] * norms
    x = np.linalg.solve(R, Qb) * norms
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=tol * np.abs(x_ref).max())
    # nearly collinear columns: the Householder QR, exactly as numpy's
    Sw[:, 2] = Sw[:, 0] + 1e-5 * Sw[:, 2]
    A = _stack(Sw)
    assert np.linalg.cond(A / np.linalg.norm(A, axis=0)) > NORMAL_COND_MAX
    R, Qb = _triangular_factor(Sw, r)
    Q, R_ref = np.linalg.qr(A)
    np.testing.assert_array_equal(R, R_ref)
    np.testing.assert_array_equal(Qb, Q.T @ b)
