"""The user's own test article, described in a campaign file alone: a free-free steel
tube on two springs given in metres, against an exact continuous-beam solution, the
exact free-free roots and a rigid-body calculation; positions in metres; the errors.

FE tolerance (``_check_bracket``): consistent-mass Hermite elements are a Rayleigh-Ritz
method, so FE frequencies are upper bounds that fall under nested refinement
(exact <= f_48 <= f_24); the error is C h^4, so the error of f_48 is (f_24 - f_48) / 15 to
leading order, and we allow twice that. Both sides get a round-off allowance
``n_dof eps lambda_max / (2 lambda)`` (backward-stable symmetric eigensolver): it, not the
mesh, limits the suspension modes.
"""

import tomllib
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.optimize import brentq

from truthbench.campaign.runner import run_campaign
from truthbench.campaign.spec import load_campaign, parse_campaign, position_station_name
from truthbench.effects import SetupBuilder
from truthbench.effects.structural import Geometry
from truthbench.errors import CampaignError, ModelError
from truthbench.fe.beam import RectangularBarSection, TubeSection
from truthbench.plants import Actuator, Sensor, make_plant

ROOT = Path(__file__).resolve().parents[2]
STEEL = {"E_pa": 200e9, "rho_kg_m3": 7850.0, "nu": 0.29}  # the "steel" preset
R, T, L, K_SPRING, X_SPRINGS = 0.0127, 0.0015, 1.2, 2000.0, (0.1, 1.1)
FREE_FREE = np.array([4.73004074486, 7.85320462410, 10.9956078380, 14.1371654913,
                      17.2787596574, 20.4203522456])  # cos cosh = 1

CAMPAIGN = """
[campaign]
name = "steel_tube_check"

[plant]
type = "free_free_beam"
n_elements = {n}
material = "steel"
suspension_x_m = [0.1, 1.1]

[plant.parameters]
r_m = 0.0127
t_m = 0.0015
L_m = 1.2
suspension_stiffness_n_m = 2000.0

[[sensors]]
x_m = 0.6
direction = "z"

[[tests]]
name = "tap"
actuators = [{{ x_m = 0.3, direction = "z" }}]
band_hz = [1.0, 500.0]
fs_hz = 2048.0
record_s = 1.0

[update]
method = "none"
"""


def _constants():
    s = TubeSection(R, T)
    return STEEL["E_pa"] * s.second_moment_m4, STEEL["rho_kg_m3"] * s.area_m2


# ---- the oracles ------------------------------------------------------------------------

def _field(beta, x):
    """Transfer matrices of Euler-Bernoulli segments of length x for the state
    [w, w', w'', w'''] (EI w'''' = rho A omega^2 w = EI beta^4 w), with the Krylov
    functions S, T, U, V of beta x; shape (n, 4, 4) for n values of beta."""
    b = beta * x
    S, Tk = (np.cosh(b) + np.cos(b)) / 2, (np.sinh(b) + np.sin(b)) / 2
    U, V = (np.cosh(b) - np.cos(b)) / 2, (np.sinh(b) - np.sin(b)) / 2
    rows = [[S, Tk / beta, U / beta**2, V / beta**3],
            [beta * V, S, Tk / beta, U / beta**2],
            [beta**2 * U, beta * V, S, Tk / beta],
            [beta**3 * Tk, beta**2 * U, beta * V, S]]
    return np.moveaxis(np.array(rows), (0, 1), (-2, -1))


def _spring_beam_determinant(omega):
    """Free ends (w'' = w''' = 0 at both), point springs k at X_SPRINGS: across a spring
    EI w''' jumps by -k w. The start state is [w0, w0', 0, 0]; the end's w'', w''' rows
    give a 2x2 determinant, scaled by beta^5 cosh^2(beta L) to keep it O(1)."""
    EI, rhoA = _constants()
    omega = np.atleast_1d(omega)
    beta = (rhoA * omega**2 / EI) ** 0.25
    P = np.eye(4)
    P[3, 0] = -K_SPRING / EI
    a, b = X_SPRINGS
    Tm = _field(beta, L - b) @ P @ _field(beta, b - a) @ P @ _field(beta, a)
    D = Tm[:, 2:4, 0:2]
    det = D[:, 0, 0] * D[:, 1, 1] - D[:, 0, 1] * D[:, 1, 0]
    return det / (beta**5 * np.cosh(beta * L) ** 2)


