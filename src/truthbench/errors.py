"""The error hierarchy of truthbench.

Every message names the file, key or parameter at fault, what was expected and what
was received.
"""


class TruthbenchError(Exception):
    """Base class of every error raised on purpose by truthbench."""


class CampaignError(TruthbenchError, ValueError):
    """A campaign file or campaign specification is malformed."""


class DataFormatError(TruthbenchError, ValueError):
    """A data file (HDF5, UFF, LVM) is corrupt, truncated or not of the expected form."""


class ModelError(TruthbenchError, ValueError):
    """A model or plant was asked for something it does not have (a station, a DOF)."""


class IdentifiabilityError(TruthbenchError, ValueError):
    """An update problem cannot determine its parameters (too few equations, collinear)."""


class ConvergenceError(TruthbenchError, RuntimeError):
    """An iterative method did not converge within its limits."""
