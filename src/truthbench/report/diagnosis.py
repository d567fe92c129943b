"""The diagnosis report: ``diagnosis.md`` and ``diagnosis.html`` with figures, from a
:class:`~truthbench.diagnose.Diagnosis` (never reruns numerics)."""

from __future__ import annotations

import re
from pathlib import Path

from truthbench.diagnose.result import where
from truthbench.report.format import markdown, pct, sig, table
from truthbench.report.html import write_html


def _save(fig, path: Path) -> str:
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)




def _value(v: float, s: float | None = None) -> str:
    return sig(v) if s is None else f"{sig(v)} ± {sig(s, 2)}"


def diagnosis_markdown(diag, figures: dict[str, str] | None = None,
                       sources: tuple[str, ...] = ()) -> str:
    """The report's markdown; ``figures`` maps a figure's role to its file name."""
    figures = figures or {}
    out = ["# truthbench diagnosis", ""]
    if sources:
        out += [f"- data: {', '.join(sources)}"]
    out += [f"- tests: {', '.join(t.name for t in diag.tests)}; "
            f"{diag.n} real values compared (lines x outputs x inputs x 2)",
            f"- declared parameters (the baseline fits them): "
            f"{', '.join(diag.declared) or 'none'}",
            f"- criterion: delta BIC (noise scale profiled out, "
            f"{sig(diag.n_independent)} independent values) above "
            f"{sig(diag.settings.threshold)} + 2 ln(candidates tried) "
            f"({', '.join(sig(x) for x in diag.thresholds) or '-'} at each step); at most "
            f"{diag.settings.max_effects} effects",
            ""]
    out += ["## Can the model resolve the data?", "",
            "Checked before any effect is tried: a residual the model's own form leaves "
            "is not reported as an effect it lacks.", ""]
    if diag.mesh is not None:
        out += [f"- **Mesh**: {diag.mesh.summary()}."]
    if diag.missing:
        out += [f"- **Mode the model lacks**: {m.summary()}." for m in diag.missing]
    else:
        out += ["- **Modes**: every mode identified in the data has a model mode its "
                "channels see."]
    if diag.mounting is not None:
        out += [f"- **Mounting**: {diag.mounting.summary()}."]
    out += [f"- **Not tried**: {effect}: {reason}." for effect, reason in diag.not_tried]
    out += ["", "## Verdict", ""]
    holds = diag.uncertainty_holds
    if not diag.found:
        out += ["Nothing missing: no candidate effect lowers the residual enough to "
                "outweigh its added parameters.", ""]
    for f in diag.found:
        params = ", ".join(f"{k} = {_value(v, f.std.get(k) if holds else None)}"
                           for k, v in f.fitted.items())
        effect = ", ".join(f"{k} = {sig(v)}" for k, v in f.parameters.items())
        place = where(f.options, x_m=f.x_m)
        line = (f"- **{f.effect}** at {place}: {params} (effect parameters: {effect}); "
                f"delta BIC {sig(f.delta_bic)}")
        for a in f.alternatives:
            alt = ", ".join(f"{k} = {sig(v)}" for k, v in a.parameters.items())
            grown = ("" if not a.margin > diag.settings.ambiguity_margin else
                     f" (the margin {sig(diag.settings.ambiguity_margin)} grown to "
                     f"{sig(a.margin)}: the residual is model error, correlated across "
                     f"lines, and holds fewer independent values than it has lines)")
            line += (f"\n- **or {a.effect}** at {where(a.options, x_m=a.x_m)} ({alt}): "
                     f"delta BIC {sig(a.delta_bic)}, within the margin of it{grown}: these data "
                     f"cannot tell {'the two' if len(f.alternatives) == 1 else 'them'} "
                     f"apart")
        out.append(line)
    if diag.found:
        if holds:
            out += ["", f"Standard deviations (±) are stated: the final residual is at the "
                    f"noise level ({sig(diag.noise_ratio, 3)} times the noise variance; "
                    f"they are stated below {sig(diag.UNCERTAINTY_CHI2)})."]
        else:
            out += ["", f"No standard deviations are stated: the final residual is "
                    f"{sig(diag.noise_ratio, 3)} times the noise variance, so it is model "
                    f"error, not noise, and a covariance scaled by it would not describe "
                    f"the error of the values."]
    if any(f.alternatives for f in diag.found):
        out += ["", "### The measurement that would settle it", ""]
        out += [f"- {m.summary()}" for m in diag.measurements]
        settled = {m.between[0] for m in diag.measurements}  # (found, runner-up) pairs
        out += [f"- {' or '.join([f.effect, *(a.effect for a in f.alternatives)])}: no "
                f"sensor or excitation point of this structure separates them (they act on "
                f"every channel alike); a calibration of the measurement chain would"
                for f in diag.found if f.alternatives and f.label not in settled]
    if diag.dropped:
        out += ["", "Dropped after a later finding explained the data better "
                "(backward elimination): " + "; ".join(
                    f"{f.effect} at {where(f.options)} (delta BIC {sig(f.delta_bic)} "
                    f"without it)" for f in diag.dropped)]
    out += ["", "## Error before and after", "",
            "The FRF error is the noise-weighted relative RMS of the residual over every "
            "compared value, `sqrt(sum |w (D - M)|^2 / sum |w D|^2)`, w = 1 / sigma from "
            "each value's coherence and averages; the reduced chi2 is 1 when the residual "
            "is noise.", ""]
    rows = [{"model": "baseline (declared parameters fitted)", **_row(diag.before)},
            {"model": "with the effects found", **_row(diag.after)}]
    import pandas as pd

    out.append(markdown(pd.DataFrame(rows)))
    dec = diag.declared_values("baseline"), diag.declared_values("final")
    if diag.declared:
        out += ["", "Declared parameters: " + "; ".join(
            f"{k} {sig(dec[0][k])} -> {sig(dec[1][k])}" for k in diag.declared), ""]
    for role, name in figures.items():
        if role.startswith("residual"):
            out += ["", f"![residual over noise, {role[9:]}]({name})"]
    out += ["", "## Candidates", "",
            "Screened by the first-order (score) drop of chi2, the best refitted with the "
            "declared parameters and the effects found before; ranked by delta BIC.", ""]
    cand = diag.to_pandas("candidates")
    refitted = cand[cand["delta_bic"].notna()] if not cand.empty else cand
    if not refitted.empty:
        refitted = refitted.assign(fitted=[
            ", ".join(f"{k[4:]} {sig(v)}" for k, v in r.items()
                      if k.startswith("fit ") and v == v)
            for _, r in refitted.iterrows()])
        out.append(markdown(table(refitted.head(30), [
            ("step", "step", lambda v: str(int(v) + 1)), ("candidate", "candidate", str),
            ("delta_bic", "delta BIC", sig), ("screen_chi2_drop", "screened chi2 drop", sig),
            ("fitted", "fitted", str), ("status", "status", str)])))
    failed = cand[cand["status"].str.startswith(("not separable", "model refused"))] \
        if not cand.empty else cand
    if not failed.empty:
        out += ["", "Candidates the data cannot separate from the declared parameters or "
                "that the model refused (a limit of these data, not a verdict):", ""]
        out += [f"- {r.candidate}: {r.status}" for r in failed.head(10).itertuples()]
    if "candidates" in figures:
        out += ["", f"![candidates]({figures['candidates']})"]
    out += ["", "## Residual views", ""]
    ch = diag.to_pandas("channels")
    if not ch.empty:
        out.append(markdown(table(ch, [
            ("model", "model", str), ("test", "test", str), ("output", "output", str),
            ("input", "input", str), ("frf_error", "FRF error [%]", lambda v: pct(100 * v)),
            ("reduced_chi2", "reduced chi2", sig),
            ("magnitude_ratio", "magnitude ratio", lambda v: sig(v, 5)),
            ("delay_s", "phase-slope delay [ms]", lambda v: sig(1e3 * v, 3))])))
    modes = diag.to_pandas("modes")
    out += ["", "Paired modes (data identified by pLSCF, paired by MAC at the measured "
            "DOFs; MPC 1 for a real mode):", ""]
    if modes.empty:
        out.append("(none identified)\n")
    else:
        out.append(markdown(table(modes, [
            ("model", "model", str), ("test", "test", str), ("freq_hz", "data Hz", sig),
            ("freq_error_pct", "freq error [%]", pct),
            ("damping_ratio", "data damping [%]", lambda v: pct(100 * v, 3)),
            ("damping_error_pct", "damping error [%]", lambda v: pct(v, 1)),
            ("mac", "MAC", lambda v: f"{v:.4f}"), ("mpc", "data MPC", lambda v: f"{v:.4f}")])))
    if "modes" in figures:
        out += ["", f"![paired modes]({figures['modes']})"]
    pairs = diag.to_pandas("pairs")
    if not pairs.empty:
        out += ["", "Pairs that should agree (same channels in two tests: level dependence "
                "or drift; reciprocal pairs), their difference over its noise:", ""]
        out.append(markdown(table(pairs, [
            ("kind", "kind", str), ("first", "first", str), ("second", "second", str),
            ("reduced_chi2", "reduced chi2", sig),
            ("relative_difference", "difference [%]", lambda v: pct(100 * v)),
            ("n_lines", "lines", lambda v: str(int(v)))])))
    for role, name in figures.items():
        if role.startswith("frf"):
            out += ["", f"![FRF, {role[4:]}]({name})"]
    return "\n".join(out) + "\n"


