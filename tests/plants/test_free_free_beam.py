"""What holds the free-free beam: ``supports`` springs, foam or none."""

import numpy as np
import pytest

from truthbench.errors import ModelError
from truthbench.fe.beam import TubeSection
from truthbench.plants import Actuator, Sensor, make_plant
from truthbench.plants.base import SUPPORTS


def test_springs_and_foam_are_the_suspended_beam():
    """Declaring springs or foam changes no matrix: both hang the beam on its suspension
    points, as the undeclared plant does."""
    unset = make_plant("free_free_beam", n_elements=12)
    ref = unset.build({"suspension_damping_n_s_m": 0.4})
    for kind in ("springs", "foam"):
        plant = make_plant("free_free_beam", n_elements=12, supports=kind)
        assert plant.supports == kind
        assert plant.support_nodes() == plant.suspension_nodes() == unset.suspension_nodes()
        m = plant.build({"suspension_damping_n_s_m": 0.4})
        for name in ("M", "C", "K"):
            assert (getattr(m, name) != getattr(ref, name)).nnz == 0
    assert unset.supports is None and unset.support_nodes() == (3, 9)


def test_nothing_touches_a_beam_without_supports():
    """``supports = "none"``: no suspension parameters and no springs; six rigid-body
    modes at 0 Hz, and at low frequency the driving-point accelerance at an end is the
    rigid bar's, ``1/m + (L/2)^2 / (m L^2 / 12) = 4 / m`` (the elastic modes add
    ``-(f / f_1)^2`` of their flexibility, 1e-9 relative at 1 mHz)."""
    plant = make_plant("free_free_beam", n_elements=12, supports="none")
    assert plant.support_nodes() == ()
    assert not any(k.startswith("suspension") for k in plant.parameter_names())
    p = plant.resolve()
    model = plant.build(None, [Actuator("end_a", "z")], [Sensor("end_a", "z")])
    md = model.modes(10)
    assert md.rigid.sum() == 6 and np.all(md.freq_hz[:6] == 0.0)
    mass = p["rho_kg_m3"] * TubeSection(p["r_m"], p["t_m"]).area_m2 * p["L_m"]
    H = model.frf(np.array([1e-3]))[0, 0, 0]
    assert H == pytest.approx(4.0 / mass, rel=1e-8)
    # the same beam on springs: the suspension holds it, its accelerance falls to 0
    hung = make_plant("free_free_beam", n_elements=12).build(
        None, [Actuator("end_a", "z")], [Sensor("end_a", "z")])
    assert abs(hung.frf(np.array([1e-3]))[0, 0, 0]) < 1e-4 / mass


def test_what_a_plant_holds_and_refuses():
    assert SUPPORTS == ("springs", "foam", "none")
    assert make_plant("hub_beam", n_elements=6).support_nodes() == (0,)  # the hub bearing
    with pytest.raises(ModelError, match="'supports' must be one of 'springs', 'foam', "
                                         "'none'; got 'sand'"):
        make_plant("free_free_beam", supports="sand")
    with pytest.raises(ModelError, match="hub_beam has no 'supports' to declare"):
        make_plant("hub_beam", supports="foam")
    with pytest.raises(ModelError, match="expected no suspension points"):
        make_plant("free_free_beam", n_elements=10, supports="none",
                   suspension_fractions=(0.2, 0.8))
    free = make_plant("free_free_beam", n_elements=10, supports="none")
    with pytest.raises(ModelError, match="supports = 'none' has no parameter "
                                         "'suspension_stiffness_n_m'"):
        free.resolve({"suspension_stiffness_n_m": 100.0})
