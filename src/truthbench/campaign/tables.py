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


def _ok(result):
    return [t for t in result.trials if not t.error]


def _updated(result):
    return [t for t in _ok(result) if t.update is not None]


# ---- per-trial tables ------------------------------------------------------------------
PARAMETER_COLUMNS = ("trial", "parameter", "unit", "method", "primary", "nominal", "truth",
                     "updated", "error_before_pct", "error_after_pct", "converged")


def parameters(result):
    """One row per trial, update parameter and updater: ``nominal`` (the starting value),
    ``truth`` (the trial's hardware), ``updated``, relative errors against the truth
    before and after (%), whether the updater converged."""
    primary = (result.spec.update_methods() or [None])[0]
    units = {}
    rows = []
    for tr in _updated(result):
        for method, res in tr.comparison.items():
            if isinstance(res, str):  # that updater failed in this trial
                continue
            for name, x0, x in zip(res.names, res.initial, res.values, strict=True):
                if name not in units:
                    units[name] = parameter_unit(result.spec, name)
                truth = float(tr.truth.get(name, np.nan))
                rows.append((tr.trial, name, units[name], method, method == primary,
                             float(x0), truth, float(x), 100 * (x0 / truth - 1),
                             100 * (x / truth - 1), bool(res.converged)))
    return _df(rows, PARAMETER_COLUMNS)


MODE_COLUMNS = ("trial", "model", "mode", "truth_freq_hz", "freq_error_pct",
                "damping_error_pct", "mac")


def modes(result):
    """One row per trial, model and truth mode (paired by MAC at the sensors,
    :func:`~truthbench.campaign.metrics.modal_accuracy`): ``model`` is ``"initial"`` or
    an updater's name; frequency and damping errors against the truth (%), MAC."""
    rows = []
    for tr in _ok(result):
        for model, acc in tr.accuracy.items():
            if model == "updated":  # the primary updater's, under its own name too
                continue
            for i, (f, fe, de, mac) in enumerate(zip(
                    acc["truth_freq_hz"], acc["freq_error_pct"], acc["damping_error_pct"],
                    acc["mac"], strict=True)):
                rows.append((tr.trial, model, i, float(f), float(fe), float(de), float(mac)))
    return _df(rows, MODE_COLUMNS)


COVERAGE_COLUMNS = ("trial", "test", "parameter", "held_out", "identified", "truth",
                    "lower", "upper", "truth_inside")


def coverage(result):
    """One row per trial, test and bounded modal parameter (``f<k>_hz`` in Hz,
    ``zeta<k>``): the identified and the true value, the bound ``[lower, upper]`` (the
    initial model plus the mean error, -+ the k-sigma bound) and whether the truth lies
    inside it (a NaN truth, a mode not paired, counts as outside)."""
    rows = []
    names = [t.name for t in result.spec.tests]
    for tr in _ok(result):
        u = tr.uncertainty
        if u is None:
            continue
        centre = u.theta_0 + u.mean
        for j in range(u.theta_tests.shape[0]):
            for i, p in enumerate(u.names):
                rows.append((tr.trial, names[j], p, bool(u.holdout[j]),
                             float(u.theta_tests[j, i]), float(u.theta_truth[j, i]),
                             float(centre[i] - u.bound[i]), float(centre[i] + u.bound[i]),
                             bool(u.inside[j, i])))
    return _df(rows, COVERAGE_COLUMNS)


def frf_error(result):
    """One row per trial and test: relative FRF error ``||G_D - G_M|| / ||G_D||`` over
    the test's update lines, of the initial and the updated model (%)."""
    rows = []
    for tr in _updated(result):
        for rec, hi, hu, mask in zip(tr.tests, tr.H_initial, tr.H_updated, tr.update_mask,
                                     strict=True):
            keep = rec.freq_hz > 0
            data = rec.H[mask]
            norm = np.linalg.norm(data)
            rows.append((tr.trial, rec.name,
                         100 * np.linalg.norm(data - hi[mask[keep]]) / norm,
                         100 * np.linalg.norm(data - hu[mask[keep]]) / norm))
    return _df(rows, ("trial", "test", "frf_error_before_pct", "frf_error_after_pct"))


