"""Tables of a campaign result (pandas): per-trial records and their summaries.

Two kinds, both reached through :class:`~truthbench.campaign.results.CampaignResult`:

* :func:`table` (``result.to_pandas(name)``): tidy, one row per trial and item (a
  parameter and updater, a mode, a test, a bound entry), no aggregation;
* :func:`summary` (``result.summary(name)``): the aggregations over trials the report
  shows (means, RMS, coverage fractions with intervals).

Column names are snake_case with the unit at the end where a number could be misread
(``error_after_pct``, ``truth_freq_hz``, ``seconds``); columns named ``nominal``,
``truth``, ``updated`` hold values in the unit of their row's ``unit`` column.
Trials that failed (``TrialResult.error``) are left out of every table except
``stage_times``.

Every table comes from one pass over the trials' summaries
(:class:`~truthbench.campaign.summary.TrialSummary`, :class:`Tables`), which a stored
result reads without loading its trials' FRFs: the memory of the tables and of the
report grows with their rows, not with the trials.
"""

from __future__ import annotations

import numpy as np

TABLES = ("parameters", "modes", "methods", "coverage", "uncertainty", "frf_error",
          "frf_band", "tests", "stage_times")
"""Names accepted by :func:`table` and :func:`summary` (``methods`` and ``uncertainty``
are summaries only)."""

_APPENDED_UNITS = {"delay_s": "s", "sensor_gain": "-"}
"""Units of the measurement-chain update parameters
(:data:`truthbench.update.APPENDED_PARAMETERS`)."""


def parameter_unit(spec, name: str) -> str:
    """SI unit of an update parameter (``E_pa`` -> ``"Pa"``, ``E_pa@g2`` -> ``"Pa"``,
    ``delay_s`` -> ``"s"``), or ``""`` when the plant does not know it."""
    if name in _APPENDED_UNITS:
        return _APPENDED_UNITS[name]
    info = spec.make_plant().parameters.get(name.split("@")[0])
    return info.unit if info is not None else ""


def _df(rows, columns):
    import pandas as pd

    return pd.DataFrame(rows, columns=columns)


# ---- per-trial tables, built in one pass over the trials' summaries ---------------------
PARAMETER_COLUMNS = ("trial", "parameter", "unit", "method", "primary", "nominal", "truth",
                     "updated", "error_before_pct", "error_after_pct", "converged")
MODE_COLUMNS = ("trial", "model", "mode", "truth_freq_hz", "freq_error_pct",
                "damping_error_pct", "mac")
COVERAGE_COLUMNS = ("trial", "test", "parameter", "held_out", "identified", "truth",
                    "lower", "upper", "truth_inside")
FRF_ERROR_COLUMNS = ("trial", "test", "frf_error_before_pct", "frf_error_after_pct")
FRF_BAND_COLUMNS = ("trial", "tests", "n_tests", "k_sigma", "n_lines", "inside_initial",
                    "inside_updated")
TEST_COLUMNS = ("trial", "test", "band_low_hz", "band_high_hz", "n_averages",
                "mean_coherence_in_band")


