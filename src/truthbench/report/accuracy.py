"""The accuracy report: ``report.md``, ``report.html`` and figures from a
:class:`~truthbench.campaign.results.CampaignResult`.

Formatting only: every number comes from the result object (its summaries,
:mod:`truthbench.campaign.tables`; its coverage, :mod:`truthbench.campaign.coverage`;
its stages) and every figure from :meth:`CampaignResult.plot
<truthbench.campaign.results.CampaignResult.plot>`; nothing here reruns numerics.
Numbers are rounded to what they mean (4 significant digits, percentages to 0.01,
MAC to 4 decimals, parameter values with an SI prefix on their unit).

Figures written beside ``report.md``: ``frf_<test>.png`` (one per test of the first
completed trial: data against the initial and updated model, magnitude, phase and
coherence per output), ``poles.png`` (Figure 10.6, one panel per mode),
``frf_band.png`` (the FRF-domain band), ``calibration.png`` (held-out coverage
against k) and ``convergence.png`` (the coverage and error statistics against the number
of trials, from :data:`CONVERGENCE_MIN_TRIALS` trials), the last four when the campaign
has what they show.
"""

from __future__ import annotations

import re
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from truthbench.report import format as fmt

CHAPTER = ('"Modeling: Limitations and Realities", a draft textbook chapter of 1998')
"""The source of the method whose equation, table and figure numbers the report cites."""


def figure_name(test: str) -> str:
    """The file name of a test's FRF figure: ``frf_<test>.png``, characters other than
    letters, digits, ``.``, ``_`` and ``-`` replaced by ``_``."""
    return "frf_" + re.sub(r"[^A-Za-z0-9_.-]", "_", test) + ".png"


def _save(fig, path: Path) -> str:
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name


def _names(items) -> str:
    items = [f"`{x}`" for x in items]
    if len(items) <= 1:
        return "".join(items) or "none"
    return ", ".join(items[:-1]) + " and " + items[-1]


def _given(v) -> str:
    """A value of the campaign file, as given."""
    return f"{v:g}"


def _input_unit(test) -> str:
    rot = {a.direction in ("rx", "ry", "rz") for a in test.actuators}
    return " / ".join(u for flag, u in ((False, "N"), (True, "N m")) if flag in rot)


# ---- sections ------------------------------------------------------------------------
def _header(result, results_path) -> list[str]:
    spec = result.spec
    n_failed = len(result.tables.failed)
    n_updated = len(result.tables.updated)
    done = (f"{n_updated} updated" if spec.update_methods()
            else f"{len(result.trials) - n_failed} completed")
    written = result.created_utc or datetime.now(UTC).isoformat(timespec="seconds")
    lines = [f"# truthbench accuracy report: {spec.campaign.name}", ""]
    if spec.campaign.description:
        lines += [spec.campaign.description, ""]
    lines += [f"- campaign file: `{spec.source}`",
              f"- seed: {result.seed}; trials: {len(result.trials)} ({done}, "
              f"{n_failed} failed)",
              f"- truthbench {result.version}; results written {written}"]
    path = results_path or result.path
    if path:
        lines.append(f"- results: `{path}`")
    if result.injected:
        lines.append(f"- a single test of trial {result.trials[0].trial}, injected effects: "
                     + ", ".join(f"`{x}`" for x in result.injected))
    lines += ["", f"Equation, table and figure numbers (Eq. 10.46-10.50, Figure 10.6) are "
                  f"those of {CHAPTER}, the method this benchmark implements.", ""]
    return lines


def _tests_section(result) -> list[str]:
    df = result.summary("tests")
    units = {t.name: _input_unit(t) for t in result.spec.tests}
    df = df.assign(level=[f"{v:g} {units[n]}" for n, v in zip(df["test"],
                                                                        df["level_rms"],
                                                                        strict=True)],
                   band=[f"{lo:g}-{hi:g}" for lo, hi in zip(df["band_low_hz"],
                                                            df["band_high_hz"], strict=True)])
    table = fmt.table(df, [
        ("test", "test", str), ("actuators", "actuators", str),
        ("level", "level RMS", str), ("band", "band [Hz]", str),
        ("fs_hz", "fs [Hz]", _given), ("record_s", "record [s]", _given),
        ("averages", "averages", fmt.integer), ("window", "window", str),
        ("noise_fraction", "noise / signal", _given),
        ("mean_coherence_in_band", "mean coherence in band", fmt.fixed(4))])
    return ["## Tests", "", fmt.markdown(table)]