def frf_band(result):
    """One row per trial with an FRF band (:mod:`truthbench.campaign.frf_band_stage`):
    its tests, ``k_sigma``, lines, and the fraction of the initial and updated model
    inside it (NaN without an update)."""
    rows = []
    for tr in _ok(result):
        b = tr.frf_band
        if b is None:
            continue
        rows.append((tr.trial, ", ".join(b.tests), len(b.tests), b.band.k_sigma,
                     int(b.line_mask.sum()), b.inside.get("initial", np.nan),
                     b.inside.get("updated", np.nan)))
    return _df(rows, ("trial", "tests", "n_tests", "k_sigma", "n_lines", "inside_initial",
                      "inside_updated"))


def tests(result):
    """One row per trial and test: the excited band (Hz), the averages of the FRF
    estimate and the mean coherence over the band's lines (all pairs)."""
    bands = {t.name: tuple(t.band_hz) for t in result.spec.tests}
    rows = []
    for tr in _ok(result):
        for rec in tr.tests:
            lo, hi = bands.get(rec.name, rec.frf.band_hz or (np.nan, np.nan))
            sel = (rec.freq_hz >= lo) & (rec.freq_hz <= hi)
            coh = (float(rec.coherence[sel].mean())
                   if rec.coherence is not None and sel.any() else np.nan)
            rows.append((tr.trial, rec.name, lo, hi, rec.frf.n_averages, coh))
    return _df(rows, ("trial", "test", "band_low_hz", "band_high_hz", "n_averages",
                      "mean_coherence_in_band"))


def stage_times(result):
    """One row per trial (failed ones too): wall-clock seconds of every stage
    (:data:`~truthbench.campaign.results.STAGES`) and their total."""
    from truthbench.campaign.results import STAGES

    rows = []
    for tr in result.trials:
        s = [float(tr.seconds.get(k, 0.0)) for k in STAGES]
        rows.append((tr.trial, *s, float(sum(s))))
    return _df(rows, ("trial", *STAGES, "total"))


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
    primary = (result.spec.update_methods() or [None])[0]
    cols = ["truth_freq_hz"] + [f"{s}_{c}" for s in ("initial", "updated")
                                for c in ("freq_error_pct", "damping_error_pct", "mac")]
    found: dict = {}
    for tr in _updated(result):
        for stage, model in (("initial", "initial"), ("updated", primary)):
            acc = tr.accuracy.get(model)
            if acc is None:
                continue
            for f, fe, de, mac in zip(acc["truth_freq_hz"], acc["freq_error_pct"],
                                      acc["damping_error_pct"], acc["mac"], strict=True):
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
    cols = ("method", "parameter_rms_error_pct", "mean_abs_freq_error_pct", "min_mac",
            "failed_trials")
    ok = _updated(result)
    if not ok:
        return _df([], cols)
    methods = list(dict.fromkeys(result.spec.update_methods()
                                 + [m for t in ok for m in t.comparison]))
    rows = []
    for label in ["none", *methods]:
        perr, ferr, macs, fails = [], [], [], 0
        for t in ok:
            if label == "none":
                names, vals, stage = t.update.names, t.update.initial, "initial"
            else:
                res = t.comparison.get(label)
                if res is None or isinstance(res, str):
                    fails += 1
                    continue
                names, vals, stage = res.names, res.values, label
            truth = np.array([t.truth[n] for n in names])
            perr.extend(100 * (np.asarray(vals) / truth - 1))
            acc = t.accuracy.get(stage)
            if acc:
                ferr.extend(np.abs(acc["freq_error_pct"]))
                macs.extend(acc["mac"])
        rows.append((label, float(np.sqrt(np.mean(np.square(perr)))) if perr else np.nan,
                     float(np.mean(ferr)) if ferr else np.nan,
                     float(np.min(macs)) if macs else np.nan, fails))
    return _df(rows, cols)


def uncertainty_summary(result):
    """The first trial's uncertainty model (Eq. 10.46-10.50): per bounded parameter the
    initial model, mean error, standard deviation, bound, and how many building tests
    (identified values) and how many tests' true values (building and held out) lie
    inside it, of ``tests``."""
    cols = ("parameter", "initial_model", "mean_error", "std", "bound", "tests_inside",
            "truth_inside", "tests")
    stages = [t.uncertainty for t in _ok(result) if t.uncertainty is not None]
    if not stages:
        return _df([], cols)
    u = stages[0]
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