def _exact_vertical(n_modes):
    """Roots of the determinant: a scan at 0.5 rad/s (the two lowest roots are 27 rad/s
    apart) and brentq in every sign change (the determinant is entire: no poles)."""
    grid = np.arange(1.0, 2 * np.pi * 1100, 0.5)
    d = _spring_beam_determinant(grid)
    cross = np.nonzero(np.sign(d[:-1]) != np.sign(d[1:]))[0]
    roots = [brentq(lambda w: _spring_beam_determinant(w)[0], grid[i], grid[i + 1],
                    xtol=1e-12, rtol=4 * np.finfo(float).eps) for i in cross]
    assert len(roots) >= n_modes
    return np.array(roots[:n_modes])


def _rigid_bar():
    """Rigid bar on two springs: heave y and pitch theta about the centre,
    M = diag(m, m L^2 / 12), K = sum over springs of k [1, d; d, d^2], d = x - L/2."""
    _, rhoA = _constants()
    m = rhoA * L
    d = np.array(X_SPRINGS) - L / 2
    Kr = K_SPRING * np.array([[len(d), d.sum()], [d.sum(), (d**2).sum()]])
    lam, vec = sla.eigh(Kr, np.diag([m, m * L**2 / 12]))
    return np.sqrt(lam), m


def _plane(model, directions):
    """Frequencies (rad/s) of the model's K, M restricted to one bending plane (which the
    other DOFs do not couple to), rigid zeros dropped, with the round-off allowance."""
    rows = np.array([lab.split(".")[1] in directions for lab in model.dof_labels])
    K, M = model.K.toarray(), model.M.toarray()
    assert np.all(K[np.ix_(rows, ~rows)] == 0) and np.all(M[np.ix_(rows, ~rows)] == 0)
    lam = sla.eigh(K[np.ix_(rows, rows)], M[np.ix_(rows, rows)], eigvals_only=True)
    lam_max = lam.max()
    lam = lam[lam > 1e-6 * np.sqrt(lam_max)]
    return np.sqrt(lam), rows.sum() * np.finfo(float).eps * lam_max / lam / 2


def _check_bracket(f_n, f_2n, exact, roundoff):
    slack = roundoff * exact
    assert np.all(f_2n <= f_n + slack)
    assert np.all(exact <= f_2n + slack), f_2n / exact - 1
    assert np.all(f_2n - exact <= 2 * (f_n - f_2n) / 15 + slack), (f_2n / exact - 1)


@pytest.fixture(scope="module")
def steel_models(tmp_path_factory):
    """The steel tube built from campaign files alone, at 24 and 48 elements (nodes
    every 0.05 and 0.025 m: the springs at 0.1 and 1.1 m fall on nodes)."""
    out = {}
    for n in (24, 48):
        path = tmp_path_factory.mktemp("article") / f"steel_{n}.toml"
        path.write_text(CAMPAIGN.format(n=n))
        spec = load_campaign(path)
        out[n] = spec.make_plant().build(spec.nominal_parameters())
    return out


def test_steel_tube_vertical_modes_match_the_exact_beam_on_springs(steel_models):
    exact = _exact_vertical(6)  # bounce, pitch, four bending modes
    f24, _ = _plane(steel_models[24], ("z", "ry"))
    f48, roundoff = _plane(steel_models[48], ("z", "ry"))
    _check_bracket(f24[:6], f48[:6], exact, roundoff[:6])
    # the springs stiffen the first bending mode above the free-free one (by 0.5 %)
    EI, rhoA = _constants()
    free = FREE_FREE[0] ** 2 * np.sqrt(EI / (rhoA * L**4))
    assert exact[2] > free * 1.004


