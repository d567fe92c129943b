"""The settings of the diagnosis, declared once (:mod:`truthbench.settings`): the Python
call, the model file's ``[diagnose]`` table and the command's options are built from
:class:`DiagnoseSettings`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from truthbench.diagnose import adequacy
from truthbench.settings import Configurable, setting


@dataclass(frozen=True, kw_only=True)
class DiagnoseSettings(Configurable):
    """Settings of :func:`diagnose`, declared once (:mod:`truthbench.settings`): the
    model file's ``[diagnose]`` table and the command's options are built from these."""

    name = "diagnose"

    candidates: tuple[str, ...] | None = None
    point_map: Mapping[int, float] = field(default_factory=dict)
    channel_map: Mapping[str, Mapping] = field(default_factory=dict)
    band_hz: tuple[float, float] | None = setting(
        None, "band of lines compared (default: every line the data hold)", kind="band",
        unit="Hz")
    tolerance_m: float = setting(1e-3, "largest distance of a measured point from its "
                                 "model node", unit="m", low=0, low_open=True)
    max_effects: int = setting(2, "most effects in the final model", low=0, high=5)
    threshold: float = setting(10.0, "least delta BIC of an effect (the model refitted "
                               "with it against the model without it)", low=0)
    refits: int = setting(4, "best screened candidates refitted at each step, besides "
                          "the best location of every other effect", low=1, high=50)
    ambiguity_margin: float = setting(10.0, "delta BIC within which a runner-up makes the "
                                      "verdict 'A or B'", low=0)
    estimator: bool = setting(True, "compare through the data's estimator (leakage of "
                              "averaged H1) when it is known")
    window: str | None = setting(None, "segment window of averaged FRFs from other tools "
                                 "(UFF files do not say); the segment length follows from "
                                 "the line spacing", kind="str",
                                 choices=("rectangular", "bartlett", "hann", "hamming"))
    fs_hz: float | None = setting(None, "sampling rate of those FRFs (default: twice the "
                                  "highest line)", kind="float", unit="Hz", low=0,
                                  low_open=True)
    averages: int | None = setting(None, "their number of averages (UFF FRF sets do not "
                                   "say): with the coherence it sets the noise weight of "
                                   "every value; without it the fit weights values "
                                   "relatively", kind="int", low=1)
    identify_modes: bool = setting(True, "identify the data's modes (pLSCF) for the "
                                   "paired-mode views")
    check_modes: bool = setting(True, "look for modes the model lacks")
    mounting: bool = setting(False, "model the channels' off-axis mounting in the "
                             "comparison: every translational sensor and shaker off the "
                             "beam's axis, reading and driving its torsion, roll and "
                             "bending across (one real amplitude per path and transfer "
                             "function)")
    noise_margin: float = setting(0.1, "no effect is sought once the residual's variance "
                                  "is within this fraction of the noise's", low=0, high=1)
    excess_share: float = setting(0.25, "share of the residual's excess over the noise an "
                                  "effect must explain", low=0, high=1)
    mesh_tolerance: float = setting(adequacy.MESH_TOLERANCE, "largest unexplained change "
                                    "of the fit, in noise units, when the mesh is halved",
                                    low=0, low_open=True)
    max_refinement: int = setting(adequacy.MAX_REFINEMENT, "most times the mesh is "
                                  "refined (1: never)", low=1)
    max_iterations: int = setting(30, "most Gauss-Newton iterations of a full refit",
                                  low=1)
    tolerance: float = setting(1e-6, "relative step at which a full refit has converged",
                               low=0, low_open=True)