class Tables:
    """The per-trial tables of a result, reduced from its trials' summaries
    (:class:`~truthbench.campaign.summary.TrialSummary`) in one pass: :meth:`add` each
    summary in trial order, then :meth:`frame` gives a table. Memory grows with the
    rows (tens of bytes per number), not with the trials' FRFs.

    Attributes
    ----------
    trials : list of int
        Every trial added, in order.
    failed : list of (int, str)
        The failed trials and their messages.
    updated : list of int
        The trials the primary updater ran in.
    methods : dict
        Every updater name of those trials (keys, in order of appearance).
    stages : list of (int, UncertaintyStage)
        The uncertainty stages of the trials that did not fail.
    first : dict
        The first trial that did not fail (``"ok"``), that updated (``"updated"``), with
        an uncertainty stage (``"uncertainty"``), with an FRF band (``"frf_band"``); None
        where there is none.
    band : dict or None
        The FRF band of the first trial with one (its summary's ``frf_band``).
    """

    def __init__(self, spec):
        self.spec = spec
        self.primary = (spec.update_methods() or [None])[0]
        self.trials: list[int] = []
        self.failed: list[tuple[int, str]] = []
        self.updated: list[int] = []
        self.methods: dict = {}  # every updater name seen, in order
        self.stages: list = []
        self.first = dict.fromkeys(("ok", "updated", "uncertainty", "frf_band"))
        self.band: dict | None = None
        self._rows = {name: [] for name in ("parameters", "modes", "frf_error", "frf_band",
                                             "tests", "stage_times")}
        self._units: dict = {}
        self._names: dict = {}  # one str object per distinct name

    def _name(self, text: str) -> str:
        return self._names.setdefault(text, text)

    def add(self, s) -> None:
        """Reduce one trial's summary into the tables."""
        from truthbench.campaign.results import STAGES

        t = s.trial
        self.trials.append(t)
        secs = [float(s.seconds.get(k, 0.0)) for k in STAGES]
        self._rows["stage_times"].append((t, *secs, float(sum(secs))))
        if s.error:
            self.failed.append((t, s.error))
            return
        self.first["ok"] = t if self.first["ok"] is None else self.first["ok"]
        for rec in s.tests:
            self._rows["tests"].append((t, self._name(rec.name), *rec.band_hz,
                                        rec.n_averages, rec.coherence))
        if s.uncertainty is not None:
            self.stages.append((t, s.uncertainty))
            if self.first["uncertainty"] is None:
                self.first["uncertainty"] = t
        if s.frf_band is not None:
            b = s.frf_band
            if self.first["frf_band"] is None:
                self.band = b
            self._rows["frf_band"].append((t, ", ".join(b["tests"]), len(b["tests"]),
                                           b["k_sigma"], b["n_lines"],
                                           b["inside"].get("initial", np.nan),
                                           b["inside"].get("updated", np.nan)))
            if self.first["frf_band"] is None:
                self.first["frf_band"] = t
        for model, acc in s.accuracy.items():
            if model == "updated":  # the primary updater's, under its own name too
                continue
            model = self._name(model)
            for i, (f, fe, de, mac) in enumerate(zip(
                    acc["truth_freq_hz"], acc["freq_error_pct"], acc["damping_error_pct"],
                    acc["mac"], strict=True)):
                self._rows["modes"].append((t, model, i, float(f), float(fe), float(de),
                                            float(mac)))
        if not s.updated:
            return
        self.updated.append(t)
        self.methods.update(dict.fromkeys(s.updates))
        if self.first["updated"] is None:
            self.first["updated"] = t
        for rec in s.tests:
            self._rows["frf_error"].append((t, self._name(rec.name), rec.frf_error_before_pct,
                                            rec.frf_error_after_pct))
        for method, res in s.updates.items():
            if isinstance(res, str):  # that updater failed in this trial
                continue
            method = self._name(method)
            for name, x0, x in zip(res["names"], res["initial"], res["values"], strict=True):
                if name not in self._units:
                    self._units[name] = parameter_unit(self.spec, name)
                truth = float(s.truth.get(name, np.nan))
                self._rows["parameters"].append(
                    (t, self._name(name), self._units[name], method, method == self.primary,
                     float(x0), truth, float(x), 100 * (x0 / truth - 1),
                     100 * (x / truth - 1), bool(res["converged"])))

    def frame(self, name: str):
        """The per-trial table ``name`` (see :func:`table`) as a new DataFrame."""
        from truthbench.campaign.results import STAGES

        columns = {"parameters": PARAMETER_COLUMNS, "modes": MODE_COLUMNS,
                   "frf_error": FRF_ERROR_COLUMNS, "frf_band": FRF_BAND_COLUMNS,
                   "tests": TEST_COLUMNS, "stage_times": ("trial", *STAGES, "total")}
        if name == "coverage":
            return self._coverage()
        return _df(self._rows[name], columns[name])

    def _coverage(self):
        import pandas as pd

        names = [t.name for t in self.spec.tests]
        parts = []
        for t, u in self.stages:
            n_tests, p = u.theta_tests.shape
            centre = u.theta_0 + u.mean
            parts.append(pd.DataFrame({
                "trial": np.full(n_tests * p, t),
                "test": np.repeat(np.array(names[:n_tests], dtype=object), p),
                "parameter": np.tile(np.array(u.names, dtype=object), n_tests),
                "held_out": np.repeat(np.asarray(u.holdout, bool), p),
                "identified": np.asarray(u.theta_tests, float).ravel(),
                "truth": np.asarray(u.theta_truth, float).ravel(),
                "lower": np.tile(centre - u.bound, n_tests),
                "upper": np.tile(centre + u.bound, n_tests),
                "truth_inside": np.asarray(u.inside, bool).ravel()}))
        if not parts:
            return _df([], COVERAGE_COLUMNS)
        return pd.concat(parts, ignore_index=True)