def test_steel_tube_lateral_modes_are_the_free_free_roots(steel_models):
    """No lateral springs: y and rz are rigid, the bending modes are the free-free roots."""
    EI, rhoA = _constants()
    exact = FREE_FREE[:5] ** 2 * np.sqrt(EI / (rhoA * L**4))
    f24, _ = _plane(steel_models[24], ("y", "rz"))
    f48, roundoff = _plane(steel_models[48], ("y", "rz"))
    assert len(f48) == steel_models[48].K.shape[0] // 3 - 2  # two rigid modes dropped
    _check_bracket(f24[:5], f48[:5], exact, roundoff[:5])


def test_steel_tube_suspension_modes_against_a_rigid_bar():
    """The rigid bar is the Rayleigh-Ritz model on the two rigid motions, so its
    frequencies bound the exact ones from above. From below: to leading order in
    (omega_r / omega_n)^2 the springs couple each rigid mode r to the flexible free-free
    modes n and lower omega_r^2 by sum_n (sum_s k psi_r(x_s) phi_n(x_s))^2 /
    (omega_n^2 - omega_r^2) <= omega_r^2 sum_n (sum_s k phi_n(x_s)^2) / (omega_n^2 -
    omega_r^2) (Cauchy-Schwarz; sum_s k psi_r^2 = omega_r^2). Mass-normalised free-free
    shapes are phi_n = Phi_n / sqrt(m) with Phi_n of mean square 1, |Phi_n| <= 2 (reached at
    the free ends), so with two springs sum_s k phi_n^2 <= 8 k / m and
    1 - omega / omega_rigid <= (4 k / m) sum_n 1 / (omega_n^2 - omega_r^2): 1.7 % here,
    where the suspension frequencies are 12 % of the first bending frequency."""
    exact = _exact_vertical(2)
    rigid, m = _rigid_bar()
    EI, rhoA = _constants()
    n = np.arange(1, 2001)
    beta_l = np.where(n <= 6, np.r_[FREE_FREE, np.zeros(1994)], (2 * n + 1) * np.pi / 2)
    omega_n = beta_l**2 * np.sqrt(EI / (rhoA * L**4))
    bound = np.array([4 * K_SPRING / m * np.sum(1 / (omega_n**2 - w**2)) for w in rigid])
    assert np.all(rigid / omega_n[0] < 0.125) and np.all(bound < 0.018)
    lowering = 1 - exact / rigid
    assert np.all(lowering >= -1e-12), lowering  # Rayleigh-Ritz: rigid >= exact
    assert np.all(lowering <= bound), (lowering, bound)
    # bounce 9.48 Hz, pitch 13.68 Hz (rigid); exact 0.54 % and 0.03 % lower
    np.testing.assert_allclose(rigid / (2 * np.pi), [9.4795, 13.6825], atol=5e-4)


def test_steel_tube_campaign_positions_and_coordinates(steel_models, tmp_path):
    path = tmp_path / "steel.toml"
    path.write_text(CAMPAIGN.format(n=24))
    spec = load_campaign(path)
    plant = spec.make_plant()
    p = spec.nominal_parameters()
    assert {k: p[k] for k in STEEL} == STEEL  # the material preset fills E, rho, nu
    assert plant.suspension_nodes() == (2, 22)
    assert spec.sensors[0].station == "x600mm" and spec.sensors[0].x_m is None
    assert spec.tests[0].actuators[0].station == "x300mm"
    np.testing.assert_allclose(plant.station_coordinates_m("x300mm", p), [0.3, 0, 0],
                               atol=1e-15)
    xyz = plant.node_coordinates_m(p)
    assert xyz.shape == (25, 3) and xyz[-1, 0] == pytest.approx(1.2)
    # the model's output and input sit at those nodes
    model = plant.build(p, [Actuator("x300mm", "z")], [Sensor("x600mm", "z")])
    assert model.dof_labels[int(np.argmax(model.B[:, 0]))] == "n6.z"
    assert model.dof_labels[int(np.argmax(model.C_out[0]))] == "n12.z"
    # the validated spec writes itself back as a campaign that loads to the same plant
    again = parse_campaign(spec.to_toml_dict(), "again")
    assert again.make_plant() == plant