def _parameter_table(result):
    """The parameter summary as strings under their headers (for the report and the
    command line)."""
    df = result.summary("parameters")
    if df.empty:
        return None
    rows = []
    for _, r in df.iterrows():
        scale, unit = fmt.si_scale([r["nominal"], r["truth"], r["updated"]], r["unit"])
        rows.append({**r.to_dict(), "unit": unit or "-",
                     **{k: r[k] / scale for k in ("nominal", "truth", "updated")}})
    import pandas as pd

    df = pd.DataFrame(rows)
    cols = [("parameter", "parameter", str), ("unit", "unit", str)]
    if df["method"].nunique() > 1:
        cols.append(("method", "updater", str))
    cols += [("nominal", "nominal", fmt.sig), ("truth", "truth", fmt.sig),
             ("updated", "updated", fmt.sig),
             ("error_before_pct", "error before [%]", fmt.pct),
             ("error_after_pct", "error after [%]", fmt.pct)]
    if df["trials"].max() > 1:
        cols.append(("rms_error_after_pct", "RMS error after [%]", fmt.pct))
    return fmt.table(df, cols)


def parameter_text(result) -> str:
    """The parameter table as plain text (what ``truthbench run`` prints), or ``""``
    when no trial updated."""
    table = _parameter_table(result)
    return "" if table is None else table.to_string(index=False)


def _update_details(result) -> list[str]:
    trial = result.trial(result.tables.first["updated"])
    u = trial.update
    sv = ", ".join(fmt.sig(s, 3) for s in u.singular_values)
    text = (f"Trial {trial.trial}, `{u.method}`: {u.n_iterations} iterations, "
            f"{'converged' if u.converged else 'did not converge'}; cost "
            f"{fmt.sig(u.cost_history[0])} -> {fmt.sig(u.cost_history[-1])}; singular "
            f"values of the weighted sensitivity matrix {sv} (condition number "
            f"{fmt.sig(u.condition_number)})")
    corr = np.asarray(u.correlation)
    if corr.shape[0] > 1:
        off = np.abs(corr - np.diag(np.diag(corr))).max()
        text += f"; largest parameter correlation (from (S^T S)^-1) {off:.4f}"
    return [text + ".", ""]


def _parameters_section(result) -> list[str]:
    table = _parameter_table(result)
    if table is None:
        return []
    spec = result.spec
    methods = spec.update_methods()
    n = len(result.tables.updated)
    over = ("" if n == 1 else f" Values and errors are means over {n} trials (the bias); "
                              f"the RMS error is over trials.")
    lines = ["## Parameter errors before and after updating", "",
             f"Updaters: {_names(methods)}" + (" (the first is the primary)"
                                                if len(methods) > 1 else "")
             + f"; updated parameters: {_names(spec.update.parameters)}; weighting of the "
               f"FRF residual: {spec.update.weighting}. Errors are relative to the known "
               f"truth.{over}", "", fmt.markdown(table)]
    lines += _update_details(result)
    worst = result.summary("parameters")
    worst = worst[worst["method"] == result.primary_method]["error_after_pct"].abs().max()
    noise = max((t.noise_fraction for t in spec.tests), default=0.0)
    lines += [f"The largest remaining parameter error of the primary updater is "
              f"{fmt.pct(worst)} % (sensor noise up to {100 * noise:g} % of the signal "
              f"standard deviation; noise, FRF estimation bias near resonances and finite "
              f"record length all contribute, so this is the method's accuracy on this "
              f"campaign, not an exact recovery).", ""]
    return lines


