"""Figures of a campaign result (matplotlib): FRFs, poles, the FRF band.

Each function draws what the result holds and computes nothing the campaign did not
(beyond magnitudes, phases and the mapping of the (omega, zeta) bound into the
s-plane); it returns a new :class:`matplotlib.figure.Figure`, which the caller closes
(``matplotlib.pyplot.close(fig)``). Reached through
:meth:`CampaignResult.plot <truthbench.campaign.results.CampaignResult.plot>`.
"""

from __future__ import annotations

import re

import numpy as np

from truthbench.io.hdf5 import frf_unit

_MARKERS = "os^vD<>ph*"


def _pyplot():
    import matplotlib.pyplot as plt

    return plt


def _phase_deg(h: np.ndarray) -> np.ndarray:
    """Wrapped phase in degrees with NaN where it wraps (no vertical lines)."""
    deg = np.degrees(np.angle(h))
    out = deg.astype(float).copy()
    out[1:][np.abs(np.diff(deg)) > 180.0] = np.nan
    return out


def _test_band(spec, rec) -> tuple[float, float]:
    for t in spec.tests:
        if t.name == rec.name:
            return tuple(t.band_hz)
    if rec.frf.band_hz is not None:
        return rec.frf.band_hz
    return float(rec.freq_hz[0]), float(rec.freq_hz[-1])


def plot_frf(result, trial, test: str | None = None, *, input: int = 0,  # noqa: A002
             max_outputs: int = 4):
    """One test's FRFs: data (H1, over the excited band) against the initial and
    updated model, magnitude and phase, and the coherence, one column per output.

    Parameters
    ----------
    result : CampaignResult
    trial : TrialResult
    test : str, optional
        Default the trial's first test.
    input : int
        The input (column of ``H``) drawn.
    max_outputs : int
        At most this many outputs (columns), in the test's order.

    Returns
    -------
    matplotlib.figure.Figure
        Frequency in Hz; magnitude in the FRF's unit (output unit per input unit);
        phase in degrees; the update lines shaded.
    """
    plt = _pyplot()
    rec = trial.tests[0] if test is None else trial.test(test)
    j = [r.name for r in trial.tests].index(rec.name)
    frf = rec.frf
    if not 0 <= input < rec.H.shape[2]:
        raise ValueError(f"test {rec.name!r} has {rec.H.shape[2]} input(s); got input={input}")
    f = rec.freq_hz
    pos = f > 0
    lo, hi = _test_band(result.spec, rec)
    excited = pos & (f >= lo) & (f <= hi)  # H1 means nothing outside the excited band
    n_out = min(max_outputs, rec.H.shape[1])
    rows = 3 if rec.coherence is not None else 2
    fig, axes = plt.subplots(rows, n_out, figsize=(3.5 * n_out + 0.5, 2.0 * rows + 1.1),
                             sharex=True, squeeze=False)
    models = []
    if len(trial.H_initial) > j:
        models.append(("initial model", trial.H_initial[j], "C3", "--"))
    if len(trial.H_updated) > j:
        models.append(("updated model", trial.H_updated[j], "C0", "-"))
    mask = trial.update_mask[j] if len(trial.update_mask) > j else None
    for o in range(n_out):
        h = rec.H[:, o, input]
        ax_m, ax_p = axes[0, o], axes[1, o]
        ax_m.semilogy(f[excited], np.abs(h[excited]), color="0.55", lw=1.3, label="data (H1)")
        ax_p.plot(f[excited], np.degrees(np.angle(h[excited])), ".", color="0.55", ms=1.5,
                  label="data (H1)")
        for label, H, color, ls in models:
            ax_m.semilogy(f[pos], np.abs(H[:, o, input]), color=color, ls=ls, lw=1.0,
                          label=label)
            ax_p.plot(f[pos], _phase_deg(H[:, o, input]), color=color, ls=ls, lw=1.0)
        if rows == 3:
            axes[2, o].plot(f[excited], rec.coherence[excited, o, input], color="0.3", lw=1.0)
            axes[2, o].set_ylim(0.0, 1.05)
            axes[2, o].set_ylabel("coherence [-]")
        if mask is not None and mask.any():
            band = f[mask]
            for ax in axes[:, o]:
                ax.axvspan(band.min(), band.max(), color="C2", alpha=0.07, lw=0)
        ax_m.set_title(frf.outputs[o].label, fontsize=10)
        ax_m.set_ylabel(f"|H| [{frf_unit(frf.outputs[o], frf.inputs[input])}]")
        ax_p.set_ylabel("phase [deg]")
        ax_p.set_ylim(-190, 190)
        ax_p.set_yticks([-180, -90, 0, 90, 180])
        axes[-1, o].set_xlabel("frequency [Hz]")
        axes[-1, o].set_xlim(0, hi)
        for ax in axes[:, o]:
            ax.grid(True, which="major", alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize=7)
    chan = frf.inputs[input]
    fig.suptitle(f"{rec.name}: input {chan.label} [{chan.unit}], trial {trial.trial}"
                 + ("; update lines shaded" if mask is not None and mask.any() else ""),
                 fontsize=10)
    fig.tight_layout()
    return fig


