"""Sensitivity localization of damping parameters (Eq. 10.31-10.44 with measured damping).

Oracles: the exact poles of ``det(s^2 M + s C + K) = 0`` refined by Newton's method from
the undamped frequency (independent of the modal first-order form the code uses),
central differences of those poles, and known truth parameters.
"""

import warnings

import numpy as np
import pytest

from truthbench.errors import IdentifiabilityError
from truthbench.model import complex_modes, solve_modes
from truthbench.plants import make_plant
from truthbench.update import (
    SensitivityResult,
    UpdateProblem,
    damping_sensitivities,
    macroelement_matrices,
    make_updater,
    system_matrices,
)
from truthbench.update.sensitivity import MeasuredModes, sensitivity_update

# --------------------------------------------------------------------------------------
# the hub-beam (the chapter's Section 10.5): hub dashpot, in-plane (y) modes, hub angle + 4 y
# --------------------------------------------------------------------------------------
HUB = make_plant("hub_beam", n_elements=8)
HUB_NOM = HUB.resolve()
HUB_LABELS = HUB.build().dof_labels
Y = np.array([i for i, s in enumerate(HUB_LABELS) if s.endswith(".y")])
TRANS = np.array([i for i, s in enumerate(HUB_LABELS) if s.split(".")[1] in ("x", "y", "z")])
HUB_SENSORS = np.concatenate([[HUB_LABELS.index("n0.rz")], Y[1::2]])  # hub angle, 4 y
DAMPER = "hub_damping_n_m_s_rad"


def in_plane(modes, n):
    """The first ``n`` elastic modes with more than 90 % of their translation in y."""
    share = np.sum(modes.shapes[Y] ** 2, 0) / np.sum(modes.shapes[TRANS] ** 2, 0)
    return np.nonzero((share > 0.9) & ~modes.rigid)[0][:n]


def exact_pole(M, C, K, omega):
    """Oracle: the root of ``det(s^2 M + s C + K)`` near ``j omega`` (Newton on
    ``1 / trace(T(s)^-1 T'(s))``), independent of the modal form and its pairing."""
    s, done = 1j * omega, -1
    for _ in range(50):
        T = s * s * M + s * C + K
        ds = 1.0 / np.trace(np.linalg.solve(T, 2 * s * M + C))
        s = s - ds
        if done < 0 and abs(ds) < 1e-11 * abs(s):
            done = 2  # quadratic convergence: two more steps reach rounding (~1e-13)
        elif done > 0:
            done -= 1
        if done == 0:
            return s
    raise AssertionError("Newton did not converge")


def oracle_zeta(theta, n_modes):
    """Exact damping ratios and poles of the first ``n_modes`` in-plane modes, Newton
    started at each one's undamped frequency at ``theta`` (the y and z bending pairs are
    only 0.05 % apart: a start from another parameter value may find the z mode)."""
    m = HUB.build(theta)
    M, C, K = (a.toarray() for a in (m.M, m.C, m.K))
    modes = solve_modes(M, K)
    s = np.array([exact_pole(M, C, K, w) for w in modes.omega_rad_s[in_plane(modes,
                                                                           n_modes)]])
    return -s.real / np.abs(s), s


def hub_measured(truth, n_modes=4, *, damping=True, phase=0.3 - 1.2j):
    """Noise-free 'measured' modes: the truth model's exact complex modes (undamped
    natural frequency |s|, damping ratio, complex shape at HUB_SENSORS times an
    arbitrary complex factor)."""
    model = HUB.build(truth)
    modes = model.modes()
    cm = complex_modes(model, modes)
    pick = in_plane(modes, n_modes)
    return MeasuredModes(cm.omega_rad_s[pick] / (2 * np.pi),
                         phase * cm.shapes[np.ix_(HUB_SENSORS, pick)], HUB_SENSORS,
                         damping_ratio=cm.damping_ratio[pick] if damping else None)


def _rel(res, truth):
    return np.array([v / truth[k] - 1 for k, v in zip(res.names, res.values, strict=True)])


