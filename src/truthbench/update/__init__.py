"""Model updating: the FRF predictor, the finite-difference FRF method, sensitivity
localization, the one identifiability check, and the registry of updaters configured as
objects."""

from truthbench.update.finite_difference import (
    FiniteDifferenceUpdater,
    IterationSettings,
    UpdateResult,
    finite_difference_update,
    sensitivity_matrix,
)
from truthbench.update.identifiability import check_identifiable, check_overdetermined
from truthbench.update.macroelements import (
    Macroelement,
    SystemMatrices,
    macroelement_matrices,
    system_matrices,
)
from truthbench.update.modal_sensitivity import damping_sensitivities, eigen_sensitivities
from truthbench.update.predictor import (
    APPENDED_PARAMETERS,
    EffectTerm,
    FRFPredictor,
    PredictedTest,
)
from truthbench.update.registry import (
    UPDATERS,
    UpdateProblem,
    Updater,
    get_updater,
    make_updater,
    register_updater,
)
from truthbench.update.sensitivity import (
    MeasuredModes,
    ModalPairs,
    SensitivityResult,
    SensitivityUpdater,
    sensitivity_update,
)

__all__ = ["APPENDED_PARAMETERS", "UPDATERS", "EffectTerm", "FRFPredictor",
           "FiniteDifferenceUpdater", "IterationSettings", "Macroelement", "MeasuredModes",
           "ModalPairs", "PredictedTest", "SensitivityResult", "SensitivityUpdater",
           "SystemMatrices", "UpdateProblem", "UpdateResult", "Updater", "check_identifiable",
           "check_overdetermined", "damping_sensitivities", "eigen_sensitivities",
           "finite_difference_update", "get_updater", "macroelement_matrices", "make_updater",
           "register_updater", "sensitivity_matrix", "sensitivity_update", "system_matrices"]
