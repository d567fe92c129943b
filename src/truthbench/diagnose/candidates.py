"""The candidate missing effects: every registered effect that declares how diagnosis fits
it (:class:`~truthbench.effects.base.Diagnosable`), at every location it can have.

A :class:`Candidate` is one effect with its options fixed (a station, a direction, an
output channel) and its fitted parameters free, as an
:class:`~truthbench.update.EffectTerm` of the FRF predictor. Locations:

``station``
    every node of the model that can move in the candidate's direction (a station
    ``n<k>`` per node);
``sensor``
    every output channel of every test (index into the test's sensors; the channels of
    the tests are the same physical sensors when their labels agree);
``support``
    all supports together and, when there are several, each one (``boundary``);
directions
    ``translation``: every translational direction the data measure; ``bending``: the
    bending rotation of every measured transverse direction (z -> ry, y -> rz).

Where the article touches ground is the model's to say: with ``[plant] supports``
declared, grounded springs and dashpots are tried only at the supports ("springs",
"foam") or nowhere ("none"); a spring at a suspension point in its own direction is the
support's stiffness, tried as ``boundary`` (which can also soften it).

The natural size of each fitted parameter (its FD step and trust region) is a fraction
of a model reference (:func:`references`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from truthbench.effects import EFFECTS, EffectSpec, parse_effect
from truthbench.effects.base import FitParam
from truthbench.errors import ModelError
from truthbench.plants.base import Plant
from truthbench.update.predictor import EffectTerm

_BENDING = {"z": "ry", "y": "rz"}

GROUNDING = ("grounded_spring", "grounded_dashpot")
"""Effects that reach ground: tried only where the article touches it when the model
declares its supports (``[plant] supports``), and nowhere for ``supports = "none"``."""


@dataclass(frozen=True)
class Candidate:
    """One effect at one location with its fitted parameters free.

    Attributes
    ----------
    effect : str
        Registry name.
    options : dict
        The effect's options (station, direction, sensor).
    label : str
        Unique name, e.g. ``"added_mass@n12"``, ``"grounded_dashpot@n3.z"``,
        ``"channel_gain@mid.z.acc"``, ``"time_delay"``.
    fitted : tuple of FitParam
    node : int or None
        The model node of a located candidate (a joint's: the element its hinge is in).
    levels : tuple of (test, coefficient), optional
        Coulomb friction only: each test's equivalent viscous damping per newton of
        friction, ``sqrt(2 / pi) / sigma_v`` with ``sigma_v`` the RMS velocity at the
        friction's DOF in that test (statistical linearisation for a Gaussian response:
        ``E[F_c sign(v) v] / E[v^2]``), set by :func:`bind_levels`.
    pinned : tuple of (name, value), optional
        Fitted parameters held at a physical bound the fit crossed (:meth:`pin`): they
        are no longer in ``fitted`` and enter the model at that value.
    """

    effect: str
    options: dict
    label: str
    fitted: tuple[FitParam, ...]
    node: int | None = None
    levels: tuple[tuple[str, float], ...] | None = None
    pinned: tuple[tuple[str, float], ...] = ()

    def pin(self, values: Mapping[str, float]) -> Candidate:
        """The candidate with the fitted parameters ``values`` (own name -> value) held
        there: the constrained fit of a parameter whose free optimum lies beyond its
        physical bound holds it at the bound (a joint's damping at 0 while its stiffness
        loss is still fitted)."""
        return replace(self, fitted=tuple(p for p in self.fitted if p.name not in values),
                       pinned=self.pinned + tuple((k, float(v)) for k, v in values.items()))

    @property
    def spec(self) -> EffectSpec:
        return parse_effect({"name": self.effect, **self.options}, self.label, "diagnosis")

    def terms(self, start: Mapping[str, float] | None = None) -> tuple[EffectTerm, ...]:
        """The candidate as effect terms of the predictor (fitted names are the
        :class:`FitParam` names, keyed ``label.name``): one term, or for friction one
        equivalent dashpot per test sharing the friction force."""
        init = {p.name: p.start for p in self.fitted}
        init.update(start or {})
        names = tuple(p.name for p in self.fitted)
        held = dict(self.pinned)
        if self.effect == "coulomb_friction":
            if self.levels is None:
                raise ModelError(f"candidate {self.label!r}: the tests' levels are not "
                                 f"bound (bind_levels)")
            dashpot = parse_effect({"name": "grounded_dashpot", **self.options},
                                   self.label, "diagnosis")
            return tuple(EffectTerm(
                f"{self.label}/{test}", dashpot, names,
                lambda f, k=k: {"damping_n_s_m": k * f["force_n"]}, init, (test,),
                self.label) for test, k in self.levels)
        to_values = EFFECTS[self.effect].diagnosis.to_values
        if held:
            to_values = ((lambda f: {**held, **f}) if to_values is None else
                         (lambda f, g=to_values: g({**held, **f})))
        return (EffectTerm(self.label, self.spec, names, to_values, init),)

    def keys(self) -> tuple[str, ...]:
        return tuple(f"{self.label}.{p.name}" for p in self.fitted)

    def scales(self, refs: Mapping[str, float]) -> dict[str, float]:
        """Natural size of each fitted parameter (key -> size in its unit)."""
        return {f"{self.label}.{p.name}": p.factor * refs[p.reference] for p in self.fitted}

    def effect_values(self, fitted: Mapping[str, float]) -> dict[str, float]:
        """The effect's own parameter values for fitted values (by own name)."""
        if self.effect == "coulomb_friction":
            return {"force_n": float(fitted["force_n"])}
        return self.terms()[0].values({f"{self.label}.{k}": v for k, v in fitted.items()})


