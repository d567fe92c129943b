"""The updaters of this room behind one small protocol, chosen by name.

An updater has a ``name`` and ``update(problem) -> UpdateResult``. The
:class:`UpdateProblem` carries what every method may need (FRF data and a predictor for
the finite-difference method, a matrix builder and measured modes for sensitivity
localization); each updater takes what it needs and raises a ``ValueError`` naming what
is missing. The shared contract test (``tests/update/test_updater_contract.py``) runs
over every entry of :data:`UPDATERS`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from truthbench.update.finite_difference import UpdateResult, finite_difference_update
from truthbench.update.macroelements import BuildMK, BuildSystem
from truthbench.update.sensitivity import MeasuredModes, sensitivity_update


def _frozen_array(a, dtype=None):
    if a is None:
        return None
    out = np.array(a, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


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
        (finite-difference method).
    frf_data : array_like, complex, optional
        Measured FRFs ``G_D`` (any fixed shape, e.g. (n_freq, n_out, n_in)).
    frf_weights : array_like, optional
        Non-negative weight of every FRF entry, ``frf_data``'s shape.
    n_pairs : int, optional
        Number of SISO transfer functions ``m r`` in ``frf_data`` (checked ``> p``).
    build_mk : callable, optional
        ``build_mk(theta) -> (M, K)`` (sensitivity localization, no damping).
    measured : MeasuredModes or sequence of MeasuredModes, optional
        Identified modes with their model DOF indices (sensitivity localization); their
        optional ``damping_ratio`` is used with ``build_model``.
    options : mapping, optional
        Keyword options per updater name, e.g.
        ``{"sensitivity": {"c_phi": 0.2}, "finite_difference": {"max_iterations": 30}}``;
        each updater reads only its own entry.
    build_model : callable, optional
        ``build_model(theta)`` returning a :class:`~truthbench.model.StructuralModel`
        (e.g. ``plant.build``: physical damping ``C`` plus ``modal_damping_ratio``) or
        ``(M, C, K)``: the model with its damping. Sensitivity localization uses it in
        place of ``build_mk`` when given; it is needed to update damping parameters
        (hub dashpot, suspension dashpot, ``modal_damping_ratio``) from measured
        damping ratios.
    """

    names: tuple[str, ...]
    theta0: Mapping[str, float]
    predict_frf: Callable[[Mapping[str, float]], np.ndarray] | None = None
    frf_data: np.ndarray | None = None
    frf_weights: np.ndarray | None = None
    n_pairs: int | None = None
    build_mk: BuildMK | None = None
    measured: tuple[MeasuredModes, ...] | None = None
    options: Mapping[str, Mapping[str, object]] = field(default_factory=dict)
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
        object.__setattr__(self, "frf_data", _frozen_array(self.frf_data))
        object.__setattr__(self, "frf_weights", _frozen_array(self.frf_weights, float))
        if self.n_pairs is not None and (int(self.n_pairs) != self.n_pairs
                                         or self.n_pairs < 1):
            raise ValueError(f"UpdateProblem: 'n_pairs' must be a positive integer; got "
                             f"{self.n_pairs!r}")
        if self.measured is not None:
            meas = (self.measured,) if isinstance(self.measured, MeasuredModes) \
                else tuple(self.measured)
            bad = [type(m).__name__ for m in meas if not isinstance(m, MeasuredModes)]
            if bad:
                raise ValueError(f"UpdateProblem: 'measured' must hold MeasuredModes; got "
                                 f"{bad}")
            object.__setattr__(self, "measured", meas)
        opts = {}
        for key, value in dict(self.options).items():
            if not isinstance(value, Mapping):
                raise ValueError(f"UpdateProblem: 'options' maps an updater name to its "
                                 f"keyword options; got {type(value).__name__} for {key!r}")
            opts[str(key)] = MappingProxyType(dict(value))
        object.__setattr__(self, "options", MappingProxyType(opts))

    def options_for(self, name: str) -> dict[str, object]:
        """Keyword options of the updater ``name`` (a new dict; empty if none)."""
        return dict(self.options.get(name, {}))


def _require(updater: str, problem: UpdateProblem, fields: Sequence[str]) -> None:
    missing = [f for f in fields if getattr(problem, f) is None]
    if missing:
        raise ValueError(f"updater {updater!r} needs {missing} in the UpdateProblem; got None "
                         f"for {'it' if len(missing) == 1 else 'them'}")


@runtime_checkable
class Updater(Protocol):
    """What every registered updater provides."""

    name: str

    def update(self, problem: UpdateProblem) -> UpdateResult: ...


class FiniteDifferenceUpdater:
    """Finite-difference FRF updating (METHOD 5.1,
    :func:`~truthbench.update.finite_difference.finite_difference_update`).
    Needs ``predict_frf``, ``frf_data`` and ``n_pairs``; uses ``frf_weights``."""

    name: ClassVar[str] = "finite_difference"

    def update(self, problem: UpdateProblem) -> UpdateResult:
        _require(self.name, problem, ("predict_frf", "frf_data", "n_pairs"))
        return finite_difference_update(
            problem.predict_frf, problem.frf_data, problem.theta0, problem.names,
            n_pairs=int(problem.n_pairs), weights=problem.frf_weights,
            **problem.options_for(self.name))


class SensitivityUpdater:
    """Sensitivity localization from measured modes (METHOD 5.3,
    :func:`~truthbench.update.sensitivity.sensitivity_update`).
    Needs ``measured`` and ``build_model`` (with damping) or ``build_mk``; uses
    ``build_model`` when both are given."""

    name: ClassVar[str] = "sensitivity"

    def update(self, problem: UpdateProblem) -> UpdateResult:
        build = problem.build_model if problem.build_model is not None else problem.build_mk
        missing = (["build_mk"] if build is None else []) + (
            ["measured"] if problem.measured is None else [])
        if missing:
            raise ValueError(f"updater {self.name!r} needs {missing} in the UpdateProblem; "
                             f"got None for {'it' if len(missing) == 1 else 'them'} "
                             f"('build_model', the model with its damping, may stand in "
                             f"for 'build_mk')")
        return sensitivity_update(build, problem.theta0, problem.names,
                                  problem.measured, **problem.options_for(self.name))


_REGISTRY: dict[str, Updater] = {}

#: Read-only view of the registered updaters, by name.
UPDATERS = MappingProxyType(_REGISTRY)


def register_updater(updater: Updater, *, replace: bool = False) -> None:
    """Register ``updater`` under ``updater.name`` (``replace=True`` to overwrite)."""
    name = getattr(updater, "name", None)
    if not isinstance(name, str) or not name:
        raise ValueError(f"an updater needs a non-empty string 'name'; got {name!r}")
    if not callable(getattr(updater, "update", None)):
        raise ValueError(f"updater {name!r} has no callable 'update(problem)' method")
    if name in _REGISTRY and not replace:
        raise ValueError(f"an updater named {name!r} is already registered; pass "
                         f"replace=True to overwrite it")
    _REGISTRY[name] = updater


def get_updater(name: str) -> Updater:
    """The updater registered under ``name``.

    Raises
    ------
    ValueError
        Unknown name; the message lists the registered ones.
    """
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown updater {name!r}; expected one of {sorted(_REGISTRY)}") \
            from None


register_updater(FiniteDifferenceUpdater())
register_updater(SensitivityUpdater())