def _mode_number(name: str) -> str:
    return re.sub(r"\D", "", name) or "?"


def _extent(points: np.ndarray):
    return (np.nanmin(points.real), np.nanmax(points.real),
            np.nanmin(points.imag), np.nanmax(points.imag))


def plot_poles(result, trial, *, max_columns: int = 4):
    """Figure 10.6 per mode: the identified poles of every test (by name; held-out tests
    filled), their mean, the k-sigma bound of the uncertainty stage, and the initial and
    updated model; one panel per bounded mode, each zoomed on its tests and bound.

    A model pole far outside a panel's view is named in the panel instead of widening
    the view until the bound is invisible.

    Returns
    -------
    matplotlib.figure.Figure
        Real part against imaginary part of the poles, rad/s.
    """
    from truthbench.uncertainty.plots import bound_outline, pole

    u = trial.uncertainty
    if u is None:
        raise ValueError(f"trial {trial.trial} has no uncertainty stage (no pole plot)")
    plt = _pyplot()
    k = len(u.names) // 2
    names = [t.name for t in result.spec.tests][: u.theta_tests.shape[0]]
    centre = u.theta_0 + u.mean
    k_sigma = result.spec.uncertainty.k_sigma
    ncols = min(k, max_columns)
    nrows = -(-k // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.3 * ncols + 2.4, 3.2 * nrows + 0.5),
                             squeeze=False)
    for i in range(k):
        ax = axes.flat[i]
        w = 2 * np.pi
        s_tests = pole(w * u.theta_tests[:, i], u.theta_tests[:, k + i])
        for j, s in enumerate(s_tests):
            held = bool(u.holdout[j])
            ax.plot(s.real, s.imag, _MARKERS[j % len(_MARKERS)], ms=6, zorder=4,
                    color=f"C{j % 10}", mfc=f"C{j % 10}" if held else "none",
                    label=names[j] + (" (held out)" if held else ""))
        outline = bound_outline(w * centre[i], centre[k + i], w * u.bound[i], u.bound[k + i])
        s_mean = pole(w * centre[i], centre[k + i])
        ax.plot(outline.real, outline.imag, "k-", lw=1.5, zorder=6,
                label=f"{k_sigma:g}-sigma bound")
        ax.plot(s_mean.real, s_mean.imag, "k+", ms=11, mew=1.5, zorder=7, label="mean")
        base = np.concatenate([s_tests, outline, [s_mean]])
        x0, x1, y0, y1 = _extent(base)
        models = [("initial model", u.theta_0, "x", "C3")]
        if u.theta_updated is not None:
            models.append(("updated model", u.theta_updated, "*", "C2"))
        off = []
        for label, theta, marker, color in models:
            f_m, z_m = theta[i], theta[k + i]
            if not np.isfinite(f_m):
                continue
            s_m = pole(w * f_m, z_m)
            ax.plot(s_m.real, s_m.imag, marker, color=color, ms=8, mew=1.5, zorder=3,
                    alpha=0.8, label=label)
            wide = _extent(np.concatenate([base, [s_m]]))
            if (wide[1] - wide[0] <= 4 * max(x1 - x0, 1e-12)
                    and wide[3] - wide[2] <= 4 * max(y1 - y0, 1e-12)):
                x0, x1, y0, y1 = wide
            else:
                off.append(f"{label}: {f_m:.4g} Hz, zeta {z_m:.3g} (off view)")
        px, py = 0.12 * max(x1 - x0, 1e-9), 0.12 * max(y1 - y0, 1e-9)
        ax.set_xlim(x0 - px, x1 + px)
        ax.set_ylim(y0 - py, y1 + py)
        if off:
            ax.text(0.02, 0.02, "\n".join(off), transform=ax.transAxes, fontsize=7,
                    va="bottom", color="0.25")
        ax.set_title(f"mode {_mode_number(u.names[i])}: {centre[i]:.2f} Hz (mean)",
                     fontsize=10)
        ax.set_xlabel("real part [rad/s]")
        ax.set_ylabel("imaginary part [rad/s]")
        ax.ticklabel_format(useOffset=False)
        ax.grid(True, alpha=0.3)
    for ax in axes.flat[k:]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="center right", fontsize=8, frameon=False)
    fig.suptitle(f"Poles of the tests and the uncertainty bound, trial {trial.trial}",
                 fontsize=11)
    fig.tight_layout(rect=(0, 0, 1 - 2.2 / (3.3 * ncols + 2.4), 1))
    return fig


