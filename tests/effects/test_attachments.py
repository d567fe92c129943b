"""Point attachments (added mass, grounded spring and dashpot) on a node and between nodes.

Between nodes an attachment acts through the element's shape functions at its point
(:meth:`~truthbench.plants.base.Plant.point_weights`). The oracles: the same
attachment on a node of a refined mesh, and the continuum Euler-Bernoulli free-free
beam (first-order perturbation with its exact mode shapes); on a node, the matrices of
the grounded link to the last bit.
"""

import copy
import re

import numpy as np
import pytest
import scipy.linalg as sl
from scipy.integrate import quad
from scipy.optimize import brentq

from truthbench.campaign.plan import CampaignPlan
from truthbench.campaign.spec import parse_campaign
from truthbench.campaign.truth import build_hardware
from truthbench.effects import parse_effect
from truthbench.effects.setup import realise
from truthbench.errors import CampaignError, ModelError
from truthbench.fe.beam import TubeSection
from truthbench.plants import make_plant

#: The point: the middle of element 4 of the 10-element mesh and of element 13 of the
#: 30-element mesh (xi = 0.5, where interpolation is poorest), node 9, 18, 36 of the 20,
#: 40, 80-element meshes. The first four bending modes all move there (their nodal
#: points are at 0.224, 0.132/0.5, 0.356, 0.277/0.5 of the length and mirrored).
FRACTION = 0.45
#: Free-free: suspension springs (a plant parameter that must be > 0) of 1e-6 N/m, their
#: rigid-body modes at ~1e-3 rad/s.
PARAMS = {"suspension_stiffness_n_m": 1e-6}
VALUE_KEY = {"added_mass": "mass_kg", "grounded_spring": "stiffness_n_m",
             "grounded_dashpot": "damping_n_s_m"}


def _effect(name, value, station="p", **options):
    return parse_effect({"name": name, "station": station, **options,
                         "parameters": {VALUE_KEY[name]: value}}, "e")


def _vertical_bending(n_elements, name, value):
    """The first four vertical bending modes of the free-free tube with the attachment
    at ``FRACTION`` in z: ``omega^2`` (rad^2/s^2) and the first-order decay rates
    ``phi^T C phi / 2`` (1/s) of the mass-normalised modes (C is the dashpot alone)."""
    plant = make_plant("free_free_beam", n_elements=n_elements, stations={"p": FRACTION})
    model = realise(plant, PARAMS, [_effect(name, value)]).model
    v = np.array([lab.endswith((".z", ".ry")) for lab in model.dof_labels])
    K, M, C = (A.toarray()[np.ix_(v, v)] for A in (model.K, model.M, model.C))
    w2, phi = sl.eigh(K, M)
    phi = phi[:, 2:6]  # after heave and pitch
    return w2[2:6], np.einsum("ik,ij,jk->k", phi, C, phi) / 2


@pytest.mark.parametrize("name, value", [("added_mass", 0.05), ("grounded_spring", 2.0e3),
                                         ("grounded_dashpot", 5.0)])
def test_between_nodes_converges_to_the_attachment_on_a_node(name, value):
    """The attachment at the middle of an element of the 10- and 30-element meshes
    against the same attachment on node 36 of the 80-element mesh.

    Mass and spring: the attachment's own error is that of its frequency shift,
    ``e_att(n) = |(omega^2 - omega_bare^2)(n) - (same)(80)| / omega^2(80)``, the bare
    mesh's discretisation error ``|omega_bare^2(n) - omega_bare^2(80)| / omega^2(80)``.
    The dashpot: the relative error of the decay rates. Measured (modes 1-4), from 10 to
    30 elements (h / 3, xi = 0.5 on both): the mass's e_att falls with order 3.0-3.1
    (1.9e-5..6.8e-4 to 6.8e-7..2.3e-5; a point load inside a cubic element, where the
    exact shape has a kink, converges at h^3), the spring's with order 2.7-4.2 (mode 1
    reaches 1.1e-7), the dashpot's with order 4.0 (the Hermite interpolation of the
    mode shape); the bare mesh's with order 4 (6.7e-5..4.8e-3 at 10 elements). A
    wrong weight (linear interpolation of w, or a rotation of the wrong sign) converges
    at order 2 or 1. The test asserts the trend: faster than second order, and on the
    10-element mesh the attachment adds less error than the mesh already has.
    """
    i = 1 if name == "grounded_dashpot" else 0
    ref, ref_bare = _vertical_bending(80, name, value)[i], _vertical_bending(80, name, 0.0)[0]
    err, mesh = {}, {}
    for n in (10, 30):
        got, bare = _vertical_bending(n, name, value)[i], _vertical_bending(n, name, 0.0)[0]
        err[n] = (np.abs(got - ref) / ref if i else
                  np.abs((got - bare) - (ref - ref_bare)) / ref)
        mesh[n] = np.abs(bare - ref_bare) / ref_bare
    order = np.log(err[10] / err[30]) / np.log(3.0)
    assert np.all(order > 2.0), order
    assert np.all(np.log(mesh[10] / mesh[30]) / np.log(3.0) > 3.5)  # the mesh: order 4
    if not i:
        assert np.all(err[10] < mesh[10]), (err[10], mesh[10])


