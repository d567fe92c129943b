"""The updaters of this room behind one small protocol, configured as objects, chosen by
name.

An updater is a frozen, keyword-only dataclass whose fields are its settings, each
declared once with its default, unit and constraint (:func:`truthbench.settings.setting`;
scikit-learn's convention: nothing is computed in the constructor). The settings every
iterated updater shares are declared once in
:class:`~truthbench.update.finite_difference.IterationSettings`; the campaign's
``[update]`` table is built from these declarations
(:func:`truthbench.settings.settings_model`), and the functions that run the methods
take their defaults from the classes. An updater declares

* ``name``: its registry key;
* ``needs``: what it reads from an :class:`UpdateProblem` (``"frf"``: measured FRFs and
  a predictor; ``"modes"``: identified modes and a model builder);
* :meth:`unsupported`: which parameters it cannot update, with the reason (by the
  parameters' kinds: ``"plant"``, ``"appended"``, ``"effect"``, see
  :mod:`truthbench.update.predictor`);

and implements ``update(problem) -> UpdateResult``. ``from_settings(mapping)`` builds
one from a campaign's ``[update]`` table (the settings it declares; the rest are
ignored).
The shared contract test (``tests/update/test_updater_contract.py``) runs over every
entry of :data:`UPDATERS`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Protocol, runtime_checkable

import numpy as np

from truthbench._validation import check_number, readonly
from truthbench.settings import Registry
from truthbench.update.finite_difference import FiniteDifferenceUpdater, UpdateResult
from truthbench.update.macroelements import BuildMK, BuildSystem
from truthbench.update.sensitivity import MeasuredModes, SensitivityUpdater

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
    start : mapping, optional
        Values of (some of) ``names`` that the FRF updater starts from when they fit
        better than ``theta0`` (e.g. a modal update's result; see
        :func:`~truthbench.update.finite_difference_update`); ``theta0`` stays the
        reference the result's changes are counted from.
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
    start: Mapping[str, float] | None = None

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
        if self.start is not None:
            object.__setattr__(self, "start", MappingProxyType(
                {k: float(v) for k, v in self.start.items()}))
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


_REGISTRY = Registry("updater", ("update", "unsupported"))

#: Read-only view of the registered updater classes, by name.
UPDATERS = _REGISTRY.view


def register_updater(cls: type, *, replace: bool = False) -> type:
    """Register an updater class under ``cls.name`` (``replace=True`` to overwrite); usable
    as a class decorator."""
    return _REGISTRY.register(cls, replace=replace)


def make_updater(name: str, settings: Mapping[str, object] | None = None) -> Updater:
    """The updater registered under ``name``, configured from ``settings`` (a campaign's
    ``[update]`` table as a mapping; None for the defaults).

    Raises
    ------
    ValueError
        Unknown name (the message lists the registered ones) or a bad setting.
    """
    return _REGISTRY.make(name, settings)


def get_updater(name: str) -> Updater:
    """The updater registered under ``name`` with its default settings."""
    return make_updater(name)


register_updater(FiniteDifferenceUpdater)
register_updater(SensitivityUpdater)