def test_shipped_steel_tube_campaign_runs():
    d = tomllib.loads((ROOT / "campaigns" / "steel_tube.toml").read_text())
    for t in d["tests"]:
        t.update(record_s=4.0, averages=4, oversample=2)
    spec = parse_campaign(d, "steel_tube.toml (short records)")
    assert spec.plant.section == "tube" and spec.plant.material == "steel"
    trial = run_campaign(spec, trials=1).trials[0]
    assert trial.error is None
    assert set(trial.update.names) == {"E_pa", "rho_kg_m3"}
    rec = trial.tests[0]
    assert [c.station for c in rec.frf.outputs] == ["x0mm", "x300mm", "x600mm", "x1150mm"]
    assert rec.frf.inputs[0].coordinates_m == pytest.approx((0.05, 0.0, 0.0), abs=1e-15)


# ---- positions in metres -----------------------------------------------------------------

def test_node_at_m_and_element_count_hints():
    plant = make_plant("free_free_beam", n_elements=24)
    p = {"L_m": 1.2}
    assert plant.node_at_m(0.1, p) == 2
    assert plant.node_at_m(0.1 + 9e-5, p) == 2  # within the default 0.1 mm
    assert plant.fraction_at_m(1.2, p) == 1.0
    with pytest.raises(ModelError, match=r"x_m = 0.42 m is not on a node of the 24-element "
                                         r"mesh: the nearest node \(node 8\) is at 0.4 m, "
                                         r"0.02 m away \(tolerance 0.0001 m\); "
                                         r"n_elements = 20, 40, 60, 80, 100 put a node there"):
        plant.node_at_m(0.42, p)
    with pytest.raises(ModelError, match=r"x_m = 1.3 m is off the beam, which runs from 0 to "
                                         r"1.2 m"):
        plant.node_at_m(1.3, p)
    with pytest.raises(ModelError, match="finite number"):
        plant.node_at_m(float("nan"), p)
    # groups of different lengths: nodes are not evenly spaced
    grouped = make_plant("free_free_beam", n_elements=4, n_groups=2)
    q = {"L_m": 1.2, "L_m@g1": 0.2, "L_m@g2": 1.0}
    np.testing.assert_allclose(grouped.node_coordinates_m(q)[:, 0], [0, 0.1, 0.2, 0.7, 1.2])
    assert grouped.node_at_m(0.7, q) == 3
    with pytest.raises(ModelError, match=r"n_elements = 20, 40, 60"):  # 0.1 m into g2
        grouped.node_at_m(0.3, q)
    with pytest.raises(ModelError, match=r"no parameter 'L_m@g7'"):
        grouped.node_coordinates_m({"L_m@g7": 1.0})


@pytest.mark.parametrize("x_m,name", [(0.05, "x50mm"), (0.0125, "x12p5mm"), (1.1, "x1100mm"),
                                      (0.0, "x0mm"), (-4e-5, "xm0p04mm"),
                                      (0.1234567891, "x123p456789mm")])
def test_generated_station_names_are_safe_labels(x_m, name):
    assert position_station_name(x_m) == name
    assert name.isalnum() and name.islower()


def test_station_in_metres_and_by_fraction_are_the_same_node(tmp_path):
    d = tomllib.loads(CAMPAIGN.format(n=24))
    d["plant"]["stations"] = {"gauge": {"x_m": 0.45}, "third": 0.375}
    d["sensors"] = [{"station": "gauge", "direction": "z"},
                    {"x_m": 0.45, "direction": "z", "quantity": "strain"}]
    spec = parse_campaign(d, "g.toml")
    plant = spec.make_plant()
    assert plant.station_node("gauge") == plant.station_node("third") == 9
    assert plant.station_node(spec.sensors[1].station) == 9


