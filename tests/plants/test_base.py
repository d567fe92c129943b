"""Points of the beam: stations between nodes and their interpolation weights
(:meth:`Plant.point_weights`), and point attachments in :class:`StructuralAdditions`."""

import numpy as np
import pytest

from truthbench.errors import ModelError
from truthbench.plants import Actuator, Sensor, make_plant
from truthbench.plants.base import DIRECTIONS, StructuralAdditions

EPS = np.finfo(float).eps
#: two groups of different lengths: the elements of g1 are 0.14 m, those of g2 0.26 m
UNEQUAL = {"L_m@g1": 0.7, "L_m@g2": 1.3}


def _point_x(plant, fraction, params):
    """Axial coordinate of a fraction of the element count (the stations' convention)."""
    x = plant.node_x_m(plant.resolve(params))
    pos = fraction * plant.n_elements
    e = min(int(np.floor(pos)), plant.n_elements - 1)
    return x[e] + (pos - e) * (x[e + 1] - x[e])


def test_a_node_gives_its_dof_alone_with_weight_one():
    """On a node (a station, or a fraction whose product with the element count rounds
    to a whole number: 0.35 * 20 = 7.000000000000001) the weights are that DOF with
    exactly 1.0, the DOF that sensors and actuators use."""
    plant = make_plant("free_free_beam", n_elements=20, stations={"gauge": 0.35})
    for position, node in (("mid", 10), ("end_a", 0), ("end_b", 20), ("gauge", 7),
                           (0.35, 7), (1, 20), (np.float64(0.25), 5)):
        for d, direction in enumerate(DIRECTIONS):
            w = plant.point_weights(position, direction, UNEQUAL)
            assert w == ((6 * node + d, 1.0),)
            assert type(w[0][1]) is float
            if isinstance(position, str):
                assert w[0][0] == plant.global_dof(position, direction)


@pytest.mark.parametrize("direction", DIRECTIONS)
def test_translation_weights_are_a_partition_of_unity(direction):
    """The weights of a translation's own DOFs sum to 1 (a rigid translation moves the
    point with it), to the round-off of three products; a rotation's too."""
    plant = make_plant("free_free_beam", n_elements=10, n_groups=2)
    rng = np.random.default_rng(17)
    d = DIRECTIONS.index(direction)
    for fraction in rng.uniform(0, 1, 50):
        w = plant.point_weights(float(fraction), direction, UNEQUAL)
        assert len(w) == (4 if direction in ("y", "z") else 2)
        own = sum(v for g, v in w if g % 6 == d)
        assert abs(own - 1.0) <= 4 * EPS


@pytest.mark.parametrize("direction", ["y", "z"])
def test_hermite_weights_reproduce_a_cubic_exactly(direction):
    """Nodal values and slopes of ``w(x) = a + b x + c x^2 + d x^3`` (the rotation DOF
    being ``theta_z = +dv/dx`` for y and ``theta_y = -dw/dx`` for z) interpolate to
    ``w`` at the point to round-off, in both groups of a beam with elements of
    different lengths."""
    plant = make_plant("free_free_beam", n_elements=10, n_groups=2)
    x = plant.node_x_m(plant.resolve(UNEQUAL))
    rng = np.random.default_rng(3)
    a, b, c, d = rng.normal(size=4)
    w = a + b * x + c * x**2 + d * x**3
    slope = b + 2 * c * x + 3 * d * x**2
    q = np.zeros(6 * len(x))
    q[DIRECTIONS.index(direction)::6] = w
    if direction == "y":
        q[5::6] = slope
    else:
        q[4::6] = -slope
    for fraction in (*rng.uniform(0, 1, 40), 0.03, 0.97):
        xp = _point_x(plant, fraction, UNEQUAL)
        weights = plant.point_weights(float(fraction), direction, UNEQUAL)
        terms = np.array([v * q[g] for g, v in weights])
        exact = a + b * xp + c * xp**2 + d * xp**3
        assert abs(terms.sum() - exact) <= 16 * EPS * (np.abs(terms).sum() + abs(exact))


@pytest.mark.parametrize("direction", ["x", "rx", "ry", "rz"])
def test_linear_weights_reproduce_a_linear_field(direction):
    """Axial translation and rotations: linear between the nodes, exact for a + b x."""
    plant = make_plant("free_free_beam", n_elements=10, n_groups=2)
    x = plant.node_x_m(plant.resolve(UNEQUAL))
    q = np.zeros(6 * len(x))
    q[DIRECTIONS.index(direction)::6] = 0.3 - 1.7 * x
    for fraction in np.random.default_rng(5).uniform(0, 1, 40):
        xp = _point_x(plant, fraction, UNEQUAL)
        terms = np.array([v * q[g] for g, v in plant.point_weights(fraction, direction,
                                                                   UNEQUAL)])
        assert abs(terms.sum() - (0.3 - 1.7 * xp)) <= 8 * EPS * np.abs(terms).sum()


