"""Sensor placement: shape-sensitivity ranking (Eq. 10.45) and the observability gramian."""

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.integrate import trapezoid

from truthbench.errors import ModelError
from truthbench.model import StructuralModel, modal_system, solve_modes
from truthbench.placement import (
    greedy_d_optimal,
    modal_candidate_system,
    modal_gramian_contributions,
    observability_gramian,
    rank_sensors_by_gramian,
    rank_sensors_by_sensitivity,
    shape_sensitivities,
)

# ---- a planar Euler-Bernoulli beam (textbook Hermite element), written here -----------


def _element(EI, rhoA, L):
    k = EI / L**3 * np.array([[12, 6 * L, -12, 6 * L], [6 * L, 4 * L**2, -6 * L, 2 * L**2],
                              [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L**2, -6 * L, 4 * L**2]])
    m = rhoA * L / 420 * np.array([[156, 22 * L, 54, -13 * L],
                                   [22 * L, 4 * L**2, 13 * L, -3 * L**2],
                                   [54, 13 * L, 156, -22 * L],
                                   [-13 * L, -3 * L**2, -22 * L, 4 * L**2]])
    return k, m


def _beam_builder(n_el=20, n_groups=5, clamped=False):
    """``theta`` = EI of each group (N m^2); unit length 1 m, rho A = 1 kg/m."""
    per = n_el // n_groups

    def build(theta):
        n = 2 * (n_el + 1)
        K, M = np.zeros((n, n)), np.zeros((n, n))
        for e in range(n_el):
            k, m = _element(theta[e // per], 1.0, 1.0 / n_el)
            K[2 * e:2 * e + 4, 2 * e:2 * e + 4] += k
            M[2 * e:2 * e + 4, 2 * e:2 * e + 4] += m
        return (M[2:, 2:], K[2:, 2:]) if clamped else (M, K)

    return build


# ---- shape sensitivities ---------------------------------------------------------------


def _chain(theta):
    """4-DOF spring-mass chain fixed at one end: theta = (k1, k2, k3, k4, m3)."""
    k = theta[:4]
    K = np.zeros((4, 4))
    for i, ki in enumerate(k):
        K[i, i] += ki
        if i > 0:
            K[i - 1, i - 1] += ki
            K[i - 1, i] -= ki
            K[i, i - 1] -= ki
    M = np.diag([1.0, 2.0, theta[4], 1.5])
    return M, K


def test_finite_differences_match_fox_kapoor_exact_full_basis():
    theta = np.array([1000.0, 800.0, 1200.0, 500.0, 1.2])
    sens = shape_sensitivities(_chain, theta)
    M, K = _chain(theta)
    lam, Phi = sla.eigh(K, M)
    Phi = Phi * np.sign(Phi[np.argmax(np.abs(Phi), axis=0), range(4)])
    h = 1.0  # the chain is linear in theta: an exact difference
    for j in range(5):
        e = np.zeros(5)
        e[j] = 1.0
        Mp, Kp = _chain(theta + h * e)
        dK, dM = (Kp - K) / h, (Mp - M) / h
        for i in range(4):
            # Fox and Kapoor (1968), all modes: exact for a full modal basis
            ref = -0.5 * (Phi[:, i] @ dM @ Phi[:, i]) * Phi[:, i]
            for k in range(4):
                if k != i:
                    ref = ref + (Phi[:, k] @ (dK - lam[i] * dM) @ Phi[:, i]) / (
                        lam[i] - lam[k]) * Phi[:, k]
            np.testing.assert_allclose(sens.dphi[:, i, j], ref, rtol=1e-5,
                                       atol=1e-6 * np.abs(ref).max())
            dlam = Phi[:, i] @ (dK - lam[i] * dM) @ Phi[:, i]
            assert sens.domega_rad_s[i, j] == pytest.approx(dlam / (2 * np.sqrt(lam[i])),
                                                            rel=1e-6)


def test_free_free_default_skips_rigid_modes_and_rejects_repeated():
    build = _beam_builder(n_el=10, n_groups=2)
    sens = shape_sensitivities(build, np.ones(2), n_modes=8)
    assert sens.mode_indices.tolist() == [2, 3, 4, 5, 6, 7]  # two planar rigid modes
    with pytest.raises(ModelError, match="mode 0 .* repeated"):
        shape_sensitivities(build, np.ones(2), modes=[0], n_modes=8)
    with pytest.raises(ModelError, match="abs_step"):
        shape_sensitivities(build, np.array([1.0, 0.0]))


def test_score_and_greedy_by_hand():
    # DOF 0 and 1 see parameter 0 identically; DOF 2 sees only parameter 1, weakly
    dphi = np.zeros((3, 1, 2))
    dphi[0, 0, 0] = 2.0
    dphi[1, 0, 0] = 2.0
    dphi[2, 0, 1] = 1.0
    r = rank_sensors_by_sensitivity(dphi, sigma=[1.0, 0.5], labels=["a", "b", "c"])
    np.testing.assert_allclose(r.scores, [2.0, 2.0, 0.5])
    assert r.ranked_labels == ("a", "b", "c")
    # the greedy D-optimal set skips the redundant "b" for "c", though "c" scores lower
    assert r.selected_labels == ("a", "c")
    two_modes = np.concatenate([dphi, 3 * dphi], axis=1)
    r2 = rank_sensors_by_sensitivity(two_modes, [1.0, 0.5], modes=[1], mode_weights=[4.0])
    np.testing.assert_allclose(r2.scores, 3 * 2 * np.array([2.0, 2.0, 0.5]))
    df = r.to_pandas()
    assert list(df.index) == ["a", "b", "c"]
    assert df.loc["c", "selection_step"] == 2 and df.loc["b", "selection_step"] == 0


def test_beam_e_change_at_an_end_moves_that_end_most_and_symmetry():
    n_el, n_g = 20, 5
    sens = shape_sensitivities(_beam_builder(n_el, n_g), np.ones(n_g))
    trans = np.arange(0, 2 * (n_el + 1), 2)  # translation DOFs, nodes 0..n_el
    D = sens.dphi[trans][:, :3]  # three lowest bending modes
    scores = []
    for g in range(n_g):
        sigma = np.zeros(n_g)
        sigma[g] = 0.05  # 5 % EI uncertainty in group g only
        scores.append(rank_sensors_by_sensitivity(D, sigma).scores)
    scores = np.array(scores)
    # an EI change in the end group moves that free end most
    assert np.argmax(scores[0]) == 0 and np.argmax(scores[-1]) == n_el
    # mirror symmetry of the free-free beam: group g <-> group n_g-1-g, node x <-> L - x
    np.testing.assert_allclose(scores, scores[::-1, ::-1], rtol=1e-5, atol=1e-9)


def test_plant_sparse_matrices_and_mirror_symmetry():
    from truthbench.plants import make_plant

    plant = make_plant("free_free_beam", n_elements=10, n_groups=2)
    E = 68.9e9

    def build(theta):
        m = plant.build({"E_pa@g1": theta[0], "E_pa@g2": theta[1]})
        return m.M, m.K  # sparse

    sens = shape_sensitivities(build, [E, E], n_modes=12)
    labels = plant.build().dof_labels
    z = [i for i, lab in enumerate(labels) if lab.endswith(".z")]  # nodes 0..10
    s1 = rank_sensors_by_sensitivity(sens.dphi[z], [0.03 * E, 0.0]).scores
    s2 = rank_sensors_by_sensitivity(sens.dphi[z], [0.0, 0.03 * E]).scores
    np.testing.assert_allclose(s1, s2[::-1], rtol=1e-4, atol=1e-6 * s1.max())


# ---- observability gramian -------------------------------------------------------------


def test_gramian_equals_output_energy_from_python_control():
    import control

    A = np.array([[0.0, 1.0, 0.0], [-4.0, -0.4, 1.0], [0.0, 0.0, -2.0]])
    C = np.array([[1.0, 0.0, 0.5], [0.0, 1.0, 0.0]])
    W = observability_gramian(A, C)
    # x0^T W x0 = int ||y||^2 dt of the free response from x0 (python-control simulation)
    sys = control.ss(A, np.zeros((3, 1)), C, 0)
    t = np.linspace(0.0, 60.0, 24001)
    for x0 in ([1.0, -0.5, 2.0], [0.0, 1.0, 0.0]):
        y = np.atleast_2d(control.initial_response(sys, T=t, X0=x0).outputs)
        assert np.asarray(x0) @ W @ np.asarray(x0) == pytest.approx(
            trapezoid((y**2).sum(axis=0), t), rel=1e-4)


def test_gramian_equals_control_gram():
    pytest.importorskip("slycot")  # control.gram needs slycot's sb03md
    import control

    A = np.array([[0.0, 1.0, 0.0], [-4.0, -0.4, 1.0], [0.0, 0.0, -2.0]])
    C = np.array([[1.0, 0.0, 0.5]])
    sys = control.ss(A, np.zeros((3, 1)), C, 0)
    np.testing.assert_allclose(observability_gramian(A, C), control.gram(sys, "o"),
                               rtol=1e-10)


@pytest.mark.parametrize("method", ["modal", "lyapunov"])
def test_single_mode_closed_form(method):
    w, z = 2 * np.pi * 3.0, 0.01
    phi = np.array([0.1, -0.4, 0.7, 1.0])
    A, Cv = modal_candidate_system([w], [z], phi[:, None], "velocity")
    r = rank_sensors_by_gramian(A, Cv, normalize="none", method=method)
    np.testing.assert_allclose(r.scores, phi**2 / (2 * z * w), rtol=1e-10)  # phi^2/(2 zeta w)
    _, Cd = modal_candidate_system([w], [z], phi[:, None], "displacement")
    rd = rank_sensors_by_gramian(A, Cd, normalize="none", method=method)
    np.testing.assert_allclose(rd.scores, phi**2 * (1 / (2 * z * w**3) + z / w**3), rtol=1e-10)
    # light damping: phi^2 / (2 zeta w^3) to O(zeta^2)
    np.testing.assert_allclose(rd.scores, phi**2 / (2 * z * w**3), rtol=3 * z**2)
    rn = rank_sensors_by_gramian(A, Cd)  # mode-normalised: shares of phi^2
    np.testing.assert_allclose(rn.scores, phi**2 / np.sum(phi**2), rtol=1e-10)
    assert rn.ranked_labels[0] == "dof3"


def _cantilever_model(n_el=20, zeta=0.01, tip_damper=0.0):
    M, K = _beam_builder(n_el, 1, clamped=True)(np.ones(1))
    n = M.shape[0]
    C = np.zeros((n, n))
    C[-2, -2] = tip_damper  # a dashpot on the tip translation: non-proportional
    rows = np.eye(n)[0::2]  # translation of nodes 1..n_el
    return StructuralModel(M=M, C=C, K=K, B=np.zeros((n, 1)), C_out=rows,
                           quantities=("velocity",) * rows.shape[0], modal_damping_ratio=zeta)


def test_cantilever_gramian_ranking():
    model = _cantilever_model()
    modes = solve_modes(model.M, model.K, 4)
    A, _, C, _ = modal_system(model, modes)
    x = np.arange(1, 21) / 20
    r1 = rank_sensors_by_gramian(A, C, modes=[0])
    assert x[r1.order[0]] == 1.0  # first mode: the tip
    r2 = rank_sensors_by_gramian(A, C, modes=[1])
    outer = x >= 0.5  # away from the clamp, where every shape vanishes
    worst = x[outer][np.argmin(r2.scores[outer])]
    assert worst == pytest.approx(0.7834, abs=0.03)  # node of the second mode (0.7834 L)
    # diagonal Xi: the closed form and per-candidate Lyapunov solutions agree
    Gm = modal_gramian_contributions(A, C, method="modal")
    Gl = modal_gramian_contributions(A, C, method="lyapunov")
    np.testing.assert_allclose(Gl, Gm, rtol=1e-8, atol=1e-12 * Gm.max())
    rall = rank_sensors_by_gramian(A, C)
    assert rall.scores.sum() == pytest.approx(1.0)
    assert rall.contributions.sum(axis=0) == pytest.approx(np.ones(4))


def test_non_proportional_damping_uses_lyapunov():
    model = _cantilever_model(zeta=0.005, tip_damper=0.05)
    modes = solve_modes(model.M, model.K, 4)
    A, _, C, _ = modal_system(model, modes)
    with pytest.raises(ValueError, match="method='modal' needs a diagonal"):
        modal_gramian_contributions(A, C, method="modal")
    Gl = modal_gramian_contributions(A, C)  # auto -> lyapunov
    # light coupling: close to the closed form on the diagonal of Xi
    m = 4
    A_diag = A.copy()
    A_diag[m:, m:] = np.diag(np.diag(A[m:, m:]))
    Gd = modal_gramian_contributions(A_diag, C)
    np.testing.assert_allclose(Gl, Gd, rtol=0.1, atol=1e-3 * Gd.max())


def test_gramian_errors():
    w = np.array([0.0, 10.0])
    A, C = modal_candidate_system(w, [0.0, 0.01], np.ones((3, 2)))
    with pytest.raises(ValueError, match="rigid-body"):
        rank_sensors_by_gramian(A, C)
    assert rank_sensors_by_gramian(A, C, modes=[1]).scores.shape == (3,)
    with pytest.raises(ValueError, match="stable"):
        observability_gramian(A, C)
    with pytest.raises(ValueError, match="modal first-order form"):
        rank_sensors_by_gramian(np.eye(4), C)
    with pytest.raises(ValueError, match="'C'.*columns"):
        observability_gramian(-np.eye(3), np.ones((1, 2)))
    with pytest.raises(ValueError, match="'sensor_noise'"):
        rank_sensors_by_gramian(A, C, modes=[1], sensor_noise=[1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="'normalize'"):
        rank_sensors_by_gramian(A, C, modes=[1], normalize="max")
    with pytest.raises(ValueError, match="'quantity'"):
        modal_candidate_system(w, 0.01, np.ones((3, 2)), "strain")
    with pytest.raises(ValueError, match="seen by no candidate"):
        rank_sensors_by_gramian(A, np.zeros_like(C), modes=[1])
    # noise scaling: a noisier sensor scores less
    r = rank_sensors_by_gramian(A, C, modes=[1], sensor_noise=[1.0, 2.0, 1.0])
    assert r.scores[1] == pytest.approx(r.scores[0] / 4)


def test_sensitivity_errors():
    dphi = np.ones((3, 2, 2))
    with pytest.raises(ValueError, match="'dphi'.*shape"):
        rank_sensors_by_sensitivity(np.ones((3, 2)), [1.0, 1.0])
    with pytest.raises(ValueError, match="'sigma'.*2 non-negative"):
        rank_sensors_by_sensitivity(dphi, [1.0, -1.0])
    with pytest.raises(ValueError, match="'modes'"):
        rank_sensors_by_sensitivity(dphi, [1.0, 1.0], modes=[5])
    with pytest.raises(ValueError, match="'labels'.*3 labels"):
        rank_sensors_by_sensitivity(dphi, [1.0, 1.0], labels=["a"])
    with pytest.raises(ValueError, match="all sensitivity rows are zero|All sensitivity"):
        rank_sensors_by_sensitivity(np.zeros((3, 2, 2)), [1.0, 1.0])
    with pytest.raises(ValueError, match="'n_select'"):
        greedy_d_optimal(dphi, 4)
    with pytest.raises(ValueError, match="'mode_weights'"):
        rank_sensors_by_sensitivity(dphi, [1.0, 1.0], mode_weights=[1.0])
    with pytest.raises(ValueError, match="finite"):
        rank_sensors_by_sensitivity(np.full((3, 2, 2), np.nan), [1.0, 1.0])