def _free_free_modes():
    """``phi_k(x)^2 / int(phi_k^2 dx)`` (1/m) at ``FRACTION`` of the exact free-free
    Euler-Bernoulli modes 1-4: ``phi = cosh bx + cos bx - s (sinh bx + sin bx)``,
    ``cos bL cosh bL = 1``."""
    L = 1.8
    x = FRACTION * L
    out = []
    for lo, hi in ((4.0, 5.5), (7.0, 8.5), (10.5, 11.5), (13.5, 14.5)):
        bl = brentq(lambda z: np.cos(z) * np.cosh(z) - 1.0, lo, hi, xtol=1e-14)
        b, s = bl / L, (np.cosh(bl) - np.cos(bl)) / (np.sinh(bl) - np.sin(bl))

        def phi(y, b=b, s=s):
            return np.cosh(b * y) + np.cos(b * y) - s * (np.sinh(b * y) + np.sin(b * y))

        out.append(phi(x) ** 2 / quad(lambda y, phi=phi: phi(y) ** 2, 0.0, L, limit=200,
                                      epsabs=0.0, epsrel=1e-12)[0])
    return np.array(out)


@pytest.mark.parametrize("name, value", [("added_mass", 0.02), ("grounded_spring", 400.0)])
def test_small_attachment_matches_the_continuum_first_order_shift(name, value):
    """Rayleigh: ``d(omega^2) / omega^2 = -m phi(x)^2 / (rho A int phi^2)`` for a mass,
    ``d(omega^2) = k phi(x)^2 / (rho A int phi^2)`` for a spring, to first order, with the
    exact continuum modes. The 80-element shift differs from it by the second-order
    term, proportional to the value: measured relative differences 7-13 % (mass, 20 g)
    and 0.05-1 % (spring, 400 N/m), halving with the value; the mesh's part (< 1e-5)
    is far below. The test asserts the halving."""
    p = make_plant("free_free_beam").resolve()
    rho_a = p["rho_kg_m3"] * TubeSection(p["r_m"], p["t_m"]).area_m2
    shape = _free_free_modes() / rho_a
    bare = _vertical_bending(80, name, 0.0)[0]
    rel = []
    for v in (value, value / 2):
        shift = _vertical_bending(80, name, v)[0] / bare - 1.0
        first = -v * shape if name == "added_mass" else v * shape / bare
        rel.append(np.abs(shift - first) / np.abs(first))
    np.testing.assert_allclose(rel[1] / rel[0], 0.5, atol=0.05)


def test_dashpot_decay_rates_converge_to_the_continuum():
    """First-order decay rate of a dashpot: ``sigma = c phi(x)^2 / (2 rho A int phi^2)``
    (1/s) with the exact continuum mode. The model's ``phi^T C phi / 2`` converges to
    it at the order of the Hermite element's mode shapes, 4: measured 3.85-3.97 from
    10 elements (the point between nodes) to 20, 3.96-3.99 from 20 to 40 (relative
    errors 1.2e-4..1.1e-2, 8.6e-6..6.7e-4, 5.4e-7..4.3e-5)."""
    p = make_plant("free_free_beam").resolve()
    rho_a = p["rho_kg_m3"] * TubeSection(p["r_m"], p["t_m"]).area_m2
    c = 5.0
    expect = c * _free_free_modes() / (2 * rho_a)
    err = [np.abs(_vertical_bending(n, "grounded_dashpot", c)[1] / expect - 1.0)
           for n in (10, 20, 40)]
    for coarse, fine in zip(err, err[1:], strict=False):
        assert np.all(np.log2(coarse / fine) > 3.5), np.log2(coarse / fine)