def _row(res) -> dict:
    return {"FRF error [%]": pct(100 * res.frf_error), "reduced chi2": sig(res.reduced_chi2),
            "phase-slope delay [ms]": sig(1e3 * res.delay_s, 3)}


def write_diagnosis(diag, out_dir: str | Path, *, sources: tuple[str, ...] = ()) -> Path:
    """Write ``diagnosis.md``, ``diagnosis.html`` and their figures into ``out_dir``.

    Returns
    -------
    pathlib.Path
        The HTML file.
    """
    import matplotlib

    matplotlib.use("Agg")  # files only: a report writer never opens a window
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = {}
    for k, t in enumerate(diag.tests):
        figures[f"residual {t.name}"] = _save(diag.plot("residual", test=k),
                                              out / f"residual_{_safe(t.name)}.png")
        figures[f"frf {t.name}"] = _save(diag.plot("frf", test=k),
                                         out / f"frf_{_safe(t.name)}.png")
    if any(x.delta_bic == x.delta_bic for x in diag.tried):
        figures["candidates"] = _save(diag.plot("candidates"), out / "candidates.png")
    if diag.before.modes:
        figures["modes"] = _save(diag.plot("modes"), out / "modes.png")
    md = out / "diagnosis.md"
    md.write_text(diagnosis_markdown(diag, figures, sources), encoding="utf-8")
    return write_html(md)


