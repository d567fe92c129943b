"""What a campaign run produces: test records, trial results, the campaign result.

Frozen dataclasses; a trial (:mod:`truthbench.campaign.trial`) makes them, the store
(:mod:`truthbench.campaign.store`) writes them in the HDF5 format of
:mod:`truthbench.io.hdf5`, and :meth:`CampaignResult.load` reads them back. The report
(:mod:`truthbench.report`) only formats what they hold.

Looking at a result
-------------------
* ``result.to_pandas(name)``: a tidy per-trial table, one row per trial and item
  (``"parameters"``, ``"modes"``, ``"coverage"``, ``"frf_error"``, ``"frf_band"``,
  ``"tests"``, ``"stage_times"``; :mod:`truthbench.campaign.tables`);
* ``result.summary(name)``: the aggregation over trials the report shows (the same
  names, plus ``"methods"`` and ``"uncertainty"``);
* ``result.coverage()``: the bound's coverage with its intervals
  (:class:`~truthbench.campaign.coverage.CoverageSummary`);
* ``result.plot(kind, trial=..., test=...)``: a matplotlib figure (``"frf"``,
  ``"poles"``, ``"frf_band"``, ``"calibration"``; :mod:`truthbench.campaign.figures`).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from truthbench.campaign.spec import CampaignSpec
from truthbench.errors import DataFormatError
from truthbench.measure.frfdata import FRFData

if TYPE_CHECKING:
    from truthbench.campaign.frf_band_stage import FrfBandStage
    from truthbench.campaign.summary import TrialSummary
    from truthbench.campaign.tables import Tables

STAGES = ("simulate", "frf", "identify", "bound", "update", "score")
"""Stages timed per trial (:attr:`TrialResult.seconds`): truth simulation, FRF
estimation, modal identification, the uncertainty models (modal bound and FRF band),
the updaters, and scoring against the truth (model FRFs and modal accuracy)."""


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
        Recorded input (N or N m) and (noisy) output time histories (the outputs'
        units); ``n_samples`` is 0 when the campaign's ``[output]`` does not keep them.
    fs_hz : float
    parameters : dict
        The exact truth parameters of the hardware in this test.
    modes : ModalParameters or None
        Identified modes (:class:`~truthbench.identify.ModalParameters`), or None.
    """

    __test__ = False  # not a pytest test class

    name: str
    frf: FRFData
    u: np.ndarray
    y: np.ndarray
    fs_hz: float
    parameters: dict
    modes: object | None = None

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

    def to_pandas(self, table: str | None = None):
        """The FRFs' tables (:meth:`FRFData.to_pandas
        <truthbench.measure.frfdata.FRFData.to_pandas>`)."""
        return self.frf.to_pandas(table)

    def plot(self, kind: str | None = None, ax=None, **options):
        """The FRFs' figures (:meth:`FRFData.plot
        <truthbench.measure.frfdata.FRFData.plot>`); returns the figure."""
        return self.frf.plot(kind, ax, **options)