def test_on_a_node_the_attachments_are_todays_links_to_the_last_bit():
    """On a node (a default station, and a user station given as a fraction that is a
    node, 0.35 * 20) every attachment is the grounded link it was: the same entries of
    ``links`` and no points, so the same sparse matrices."""
    plant = make_plant("free_free_beam", n_elements=20, stations={"gauge": 0.35})
    effects = [_effect("added_mass", 0.05, "mid"), _effect("added_mass", 0.03, "gauge"),
               _effect("grounded_spring", 3.0e4, "gauge", direction="y"),
               _effect("grounded_dashpot", 7.0, "end_b", direction="z"),
               _effect("grounded_spring", 2.0, "quarter", direction="ry")]
    additions = realise(plant, {}, effects).additions
    assert additions.points == ()
    assert additions.links == (
        ("mass", 60, -1, 0.05), ("mass", 61, -1, 0.05), ("mass", 62, -1, 0.05),
        ("mass", 42, -1, 0.03), ("mass", 43, -1, 0.03), ("mass", 44, -1, 0.03),
        ("spring", 43, -1, 3.0e4), ("dashpot", 122, -1, 7.0), ("spring", 34, -1, 2.0))


def test_between_nodes_the_attachments_are_points():
    plant = make_plant("free_free_beam", n_elements=20, stations={"p": 0.33})
    additions = realise(plant, {}, [_effect("added_mass", 0.05),
                                    _effect("grounded_spring", 1.0e3, direction="x"),
                                    _effect("grounded_dashpot", 0.0)]).additions
    assert additions.links == ()
    assert additions.points == (
        *(("mass", plant.point_weights("p", d, plant.resolve()), 0.05) for d in "xyz"),
        ("spring", plant.point_weights("p", "x"), 1.0e3))  # no dashpot of 0


def test_sag_is_computed_with_points_and_keeps_them():
    """The sag's static solution carries the masses between nodes, and the frozen
    additions keep them beside the angles."""
    plant = make_plant("free_free_beam", n_elements=10, stations={"p": 0.45})
    sag = parse_effect({"name": "sag", "parameters": {"scale": 1.0}}, "e")
    heavy = realise(plant, {}, [_effect("added_mass", 0.3), sag]).additions
    light = realise(plant, {}, [sag]).additions
    assert len(heavy.points) == 3
    assert np.all(np.abs(heavy.sag_angles_rad - light.sag_angles_rad) > 0)
    dM = (plant.build(None, additions=heavy).M - plant.build(None, additions=light).M)
    labels = plant.build().dof_labels
    for d in "xyz":  # a rigid translation carries the whole mass (partition of unity)
        t = np.array([lab.endswith(f".{d}") for lab in labels], dtype=float)
        assert t @ dM @ t == pytest.approx(0.3, rel=1e-14)


@pytest.mark.parametrize("effect", [
    {"name": "joint", "station": "odd", "parameters": {"stiffness_loss": 0.1}},
    {"name": "coulomb_friction", "station": "odd"},
    {"name": "process_noise", "station": "odd"}])
def test_effects_that_need_a_node_refuse_a_station_between_nodes(effect):
    plant = make_plant("free_free_beam", n_elements=20, stations={"odd": 0.33})
    with pytest.raises(ModelError, match="station 'odd' at fraction 0.33 of the length lies "
                                         "between nodes 6 and 7 .*only point attachments"):
        realise(plant, {}, [parse_effect(effect, "e")])


def test_campaign_with_a_station_between_nodes(base):
    """A campaign's station between nodes carries a point attachment; a sensor, an
    actuator or a joint there is an error naming the key."""
    base["plant"]["stations"] = {"odd": 0.33}
    base["truth"]["effects"] = [{"name": "added_mass", "station": "odd",
                                 "parameters": {"mass_kg": 0.05}},
                                {"name": "grounded_spring", "station": "odd",
                                 "parameters": {"stiffness_n_m": 100.0}}]
    spec = parse_campaign(base)
    plan = CampaignPlan.compile(spec)
    additions = build_hardware(plan, plan.tests[0], 0, spec.campaign.seed).additions
    assert [p[0] for p in additions.points] == ["mass"] * 3 + ["spring"]
    between = "lies between nodes 2 and 3 of the 8-element mesh"
    for key, edit in (
            ("sensors[1].station", lambda d: d["sensors"][1].update(station="odd")),
            ("tests[0].actuators[0].station",
             lambda d: d["tests"][0]["actuators"][0].update(station="odd")),
            ("truth.effects[2].station", lambda d: d["truth"]["effects"].append(
                {"name": "joint", "station": "odd", "parameters": {"stiffness_loss": 0.1}}))):
        bad = copy.deepcopy(base)
        edit(bad)
        with pytest.raises(CampaignError, match=rf"key '{re.escape(key)}'.*{between}"):
            parse_campaign(bad)
