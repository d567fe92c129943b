"""Closing the loop with measured data: trace the residual to the effect the model lacks.

Measured FRFs (any file :func:`truthbench.load_frf` reads) and a model (a plant and the
parameters the user trusts it to get wrong) go in; :func:`diagnose` fits the declared
parameters (the baseline), computes the residual in every view that carries a signature
(:mod:`.residual`), tries every effect of the registry that can be missing at every
location it can have (:mod:`.candidates`, screened by a score test and refitted,
:mod:`.fit`), adds the best by an information criterion until none is significant, and
returns a :class:`Diagnosis` with the effects found, their fitted values and
uncertainty, and the residual before and after.
"""

from truthbench.diagnose.candidates import Candidate, catalogue
from truthbench.diagnose.core import DiagnoseSettings, Found, Tried, diagnose
from truthbench.diagnose.data import MeasuredTest, prepare
from truthbench.diagnose.residual import Residual
from truthbench.diagnose.result import Diagnosis

__all__ = ["Candidate", "DiagnoseSettings", "Diagnosis", "Found", "MeasuredTest", "Residual",
           "Tried", "catalogue", "diagnose", "prepare"]
