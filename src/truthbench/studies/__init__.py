"""studies: the chapter's numerical studies, reproduced on truthbench's own numerics.

* :mod:`~truthbench.studies.discretization` -- Figure 10.2: frequency and mode-shape
  errors of a free-free tube beam against the number of finite elements, with the
  exact Euler-Bernoulli solution as the reference (:ref:`method-discretization`).
* :mod:`~truthbench.studies.damping_smoothing` -- Figure 10.3: the damping ratio read
  from the peak of a Bartlett-smoothed, 10-average FRF of a noisy single-DOF system,
  against the number of points per window (:ref:`method-smoothing`).

Each study is a pure function returning a frozen result with ``.to_pandas()`` and
``.plot()`` (a figure, :mod:`truthbench.presentation`); the command line
(``truthbench study ...``) writes the CSV and PNG.
"""

from truthbench.studies.damping_smoothing import (
    DampingSmoothingStudy,
    damping_smoothing_study,
    sdof_state_space,
)
from truthbench.studies.discretization import (
    DiscretizationStudy,
    discretization_study,
    free_free_roots,
    free_free_shape,
)

__all__ = [
    "DampingSmoothingStudy",
    "DiscretizationStudy",
    "damping_smoothing_study",
    "discretization_study",
    "free_free_roots",
    "free_free_shape",
    "sdof_state_space",
]
