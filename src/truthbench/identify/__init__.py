"""identify room: modal parameter estimation, shape correlation and mode pairing.

Owns: the :class:`ModalParameters` result; peak picking (:mod:`.peak`); the
polyreference least-squares complex frequency-domain estimator with its stabilization
diagram and automatic pole selection (:mod:`.plscf`); least-squares frequency-domain
residues (:mod:`.lsfd`); mass normalisation through a driving point (:mod:`.scaling`);
MAC, COMAC, shape error and mode pairing (:mod:`.correlation`); Guyan reduction and
shape expansion (:mod:`.reduction`); the identifier registry (:mod:`.registry`); and
the identify-a-file workflow (:mod:`.workflow`: :func:`identify_frfs` on an
:class:`~truthbench.measure.FRFData`, :func:`identify_file` on any file
:func:`truthbench.io.load_frf` reads, the exponential-window correction).

Everything is a pure function on arrays returning frozen result objects. Conventions:
FRF arrays are complex ``(n_freq, n_out, n_in)`` with ``freq_hz`` ``(n_freq,)``; shapes
are ``(n_out, n_modes)``; residues ``(n_modes, n_out, n_in)``; poles in rad/s with
positive imaginary part.
"""

from truthbench.identify.correlation import (
    ModePairing,
    auto_mac,
    comac,
    mac,
    modal_scale_factor,
    pair_modes,
    shape_error,
)
from truthbench.identify.lsfd import LSFDResult, lsfd, refine_poles
from truthbench.identify.modal import ModalParameters, modal_from_poles, poles_from_modal
from truthbench.identify.peak import PeakIdentifier, PeakPickingResult, peak_picking
from truthbench.identify.plscf import (
    PLSCFIdentifier,
    PLSCFResult,
    PoleSelection,
    StabilityCriteria,
    StabilizationDiagram,
    identify_plscf,
    plscf_stabilization,
    select_poles,
)
from truthbench.identify.reduction import (
    GuyanReduction,
    ShapeExpansion,
    expand_shapes,
    guyan_reduction,
)
from truthbench.identify.registry import (
    IDENTIFIERS,
    Identifier,
    get_identifier,
    make_identifier,
    register_identifier,
)
from truthbench.identify.scaling import mass_normalize_shapes
from truthbench.identify.workflow import (
    EULER_BERNOULLI_FREE_FREE_RATIOS,
    DatasetIdentification,
    IdentifyReport,
    correct_exponential_window,
    identify_file,
    identify_frfs,
)

__all__ = [
    "EULER_BERNOULLI_FREE_FREE_RATIOS",
    "IDENTIFIERS",
    "DatasetIdentification",
    "GuyanReduction",
    "IdentifyReport",
    "Identifier",
    "LSFDResult",
    "ModalParameters",
    "ModePairing",
    "PLSCFIdentifier",
    "PLSCFResult",
    "PeakIdentifier",
    "PeakPickingResult",
    "PoleSelection",
    "ShapeExpansion",
    "StabilityCriteria",
    "StabilizationDiagram",
    "auto_mac",
    "comac",
    "correct_exponential_window",
    "expand_shapes",
    "get_identifier",
    "guyan_reduction",
    "identify_file",
    "identify_frfs",
    "identify_plscf",
    "lsfd",
    "mac",
    "make_identifier",
    "mass_normalize_shapes",
    "modal_from_poles",
    "modal_scale_factor",
    "pair_modes",
    "peak_picking",
    "plscf_stabilization",
    "poles_from_modal",
    "refine_poles",
    "register_identifier",
    "select_poles",
    "shape_error",
]