# ---- errors ------------------------------------------------------------------------------

def _bad(d, pattern):
    with pytest.raises(CampaignError, match="(?s)" + pattern):
        parse_campaign(d, "art.toml")


@pytest.fixture
def tube_dict():
    return tomllib.loads(CAMPAIGN.format(n=24))


def test_unknown_section_and_material(tube_dict):
    tube_dict["plant"]["section"] = "box"
    _bad(tube_dict, r"art.toml.*'plant.section': expected one of 'tube', 'rectangular_bar', "
                    r"'circular_bar'; got 'box'")
    tube_dict["plant"]["section"] = "tube"
    tube_dict["plant"]["material"] = "brass"
    _bad(tube_dict, r"art.toml.*'plant.material': expected one of 'aluminium', 'steel'; "
                    r"got 'brass'")


def test_dimension_of_another_section(tube_dict):
    tube_dict["plant"]["section"] = "circular_bar"
    tube_dict["plant"]["parameters"] = {"d_m": 0.02, "r_m": 0.01}
    _bad(tube_dict, r"art.toml: key 'plant.parameters.r_m': free_free_beam with a "
                    r"circular_bar section has no parameter 'r_m' \(a dimension of the tube "
                    r"section\); expected the circular_bar section's dimensions d_m; got 'r_m'")
    tube_dict["plant"]["section"] = "rectangular_bar"
    tube_dict["plant"]["parameters"] = {"b_m": 0.02}
    _bad(tube_dict, r"art.toml: key 'plant.parameters': free_free_beam with a rectangular_bar "
                    r"section needs parameter\(s\) 'h_m' \(height along local z \(vertical\), "
                    r"m\): they have no default; got none")


def test_positions_off_the_beam_and_between_nodes(tube_dict):
    tube_dict["sensors"][0]["x_m"] = 1.25
    _bad(tube_dict, r"art.toml: key 'sensors\[0\].x_m': position x_m = 1.25 m is off the "
                    r"beam, which runs from 0 to 1.2 m")
    tube_dict["sensors"][0]["x_m"] = 0.42
    _bad(tube_dict, r"art.toml: key 'sensors\[0\].x_m': position x_m = 0.42 m is not on a "
                    r"node .*nearest node \(node 8\) is at 0.4 m, 0.02 m away.*n_elements = "
                    r"20, 40")
    tube_dict["sensors"][0]["x_m"] = 0.6
    tube_dict["tests"][0]["actuators"][0]["x_m"] = 0.31
    _bad(tube_dict, r"key 'tests\[0\].actuators\[0\].x_m': position x_m = 0.31 m is not on "
                    r"a node")
    tube_dict["tests"][0]["actuators"][0]["x_m"] = 0.3
    tube_dict["plant"]["stations"] = {"gauge": {"x_m": -0.1}}
    _bad(tube_dict, r"key 'plant.stations.gauge.x_m': position x_m = -0.1 m is off the beam")
    tube_dict["plant"]["stations"] = {"gauge": 1.5}
    _bad(tube_dict, r"key 'plant.stations': expected station 'gauge' as a fraction of the "
                    r"length in \[0, 1\] or as a position \{ x_m = <metres from the first "
                    r"end> \}, not 1.5")
    tube_dict["plant"]["stations"] = {"gauge": {"x": 0.3}}
    _bad(tube_dict, r"1 problem.*key 'plant.stations': expected station 'gauge' .* not "
                    r"\{'x': 0.3\}")
    tube_dict["plant"]["stations"] = {}
    tube_dict["plant"]["node_tolerance_m"] = 0.025
    assert parse_campaign({**tube_dict, "sensors": [{"x_m": 0.42, "direction": "z"}]},
                          "loose.toml").make_plant().station_node("x420mm") == 8


