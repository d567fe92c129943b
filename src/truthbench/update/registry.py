"""The updaters of this room behind one small protocol, configured as objects, chosen by
name.

An updater is a frozen object whose constructor holds its settings (scikit-learn's
convention: nothing is computed there). It declares

* ``name``: its registry key;
* ``needs``: what it reads from an :class:`UpdateProblem` (``"frf"``: measured FRFs and
  a predictor; ``"modes"``: identified modes and a model builder);
* :meth:`unsupported`: which parameters it cannot update, with the reason (by the
  parameters' kinds: ``"plant"``, ``"appended"``, ``"effect"``, see
  :mod:`truthbench.update.predictor`);

and implements ``update(problem) -> UpdateResult``. ``from_settings(mapping)`` builds
one from a campaign's ``[update]`` table (the keys it knows; the rest are ignored).
The shared contract test (``tests/update/test_updater_contract.py``) runs over every
entry of :data:`UPDATERS`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from types import MappingProxyType
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from truthbench._validation import check_choice, check_number, readonly
from truthbench.update.finite_difference import UpdateResult, finite_difference_update
from truthbench.update.macroelements import BuildMK, BuildSystem
from truthbench.update.sensitivity import MeasuredModes, sensitivity_update

NEEDS = {"frf": ("predict_frf", "frf_data", "n_pairs"), "modes": ("measured",)}
"""What each kind of input means in :class:`UpdateProblem` fields (``"modes"`` also
needs ``build_model`` or ``build_mk``)."""


@dataclass(frozen=True)
class UpdateProblem:
    """Everything an updater may need; fields a method does not use may be None.

    Parameters
    ----------
    names : sequence of str
        The p parameters to update.
    theta0 : mapping
        Starting values of all model parameters (stored as a read-only copy).
    predict_frf : callable, optional
        ``predict_frf(theta) -> G_M``, complex array of the data's shape
        (e.g. :meth:`~truthbench.update.FRFPredictor.predict_vector`).
    frf_data : array_like, complex, optional
        Measured FRFs ``G_D`` (any fixed shape, e.g. (n_freq, n_out, n_in)).
    frf_weights : array_like, optional
        Non-negative weight of every FRF entry, ``frf_data``'s shape.
    n_pairs : int, optional
        Number of SISO transfer functions ``m r`` in ``frf_data`` (checked ``> p``).
    additive : mapping of str -> float, optional
        Parameters that start at 0 and are updated additively, with their scale (the
        parameter's unit), e.g. a delay (:meth:`FRFPredictor.additive_scales`).
    build_mk : callable, optional
        ``build_mk(theta) -> (M, K)`` (sensitivity localization, no damping).
    measured : MeasuredModes or sequence of MeasuredModes, optional
        Identified modes with their model DOF indices (sensitivity localization); their
        optional ``damping_ratio`` is used with ``build_model``.
    build_model : callable, optional
        ``build_model(theta)`` returning a :class:`~truthbench.model.StructuralModel`
        (e.g. ``plant.build``) or ``(M, C, K)``: the model with its damping.
        Sensitivity localization uses it in place of ``build_mk`` when given; it is
        needed to update damping parameters from measured damping ratios.
    """

    names: tuple[str, ...]
    theta0: Mapping[str, float]
    predict_frf: Callable[[Mapping[str, float]], np.ndarray] | None = None
    frf_data: np.ndarray | None = None
    frf_weights: np.ndarray | None = None
    n_pairs: int | None = None
    additive: Mapping[str, float] | None = None
    build_mk: BuildMK | None = None
    measured: tuple[MeasuredModes, ...] | None = None
    build_model: BuildSystem | None = None

    def __post_init__(self):
        names = (self.names,) if isinstance(self.names, str) else tuple(self.names)
        if not names:
            raise ValueError("UpdateProblem: 'names' is empty; expected the parameters to "
                             "update")
        object.__setattr__(self, "names", names)
        if not isinstance(self.theta0, Mapping):
            raise ValueError(f"UpdateProblem: 'theta0' must be a mapping of parameter values;"
                             f" got {type(self.theta0).__name__}")
        object.__setattr__(self, "theta0", MappingProxyType(dict(self.theta0)))
        if self.frf_data is not None:
            object.__setattr__(self, "frf_data", readonly(self.frf_data))
        if self.frf_weights is not None:
            object.__setattr__(self, "frf_weights", readonly(self.frf_weights, float))
        if self.n_pairs is not None:
            check_number("n_pairs", self.n_pairs, low=1, integer=True, where="UpdateProblem")
        if self.additive is not None:
            object.__setattr__(self, "additive", MappingProxyType(dict(self.additive)))
        if self.measured is not None:
            meas = (self.measured,) if isinstance(self.measured, MeasuredModes) \
                else tuple(self.measured)
            bad = [type(m).__name__ for m in meas if not isinstance(m, MeasuredModes)]
            if bad:
                raise ValueError(f"UpdateProblem: 'measured' must hold MeasuredModes; got "
                                 f"{bad}")
            object.__setattr__(self, "measured", meas)

    def missing(self, needs: Sequence[str]) -> list[str]:
        """Fields an updater with these ``needs`` lacks."""
        out = [f for need in needs for f in NEEDS[need] if getattr(self, f) is None]
        if "modes" in needs and self.build_model is None and self.build_mk is None:
            out.insert(0, "build_mk")
        return out


@runtime_checkable
class Updater(Protocol):
    """What every registered updater provides."""

    name: str
    needs: frozenset[str]

    def unsupported(self, kinds: Mapping[str, str]) -> dict[str, str]: ...

    def update(self, problem: UpdateProblem) -> UpdateResult: ...


class _Base:
    """Settings handling shared by the updaters."""

    name: ClassVar[str] = ""
    needs: ClassVar[frozenset[str]] = frozenset()
    settings_keys: ClassVar[dict[str, str]] = {}
    """``[update]`` key -> constructor argument."""

    @classmethod
    def from_settings(cls, settings: Mapping[str, object] | None = None):
        """An updater with the settings of a campaign's ``[update]`` table (a mapping;
        keys it does not know are ignored)."""
        settings = dict(settings or {})
        return cls(**{arg: settings[key] for key, arg in cls.settings_keys.items()
                      if settings.get(key) is not None})

    def _require(self, problem: UpdateProblem) -> None:
        missing = problem.missing(sorted(self.needs))
        if missing:
            raise ValueError(f"updater {self.name!r} needs {missing} in the UpdateProblem; "
                             f"got None for {'it' if len(missing) == 1 else 'them'}")

    def settings(self) -> dict[str, object]:
        """The constructor settings, by name."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class FiniteDifferenceUpdater(_Base):
    """Finite-difference FRF updating (Eq. 10.12-10.21,
    :func:`~truthbench.update.finite_difference.finite_difference_update`); the
    settings are that function's. Needs ``predict_frf``, ``frf_data`` and ``n_pairs``;
    uses ``frf_weights`` and ``additive``. Updates any parameter the predictor can vary."""

    name: ClassVar[str] = "finite_difference"
    needs: ClassVar[frozenset[str]] = frozenset({"frf"})
    settings_keys: ClassVar[dict[str, str]] = {
        "max_iterations": "max_iterations", "tolerance": "tolerance",
        "relative_step": "relative_step", "scheme": "scheme"}

    max_iterations: int = 20
    tolerance: float = 1e-6
    relative_step: float = 1e-4
    scheme: str = "central"
    rcond: float = 1e-4
    max_step: float = 0.5

    def __post_init__(self):
        where = "FiniteDifferenceUpdater"
        check_number("max_iterations", self.max_iterations, low=1, integer=True, where=where)
        check_number("tolerance", self.tolerance, low=0, low_open=True, where=where)
        check_number("relative_step", self.relative_step, low=0, high=0.1, low_open=True,
                     high_open=True, where=where)
        check_choice("scheme", self.scheme, ("central", "forward"), where=where)

    def unsupported(self, kinds: Mapping[str, str]) -> dict[str, str]:
        return {}

    def update(self, problem: UpdateProblem) -> UpdateResult:
        self._require(problem)
        return finite_difference_update(
            problem.predict_frf, problem.frf_data, problem.theta0, problem.names,
            n_pairs=int(problem.n_pairs), weights=problem.frf_weights,
            additive=dict(problem.additive) if problem.additive else None,
            **self.settings())