def plot_frf_band(result, trial, *, input: int = 0, max_outputs: int = 4):  # noqa: A002
    """The FRF-domain uncertainty model of a trial: the tests' mean FRF with its
    k-sigma band (magnitude and phase, linearised from the real/imaginary covariance)
    and the initial and updated model, one column per output.

    Returns
    -------
    matplotlib.figure.Figure
    """
    b = trial.frf_band
    if b is None:
        raise ValueError(f"trial {trial.trial} has no FRF band (fewer than three tests "
                         f"share inputs, outputs and lines)")
    plt = _pyplot()
    fu = b.band
    rec = trial.test(b.tests[0])
    f = fu.freq_hz
    n_out = min(max_outputs, fu.mean.shape[1])
    fig, axes = plt.subplots(2, n_out, figsize=(3.5 * n_out + 0.5, 5.2), sharex=True,
                             squeeze=False)
    models = {w: b.model(trial, w) for w in ("initial", "updated")}
    for o in range(n_out):
        m = fu.mean[:, o, input]
        a = np.abs(m)
        s = fu.k_sigma * fu.std_magnitude[:, o, input]
        ax_m, ax_p = axes[0, o], axes[1, o]
        ax_m.fill_between(f, np.maximum(a - s, a * 1e-3), a + s, color="C0", alpha=0.3,
                          lw=0, label=f"{fu.k_sigma:g}-sigma band ({fu.n_tests} tests)")
        ax_m.semilogy(f, a, color="C0", lw=1.0, label="mean of the tests")
        ph = np.degrees(np.angle(m))
        sp = np.minimum(np.degrees(fu.k_sigma * fu.std_phase_rad[:, o, input]), 180.0)
        ax_p.fill_between(f, ph - sp, ph + sp, color="C0", alpha=0.3, lw=0)
        ax_p.plot(f, _phase_deg(m), color="C0", lw=1.0)
        for which, style in (("initial", "C3--"), ("updated", "C2:")):
            H = models[which]
            if H is not None:
                ax_m.semilogy(f, np.abs(H[:, o, input]), style, lw=1.2,
                              label=f"{which} model")
                ax_p.plot(f, _phase_deg(H[:, o, input]), style, lw=1.2)
        ax_m.set_title(b.output_labels[o], fontsize=10)
        ax_m.set_ylabel(f"|H| [{frf_unit(rec.frf.outputs[o], rec.frf.inputs[input])}]")
        ax_p.set_ylabel("phase [deg]")
        ax_p.set_yticks([-180, -90, 0, 90, 180])
        ax_p.set_xlabel("frequency [Hz]")
        for ax in (ax_m, ax_p):
            ax.grid(True, which="major", alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.suptitle(f"FRF band of {', '.join(b.tests)} (input {b.input_labels[input]}), "
                 f"trial {trial.trial}", fontsize=10)
    fig.tight_layout()
    return fig


def plot_convergence(result, *, max_curves: int = 6):
    """The coverage and error statistics against the number of trials
    (:func:`truthbench.campaign.convergence.convergence`), each with its confidence
    band: one panel per statistic the campaign has (coverage of the bound, identified
    frequency error per mode, parameter error after the primary updater per parameter).

    Returns
    -------
    matplotlib.figure.Figure
        Trials on a logarithmic axis; coverage as a fraction, errors in %.

    Raises
    ------
    ValueError
        Fewer than two trials with an uncertainty stage or an update.
    """
    from matplotlib import ticker

    from truthbench.campaign.convergence import convergence

    c = convergence(result)
    panels = []
    if c.coverage is not None:
        panels.append("coverage")
        if c.modes:
            panels.append("identification")
    if c.parameter_error is not None:
        panels.append("parameters")
    if not panels:
        raise ValueError("no convergence figure: fewer than two trials with an uncertainty "
                         "stage or an update")
    plt = _pyplot()
    fig, axes = plt.subplots(len(panels), 1, figsize=(7.0, 2.6 * len(panels) + 0.6),
                             squeeze=False)
    level = f"{100 * c.confidence:g} %"
    for ax, panel in zip(axes[:, 0], panels, strict=True):
        if panel == "coverage":
            n, (p, lo, hi) = c.trials, c.coverage.T
            ax.fill_between(n, lo, hi, color="C0", alpha=0.25, lw=0,
                            label=f"{level} interval (trial-clustered)")
            ax.plot(n, p, "C0-", lw=1.3, label=f"{c.coverage_of} truths inside the bound")
            if c.expected is not None:
                ax.axhline(c.expected, color="k", ls="--", lw=1.0,
                           label=f"normal theory {c.expected:.3f}")
            ax.set_ylabel("coverage [-]")
        else:
            if panel == "identification":
                n, stats, names = c.trials, c.identification, c.modes
                ax.set_ylabel("identified frequency\nerror [%]")
            else:
                n, stats, names = c.parameter_trials, c.parameter_error, c.parameters
                ax.set_ylabel(f"parameter error after\n{result.primary_method} [%]")
            for k, name in enumerate(names[:max_curves]):
                color = f"C{k % 10}"
                ax.fill_between(n, stats[:, 1, k], stats[:, 2, k], color=color, alpha=0.2,
                                lw=0)
                ax.plot(n, stats[:, 0, k], color=color, lw=1.2, label=f"{name} (mean)")
                if panel == "parameters":
                    ax.plot(n, c.parameter_rms[:, k], color=color, ls=":", lw=1.0,
                            label=f"{name} (RMS)")
            ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(ticker.NullFormatter())
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel("trials")
    fig.suptitle(f"Convergence with the number of trials ({level} bands)", fontsize=10)
    fig.tight_layout()
    return fig
