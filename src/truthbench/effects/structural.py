"""Effects on the structure (M, C, K) and on the plant's parameters (Table 10.1, linear).

Relative parameters (``*_rel``) multiply the plant parameter by ``1 + value``.
"""

from __future__ import annotations

from dataclasses import replace
from typing import ClassVar

import numpy as np

from truthbench.effects.base import (
    Diagnosable,
    Effect,
    EffectParam,
    FitParam,
    register_effect,
)
from truthbench.errors import ModelError
from truthbench.fe.assembly import direction_index
from truthbench.fe.beam import element_matrices


def _scale(setup, name: str, group: str, rel: float) -> None:
    key = name if group == "all" else f"{name}@{group}"
    if group != "all" and group not in setup.plant.group_names:
        raise ModelError(f"element group {group!r} does not exist; groups are "
                         f"{', '.join(setup.plant.group_names)}")
    setup.scale_parameter(key, 1.0 + rel)


@register_effect
class Material(Effect):
    name: ClassVar[str] = "material"
    description: ClassVar[str] = "E, rho, nu of an element group (or all) differ from nominal"
    params: ClassVar = (EffectParam("E_rel", 0.0, "relative error of E", -0.9),
                        EffectParam("rho_rel", 0.0, "relative error of rho", -0.9),
                        EffectParam("nu_rel", 0.0, "relative error of nu", -0.9))
    options: ClassVar = {"group": "all"}

    def contribute(self, values, options, setup):
        for key, par in (("E_rel", "E_pa"), ("rho_rel", "rho_kg_m3"), ("nu_rel", "nu")):
            _scale(setup, par, options["group"], values[key])


#: Geometry's relative errors and the section dimension each scales.
_DIMENSION_RELS = (("r_rel", "r_m"), ("t_rel", "t_m"), ("b_rel", "b_m"), ("h_rel", "h_m"),
                   ("d_rel", "d_m"))


@register_effect
class Geometry(Effect):
    name: ClassVar[str] = "geometry"
    description: ClassVar[str] = ("the section's dimensions (tube r, t; rectangular bar b, h; "
                                  "circular bar d) and the length differ from nominal")
    # new parameters go at the end: draws of the earlier ones stay as they were
    params: ClassVar = (EffectParam("r_rel", 0.0, "relative error of the mean radius", -0.9),
                        EffectParam("t_rel", 0.0, "relative error of the wall thickness", -0.9),
                        EffectParam("L_rel", 0.0, "relative error of the length", -0.9),
                        EffectParam("b_rel", 0.0, "relative error of a bar's width", -0.9),
                        EffectParam("h_rel", 0.0, "relative error of a bar's height", -0.9),
                        EffectParam("d_rel", 0.0, "relative error of a bar's diameter", -0.9))
    options: ClassVar = {"group": "all"}

    def contribute(self, values, options, setup):
        from truthbench.fe.beam import SECTIONS

        section = setup.plant.section
        dims = SECTIONS[section].dimensions
        for key, par in _DIMENSION_RELS:
            if par in dims:
                _scale(setup, par, options["group"], values[key])
            elif values[key] != 0.0:
                raise ModelError(
                    f"effect 'geometry': parameter {key!r} = {values[key]:g} scales {par!r}, "
                    f"which the {section} section does not have; expected 0 (the section's "
                    f"dimensions are {', '.join(dims)}: use "
                    f"{', '.join(k for k, p in _DIMENSION_RELS if p in dims)})")
        if options["group"] == "all":
            setup.scale_parameter("L_m", 1.0 + values["L_rel"])
        else:
            g = options["group"]
            seg = setup.parameters.get(f"L_m@{g}",
                                       setup.parameters["L_m"] / setup.plant.n_groups)
            setup.parameters[f"L_m@{g}"] = seg * (1.0 + values["L_rel"])