@dataclass(frozen=True)
class SensitivityUpdater(_Base):
    """Sensitivity localization from measured modes (Eq. 10.31-10.44,
    :func:`~truthbench.update.sensitivity.sensitivity_update`); the settings are that
    function's. Needs ``measured`` and ``build_model`` (with damping) or ``build_mk``;
    uses ``build_model`` when both are given. Updates plant parameters only."""

    name: ClassVar[str] = "sensitivity"
    needs: ClassVar[frozenset[str]] = frozenset({"modes"})
    settings_keys: ClassVar[dict[str, str]] = {
        "max_iterations": "max_iterations", "mac_min": "mac_min", "c_zeta": "c_zeta"}

    max_iterations: int = 30
    mac_min: float = 0.6
    c_zeta: float = 1.0
    c_phi: float = 0.1
    c_lambda: float = 1.0
    tolerance: float = 1e-8

    def __post_init__(self):
        where = "SensitivityUpdater"
        check_number("max_iterations", self.max_iterations, low=1, integer=True, where=where)
        check_number("mac_min", self.mac_min, low=0, high=1, where=where)
        for key in ("c_zeta", "c_phi", "c_lambda"):
            check_number(key, getattr(self, key), low=0, where=where)

    def unsupported(self, kinds: Mapping[str, str]) -> dict[str, str]:
        why = {"appended": "it belongs to the measurement chain, which identified modes do "
                           "not carry (a delay does not move the poles, a gain does not "
                           "change scaled shapes)",
               "effect": "modal data are matched against the plant's own matrices; effect "
                         "parameters are updated from FRFs"}
        return {name: why[kind] for name, kind in kinds.items() if kind in why}

    def update(self, problem: UpdateProblem) -> UpdateResult:
        missing = problem.missing(["modes"])
        if missing:
            raise ValueError(f"updater {self.name!r} needs {missing} in the UpdateProblem; "
                             f"got None for {'it' if len(missing) == 1 else 'them'} "
                             f"('build_model', the model with its damping, may stand in "
                             f"for 'build_mk')")
        build = problem.build_model if problem.build_model is not None else problem.build_mk
        return sensitivity_update(build, problem.theta0, problem.names, problem.measured,
                                  **self.settings())