def references(plant: Plant, nominal: Mapping[str, float], f_max_hz: float,
               f_ref_hz: float | None = None, f_min_hz: float = 0.0) -> dict[str, float]:
    """The model quantities the fitted parameters' natural sizes are fractions of.

    ``mass``: the structure's translational mass (kg); ``stiffness``: mass times the
    squared reference angular frequency (N/m); ``damping``: ``2 omega_ref mass``
    (N s/m; 1 % of it damps the first mode by about 1 %); ``rotary_damping``: damping
    times the squared element length (N m s/rad); ``time``: ``1 / (2 pi f_max)`` (s);
    ``time_squared``: its square (s^2); ``unit``: 1. ``f_ref_hz`` defaults to the lowest
    elastic mode at or above ``f_min_hz`` (the compared band's low edge: a suspension
    mode below the band would make the sizes of structural springs and dashpots far too
    small).
    """
    model = plant.build(nominal)
    labels = model.dof_labels
    x = np.array([lab.endswith(".x") for lab in labels], dtype=float)
    y = np.array([lab.endswith(".y") for lab in labels], dtype=float)
    z = np.array([lab.endswith(".z") for lab in labels], dtype=float)
    mass = max(float(v @ (model.M @ v)) for v in (x, y, z))
    if f_ref_hz is None:
        modes = model.modes(min(24, model.n_dofs))
        elastic = modes.freq_hz[~modes.rigid]
        elastic = elastic[(elastic > 0) & (elastic >= f_min_hz)]
        f_ref_hz = float(elastic[0]) if elastic.size else f_max_hz
    w = 2 * np.pi * f_ref_hz
    h = float(np.mean(np.diff(plant.node_x_m(nominal))))
    time = 1.0 / (2 * np.pi * f_max_hz)
    return {"mass": mass, "stiffness": mass * w * w, "damping": 2 * w * mass,
            "rotary_damping": 2 * w * mass * h * h, "time": time, "time_squared": time**2,
            "unit": 1.0}


def _free_directions(plant: Plant, nominal, node: int) -> set[str]:
    labels = plant.build(nominal).dof_labels
    return {lab.split(".")[1] for lab in labels if lab.startswith(f"n{node}.")}