def _modes_section(result) -> list[str]:
    df = result.summary("modes")
    if df.empty:
        return []
    mac = fmt.fixed(4)
    table = fmt.table(df, [
        ("truth_freq_hz", "truth mode [Hz]", fmt.sig),
        ("initial_freq_error_pct", "initial: frequency error [%]", fmt.pct),
        ("initial_damping_error_pct", "initial: damping error [%]", fmt.pct),
        ("initial_mac", "initial: MAC", mac),
        ("updated_freq_error_pct", "updated: frequency error [%]", fmt.pct),
        ("updated_damping_error_pct", "updated: damping error [%]", fmt.pct),
        ("updated_mac", "updated: MAC", mac)])
    return ["## Modes of the initial and updated model against the truth", "",
            "Truth modes inside the update band that the sensors see, paired by MAC at the "
            "sensors (mean over trials); \"updated\" is the primary updater's model.", "",
            fmt.markdown(table)]


def _methods_section(result) -> list[str]:
    df = result.summary("methods")
    if df.empty:
        return []
    table = fmt.table(df, [
        ("method", "updater", str),
        ("parameter_rms_error_pct", "parameter RMS error [%]", fmt.pct),
        ("mean_abs_freq_error_pct", "mean abs. frequency error [%]", fmt.pct),
        ("min_mac", "smallest MAC", fmt.fixed(4)),
        ("failed_trials", "failed trials", fmt.integer)])
    return ["## Updating methods side by side", "",
            "Against the known truth: no update (\"none\"), then every updater of the "
            "campaign, over the updated trials.", "", fmt.markdown(table)]


def _uncertainty_section(result, out: Path) -> list[str]:
    df = result.summary("uncertainty")
    if df.empty:
        return []
    cov = result.coverage()
    k = cov.k_sigma
    units = ["Hz" if p.endswith("_hz") else "-" for p in df["parameter"]]
    table = fmt.table(df.assign(unit=units), [
        ("parameter", "parameter", str), ("unit", "unit", str),
        ("initial_model", "initial model", fmt.sig), ("mean_error", "mean error", fmt.sig),
        ("std", "std", fmt.sig), ("bound", f"{k:g}-sigma bound", fmt.sig),
        ("tests_inside", "tests inside", fmt.integer),
        ("truth_inside", "truths inside", fmt.integer), ("tests", "tests", fmt.integer)])
    lines = ["## Uncertainty model (Eq. 10.46-10.50)", "",
             f"Identified per-test frequencies and damping ratios minus the initial model; "
             f"mean error and {k:g}-sigma bound from the {cov.n_build} building tests "
             f"(first trial). \"tests inside\" counts the building tests' identified values "
             f"inside the bound, \"truths inside\" the tests (building and held out) whose "
             f"true modal parameters lie inside it.", "", fmt.markdown(table)]
    c = cov.in_sample
    ci = (f"; 95 % interval {c.ci_low:.3f}-{c.ci_high:.3f}, clustered by trial"
          if cov.n_trials > 1 else "")
    expect = ("" if cov.in_sample_expected is None else
              f"; a normal population predicts {cov.in_sample_expected:.3f} for identified "
              f"values, since a test that builds the bound is inside it almost by "
              f"construction")
    lines += [f"In-sample coverage over {cov.n_trials} trial(s): {c.n_inside} of "
              f"{c.n_total} true parameters of the building tests inside their bound "
              f"({c.fraction:.3f}{ci}){expect}.", ""]
    if cov.holdout is not None:
        h = cov.holdout
        agrees = "inside" if h.agrees_with(cov.holdout_expected) else "OUTSIDE"
        lines += [f"**Held-out coverage** (the bound's calibration): {h.n_inside} of "
                  f"{h.n_total} true parameters of held-out tests inside the bound "
                  f"({h.fraction:.3f}, 95 % interval {h.ci_low:.3f}-{h.ci_high:.3f}); a "
                  f"normal population with its variance estimated from {cov.n_build} tests "
                  f"predicts {cov.holdout_expected:.3f} (Student-t; {agrees} the interval). "
                  f"The parameters of one trial move together, so the interval is "
                  f"clustered by trial; per parameter (Wilson intervals, trials "
                  f"independent):", ""]
        per = cov.to_pandas()
        per = per.assign(interval=[f"{100 * lo:.1f}-{100 * hi:.1f}" for lo, hi in
                                   zip(per["ci_low"], per["ci_high"], strict=True)])
        lines.append(fmt.markdown(fmt.table(per, [
            ("parameter", "parameter", str), ("truths", "truths", fmt.integer),
            ("inside", "inside", fmt.integer),
            ("coverage", "coverage [%]", lambda v: fmt.pct(100 * v, 1)),
            ("interval", "95 % interval [%]", str)])))
        lines += ["A shortfall means the truth varies in ways the tests do not sample, or "
                  "the identification is biased (the bound is built from identified values, "
                  "the truth is not).", ""]
        if cov.calibration is not None:
            name = _save(cov.plot(), out / "calibration.png")
            lines += [f"![Calibration of the bound: held-out coverage against k]({name})", ""]
    trial = result.trial(result.tables.first["uncertainty"])
    name = _save(result.plot("poles", trial=trial.trial), out / "poles.png")
    held = "; held-out tests filled" if np.any(trial.uncertainty.holdout) else ""
    lines += [f"Poles of trial {trial.trial}'s tests with the {k:g}-sigma bound, one panel "
              f"per mode (Figure 10.6{held}):", "",
              f"![Pole plot (Figure 10.6)]({name})", ""]
    return lines