def test_hermite_rotation_weights_scale_with_the_element_length():
    """The rotation weights of a y or z point are lengths (m/rad): the element's own,
    0.14 m in group g1 and 0.26 m in g2 here, so the default length gives others."""
    plant = make_plant("free_free_beam", n_elements=10, n_groups=2)
    for fraction, h in ((0.25, 0.14), (0.75, 0.26)):
        w = dict(plant.point_weights(fraction, "z", UNEQUAL))
        a = int(fraction * 10)
        # xi = 0.5: N2 = h xi (1 - xi)^2 = h / 8, and theta_y = -dw/dx
        assert w[6 * a + 4] == pytest.approx(-h / 8, rel=4 * EPS)
        assert w[6 * (a + 1) + 4] == pytest.approx(h / 8, rel=4 * EPS)
    assert dict(plant.point_weights(0.25, "z"))[6 * 2 + 4] == pytest.approx(-0.18 / 8)


def test_station_between_nodes_serves_only_point_attachments():
    """A station between nodes is accepted by the plant and located by its weights and
    coordinates; a sensor or actuator there is refused, naming the two nodes."""
    plant = make_plant("free_free_beam", n_elements=20, stations={"odd": 0.33})
    assert plant.station_fraction("odd") == 0.33
    w = plant.point_weights("odd", "z")
    assert [g for g, _ in w] == [6 * 6 + 2, 6 * 6 + 4, 6 * 7 + 2, 6 * 7 + 4]
    xyz = plant.station_coordinates_m("odd")
    np.testing.assert_allclose(xyz, [0.33 * 1.8, 0.0, 0.0], rtol=0, atol=4 * EPS * 1.8)
    msg = (r"station 'odd' at fraction 0.33 of the length lies between nodes 6 and 7 of "
           r"the 20-element mesh .*only point attachments")
    with pytest.raises(ModelError, match=msg):
        plant.station_node("odd")
    with pytest.raises(ModelError, match=msg):
        plant.build(None, [], [Sensor("odd", "z")])
    with pytest.raises(ModelError, match=msg):
        plant.build(None, [Actuator("odd", "z")], [])
    with pytest.raises(ModelError, match=msg):
        plant.build(None, [], [Sensor("odd", "z", "strain")])
    with pytest.raises(ModelError, match=msg):
        plant.global_dof("odd", "z")


@pytest.mark.parametrize("fraction", [1.2, -0.1, float("nan"), float("inf"), "0.5", True])
def test_a_station_off_the_beam_is_refused(fraction):
    with pytest.raises(ModelError, match=r"station 'bad' at fraction .* is off the beam; "
                                         r"expected a fraction of the length in \[0, 1\]"):
        make_plant("free_free_beam", n_elements=20, stations={"bad": fraction})


def test_point_weights_bad_input():
    plant = make_plant("free_free_beam", n_elements=20)
    with pytest.raises(ModelError, match=r"point at fraction 1.5 is off the beam"):
        plant.point_weights(1.5, "z")
    with pytest.raises(ModelError, match=r"point at fraction nan is off the beam"):
        plant.point_weights(float("nan"), "z")
    with pytest.raises(ModelError, match="no station 'nose'"):
        plant.point_weights("nose", "z")
    with pytest.raises(ModelError, match=r"direction must be one of x, y, z, rx, ry, rz; "
                                         r"got 'up'"):
        plant.point_weights(0.3, "up")
    with pytest.raises(ModelError, match=r"'L_m' must be a positive"):
        plant.point_weights(0.33, "z", {"L_m": -1.0})


def _csr_bits(A):
    A = A.tocsr()
    return A.data.tobytes(), A.indices.tobytes(), A.indptr.tobytes(), A.shape


def test_a_point_on_a_node_is_the_grounded_link_to_the_last_bit():
    """``value * u u^T`` with ``u`` one weight of 1.0 is the link's diagonal entry:
    the same sparse data, indices and pointers."""
    n = 6 * 21
    links = (("mass", 62, -1, 0.05), ("spring", 62, -1, 3.0e4), ("dashpot", 17, -1, 7.0),
             ("mass", 62, -1, 0.01))
    points = tuple((kind, ((a, 1.0),), v) for kind, a, _, v in links)
    for old, new in zip(StructuralAdditions(links).matrices(n),
                        StructuralAdditions(points=points).matrices(n), strict=True):
        assert _csr_bits(old) == _csr_bits(new)