def catalogue(plant: Plant, nominal: Mapping[str, float], tests, *,
              names: Sequence[str] | None = None) -> list[Candidate]:
    """Every candidate the data can test.

    Parameters
    ----------
    plant : Plant
        The model with a station ``n<k>`` at every node (:func:`with_node_stations`).
    nominal : mapping
    tests : sequence of MeasuredTest
    names : sequence of str, optional
        Effects to try (registry names); default every diagnosable effect.

    Returns
    -------
    list of Candidate

    Raises
    ------
    ModelError
        An unknown or not diagnosable effect name.
    """
    diagnosable = {n: c for n, c in EFFECTS.items() if c.diagnosis is not None}
    if names is None:
        names = sorted(diagnosable)
    bad = [n for n in names if n not in diagnosable]
    if bad:
        raise ModelError(f"effects {bad} cannot be tried as missing; the candidates are "
                         f"{', '.join(sorted(diagnosable))}")
    measured = sorted({s.direction for t in tests for s in t.sensors} |
                      {a.direction for t in tests for a in t.actuators})
    levels_known = all(t.frf.input_rms is not None and t.frf.band_hz is not None
                       for t in tests)
    translations = [d for d in measured if d in ("x", "y", "z")]
    nodes = range(plant.n_elements + 1)
    free = {k: _free_directions(plant, nominal, k) for k in nodes}
    sensors = list(dict.fromkeys(s.label for t in tests for s in t.sensors))
    suspended = "suspension_stiffness_n_m" in plant.parameters
    touching = set(plant.support_nodes())
    supports = getattr(plant, "supports", None)
    out = []
    for name in names:
        cls = diagnosable[name]
        form = cls.diagnosis
        if name == "boundary" and not suspended:
            continue  # no suspension to be wrong
        grounding = name in GROUNDING
        if grounding and supports == "none":
            continue  # nothing touches the article: no path to ground
        if form.directions == "translation":
            dirs = translations
        elif form.directions == "measured":
            dirs = measured
        elif form.directions == "bending":
            dirs = [_BENDING[d] for d in translations if d in _BENDING]
        else:
            dirs = [None]
        if name == "joint":
            # a concentrated hinge at every element's centre (its place is searched
            # along the element once found: :mod:`.place`), tagged with its element
            for k in range(plant.n_elements):
                station = point_station((k + 0.5) / plant.n_elements)
                for d in dirs:
                    out.append(Candidate(name, {"station": station, "direction": d,
                                                "form": "hinge"},
                                         f"{name}@{station}.{d}", form.fitted, k))
        elif form.location == "station":
            for k in nodes:
                for d in dirs:
                    if d is not None and d not in free[k] and form.directions != "bending":
                        continue
                    if name == "coulomb_friction" and not levels_known:
                        continue
                    if d is None and not free[k] & {"x", "y", "z"}:
                        continue
                    if grounding and supports is not None and k not in touching:
                        continue  # declared supports: ground is reached only there
                    if (name == "grounded_spring" and suspended and d == "z"
                            and k in touching and "boundary" in names):
                        continue  # the support's own spring: boundary@support (either way)
                    opts = {"station": f"n{k}"}
                    label = f"{name}@n{k}"
                    if d is not None:
                        opts["direction"] = d
                        label += f".{d}"
                    out.append(Candidate(name, opts, label, form.fitted, k))
        elif form.location == "sensor":
            for lab in sensors:
                out.append(Candidate(name, {"sensor": lab}, f"{name}@{lab}", form.fitted))
        elif form.location == "support":
            out.append(Candidate(name, {}, name, form.fitted))
            if len(touching) > 1:
                for k in range(len(plant.support_nodes())):
                    out.append(Candidate(name, {"support": k}, f"{name}@support{k}",
                                         form.fitted))
        else:
            out.append(Candidate(name, {}, name, form.fitted))
    return out


