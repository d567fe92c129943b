"""The FRF-domain uncertainty stage of a campaign (the chapter's Section 10.3: the mean
of the data gives the model and their variance bounds the transfer functions;
:ref:`method-uncertainty-model`).

Per trial, the tests that share inputs, outputs and frequency lines form groups; the
largest group (at least three tests, the first such group on a tie) over the lines
every test of it excites (above 0 Hz, finite in every test) gives
:func:`truthbench.uncertainty.frf_uncertainty`: the mean FRF and the covariance of its
real and imaginary parts, line by line. The initial and updated model FRFs of the
group's first test are scored against the ``k``-sigma ellipse (``[uncertainty]
k_sigma``): the fraction of lines and input-output pairs inside it.

The stage runs after the rest of the trial (:func:`with_frf_band`); its result is
stored with the trial (``trials/<k>/frf_band`` in :mod:`truthbench.io.hdf5`) so the
report reads it and reruns nothing.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from truthbench.presentation import Presentable

MIN_TESTS = 3
"""Tests a band needs: the 2 x 2 covariance of real and imaginary parts from two tests
is singular."""


@dataclass(frozen=True)
class FrfBandStage(Presentable):
    """The FRF band of one trial.

    Table ``"lines"`` (:meth:`to_pandas`): one row per line and input-output pair, with
    the channel labels. Figure ``"magnitude"`` (:meth:`plot`): the mean FRF's magnitude
    and its band (:class:`~truthbench.uncertainty.frequency.FrfUncertainty`; the
    campaign result's ``plot("frf_band")`` adds the models).

    Attributes
    ----------
    tests : tuple of str
        The tests of the group, in campaign order.
    band : truthbench.uncertainty.frequency.FrfUncertainty
        Mean FRF (n_freq_band, n_out, n_in), complex, in the FRFs' units, and the
        covariance (n_freq_band, n_out, n_in, 2, 2) of its real and imaginary parts,
        units squared; ``band.freq_hz`` the lines, Hz; ``band.k_sigma``,
        ``band.n_tests``.
    line_mask : ndarray of bool, shape (n_freq,)
        The band's lines among the tests' frequency lines.
    inside : dict of str -> float
        ``"initial"``, ``"updated"`` (when the trial updated): fraction of the model's
        lines and pairs inside the ``k``-sigma ellipse, in [0, 1].
    output_labels, input_labels : tuple of str
    """

    TABLES = ("lines",)
    PLOTS = ("magnitude",)

    tests: tuple[str, ...]
    band: object
    line_mask: np.ndarray
    inside: dict
    output_labels: tuple[str, ...]
    input_labels: tuple[str, ...]

    def __post_init__(self):
        mask = np.array(self.line_mask, dtype=bool)
        mask.setflags(write=False)
        object.__setattr__(self, "line_mask", mask)
        object.__setattr__(self, "tests", tuple(self.tests))
        object.__setattr__(self, "inside", dict(self.inside))
        object.__setattr__(self, "output_labels", tuple(self.output_labels))
        object.__setattr__(self, "input_labels", tuple(self.input_labels))

    def model(self, trial, which: str) -> np.ndarray | None:
        """The ``which`` ("initial" or "updated") model FRF of the group's first test at
        the band's lines, shape (n_freq_band, n_out, n_in), or None when the trial has
        no model FRFs.

        Parameters
        ----------
        trial : TrialResult
            The trial this band belongs to.
        """
        models = trial.H_initial if which == "initial" else trial.H_updated
        if not models:
            return None
        names = [rec.name for rec in trial.tests]
        rec = trial.tests[names.index(self.tests[0])]
        model = np.asarray(models[names.index(self.tests[0])])
        # model FRFs are stored at the lines above 0 Hz
        return model[self.line_mask[rec.freq_hz > 0]]

    def _plot_magnitude(self, ax, **options):
        """The band's mean magnitude and its ``k``-sigma band, one panel per pair."""
        return self.band.plot("magnitude", ax, **options)

    def _table_lines(self):
        """One row per line and input-output pair: the band's mean and standard
        deviations (:class:`~truthbench.uncertainty.frequency.FrfUncertainty`) with the
        channel labels."""
        df = self.band.to_pandas().reset_index()
        df["output"] = np.asarray(self.output_labels, dtype=object)[df["output"]]
        df["input"] = np.asarray(self.input_labels, dtype=object)[df["input"]]
        return df


def frf_band(plan, records, H_initial=(), H_updated=(), *,
             k_sigma: float | None = None) -> FrfBandStage | None:
    """The FRF band of one trial's tests.

    Parameters
    ----------
    plan : CampaignPlan
    records : sequence of TestRecord
        The trial's tests.
    H_initial, H_updated : sequence of ndarray, optional
        The model FRFs per test at the lines above 0 Hz (``TrialResult.H_initial``,
        ``H_updated``); empty when the trial did not update.
    k_sigma : float, optional
        Default ``[uncertainty] k_sigma``.

    Returns
    -------
    FrfBandStage or None
        None when no group has :data:`MIN_TESTS` tests or no line is common to all.
    """
    from truthbench.uncertainty import frf_uncertainty

    k = plan.spec.uncertainty.k_sigma if k_sigma is None else float(k_sigma)
    groups: dict = {}
    for j, rec in enumerate(records):
        key = (rec.input_labels, rec.output_labels, rec.freq_hz.tobytes())
        groups.setdefault(key, []).append(j)
    if not groups:
        return None
    (inputs, outputs, _), members = max(groups.items(), key=lambda kv: len(kv[1]))
    if len(members) < MIN_TESTS:
        return None
    bands = {t.name: t.band_hz for t in plan.tests}
    f = records[members[0]].freq_hz
    lo = max(bands[records[j].name][0] for j in members)
    hi = min(bands[records[j].name][1] for j in members)
    H = np.array([records[j].H for j in members])
    keep = (f > 0) & (f >= lo) & (f <= hi) & np.all(np.isfinite(H), axis=(0, 2, 3))
    if not keep.any():
        return None
    band = frf_uncertainty(H[:, keep], freq_hz=f[keep], k_sigma=k)
    inside = {}
    first = members[0]
    for which, models in (("initial", H_initial), ("updated", H_updated)):
        if len(models) > first:
            inside[which] = band.fraction_inside(np.asarray(models[first])[keep[f > 0]])
    return FrfBandStage(tuple(records[j].name for j in members), band, keep, inside,
                        outputs, inputs)


def with_frf_band(plan, trial):
    """``trial`` (:class:`~truthbench.campaign.results.TrialResult`) with its FRF band
    set (:func:`frf_band`) and the seconds it took added to the ``"bound"`` stage.

    A failed trial, or one without a group of comparable tests, is returned unchanged.
    """
    if trial.error:
        return trial
    t0 = time.perf_counter()
    band = frf_band(plan, trial.tests, trial.H_initial, trial.H_updated)
    if band is None:
        return trial
    seconds = dict(trial.seconds)
    seconds["bound"] = seconds.get("bound", 0.0) + time.perf_counter() - t0
    return replace(trial, frf_band=band, seconds=seconds)
