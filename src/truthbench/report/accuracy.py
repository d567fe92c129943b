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
    return path
