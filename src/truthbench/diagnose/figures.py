"""Figures of a diagnosis (matplotlib, imported on use)."""

from __future__ import annotations

import numpy as np


def plot_diagnosis(diag, kind: str, *, test: int = 0):
    """See :meth:`truthbench.diagnose.Diagnosis.plot`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = ("residual", "frf", "candidates", "modes")
    if kind not in kinds:
        raise ValueError(f"kind must be one of {', '.join(kinds)}; got {kind!r}")
    if not 0 <= test < len(diag.tests):
        raise ValueError(f"test must be in 0..{len(diag.tests) - 1}; got {test}")
    t = diag.tests[test]
    f = t.freq_hz
    if kind in ("residual", "frf"):
        models = {"baseline": diag.model_frfs("baseline")[test],
                  "final": diag.model_frfs("final")[test]}
        n_out, n_in = t.H.shape[1:]
        fig, axes = plt.subplots(n_out * n_in, 1, sharex=True, squeeze=False,
                                 figsize=(8, 1.8 * n_out * n_in + 1.2))
        for k, ax in enumerate(axes[:, 0]):
            o, i = divmod(k, n_in)
            lab = f"{t.sensors[o].label} / {t.actuators[i].label}"
            unit = f"{t.frf.outputs[o].unit}/{t.frf.inputs[i].unit}"
            if kind == "residual":
                for name, M in models.items():
                    r = np.abs(t.H[:, o, i] - M[:, o, i]) / t.sigma[:, o, i]
                    ax.semilogy(f, r, lw=0.8, label=name)
                ax.set_ylabel("|residual| / sigma [-]")
            else:
                ax.semilogy(f, np.abs(t.H[:, o, i]), "k.", ms=2, label="data")
                for name, M in models.items():
                    ax.semilogy(f, np.abs(M[:, o, i]), lw=1, label=name)
                ax.set_ylabel(f"|H| [{unit}]")
            ax.set_title(lab, fontsize="small")
        axes[0, 0].legend(fontsize="small")
        axes[-1, 0].set_xlabel("frequency [Hz]")
        fig.suptitle(f"{t.name}: {'residual over noise' if kind == 'residual' else 'FRF'}")
        fig.tight_layout()
        return fig
    if kind == "candidates":
        fig, ax = plt.subplots(figsize=(8, 4.5))
        steps = sorted({x.step for x in diag.tried})
        for s in steps:
            ranked = diag.ranked(s)[:15]
            if not ranked:
                continue
            y = np.arange(len(ranked)) + 0.4 * s
            ax.barh(y, [max(r.delta_bic, 1e-1) for r in ranked], height=0.35,
                    label=f"step {s + 1}")
            for yy, r in zip(y, ranked, strict=True):
                ax.text(max(r.delta_bic, 1e-1), yy, f" {r.label}", va="center",
                        fontsize="x-small")
        ax.axvline(diag.settings.threshold, color="k", ls="--", lw=0.8,
                   label=f"threshold {diag.settings.threshold:g}")
        ax.set_xscale("log")
        ax.set_xlabel("delta BIC [-] (log)")
        ax.set_yticks([])
        ax.legend(fontsize="small")
        ax.set_title("candidates refitted, best first")
        fig.tight_layout()
        return fig
    fig, ax = plt.subplots(figsize=(7, 3.5))
    for name, res in (("before", diag.before), ("after", diag.after)):
        if res.modes:
            ax.plot([m.freq_hz for m in res.modes], [m.freq_error_pct for m in res.modes],
                    "o" if name == "before" else "s", label=name)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("data mode frequency [Hz]")
    ax.set_ylabel("model - data frequency [%]")
    ax.legend(fontsize="small")
    ax.set_title("paired modes")
    fig.tight_layout()
    return fig