@register_effect
class Parameter(Effect):
    name: ClassVar[str] = "parameter"
    description: ClassVar[str] = ("any plant parameter off by a relative amount (hub "
                                  "inertia, hub damper, suspension, modal damping)")
    params: ClassVar = (EffectParam("rel", 0.0, "relative error", -0.99),)
    options: ClassVar = {"parameter": None}

    def contribute(self, values, options, setup):
        name = options["parameter"]
        if name.split("@")[0] not in setup.parameters:
            raise ModelError(f"effect 'parameter': the plant has no parameter {name!r}")
        setup.scale_parameter(name, 1.0 + values["rel"])


@register_effect
class Discretization(Effect):
    name: ClassVar[str] = "discretization"
    description: ClassVar[str] = "the truth is meshed finer than the model (h-refinement)"
    params: ClassVar = ()
    options: ClassVar = {"refine": 4}
    neutral: ClassVar = {"refine": 1}

    def contribute(self, values, options, setup):
        k = int(options["refine"])
        if k < 1:
            raise ModelError(f"effect 'discretization': refine must be >= 1; got {k}")
        setup.plant = replace(setup.plant, n_elements=setup.plant.n_elements * k)


@register_effect
class ElementPhysics(Effect):
    name: ClassVar[str] = "element_physics"
    description: ClassVar[str] = ("the truth has shear deformation and rotary inertia "
                                  "(Timoshenko); the model is Euler-Bernoulli. `scale` "
                                  "multiplies both (1: the Timoshenko beam of the section)")
    params: ClassVar = (EffectParam("scale", 1.0, "fraction of the Timoshenko shear "
                                    "deformation and rotary inertia", 0.0),)
    neutral: ClassVar = {"scale": 0.0}
    diagnosis: ClassVar = Diagnosable((FitParam("scale", "unit", 0.5, minimum=0.0),))

    def contribute(self, values, options, setup):
        if values["scale"] != 0:
            setup.plant = replace(setup.plant, timoshenko=float(values["scale"]))


def support_node(plant, support) -> int:
    """The node of suspension point ``support`` (an index into the plant's
    ``suspension_nodes()``, 0 first).

    Raises
    ------
    ModelError
        The plant has no suspension, or ``support`` is not the index of one of its
        suspension points (named, with what was expected and what was received).
    """
    nodes = plant.suspension_nodes() if hasattr(plant, "suspension_nodes") else ()
    if not nodes or "suspension_stiffness_n_m" not in plant.parameters:
        raise ModelError(f"effect 'boundary' needs a suspended plant; {plant.kind} has no "
                         f"suspension points; got support = {support!r}")
    if (isinstance(support, bool) or not isinstance(support, int | float)
            or support != int(support) or not 0 <= support < len(nodes)):
        raise ModelError(f"effect 'boundary': option 'support' expected 'all' or the index of "
                         f"a suspension point, 0..{len(nodes) - 1} (at nodes "
                         f"{', '.join(map(str, nodes))}); got {support!r}")
    return nodes[int(support)]


def _stiffness_ratio(fitted) -> dict[str, float]:
    """The boundary fitted on a log scale: ``stiffness_rel = exp(x) - 1``."""
    return {"stiffness_rel": float(np.expm1(fitted["log_stiffness_ratio"]))}


