"""placement room: ranking candidate sensor locations (Section 10.3,
Eq. 10.45; :ref:`method-placement`).

Owns: ranking by the mode-shape sensitivity to the expected error sources, with a greedy
D-optimal selection that avoids redundant DOFs, and a finite-difference fallback for the
eigenvector sensitivities; ranking by the scaled observability gramian of the modal
state space (:mod:`.ranking`). Pure functions returning a frozen :class:`SensorRanking`.
"""

from truthbench.placement.ranking import (
    SensorRanking,
    ShapeSensitivities,
    greedy_d_optimal,
    modal_candidate_system,
    modal_gramian_contributions,
    observability_gramian,
    rank_sensors_by_gramian,
    rank_sensors_by_sensitivity,
    shape_sensitivities,
)

__all__ = [
    "SensorRanking",
    "ShapeSensitivities",
    "greedy_d_optimal",
    "modal_candidate_system",
    "modal_gramian_contributions",
    "observability_gramian",
    "rank_sensors_by_gramian",
    "rank_sensors_by_sensitivity",
    "shape_sensitivities",
]