_REGISTRY: dict[str, type] = {}

#: Read-only view of the registered updater classes, by name.
UPDATERS = MappingProxyType(_REGISTRY)


def register_updater(cls: type, *, replace: bool = False) -> type:
    """Register an updater class under ``cls.name`` (``replace=True`` to overwrite); usable
    as a class decorator."""
    name = getattr(cls, "name", None)
    if not isinstance(name, str) or not name:
        raise ValueError(f"an updater needs a non-empty string 'name'; got {name!r}")
    for attr in ("update", "unsupported", "from_settings"):
        if not callable(getattr(cls, attr, None)):
            raise ValueError(f"updater {name!r} has no callable {attr!r}")
    if name in _REGISTRY and not replace:
        raise ValueError(f"an updater named {name!r} is already registered; pass "
                         f"replace=True to overwrite it")
    _REGISTRY[name] = cls
    return cls


def make_updater(name: str, settings: Mapping[str, object] | None = None) -> Updater:
    """The updater registered under ``name``, configured from ``settings`` (a campaign's
    ``[update]`` table as a mapping; None for the defaults).

    Raises
    ------
    ValueError
        Unknown name (the message lists the registered ones) or a bad setting.
    """
    try:
        cls = _REGISTRY[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown updater {name!r}; expected one of {sorted(_REGISTRY)}") \
            from None
    return cls.from_settings(settings)


def get_updater(name: str) -> Updater:
    """The updater registered under ``name`` with its default settings."""
    return make_updater(name)


register_updater(FiniteDifferenceUpdater)
register_updater(SensitivityUpdater)
