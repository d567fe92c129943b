"""Cross-sections against oracles nobody here wrote: tabulated torsion constants, the
exact free-free Euler-Bernoulli roots in both bending planes, the exact rod
formula and the discrete dispersion of linear elements in torsion, and the Timoshenko
frequency equation of a simply supported beam.

Tolerance rule of the eigenvalue tests (``_check_bracket``): a conforming element with
consistent mass is a Rayleigh-Ritz method, so its frequencies are upper bounds that fall
under nested refinement (exact <= f_2n <= f_n). With an error ``C h^p`` the error of
``f_2n`` is ``(f_n - f_2n) / (2^p - 1)`` to leading order; we allow twice that for the
higher-order terms. ``p = 4`` for Hermite Euler-Bernoulli elements, ``p = 2``
for the Timoshenko element (its observed rate: errors fall 4x per halving here, as the
shear parameter 12 E I / (kappa G A h^2) grows with refinement). Both sides get a
round-off allowance ``n_dof eps lambda_max / lambda`` (backward-stable symmetric
eigensolver).
"""

import numpy as np
import pytest
import scipy.linalg as sla

from truthbench.fe.assembly import assemble, finish_structure, group_section, straight_member
from truthbench.fe.beam import (
    SECTIONS,
    CircularBarSection,
    RectangularBarSection,
    TubeSection,
    element_matrices,
    make_section,
    rectangle_torsion_constant,
    shear_modulus,
)

E, NU, RHO = 200e9, 0.29, 7850.0
FREE_FREE = np.array([4.73004074486, 7.85320462410, 10.9956078380, 14.1371654913])
AXIAL, V, W, TORSION, RY, RZ = range(6)


def _material(kind, **dims):
    return {"E_pa": E, "nu": NU, "rho_kg_m3": RHO, "section": kind, **dims}


def _modes(props, L, n, keep, clamped=(), timoshenko=False):
    """Frequencies (rad/s) of a straight member restricted to the DOF directions
    ``keep`` at every node, and the round-off allowance of each (relative)."""
    mesh = straight_member([0, 0, 0], [L, 0, 0], n)
    cl = {i for i in range(mesh.n_dofs) if i % 6 not in keep} | set(clamped)
    K, M = assemble(mesh, {"beam": props}, timoshenko=timoshenko)
    Mf, _, Kf, _ = finish_structure(K, M, mesh.n_dofs, clamped=cl)
    lam = sla.eigh(Kf.toarray(), Mf.toarray(), eigvals_only=True)
    lam_max = lam.max()
    lam = lam[lam > 1e-6 * lam_max ** 0.5]  # drop rigid-body zeros
    roundoff = Kf.shape[0] * np.finfo(float).eps * lam_max / lam / 2  # on omega
    return np.sqrt(lam), roundoff


def _check_bracket(f_n, f_2n, exact, p, roundoff):
    """exact <= f_2n <= f_n and f_2n - exact <= 2 (f_n - f_2n) / (2^p - 1), relative
    round-off ``roundoff`` allowed on each side."""
    slack = roundoff * exact
    assert np.all(f_2n <= f_n + slack), (f_n, f_2n)
    assert np.all(exact <= f_2n + slack), (f_2n / exact - 1)
    bound = 2.0 * (f_n - f_2n) / (2.0**p - 1.0)
    assert np.all(f_2n - exact <= bound + slack), ((f_2n - exact) / exact, bound / exact)


# ---- section properties ---------------------------------------------------------------

# Timoshenko and Goodier, Theory of Elasticity (3rd ed.), Sect. 109, table of k1 in
# J = k1 a b^3 (a the long side, b the short one), three decimals
TORSION_TABLE = {1.0: 0.141, 1.2: 0.166, 1.5: 0.196, 2.0: 0.229, 2.5: 0.249, 3.0: 0.263,
                 4.0: 0.281, 5.0: 0.291, 10.0: 0.312}


@pytest.mark.parametrize("ratio", sorted(TORSION_TABLE))
def test_rectangle_torsion_constant_matches_the_table(ratio):
    b = 0.01
    k1 = rectangle_torsion_constant(ratio * b, b) / (ratio * b * b**3)
    assert abs(k1 - TORSION_TABLE[ratio]) <= 0.0005  # half a unit of the table's last digit
    assert rectangle_torsion_constant(b, ratio * b) == rectangle_torsion_constant(ratio * b, b)


def test_rectangle_torsion_constant_thin_strip():
    """Timoshenko and Goodier's narrow-rectangle formula J = a b^3 / 3 (1 - 0.630 b / a):
    exact but for exponentially small terms at a / b = 10; the printed coefficient's
    rounding (0.0005) allows 0.0005 b / a = 5e-5 relative."""
    a, b = 1.0, 0.1
    assert rectangle_torsion_constant(a, b) == pytest.approx(a * b**3 / 3 * (1 - 0.630 * b / a),
                                                             rel=5e-5 / (1 - 0.063))