def test_suspension_points_off_nodes_or_on_a_plant_without_suspension(tube_dict):
    tube_dict["plant"]["suspension_x_m"] = [0.1, 1.13]
    _bad(tube_dict, r"art.toml: key 'plant.suspension_x_m\[1\]': position x_m = 1.13 m is "
                    r"not on a node of the 24-element mesh: the nearest node \(node 23\) is "
                    r"at 1.15 m, 0.02 m away")
    tube_dict["plant"]["suspension_x_m"] = []
    _bad(tube_dict, r"'plant.suspension_x_m': expected list should have at least 1 item")
    tube_dict["plant"]["suspension_x_m"] = [0.1]
    tube_dict["plant"]["type"] = "hub_beam"
    tube_dict["plant"]["parameters"].pop("suspension_stiffness_n_m")
    _bad(tube_dict, r"art.toml: key 'plant.suspension_x_m': hub_beam has no suspension; "
                    r"expected no suspension_x_m .*got \[0.1\]")


def test_sensor_and_actuator_placed_by_both_or_neither(tube_dict):
    tube_dict["sensors"][0]["station"] = "mid"
    _bad(tube_dict, r"art.toml.*key 'sensors\[0\]': expected a sensor placed by 'station' .* "
                    r"or by 'x_m' .*exactly one of them; both are given; got")
    del tube_dict["sensors"][0]["station"], tube_dict["sensors"][0]["x_m"]
    _bad(tube_dict, r"key 'sensors\[0\]': expected a sensor placed .*neither is given")
    tube_dict["sensors"][0]["x_m"] = 0.6
    tube_dict["tests"][0]["actuators"] = [{"direction": "z"}]
    _bad(tube_dict, r"key 'tests\[0\].actuators\[0\]': expected an actuator placed .*neither")


def test_generated_name_taken_by_another_station(tube_dict):
    tube_dict["plant"]["stations"] = {"x600mm": 0.25}
    _bad(tube_dict, r"key 'sensors\[0\].x_m': the position 0.6 m gets the station name "
                    r"'x600mm', which already names another point")
    tube_dict["plant"]["stations"] = {"x600mm": 0.5}  # the same node: shared
    assert parse_campaign(tube_dict, "ok.toml").sensors[0].station == "x600mm"


def test_geometry_effect_on_a_dimension_the_section_lacks(tube_dict):
    tube_dict["truth"] = {"effects": [{"name": "geometry", "parameters": {
        "t_rel": 0.01, "d_rel": {"mean": 0.0, "std": 0.01}}}]}
    _bad(tube_dict, r"art.toml: key 'truth.effects\[0\].parameters.d_rel': 'd_rel' scales "
                    r"'d_m', which the tube section does not have; expected one of r_rel, "
                    r"t_rel \(or 'L_rel'\), got 'd_rel' with mean 0 and std 0.01")
    tube_dict["truth"]["effects"][0]["parameters"].pop("d_rel")
    assert parse_campaign(tube_dict, "ok.toml").truth_effects()[0].name == "geometry"


def test_plant_level_errors():
    with pytest.raises(ModelError, match=r"free_free_beam: 'section' must be one of 'tube', "
                                         r"'rectangular_bar', 'circular_bar'; got 'I'"):
        make_plant("free_free_beam", section="I")
    with pytest.raises(ModelError, match="suspension point at fraction 0.1 .* not on a node"):
        make_plant("free_free_beam", n_elements=24, suspension_fractions=(0.1,))
    with pytest.raises(ModelError, match="hub_beam has no option 'suspension_fractions'"):
        make_plant("hub_beam", suspension_fractions=(0.5,))
    with pytest.raises(ModelError, match="needs parameter.*'d_m' \\(diameter, m\\)"):
        make_plant("hub_beam", section="circular_bar").resolve()


# ---- other sections through the plants ------------------------------------------------------