# --------------------------------------------------------------------------------------
# the exact damping ratios and the first-order sensitivities
# --------------------------------------------------------------------------------------
def test_complex_modes_are_the_physical_poles():
    """With all modes, complex_modes' poles are the roots of det(s^2 M + s C + K)
    (modal_table's damping column comes from it; tests/test_model.py checks that column
    against python-control's damp)."""
    model = HUB.build({**HUB_NOM, "modal_damping_ratio": 0.0})
    modes = model.modes()
    cm = complex_modes(model, modes)
    pick = in_plane(modes, 4)
    _, s = oracle_zeta({**HUB_NOM, "modal_damping_ratio": 0.0}, 4)
    np.testing.assert_allclose(cm.poles[pick], s, rtol=1e-10)
    np.testing.assert_allclose(cm.omega_rad_s[pick], np.abs(s), rtol=1e-10)
    # the dashpot lowers |s| of the first in-plane mode by 2e-4 relative: the real-mode
    # frequency is not the data's natural frequency
    assert 1e-4 < 1 - cm.omega_rad_s[pick[0]] / modes.omega_rad_s[pick[0]] < 1e-3
    # the complex shape, scaled so that its own modal coordinate is 1
    eta = modes.shapes.T @ (model.M @ cm.shapes[:, pick])
    np.testing.assert_allclose(np.diag(eta[pick]), 1.0, rtol=1e-10)


def _fd_zeta(theta, name, n_modes, h=1e-3):
    """Richardson-extrapolated central difference (steps h, h/2) of the oracle damping
    ratios of the first ``n_modes`` in-plane modes per unit relative change of ``name``."""
    out = []
    for step in (h, h / 2):
        up = {**theta, name: theta[name] * (1 + step)}
        dn = {**theta, name: theta[name] * (1 - step)}
        out.append((oracle_zeta(up, n_modes)[0] - oracle_zeta(dn, n_modes)[0])
                   / (2 * step))
    return (4 * out[1] - out[0]) / 3


NAMES_FD = [DAMPER, "E_pa", "rho_kg_m3", "hub_inertia_kg_m2"]


def _first_order_error(c):
    theta = {**HUB_NOM, DAMPER: c, "modal_damping_ratio": 0.0}
    sysm = system_matrices(HUB.build, theta)
    modes = solve_modes(sysm.M, sysm.K)
    macros = macroelement_matrices(HUB.build, theta, NAMES_FD)
    dz = damping_sensitivities(modes, macros, sysm.C)
    pick = in_plane(modes, 3)
    rel = np.empty((pick.size, len(NAMES_FD)))
    for j, name in enumerate(NAMES_FD):
        fd = _fd_zeta(theta, name, pick.size)
        rel[:, j] = np.abs(dz[pick, j] - fd) / np.abs(fd)
    return rel, macros


def test_first_order_damping_sensitivity_light_dashpot():
    """d zeta / d alpha = phi^T C_j phi / (2 omega) (+ the cross terms of E, rho and the
    hub inertia) against central differences of the exact damping ratio.

    Light dashpot c = 0.5 N m s/rad (zeta_1 = 0.06 %). The first-order expression is
    exact to first order in the damping; zeta is odd in C (C -> -C mirrors the poles),
    so its error is O(C^3) and the derivative's relative error O(kappa^2), kappa the
    damping coupling ``|Xi_k1| omega_1 / |omega_1^2 - omega_k^2|`` = 2.1e-3 for mode 1
    (largest towards the rigid hub rotation), i.e. a few 1e-5 (measured: 3.4e-5 on mode 1,
    2.4e-6 on mode 2, 3e-7 on mode 3, for all four parameters); the tolerance 1e-4 is
    about three times that. The oracle's own rounding is ~1e-7 relative here: the
    hundredfold growth at ten times the dashpot (measured 100.3) shows that what is
    compared is the approximation's error, not noise."""
    rel, macros = _first_order_error(0.5)
    assert [me.kind for me in macros] == ["damping", "structural", "structural",
                                          "structural"]
    hub = HUB_LABELS.index("n0.rz")  # the dashpot: one entry, c, at the hub angle
    assert macros[0].dC.nnz == 1 and macros[0].dC[hub, hub] == pytest.approx(0.5, rel=1e-12)
    assert macros[0].dM.nnz == macros[0].dK.nnz == 0
    assert rel.max() < 1e-4, rel
    # second order: ten times the dashpot, a hundred times the error on mode 1
    rel5, _ = _first_order_error(5.0)
    ratio = rel5[0] / rel[0]
    assert np.all((ratio > 90) & (ratio < 110)), ratio
    assert rel5.max() < 1e-2  # nominal dashpot: still within 0.4 %