def write_study(result, out_dir: str | Path) -> Path:
    """Write ``study.csv``, ``study.md``, ``study.html`` and ``detection.png`` of a
    diagnose-study (:class:`~truthbench.campaign.diagnose_study.StudyResult`): the scores
    of every truth form side by side with their targets, the counts and errors, and per
    form the confusion and the detection against strength.

    Returns
    -------
    pathlib.Path
        The HTML file.
    """
    from truthbench.campaign.diagnose_study import REFINE, SIZE_TOLERANCE, TARGETS

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    result.trials.to_csv(out / "study.csv", index=False)
    fig = _save(result.plot(), out / "detection.png")
    summary = result.to_pandas("summary").set_index("form")
    forms = list(summary.index)
    refine = ", ".join(map(str, REFINE[:-1])) + f" or {REFINE[-1]}"
    lines = [f"# truthbench diagnose-study: {result.campaign}", "",
             f"- {int(summary['trials'].iloc[0])} trials, seed {result.seed}; each injects "
             f"none, one or two effects at random strengths and places, simulates the "
             f"campaign's tests, diagnoses them against the nominal model and scores what "
             f"was found.",
             " ".join([f"- Truth forms: {', '.join(forms)}, on the same draws.",
                       *(_FORM_TEXT[f].format(refine=refine) for f in forms)]),
             f"- A right finding's size is right within {pct(100 * SIZE_TOLERANCE, 0)} % "
             f"of the injected size, measured in a unit that does not depend on the model "
             f"form (a joint by its equivalent rotational stiffness); located: within one "
             f"model element of the true place, or the right channel.",
             "", "## Scores", ""]
    header = ["score", "target (other form)"] + [f"{f} form" for f in forms]
    rows = []
    for score, of in _SCORES:
        target = TARGETS.get(score)
        rows.append([score, "-" if target is None else f">= {pct(100 * target, 0)} %"]
                    + [_share_text(summary.loc[f, score], summary.loc[f, of] if of else None)
                       for f in forms])
    lines.append(markdown(_frame(rows, header)))
    lines += ["", "## Counts and errors", ""]
    rows = [[c] + [_fmt(c)(summary.loc[f, c]) for f in forms] for c in summary.columns
            if c not in {s for s, _ in _SCORES}]
    lines.append(markdown(_frame(rows, ["", *forms])))
    for form in forms:
        conf = result.to_pandas("confusion", form=form)
        lines += ["", f"## Confusion, {form} form (single-effect trials: injected in rows, "
                      f"first found in columns)", ""]
        if conf.empty:
            lines.append("(no single-effect trial)\n")
        else:
            conf = conf.reset_index().rename(columns={"injected": "injected \\ found"})
            lines.append(markdown(conf.astype(str)))
        det = result.to_pandas("detection", form=form)
        lines += ["", f"## Detection against strength, {form} form (single-effect trials, "
                      f"strength quartiles)", ""]
        if not det.empty:
            lines.append(markdown(table(det, [
                ("effect", "effect", str), ("parameter", "parameter", str),
                ("strength_low", "from", sig), ("strength_high", "to", sig),
                ("trials", "trials", lambda v: str(int(v))),
                ("first_correct", "right first",
                 lambda v: "-" if v != v else pct(100 * v, 0) + " %")])))
    lines += ["", f"![detection against strength]({fig})", ""]
    md = out / "study.md"
    md.write_text("\n".join(lines), encoding="utf-8")
    return write_html(md)