def _frf_band_section(result, out: Path) -> list[str]:
    first = result.tables.first["frf_band"]
    if first is None:
        return []
    b = result.tables.band
    lines = ["## FRF-domain uncertainty model", "",
             f"Mean FRF and {b['k_sigma']:g}-sigma band (covariance of real and imaginary "
             f"parts, line by line) over trial {first}'s tests {_names(b['tests'])}, "
             f"which share input, outputs and lines."]
    for which, frac in b["inside"].items():
        lines.append(f"The {which} model lies inside the band at {100 * frac:.1f} % of the "
                     f"lines and pairs.")
    s = result.summary("frf_band")
    n = int(s["trials"].iloc[0])
    if n > 1:
        lines.append(f"Over {n} trials the mean fractions are "
                     f"{100 * s['inside_initial'].iloc[0]:.1f} % (initial) and "
                     f"{100 * s['inside_updated'].iloc[0]:.1f} % (updated).")
    if result.trial(first).frf_band is None:
        return lines + [_KEPT_NOTE, ""]
    name = _save(result.plot("frf_band", trial=first), out / "frf_band.png")
    return lines + ["", f"![FRF band]({name})", ""]


_KEPT_NOTE = ("(The figure needs the trial's FRFs, which the campaign keeps for trial 0 only: "
              "`[output] frfs`.)")


def _frf_error_section(result) -> list[str]:
    df = result.summary("frf_error")
    if df.empty:
        return []
    table = fmt.table(df, [("test", "test", str),
                           ("frf_error_before_pct", "FRF error before [%]", fmt.pct),
                           ("frf_error_after_pct", "FRF error after [%]", fmt.pct)])
    return ["## FRF error over the update band", "",
            "Relative FRF error (norm of data minus model over norm of data) over each "
            "test's update lines, mean over trials.", "",
            fmt.markdown(table)]


CONVERGENCE_MIN_TRIALS = 20
"""Trials (with an uncertainty stage or an update) from which the report shows the
convergence of its statistics with the trial count."""


