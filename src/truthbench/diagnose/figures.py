"""Figures of a diagnosis (matplotlib, imported on use; the caller chooses the backend)."""

from __future__ import annotations

import numpy as np

KINDS = ("residual", "frf", "candidates", "modes")


def _axes(ax, panels: int, figsize):
    """A figure with ``panels`` stacked axes, or ``ax``'s figure when one panel is
    wanted and ``ax`` is given."""
    import matplotlib.pyplot as plt

    if ax is not None:
        if panels != 1:
            raise ValueError(f"this figure has {panels} panels (one per transfer function); "
                             f"give ax=None, or choose a test with one")
        return ax.figure, np.array([[ax]])
    fig, axes = plt.subplots(panels, 1, sharex=True, squeeze=False, figsize=figsize)
    return fig, axes


def plot_diagnosis(diag, kind: str | None = None, *, ax=None, test: int = 0):
    """See :meth:`truthbench.diagnose.Diagnosis.plot`."""
    kind = "residual" if kind is None else kind
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}; got {kind!r}")
    if not 0 <= test < len(diag.tests):
        raise ValueError(f"test must be in 0..{len(diag.tests) - 1}; got {test}")
    t = diag.tests[test]
    f = t.freq_hz
    if kind in ("residual", "frf"):
        models = {"baseline": diag.model_frfs("baseline")[test],
                  "final": diag.model_frfs("final")[test]}
        n_out, n_in = t.H.shape[1:]
        fig, axes = _axes(ax, n_out * n_in, (8, 1.8 * n_out * n_in + 1.2))
        for k, a in enumerate(axes[:, 0]):
            o, i = divmod(k, n_in)
            lab = f"{t.sensors[o].label} / {t.actuators[i].label}"
            unit = f"{t.frf.outputs[o].unit}/{t.frf.inputs[i].unit}"
            if kind == "residual":
                for name, M in models.items():
                    r = np.abs(t.H[:, o, i] - M[:, o, i]) / t.sigma[:, o, i]
                    a.semilogy(f, r, lw=0.8, label=name)
                a.set_ylabel("|residual| / sigma [-]")
            else:
                a.semilogy(f, np.abs(t.H[:, o, i]), "k.", ms=2, label="data")
                for name, M in models.items():
                    a.semilogy(f, np.abs(M[:, o, i]), lw=1, label=name)
                a.set_ylabel(f"|H| [{unit}]")
            for m in diag.missing:  # lines left out: a mode the model lacks
                a.axvspan(*m.band_hz, color="0.85", zorder=0)
            a.set_title(lab, fontsize="small")
        axes[0, 0].legend(fontsize="small")
        axes[-1, 0].set_xlabel("frequency [Hz]")
        if ax is None:
            fig.suptitle(f"{t.name}: {'residual over noise' if kind == 'residual' else 'FRF'}")
            fig.tight_layout()
        return fig
    fig, axes = _axes(ax, 1, (8, 4.5) if kind == "candidates" else (7, 3.5))
    a = axes[0, 0]
    if kind == "candidates":
        steps = sorted({x.step for x in diag.tried})
        for s in steps:
            ranked = diag.ranked(s)[:15]
            if not ranked:
                continue
            y = np.arange(len(ranked)) + 0.4 * s
            a.barh(y, [max(r.delta_bic, 1e-1) for r in ranked], height=0.35,
                   label=f"step {s + 1}")
            for yy, r in zip(y, ranked, strict=True):
                a.text(max(r.delta_bic, 1e-1), yy, f" {r.label}", va="center",
                       fontsize="x-small")
        a.axvline(diag.settings.threshold, color="k", ls="--", lw=0.8,
                  label=f"threshold {diag.settings.threshold:g}")
        a.set_xscale("log")
        a.set_xlabel("delta BIC [-] (log)")
        a.set_yticks([])
        a.legend(fontsize="small")
        a.set_title("candidates refitted, best first")
    else:
        for name, res in (("before", diag.before), ("after", diag.after)):
            if res.modes:
                a.plot([m.freq_hz for m in res.modes], [m.freq_error_pct for m in res.modes],
                       "o" if name == "before" else "s", label=name)
        for m in diag.missing:
            a.axvline(m.freq_hz, color="0.5", ls=":", lw=1)
        a.axhline(0, color="k", lw=0.5)
        a.set_xlabel("data mode frequency [Hz]")
        a.set_ylabel("model - data frequency [%]")
        a.legend(fontsize="small")
        a.set_title("paired modes (dotted: modes the model lacks)")
    if ax is None:
        fig.tight_layout()
    return fig
