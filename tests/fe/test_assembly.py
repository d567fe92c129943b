"""Assembled members against the exact Euler-Bernoulli and rod solutions."""

import numpy as np
import pytest
import scipy.linalg as sla

from truthbench.fe.assembly import Lumped, assemble, finish_structure, straight_member
from truthbench.fe.beam import TubeSection, shear_modulus

PROPS = dict(E_pa=68.9e9, nu=0.33, rho_kg_m3=2700.0, r_m=0.011875, t_m=0.00165)
L = 1.8
FREE_FREE = np.array([4.73004074486, 7.85320462410, 10.9956078380, 14.1371654913,
                      17.2787596574])
CLAMPED_FREE = np.array([1.87510406871, 4.69409113297, 7.85475743824, 10.9955407349,
                         14.1371683910])


def _scale():
    s = TubeSection(PROPS["r_m"], PROPS["t_m"])
    return np.sqrt(PROPS["E_pa"] * s.second_moment_m4 / (PROPS["rho_kg_m3"] * s.area_m2 * L**4))


def _modes(n_el, clamped=(), keep=None):
    """Modes of a straight member; ``keep`` (direction indices) restricts every node to
    those DOFs (a planar problem, which separates the degenerate y/z bending pairs)."""
    mesh = straight_member([0, 0, 0], [L, 0, 0], n_el)
    if keep is not None:
        clamped = set(clamped) | {i for i in range(mesh.n_dofs) if i % 6 not in keep}
    K, M = assemble(mesh, {"beam": PROPS})
    Mf, _, Kf, free = finish_structure(K, M, mesh.n_dofs, clamped=clamped)
    lam, Phi = sla.eigh(Kf.toarray(), Mf.toarray())
    labels = np.array(mesh.dof_labels())[free]
    return np.sqrt(np.clip(lam, 0, None)), Phi, labels


BENDING_XZ, AXIAL, TORSION = (2, 4), (0,), (3,)


def test_six_rigid_body_modes_unconstrained():
    omega, _, _ = _modes(20)
    # rigid modes: omega below 1e-4 of the first flexible frequency (dense eigh leaves
    # rigid frequencies at about sqrt(eps * omega_max^2), here ~1e-5 of the first)
    first = FREE_FREE[0] ** 2 * _scale()
    assert np.sum(omega < 1e-4 * first) == 6
    assert omega[6] > 0.99 * first


@pytest.mark.parametrize("case,roots,clamped", [("free-free", FREE_FREE, ()),
                                                 ("clamped-free", CLAMPED_FREE, range(6))])
def test_bending_frequencies_within_005_percent_at_20_elements(case, roots, clamped):
    omega, _, _ = _modes(20, clamped, keep=BENDING_XZ)
    bend = omega[omega > 1e-3 * roots[0] ** 2 * _scale()][:5]
    exact = roots**2 * _scale()
    err = bend / exact - 1
    assert np.all(err > 0)  # consistent mass overestimates
    assert np.all(err < 5e-4), err


def test_bending_error_falls_16_times_per_halving():
    exact = FREE_FREE[:3] ** 2 * _scale()
    errs = []
    for n in (10, 20, 40):
        omega, _, _ = _modes(n, keep=BENDING_XZ)
        errs.append(omega[omega > 1.0][:3] / exact - 1)
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    # h^4 convergence: 2^4 = 16; pre-asymptotic terms keep the ratio a little below 16
    assert np.all((ratios > 14.5) & (ratios < 16.5)), ratios


def test_axial_and_torsional_frequencies_against_rod_formulas():
    n = 20
    h = L / n
    for keep, wave_speed in ((AXIAL, np.sqrt(PROPS["E_pa"] / PROPS["rho_kg_m3"])),
                             (TORSION, np.sqrt(shear_modulus(PROPS["E_pa"], PROPS["nu"])
                                             / PROPS["rho_kg_m3"]))):
        w, _, _ = _modes(n, keep=keep)
        w = w[w > 1.0][:3]
        k = np.arange(1, 4) * np.pi / L
        exact = wave_speed * k
        # exact discrete dispersion of the consistent linear element (free ends):
        # omega^2 = 6 c^2 / h^2 (1 - cos kh) / (2 + cos kh)
        discrete = np.sqrt(6 * wave_speed**2 / h**2 * (1 - np.cos(k * h)) / (2 + np.cos(k * h)))
        np.testing.assert_allclose(w, discrete, rtol=1e-9)
        # against the continuum: leading error (kh)^2/24 (0.1 %, 0.4 %, 0.9 % here)
        lead = (k * h) ** 2 / 24
        np.testing.assert_allclose(w / exact - 1, lead, rtol=0.05)


