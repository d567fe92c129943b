"""Sensitivity localization (Eq. 10.31-10.44): eigen-sensitivities against finite differences
of the exact eigensolution, and the iterated update against a known truth."""

import warnings

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from truthbench.errors import IdentifiabilityError
from truthbench.model import Modes, solve_modes
from truthbench.plants import make_plant
from truthbench.update.macroelements import Macroelement, macroelement_matrices
from truthbench.update.sensitivity import (
    MeasuredModes,
    SensitivityResult,
    eigen_sensitivities,
    sensitivity_update,
)


# --------------------------------------------------------------------------------------
# oracle: central differences of scipy.linalg.eigh (mass-normalised, sign-consistent)
# --------------------------------------------------------------------------------------
def _eigh(build, theta, M_ref, Phi_ref):
    M, K = build(theta)
    lam, Phi = sla.eigh(K, M)  # Phi^T M Phi = I
    sign = np.sign(np.einsum("ij,ij->j", Phi, M_ref @ Phi_ref))
    return lam, Phi * sign


def _fd(build, theta, name, M_ref, Phi_ref, h):
    """Richardson-extrapolated central differences (steps h and h/2) per unit relative
    change; truncation O(h^4)."""
    out = []
    for step in (h, h / 2):
        up, dn = dict(theta), dict(theta)
        up[name] = theta[name] * (1 + step)
        dn[name] = theta[name] * (1 - step)
        lp, pp = _eigh(build, up, M_ref, Phi_ref)
        lm, pm = _eigh(build, dn, M_ref, Phi_ref)
        out.append(((lp - lm) / (2 * step), (pp - pm) / (2 * step)))
    (l1, p1), (l2, p2) = out
    return (4 * l2 - l1) / 3, (4 * p2 - p1) / 3


# planar (x-z) free-free beam: z and ry DOFs only, no degenerate y/z pairs
BEAM = make_plant("free_free_beam", n_elements=8, n_groups=2)
_NOM = BEAM.resolve()
BEAM_THETA = {**_NOM, "E_pa@g1": _NOM["E_pa"], "E_pa@g2": 1.05 * _NOM["E_pa"],
              "rho_kg_m3@g1": _NOM["rho_kg_m3"], "rho_kg_m3@g2": 0.9 * _NOM["rho_kg_m3"],
              "t_m@g2": _NOM["t_m"]}
_LABELS = BEAM.build().dof_labels
PLANAR = np.array([i for i, s in enumerate(_LABELS) if s.endswith((".z", ".ry"))])


def planar_mk(theta):
    m = BEAM.build(theta)
    M, K = m.M.toarray(), m.K.toarray()
    return M[np.ix_(PLANAR, PLANAR)], K[np.ix_(PLANAR, PLANAR)]


def test_planar_subset_is_decoupled():
    m = BEAM.build(BEAM_THETA)
    rest = np.setdiff1d(np.arange(m.n_dofs), PLANAR)
    assert abs(m.K.toarray()[np.ix_(PLANAR, rest)]).max() == 0
    assert abs(m.M.toarray()[np.ix_(PLANAR, rest)]).max() == 0


@pytest.mark.parametrize("name", ["E_pa@g1", "E_pa@g2", "rho_kg_m3@g1", "rho_kg_m3@g2",
                                  "t_m@g2"])
def test_beam_sensitivities_match_finite_differences(name):
    """Fox-Kapoor eigenvalue and eigenvector derivatives (with the mass-normalisation
    term) equal central differences of eigh within 1e-5 relative."""
    (me,) = macroelement_matrices(planar_mk, BEAM_THETA, [name])
    M, K = planar_mk(BEAM_THETA)
    modes = solve_modes(M, K)
    dlam, dphi = eigen_sensitivities(modes, [me])
    assert dlam.shape == (18, 1) and dphi.shape == (18, 18, 1)
    fl, fp = _fd(planar_mk, BEAM_THETA, name, M, modes.shapes, 2e-3)
    lam = modes.omega_rad_s**2
    elastic = modes.freq_hz > 10  # the two suspension modes are near 3.5 Hz
    # elastic modes: relative to the derivative itself
    rel_l = np.abs(dlam[:, 0] - fl) / np.abs(fl)
    rel_p = np.linalg.norm(dphi[:, :, 0] - fp, axis=0) / np.linalg.norm(fp, axis=0)
    assert rel_l[elastic].max() < 1e-5
    assert rel_p[elastic].max() < 1e-5
    # suspension modes: their E derivative is ~1e-4 of lambda, below the oracle's
    # rounding (eps lambda_max / h); compare in the natural scale lambda_i, ||phi_i||
    nat_l = np.abs(dlam[:, 0] - fl) / lam
    nat_p = np.linalg.norm(dphi[:, :, 0] - fp, axis=0) / np.linalg.norm(modes.shapes, axis=0)
    assert nat_l.max() < 1e-5 and nat_p.max() < 1e-5
    if name.startswith("rho"):
        # the mass-normalisation term -1/2 (phi_i^T M_j phi_i) phi_i matters
        h = np.einsum("ni,nm,mi->i", modes.shapes, me.dM.toarray(), modes.shapes)
        without = dphi[:, :, 0] + 0.5 * h * modes.shapes
        rel_wo = np.linalg.norm(without - fp, axis=0) / np.linalg.norm(fp, axis=0)
        assert rel_wo[elastic].min() > 1e-3 and np.median(rel_wo[elastic]) > 0.1


