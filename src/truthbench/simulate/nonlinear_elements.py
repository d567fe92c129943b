"""The nonlinear elements of :mod:`truthbench.simulate.nonlinear`: the element laws
(:data:`LAWS`: :class:`CoulombFriction`, :class:`CubicStiffness`, :class:`DeadBand`,
:class:`AmplitudeDependentDamping`), each a frozen record of its checked parameters with
the code the simulation kernel knows it by, and :class:`NonlinearElement`, a law placed
in the state space by the rows that read its displacement and velocity and the columns
through which its force acts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from truthbench.errors import ModelError

from . import _nonlinear_kernel as _kern

__all__ = [
    "LAWS",
    "AmplitudeDependentDamping",
    "CoulombFriction",
    "CubicStiffness",
    "DeadBand",
    "NonlinearElement",
    "NonlinearLaw",
]


# ----------------------------------------------------------------------------------
# element laws
# ----------------------------------------------------------------------------------


@runtime_checkable
class NonlinearLaw(Protocol):
    """What an element law provides: a registry name, a kernel code and parameters.

    ``force(d, v)`` evaluates the law (vectorised; for friction the slipping force).
    """

    name: ClassVar[str]
    kind: ClassVar[int]

    def params(self) -> tuple[float, float]: ...

    def force(self, d, v) -> np.ndarray: ...


def _parameter(owner: str, name: str, value, *, minimum: float | None = 0.0) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{owner}.{name} must be a real number; got {value!r}") from exc
    if not math.isfinite(out):
        raise ValueError(f"{owner}.{name} must be finite; got {value!r}")
    if minimum is not None and out < minimum:
        raise ValueError(f"{owner}.{name} must be >= {minimum:g}; got {value!r}")
    return out


@dataclass(frozen=True)
class CoulombFriction:
    """Coulomb friction: ``f = -force_n sign(v)`` while slipping, stick within ``force_n``.

    Attributes
    ----------
    force_n : float
        Friction force ``F_c >= 0``, N (a moment in N m at a rotational DOF). Static and
        kinetic friction are equal.
    """

    force_n: float
    name: ClassVar[str] = "coulomb_friction"
    kind: ClassVar[int] = _kern.KIND_COULOMB

    def __post_init__(self):
        object.__setattr__(self, "force_n", _parameter("CoulombFriction", "force_n",
                                                       self.force_n))

    def params(self) -> tuple[float, float]:
        return (self.force_n, 0.0)

    def force(self, d, v) -> np.ndarray:
        """Slipping force ``-F_c sign(v)`` (0 at ``v = 0``; sticking is the simulator's)."""
        return -self.force_n * np.sign(np.asarray(v, dtype=float)) + 0.0 * np.asarray(d)


@dataclass(frozen=True)
class CubicStiffness:
    """Cubic spring: ``f = -k3_n_m3 d^3`` (``k3 > 0`` hardening, ``< 0`` softening).

    Attributes
    ----------
    k3_n_m3 : float
        Cubic stiffness, N/m^3 (N m/rad^3 at a rotational DOF).
    """

    k3_n_m3: float
    name: ClassVar[str] = "cubic_stiffness"
    kind: ClassVar[int] = _kern.KIND_CUBIC

    def __post_init__(self):
        object.__setattr__(self, "k3_n_m3", _parameter("CubicStiffness", "k3_n_m3",
                                                       self.k3_n_m3, minimum=None))

    def params(self) -> tuple[float, float]:
        return (self.k3_n_m3, 0.0)

    def force(self, d, v) -> np.ndarray:
        d = np.asarray(d, dtype=float)
        return -self.k3_n_m3 * d**3 + 0.0 * np.asarray(v)


@dataclass(frozen=True)
class DeadBand:
    """Spring with free play: ``f = -k (d - sign(d) gap)`` for ``|d| > gap``, else 0.

    Attributes
    ----------
    gap_m : float
        Half-width of the free play, m (rad), ``>= 0``.
    stiffness_n_m : float
        Contact stiffness, N/m (N m/rad), ``>= 0``.
    """

    gap_m: float
    stiffness_n_m: float
    name: ClassVar[str] = "dead_band"
    kind: ClassVar[int] = _kern.KIND_DEADBAND

    def __post_init__(self):
        object.__setattr__(self, "gap_m", _parameter("DeadBand", "gap_m", self.gap_m))
        object.__setattr__(self, "stiffness_n_m",
                           _parameter("DeadBand", "stiffness_n_m", self.stiffness_n_m))

    def params(self) -> tuple[float, float]:
        return (self.gap_m, self.stiffness_n_m)

    def force(self, d, v) -> np.ndarray:
        d = np.asarray(d, dtype=float)
        excess = np.sign(d) * np.maximum(np.abs(d) - self.gap_m, 0.0)
        return -self.stiffness_n_m * excess + 0.0 * np.asarray(v)


@dataclass(frozen=True)
class AmplitudeDependentDamping:
    """Quadratic (velocity-squared) damping: ``f = -c2_n_s2_m2 |v| v``.

    The equivalent viscous damping grows with the amplitude (``8 c2 omega X / (3 pi)``
    for harmonic motion of amplitude ``X``): a weak nonlinearity of Table 10.1.

    Attributes
    ----------
    c2_n_s2_m2 : float
        Coefficient, N s^2/m^2 (N m s^2/rad^2), ``>= 0``.
    """

    c2_n_s2_m2: float
    name: ClassVar[str] = "amplitude_dependent_damping"
    kind: ClassVar[int] = _kern.KIND_QUADRATIC_DAMPING

    def __post_init__(self):
        object.__setattr__(self, "c2_n_s2_m2",
                           _parameter("AmplitudeDependentDamping", "c2_n_s2_m2",
                                      self.c2_n_s2_m2))

    def params(self) -> tuple[float, float]:
        return (self.c2_n_s2_m2, 0.0)

    def force(self, d, v) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        return -self.c2_n_s2_m2 * np.abs(v) * v + 0.0 * np.asarray(d)


#: Element laws by registry name.
LAWS: dict[str, type] = {
    cls.name: cls
    for cls in (CoulombFriction, CubicStiffness, DeadBand, AmplitudeDependentDamping)
}


# ----------------------------------------------------------------------------------
# elements: a law placed in the state space
# ----------------------------------------------------------------------------------


def _vector(owner: str, name: str, value) -> np.ndarray:
    arr = np.asarray(value)
    if np.iscomplexobj(arr):
        raise ModelError(f"{owner}.{name} must be real; got a complex array")
    try:
        arr = np.array(arr, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{owner}.{name} must be a real vector; got {value!r}") from exc
    if arr.ndim != 1:
        raise ModelError(f"{owner}.{name} must be a 1-D vector; got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{owner}.{name} contains non-finite values (nan or inf)")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class NonlinearElement:
    """A nonlinear law acting between the state and a force input of a linear system.

    Attributes
    ----------
    law : NonlinearLaw
        One of :data:`LAWS` (e.g. ``CoulombFriction(5.0)``).
    displacement_row : ndarray, shape (n,)
        ``c_d``: the element displacement ``d = c_d x``, m (rad).
    velocity_row : ndarray, shape (n,)
        ``c_v``: the element velocity ``v = c_v x``, m/s (rad/s); for a friction element
        ``c_v @ force_column`` must be positive (the force acts on the velocity it
        opposes; it is ``1 / m_eff``).
    force_column : ndarray, shape (n,)
        ``b``: the column of ``B_nl`` through which the element force enters ``x'``.
    output_column : ndarray, shape (n_out,), optional
        The column of ``D_nl`` (direct effect of the force on the outputs, e.g. on an
        acceleration); zeros by default.

    Notes
    -----
    For the modal form of :func:`truthbench.model.modal_system` (state
    ``[eta; eta']``, mass-normalised shapes) use :meth:`modal`.
    """

    law: NonlinearLaw
    displacement_row: np.ndarray
    velocity_row: np.ndarray
    force_column: np.ndarray
    output_column: np.ndarray | None = None

    def __post_init__(self):
        if not isinstance(self.law, tuple(LAWS.values())):
            raise TypeError(
                "NonlinearElement.law must be one of "
                f"{', '.join(cls.__name__ for cls in LAWS.values())}; "
                f"got {type(self.law).__name__}"
            )
        for name in ("displacement_row", "velocity_row", "force_column"):
            object.__setattr__(self, name, _vector("NonlinearElement", name,
                                                   getattr(self, name)))
        if self.output_column is not None:
            object.__setattr__(self, "output_column",
                               _vector("NonlinearElement", "output_column",
                                       self.output_column))

    @classmethod
    def modal(cls, law, shape_row, output_column=None) -> NonlinearElement:
        """Element at a physical DOF of the modal form ``x = [eta; eta']``.

        Parameters
        ----------
        law : NonlinearLaw
        shape_row : array_like, shape (n_modes,)
            Mass-normalised mode shapes at the DOF, ``Phi[dof, :]`` (for a joint between
            two DOFs, ``Phi[a, :] - Phi[b, :]``: equal and opposite forces).
        output_column : array_like, shape (n_out,), optional
            Direct effect of the force on the outputs (acceleration outputs ``i``:
            ``Phi_out[i, :] @ shape_row``).

        Returns
        -------
        NonlinearElement
            ``c_d = [phi, 0]``, ``c_v = [0, phi]``, ``b = [0; phi]``.
        """
        phi = _vector("NonlinearElement.modal", "shape_row", shape_row)
        zero = np.zeros_like(phi)
        return cls(
            law,
            np.concatenate([phi, zero]),
            np.concatenate([zero, phi]),
            np.concatenate([zero, phi]),
            output_column,
        )