@register_effect
class BoundaryConditions(Effect):
    name: ClassVar[str] = "boundary"
    default_scope: ClassVar[str] = "test"
    description: ClassVar[str] = (
        "suspension stiffness and damping differ in every test (free-free beam): the "
        "vertical spring of every suspension point is (1 + stiffness_rel) times the "
        "suspension stiffness and its dashpot gains damping_n_s_m; support = k changes "
        "suspension point k only (0 first), support = 'all' every one")
    params: ClassVar = (EffectParam("stiffness_rel", 0.0, "relative error of the suspension "
                                    "stiffness", -0.99),
                        EffectParam("damping_n_s_m", 0.0, "added suspension damping, N s/m",
                                    0.0))
    options: ClassVar = {"support": "all"}
    diagnosis: ClassVar = Diagnosable(
        (FitParam("log_stiffness_ratio", "unit", 0.5, minimum=float(np.log(0.1)),
                  maximum=float(np.log(10.0))),),
        location="support", to_values=_stiffness_ratio)
    """Diagnosed by its stiffness only, on a log scale: ``log_stiffness_ratio`` is
    ``ln(k / k_nominal)``, 0 at the start, natural size 0.5 (a factor 1.65), bounds
    ln 0.1 .. ln 10, so the screen's line searches and the fit reach 0.1 to 10 times the
    suspension stiffness evenly. Tried at every suspension point and at all of them
    (``location = "support"``: the option ``support`` is ``"all"`` or the index of one
    point). Added suspension damping is a grounded dashpot at the suspension points (a
    dashpot candidate), and a damping fitted beside the stiffness crosses zero, where the
    model refuses it."""

    def contribute(self, values, options, setup):
        if "suspension_stiffness_n_m" not in setup.parameters:
            raise ModelError(f"effect 'boundary' needs a suspended plant; "
                             f"{setup.plant.kind} has no suspension")
        support = options.get("support", "all")
        if support == "all":
            setup.scale_parameter("suspension_stiffness_n_m", 1.0 + values["stiffness_rel"])
            setup.parameters["suspension_damping_n_s_m"] += values["damping_n_s_m"]
            return
        # one point: its vertical spring and dashpot change by what "all" gives each
        dof = 6 * support_node(setup.plant, support) + 2
        if values["stiffness_rel"] != 0:
            added = values["stiffness_rel"] * setup.parameters["suspension_stiffness_n_m"]
            setup.links.append(("spring", dof, -1, added))
        if values["damping_n_s_m"] != 0:
            setup.links.append(("dashpot", dof, -1, values["damping_n_s_m"]))


def _element(plant, params, element: int, direction: str):
    """``(props, section, h, EI)`` of one element at the resolved plant parameters:
    its group's properties, its cross-section, its length (m) and its bending stiffness
    for the rotation ``direction`` (ry: bending in the x-z plane, ``I_y``; rz: ``I_z``;
    N m^2)."""
    props, sec, h = plant.element_section(element, params)
    second = sec.second_moment_z_m4 if direction == "rz" else sec.second_moment_y_m4
    return props, sec, h, props["E_pa"] * second


def element_bending(plant, params, node: int, direction: str) -> tuple[float, float]:
    """``(EI, h)`` of the element a joint at ``node`` weakens (the one beginning there;
    the last one at the last node), for the bending rotation ``direction`` (ry: bending
    in the x-z plane, ``I_y``; rz: ``I_z``): N m^2 and m, at the resolved plant
    parameters ``params``."""
    _, _, h, EI = _element(plant, params, min(node, plant.n_elements - 1), direction)
    return EI, h


