"""Macroelements (Eq. 10.40) against Table 10.2 of the chapter and the linearity identity."""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

from truthbench.plants import make_plant
from truthbench.update.macroelements import Macroelement, macroelement_matrices

PLANT = make_plant("free_free_beam", n_elements=8, n_groups=2)
NOMINAL = PLANT.resolve()
THETA = {**NOMINAL, **{f"{k}@{g}": NOMINAL[k] for k in ("E_pa", "rho_kg_m3", "r_m", "t_m", "nu")
                       for g in PLANT.group_names}}
LABELS = PLANT.build().dof_labels


def build_mk(theta):
    m = PLANT.build(theta)
    return m.M, m.K


def _dof(node, direction):
    return LABELS.index(f"n{node}.{direction}")


def _ratios(me, M, K, node):
    """Relative change of the diagonal entries at ``node`` per 1 % parameter change:
    ``K_k[i, i] / K[i, i]`` for the directions x, z, rx, ry (and likewise M)."""
    out = {}
    for d in ("x", "z", "rx", "ry"):
        i = _dof(node, d)
        out[d] = (me.dK[i, i] / K[i, i], me.dM[i, i] / M[i, i])
    return out


# node 3 joins elements 2 and 3, both in g1 (elements 0..3), and carries no suspension
# spring (those sit at nodes round(0.224 * 8) = 2 and round(0.776 * 8) = 6)
INTERIOR = 3


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        # Table 10.2, A-A blocks: (stiffness ratio, mass ratio) per 1 % change
        ("E_pa@g1", {"x": (1, 0), "z": (1, 0), "rx": (1, 0), "ry": (1, 0)}),
        ("rho_kg_m3@g1", {"x": (0, 1), "z": (0, 1), "rx": (0, 1), "ry": (0, 1)}),
        ("t_m@g1", {"x": (1, 1), "z": (1, 1), "rx": (1, 1), "ry": (1, 1)}),
        # r: mass +1, torsion mass +3 (J = 2 pi r^3 t), axial stiffness +1, bending and
        # torsion stiffness +3; the rotational mass entry A L^3/105 scales with A: +1
        ("r_m@g1", {"x": (1, 1), "z": (3, 1), "rx": (3, 3), "ry": (3, 1)}),
        # nu: torsion stiffness only, -nu / (1 + nu)
        ("nu@g1", {"x": (0, 0), "z": (0, 0), "rx": (-0.33 / 1.33, 0), "ry": (0, 0)}),
    ],
)
def test_table_10_2_patterns(name, expected):
    """The relative-change macroelement reproduces the chapter's Table 10.2 entries at a
    node inside the group."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        (me,) = macroelement_matrices(build_mk, THETA, [name])
    M, K = build_mk(THETA)
    got = _ratios(me, M, K, INTERIOR)
    for d, (k_ratio, m_ratio) in expected.items():
        assert got[d][0] == pytest.approx(k_ratio, abs=2e-5), (name, d, "K")
        assert got[d][1] == pytest.approx(m_ratio, abs=2e-5), (name, d, "M")


def test_length_pattern():
    """L +1 %: entries in L^k change by k %, entries in 1/L^k by -k % (Table 10.2)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        (me,) = macroelement_matrices(build_mk, THETA, ["L_m"])
    M, K = build_mk(THETA)
    i = {d: _dof(INTERIOR, d) for d in ("x", "z", "ry")}
    assert me.dK[i["x"], i["x"]] / K[i["x"], i["x"]] == pytest.approx(-1, abs=1e-5)  # EA/L
    assert me.dK[i["z"], i["z"]] / K[i["z"], i["z"]] == pytest.approx(-3, abs=1e-5)  # EI/L^3
    assert me.dK[i["ry"], i["ry"]] / K[i["ry"], i["ry"]] == pytest.approx(-1, abs=1e-5)
    assert me.dM[i["z"], i["z"]] / M[i["z"], i["z"]] == pytest.approx(1, abs=1e-5)  # A L
    assert me.dM[i["ry"], i["ry"]] / M[i["ry"], i["ry"]] == pytest.approx(3, abs=1e-5)


def test_group_locality():
    """E of g1 does not touch the stiffness of nodes that only g2 elements reach."""
    (me,) = macroelement_matrices(build_mk, THETA, ["E_pa@g1"])
    outside = [i for i, lab in enumerate(LABELS) if int(lab.split(".")[0][1:]) >= 5]
    assert abs(me.dK[outside][:, outside]).max() == 0.0
    assert me.dM.nnz == 0  # exactly zero, not rounding noise


@pytest.mark.parametrize("name", ["E_pa@g2", "rho_kg_m3@g1", "t_m@g2",
                                  "suspension_stiffness_n_m"])
def test_linear_parameters_are_exact_for_large_changes(name):
    """For a linear parameter ``K(theta (1 + a)) = K + a K_k`` exactly (a = 0.3)."""
    (me,) = macroelement_matrices(build_mk, THETA, [name])
    assert me.linear and me.nonlinearity < 1e-7  # rounding level
    th = dict(THETA)
    th[name] = THETA[name] * 1.3
    M1, K1 = build_mk(th)
    M0, K0 = build_mk(THETA)
    for big, small, d in ((K1, K0, me.dK), (M1, M0, me.dM)):
        err = sp.linalg.norm(big - small - 0.3 * d)
        assert err <= 1e-10 * sp.linalg.norm(small)


def test_nonlinear_parameters_warn_and_are_flagged():
    with pytest.warns(UserWarning, match=r"nonlinearly on parameters 'r_m@g1'.*'L_m'"):
        macs = macroelement_matrices(build_mk, THETA, ["E_pa@g1", "r_m@g1", "L_m"])
    assert [m.linear for m in macs] == [True, False, False]
    assert all(m.nonlinearity > 1e-5 for m in macs[1:])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # linear only: no warning
        macroelement_matrices(build_mk, THETA, ["E_pa@g1", "rho_kg_m3@g2"])


def test_dense_input_and_no_side_effects():
    theta = dict(THETA)
    before = dict(theta)

    def dense(th):
        M, K = build_mk(th)
        return M.toarray(), K.toarray()

    (a,) = macroelement_matrices(dense, theta, ["E_pa@g2"])
    (b,) = macroelement_matrices(build_mk, theta, ["E_pa@g2"])
    assert theta == before
    assert isinstance(a, Macroelement) and sp.issparse(a.dK) and a.value == THETA["E_pa@g2"]
    assert sp.linalg.norm(a.dK - b.dK) <= 1e-12 * sp.linalg.norm(b.dK)


def test_errors():
    with pytest.raises(ValueError, match=r"\['E_pa@g9'\] are not in theta"):
        macroelement_matrices(build_mk, THETA, ["E_pa@g9"])
    with pytest.raises(ValueError, match=r"non-zero parameter values; got 0 for \['z'\]"):
        macroelement_matrices(lambda th: (np.eye(2), np.eye(2)), {"z": 0.0}, ["z"])
    with pytest.raises(ValueError, match="relative_step must lie in"):
        macroelement_matrices(build_mk, THETA, ["E_pa"], relative_step=0.5)

    def growing(th):
        n = 2 if th["a"] == 1.0 else 3
        return np.eye(n), th["a"] * np.eye(n)

    with pytest.raises(ValueError, match="returned 3 DOFs at a perturbed parameter; expected 2"):
        macroelement_matrices(growing, {"a": 1.0}, ["a"])