def test_section_formulas():
    r = RectangularBarSection(b_m=0.03, h_m=0.01)
    assert r.area_m2 == pytest.approx(3e-4)
    assert r.second_moment_y_m4 == pytest.approx(0.03 * 0.01**3 / 12)
    assert r.second_moment_z_m4 == pytest.approx(0.01 * 0.03**3 / 12)
    assert r.polar_moment_m4 == pytest.approx(r.second_moment_y_m4 + r.second_moment_z_m4)
    assert r.torsion_constant_m4 < r.polar_moment_m4  # warping: J < I_p off the circle
    assert r.shear_coefficient(0.3) == pytest.approx(10 * 1.3 / 15.3)
    assert (r.outer_fibre_m("y"), r.outer_fibre_m("z")) == (0.015, 0.005)
    c = CircularBarSection(d_m=0.02)
    assert c.area_m2 == pytest.approx(np.pi * 1e-4)
    assert c.second_moment_y_m4 == c.second_moment_z_m4 == pytest.approx(np.pi * 0.02**4 / 64)
    assert c.torsion_constant_m4 == c.polar_moment_m4 == pytest.approx(np.pi * 0.02**4 / 32)
    assert c.shear_coefficient(0.3) == pytest.approx(6 * 1.3 / 8.8)
    assert c.outer_fibre_m("z") == 0.01
    t = TubeSection(0.012, 0.0015)
    assert t.shear_coefficient(0.3) == 0.5 and t.outer_fibre_m("y") == 0.012 + 0.00075
    assert t.second_moment_y_m4 == t.second_moment_z_m4 == t.second_moment_m4
    assert t.torsion_constant_m4 == t.polar_moment_m4
    assert set(SECTIONS) == {"tube", "rectangular_bar", "circular_bar"}


def test_tube_given_by_name_or_by_its_keys_is_the_same_element():
    tube = make_section("tube", {"r_m": 0.012, "t_m": 0.0015, "E_pa": 1.0})
    assert tube == TubeSection(0.012, 0.0015)
    assert group_section({"r_m": 0.012, "t_m": 0.0015}) == tube
    assert group_section({"section": tube}) is tube


def test_bad_sections_raise():
    with pytest.raises(ValueError, match=r"'section' must be one of 'tube', "
                                         r"'rectangular_bar', 'circular_bar'; got 'box'"):
        make_section("box", {})
    with pytest.raises(ValueError, match="rectangular_bar section needs b_m, h_m; missing h_m"):
        make_section("rectangular_bar", {"b_m": 0.01})
    with pytest.raises(ValueError, match=r"'d_m' must be a positive finite number \(m\); "
                                         r"got -0.01"):
        CircularBarSection(-0.01)
    with pytest.raises(ValueError, match="group 'beam'.*missing d_m"):
        group_section({"section": "circular_bar"}, "beam")
    with pytest.raises(ValueError, match="direction must be 'y' or 'z'"):
        CircularBarSection(0.01).outer_fibre_m("x")
    mesh = straight_member([0, 0, 0], [1, 0, 0], 2)
    with pytest.raises(ValueError, match="lacks property 'nu'"):
        assemble(mesh, {"beam": {"E_pa": E, "rho_kg_m3": RHO, "section": "circular_bar",
                                 "d_m": 0.01}})


def test_rectangular_element_uses_I_y_for_x_z_bending_and_I_z_for_x_y():
    sec = RectangularBarSection(b_m=0.03, h_m=0.01)
    L = 0.2
    k, m = element_matrices(E, NU, RHO, sec, L)
    assert k[W, W] == pytest.approx(12 * E * sec.second_moment_y_m4 / L**3, rel=1e-12)
    assert k[V, V] == pytest.approx(12 * E * sec.second_moment_z_m4 / L**3, rel=1e-12)
    assert k[TORSION, TORSION] == pytest.approx(
        shear_modulus(E, NU) * sec.torsion_constant_m4 / L, rel=1e-12)
    assert m[TORSION, TORSION] == pytest.approx(RHO * sec.polar_moment_m4 * L / 3, rel=1e-12)
    assert m[V, V] == m[W, W] == pytest.approx(13 / 35 * RHO * sec.area_m2 * L, rel=1e-12)
    kt, mt = element_matrices(E, NU, RHO, sec, L, timoshenko=True)
    np.testing.assert_allclose(kt, kt.T, atol=1e-9 * np.abs(kt).max())
    # shear softens the plane with the larger I more (phi = 12 E I / (kappa G A L^2))
    assert kt[V, V] / k[V, V] < kt[W, W] / k[W, W] < 1.0


# ---- frequencies against exact solutions --------------------------------------------------