def hinge_points(plant, params, element: int, xi: float, direction: str, loss: float
                 ) -> tuple[tuple[str, tuple[tuple[int, float], ...], float], ...]:
    """A joint concentrated at local coordinate ``xi`` of ``element`` as the change of K
    it makes, one or two rank-one terms ``("spring", weights, value)`` each adding
    ``value v v^T`` (the form of
    :attr:`~truthbench.plants.base.StructuralAdditions.points`).

    The joint is the element's loss of ``loss`` of its stiffness gathered at the point:
    a rotational spring ``k_b = EI (1 - loss) / (loss h)`` on the bending moment there
    and, when the element has shear deformation (a Timoshenko element, scaled as the
    plant's ``timoshenko``), a transverse spring ``k_s = kappa G A (1 - loss) /
    (loss h scale)`` on the shear force; the same flexibility as the whole element
    losing ``loss``, so a loss means the same joint wherever it is. The section forces
    at the point are, by statics alone, ``G^T f`` of node A's end forces (``G``: the
    moment's lever arm and the shear), so by the Woodbury identity the element's exact
    static stiffness becomes ``K_e - K_e G (H + G^T K_e G)^-1 G^T K_e`` with
    ``H = diag(k_b, k_s)``: exact for the statics of the Euler-Bernoulli and the
    Timoshenko element (``G^T K_e G`` is the element's own restraint of a kink:
    ``4 EI/h (3 xi^2 - 3 xi + 1)`` for Euler-Bernoulli, ``EI/h`` at the centre).

    Parameters
    ----------
    plant : Plant
    params : mapping
        Resolved plant parameters.
    element : int
        The element, 0..n_elements-1.
    xi : float
        Local coordinate in [0, 1].
    direction : {"ry", "rz"}
        The bending rotation: ry bends in the x-z plane (``I_y``), rz in x-y (``I_z``).
    loss : float
        < 1.

    Returns
    -------
    tuple of (str, tuple of (int, float), float)
        Weights ``v`` on the element's two translations (N) and two rotations (N m),
        and ``value`` (1/(N m) for the bending term); one term for an Euler-Bernoulli
        element, two with shear deformation.
    """
    props, sec, h, EI = _element(plant, params, element, direction)
    scale = float(plant.timoshenko)
    k12, _ = element_matrices(props["E_pa"], props["nu"], props["rho_kg_m3"], sec, h,
                              timoshenko=scale)
    # the plane's DOFs (w_A, theta_A, w_B, theta_B); this code's theta_y = -dw/dx
    local, sign = ((1, 5, 7, 11), 1.0) if direction == "rz" else ((2, 4, 8, 10), -1.0)
    K = k12[np.ix_(local, local)]
    flex = loss * h / (1.0 - loss)  # the lost part's length over its remaining stiffness
    G = np.array([[xi * h, -sign, 0.0, 0.0]]).T  # the moment at the point
    C = np.array([[flex / EI]])
    if scale > 0:  # and the shear force there
        # the shear flexibility per length, scale / (kappa G A) = phi h^2 / (12 EI)
        phi = plant.shear_parameter(element, "y" if direction == "rz" else "z", params)
        G = np.hstack([G, [[1.0], [0.0], [0.0], [0.0]]])
        C = np.diag([flex / EI, flex * phi * h * h / (12.0 * EI)])
    KG = K @ G
    middle = C @ np.linalg.inv(np.eye(len(C)) + G.T @ KG @ C)  # (H + G^T K G)^-1
    mu, Q = np.linalg.eigh(0.5 * (middle + middle.T))
    dofs = [6 * element + j for j in local]
    return tuple(("spring", tuple(zip(dofs, map(float, KG @ q), strict=True)), -float(m))
                 for m, q in zip(mu, Q.T, strict=True) if m != 0)


JOINT_FORMS = ("element", "hinge")
"""How a joint is modelled: the whole element beginning at its station loses stiffness,
or a concentrated hinge acts at its station (anywhere, between nodes too)."""


