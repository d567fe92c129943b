"""What a campaign run produces: test records, trial results, the campaign result.

Frozen dataclasses; the runner (:mod:`truthbench.campaign.runner`) makes them and the
store (:mod:`truthbench.campaign.store`) writes them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from truthbench.campaign.spec import CampaignSpec
from truthbench.measure.frfdata import FRFData

STAGES = ("simulate", "frf", "identify", "bound", "update", "score")
"""Stages timed per trial (:attr:`TrialResult.seconds`): truth simulation, FRF
estimation, modal identification, the uncertainty model, the updaters, and scoring
against the truth (model FRFs and modal accuracy)."""


@dataclass(frozen=True)
class TestRecord:
    """One test's measurement.

    Attributes
    ----------
    name : str
    frf : FRFData
        The estimated FRFs (H1) with their coherence and channels; ``freq_hz``, ``H``,
        ``coherence`` and the channel labels are read through it.
    u, y : ndarray, shape (n_in, n_samples), (n_out, n_samples)
        Recorded input and (noisy) output time histories.
    fs_hz : float
    parameters : dict
        The exact truth parameters of the hardware in this test.
    """

    __test__ = False  # not a pytest test class

    name: str
    frf: FRFData
    u: np.ndarray
    y: np.ndarray
    fs_hz: float
    parameters: dict
    modes: object | None = None
    """Identified modes (:class:`~truthbench.identify.ModalParameters`), or None."""

    @property
    def freq_hz(self) -> np.ndarray:
        return self.frf.freq_hz

    @property
    def H(self) -> np.ndarray:  # noqa: N802 - the field name of the FRF everywhere
        return self.frf.H

    @property
    def coherence(self) -> np.ndarray | None:
        return self.frf.coherence

    @property
    def input_labels(self) -> tuple[str, ...]:
        return self.frf.input_labels

    @property
    def output_labels(self) -> tuple[str, ...]:
        return self.frf.output_labels


@dataclass(frozen=True)
class TrialResult:
    """One Monte Carlo trial: its tests, the update and the model FRFs before and after.

    ``update`` is None when the campaign does not update; ``error`` holds the message
    of a failed trial (its tests so far are kept)."""

    trial: int
    tests: tuple[TestRecord, ...]
    truth: dict
    update: object | None = None
    H_initial: tuple[np.ndarray, ...] = ()
    H_updated: tuple[np.ndarray, ...] = ()
    update_mask: tuple[np.ndarray, ...] = ()
    accuracy: dict = field(default_factory=dict)
    """``{"initial": ..., "updated": ...}``: modes against the truth
    (:func:`~truthbench.campaign.metrics.modal_accuracy`)."""
    error: str | None = None
    comparison: dict = field(default_factory=dict)
    """Every updater's result by name (or its error message)."""
    uncertainty: object | None = None
    """:class:`~truthbench.campaign.uncertainty_stage.UncertaintyStage`, or None."""
    seconds: dict = field(default_factory=dict)
    """Wall-clock seconds per stage (:data:`STAGES`); not part of the results' identity
    (they vary from run to run)."""


@dataclass(frozen=True)
class CampaignResult:
    """Everything a campaign run produced, with what made it."""

    spec: CampaignSpec
    seed: int
    version: str
    nominal: dict
    trials: tuple[TrialResult, ...]

    @property
    def stage_seconds(self) -> dict:
        """Wall-clock seconds per stage summed over the trials (worker time, not elapsed
        time)."""
        return {k: float(sum(t.seconds.get(k, 0.0) for t in self.trials)) for k in STAGES}