def test_rectangular_bar_free_free_in_both_planes():
    """b = 30 mm (y), h = 10 mm (z): lateral (x-y) bending is 3 times stiffer in
    frequency than vertical (x-z); each plane matches its own exact roots."""
    L, dims = 0.8, {"b_m": 0.03, "h_m": 0.01}
    sec = RectangularBarSection(**dims)
    props = _material("rectangular_bar", **dims)
    for keep, I in (((W, RY), sec.second_moment_y_m4), ((V, RZ), sec.second_moment_z_m4)):
        exact = FREE_FREE**2 * np.sqrt(E * I / (RHO * sec.area_m2 * L**4))
        f_n, _ = _modes(props, L, 16, keep)
        f_2n, roundoff = _modes(props, L, 32, keep)
        _check_bracket(f_n[:4], f_2n[:4], exact, 4, roundoff[:4])
    ratio = np.sqrt(sec.second_moment_z_m4 / sec.second_moment_y_m4)
    assert ratio == pytest.approx(3.0)


@pytest.mark.parametrize("sec", [CircularBarSection(0.02), RectangularBarSection(0.03, 0.01)],
                         ids=["circular", "rectangular"])
def test_torsion_against_rod_formula(sec):
    """Free-free torsion: omega_n = (n pi / L) sqrt(G J / (rho I_p)); for the circle
    J = I_p and this is (n pi / L) sqrt(G / rho). Linear elements with consistent mass
    follow the exact discrete dispersion omega^2 = 6 c^2 / h^2 (1 - cos kh) / (2 + cos kh)."""
    L, n = 1.0, 20
    h = L / n
    props = _material(sec.kind, **{d: getattr(sec, d) for d in sec.dimensions})
    w, _ = _modes(props, L, n, (TORSION,))
    G = shear_modulus(E, NU)
    c = np.sqrt(G * sec.torsion_constant_m4 / (RHO * sec.polar_moment_m4))
    if sec.kind == "circular_bar":
        assert c == pytest.approx(np.sqrt(G / RHO), rel=1e-14)
    k = np.arange(1, 4) * np.pi / L
    discrete = np.sqrt(6 * c**2 / h**2 * (1 - np.cos(k * h)) / (2 + np.cos(k * h)))
    np.testing.assert_allclose(w[:3], discrete, rtol=1e-9)
    # against the continuum: leading error (kh)^2 / 24, next term O((kh)^4)
    np.testing.assert_allclose(w[:3] / (c * k) - 1, (k * h) ** 2 / 24, rtol=0.05)


def _timoshenko_simply_supported(sec, L, modes):
    """Lower roots of the Timoshenko frequency equation of a simply supported beam
    (w = W sin kx, psi = Psi cos kx, k = j pi / L, in kappa G A (w'' - psi') = rho A w_tt,
    E I psi'' + kappa G A (w' - psi) = rho I psi_tt): the 2x2 determinant
    (rho A w^2 - kGA k^2)(rho I w^2 - E I k^2 - kGA) - (kGA k)^2 = 0."""
    G = shear_modulus(E, NU)
    A, I, kGA = sec.area_m2, sec.second_moment_y_m4, sec.shear_coefficient(NU) * G * \
        sec.area_m2
    out = []
    for j in range(1, modes + 1):
        k = j * np.pi / L
        a = RHO * A * RHO * I
        b = -(RHO * A * (E * I * k**2 + kGA) + RHO * I * kGA * k**2)
        c = kGA * k**2 * (E * I * k**2 + kGA) - (kGA * k) ** 2
        out.append(np.sqrt((-b - np.sqrt(b * b - 4 * a * c)) / (2 * a)))
    return np.array(out)


@pytest.mark.parametrize("sec", [CircularBarSection(0.05), RectangularBarSection(0.03, 0.06)],
                         ids=["circular", "rectangular"])
def test_timoshenko_simply_supported_stocky_bar(sec):
    """L = 0.5 m: shear and rotary inertia lower the frequencies by 1-2 % (mode 1) to
    14-23 % (mode 4) below Euler-Bernoulli; the Timoshenko element follows the exact
    equation, the Euler-Bernoulli element does not."""
    L = 0.5
    props = _material(sec.kind, **{d: getattr(sec, d) for d in sec.dimensions})
    exact = _timoshenko_simply_supported(sec, L, 4)

    def ss(n):  # x-z plane, w = 0 at both ends
        return _modes(props, L, n, (W, RY), clamped=(W, 6 * n + W), timoshenko=True)

    f_n, _ = ss(32)
    f_2n, roundoff = ss(64)
    _check_bracket(f_n[:4], f_2n[:4], exact, 2, roundoff[:4])
    eb, _ = _modes(props, L, 64, (W, RY), clamped=(W, 6 * 64 + W))
    assert np.all(eb[:4] / exact - 1 > 0.01)  # the shear effect is far above the FE error
