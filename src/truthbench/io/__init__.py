"""The io room: files <-> :class:`~truthbench.measure.FRFData` and time records.

- :mod:`truthbench.io.registry`: :func:`load_frf`, the one entry that reads a data file
  into a tuple of FRFData with the reader registered for its extension, and the
  :func:`register_reader` hook; this package registers its own readers (``.h5`` /
  ``.hdf5``, ``.uff`` / ``.unv``, ``.lvm``) when it is imported.
- :mod:`truthbench.io.hdf5`: truthbench's HDF5 results and single-test files (the
  layout, writing, reading back as plain data) and :func:`read_frf`, their FRFData
  reader.
- :mod:`truthbench.io.measurements`: :func:`load_measurements`, several data files as
  acquisition systems export them: coherence-only UFF files paired with their FRF sets,
  excitation levels (``input_rms_n``) by data-set name.
- :mod:`truthbench.io.uff_frf`: reading UFF files: :func:`read_uff` (the ``.uff`` /
  ``.unv`` reader: FRF and coherence sets, units from dataset 164, points from 2411)
  and :func:`read_uff_files` (several files, coherence files paired by node, direction
  and load case), with the direction codes :data:`DIRECTION_CODES`
  (:func:`direction_label`).
- :mod:`truthbench.io.uff_write`: writing UFF files: :func:`write_uff` (151, 164, 2411,
  58), with the point numbering rule :func:`number_points`. Underneath both, the private
  dataset-58 layer through pyuff (:mod:`truthbench.io._uff58`, its writers in
  :mod:`truthbench.io._uff58_write` and the UFF codes in :mod:`truthbench.io._uff_codes`).
- :mod:`truthbench.io.lvm`: LabVIEW Measurement reader :func:`read_lvm` ->
  :class:`TimeRecord`, :func:`to_si`, and the shipped LADISK beam impact test
  :func:`ladisk_beam_impact`.
- :mod:`truthbench.io.time_records`: which channel of a time record is the input and
  what each measures, then H1 through :func:`truthbench.measure.frfs_from_time`;
  :func:`read_lvm_frf` (the ``.lvm`` reader).
- :mod:`truthbench.io.units`: unit labels and the UFF unit system (dataset 164).

The room imports :mod:`truthbench.measure` only inside its functions, so importing it
(and ``import truthbench``) stays light.
"""

from truthbench.io.hdf5 import read_frf
from truthbench.io.lvm import (
    G_STANDARD_M_S2,
    LADISK_BEAM_IMPACT_SHA256,
    ImpactRecord,
    TimeRecord,
    ladisk_beam_impact,
    read_lvm,
    to_si,
)
from truthbench.io.measurements import load_measurements
from truthbench.io.registry import load_frf, register_reader, registered_extensions
from truthbench.io.time_records import frf_from_record, read_lvm_frf
from truthbench.io.uff_frf import (
    DIRECTION_CODES,
    direction_label,
    read_uff,
    read_uff_files,
)
from truthbench.io.uff_write import PointNumbers, number_points, write_uff
from truthbench.io.units import SI, UnitSystem, parse_unit

register_reader(".h5", read_frf)
register_reader(".hdf5", read_frf)
register_reader(".lvm", read_lvm_frf)
register_reader(".uff", read_uff)
register_reader(".unv", read_uff)

__all__ = [
    "DIRECTION_CODES",
    "G_STANDARD_M_S2",
    "LADISK_BEAM_IMPACT_SHA256",
    "SI",
    "ImpactRecord",
    "PointNumbers",
    "TimeRecord",
    "UnitSystem",
    "direction_label",
    "frf_from_record",
    "ladisk_beam_impact",
    "load_frf",
    "load_measurements",
    "number_points",
    "parse_unit",
    "read_frf",
    "read_lvm",
    "read_lvm_frf",
    "read_uff",
    "read_uff_files",
    "register_reader",
    "registered_extensions",
    "to_si",
    "write_uff",
]