_FORM_TEXT = {
    "other": "The other form's truth is not the model's: a mesh {refine} times finer, "
             "shear deformation and rotary inertia drawn on or off (then `element_physics` "
             "is a right finding, not a false alarm), each effect at a node of the fine "
             "mesh, sensors and shakers mounted off the axis (torsion and lateral motion "
             "in the data).",
    "same": "The same form's truth is the model's own plant, mesh and elements, each "
            "effect at the model node nearest the other form's place.",
}

_SCORES = (("nothing found on clean", "clean trials"),
           ("right effect first", "single-effect trials"),
           ("exactly the injected", "trials with effects"),
           ("both found", "two-effect trials"),
           ("sizes within 10 %", "right findings"),
           ("located within one element", None))
"""The scores of a study and the count each is a share of."""


def _share_text(v, of) -> str:
    if v != v:
        return "-"
    return f"{pct(100 * v, 1)} %" + ("" if of is None else f" (of {int(of)})")


def _frame(rows, columns):
    import pandas as pd

    return pd.DataFrame(rows, columns=columns)


def _fmt(column: str):
    if column == "median error reduction":
        return lambda v: "-" if v != v else f"{sig(v, 3)}x"
    if column == "median location error (m)":
        return lambda v: "-" if v != v else sig(v, 3)
    if column == "median seconds per trial":
        return lambda v: "-" if v != v else sig(v, 3)
    return lambda v: "-" if v != v else str(int(v))