def test_modal_damping_ratio_sensitivity_is_exact_for_modal_damping():
    """Modal damping only (no dashpot): zeta_i = zeta_m for every elastic mode, so
    d zeta_i / d alpha = zeta_m exactly; modal_damping_ratio is its own kind."""
    plant = make_plant("free_free_beam", n_elements=8)
    theta = plant.resolve({"modal_damping_ratio": 0.004})
    names = ["modal_damping_ratio", "suspension_damping_n_s_m", "E_pa"]
    theta["suspension_damping_n_s_m"] = 1.0
    macros = macroelement_matrices(plant.build, theta, names)
    mz, ms, me = macros
    assert mz.kind == "modal_damping" and mz.dM.nnz == mz.dK.nnz == mz.dC.nnz == 0
    assert mz.dzeta_modal == pytest.approx(0.004, rel=1e-12)
    assert ms.kind == "damping" and ms.dM.nnz == ms.dK.nnz == 0
    # the two suspension dashpots (vertical, z) of 1 N s/m: dC holds exactly them
    assert ms.dC.nnz == 2 and np.allclose(ms.dC.data, 1.0, rtol=1e-12)
    assert me.kind == "structural" and me.dC.nnz == 0 and me.dzeta_modal == 0
    theta0 = {**theta, "suspension_damping_n_s_m": 0.0}
    sysm = system_matrices(plant.build, theta0)
    modes = solve_modes(sysm.M, sysm.K)
    dz = damping_sensitivities(modes, [mz], sysm.C, sysm.modal_damping_ratio)
    el = ~modes.rigid
    np.testing.assert_allclose(dz[el, 0], 0.004, rtol=1e-12)
    assert np.all(np.isnan(dz[~el, 0]))


# --------------------------------------------------------------------------------------
# noise-free recovery
# --------------------------------------------------------------------------------------
def test_recovers_hub_damper_and_E_noise_free():
    """Truth: nominal hub-beam (dashpot 5 N m s/rad, modal 0.5 %); start 30 % off in
    the dashpot and 5 % in E. Four in-plane modes (|s|, zeta, complex shapes at the hub
    angle and 4 y DOFs)."""
    truth = dict(HUB_NOM)
    start = {**truth, DAMPER: 1.3 * truth[DAMPER], "E_pa": 1.05 * truth["E_pa"]}
    meas = hub_measured(truth)
    res = sensitivity_update(HUB.build, start, [DAMPER, "E_pa"], meas)
    assert isinstance(res, SensitivityResult) and res.converged
    assert np.abs(_rel(res, truth)).max() < 1e-4
    assert np.abs(_rel(res, truth)).max() < 1e-8  # measured: ~3e-10
    assert res.n_iterations <= 8
    assert res.row_counts == {"shape": 20, "eigenvalue": 4, "damping": 4}
    assert res.singular_values.shape == (2,) and res.condition_number < 10
    assert abs(res.correlation[0, 1]) < 0.5
    last = res.pairing_history[-1][0]
    assert np.all(np.abs(last.damping_error) < 1e-10)
    assert np.all(np.abs(last.freq_error) < 1e-10) and np.all(last.mac > 1 - 1e-10)
    # the first step from the start already localises most of the change
    first = res.alpha_history[0]
    assert first[0] < -0.2 and abs(first[1] - np.log(1 / 1.05)) < 2e-3


def test_hub_damper_alone_through_the_registry_with_build_model():
    """The campaign path: UpdateProblem(build_model=plant.build, measured=... with
    damping_ratio), updater "sensitivity"."""
    truth = {**HUB_NOM, DAMPER: 3.0}
    start = {**truth, DAMPER: 0.7 * 3.0}
    problem = UpdateProblem(names=(DAMPER,), theta0=start, build_model=HUB.build,
                            measured=[hub_measured(truth, 2)])
    res = make_updater("sensitivity", {"c_zeta": 0.5}).update(problem)
    assert res.converged and abs(res.values[0] / 3.0 - 1) < 1e-8
    # (M, C, K) builders work too (no modal damping then)
    truth0 = {**truth, "modal_damping_ratio": 0.0}

    def build_mck(theta):
        m = HUB.build(theta)
        return m.M, m.C, m.K

    res = sensitivity_update(build_mck, {**truth0, DAMPER: 4.0}, [DAMPER],
                             hub_measured(truth0, 2))
    assert res.converged and abs(res.values[0] / 3.0 - 1) < 1e-8


