"""What the report needs of one trial, small enough to keep for every trial.

A :class:`TrialSummary` holds the numbers of one
:class:`~truthbench.campaign.results.TrialResult` that the result's tables and summaries
(:mod:`truthbench.campaign.tables`) and the report reduce over the trials: the updaters'
parameters against the truth, the modes against the truth, each test's FRF error over
its update lines and mean coherence in band, the uncertainty stage (the coverage flags
and what they were counted from), the FRF band's fractions, the stage times and the
error of a failed trial. It leaves out the FRFs, the model FRFs and the time histories
(hundreds of kB to MB per trial), which only the figures read, of one trial.

The worker computes it at the end of a trial (:func:`trial_summary`) and the store keeps
it beside the trial as JSON (:meth:`TrialSummary.to_json`; the ``summary`` attribute of
the trial's group, :mod:`truthbench.io.hdf5`; the stage times, which differ from run to
run, stay in the trial's ``seconds``), so that a result of ten thousand trials is
summarised by reading two small items per trial.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

_ACCURACY_KEYS = ("truth_freq_hz", "freq_error_pct", "damping_error_pct", "mac")
_UNCERTAINTY_DTYPES = {"theta_0": float, "theta_tests": float, "theta_truth": float,
                       "mean": float, "std": float, "bound": float, "inside": bool,
                       "mode_index": int, "holdout": bool, "theta_updated": float}


@dataclass(frozen=True)
class TestSummary:
    """One test of a trial.

    Attributes
    ----------
    name : str
    band_hz : (float, float)
        The excited band (Hz).
    n_averages : int or None
        Averages of the FRF estimate.
    coherence : float
        Mean coherence over the excited band's lines and every pair (NaN without
        coherence or lines).
    frf_error_before_pct, frf_error_after_pct : float
        ``100 ||G_D - G_M|| / ||G_D||`` over the test's update lines, of the initial and
        the updated (primary) model; NaN when the trial did not update.
    """

    __test__ = False  # not a pytest test class

    name: str
    band_hz: tuple[float, float]
    n_averages: int | None
    coherence: float
    frf_error_before_pct: float = np.nan
    frf_error_after_pct: float = np.nan


@dataclass(frozen=True)
class TrialSummary:
    """The numbers of one trial the tables and the report reduce over.

    Attributes
    ----------
    trial : int
    error : str or None
        The message of a failed trial.
    seconds : dict
        Stage -> wall-clock seconds.
    updated : bool
        Whether the primary updater ran (the trial has an update).
    truth : dict
        The trial's truth for scoring, name -> value.
    updates : dict
        Per updater, in the campaign's order: ``{"names", "initial", "values",
        "converged"}`` (tuple of str, two float arrays, bool), or the message of its
        failure in this trial.
    accuracy : dict
        ``"initial"``, each updater's name, ``"updated"``: ``truth_freq_hz``,
        ``freq_error_pct``, ``damping_error_pct``, ``mac`` (float arrays, one entry per
        paired mode) and ``n_unpaired_truth``
        (:func:`~truthbench.campaign.metrics.modal_accuracy`).
    tests : tuple of TestSummary
    uncertainty : UncertaintyStage or None
        The trial's uncertainty stage (a few arrays of tests x modal parameters).
    frf_band : dict or None
        ``tests`` (tuple of str), ``k_sigma``, ``n_lines``, ``inside`` (model -> fraction
        of lines and pairs inside the band).
    """

    trial: int
    error: str | None = None
    seconds: dict = field(default_factory=dict)
    updated: bool = False
    truth: dict = field(default_factory=dict)
    updates: dict = field(default_factory=dict)
    accuracy: dict = field(default_factory=dict)
    tests: tuple[TestSummary, ...] = ()
    uncertainty: object | None = None
    frf_band: dict | None = None

    # ---- JSON -------------------------------------------------------------------
    def to_json(self) -> str:
        """The summary as JSON text (floats exact: ``repr``; NaN as ``NaN``), without the
        stage times (stored beside it, they differ from run to run)."""
        u = self.uncertainty
        d = {"trial": int(self.trial), "error": self.error, "updated": bool(self.updated),
             "truth": {k: v if isinstance(v, str) else float(v) for k, v in self.truth.items()},
             "updates": {m: r if isinstance(r, str) else
                         {"names": list(r["names"]), "initial": _floats(r["initial"]),
                          "values": _floats(r["values"]), "converged": bool(r["converged"])}
                         for m, r in self.updates.items()},
             "accuracy": {s: {**{k: _floats(a[k]) for k in _ACCURACY_KEYS},
                              "n_unpaired_truth": int(a["n_unpaired_truth"])}
                          for s, a in self.accuracy.items()},
             "tests": [{"name": t.name, "band_hz": _floats(t.band_hz),
                        "n_averages": t.n_averages, "coherence": float(t.coherence),
                        "frf_error_before_pct": float(t.frf_error_before_pct),
                        "frf_error_after_pct": float(t.frf_error_after_pct)}
                       for t in self.tests],
             "uncertainty": None if u is None else {
                 "names": list(u.names),
                 **{k: None if getattr(u, k) is None else np.asarray(getattr(u, k)).tolist()
                    for k in _UNCERTAINTY_DTYPES}},
             "frf_band": None if self.frf_band is None else {
                 **self.frf_band, "tests": list(self.frf_band["tests"]),
                 "inside": {k: float(v) for k, v in self.frf_band["inside"].items()}}}
        return json.dumps(d, separators=(",", ":"))

    @classmethod
    def from_json(cls, text: str, seconds: dict | None = None) -> TrialSummary:
        """The summary :meth:`to_json` wrote, with the stage times ``seconds``."""
        from truthbench.campaign.uncertainty_stage import UncertaintyStage

        d = json.loads(text)
        u = d["uncertainty"]
        if u is not None:
            u = UncertaintyStage(names=tuple(u["names"]), **{
                k: None if u[k] is None else np.asarray(u[k], dtype=t)
                for k, t in _UNCERTAINTY_DTYPES.items()})
        band = d["frf_band"]
        if band is not None:
            band = {**band, "tests": tuple(band["tests"])}
        return cls(
            trial=int(d["trial"]), error=d["error"], seconds=dict(seconds or {}),
            updated=bool(d["updated"]), truth=d["truth"],
            updates={m: r if isinstance(r, str) else
                     {"names": tuple(r["names"]), "initial": np.asarray(r["initial"], float),
                      "values": np.asarray(r["values"], float), "converged": r["converged"]}
                     for m, r in d["updates"].items()},
            accuracy={s: {**{k: np.asarray(a[k], float) for k in _ACCURACY_KEYS},
                          "n_unpaired_truth": int(a["n_unpaired_truth"])}
                      for s, a in d["accuracy"].items()},
            tests=tuple(TestSummary(t["name"], tuple(t["band_hz"]), t["n_averages"],
                                    t["coherence"], t["frf_error_before_pct"],
                                    t["frf_error_after_pct"]) for t in d["tests"]),
            uncertainty=u, frf_band=band)


def _floats(values) -> list[float]:
    return [float(v) for v in np.ravel(values)]


def _band(spec, rec) -> tuple[float, float]:
    """The excited band of a test record: its campaign test's, else its FRF's."""
    for t in spec.tests:
        if t.name == rec.name:
            return tuple(float(v) for v in t.band_hz)
    if rec.frf.band_hz is not None:
        return tuple(float(v) for v in rec.frf.band_hz)
    return (np.nan, np.nan)


def mean_coherence(rec, band_hz) -> float:
    """Mean coherence of a test record over the lines of ``band_hz`` (Hz) and every
    pair; NaN without coherence or lines."""
    if rec.coherence is None:
        return np.nan
    lo, hi = band_hz
    sel = (rec.freq_hz >= lo) & (rec.freq_hz <= hi)
    return float(rec.coherence[sel].mean()) if sel.any() else np.nan


def frf_errors(rec, h_initial, h_updated, mask) -> tuple[float, float]:
    """``100 ||G_D - G_M|| / ||G_D||`` over the update lines ``mask`` of a test record,
    for the model FRFs ``h_initial`` and ``h_updated`` (at the record's lines above
    0 Hz), %."""
    keep = rec.freq_hz > 0
    data = rec.H[mask]
    norm = np.linalg.norm(data)
    return (100 * np.linalg.norm(data - h_initial[mask[keep]]) / norm,
            100 * np.linalg.norm(data - h_updated[mask[keep]]) / norm)


def trial_summary(spec, tr) -> TrialSummary:
    """The :class:`TrialSummary` of a trial (a
    :class:`~truthbench.campaign.results.TrialResult` of a run of ``spec``) that holds
    its FRFs and model FRFs (the trial as run, or as loaded from a file that keeps
    them)."""
    tests = []
    errors = [(np.nan, np.nan)] * len(tr.tests)
    if tr.update is not None and len(tr.H_initial) == len(tr.tests):
        errors = [frf_errors(rec, hi, hu, mask) for rec, hi, hu, mask in
                  zip(tr.tests, tr.H_initial, tr.H_updated, tr.update_mask, strict=True)]
    for rec, (before, after) in zip(tr.tests, errors, strict=True):
        band = _band(spec, rec)
        tests.append(TestSummary(rec.name, band, rec.frf.n_averages,
                                 mean_coherence(rec, band), float(before), float(after)))
    updates = {}
    if tr.update is not None:
        updates = {m: r if isinstance(r, str) else
                   {"names": tuple(r.names), "initial": np.asarray(r.initial, float),
                    "values": np.asarray(r.values, float), "converged": bool(r.converged)}
                   for m, r in tr.comparison.items()}
    b = tr.frf_band
    band = None if b is None else {"tests": tuple(b.tests), "k_sigma": float(b.band.k_sigma),
                                   "n_lines": int(np.sum(b.line_mask)),
                                   "inside": dict(b.inside)}
    return TrialSummary(trial=int(tr.trial), error=tr.error, seconds=dict(tr.seconds),
                        updated=tr.update is not None, truth=dict(tr.truth), updates=updates,
                        accuracy=dict(tr.accuracy), tests=tuple(tests),
                        uncertainty=tr.uncertainty, frf_band=band)