def tables_of(result, summaries) -> Tables:
    """The :class:`Tables` of ``result`` from its trials' summaries (an iterable, read
    once)."""
    out = Tables(result.spec)
    for s in summaries:
        out.add(s)
    return out


def parameters(result):
    """One row per trial, update parameter and updater: ``nominal`` (the starting value),
    ``truth`` (the trial's hardware), ``updated``, relative errors against the truth
    before and after (%), whether the updater converged."""
    return result.tables.frame("parameters")


def modes(result):
    """One row per trial, model and truth mode (paired by MAC at the sensors,
    :func:`~truthbench.campaign.metrics.modal_accuracy`): ``model`` is ``"initial"`` or
    an updater's name; frequency and damping errors against the truth (%), MAC."""
    return result.tables.frame("modes")


def coverage(result):
    """One row per trial, test and bounded modal parameter (``f<k>_hz`` in Hz,
    ``zeta<k>``): the identified and the true value, the bound ``[lower, upper]`` (the
    initial model plus the mean error, -+ the k-sigma bound) and whether the truth lies
    inside it (a NaN truth, a mode not paired, counts as outside)."""
    return result.tables.frame("coverage")


def frf_error(result):
    """One row per trial and test: relative FRF error ``||G_D - G_M|| / ||G_D||`` over
    the test's update lines, of the initial and the updated model (%)."""
    return result.tables.frame("frf_error")


def frf_band(result):
    """One row per trial with an FRF band (:mod:`truthbench.campaign.frf_band_stage`):
    its tests, ``k_sigma``, lines, and the fraction of the initial and updated model
    inside it (NaN without an update)."""
    return result.tables.frame("frf_band")


def tests(result):
    """One row per trial and test: the excited band (Hz), the averages of the FRF
    estimate and the mean coherence over the band's lines (all pairs)."""
    return result.tables.frame("tests")


def stage_times(result):
    """One row per trial (failed ones too): wall-clock seconds of every stage
    (:data:`~truthbench.campaign.results.STAGES`) and their total."""
    return result.tables.frame("stage_times")


_TABLES = {"parameters": parameters, "modes": modes, "coverage": coverage,
           "frf_error": frf_error, "frf_band": frf_band, "tests": tests,
           "stage_times": stage_times}


def table(result, name: str):
    """The per-trial table ``name`` of ``result``; see the module docstring."""
    if name not in _TABLES:
        raise ValueError(f"unknown table {name!r}; expected one of {', '.join(_TABLES)} "
                         f"(summaries: {', '.join(TABLES)})")
    return _TABLES[name](result)