def test_suspension_stiffness_sensitivity_in_natural_scale():
    (me,) = macroelement_matrices(planar_mk, BEAM_THETA, ["suspension_stiffness_n_m"])
    M, K = planar_mk(BEAM_THETA)
    modes = solve_modes(M, K)
    dlam, dphi = eigen_sensitivities(modes, [me])
    fl, fp = _fd(planar_mk, BEAM_THETA, "suspension_stiffness_n_m", M, modes.shapes, 2e-3)
    susp = modes.freq_hz < 10  # where the suspension matters: relative to the derivative
    assert (np.abs(dlam[susp, 0] - fl[susp]) / np.abs(fl[susp])).max() < 1e-5
    nat = np.linalg.norm(dphi[:, :, 0] - fp, axis=0) / np.linalg.norm(modes.shapes, axis=0)
    assert nat.max() < 1e-5


# free-free spring-mass chain: one rigid-body mode
MASSES = np.array([1.0, 2.0, 1.5, 0.7, 1.2])
SPRINGS = np.array([1000.0, 1500.0, 800.0, 1200.0])
CHAIN = {**{f"m{i}": v for i, v in enumerate(MASSES)},
         **{f"k{i}": v for i, v in enumerate(SPRINGS)}}


def chain_mk(theta):
    n = MASSES.size
    M = np.diag([theta[f"m{i}"] for i in range(n)])
    K = np.zeros((n, n))
    for i in range(n - 1):
        k = theta[f"k{i}"]
        K[np.ix_([i, i + 1], [i, i + 1])] += k * np.array([[1, -1], [-1, 1]])
    return M, K


@pytest.mark.parametrize("name", sorted(CHAIN))
def test_chain_sensitivities_with_rigid_mode(name):
    (me,) = macroelement_matrices(chain_mk, CHAIN, [name])
    M, K = chain_mk(CHAIN)
    modes = solve_modes(M, K)
    assert modes.rigid.sum() == 1
    dlam, dphi = eigen_sensitivities(modes, [me])
    fl, fp = _fd(chain_mk, CHAIN, name, M, modes.shapes, 1e-3)
    lam = modes.omega_rad_s**2
    # rigid-mode eigenvalue stays 0 (a spring does not resist rigid motion)
    assert abs(dlam[0, 0]) < 1e-9 * lam.max() and abs(fl[0]) < 1e-7 * lam.max()
    np.testing.assert_allclose(dlam[1:, 0], fl[1:], rtol=1e-5)
    err = np.linalg.norm(dphi[:, :, 0] - fp, axis=0)
    ref = np.linalg.norm(fp, axis=0)
    scale = np.linalg.norm(modes.shapes, axis=0)
    assert np.all(err <= 1e-5 * ref + 1e-10 * scale)
    if name.startswith("m"):
        # the rigid mode 1/sqrt(sum m): d/da_j = -1/2 m_j / (sum m)^{3/2}
        j = int(name[1:])
        expected = -0.5 * MASSES[j] / MASSES.sum() ** 1.5
        np.testing.assert_allclose(np.abs(dphi[:, 0, 0]), abs(expected), rtol=1e-9)


def _twin_chain():
    """Two identical uncoupled chains: every eigenvalue is exactly doubly repeated."""
    M1, K1 = chain_mk(CHAIN)
    return sla.block_diag(M1, M1), sla.block_diag(K1, K1)


