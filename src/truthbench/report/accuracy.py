"""The accuracy report: tables and figures from a results file (never reruns numerics).

:func:`parameter_table` and :func:`frf_error_table` return pandas DataFrames;
:func:`write_report` writes ``report.md`` and ``frf.png`` beside each other.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _trials(results: dict) -> list[tuple[str, dict]]:
    return sorted(results.get("trials", {}).items(), key=lambda kv: kv[0]) \
        if "trials" in results else []


def _ok_trials(results):
    return [(k, t) for k, t in _trials(results) if k != "attrs"
            and t["attrs"].get("status") == "ok" and "update" in t]


def parameter_table(results: dict):
    """Per updated parameter: nominal, truth, updated (trial mean), relative errors.

    With several trials the errors are the bias (mean) and RMS over trials, in %.
    """
    import pandas as pd

    rows = []
    ok = _ok_trials(results)
    if not ok:
        return pd.DataFrame()
    names = [n.decode() if isinstance(n, bytes) else n for n in ok[0][1]["update"]["names"]]
    for i, name in enumerate(names):
        truth = np.array([t["truth"]["attrs"][name] for _, t in ok])
        initial = np.array([t["update"]["initial"][i] for _, t in ok])
        updated = np.array([t["update"]["values"][i] for _, t in ok])
        before = 100 * (initial / truth - 1)
        after = 100 * (updated / truth - 1)
        rows.append({
            "parameter": name, "nominal": initial.mean(), "truth": truth.mean(),
            "updated": updated.mean(),
            "error before [%]": before.mean(), "error after [%]": after.mean(),
            "RMS error after [%]": np.sqrt(np.mean(after**2)),
        })
    return pd.DataFrame(rows)


def frf_error_table(results: dict):
    """Relative FRF error ``||G_D - G_M|| / ||G_D||`` over each test's update band,
    before and after updating (mean over trials)."""
    import pandas as pd

    rows = {}
    for _, t in _ok_trials(results):
        for name, m in t["model"].items():
            if name == "attrs":
                continue
            rec = t["tests"][name]
            mask = m["update_mask"]
            data = rec["H"][mask]
            keep = rec["freq_hz"] > 0
            hi, hu = m["H_initial"][mask[keep]], m["H_updated"][mask[keep]]
            norm = np.linalg.norm(data)
            r = rows.setdefault(name, {"test": name, "before": [], "after": []})
            r["before"].append(np.linalg.norm(data - hi) / norm)
            r["after"].append(np.linalg.norm(data - hu) / norm)
    return pd.DataFrame([{"test": r["test"],
                          "FRF error before [%]": 100 * np.mean(r["before"]),
                          "FRF error after [%]": 100 * np.mean(r["after"])}
                         for r in rows.values()])


def modal_accuracy_table(results: dict):
    """Per truth mode (paired at the sensors): frequency error, damping error and MAC of
    the initial and the updated model against the truth; mean over trials (and RMS of the
    frequency error)."""
    import pandas as pd

    rows = {}
    for _, t in _ok_trials(results):
        acc = t.get("accuracy")
        if not acc:
            continue
        for stage in ("initial", "updated"):
            a = acc[stage]
            for f, fe, de, mac in zip(a["truth_freq_hz"], a["freq_error_pct"],
                                      a["damping_error_pct"], a["mac"], strict=True):
                key = round(float(f), 1)
                r = rows.setdefault(key, {"truth mode [Hz]": float(f)})
                r.setdefault(f"{stage} freq err [%]", []).append(fe)
                r.setdefault(f"{stage} damping err [%]", []).append(de)
                r.setdefault(f"{stage} MAC", []).append(mac)
    out = []
    for key in sorted(rows):
        r = rows[key]
        row = {"truth mode [Hz]": r["truth mode [Hz]"]}
        for stage in ("initial", "updated"):
            for col in ("freq err [%]", "damping err [%]", "MAC"):
                values = r.get(f"{stage} {col}", [np.nan])
                row[f"{stage} {col}"] = float(np.mean(values))
        out.append(row)
    return pd.DataFrame(out)


def method_comparison_table(results: dict):
    """No update against every updater: parameter RMS error against the truth (%),
    mean absolute frequency error and smallest MAC of the modes against the truth, over
    trials."""
    import pandas as pd

    ok = _ok_trials(results)
    if not ok:
        return pd.DataFrame()
    methods = sorted({m for _, t in ok for m in t.get("updates", {}) if m != "attrs"})
    rows = []
    for label in ["none", *methods]:
        perr, ferr, macs, fails = [], [], [], 0
        for _, t in ok:
            stage = "initial" if label == "none" else label
            if label != "none":
                u = t["updates"][label]
                if "values" not in u:
                    fails += 1
                    continue
                names = [n.decode() if isinstance(n, bytes) else n for n in u["names"]]
                vals = u["values"]
            else:
                u = t["update"]
                names = [n.decode() if isinstance(n, bytes) else n for n in u["names"]]
                vals = u["initial"]
            truth = np.array([t["truth"]["attrs"][n] for n in names])
            perr.extend(100 * (vals / truth - 1))
            acc = t.get("accuracy", {}).get(stage)
            if acc:
                ferr.extend(np.abs(acc["freq_error_pct"]))
                macs.extend(acc["mac"])
        rows.append({"method": label,
                     "parameter RMS error [%]": float(np.sqrt(np.mean(np.square(perr))))
                     if perr else np.nan,
                     "mean |freq error| [%]": float(np.mean(ferr)) if ferr else np.nan,
                     "min MAC": float(np.min(macs)) if macs else np.nan,
                     "failed trials": fails})
    return pd.DataFrame(rows)


def uncertainty_table(results: dict):
    """The first trial's uncertainty model (Eq. 10.46-10.50): per parameter the initial
    model, mean error, standard deviation, bound, and how many building tests and true
    per-test values lie inside it (empty DataFrame when no trial has one)."""
    import pandas as pd

    trials = [(k, t) for k, t in _trials(results) if k != "attrs" and "uncertainty" in t]
    if not trials:
        return pd.DataFrame()
    u = trials[0][1]["uncertainty"]
    names = [n.decode() if isinstance(n, bytes) else n for n in u["names"]]
    build = ~np.asarray(u.get("holdout", np.zeros(u["theta_tests"].shape[0], bool)), bool)
    centre = u["theta_0"] + u["mean"]
    return pd.DataFrame({
        "parameter": names, "initial model": u["theta_0"], "mean error": u["mean"],
        "std": u["std"], "bound": u["bound"],
        "tests inside": np.sum(np.abs(u["theta_tests"][build] - centre) <= u["bound"],
                               axis=0),
        "truth inside": u["inside"].sum(axis=0), "tests": len(build)})


def plot_frfs(results: dict, path: Path, max_outputs: int = 3) -> Path | None:
    """Data against the initial and updated model FRFs (first trial, first input)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = _ok_trials(results)
    if not ok:
        return None
    _, t = ok[0]
    tests = [k for k in t["model"] if k != "attrs"]
    n_out = min(max_outputs, max(t["tests"][k]["H"].shape[1] for k in tests))
    fig, axes = plt.subplots(n_out, len(tests), figsize=(5.5 * len(tests), 2.6 * n_out),
                             squeeze=False, sharex="col")
    bands = {x["name"]: x["band_hz"] for x in results["attrs"]["spec"]["tests"]}
    for c, name in enumerate(tests):
        rec, m = t["tests"][name], t["model"][name]
        keep = rec["freq_hz"] > 0
        f = rec["freq_hz"][keep]
        lo, hi = bands.get(name, (f[0], f[-1]))
        excited = (f >= lo) & (f <= hi)  # H1 is meaningless outside the excitation band
        labels = rec["attrs"]["output_labels"]
        inputs = rec["attrs"]["input_labels"]
        for r in range(min(n_out, rec["H"].shape[1])):
            ax = axes[r, c]
            ax.semilogy(f[excited], np.abs(rec["H"][keep, r, 0][excited]), color="0.6", lw=1.2,
                        label="data (H1)")
            ax.semilogy(f, np.abs(m["H_initial"][:, r, 0]), "C3--", lw=1, label="initial model")
            ax.semilogy(f, np.abs(m["H_updated"][:, r, 0]), "C0", lw=1, label="updated model")
            band = f[m["update_mask"][keep]]
            if band.size:
                ax.axvspan(band.min(), band.max(), color="C2", alpha=0.05)
            ax.set_ylabel(f"|{labels[r]} / {inputs[0]}|")
            ax.set_xlim(0, hi)
            if r == 0:
                ax.set_title(name)
        axes[-1, c].set_xlabel("frequency [Hz]")
    axes[0, 0].legend(loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_poles(results: dict, path: Path) -> Path | None:
    """Figure 10.6 for the first trial: per-test poles, mean, bound, initial and updated
    model (identified modes paired with the initial model)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from truthbench.uncertainty.plots import plot_pole_bound

    trials = [(k, t) for k, t in _trials(results) if k != "attrs" and "uncertainty" in t]
    if not trials:
        return None
    _, t = trials[0]
    u = t["uncertainty"]
    k = u["theta_tests"].shape[1] // 2
    kw = {}
    if "theta_updated" in u:
        kw = {"freq_hz_updated": u["theta_updated"][:k], "damping_updated": u["theta_updated"][k:]}
    fig = plot_pole_bound(u["theta_tests"][:, :k], u["theta_tests"][:, k:],
                          freq_hz_fem=u["theta_0"][:k], damping_fem=u["theta_0"][k:], **kw)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _md_table(df) -> str:
    if df.empty:
        return "(none)\n"
    cols = list(df.columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for _, row in df.iterrows():
        cells = []
        for c in cols:
            v = row[c]
            cells.append(f"{v:.6g}" if isinstance(v, float | np.floating) else str(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _frf_band_section(results: dict, out: Path) -> list[str]:
    from truthbench.report.frf_band import frf_band, plot_frf_band

    fb = frf_band(results)
    if fb is None:
        return []
    lines = ["## FRF-domain uncertainty model", "",
             f"Mean FRF and {fb.band.k_sigma:g}-sigma band (covariance of real and imaginary "
             f"parts, line by line) over the first trial's tests {', '.join(fb.tests)}, "
             f"which share input, outputs and lines."]
    for which, frac in fb.inside.items():
        lines.append(f"The {which} model lies inside the band at {100 * frac:.1f} % of the "
                     f"lines and pairs.")
    png = plot_frf_band(fb, out / "frf_band.png")
    return lines + ["", f"![FRF band]({png.name})", ""]


def _uncertainty_section(results: dict, utab, out: Path) -> list[str]:
    from truthbench.report.coverage import coverage_summary, plot_calibration_figure

    cov = coverage_summary(results)
    k = cov.k_sigma
    lines = ["## Uncertainty model (Eq. 10.46-10.50)", "",
             f"Identified per-test frequencies and damping ratios minus the initial model; "
             f"mean error and {k:g}-sigma bound from the {cov.n_build} building tests "
             f"(first trial). 'truth inside' counts the tests (building and held out) "
             f"whose true modal parameters lie inside the bound.", ""]
    lines.append(_md_table(utab))
    c = cov.in_sample
    expect = ("" if cov.in_sample_expected is None else
              f"; a normal population predicts {cov.in_sample_expected:.4f} for identified "
              f"values, since a test that builds the bound is inside it almost by "
              f"construction")
    ci = (f" (95 % interval {c.ci_low:.4f}-{c.ci_high:.4f}, clustered by trial)"
          if cov.n_trials > 1 else "")
    lines += ["", f"In-sample coverage over {cov.n_trials} trial(s): {c.fraction:.4f} of "
                  f"{c.n_total} true parameters of the building tests inside their bound"
                  f"{ci}{expect}.", ""]
    if cov.holdout is not None:
        h = cov.holdout
        lines += [f"**Held-out coverage** (the bound's calibration): {h.fraction:.4f} of "
                  f"{h.n_total} true parameters of held-out tests inside the bound (95 % "
                  f"interval {h.ci_low:.4f}-{h.ci_high:.4f}); a normal population with "
                  f"its variance estimated from {cov.n_build} tests predicts "
                  f"{cov.holdout_expected:.4f} (Student-t; "
                  f"{'inside' if h.agrees_with(cov.holdout_expected) else 'OUTSIDE'} the "
                  f"interval). The parameters of one trial move together, so the "
                  f"interval is clustered by trial; per parameter (Wilson intervals, trials "
                  f"independent):", ""]
        lines.append(_md_table(cov.per_parameter))
        lines += ["A shortfall means the truth varies in ways the tests do not sample, or "
                  "the identification is biased (the bound is built from identified values, "
                  "the truth is not).", ""]
        png = plot_calibration_figure(cov, out / "calibration.png")
        if png is not None:
            lines += ["![Calibration of the bound](calibration.png)", ""]
    png = plot_poles(results, out / "poles.png")
    if png is not None:
        lines += ["![Pole plot (Figure 10.6)](poles.png)", ""]
    return lines


def write_report(results: dict, out_dir: str | Path) -> Path:
    """Write ``report.md`` and ``frf.png`` for a results file read by
    :func:`~truthbench.campaign.store.read_results`."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    a = results["attrs"]
    spec = a["spec"]
    trials = [(k, t) for k, t in _trials(results) if k != "attrs"]
    failed = [(k, t) for k, t in trials if t["attrs"].get("status") != "ok"]
    ok = _ok_trials(results)
    lines = [f"# truthbench accuracy report: {a['campaign']}", ""]
    if spec["campaign"].get("description"):
        lines += [spec["campaign"]["description"], ""]
    lines += [f"- campaign file: `{a.get('source', '')}`",
              f"- seed: {a['seed']}; trials: {len(trials)} ({len(ok)} updated, "
              f"{len(failed)} failed)",
              f"- truthbench {a['truthbench_version']}, written {a['created_utc']}",
              f"- results: `{results.get('path', '')}`", ""]

    lines += ["## Tests", "",
              "| test | actuators | level RMS | band [Hz] | fs [Hz] | record [s] | averages | "
              "window | noise / signal | mean coherence in band |", "|" + "---|" * 10]
    first = trials[0][1] if trials else None
    for t in spec["tests"]:
        coh = ""
        if first is not None and t["name"] in first["tests"]:
            rec = first["tests"][t["name"]]
            band = (rec["freq_hz"] >= t["band_hz"][0]) & (rec["freq_hz"] <= t["band_hz"][1])
            coh = f"{rec['coherence'][band].mean():.4f}"
        acts = ", ".join(f"{x['station']}.{x['direction']}" for x in t["actuators"])
        lines.append(f"| {t['name']} | {acts} | {t['level_rms']} | {t['band_hz'][0]:g}-"
                     f"{t['band_hz'][1]:g} | {t['fs_hz']:g} | {t['record_s']:g} | "
                     f"{t['averages']} | {t['window']} | {t['noise_fraction']:g} | {coh} |")
    lines.append("")

    upd = spec.get("update", {})
    lines += ["## Parameter errors before and after updating", "",
              f"Method: `{upd.get('method')}`, parameters {upd.get('parameters')}, weighting "
              f"`{upd.get('weighting')}`. Errors are relative to the known truth.", ""]
    ptab = parameter_table(results)
    lines.append(_md_table(ptab))
    if ok:
        u = ok[0][1]["update"]
        sv = ", ".join(f"{s:.3g}" for s in u["singular_values"])
        lines += ["", f"Trial {ok[0][0]}: {len(u['history']) - 1} iterations, converged: "
                      f"{bool(u['attrs']['converged'])}; cost {u['cost_history'][0]:.4g} -> "
                      f"{u['cost_history'][-1]:.4g}; singular values of S: {sv}; condition "
                      f"number {u['attrs']['condition_number']:.4g}.", ""]
        corr = np.asarray(u["correlation"])
        if corr.shape[0] > 1:
            off = np.abs(corr - np.diag(np.diag(corr))).max()
            lines += [f"Largest parameter correlation (from (S^T S)^-1): {off:.6f}.", ""]
    noise = max((t["noise_fraction"] for t in spec["tests"]), default=0.0)
    if ok:
        worst = ptab["error after [%]"].abs().max() if not ptab.empty else float("nan")
        lines += [f"The largest remaining parameter error is {worst:.3f} % "
                  f"(sensor noise up to {100 * noise:g} % of the signal standard deviation; "
                  "noise, FRF estimation bias near resonances and finite record length all "
                  "contribute, so this is the method's accuracy on this campaign, not an "
                  "exact recovery).", ""]

    acc = modal_accuracy_table(results)
    if not acc.empty:
        lines += ["## Modes of the initial and updated model against the truth", "",
                  "Truth modes inside the update band that the sensors see, paired by MAC "
                  "at the sensors (mean over trials).", ""]
        lines.append(_md_table(acc))
        lines.append("")
    comp = method_comparison_table(results)
    if len(comp) > 2 or (not comp.empty and len(comp) == 2):
        lines += ["## Updating methods side by side", "",
                  "Against the known truth: no update, then every updater of the campaign.",
                  ""]
        lines.append(_md_table(comp))
        lines.append("")
    utab = uncertainty_table(results)
    if not utab.empty:
        lines += _uncertainty_section(results, utab, out)
    lines += _frf_band_section(results, out)
    lines += ["## FRF error over the update band", ""]
    lines.append(_md_table(frf_error_table(results)))
    if failed:
        lines += ["", "## Failed trials", ""]
        for k, t in failed:
            lines.append(f"- trial {k}: {t['attrs']['error'].splitlines()[0]}")
        lines.append("")
    png = plot_frfs(results, out / "frf.png")
    if png is not None:
        lines += ["", "## Data against the initial and updated model", "",
                  "![FRFs](frf.png)", ""]
    path = out / "report.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    from truthbench.report.html import write_html

    write_html(path)
    return path