def not_tried(plant: Plant, tests, names: Sequence[str] | None = None
              ) -> tuple[tuple[str, str], ...]:
    """The effects of ``names`` (default: every diagnosable one) that :func:`catalogue`
    leaves out as a whole here, each with the reason a user can act on."""
    names = sorted(n for n, c in EFFECTS.items() if c.diagnosis is not None) \
        if names is None else list(names)
    out = []
    if "coulomb_friction" in names:
        unknown = [t.name for t in tests
                   if t.frf.input_rms is None or t.frf.band_hz is None]
        if unknown:
            out.append(("coulomb_friction",
                        f"the input level of test(s) {unknown} is not known (UFF FRFs do "
                        f"not carry it): state it in the model file, [diagnose] "
                        f"input_rms_n = {{ \"<data set>\" = <N RMS> }}, or give time "
                        f"records"))
    if "boundary" in names and "suspension_stiffness_n_m" not in plant.parameters:
        out.append(("boundary", "the model has no suspension to be wrong"))
    if getattr(plant, "supports", None) == "none":
        out += [(n, 'the model file states supports = "none": nothing touches the '
                    'article, so nothing grounds it') for n in names if n in GROUNDING]
    return tuple(out)


def bind_levels(cands, hardware_of, tests) -> list[Candidate]:
    """Friction candidates with each test's level coefficient (:attr:`Candidate.levels`)
    from the current model: ``sigma_v^2 = sum_i sum_k |j omega R_i(f_k)|^2 G_i df`` over
    the test's lines, ``R_i`` the receptance from input i to the friction's DOF and
    ``G_i = rms_i^2 / bandwidth`` the input's flat one-sided PSD in its band. Others are
    returned unchanged.

    ``hardware_of(test)`` gives the current model's hardware instrumented with the
    test's inputs.
    """
    out = []
    for c in cands:
        if c.effect != "coulomb_friction":
            out.append(c)
            continue
        levels = []
        for t in tests:
            hw = hardware_of(t)
            model = hw.model
            label = f"n{c.node}.{c.options['direction']}"
            if label not in model.dof_labels:
                break
            E = np.zeros((1, model.n_dofs))
            E[0, model.dof_labels.index(label)] = 1.0
            f = t.freq_hz
            n_in = len(t.actuators)
            R = model.with_io(B=model.B[:, :n_in], C_out=E, quantities=("velocity",)
                              ).frf(f, modes=hw.modes)[:, 0, :]  # (n_f, n_in)
            lo, hi = t.frf.band_hz
            psd = np.asarray(t.frf.input_rms, float) ** 2 / max(hi - lo, 1e-300)
            df = float(np.median(np.diff(f))) if f.size > 1 else 1.0
            sigma = float(np.sqrt(np.sum(np.abs(R) ** 2 * psd[None, :]) * df))
            if not sigma > 0:
                break
            levels.append((t.name, float(np.sqrt(2 / np.pi) / sigma)))
        else:
            out.append(replace(c, levels=tuple(levels)))
    return out


def with_node_stations(plant: Plant) -> Plant:
    """The plant with a station ``n<k>`` at every node (candidates are placed on them)
    and one at every element's midpoint (:func:`point_station`: point attachments are
    screened there too)."""
    n = plant.n_elements
    stations = dict(plant.stations)
    stations.update({f"n{k}": k / n for k in range(n + 1)})
    stations.update({point_station((k + 0.5) / n): (k + 0.5) / n for k in range(n)})
    return replace(plant, stations=stations)


def point_station(fraction: float) -> str:
    """The name of the station at ``fraction`` of the article's length, ``x<fraction>``
    (unique by its value, so it survives a mesh refinement)."""
    return f"x{fraction:.6f}"


def at_fraction(c: Candidate, fraction: float, n_elements: int) -> Candidate:
    """A located candidate moved to the station at ``fraction`` (:func:`point_station`,
    which the plant must have), its node the nearest (a joint's: its element, the one
    the point falls in)."""
    name = point_station(fraction)
    opts = {**c.options, "station": name}
    label = f"{c.effect}@{name}" + (f".{opts['direction']}" if "direction" in opts else "")
    node = int(np.clip(np.floor(fraction * n_elements), 0, n_elements - 1)) \
        if c.effect == "joint" else int(round(fraction * n_elements))
    return replace(c, options=opts, label=label, node=node)
