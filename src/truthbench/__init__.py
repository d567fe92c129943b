"""truthbench: synthetic test campaigns with known truth for FE model updating.

The package is organised in rooms (see ``README.md``): ``fe`` (beam element and
assembly), ``plants`` (parametric test articles), ``model`` (the structural model
object), ``simulate``, ``measure``, ``identify``, ``update``, ``campaign`` and
``report``. Heavy dependencies (python-control, matplotlib, h5py) are imported only
where they are needed so the command line starts quickly.
"""

__version__ = "0.1.0"

import truthbench.campaign.store  # noqa: E402, F401 - registers the .h5/.hdf5 FRF reader of truthbench.io