@pytest.mark.slow
def test_large_dashpot_fixed_point_is_exact_though_the_jacobian_is_not():
    """A dashpot of 50 N m s/rad (zeta_1 = 5.7 %, |s_1| 2 % below the real-mode
    frequency): the first-order Jacobian is off by about 46 % on mode 1, so the
    iteration converges only linearly; but the residuals are exact, so the fixed point
    is the truth. Matching the first-order damping ratio instead would miss it."""
    truth = {**HUB_NOM, DAMPER: 50.0}
    start = {**truth, DAMPER: 65.0, "E_pa": 1.05 * truth["E_pa"]}
    meas = hub_measured(truth)
    # how poor the Jacobian is at the truth
    sysm = system_matrices(HUB.build, truth)
    modes = solve_modes(sysm.M, sysm.K)
    (me,) = macroelement_matrices(HUB.build, truth, [DAMPER])
    i1 = in_plane(modes, 1)[0]
    dz = damping_sensitivities(modes, [me], sysm.C, sysm.modal_damping_ratio)[i1, 0]
    th0 = {**truth, "modal_damping_ratio": 0.0}  # the oracle is physical C only
    fd = _fd_zeta(th0, DAMPER, 1)[0]
    assert abs(dz / fd - 1) > 0.3  # measured: 0.47
    res = sensitivity_update(HUB.build, start, [DAMPER, "E_pa"], meas, max_iterations=40)
    assert res.converged
    assert np.abs(_rel(res, truth)).max() < 1e-7  # measured: ~1e-9
    steps = np.abs(res.alpha_history[:, 0])
    assert res.n_iterations > 10  # linear convergence (rate ~0.3 per step)
    assert np.all(steps[3:8] / steps[2:7] > 0.1)
    # first-order zeta_1 = zeta_m + c phi_hub^2 / (2 omega_1) is linear in c: the
    # dashpot that matches the measured zeta_1 with it is 11 % too small (44.6)
    z_fo = 0.005 + np.array([(me.dC @ modes.shapes[:, i1]) @ modes.shapes[:, i1]
                             / (2 * modes.omega_rad_s[i1])])[0]
    c_fo = 50.0 * (meas.damping_ratio[0] - 0.005) / (z_fo - 0.005)
    assert abs(c_fo / 50.0 - 1) > 0.08


def test_recovers_modal_damping_ratio_free_free_beam():
    """Free-free beam: modal damping 0.5 % (truth) from a start 30 % high, with E
    updated too; z modes at 5 DOFs, with the suspension modes."""
    plant = make_plant("free_free_beam", n_elements=8)
    nom = plant.resolve()
    labels = plant.build().dof_labels
    z = np.array([i for i, s in enumerate(labels) if s.endswith(".z")])
    tr = np.array([i for i, s in enumerate(labels) if s.split(".")[1] in ("x", "y", "z")])
    sensors = z[::2]

    def measured(truth, n):
        model = plant.build(truth)
        modes = model.modes()
        cm = complex_modes(model, modes)
        share = np.sum(modes.shapes[z] ** 2, 0) / np.sum(modes.shapes[tr] ** 2, 0)
        pick = np.nonzero((share > 0.9) & ~modes.rigid)[0][:n]
        return MeasuredModes(cm.omega_rad_s[pick] / (2 * np.pi),
                             -2.0 * cm.shapes[np.ix_(sensors, pick)], sensors,
                             damping_ratio=cm.damping_ratio[pick])

    truth = {**nom, "E_pa": 1.02 * nom["E_pa"]}
    start = {**nom, "modal_damping_ratio": 1.3 * nom["modal_damping_ratio"]}
    res = sensitivity_update(plant.build, start, ["modal_damping_ratio", "E_pa"],
                             measured(truth, 4))
    assert res.converged and np.abs(_rel(res, truth)).max() < 1e-10
    # with a suspension dashpot (non-proportional; it damps the 3.6 and 4.1 Hz
    # suspension modes by 12-13 %) both damping parameters separate
    truth = {**nom, "suspension_damping_n_s_m": 2.0}
    start = {**truth, "suspension_damping_n_s_m": 2.6, "modal_damping_ratio": 0.0065}
    names = ["modal_damping_ratio", "suspension_damping_n_s_m"]
    res = sensitivity_update(plant.build, start, names, measured(truth, 6))
    assert res.converged and np.abs(_rel(res, truth)).max() < 1e-10
    assert res.condition_number < 3 and abs(res.correlation[0, 1]) < 0.5


