"""The uncertainty table as code: one protocol, one registry of named effects.

Every row of Table 10.1 is an :class:`Effect` subclass registered by name. An effect
declares

* ``params``: its random parameters (units in the names), each drawn from a mean part
  (the hardware's bias) and a variance part (standard deviation);
* ``options``: fixed settings (a station, a direction, a group);
* ``target``: what it changes, one of :data:`TARGETS`;
* ``default_scope``: when its variance part is drawn, one of :data:`SCOPES`;

and implements ``contribute(values, options, setup)``, adding its realised change to a
:class:`~truthbench.effects.setup.SetupBuilder` (plant parameters, structural additions,
appended dynamics, measurement chain, nonlinear elements).

Scopes (Table 10.4 vocabulary):

``hardware``
    drawn once per Monte Carlo trial (one piece of hardware);
``reassembly``
    drawn again at every assembly of the hardware (tests carry an ``assembly`` index);
``test``
    drawn for every test;
``drift``
    a random walk in the time between tests: ``value(t) = mean + std * W(t / 1 h)``
    with ``W`` a standard Wiener process, so ``std`` is the spread after one hour.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from truthbench.errors import CampaignError

SCOPES = ("hardware", "reassembly", "test", "drift")
TARGETS = ("structure", "appended", "measurement", "nonlinear", "loop")


@dataclass(frozen=True)
class EffectParam:
    """A random parameter of an effect: name (with unit), default mean, meaning."""

    name: str
    default: float
    description: str
    minimum: float | None = None


@dataclass(frozen=True)
class Distribution:
    """Mean part and variance part (standard deviation) of one parameter."""

    mean: float
    std: float = 0.0


@dataclass(frozen=True)
class FitParam:
    """A parameter diagnosis fits when it tries an effect as missing.

    Parameters
    ----------
    name : str
        The fitted parameter (an effect parameter, or another parameterisation, see
        :attr:`Diagnosable.to_values`).
    reference : {"mass", "stiffness", "damping", "rotary_damping", "time", "time_squared", \
"force", "unit"}
        The model quantity its natural size is a fraction of (total mass, modal stiffness
        and damping of the first elastic mode, 1 / (2 pi f_max), its square, the inputs'
        mean RMS, 1): sets the fit's step and trust region, not the answer.
    factor : float
        The natural size as a fraction of ``reference``.
    start : float
        Starting value (the effect's neutral value).
    minimum, maximum : float, optional
        Physical bounds of the fitted value: a fit outside them by more than two standard
        deviations is not physical and is not chosen.
    """

    name: str
    reference: str
    factor: float
    start: float = 0.0
    minimum: float | None = None
    maximum: float | None = None


@dataclass(frozen=True)
class Diagnosable:
    """How diagnosis tries an effect as missing: its fitted parameters and where.

    ``location`` is ``"station"`` (tried at every node of the model), ``"sensor"`` (at
    every output channel), ``"support"`` (with the option ``support`` = ``"all"`` and
    the index of every suspension point of the plant) or None (no location).
    ``directions`` is ``"translation"`` (tried in every measured translational
    direction), ``"measured"`` (every measured direction, rotations included),
    ``"bending"`` (the bending rotation of every measured transverse direction: z -> ry,
    y -> rz) or None.
    ``to_values(fitted) -> effect values`` turns the fitted parameters into the effect's
    own (default: they are the effect's own).
    """

    fitted: tuple[FitParam, ...]
    location: str | None = None
    directions: str | None = None
    to_values: Callable[[Mapping[str, float]], dict[str, float]] | None = None


class Effect:
    """Base class of the effects; subclasses are registered with :func:`register_effect`."""

    name: ClassVar[str] = ""
    target: ClassVar[str] = "structure"
    default_scope: ClassVar[str] = "hardware"
    params: ClassVar[tuple[EffectParam, ...]] = ()
    options: ClassVar[dict[str, object]] = {}
    description: ClassVar[str] = ""
    per_test_channels: ClassVar[bool] = False
    """True when the effect depends on the test's own actuators or sensors (sensor mass,
    a loop between channels): a model with it is realised test by test."""
    neutral: ClassVar[Mapping[str, float] | None] = {}
    """Parameter values (overriding the defaults) and option values at which the effect
    changes nothing, e.g. ``{"scale": 0.0}`` for sag; None for an effect that has no
    neutral setting (element physics is either Timoshenko or not). The shared contract
    test checks that the hardware with the effect at these values has the nominal
    FRF."""

    diagnosis: ClassVar[Diagnosable | None] = None
    """How diagnosis fits this effect as a missing one (None: it is not a candidate)."""
    between_nodes: ClassVar[bool] = False
    """True when the effect's ``station`` may lie between nodes (a point attachment,
    through :meth:`~truthbench.plants.base.Plant.point_weights`); False when it needs
    a node (:meth:`~truthbench.plants.base.Plant.station_node`)."""

    @classmethod
    def locates_between_nodes(cls, options: Mapping[str, object]) -> bool:
        """Whether the effect with ``options`` may have its station between nodes
        (:attr:`between_nodes`; a joint only in its hinge form)."""
        return cls.between_nodes

    @classmethod
    def neutral_values(cls) -> tuple[dict[str, float], dict[str, object]] | None:
        """``(parameter values, option overrides)`` at which the effect does nothing, or
        None."""
        if cls.neutral is None:
            return None
        values = {p.name: float(cls.neutral.get(p.name, p.default)) for p in cls.params}
        options = {k: v for k, v in cls.neutral.items() if k in cls.options}
        return values, options

    def contribute(self, values: Mapping[str, float], options: Mapping[str, object],
                   setup) -> None:  # pragma: no cover - abstract
        raise NotImplementedError


EFFECTS: dict[str, type[Effect]] = {}


def register_effect(cls: type[Effect]) -> type[Effect]:
    """Class decorator: add an effect to the registry under ``cls.name``."""
    if cls.target not in TARGETS or cls.default_scope not in SCOPES:
        raise ValueError(f"effect {cls.name!r}: bad target or scope")
    EFFECTS[cls.name] = cls
    return cls


@dataclass(frozen=True)
class EffectSpec:
    """A validated effect entry of a campaign: which effect, when drawn, with what."""

    name: str
    scope: str
    options: dict = field(default_factory=dict)
    distributions: dict[str, Distribution] = field(default_factory=dict)

    @property
    def effect(self) -> Effect:
        return EFFECTS[self.name]()


def parse_effect(entry: Mapping, where: str, source: str = "<memory>") -> EffectSpec:
    """Validate one ``[[truth.effects]]`` table.

    Expected keys: ``name``; optionally ``scope``, ``parameters`` (each a number, the mean,
    or a table ``{ mean = ..., std = ... }``) and the effect's own options.

    Raises
    ------
    CampaignError
        Naming ``source`` and the key ``where``.
    """
    def fail(key, msg):
        raise CampaignError(f"{source}: key '{where}{key}': {msg}")

    if not isinstance(entry, Mapping):
        fail("", f"expected a table; got {entry!r}")
    name = entry.get("name")
    if name not in EFFECTS:
        fail(".name", f"unknown effect {name!r}; expected one of {', '.join(sorted(EFFECTS))}")
    cls = EFFECTS[name]
    scope = entry.get("scope", cls.default_scope)
    if scope not in SCOPES:
        fail(".scope", f"expected one of {', '.join(SCOPES)}; got {scope!r}")
    known = {"name", "scope", "parameters", *cls.options}
    for key in entry:
        if key not in known:
            fail(f".{key}", f"effect {name!r} has no option {key!r}; expected one of "
                            f"{', '.join(sorted(known))}")
    options = {k: entry.get(k, default) for k, default in cls.options.items()}
    for k, v in options.items():
        if v is None:
            fail(f".{k}", f"effect {name!r} needs option {k!r}")
    params = {p.name: p for p in cls.params}
    dists = {p.name: Distribution(p.default) for p in cls.params}
    raw = entry.get("parameters", {})
    if not isinstance(raw, Mapping):
        fail(".parameters", f"expected a table; got {raw!r}")
    for key, value in raw.items():
        if key not in params:
            fail(f".parameters.{key}", f"effect {name!r} has no parameter {key!r}; expected "
                                       f"one of {', '.join(params) or '(none)'}")
        if isinstance(value, Mapping):
            extra = set(value) - {"mean", "std"}
            if extra:
                fail(f".parameters.{key}", f"expected keys mean and std; got {sorted(extra)}")
            mean = value.get("mean", params[key].default)
            std = value.get("std", 0.0)
        else:
            mean, std = value, 0.0
        for label, v in (("mean", mean), ("std", std)):
            if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
                fail(f".parameters.{key}.{label}", f"expected a finite number; got {v!r}")
        if std < 0:
            fail(f".parameters.{key}.std", f"expected a standard deviation >= 0 (the "
                                           f"variance part); got {std!r}")
        lo = params[key].minimum
        if lo is not None and mean < lo:
            fail(f".parameters.{key}.mean", f"expected a value >= {lo}; got {mean!r}")
        dists[key] = Distribution(float(mean), float(std))
    return EffectSpec(name, scope, options, dists)


def effect_from_inject(text: str) -> EffectSpec:
    """Parse ``NAME:param=value,...`` (the CLI's ``--inject``) into an effect at its
    mean values (options too: ``station=mid``)."""
    name, _, rest = text.partition(":")
    entry: dict = {"name": name.strip()}
    params: dict = {}
    for item in filter(None, (x.strip() for x in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq:
            raise CampaignError(f"--inject {text!r}: expected NAME:param=value,...; got "
                                f"{item!r}")
        key = key.strip()
        try:
            params[key] = float(value)
        except ValueError:
            cls = EFFECTS.get(entry["name"])
            if cls is not None and key in {p.name for p in cls.params}:
                raise CampaignError(
                    f"--inject {text!r}: parameter {key!r} of effect {entry['name']!r} "
                    f"must be a number; got {value.strip()!r}") from None
            entry[key] = value.strip()
    cls = EFFECTS.get(entry["name"])
    if cls is not None:
        opts = {k: params.pop(k) for k in list(params) if k in cls.options}
        entry.update(opts)
    entry["parameters"] = params
    return parse_effect(entry, "inject", "--inject")


def mean_values(spec: EffectSpec) -> dict[str, float]:
    """Every parameter of the effect at its mean (the hardware's bias, no variance)."""
    return {p.name: float(spec.distributions[p.name].mean) for p in spec.effect.params}


def draw(spec: EffectSpec, rng: np.random.Generator) -> dict[str, float]:
    """One draw of every parameter: ``mean + std * N(0, 1)``, clipped at the minimum.

    A normal number is drawn for every parameter even when its std is 0, so changing one
    parameter's variance does not shift the draws of the others."""
    out = {}
    for p in spec.effect.params:
        d = spec.distributions[p.name]
        v = d.mean + d.std * rng.standard_normal()
        if p.minimum is not None:
            v = max(v, p.minimum)
        out[p.name] = float(v)
    return out