# ---- summaries over trials -------------------------------------------------------------
def parameters_summary(result):
    """Per updater and parameter, over the updated trials: mean nominal, truth and
    updated value, mean error before and after (%) (the bias) and the RMS error after
    (%); primary updater first."""
    df = parameters(result)
    cols = ("parameter", "unit", "method", "nominal", "truth", "updated", "error_before_pct",
            "error_after_pct", "rms_error_after_pct", "trials")
    if df.empty:
        return _df([], cols)
    rows = []
    for method in dict.fromkeys(result.spec.update_methods() + list(df["method"])):
        part = df[df["method"] == method]
        for name in dict.fromkeys(part["parameter"]):
            p = part[part["parameter"] == name]
            after = p["error_after_pct"].to_numpy()
            rows.append((name, p["unit"].iloc[0], method, p["nominal"].mean(),
                         p["truth"].mean(), p["updated"].mean(), p["error_before_pct"].mean(),
                         after.mean(), float(np.sqrt(np.mean(after**2))), len(p)))
    return _df(rows, cols)


def modes_summary(result):
    """Per truth mode (trials' modes matched to 0.1 Hz): the initial and the updated
    (primary updater's) model's frequency error, damping error (%) and MAC against the
    truth, mean over trials; ``truth_freq_hz`` is the first trial's value."""
    tables = result.tables
    cols = ["truth_freq_hz"] + [f"{s}_{c}" for s in ("initial", "updated")
                                for c in ("freq_error_pct", "damping_error_pct", "mac")]
    df = tables.frame("modes")
    stage_of = {"initial": "initial", tables.primary: "updated"}
    df = df[df["trial"].isin(tables.updated) & df["model"].isin(list(stage_of))]
    found: dict = {}
    for model, f, fe, de, mac in zip(df["model"], df["truth_freq_hz"], df["freq_error_pct"],
                                     df["damping_error_pct"], df["mac"], strict=True):
        stage = stage_of[model]
        r = found.setdefault(round(float(f), 1), {"truth_freq_hz": float(f)})
        r.setdefault(f"{stage}_freq_error_pct", []).append(fe)
        r.setdefault(f"{stage}_damping_error_pct", []).append(de)
        r.setdefault(f"{stage}_mac", []).append(mac)
    rows = []
    for key in sorted(found):
        r = found[key]
        rows.append([r["truth_freq_hz"]] + [float(np.mean(r.get(c, [np.nan])))
                                            for c in cols[1:]])
    return _df(rows, cols)


def methods_summary(result):
    """No update against every updater (campaign order): RMS parameter error against
    the truth (%), mean absolute frequency error (%) and smallest MAC of the modes
    against the truth, over the updated trials, and the trials where the updater
    failed."""
    tables = result.tables
    cols = ("method", "parameter_rms_error_pct", "mean_abs_freq_error_pct", "min_mac",
            "failed_trials")
    if not tables.updated:
        return _df([], cols)
    params = tables.frame("parameters")
    modes = tables.frame("modes")
    modes = modes[modes["trial"].isin(tables.updated)]
    methods = list(dict.fromkeys(result.spec.update_methods() + list(tables.methods)))
    rows = []
    for label in ["none", *methods]:
        if label == "none":
            perr = params.loc[params["method"] == tables.primary, "error_before_pct"]
            model, fails = "initial", 0
        else:
            part = params[params["method"] == label]
            perr = part["error_after_pct"]
            model, fails = label, len(tables.updated) - part["trial"].nunique()
        acc = modes[modes["model"] == model]
        ferr, macs = np.abs(acc["freq_error_pct"].to_numpy()), acc["mac"].to_numpy()
        perr = perr.to_numpy()
        rows.append((label, float(np.sqrt(np.mean(np.square(perr)))) if perr.size else np.nan,
                     float(np.mean(ferr)) if ferr.size else np.nan,
                     float(np.min(macs)) if macs.size else np.nan, fails))
    return _df(rows, cols)