@dataclass(frozen=True)
class TrialResult:
    """One Monte Carlo trial: its tests, the update and the model FRFs before and after.

    Attributes
    ----------
    trial : int
    tests : tuple of TestRecord
        In campaign order.
    truth : dict
        The trial's hardware truth for scoring (:func:`~truthbench.campaign.trial.
        hardware_truth`), name -> value in the parameter's unit.
    update : UpdateResult or None
        The primary updater's result; None when the campaign does not update, or the
        trial failed.
    H_initial, H_updated : tuple of ndarray, complex, each (n_freq_pos, n_out, n_in)
        Model FRFs per test at the test's lines above 0 Hz, in the test's FRF units.
    update_mask : tuple of ndarray of bool, each (n_freq,)
        Lines of each test used by the update.
    accuracy : dict
        ``{"initial": ..., "<method>": ..., "updated": ...}``: modes against the truth
        (:func:`~truthbench.campaign.metrics.modal_accuracy`); ``"updated"`` is the
        primary updater's.
    error : str or None
        The message of a failed trial (its tests so far are kept).
    comparison : dict
        Every updater's result by name (or its error message).
    uncertainty : UncertaintyStage or None
        :class:`~truthbench.campaign.uncertainty_stage.UncertaintyStage`.
    seconds : dict
        Wall-clock seconds per stage (:data:`STAGES`); not part of the results'
        identity (they vary from run to run).
    frf_band : FrfBandStage or None
        The FRF-domain uncertainty model
        (:class:`~truthbench.campaign.frf_band_stage.FrfBandStage`), or None.
    summary : TrialSummary or None
        What the tables and the report need of the trial
        (:class:`~truthbench.campaign.summary.TrialSummary`): set by the trial that ran
        it and read back from its file; None for a trial built otherwise (then
        computed from it when needed).
    """

    trial: int
    tests: tuple[TestRecord, ...]
    truth: dict
    update: object | None = None
    H_initial: tuple[np.ndarray, ...] = ()
    H_updated: tuple[np.ndarray, ...] = ()
    update_mask: tuple[np.ndarray, ...] = ()
    accuracy: dict = field(default_factory=dict)
    error: str | None = None
    comparison: dict = field(default_factory=dict)
    uncertainty: object | None = None
    seconds: dict = field(default_factory=dict)
    frf_band: FrfBandStage | None = None
    summary: TrialSummary | None = None

    def test(self, name: str) -> TestRecord:
        """The test record called ``name``.

        Raises
        ------
        KeyError
            Naming the test and the trial's tests.
        """
        for rec in self.tests:
            if rec.name == name:
                return rec
        raise KeyError(f"trial {self.trial} has no test {name!r}; its tests are "
                       f"{', '.join(r.name for r in self.tests) or 'none'}")


class StoredTrials(Sequence):
    """The trials of results files, read from disk one at a time when used: the
    :attr:`CampaignResult.trials` of a loaded result.

    Indexing or iterating reads a trial whole (FRFs, model FRFs, time histories) and
    keeps the last two read; :meth:`summaries` reads only each trial's summary. So a
    result of ten thousand trials is loaded, tabulated and reported with a few trials in
    memory at a time.

    Parameters
    ----------
    spec : CampaignSpec
        The campaign the files store.
    entries : sequence of (str, str)
        ``(file, group key under /trials)`` of every trial, in trial order.
    """

    def __init__(self, spec: CampaignSpec, entries):
        self.spec = spec
        self.entries = tuple((str(f), str(k)) for f, k in entries)
        self.numbers = tuple(int(k) for _, k in self.entries)
        self._cache: dict = {}

    def __len__(self) -> int:
        return len(self.entries)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return tuple(self[k] for k in range(*i.indices(len(self))))
        i = range(len(self))[i]  # negative indices, IndexError
        if i not in self._cache:
            from truthbench.io import hdf5

            path, key = self.entries[i]
            with hdf5.reading(path) as f:
                self._cache[i] = _trial(self.spec, hdf5.read_trial(
                    f, key, hdf5.read_attrs(f), _legacy(self.spec)))
            while len(self._cache) > 2:
                self._cache.pop(next(iter(self._cache)))
        return self._cache[i]

    def summaries(self):
        """Every trial's :class:`~truthbench.campaign.summary.TrialSummary`, in order:
        read from each file's ``summary`` (a trial of a file written before trials had
        one is read whole and summarised)."""
        from truthbench.campaign.summary import TrialSummary, trial_summary
        from truthbench.io import hdf5

        i, n = 0, len(self.entries)
        while i < n:
            path = self.entries[i][0]
            with hdf5.reading(path) as f:
                while i < n and self.entries[i][0] == path:
                    text, seconds = hdf5.read_summary(f, self.entries[i][1])
                    yield (TrialSummary.from_json(text, seconds) if text is not None
                           else trial_summary(self.spec, self[i]))
                    i += 1


def _summaries(spec, trials):
    """The summaries of a sequence of trials (:class:`StoredTrials` reads them from its
    files; a trial in memory gives its own, or one computed from it)."""
    if isinstance(trials, StoredTrials):
        yield from trials.summaries()
        return
    from truthbench.campaign.summary import trial_summary

    for tr in trials:
        yield tr.summary if tr.summary is not None else trial_summary(spec, tr)


