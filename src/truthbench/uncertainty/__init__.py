"""uncertainty room: the uncertainty model over repeated tests (Section 10.3,
Eq. 10.46-10.50; :ref:`method-uncertainty-model`).

Owns: the parameter uncertainty model (mean error, covariance, 3-sigma bound, mean model)
with the chapter's confidence-factor weighting (:mod:`.model`); its frequency-domain
counterpart, the mean FRF with a real/imaginary covariance ellipse (:mod:`.frequency`);
the coverage of k-sigma bounds against normal theory, with binomial confidence
intervals and calibration curves (:mod:`.coverage`); and the figures, the pole plot of
Figure 10.6 and a calibration plot (:mod:`.plots`, matplotlib imported on use).

Pure functions on arrays returning frozen results; nothing here does I/O or prints.
"""

from truthbench.uncertainty.coverage import (
    CalibrationCurve,
    Coverage,
    bound_coverage,
    calibration_curve,
    clopper_pearson_interval,
    coverage_fraction,
    expected_coverage,
    wilson_interval,
)
from truthbench.uncertainty.frequency import (
    FrfUncertainty,
    expected_frf_coverage,
    frf_uncertainty,
)
from truthbench.uncertainty.model import UncertaintyModel, uncertainty_model

__all__ = [
    "CalibrationCurve",
    "Coverage",
    "FrfUncertainty",
    "UncertaintyModel",
    "bound_coverage",
    "calibration_curve",
    "clopper_pearson_interval",
    "coverage_fraction",
    "expected_coverage",
    "expected_frf_coverage",
    "frf_uncertainty",
    "uncertainty_model",
    "wilson_interval",
]