@register_effect
class Joint(Effect):
    """A joint: a local loss of bending stiffness, with a rotational dashpot across it.

    ``form = "element"`` (the default): the element beginning at the station (a node)
    loses ``stiffness_loss`` of its stiffness, all of it (bending, axial, torsion), as a
    bolted or clamped joint made by a short soft part. ``form = "hinge"``: that loss
    gathered at the station, on a node or between nodes, in the bending plane of
    ``direction``: a rotational spring, and a transverse one where the element has shear
    deformation (:func:`hinge_points`); it is exact for the element's statics, and it
    keeps at its point what the whole-element loss smears over the element, which the
    higher bending modes, whose curvature changes sign within a few elements, tell
    apart.
    The dashpot acts on the relative bending rotation of the element's end nodes.
    """

    name: ClassVar[str] = "joint"
    description: ClassVar[str] = ("a joint at a station: the element beginning there loses "
                                  "stiffness (or a concentrated hinge acts there: form = "
                                  "\"hinge\"), and a concentrated rotational dashpot acts "
                                  "across it (non-proportional damping)")
    params: ClassVar = (EffectParam("stiffness_loss", 0.0, "fraction of the joint element's "
                                    "stiffness lost", 0.0),
                        EffectParam("damping_n_m_s_rad", 0.0, "dashpot on the relative "
                                    "bending rotation across the joint element", 0.0))
    options: ClassVar = {"station": None, "direction": "ry", "form": "element"}
    diagnosis: ClassVar = Diagnosable(
        (FitParam("stiffness_loss", "unit", 0.1, minimum=0.0, maximum=0.99),
         FitParam("damping_n_m_s_rad", "rotary_damping", 0.1, minimum=0.0)),
        location="station", directions="bending")

    @classmethod
    def locates_between_nodes(cls, options) -> bool:
        return options.get("form") == "hinge"

    def contribute(self, values, options, setup):
        plant = setup.plant
        form = options.get("form", "element")
        if form not in JOINT_FORMS:
            raise ModelError(f"effect 'joint': form must be one of {', '.join(JOINT_FORMS)}; "
                             f"got {form!r}")
        loss = values["stiffness_loss"]
        if not loss < 1:
            raise ModelError("effect 'joint': stiffness_loss must be < 1")
        d = direction_index(options["direction"])
        if form == "element":
            e = min(plant.station_node(options["station"]), plant.n_elements - 1)
            setup.element_scale.append((e, 1.0 - loss))
        else:
            if options["direction"] not in ("ry", "rz"):
                raise ModelError(f"effect 'joint': a hinge bends about ry or rz; got "
                                 f"direction {options['direction']!r}")
            pos = plant.station_fraction(options["station"]) * plant.n_elements
            e = min(int(np.floor(pos)), plant.n_elements - 1)
            xi = float(pos - e)
            if abs(xi - round(xi)) <= 1e-9:
                xi = float(round(xi))
            if loss != 0:  # smooth through 0 for fitting; made when the setup is frozen,
                # with the element's physics as the other effects leave it
                setup.hinges.append((e, xi, options["direction"], loss))
        if values["damping_n_m_s_rad"] != 0:  # smooth through 0 for fitting
            setup.links.append(("dashpot", 6 * e + d, 6 * (e + 1) + d,
                                values["damping_n_m_s_rad"]))


@register_effect
class AddedMass(Effect):
    """A point mass at a station, on a node or between nodes.

    The mass ``m`` (kg) moves with the beam's translations x, y, z at its point: for each
    translation ``d`` it adds ``m u_d u_d^T`` to M, with ``u_d`` the weights of
    :meth:`~truthbench.plants.base.Plant.point_weights` (kinetic energy
    ``m/2 (u_d^T dq/dt)^2``). On a node that is ``m`` on the node's three translations, as
    a lumped mass. Between nodes ``u_y``, ``u_z`` are the element's Hermite functions and
    include the nodal rotations, so ``u u^T`` also puts inertia on the rotations and
    couples them with the translations: this is the consistent mass of a point mass, the
    inertia of the point's translation expressed through the nodal DOFs, not a rotary
    inertia of the mass about its own centre (a point mass has none).
    """

    name: ClassVar[str] = "added_mass"
    description: ClassVar[str] = "a point mass at a station (structural change, Table 10.4)"
    params: ClassVar = (EffectParam("mass_kg", 0.0, "added mass, kg", 0.0),)
    options: ClassVar = {"station": None}
    between_nodes: ClassVar[bool] = True
    diagnosis: ClassVar = Diagnosable((FitParam("mass_kg", "mass", 0.01, minimum=0.0),),
                                      location="station")

    def contribute(self, values, options, setup):
        for d in ("x", "y", "z"):
            setup.attach("mass", options["station"], d, values["mass_kg"])


