"""The two plants: the exact hub-beam frequency equation, strain output, stations."""

import numpy as np
import pytest

from truthbench.errors import ModelError
from truthbench.fe.beam import TubeSection
from truthbench.plants import Actuator, Sensor, make_plant

HUB_ROOTS = {  # the hub-beam frequency equation, lambda = beta L
    0.1: [2.638924696, 4.79377085, 7.875652943, 11.00310416],
    1 / 3: [2.213498732, 4.72340047, 7.860971497],
    1.0: [2.010003322, 4.703794262, 7.856823551, 10.99629338],
    10.0: [1.89007648, 4.695058307],
}


def _beam_constants(p):
    s = TubeSection(p["r_m"], p["t_m"])
    return p["E_pa"] * s.second_moment_m4, p["rho_kg_m3"] * s.area_m2, p["L_m"]


@pytest.mark.parametrize("eta", sorted(HUB_ROOTS))
def test_hub_beam_matches_frequency_equation(eta):
    plant = make_plant("hub_beam", n_elements=20)
    EI, rhoA, L = _beam_constants(plant.resolve())
    model = plant.build({"hub_inertia_kg_m2": eta * rhoA * L**3, "hub_damping_n_m_s_rad": 0})
    md = model.modes()
    in_plane = np.array([lab.endswith((".y", ".rz")) for lab in model.dof_labels])
    frac = (md.shapes[in_plane] ** 2).sum(0) / (md.shapes**2).sum(0)
    omega = md.omega_rad_s[frac > 0.99]
    assert omega[0] == 0.0  # the rigid-body root lambda = 0
    roots = np.array(HUB_ROOTS[eta])
    exact = roots**2 * np.sqrt(EI / (rhoA * L**4))
    np.testing.assert_allclose(omega[1:1 + len(roots)], exact, rtol=5e-4)


def test_root_strain_equals_beam_theory_under_static_tip_load():
    """Cantilever (hub held): root surface strain = c F L / (E I); Hermite elements are
    exact for a tip load."""
    plant = make_plant("hub_beam", n_elements=8)
    p = plant.resolve()
    model = plant.build(None, [Actuator("tip", "y")], [Sensor("root", "y", "strain")])
    keep = np.array([lab != "n0.rz" for lab in model.dof_labels])
    K = model.K.toarray()[np.ix_(keep, keep)]
    u = np.linalg.solve(K, model.B[keep, 0])  # 1 N at the tip
    strain = model.C_out[0, keep] @ u
    EI, _, L = _beam_constants(p)
    c = p["r_m"] + p["t_m"] / 2
    # +y tip force: moment at root -F L about z at the +y surface gives compression
    assert strain == pytest.approx(-c * L / EI, rel=1e-10)


def test_free_free_beam_has_suspension_modes_and_flexible_modes():
    plant = make_plant("free_free_beam", n_elements=20)
    model = plant.build()
    md = model.modes()
    EI, rhoA, L = _beam_constants(plant.resolve())
    first = 4.73004074486**2 * np.sqrt(EI / (rhoA * L**4))
    # 4 unrestrained rigid modes (x, y, rx, rz); 2 suspension modes well below the first
    assert md.rigid.sum() == 4
    sus = md.omega_rad_s[~md.rigid][:2]
    assert np.all(sus < 0.15 * first)
    assert plant.resolve()["suspension_stiffness_n_m"] == 200.0


def test_added_mass_groups_and_lengths():
    plant = make_plant("free_free_beam", n_elements=20, n_groups=4)
    assert plant.group_names == ("g1", "g2", "g3", "g4")
    assert "E_pa@g3" in plant.parameter_names()
    x = plant.node_x_m(plant.resolve({"L_m@g1": 0.9}))
    assert x[-1] == pytest.approx(0.9 + 3 * 0.45)
    base = plant.build()
    stiff = plant.build({"E_pa@g2": 2 * 68.9e9})
    assert not np.allclose(base.K.toarray(), stiff.K.toarray())
    np.testing.assert_allclose(base.M.toarray(), stiff.M.toarray(), rtol=0,
                               atol=1e-14 * abs(base.M).max())


def test_plant_bad_input():
    plant = make_plant("free_free_beam", n_elements=20)
    with pytest.raises(ModelError, match="no station 'nose'"):
        plant.build(None, [], [Sensor("nose", "z")])
    with pytest.raises(ModelError, match="no parameter 'E'"):
        plant.resolve({"E": 1.0})
    with pytest.raises(ModelError, match="'L_m' must be a positive"):
        plant.resolve({"L_m": -1.0})
    with pytest.raises(ModelError, match="station 'odd' at fraction 0.33 of the length lies "
                                         "between nodes 6 and 7"):
        make_plant("free_free_beam", n_elements=20, stations={"odd": 0.33}).build(
            None, [], [Sensor("odd", "z")])
    with pytest.raises(ModelError, match="unknown plant type"):
        make_plant("tripod")
    with pytest.raises(ModelError, match="clamped"):
        make_plant("hub_beam").build(None, [Actuator("hub", "x")], [])
    with pytest.raises(ModelError, match="direction"):
        plant.build(None, [], [Sensor("mid", "up")])
    with pytest.raises(ModelError, match="multiple of n_groups"):
        make_plant("hub_beam", n_elements=10, n_groups=3)
