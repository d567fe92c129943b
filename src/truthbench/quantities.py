"""What a channel measures: the one table of quantities, their power of j omega and units.

Every room that needs to know what "acceleration" means (the model's output rows, the FRF
data type, the UFF and LVM readers and writers, identification) reads this table; none
keeps its own.

=============  =====  ===========  ============  =========  =====  ===========
quantity       power  unit         unit (rot.)   UFF code   short  FRF name
=============  =====  ===========  ============  =========  =====  ===========
displacement   0      m            rad           8          dis    receptance
velocity       1      m/s          rad/s         11         vel    mobility
acceleration   2      m/s^2        rad/s^2       12         acc    accelerance
strain         0      m/m          m/m           3          str    -
force          -      N            N m           13         frc    -
=============  =====  ===========  ============  =========  =====  ===========

``power`` is k in ``H_quantity = (j omega)^k H_displacement``: strain is a
displacement-type output (a fixed combination of nodal displacements), force is an
excitation quantity (the FRF denominator) and has none. The UFF codes are the "specific
data type" of UFF dataset 58 records 8-10 (3 strain, 8 displacement, 11 velocity, 12
acceleration, 13 excitation force).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np


@dataclass(frozen=True)
class Quantity:
    """One measured quantity (see the module table)."""

    name: str
    power: int | None
    unit: str
    rotational_unit: str
    uff_code: int
    short: str
    frf_name: str | None = None

    def unit_for(self, direction: str | None) -> str:
        """SI unit of this quantity along a DOF direction (``rx``, ``ry``, ``rz`` are
        rotations; anything else, or None, a translation)."""
        return self.rotational_unit if direction in ("rx", "ry", "rz") else self.unit


QUANTITIES = MappingProxyType({q.name: q for q in (
    Quantity("displacement", 0, "m", "rad", 8, "dis", "receptance"),
    Quantity("velocity", 1, "m/s", "rad/s", 11, "vel", "mobility"),
    Quantity("acceleration", 2, "m/s^2", "rad/s^2", 12, "acc", "accelerance"),
    Quantity("strain", 0, "m/m", "m/m", 3, "str"),
    Quantity("force", None, "N", "N m", 13, "frc"),
)})
"""The quantities by name."""

RESPONSE_QUANTITIES = tuple(n for n, q in QUANTITIES.items() if q.power is not None)
"""Quantities an output channel may measure (all but force)."""

MOTION_QUANTITIES = ("displacement", "velocity", "acceleration")
"""The motion quantities, in order of their power of j omega (0, 1, 2)."""


def quantity(name: str) -> Quantity:
    """The :class:`Quantity` called ``name``.

    Raises
    ------
    ValueError
        Unknown name; the message lists the known ones.
    """
    try:
        return QUANTITIES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown quantity {name!r}; expected one of "
                         f"{', '.join(QUANTITIES)}") from None


def by_short(short: str) -> Quantity:
    """The quantity whose short label is ``short`` (``"acc"`` -> acceleration)."""
    for q in QUANTITIES.values():
        if q.short == short:
            return q
    raise ValueError(f"unknown quantity label {short!r}; expected one of "
                     f"{', '.join(q.short for q in QUANTITIES.values())}")


def by_frf_name(frf_name: str) -> Quantity:
    """The output quantity of an FRF type (``"accelerance"`` -> acceleration)."""
    for q in QUANTITIES.values():
        if q.frf_name == frf_name:
            return q
    raise ValueError(f"unknown FRF type {frf_name!r}; expected one of "
                     f"{', '.join(q.frf_name for q in QUANTITIES.values() if q.frf_name)}")


def by_uff_code(code: int) -> Quantity | None:
    """The quantity of a UFF specific data type code, or None if it is none of ours."""
    for q in QUANTITIES.values():
        if q.uff_code == int(code):
            return q
    return None


def powers(names: Sequence[str]) -> np.ndarray:
    """Power of j omega of each response quantity, shape (len(names),), int."""
    out = []
    for name in names:
        q = quantity(name)
        if q.power is None:
            raise ValueError(f"quantity {name!r} is an excitation, not a response; expected "
                             f"one of {', '.join(RESPONSE_QUANTITIES)}")
        out.append(q.power)
    return np.array(out, dtype=int)


def convert_outputs(freq_hz: np.ndarray, H: np.ndarray, quantities: Sequence[str],
                    target: str) -> np.ndarray:
    """FRFs of several output quantities brought to one: row i times
    ``(j omega)^(p_target - p_i)``.

    Parameters
    ----------
    freq_hz : ndarray, shape (n_freq,)
        Hz. A negative power at 0 Hz gives inf or NaN there; drop that line first.
    H : ndarray, complex, shape (n_freq, n_out, n_in)
    quantities : sequence of str, length n_out
    target : str
        A response quantity.

    Returns
    -------
    ndarray, complex, shape (n_freq, n_out, n_in)
        A new array.
    """
    H = np.asarray(H)
    p = quantity(target).power
    if p is None:
        raise ValueError(f"target quantity {target!r} is an excitation, not a response")
    k = p - powers(quantities)
    if len(k) != H.shape[1]:
        raise ValueError(f"expected one quantity per output ({H.shape[1]}); got {len(k)}")
    jw = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return H * (jw[:, None] ** k[None, :])[:, :, None]
