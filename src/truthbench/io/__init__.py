"""The io room: reading and writing measured and exchanged test data.

- :mod:`truthbench.io.lvm`: LabVIEW Measurement (.lvm, Writer_Version 2) reader
  :func:`read_lvm` -> :class:`TimeRecord`, :func:`to_si`, and the shipped LADISK
  beam impact test :func:`ladisk_beam_impact` -> :class:`ImpactRecord`.
- :mod:`truthbench.io.uff`: UFF dataset 58 :func:`write_uff58_frf`,
  :func:`write_uff58_time`, :func:`read_uff58` -> :class:`UFFData` (through pyuff).
- :mod:`truthbench.io.registry`: :func:`load_data` by extension and the
  :func:`register_reader` hook (the campaign room registers ``.h5`` / ``.hdf5``).
"""

from truthbench.io.lvm import (
    G_STANDARD_M_S2,
    LADISK_BEAM_IMPACT_SHA256,
    ImpactRecord,
    TimeRecord,
    ladisk_beam_impact,
    read_lvm,
    to_si,
)
from truthbench.io.registry import load_data, register_reader, registered_extensions
from truthbench.io.uff import (
    DIRECTIONS,
    FRF_TYPES,
    NODE_OFFSET,
    TIME_QUANTITIES,
    UFFData,
    read_uff58,
    write_uff58_frf,
    write_uff58_time,
)

register_reader(".lvm", read_lvm)
register_reader(".uff", read_uff58)
register_reader(".unv", read_uff58)

__all__ = [
    "DIRECTIONS",
    "FRF_TYPES",
    "G_STANDARD_M_S2",
    "LADISK_BEAM_IMPACT_SHA256",
    "NODE_OFFSET",
    "TIME_QUANTITIES",
    "ImpactRecord",
    "TimeRecord",
    "UFFData",
    "ladisk_beam_impact",
    "load_data",
    "read_lvm",
    "read_uff58",
    "register_reader",
    "registered_extensions",
    "to_si",
    "write_uff58_frf",
    "write_uff58_time",
]