def test_rectangular_bar_plant_lateral_modes_and_strain_gauge():
    """A steel flat bar 40 x 8 mm on the hub-beam (hub held): root strain under a static
    tip load is c F L / (E I) with c = b / 2 in the plane of I_z (Hermite elements are
    exact for a tip load); the free-free plant's lateral modes use I_z."""
    b, h, Lb = 0.04, 0.008, 1.0
    sec = RectangularBarSection(b, h)
    params = {"b_m": b, "h_m": h, "L_m": Lb}
    hub = make_plant("hub_beam", n_elements=8, section="rectangular_bar", material="steel")
    model = hub.build(params, [Actuator("tip", "y"), Actuator("tip", "z")],
                      [Sensor("root", "y", "strain"), Sensor("root", "z", "strain")])
    keep = np.array([lab != "n0.rz" for lab in model.dof_labels])
    u = np.linalg.solve(model.K.toarray()[np.ix_(keep, keep)], model.B[keep])
    strain = model.C_out[:, keep] @ u
    assert strain[0, 0] == pytest.approx(-(b / 2) * Lb / (200e9 * sec.second_moment_z_m4),
                                         rel=1e-9)
    assert strain[1, 1] == pytest.approx(-(h / 2) * Lb / (200e9 * sec.second_moment_y_m4),
                                         rel=1e-9)
    ff = make_plant("free_free_beam", section="rectangular_bar", material="steel")
    f20, _ = _plane(ff.build(params), ("y", "rz"))
    f40, roundoff = _plane(replace_n(ff, 40).build(params), ("y", "rz"))
    exact = FREE_FREE[:4] ** 2 * np.sqrt(200e9 * sec.second_moment_z_m4
                                         / (7850.0 * sec.area_m2 * Lb**4))
    _check_bracket(f20[:4], f40[:4], exact, roundoff[:4])


def replace_n(plant, n):
    from dataclasses import replace

    return replace(plant, n_elements=n)


def test_material_override_and_circular_bar_parameters():
    plant = make_plant("free_free_beam", section="circular_bar", material="steel")
    p = plant.resolve({"d_m": 0.02, "E_pa": 210e9})
    assert (p["E_pa"], p["rho_kg_m3"], p["nu"], p["d_m"]) == (210e9, 7850.0, 0.29, 0.02)
    assert "r_m" not in p and "t_m" not in p
    tube = make_plant("free_free_beam").resolve()
    assert (tube["E_pa"], tube["rho_kg_m3"], tube["nu"]) == (68.9e9, 2700.0, 0.33)
    assert list(tube)[:7] == ["E_pa", "nu", "rho_kg_m3", "r_m", "t_m", "L_m",
                              "modal_damping_ratio"]


def test_geometry_effect_scales_the_dimensions_of_the_section():
    bar = make_plant("free_free_beam", n_groups=2, section="rectangular_bar")
    zero = dict.fromkeys(("r_rel", "t_rel", "L_rel", "b_rel", "h_rel", "d_rel"), 0.0)
    setup = SetupBuilder(plant=bar, parameters=bar.resolve({"b_m": 0.03, "h_m": 0.01}))
    Geometry().contribute({**zero, "b_rel": 0.1, "h_rel": -0.1}, {"group": "g2"}, setup)
    assert setup.parameters["b_m@g2"] == pytest.approx(0.033)
    assert setup.parameters["h_m@g2"] == pytest.approx(0.009)
    assert setup.parameters["b_m"] == 0.03
    tube = make_plant("free_free_beam")
    setup = SetupBuilder(plant=tube, parameters=tube.resolve())
    with pytest.raises(ModelError, match=r"effect 'geometry': parameter 'b_rel' = 0.02 scales "
                                         r"'b_m', which the tube section does not have; "
                                         r"expected 0 .*use r_rel, t_rel"):
        Geometry().contribute({**zero, "b_rel": 0.02}, {"group": "all"}, setup)
    # the tube's own parameters are drawn first, as before the bars existed
    assert [p.name for p in Geometry.params][:3] == ["r_rel", "t_rel", "L_rel"]
