"""The tube element against Table 10.2 (the chapter's Section 10.1.1) and basic mechanics."""

import numpy as np
import pytest

from truthbench.fe.beam import (
    TubeSection,
    element_matrices,
    rotation_matrix,
    sag_rotation,
    transformation_matrix,
)

NOMINAL = dict(E_pa=70e9, nu=0.3, rho_kg_m3=2700.0, r_m=0.012, t_m=0.0015, L_m=0.2)
AXIAL, V, W, TORSION, RY, RZ = range(6)


def _aa(**kw):
    p = {**NOMINAL, **kw}
    k, m = element_matrices(p["E_pa"], p["nu"], p["rho_kg_m3"], TubeSection(p["r_m"], p["t_m"]),
                            p["L_m"])
    return k[:6, :6], m[:6, :6]


def _percent_change(name):
    """First-order % change of every non-zero A-A entry for a +1 % change of ``name``
    (central difference in log space, exact for power laws)."""
    h = 1e-4
    kp, mp = _aa(**{name: NOMINAL[name] * (1 + h)})
    km, mm = _aa(**{name: NOMINAL[name] * (1 - h)})
    k0, m0 = _aa()
    with np.errstate(divide="ignore", invalid="ignore"):
        dk = np.where(k0 != 0, (kp - km) / (2 * h * k0), 0.0)
        dm = np.where(m0 != 0, (mp - mm) / (2 * h * m0), 0.0)
    return dk, dm, k0 != 0, m0 != 0


def test_table_10_2_E_and_rho():
    dk, dm, kz, mz = _percent_change("E_pa")
    assert np.allclose(dk[kz], 1.0, atol=1e-6) and np.allclose(dm[mz], 0.0, atol=1e-9)
    dk, dm, kz, mz = _percent_change("rho_kg_m3")
    assert np.allclose(dk[kz], 0.0, atol=1e-9) and np.allclose(dm[mz], 1.0, atol=1e-6)


def test_table_10_2_radius():
    dk, dm, kz, mz = _percent_change("r_m")
    expected_m = np.where(mz, 1.0, 0.0)
    expected_m[TORSION, TORSION] = 3.0
    expected_k = np.where(kz, 3.0, 0.0)
    expected_k[AXIAL, AXIAL] = 1.0
    np.testing.assert_allclose(dm, expected_m, atol=1e-6)
    np.testing.assert_allclose(dk, expected_k, atol=1e-6)


def test_table_10_2_thickness_acts_like_E_and_rho_together():
    dk, dm, kz, mz = _percent_change("t_m")
    assert np.allclose(dk[kz], 1.0, atol=1e-6) and np.allclose(dm[mz], 1.0, atol=1e-6)


def test_table_10_2_length_powers():
    dk, dm, kz, mz = _percent_change("L_m")
    em = np.zeros((6, 6))
    em[AXIAL, AXIAL] = em[V, V] = em[W, W] = em[TORSION, TORSION] = 1.0
    em[V, RZ] = em[RZ, V] = em[W, RY] = em[RY, W] = 2.0
    em[RY, RY] = em[RZ, RZ] = 3.0
    ek = np.zeros((6, 6))
    ek[AXIAL, AXIAL] = ek[TORSION, TORSION] = ek[RY, RY] = ek[RZ, RZ] = -1.0
    ek[V, V] = ek[W, W] = -3.0
    ek[V, RZ] = ek[RZ, V] = ek[W, RY] = ek[RY, W] = -2.0
    np.testing.assert_allclose(dm, em, atol=1e-6)
    np.testing.assert_allclose(dk, ek, atol=1e-6)


def test_table_10_2_poisson_only_torsion():
    dk, dm, kz, mz = _percent_change("nu")
    nu = NOMINAL["nu"]
    expected = np.zeros((6, 6))
    expected[TORSION, TORSION] = -nu / (1 + nu)
    np.testing.assert_allclose(dk, expected, atol=1e-7)
    assert np.allclose(dm, 0.0)


def test_aa_blocks_match_eq_10_3_entries():
    k, m = _aa()
    p = NOMINAL
    s = TubeSection(p["r_m"], p["t_m"])
    A, I, J, L, rho, E = s.area_m2, s.second_moment_m4, s.polar_moment_m4, p["L_m"], \
        p["rho_kg_m3"], p["E_pa"]
    G = E / (2 * (1 + p["nu"]))
    assert m[V, RZ] == pytest.approx(rho * 11 * A * L**2 / 210, rel=1e-12)
    assert m[W, RY] == pytest.approx(-rho * 11 * A * L**2 / 210, rel=1e-12)
    assert m[TORSION, TORSION] == pytest.approx(rho * J * L / 3, rel=1e-12)
    assert k[V, RZ] == pytest.approx(6 * E * I / L**2, rel=1e-12)
    assert k[W, RY] == pytest.approx(-6 * E * I / L**2, rel=1e-12)
    assert k[TORSION, TORSION] == pytest.approx(G * J / L, rel=1e-12)
    assert A == pytest.approx(2 * np.pi * 0.012 * 0.0015)


@pytest.mark.parametrize("timoshenko", [False, True])
def test_element_symmetric_with_six_rigid_body_modes_in_any_orientation(timoshenko):
    k, m = element_matrices(70e9, 0.3, 2700.0, TubeSection(0.012, 0.0015), 0.3,
                            timoshenko=timoshenko)
    assert np.allclose(k, k.T) and np.allclose(m, m.T)
    R = rotation_matrix(np.array([0.3, -1.2, 0.7]))
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
    T = transformation_matrix(R)
    kg = T.T @ k @ T
    lam = np.linalg.eigvalsh(kg)
    assert np.sum(np.abs(lam) < 1e-9 * lam.max()) == 6
    # rigid translations along global axes produce no force
    xa, xb = np.zeros(3), 0.3 * R[0]
    for d in range(3):
        u = np.zeros(12)
        u[d] = u[6 + d] = 1.0
        assert np.abs(kg @ u).max() < 1e-6 * np.abs(kg).max()
    # rigid rotation about global z: translations omega x position
    u = np.zeros(12)
    u[5] = u[11] = 1.0
    u[6:9] = np.cross([0, 0, 1.0], xb - xa)
    assert np.abs(kg @ u).max() < 1e-6 * np.abs(kg).max()
    # positive definite mass
    assert np.linalg.eigvalsh(m).min() > 0


def test_sag_rotation_is_identity_at_zero_and_orthogonal():
    np.testing.assert_array_equal(sag_rotation(0.0), np.eye(3))
    T = sag_rotation(0.1)
    np.testing.assert_allclose(T @ T.T, np.eye(3), atol=1e-15)
    assert T[0, 2] == pytest.approx(-np.sin(0.1)) and T[2, 0] == pytest.approx(np.sin(0.1))


@pytest.mark.parametrize("name,value", [("L_m", -0.2), ("E_pa", 0.0), ("t_m", np.nan)])
def test_bad_element_parameters_raise(name, value):
    p = {**NOMINAL, name: value}
    with pytest.raises(ValueError, match=name):
        element_matrices(p["E_pa"], p["nu"], p["rho_kg_m3"], TubeSection(p["r_m"], p["t_m"]),
                         p["L_m"])
    with pytest.raises(ValueError, match="nu"):
        element_matrices(70e9, 0.7, 2700.0, TubeSection(0.01, 0.001), 0.1)
    with pytest.raises(ValueError, match="'section' must be a cross-section"):
        element_matrices(70e9, 0.3, 2700.0, (0.01, 0.001), 0.1)