def test_lumped_masses_springs_dashpots_and_clamps():
    mesh = straight_member([0, 0, 0], [1, 0, 0], 2)
    K, M = assemble(mesh, {"beam": PROPS})
    lumped = Lumped(masses=((8, 0.5),), springs=((14, 100.0),), dashpots=((2, 3.0),))
    Mf, Cf, Kf, free = finish_structure(K, M, mesh.n_dofs, lumped, clamped=[0, 1])
    assert Mf.shape == (16, 16) and list(free[:2]) == [2, 3]
    i8 = int(np.where(free == 8)[0][0])
    assert Mf[i8, i8] == pytest.approx(M[8, 8] + 0.5)
    assert Cf[0, 0] == 3.0 and Cf.nnz == 1
    with pytest.raises(ValueError, match="clamped DOFs"):
        finish_structure(K, M, mesh.n_dofs, clamped=[99])
    with pytest.raises(ValueError, match=">= 0"):
        finish_structure(K, M, mesh.n_dofs, Lumped(springs=((3, -1.0),)))


def test_sag_couples_axial_and_vertical_bending():
    mesh = straight_member([0, 0, 0], [1, 0, 0], 4)
    K0, _ = assemble(mesh, {"beam": PROPS})
    K1, _ = assemble(mesh, {"beam": PROPS}, sag_angles_rad=np.full(4, 0.01))
    x, z = np.arange(0, 30, 6), np.arange(2, 30, 6)
    assert np.abs(K0[np.ix_(x, z)].toarray()).max() == 0.0
    assert np.abs(K1[np.ix_(x, z)].toarray()).max() > 0.0


def test_missing_group_properties_raise():
    mesh = straight_member([0, 0, 0], [1, 0, 0], 2, groups=("a", "b"))
    with pytest.raises(ValueError, match="group"):
        assemble(mesh, {"a": PROPS})
    with pytest.raises(ValueError, match="n_elements"):
        straight_member([0, 0, 0], [1, 0, 0], 0)


def test_batched_assembly_equals_element_by_element_transformation():
    """The batched T^T k T equals the textbook loop with the 12x12 kron(I4, R) of each
    element, for a crooked 3D member with sag angles (nothing shared between elements)."""
    from truthbench.fe.assembly import BeamMesh
    from truthbench.fe.beam import element_matrices, rotation_matrix, sag_rotation
    from truthbench.fe.beam import transformation_matrix as T_of

    rng = np.random.default_rng(3)
    nodes = np.cumsum(rng.uniform(0.1, 0.4, size=(6, 3)), axis=0)
    nodes[3] = nodes[2] + [0.0, 0.0, 0.3]  # one vertical element (the y up-vector branch)
    elements = np.column_stack([np.arange(5), np.arange(1, 6)])
    mesh = BeamMesh(nodes, elements, ("a", "a", "b", "b", "a"))
    props = {g: {"E_pa": 70e9 * s, "nu": 0.33, "rho_kg_m3": 2700.0, "r_m": 0.012,
                 "t_m": 0.0015} for g, s in (("a", 1.0), ("b", 1.3))}
    sag = rng.uniform(-0.05, 0.05, 5)
    K, M = assemble(mesh, props, sag_angles_rad=sag)
    K0, M0 = np.zeros((36, 36)), np.zeros((36, 36))
    for e, (a, b) in enumerate(elements):
        p = props[mesh.groups[e]]
        k, m = element_matrices(p["E_pa"], p["nu"], p["rho_kg_m3"],
                                TubeSection(p["r_m"], p["t_m"]),
                                float(np.linalg.norm(nodes[b] - nodes[a])))
        T = T_of(sag_rotation(sag[e]) @ rotation_matrix(nodes[b] - nodes[a]))
        d = np.r_[6 * a + np.arange(6), 6 * b + np.arange(6)]
        K0[np.ix_(d, d)] += T.T @ k @ T
        M0[np.ix_(d, d)] += T.T @ m @ T
    assert np.max(np.abs(K.toarray() - K0)) <= 1e-12 * np.max(np.abs(K0))
    assert np.max(np.abs(M.toarray() - M0)) <= 1e-12 * np.max(np.abs(M0))
