"""Model updating: the finite-difference FRF method, sensitivity localization, and the
registry of interchangeable updaters."""

from truthbench.update.finite_difference import (
    UpdateResult,
    check_overdetermined,
    finite_difference_update,
    sensitivity_matrix,
)
from truthbench.update.macroelements import (
    Macroelement,
    SystemMatrices,
    macroelement_matrices,
    system_matrices,
)
from truthbench.update.registry import (
    UPDATERS,
    FiniteDifferenceUpdater,
    SensitivityUpdater,
    UpdateProblem,
    Updater,
    get_updater,
    register_updater,
)
from truthbench.update.sensitivity import (
    MeasuredModes,
    ModalPairs,
    SensitivityResult,
    damping_sensitivities,
    eigen_sensitivities,
    sensitivity_update,
)

__all__ = ["UPDATERS", "FiniteDifferenceUpdater", "Macroelement", "MeasuredModes",
           "ModalPairs", "SensitivityResult", "SensitivityUpdater", "SystemMatrices",
           "UpdateProblem", "UpdateResult", "Updater", "check_overdetermined",
           "damping_sensitivities", "eigen_sensitivities", "finite_difference_update",
           "get_updater", "macroelement_matrices", "register_updater",
           "sensitivity_matrix", "sensitivity_update", "system_matrices"]
