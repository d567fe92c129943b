"""Model updating: parameterisations and updaters (finite-difference FRF method)."""

from truthbench.update.finite_difference import (
    UpdateResult,
    check_overdetermined,
    finite_difference_update,
    sensitivity_matrix,
)

__all__ = ["UpdateResult", "check_overdetermined", "finite_difference_update",
           "sensitivity_matrix"]