def test_repeated_eigenvalues_no_division_by_zero():
    M, K = _twin_chain()
    modes = solve_modes(M, K)
    lam = modes.omega_rad_s**2
    assert np.allclose(lam[2::2], lam[3::2], rtol=1e-12)
    # a symmetric perturbation (the same spring in both chains) keeps the pairs
    # degenerate: the diagonal forms are exact, no warning
    n = MASSES.size
    dK = np.zeros_like(K)
    dK[np.ix_([1, 2], [1, 2])] = SPRINGS[1] * np.array([[1, -1], [-1, 1]])
    dK[np.ix_([n + 1, n + 2], [n + 1, n + 2])] = dK[np.ix_([1, 2], [1, 2])]
    sym = Macroelement("k1 both", sp.csr_matrix(M.shape), sp.csr_matrix(dK), 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dlam, dphi = eigen_sensitivities(modes, [sym])
    assert np.all(np.isfinite(dlam)) and np.all(np.isfinite(dphi))
    lp = sla.eigh(K + 1e-6 * dK, M, eigvals_only=True)
    lm = sla.eigh(K - 1e-6 * dK, M, eigvals_only=True)
    np.testing.assert_allclose(dlam[2:, 0], ((lp - lm) / 2e-6)[2:], rtol=1e-5)
    # a perturbation of one chain splits the pairs; in a mixed basis it couples them:
    # the result stays finite and a warning says it is basis dependent
    c, s = np.cos(0.3), np.sin(0.3)
    Phi = modes.shapes.copy()
    for i in range(2, M.shape[0], 2):
        a, b = Phi[:, i].copy(), Phi[:, i + 1].copy()
        Phi[:, i], Phi[:, i + 1] = c * a + s * b, -s * a + c * b
    mixed = Modes(modes.omega_rad_s, Phi, modes.rigid)
    one = np.zeros_like(K)
    one[np.ix_([1, 2], [1, 2])] = dK[np.ix_([1, 2], [1, 2])]
    single = Macroelement("k1 one", sp.csr_matrix(M.shape), sp.csr_matrix(one), 1.0)
    with pytest.warns(UserWarning, match=r"\['k1 one'\] couple the degenerate model modes"):
        dlam, dphi = eigen_sensitivities(mixed, [single])
    assert np.all(np.isfinite(dlam)) and np.all(np.isfinite(dphi))


# --------------------------------------------------------------------------------------
# the update: 3-D free-free beam, 4 groups, z sensors at 5 of 9 nodes
# --------------------------------------------------------------------------------------
PLANT = make_plant("free_free_beam", n_elements=8, n_groups=4)
NOM = PLANT.resolve()
GROUPS = PLANT.group_names
BASE = {**NOM, **{f"E_pa@{g}": NOM["E_pa"] for g in GROUPS},
        **{f"rho_kg_m3@{g}": NOM["rho_kg_m3"] for g in GROUPS}}
LABELS = PLANT.build().dof_labels
Z = np.array([i for i, s in enumerate(LABELS) if s.endswith(".z")])
TRANS = np.array([i for i, s in enumerate(LABELS) if s.split(".")[1] in ("x", "y", "z")])
SENSORS = Z[::2]  # z at nodes 0, 2, 4, 6, 8: 5 of the 54 DOFs
OFFSETS = {"E_pa@g1": 1.03, "E_pa@g2": 0.97, "E_pa@g3": 1.05, "E_pa@g4": 0.98,
           "rho_kg_m3@g1": 1.0, "rho_kg_m3@g2": 1.04, "rho_kg_m3@g3": 0.97,
           "rho_kg_m3@g4": 1.02}


def build_mk(theta):
    m = PLANT.build(theta)
    return m.M, m.K


def measured_from(truth, n_modes=5, *, scale=True):
    """Exact modes of the truth: the first ``n_modes`` vertical bending modes at SENSORS,
    with arbitrary scale and sign unless ``scale`` is False (mass-normalised)."""
    modes = solve_modes(*build_mk(truth))
    share = np.sum(modes.shapes[Z] ** 2, 0) / np.sum(modes.shapes[TRANS] ** 2, 0)
    pick = np.nonzero((share > 0.9) & (modes.freq_hz > 10))[0][:n_modes]
    shapes = modes.shapes[np.ix_(SENSORS, pick)]
    if scale:
        shapes = shapes * np.array([2.0, -0.5, 3.0, -1.0, 1.5])[: pick.size]
    return MeasuredModes(modes.freq_hz[pick], shapes, SENSORS)


def _rel(res, truth):
    return np.array([v / truth[n] - 1 for n, v in zip(res.names, res.values, strict=True)])


def test_recovers_material_parameters_with_scaled_shapes():
    """E and rho per group, a few % off; 5 bending modes at 5 DOFs. rho@g1 is the
    reference (with MSF-scaled shapes a common factor on all E and rho is invisible)."""
    truth = {k: v * OFFSETS.get(k, 1.0) for k, v in BASE.items()}
    meas = measured_from(truth)
    names = [k for k in OFFSETS if k != "rho_kg_m3@g1"]
    base = dict(BASE)
    res = sensitivity_update(build_mk, base, names, meas)
    assert base == BASE  # inputs untouched
    assert isinstance(res, SensitivityResult) and res.method == "sensitivity"
    assert res.converged and res.n_iterations <= 6
    assert np.abs(_rel(res, truth)).max() < 5e-3
    assert np.abs(_rel(res, truth)).max() < 1e-8  # exact data: Gauss-Newton to rounding
    assert res.cost_history[-1] < 1e-18 * res.cost_history[0]
    assert res.history.shape == (res.n_iterations + 1, 7)
    assert res.alpha_history.shape == (res.n_iterations, 7)
    assert len(res.pairing_history) == res.n_iterations + 1
    last = res.pairing_history[-1][0]
    assert np.all(last.mac > 0.999999) and last.unpaired_measured.size == 0


def test_mass_normalised_shapes_separate_all_of_E_and_rho():
    truth = {k: v * OFFSETS.get(k, 1.0) for k, v in BASE.items()}
    meas = measured_from(truth, scale=False)
    res = sensitivity_update(build_mk, BASE, list(OFFSETS), meas, scale_shapes=False)
    assert res.converged
    assert np.abs(_rel(res, truth)).max() < 1e-8


def test_localizes_stiffness_loss_to_its_group():
    """E@g3 down 20 % among 4 groups, 4 modes at 5 DOFs: the first (first-order) step
    already puts almost all of the change on g3; iteration removes the rest."""
    truth = {**BASE, "E_pa@g3": 0.8 * BASE["E_pa@g3"]}
    names = [f"E_pa@{g}" for g in GROUPS]
    res = sensitivity_update(build_mk, BASE, names, measured_from(truth, 4))
    first = res.alpha_history[0]
    assert np.argmax(np.abs(first)) == 2
    assert abs(first[2] - np.log(0.8)) < 0.01
    assert np.abs(np.delete(first, 2)).max() < 0.01
    assert res.converged
    total = np.log(res.values / res.initial)
    assert abs(total[2] - np.log(0.8)) < 1e-9
    assert np.abs(np.delete(total, 2)).max() < 1e-9


def test_frequencies_only_cannot_separate_E_from_rho():
    """Scaling every stiffness and every mass by one factor changes no eigenvalue: E,
    rho and the suspension stiffness together are reported, with the reason."""
    meas = measured_from({**NOM, "E_pa": 1.02 * NOM["E_pa"]}, 4)
    with pytest.raises(IdentifiabilityError,
                       match=r"cannot be separated.*d\(E_pa\).*d\(rho_kg_m3\)"
                             r".*d\(suspension_stiffness_n_m\).*scales M and K together"):
        sensitivity_update(build_mk, NOM, ["E_pa", "rho_kg_m3", "suspension_stiffness_n_m"],
                           meas, c_phi=0.0)
    # without the suspension in the set the scale is seen only through the soft
    # suspension: the correlation report says E and rho move together
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = sensitivity_update(build_mk, NOM, ["E_pa", "rho_kg_m3"], meas, c_phi=0.0,
                                 max_iterations=2)
    assert res.correlation[0, 1] > 0.9999
    assert res.condition_number > 1e3


def test_scaled_shapes_separate_E_from_rho_only_partly():
    """With MSF-scaled shapes every group's E and rho are separable except the common
    scale of all of them (and the suspension); the error names every parameter."""
    truth = {k: v * OFFSETS.get(k, 1.0) for k, v in BASE.items()}
    names = [*OFFSETS, "suspension_stiffness_n_m"]
    with pytest.raises(IdentifiabilityError) as info:
        sensitivity_update(build_mk, BASE, names, measured_from(truth))
    msg = str(info.value)
    assert "cannot be separated" in msg and "scales M and K together" in msg
    for n in names:
        assert f"d({n})" in msg


def test_nonlinear_parameter_warns_and_still_converges():
    truth = {**BASE, "r_m": 1.02 * BASE["r_m"], "E_pa@g2": 0.96 * BASE["E_pa@g2"]}
    with pytest.warns(UserWarning, match=r"nonlinearly on parameters 'r_m'"):
        res = sensitivity_update(build_mk, BASE, ["r_m", "E_pa@g2"], measured_from(truth))
    assert res.converged and res.nonlinear == ("r_m",)
    assert np.abs(_rel(res, truth)).max() < 1e-8


def test_unpaired_measured_mode_is_dropped_with_a_warning():
    truth = {**BASE, "E_pa@g2": 0.96 * BASE["E_pa@g2"]}
    good = measured_from(truth, 3)
    rng = np.random.default_rng(3)
    junk = MeasuredModes([77.0], rng.normal(size=(SENSORS.size, 1)), SENSORS)
    with pytest.warns(UserWarning, match=r"measured mode 0 of set 1 at 77 Hz has no model "
                                         r"partner"):
        res = sensitivity_update(build_mk, BASE, ["E_pa@g2"], [good, junk], mac_min=0.95)
    assert res.converged and abs(_rel(res, truth)[0]) < 1e-8
    assert res.pairing_history[0][1].unpaired_measured.tolist() == [0]


def test_non_convergence_warns():
    truth = {**BASE, "E_pa@g2": 0.8 * BASE["E_pa@g2"]}
    with pytest.warns(UserWarning, match="did not converge in 1 iterations.*max_iterations"):
        res = sensitivity_update(build_mk, BASE, ["E_pa@g2"], measured_from(truth, 3),
                                 max_iterations=1)
    assert not res.converged and res.history.shape == (2, 1)


def test_errors():
    meas = measured_from(BASE, 3)
    with pytest.raises(ValueError, match=r"\['E_pa@g9'\] are not model parameters"):
        sensitivity_update(build_mk, BASE, ["E_pa@g9"], meas)
    with pytest.raises(ValueError, match="not both 0"):
        sensitivity_update(build_mk, BASE, ["E_pa@g1"], meas, c_lambda=0, c_phi=0)
    with pytest.raises(ValueError, match="'measured' must be"):
        sensitivity_update(build_mk, BASE, ["E_pa@g1"], [1, 2])
    far = MeasuredModes(meas.freq_hz, meas.shapes, SENSORS + 100)
    with pytest.raises(ValueError, match=r"'dof_index' reaches 1\d\d, but the model has 54"):
        sensitivity_update(build_mk, BASE, ["E_pa@g1"], far)
    with pytest.raises(IdentifiabilityError, match=r"\['suspension_lateral_stiffness_n_m'\]"
                                                   r" change none"):
        sensitivity_update(build_mk, {**BASE, "suspension_lateral_stiffness_n_m": 10.0},
                           ["E_pa@g1", "suspension_lateral_stiffness_n_m"], meas)
    with pytest.raises(ValueError, match=r"'shapes' must have shape \(n_sens, 2\)"):
        MeasuredModes([1.0, 2.0], np.ones((3, 3)), [0, 1, 2])
    with pytest.raises(ValueError, match="without repeats"):
        MeasuredModes([1.0], np.ones((2, 1)), [4, 4])
    with pytest.raises(ValueError, match="finite and positive"):
        MeasuredModes([0.0], np.ones((2, 1)), [0, 1])


def test_hub_beam_lumped_inertia_rigid_mode_and_complex_shapes():
    """Hub inertia (a lumped mass term) and E per group from in-plane modes of the
    hub-beam (one rigid rotation); measured shapes complex with an arbitrary phase."""
    hub = make_plant("hub_beam", n_elements=8, n_groups=2)
    nom = hub.resolve()
    base = {**nom, "E_pa@g1": nom["E_pa"], "E_pa@g2": nom["E_pa"]}
    truth = {**base, "hub_inertia_kg_m2": 1.1 * base["hub_inertia_kg_m2"],
             "E_pa@g2": 0.95 * base["E_pa"]}

    def hub_mk(theta):
        m = hub.build(theta)
        return m.M, m.K

    labels = hub.build().dof_labels
    y = np.array([i for i, s in enumerate(labels) if s.endswith(".y")])
    trans = np.array([i for i, s in enumerate(labels) if s.split(".")[1] in ("x", "y", "z")])
    sensors = np.concatenate([[labels.index("n0.rz")], y[1::2]])  # hub angle + 4 y
    modes = solve_modes(*hub_mk(truth))
    assert modes.rigid.sum() == 1
    share = np.sum(modes.shapes[y] ** 2, 0) / np.sum(modes.shapes[trans] ** 2, 0)
    pick = np.nonzero((share > 0.9) & ~modes.rigid)[0][:4]
    meas = MeasuredModes(modes.freq_hz[pick],
                         (1 + 0.5j) * modes.shapes[np.ix_(sensors, pick)], sensors)
    names = ["hub_inertia_kg_m2", "E_pa@g1", "E_pa@g2"]
    res = sensitivity_update(hub_mk, base, names, meas)
    assert res.converged and res.n_iterations <= 6
    assert np.abs(_rel(res, truth)).max() < 1e-8
