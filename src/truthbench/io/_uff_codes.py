"""The codes of the Universal File Format (UFF) shared by its private readers and
writers (:mod:`truthbench.io._uff58`, :mod:`truthbench.io._uff58_write`,
:mod:`truthbench.io.uff_frf`, :mod:`truthbench.io.uff_write`): station to node number
(:data:`NODE_OFFSET`), the one table of direction codes (:data:`DIRECTION_CODES`,
:func:`direction_label`), the specific data types, axis labels and SI units of time
histories and FRF types (:data:`TIME_QUANTITIES`, :data:`FRF_TYPES`), the abscissae, the
function types of dataset 58 and the dataset delimiter; the conventions are described
in :mod:`truthbench.io._uff58`.
"""

from __future__ import annotations

from types import MappingProxyType

from truthbench.quantities import MOTION_QUANTITIES, quantity

__all__ = [
    "DIRECTION_CODES",
    "FRF_TYPES",
    "NODE_OFFSET",
    "TIME_QUANTITIES",
    "direction_label",
    "direction_name",
]

NODE_OFFSET = 1
"""UFF node number of truthbench station ``s`` is ``s + NODE_OFFSET``."""

DIRECTION_CODES = MappingProxyType({"x": 1, "y": 2, "z": 3, "rx": 4, "ry": 5, "rz": 6})
"""Channel direction -> UFF direction code (record 6, fields 7 and 10): translation along
and rotation about X, Y, Z. The negative code is the same axis in the minus sense
(``Channel.sign = -1``); code 0 is a scalar (no direction). The one direction table of
the UFF layers."""

_DIRECTION_NAMES = {v: k for k, v in DIRECTION_CODES.items()}


def direction_name(code: int) -> str | None:
    """The direction (x, y, z, rx, ry, rz) of a UFF direction code, None for 0 or an
    unknown code."""
    return _DIRECTION_NAMES.get(abs(int(code)))


def direction_label(code: int) -> str:
    """A UFF direction code as text: ``"+Z"``, ``"-RX"``, ``"scalar"`` (0); an unknown
    code as its number."""
    code = int(code)
    name = direction_name(code)
    if name is None:
        return "scalar" if code == 0 else str(code)
    return ("-" if code < 0 else "+") + name.upper()


def _axis(name: str) -> tuple[int, str, str]:
    """(UFF specific data type, axis label, SI unit label) of a quantity, from the one
    table :mod:`truthbench.quantities`."""
    q = quantity(name)
    return (q.uff_code, name.capitalize(), q.unit)


_FORCE = _axis("force")
_QUANTITIES = {name: _axis(name) for name in ("acceleration", "velocity", "displacement",
                                              "force")}
TIME_QUANTITIES = MappingProxyType(_QUANTITIES)
"""Time-history quantity -> (UFF specific data type, axis label, SI unit label)."""

FRF_TYPES = MappingProxyType(
    {quantity(q).frf_name: (_axis(q), _FORCE) for q in reversed(MOTION_QUANTITIES)}
)
"""FRF type -> ((numerator code, label, unit), (denominator code, label, unit))."""

_FREQUENCY_AXIS = (18, "Frequency", "Hz")
_TIME_AXIS = (17, "Time", "s")
_COHERENCE_AXIS = (0, "Coherence", "NONE")
# Function types (record 6, field 1) of dataset 58.
_FUNC_TIME = 1
_FUNC_FRF = 4
_FUNC_COHERENCE = 6
_DELIMITER = b"    -1"