@dataclass(frozen=True)
class CampaignResult:
    """Everything a campaign run produced, with what made it.

    Attributes
    ----------
    spec : CampaignSpec
    seed : int
    version : str
        The truthbench version that ran the campaign.
    nominal : dict
        The nominal plant parameters.
    trials : sequence of TrialResult
        In trial order: a tuple for a result in memory; for a loaded result a
        :class:`StoredTrials`, which reads each trial from disk when it is used.
    created_utc : str or None
        When the results file was written (ISO 8601), for a loaded result.
    path : str or None
        The file a loaded result came from.
    injected : tuple of str
        Effects injected by ``truthbench simulate --inject`` (a single-test file).

    Notes
    -----
    A single-test file of ``truthbench simulate`` loads as a result with one trial
    (the simulated trial's number) holding the one test, with an empty ``truth`` (the
    test's exact truth is its ``parameters``) and no update.

    The tables, summaries, coverage, stage times and failed trials come from one pass
    over the trials' summaries (:attr:`tables`), made the first time one is asked for;
    only the figures read a trial whole.
    """

    spec: CampaignSpec
    seed: int
    version: str
    nominal: dict
    trials: Sequence[TrialResult]
    created_utc: str | None = None
    path: str | None = None
    injected: tuple[str, ...] = ()

    # ---- files -----------------------------------------------------------------------
    @classmethod
    def load(cls, path: str | Path) -> CampaignResult:
        """Read a results file written by :meth:`save` (or ``truthbench run``), a
        single-test file of ``truthbench simulate``, or a run's folder.

        A results file's trials are read when they are used (:class:`StoredTrials`); its
        tables from the trials' summaries alone. A single-test file gives a result with
        one trial (its number from the file) holding the one test, an empty trial truth
        and no update; ``injected`` lists the effects injected. A run's folder gives its
        ``results.h5``, or, for a run that has not finished (interrupted, or still
        running), the trials its store holds
        (:class:`~truthbench.campaign.store.TrialStore`). Files written before channels
        and FRF metadata were stored get them from the stored spec (channels without
        coordinates, the band from the spec's tests).

        Raises
        ------
        DataFormatError
            Naming the file: missing, not HDF5, not a truthbench results file, a stored
            spec that is not a valid campaign; a stored part that does not parse (with
            its HDF5 path) when its trial is read.
        """
        from truthbench.campaign.store import (
            RESULTS_FILE,
            RUN_FILE,
            TRIALS_DIR,
            StoreError,
            TrialStore,
        )
        from truthbench.io import hdf5

        path = Path(path)
        if path.is_dir():  # a run's folder: its results file, else its (partial) store
            if (path / RESULTS_FILE).is_file():
                path = path / RESULTS_FILE
            else:
                store = TrialStore(path.parent if path.name == TRIALS_DIR else path)
                if not store.exists:
                    raise DataFormatError(f"{path}: holds neither {RESULTS_FILE} nor a run "
                                          f"store ({TRIALS_DIR}/{RUN_FILE})")
                try:
                    return store.load()
                except StoreError as exc:
                    raise DataFormatError(str(exc)) from None
        with hdf5.reading(path) as f:
            a = hdf5.read_attrs(f)
            spec = _stored_spec(a, path)
            common = dict(spec=spec, seed=int(a["seed"]), version=str(a["truthbench_version"]),
                          created_utc=a.get("created_utc"), path=str(path))
            if a["single_test"]:
                body = hdf5.read_body(f, a, _legacy(spec))
                return cls(nominal=spec.nominal_parameters(),
                           injected=tuple(json.loads(a.get("injected", "[]"))),
                           trials=tuple(_trial(spec, t) for t in body["trials"]), **common)
            nominal = hdf5.read_nominal(f)
            keys = hdf5.trial_keys(f)
        return cls(nominal=nominal, trials=StoredTrials(spec, [(path, k) for k in keys]),
                   **common)

    def save(self, path: str | Path) -> Path:
        """Write to HDF5 (:func:`~truthbench.campaign.store.write_results`)."""
        from truthbench.campaign.store import write_results

        return write_results(self, path)

    # ---- views -----------------------------------------------------------------------
    @cached_property
    def tables(self) -> Tables:
        """The per-trial tables (:class:`~truthbench.campaign.tables.Tables`), reduced
        from the trials' summaries in one pass the first time they are asked for."""
        from truthbench.campaign.tables import tables_of

        return tables_of(self, _summaries(self.spec, self.trials))

    @property
    def stage_seconds(self) -> dict:
        """Wall-clock seconds per stage summed over the trials (worker time, not elapsed
        time)."""
        df = self.tables.frame("stage_times")
        return {k: float(df[k].sum()) for k in STAGES}

    @property
    def primary_method(self) -> str | None:
        """The campaign's primary updater, or None when it does not update."""
        methods = self.spec.update_methods()
        return methods[0] if methods else None

    @property
    def failed(self) -> tuple[TrialResult, ...]:
        """The trials that failed (each read whole)."""
        return tuple(self.trial(t) for t, _ in self.tables.failed)

    def trial(self, number: int | None = None) -> TrialResult:
        """The trial numbered ``number``; default the first trial that did not fail (or
        the first trial when all failed).

        Raises
        ------
        KeyError
            Naming the trial and the ones the result holds.
        """
        trials = self.trials
        if number is None:
            if not len(trials):
                raise KeyError("the result holds no trial")
            number = self.tables.first["ok"]
            if number is None:
                return trials[0]
        held = (list(trials.numbers) if isinstance(trials, StoredTrials)
                else [t.trial for t in trials])
        if number in held:
            return trials[held.index(number)]
        raise KeyError(f"no trial {number}; the result holds trials "
                       f"{', '.join(str(t) for t in held) or 'none'}")

    def to_pandas(self, table: str = "parameters"):
        """A tidy per-trial table (:func:`truthbench.campaign.tables.table`).

        Parameters
        ----------
        table : str
            ``"parameters"`` (per trial, parameter and updater: nominal, truth, updated,
            errors before and after, %), ``"modes"`` (per trial, model and truth mode:
            frequency and damping error, %, MAC), ``"coverage"`` (per trial, test and
            bounded modal parameter: identified, truth, bound, inside), ``"frf_error"``,
            ``"frf_band"``, ``"tests"``, ``"stage_times"`` (seconds per stage).

        Returns
        -------
        pandas.DataFrame
        """
        from truthbench.campaign.tables import table as make

        return make(self, table)

    def summary(self, table: str = "parameters"):
        """An aggregation over trials (:func:`truthbench.campaign.tables.summary`):
        ``"parameters"`` (mean values, bias and RMS error per updater),
        ``"modes"``, ``"methods"`` (no update against every updater), ``"coverage"``
        (per parameter, Wilson intervals), ``"uncertainty"`` (the first trial's bound),
        ``"frf_error"``, ``"frf_band"``, ``"tests"``, ``"stage_times"``.

        Returns
        -------
        pandas.DataFrame
        """
        from truthbench.campaign.tables import summary

        return summary(self, table)

    def coverage(self, confidence: float = 0.95):
        """Coverage of the uncertainty bound against the truth over the trials
        (:func:`truthbench.campaign.coverage.coverage_summary`, at the campaign's
        ``k_sigma``), or None when no trial has an uncertainty stage."""
        from truthbench.campaign.coverage import coverage_summary

        return coverage_summary([u for _, u in self.tables.stages],
                                self.spec.uncertainty.k_sigma, confidence)

    def plot(self, kind: str = "frf", *, trial: int | None = None, test: str | None = None,
             **kwargs):
        """A figure of the result (:mod:`truthbench.campaign.figures`).

        Parameters
        ----------
        kind : {"frf", "poles", "frf_band", "convergence", "calibration"}
            ``"frf"``: one test's data against the initial and updated model, magnitude
            and phase (and coherence) per output, with units; ``"poles"``: the poles of
            the tests with the bound (Figure 10.6), one panel per mode; ``"frf_band"``:
            the FRF-domain band with the models; ``"convergence"``: coverage and error
            statistics against the number of trials, with confidence bands;
            ``"calibration"``: held-out coverage against k.
        trial : int, optional
            Trial number; default the first that did not fail.
        test : str, optional
            For ``"frf"``: the test (default the first).
        **kwargs
            Passed to the figure function.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from truthbench.campaign import figures

        funcs = {"frf": figures.plot_frf, "poles": figures.plot_poles,
                 "frf_band": figures.plot_frf_band, "convergence": figures.plot_convergence}
        if kind == "calibration":
            cov = self.coverage()
            if cov is None:
                raise ValueError("no calibration figure: no trial has an uncertainty stage")
            return cov.plot(**kwargs)
        if kind not in funcs:
            raise ValueError(f"unknown figure {kind!r}; expected one of "
                             f"{', '.join([*funcs, 'calibration'])}")
        if kind == "convergence":
            return figures.plot_convergence(self, **kwargs)
        tr = self.trial(trial)
        if kind == "frf":
            return figures.plot_frf(self, tr, test, **kwargs)
        return funcs[kind](self, tr, **kwargs)


# ---- reading a results file back -------------------------------------------------------
def _stored_spec(attrs, path) -> CampaignSpec:
    """The campaign a file stores (its ``spec_json``), validated."""
    from truthbench.campaign.spec import parse_campaign
    from truthbench.errors import CampaignError

    try:
        return parse_campaign(attrs["spec"], source=attrs.get("source", str(path)))
    except CampaignError as exc:
        raise DataFormatError(f"{path}: attribute 'spec_json' is not a valid campaign "
                              f"({type(exc).__name__}: {exc})") from None


def _legacy(spec) -> dict:
    """Per test, what files written before channels and FRF metadata were stored lack:
    the channels (without coordinates) and the band, from the spec."""
    from truthbench.measure.frfdata import Channel

    out = {}
    for j, t in enumerate(spec.tests):
        actuators, sensors = spec.test_io(j)
        out[t.name] = {
            "outputs": tuple(Channel(s.label, s.quantity, s.direction, station=s.station)
                             for s in sensors),
            "inputs": tuple(Channel(a.label, "force", a.direction, station=a.station)
                            for a in actuators),
            "band_hz": tuple(t.band_hz)}
    return out


def _trial(spec, d: dict):
    """A :class:`~truthbench.campaign.results.TrialResult` from what
    :func:`truthbench.io.hdf5.read_body` read of it: the typed parts, the updaters and
    accuracies in the campaign's order."""
    from truthbench.campaign.frf_band_stage import FrfBandStage
    from truthbench.campaign.uncertainty_stage import UncertaintyStage
    from truthbench.identify import ModalParameters
    from truthbench.uncertainty.frequency import FrfUncertainty
    from truthbench.update.finite_difference import UpdateResult

    methods = spec.update_methods()

    def by_method(keys):
        return sorted(keys, key=lambda m: (methods.index(m) if m in methods
                                           else len(methods), m))

    tests = tuple(TestRecord(**{**r, "modes": None if r["modes"] is None
                                else ModalParameters(**r["modes"])}) for r in d["tests"])
    kw = {k: d[k] for k in ("H_initial", "H_updated", "update_mask") if k in d}
    if "update" in d:
        kw["update"] = UpdateResult(**d["update"])
        kw["comparison"] = {m: c if isinstance(c, str) else UpdateResult(**c)
                            for m in by_method(d["comparison"]) for c in [d["comparison"][m]]}
    if "accuracy" in d:
        keys = list(d["accuracy"])
        order = ((["initial"] if "initial" in keys else [])
                 + by_method(k for k in keys if k not in ("initial", "updated"))
                 + (["updated"] if "updated" in keys else []))
        kw["accuracy"] = {k: d["accuracy"][k] for k in order}
    if "uncertainty" in d:
        kw["uncertainty"] = UncertaintyStage(**d["uncertainty"])
    if "frf_band" in d:
        b = d["frf_band"]
        band = FrfUncertainty(b["mean"], b["cov"], b["n_tests"], b["k_sigma"], b["freq_hz"])
        kw["frf_band"] = FrfBandStage(b["tests"], band, b["line_mask"], b["inside"],
                                      b["output_labels"], b["input_labels"])
    if d.get("summary") is not None:
        from truthbench.campaign.summary import TrialSummary

        kw["summary"] = TrialSummary.from_json(d["summary"], d.get("seconds"))
    return TrialResult(d["trial"], tests, d["truth"], error=d.get("error"),
                       seconds=d.get("seconds", {}), **kw)