def uncertainty_summary(result):
    """The first trial's uncertainty model (Eq. 10.46-10.50): per bounded parameter the
    initial model, mean error, standard deviation, bound, and how many building tests
    (identified values) and how many tests' true values (building and held out) lie
    inside it, of ``tests``."""
    cols = ("parameter", "initial_model", "mean_error", "std", "bound", "tests_inside",
            "truth_inside", "tests")
    stages = result.tables.stages
    if not stages:
        return _df([], cols)
    u = stages[0][1]
    build = ~np.asarray(u.holdout, bool)
    centre = u.theta_0 + u.mean
    tests_inside = np.sum(np.abs(u.theta_tests[build] - centre) <= u.bound, axis=0)
    truth_inside = np.asarray(u.inside).sum(axis=0)
    rows = [(n, u.theta_0[i], u.mean[i], u.std[i], u.bound[i], int(tests_inside[i]),
             int(truth_inside[i]), len(build)) for i, n in enumerate(u.names)]
    return _df(rows, cols)


def coverage_summary_table(result):
    """Per bounded parameter: truths counted, inside, coverage and its Wilson interval
    (held-out truths, or in-sample ones without held-out tests)
    (:attr:`CoverageSummary.per_parameter
    <truthbench.campaign.coverage.CoverageSummary.per_parameter>`)."""
    cov = result.coverage()
    if cov is None:
        return _df([], ("parameter", "truths", "inside", "coverage", "ci_low", "ci_high"))
    return cov.to_pandas()


def frf_error_summary(result):
    """Per test (campaign order): the relative FRF error over the update lines before
    and after updating (%), mean over trials."""
    df = frf_error(result)
    if df.empty:
        return df.drop(columns="trial")
    out = df.groupby("test", sort=False)[["frf_error_before_pct", "frf_error_after_pct"]]
    return out.mean().reset_index()


def frf_band_summary(result):
    """Over the trials with an FRF band: the mean fraction of the initial and updated
    model inside it, and the trials counted."""
    df = frf_band(result)
    return _df([(len(df), df["inside_initial"].mean() if len(df) else np.nan,
                 df["inside_updated"].mean() if len(df) else np.nan)],
               ("trials", "inside_initial", "inside_updated"))


def tests_summary(result):
    """Per test of the campaign: actuators, level, band (Hz), sampling rate (Hz), record
    (s), averages, window, noise fraction, and the mean coherence in band over the
    trials (NaN when no trial has the test)."""
    coh = tests(result).groupby("test", sort=False)["mean_coherence_in_band"].mean()
    rows = []
    for t in result.spec.tests:
        acts = ", ".join(f"{a.station}.{a.direction}" for a in t.actuators)
        rows.append((t.name, acts, t.level_rms, t.band_hz[0], t.band_hz[1], t.fs_hz,
                     t.record_s, t.averages, t.window, t.noise_fraction,
                     float(coh.get(t.name, np.nan))))
    return _df(rows, ("test", "actuators", "level_rms", "band_low_hz", "band_high_hz",
                      "fs_hz", "record_s", "averages", "window", "noise_fraction",
                      "mean_coherence_in_band"))


def stage_times_summary(result):
    """Per stage: seconds summed over trials (worker time), mean per trial and share of
    the total (%)."""
    from truthbench.campaign.results import STAGES

    df = stage_times(result)
    total = float(df["total"].sum()) if len(df) else 0.0
    rows = [(k, float(df[k].sum()), float(df[k].mean()) if len(df) else np.nan,
             100 * float(df[k].sum()) / total if total > 0 else np.nan) for k in STAGES]
    return _df(rows, ("stage", "seconds", "mean_per_trial_s", "share_pct"))


_SUMMARIES = {"parameters": parameters_summary, "modes": modes_summary,
              "methods": methods_summary, "coverage": coverage_summary_table,
              "uncertainty": uncertainty_summary, "frf_error": frf_error_summary,
              "frf_band": frf_band_summary, "tests": tests_summary,
              "stage_times": stage_times_summary}


def summary(result, name: str):
    """The summary over trials ``name`` of ``result``; see the module docstring."""
    if name not in _SUMMARIES:
        raise ValueError(f"unknown summary {name!r}; expected one of {', '.join(_SUMMARIES)}")
    return _SUMMARIES[name](result)