def _convergence_section(result, out: Path) -> list[str]:
    tables = result.tables
    if max(len(tables.stages), len(tables.updated)) < CONVERGENCE_MIN_TRIALS:
        return []
    from truthbench.campaign.convergence import convergence

    c = convergence(result)
    level = f"{100 * c.confidence:g} %"
    lines = ["## Convergence with the number of trials", "",
             f"Each statistic over the first n trials, for n up to all of them, with its "
             f"{level} interval: a curve that has flattened inside its band (which narrows "
             f"as 1/sqrt(n)) has enough trials."]
    if c.coverage is not None:
        p, lo, hi = c.coverage[-1]
        expect = "" if c.expected is None else f"; normal theory {c.expected:.3f}"
        lines.append(f"Coverage of the {c.coverage_of} truths after {c.trials[-1]} trials: "
                     f"{p:.3f} ({level} interval {lo:.3f}-{hi:.3f}{expect}).")
        if c.modes:
            last = c.identification[-1]
            lines.append("Mean identified frequency error against the truth: "
                         + "; ".join(f"{name} {fmt.sig(last[0, k])} % "
                                     f"({fmt.sig(last[1, k])} to {fmt.sig(last[2, k])})"
                                     for k, name in enumerate(c.modes)) + ".")
    if c.parameter_error is not None:
        last = c.parameter_error[-1]
        lines.append(f"Parameter error after `{result.primary_method}` over "
                     f"{c.parameter_trials[-1]} trials, mean (interval) and RMS: "
                     + "; ".join(f"{name} {fmt.sig(last[0, k])} % ({fmt.sig(last[1, k])} to "
                                 f"{fmt.sig(last[2, k])}), RMS "
                                 f"{fmt.sig(c.parameter_rms[-1, k])} %"
                                 for k, name in enumerate(c.parameters)) + ".")
    name = _save(result.plot("convergence"), out / "convergence.png")
    return lines + ["", f"![Convergence with the number of trials]({name})", ""]


def _failed_section(result) -> list[str]:
    failed = result.tables.failed
    if not failed:
        return []
    return (["## Failed trials", ""]
            + [f"- trial {t}: {error.splitlines()[0]}" for t, error in failed] + [""])


def _times_section(result) -> list[str]:
    df = result.summary("stage_times")
    if not df["seconds"].sum() > 0:
        return []
    table = fmt.table(df, [("stage", "stage", str), ("seconds", "seconds", fmt.sig),
                           ("share_pct", "share [%]", lambda v: fmt.pct(v, 1))])
    return ["## Time per stage", "",
            "Wall-clock seconds summed over trials (worker time).", "", fmt.markdown(table)]


def _frf_figures(result, out: Path) -> list[str]:
    if not len(result.trials):
        return []
    trial = result.trial()  # the first that did not fail, else the first
    if not trial.tests:
        return []
    if not trial.tests[0].freq_hz.size:
        return ["## FRFs of the tests", "", _KEPT_NOTE, ""]
    what = ("data against the initial and updated model"
            if trial.H_initial else "the measured FRFs")
    lines = ["## FRFs of the tests", "",
             f"Trial {trial.trial}, {what}: magnitude, phase and coherence per output, "
             f"over each test's excited band (update lines shaded).", ""]
    for rec in trial.tests:
        name = _save(result.plot("frf", trial=trial.trial, test=rec.name),
                     out / figure_name(rec.name))
        lines += [f"### {rec.name}", "", f"![FRFs of {rec.name}]({name})", ""]
    return lines


def write_report(result, out_dir: str | Path, *, results_path: str | Path | None = None
                 ) -> Path:
    """Write ``report.md``, ``report.html`` and the figures of a campaign result.

    Parameters
    ----------
    result : CampaignResult
        In memory (``truthbench run``) or loaded (:meth:`CampaignResult.load
        <truthbench.campaign.results.CampaignResult.load>`).
    out_dir : str or Path
        Created if missing.
    results_path : str or Path, optional
        The results file to name in the header (default ``result.path``).

    Returns
    -------
    Path
        ``report.md``.
    """
    import matplotlib

    matplotlib.use("Agg")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    lines = _header(result, results_path)
    lines += _tests_section(result)
    lines += _parameters_section(result)
    lines += _modes_section(result)
    lines += _methods_section(result)
    lines += _uncertainty_section(result, out)
    lines += _frf_band_section(result, out)
    lines += _frf_error_section(result)
    lines += _convergence_section(result, out)
    lines += _failed_section(result)
    lines += _times_section(result)
    lines += _frf_figures(result, out)
    path = out / "report.md"
    path.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")
    from truthbench.report.html import write_html

    write_html(path)
    return path
