"""A joint as a concentrated hinge (``form = "hinge"``).

Against beam theory: a cantilever of one element with a rotational spring ``k`` at
distance ``a`` from its root has the tip flexibility
``[[h^3/3EI + h/(kappa G A) + (h-a)^2/k, h^2/2EI + (h-a)/k], [., h/EI + 1/k]]`` (tip
force, tip moment), exactly (the shear term for a Timoshenko element only). Against a
finer mesh: the hinge on a coarse element converges to a short soft
element at its point far better than the coarse element's whole loss does.
"""

from dataclasses import replace

import numpy as np
import pytest

from truthbench.effects import parse_effect
from truthbench.effects.setup import realise
from truthbench.effects.structural import element_bending, hinge_points
from truthbench.errors import ModelError
from truthbench.fe.assembly import group_section
from truthbench.fe.beam import shear_modulus
from truthbench.plants import make_plant


def _hinge(station, loss, direction="ry", form="hinge"):
    spec = parse_effect({"name": "joint", "station": station, "direction": direction,
                         "form": form}, "joint", "test")
    return spec, {"stiffness_loss": loss, "damping_n_m_s_rad": 0.0}


@pytest.mark.parametrize("timoshenko", [False, True])
@pytest.mark.parametrize("xi", [0.0, 0.23, 0.5, 0.81])
@pytest.mark.parametrize("direction", ["ry", "rz"])
def test_a_hinge_gives_the_cantilever_flexibility_of_beam_theory(xi, direction, timoshenko):
    # nothing grounds it; an element as long as it is thick, where shear matters
    plant = make_plant("free_free_beam", n_elements=1, supports="none",
                       timoshenko=timoshenko)
    plant = replace(plant, stations={**plant.stations, "p": xi})
    params = plant.resolve({"L_m": 0.05})
    loss = 0.37
    K = realise(plant, params, [_hinge("p", loss, direction)]).model.K
    K = K.toarray() if hasattr(K, "toarray") else np.asarray(K)
    labels = list(realise(plant, params).model.dof_labels)
    trans = "z" if direction == "ry" else "y"
    tip = [labels.index(f"n1.{trans}"), labels.index(f"n1.{direction}")]
    free = [i for i, lab in enumerate(labels) if lab.startswith("n1.")]
    C = np.linalg.inv(K[np.ix_(free, free)])
    pick = [free.index(i) for i in tip]
    got = C[np.ix_(pick, pick)]
    EI, h = element_bending(plant, params, 0, direction)
    k = EI * (1 - loss) / (loss * h)
    arm = h * (1 - xi)
    props = plant.group_properties(params)[plant.element_groups()[0]]
    sec = group_section(props)
    # the element's shear flexibility, and the joint's (the loss of it, at the point)
    shear = h / (sec.shear_coefficient(props["nu"]) * shear_modulus(props["E_pa"], props["nu"])
                 * sec.area_m2) if timoshenko else 0.0
    shear *= 1 + loss / (1 - loss)
    exact = np.array([[h**3 / (3 * EI) + shear + arm**2 / k, h**2 / (2 * EI) + arm / k],
                      [h**2 / (2 * EI) + arm / k, h / EI + 1 / k]])
    # this code's rotations: theta_y = -dw/dx, theta_z = +dv/dx
    s = np.diag([1.0, -1.0 if direction == "ry" else 1.0])
    np.testing.assert_allclose(got, s @ exact @ s, rtol=1e-9)


def test_at_the_centre_the_hinge_is_a_rotational_spring_across_the_element():
    plant = make_plant("free_free_beam", n_elements=4)
    params = plant.resolve({})
    EI, h = element_bending(plant, params, 2, "ry")
    for loss in (0.1, 0.4, 0.8):
        ((kind, weights, value),) = hinge_points(plant, params, 2, 0.5, "ry", loss)
        dofs = [g for g, _ in weights]
        v = np.array([w for _, w in weights])
        assert kind == "spring" and dofs == [12 + 2, 12 + 4, 18 + 2, 18 + 4]
        # no shear force's lever arm at the centre: the change is -loss EI/h on the
        # relative rotation of the end nodes, affine in the loss
        rel = np.array([0.0, -1.0, 0.0, 1.0])
        np.testing.assert_allclose(value * np.outer(v, v), -loss * EI / h * np.outer(rel, rel),
                                   rtol=1e-12, atol=1e-12 * EI / h)


def _elastic_hz(plant, params, effects, count=6):
    hw = realise(plant, params, effects)
    f = np.sort(hw.modes.freq_hz)
    return f[f > 10.0][:count]


def test_a_hinge_converges_to_a_short_soft_element_where_a_whole_element_loss_does_not():
    point = (74 + 0.5) / 200  # the centre of element 74 of 200; element 3 of 10, xi 0.725
    loss = 0.5
    coarse = make_plant("free_free_beam", n_elements=10)
    coarse = replace(coarse, stations={**coarse.stations, "p": point, "n3": 0.3})
    params = coarse.resolve({})
    EI, h = element_bending(coarse, params, 3, "ry")
    k = EI * (1 - loss) / (loss * h)
    fine = make_plant("free_free_beam", n_elements=200)
    fine = replace(fine, stations={**fine.stations, "j": 74 / 200})
    short = h / 20
    reference = _elastic_hz(fine, params, [_hinge("j", EI / (EI + k * short), form="element")])
    # the round tube's bending modes come in pairs (z and y): a hinge in each plane
    hinge = _elastic_hz(coarse, params, [_hinge("p", loss, d) for d in ("ry", "rz")])
    whole = _elastic_hz(coarse, params, [_hinge("n3", loss, form="element")])
    # the coarse mesh's own discretization error, the same with or without a joint
    own = _elastic_hz(coarse, params, []) / _elastic_hz(fine, params, []) - 1
    err_hinge = np.abs(hinge / reference - 1 - own)
    err_whole = np.abs(whole / reference - 1 - own)
    assert err_hinge.max() < 0.25 * err_whole.max()


def test_an_element_joint_between_nodes_is_refused_and_names_the_hinge():
    plant = make_plant("free_free_beam", n_elements=4)
    plant = replace(plant, stations={**plant.stations, "p": 0.3})
    with pytest.raises(ModelError, match="hinge"):
        realise(plant, plant.resolve({}), [_hinge("p", 0.2, form="element")])
    with pytest.raises(ModelError, match="form must be one of element, hinge"):
        realise(plant, plant.resolve({}), [_hinge("p", 0.2, form="crack")])