def test_a_point_between_nodes_adds_value_u_u_transpose():
    plant = make_plant("free_free_beam", n_elements=20)
    n = 6 * 21
    u = plant.point_weights(0.33, "z")
    dM, dC, dK = StructuralAdditions(points=(("mass", u, 0.05), ("spring", u, 2.0e3),
                                             ("dashpot", u, 4.0))).matrices(n)
    vec = np.zeros(n)
    for g, v in u:
        vec[g] = v
    for A, value in ((dM, 0.05), (dK, 2.0e3), (dC, 4.0)):
        np.testing.assert_array_equal(A.toarray(), value * np.outer(vec, vec))
    with pytest.raises(ModelError, match="unknown point kind 'inerter'"):
        StructuralAdditions(points=(("inerter", u, 1.0),)).matrices(n)
    with pytest.raises(ModelError, match=r"point DOFs .* outside 0..125"):
        StructuralAdditions(points=(("mass", ((126, 1.0),), 1.0),)).matrices(n)


def _element_of(plant, params, a):
    """Stiffness and group properties of element ``a`` (its own assembly call)."""
    from truthbench.fe.assembly import group_section
    from truthbench.fe.beam import element_matrices
    p = plant.resolve(params)
    group = plant.element_groups()[a]
    props = plant.group_properties(p)[group]
    sec = group_section(props, group)
    x = plant.node_x_m(p)
    h = float(x[a + 1] - x[a])
    k, _ = element_matrices(props["E_pa"], props["nu"], props["rho_kg_m3"], sec, h,
                            timoshenko=plant.timoshenko)
    return k, props, sec, h


@pytest.mark.parametrize("scale", [0.0, 0.5, 1.0])
@pytest.mark.parametrize("direction", ["y", "z"])
def test_weights_are_the_static_field_of_a_timoshenko_cantilever(scale, direction):
    """One element clamped at node A, loaded at node B by a force P, then by a moment M:
    the weights at points inside give beam theory's deflection, ``P x^2 (3h - x) / 6EI
    + P x / (kappa G A / s)`` and ``M x^2 / 2EI``, for the Euler-Bernoulli element and
    the Timoshenko element at shear scales 0.5 and 1 (phi of order 1 on these short
    elements; the Euler-Bernoulli Hermite cubic is 5 % off there)."""
    from truthbench.fe.beam import shear_modulus
    plant = make_plant("free_free_beam", n_elements=40, timoshenko=scale)
    a = 13
    k, props, sec, h = _element_of(plant, {}, a)
    E, nu = props["E_pa"], props["nu"]
    second = sec.second_moment_z_m4 if direction == "y" else sec.second_moment_y_m4
    EI = E * second
    kGA = sec.shear_coefficient(nu) * shear_modulus(E, nu) * sec.area_m2
    shear = scale / kGA
    phi = plant.shear_parameter(a, direction)
    assert phi == pytest.approx(12 * EI * shear / h**2, rel=8 * EPS)
    if scale == 1.0:
        assert phi > 1.5  # the case this interpolation is for
    # local DOFs of the plane (w, theta) at A and B; theta_y = -dw/dx in x-z
    w_dof, r_dof = (1, 5) if direction == "y" else (2, 4)
    sign = 1.0 if direction == "y" else -1.0
    tip = [6 + w_dof, 6 + r_dof]
    Kbb = k[np.ix_(tip, tip)]
    P, M = 3.0, 0.7
    for load, exact in (([P, 0.0], lambda x: P * x**2 * (3 * h - x) / (6 * EI) + P * x * shear),
                        ([0.0, sign * M], lambda x: M * x**2 / (2 * EI))):
        qb = np.linalg.solve(Kbb, load)
        q = {6 * (a + 1) + w_dof: qb[0], 6 * (a + 1) + r_dof: qb[1]}
        for xi in (0.1, 0.25, 0.5, 0.81):
            w = plant.point_weights((a + xi) / 40, direction)
            got = sum(wt * q.get(g, 0.0) for g, wt in w)
            # a 2x2 solve and a four-term sum, at the scale of the tip deflection
            assert got == pytest.approx(exact(xi * h), rel=0, abs=64 * EPS * abs(qb[0]))


def test_timoshenko_weights_give_the_elements_consistent_translational_mass():
    """``rho A h int N N^T dxi`` over the weights of points inside an element is the
    Timoshenko element's translational mass (Przemieniecki's coefficients, as
    assembled), so a point mass between nodes and the element's own inertia are one
    discretisation."""
    from truthbench.fe.beam import _bending_blocks
    plant = make_plant("free_free_beam", n_elements=40, timoshenko=1.0)
    a = 7
    _, props, sec, h = _element_of(plant, {}, a)
    rhoA = props["rho_kg_m3"] * sec.area_m2
    phi = plant.shear_parameter(a, "y")
    _, mt = _bending_blocks(1.0, rhoA, h, 0.0, phi)
    xg, wg = np.polynomial.legendre.leggauss(6)  # exact for the degree-6 integrand
    m = np.zeros((4, 4))
    for x, wq in zip(0.5 * (xg + 1), 0.5 * wg, strict=True):
        u = np.array([wt for _, wt in plant.point_weights((a + x) / 40, "y")])
        m += rhoA * h * wq * np.outer(u, u)
    np.testing.assert_allclose(m, mt, rtol=0, atol=64 * EPS * np.abs(mt).max())