@register_effect
class SensorMass(Effect):
    name: ClassVar[str] = "sensor_mass"
    description: ClassVar[str] = "accelerometer mass loading at every sensor station"
    per_test_channels: ClassVar[bool] = True
    diagnosis: ClassVar = Diagnosable((FitParam("mass_kg", "mass", 0.005, minimum=0.0),))
    params: ClassVar = (EffectParam("mass_kg", 0.0, "mass of one accelerometer, kg", 0.0),)
    options: ClassVar = {}

    def contribute(self, values, options, setup):
        for station in dict.fromkeys(setup.sensor_stations):
            node = setup.plant.station_node(station)
            for d in range(3):
                setup.links.append(("mass", 6 * node + d, -1, values["mass_kg"]))


@register_effect
class Aerodynamic(Effect):
    name: ClassVar[str] = "aerodynamic"
    default_scope: ClassVar[str] = "test"
    description: ClassVar[str] = ("quasi-steady air forces per unit length, f = -(c v + k w), "
                                  "lumped at the nodes by tributary length")
    params: ClassVar = (EffectParam("damping_n_s_m2", 0.0, "damping per length, N s/m^2", 0.0),
                        EffectParam("stiffness_n_m2", 0.0, "stiffness per length, N/m^2", 0.0))
    options: ClassVar = {"direction": "z"}

    def contribute(self, values, options, setup):
        d = direction_index(options["direction"])
        if d > 2:
            raise ModelError("effect 'aerodynamic' acts on a translation (x, y or z)")
        x = setup.plant.node_x_m(setup.parameters)
        trib = np.zeros_like(x)
        h = np.diff(x)
        trib[:-1] += h / 2
        trib[1:] += h / 2
        for node, length in enumerate(trib):
            if values["damping_n_s_m2"] > 0:
                setup.links.append(("dashpot", 6 * node + d, -1,
                                    values["damping_n_s_m2"] * length))
            if values["stiffness_n_m2"] > 0:
                setup.links.append(("spring", 6 * node + d, -1,
                                    values["stiffness_n_m2"] * length))


@register_effect
class GravitySag(Effect):
    name: ClassVar[str] = "sag"
    default_scope: ClassVar[str] = "reassembly"
    description: ClassVar[str] = ("static deflection under gravity; every element is rotated "
                                  "by its sag angle (Eq. 10.5-10.6), coupling axial with "
                                  "vertical bending")
    params: ClassVar = (EffectParam("scale", 1.0, "multiple of the physical sag (1 = gravity "
                                    "on the nominal supports)", 0.0),)
    neutral: ClassVar = {"scale": 0.0}
    diagnosis: ClassVar = Diagnosable((FitParam("scale", "unit", 1.0, minimum=0.0),))
    options: ClassVar = {}

    def contribute(self, values, options, setup):
        setup.sag_scale += values["scale"]


def sag_angles(plant, params, additions, g_m_s2: float) -> np.ndarray:
    """Element sag angles (rad) from the static deflection under gravity ``-g`` along z.

    The static problem ``K w = f`` is solved on the vertical-bending DOFs (z, ry) of the
    free DOFs with consistent gravity loads ``f = -g M 1_z``; each element's angle is the
    chord slope ``(w_B - w_A) / L_e``.

    Returns
    -------
    ndarray, shape (n_elements,)
    """
    model = plant.build(params, additions=replace(additions, sag_angles_rad=None))
    labels = np.array(model.dof_labels)
    vert = np.array([lab.endswith((".z", ".ry")) for lab in labels])
    z = np.array([lab.endswith(".z") for lab in labels])
    K = model.K.toarray()[np.ix_(vert, vert)]
    f = -g_m_s2 * (model.M @ z.astype(float))[vert]
    try:
        w_v = np.linalg.solve(K, f)
    except np.linalg.LinAlgError:
        raise ModelError("sag: the plant is not supported vertically (singular K in z)") \
            from None
    w = np.zeros(len(labels))
    w[vert] = w_v
    wz = np.zeros(plant.n_elements + 1)
    for lab, value in zip(labels[z], w[z], strict=True):
        wz[int(lab[1:].split(".")[0])] = value
    x = plant.node_x_m(params)
    return np.arctan(np.diff(wz) / np.diff(x))