# --------------------------------------------------------------------------------------
# what is not data is not updated
# --------------------------------------------------------------------------------------
def test_damping_parameter_without_damping_data_is_not_identifiable():
    truth = dict(HUB_NOM)
    start = {**truth, DAMPER: 6.0}
    for meas in (hub_measured(truth, damping=False),
                 MeasuredModes(*(lambda m: (m.freq_hz, m.shapes, m.dof_index))(
                     hub_measured(truth)), damping_ratio=[np.nan] * 4)):
        with pytest.raises(IdentifiabilityError,
                           match=r"\['hub_damping_n_m_s_rad \(damping\)'\] change only the "
                                 r"damping.*damping ratios must be measured"):
            sensitivity_update(HUB.build, start, [DAMPER, "E_pa"], meas)
    with pytest.raises(IdentifiabilityError,
                       match=r"\['modal_damping_ratio \(modal_damping\)'\].*damping ratios "
                             r"must be measured"):
        sensitivity_update(HUB.build, start, ["modal_damping_ratio"],
                           hub_measured(truth, damping=False))
    with pytest.raises(IdentifiabilityError, match=r"switched off \('c_zeta' = 0\)"):
        sensitivity_update(HUB.build, start, [DAMPER], hub_measured(truth), c_zeta=0.0)

    # a builder without damping: the parameter changes nothing, and the message says
    # what the builder must return
    def build_mk(theta):
        m = HUB.build(theta)
        return m.M, m.K

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "damping ratios are not used"
        with pytest.raises(IdentifiabilityError,
                           match=r"\['hub_damping_n_m_s_rad'\] change none.*must return "
                                 r"the damping too"):
            sensitivity_update(build_mk, start, [DAMPER], hub_measured(truth))


def test_damping_data_with_an_undamped_builder_is_ignored_with_a_warning():
    truth = {**HUB_NOM, "E_pa": 0.97 * HUB_NOM["E_pa"]}

    def build_mk(theta):
        m = HUB.build(theta)
        return m.M, m.K

    with_z = hub_measured(truth, phase=1.0)
    no_z = hub_measured(truth, damping=False, phase=1.0)
    with pytest.warns(UserWarning, match="builder returns only \\(M, K\\): the damping "
                                         "ratios are not used"):
        a = sensitivity_update(build_mk, HUB_NOM, ["E_pa"], with_z)
    b = sensitivity_update(build_mk, HUB_NOM, ["E_pa"], no_z)
    np.testing.assert_array_equal(a.values, b.values)
    assert a.row_counts["damping"] == 0


def test_structural_update_ignores_damping_rows():
    """With a damping model and measured damping but only stiffness parameters, the
    damping rows are left out (the damping mismatch could only bias E)."""
    truth = {**HUB_NOM, "E_pa": 0.97 * HUB_NOM["E_pa"]}
    res = sensitivity_update(HUB.build, HUB_NOM, ["E_pa"], hub_measured(truth))
    assert res.row_counts["damping"] == 0 and res.converged
    assert abs(_rel(res, truth)[0]) < 1e-8


def test_measured_damping_ratio_validation():
    mm = MeasuredModes([10.0, 20.0], np.ones((3, 2)), [0, 1, 2],
                       damping_ratio=[0.01, np.nan])
    assert mm.has_damping and not mm.damping_ratio.flags.writeable
    assert not MeasuredModes([10.0], np.ones((3, 1)), [0, 1, 2]).has_damping
    assert not MeasuredModes([10.0], np.ones((3, 1)), [0, 1, 2],
                             damping_ratio=[np.nan]).has_damping
    for bad in ([0.01], [0.01, -0.1], [0.01, 1.0], [0.01, np.inf]):
        with pytest.raises(ValueError, match=r"'damping_ratio' must have shape \(2,\)"):
            MeasuredModes([10.0, 20.0], np.ones((3, 2)), [0, 1, 2], damping_ratio=bad)
    with pytest.raises(ValueError, match="'c_zeta' must be"):
        sensitivity_update(HUB.build, HUB_NOM, [DAMPER], hub_measured(HUB_NOM), c_zeta=-1)
    with pytest.raises(ValueError, match="must return \\(M, K\\), \\(M, C, K\\) or a "
                                         "StructuralModel; got a 4-tuple"):
        system_matrices(lambda th: (1, 2, 3, 4), HUB_NOM)
