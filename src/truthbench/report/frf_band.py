"""The frequency-domain uncertainty model in the report: mean FRF and its k-sigma band.

The tests of the first trial that share inputs, outputs and frequency lines (at least
three of them), over the band all of them excite, give
:func:`truthbench.uncertainty.frf_uncertainty`: the mean FRF and the covariance of its
real and imaginary parts, line by line. The initial and updated model
FRFs are checked against the band (the fraction of lines whose model value lies inside
the k-sigma ellipse) and drawn with it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class FrfBand:
    """The FRF band of one group of tests.

    Attributes
    ----------
    tests : tuple of str
        The tests in the group.
    band : FrfUncertainty
        Mean FRF and covariance over the lines inside every test's excited band.
    inside : dict of str -> float
        ``"initial"``, ``"updated"``: fraction of lines and pairs inside the band
        (the same for every test of the group: the model does not vary by test).
    models : dict of str -> ndarray, complex, shape (n_freq, n_out, n_in)
    output_labels, input_labels : tuple of str
    """

    tests: tuple[str, ...]
    band: object
    inside: dict
    models: dict
    output_labels: tuple[str, ...]
    input_labels: tuple[str, ...]


def _labels(t, key) -> tuple[str, ...]:
    return tuple(x.decode() if isinstance(x, bytes) else str(x) for x in t["attrs"][key])


def frf_band(results: dict, k_sigma: float = 3.0) -> FrfBand | None:
    """The band of the largest group of comparable tests of the first ok trial.

    Returns None when no group has three tests (the 2 x 2 covariance of real and
    imaginary parts needs at least three).
    """
    from truthbench.uncertainty import frf_uncertainty

    trials = [t for k, t in sorted(results.get("trials", {}).items())
              if k != "attrs" and t["attrs"].get("status") == "ok"]
    if not trials:
        return None
    tr = trials[0]
    groups: dict = {}
    for name, t in tr["tests"].items():
        if name == "attrs":
            continue
        key = (_labels(t, "input_labels"), _labels(t, "output_labels"),
               t["freq_hz"].tobytes())
        groups.setdefault(key, []).append(name)
    (inputs, outputs, _), names = max(groups.items(), key=lambda kv: len(kv[1]))
    if len(names) < 3:
        return None
    f = tr["tests"][names[0]]["freq_hz"]
    bands = [t["band_hz"] for t in results["attrs"]["spec"]["tests"] if t["name"] in names]
    keep = (f > 0) & (f >= max(b[0] for b in bands)) & (f <= min(b[1] for b in bands))
    H = np.array([tr["tests"][n]["H"][keep] for n in names])
    band = frf_uncertainty(H, freq_hz=f[keep], k_sigma=k_sigma)
    models, inside = {}, {}
    model = tr.get("model", {}).get(names[0], {})
    for which in ("initial", "updated"):
        if f"H_{which}" in model:
            models[which] = np.asarray(model[f"H_{which}"])[keep[f > 0]]
            inside[which] = band.fraction_inside(models[which])
    return FrfBand(tuple(names), band, inside, models, outputs, inputs)


def plot_frf_band(fb: FrfBand, path: str | Path, max_outputs: int = 3) -> Path:
    """Magnitude of the mean FRF with the k-sigma magnitude band, and the models."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    b = fb.band
    n_out = min(max_outputs, b.mean.shape[1])
    fig, axes = plt.subplots(n_out, 1, figsize=(7.0, 2.4 * n_out + 0.6), sharex=True,
                             squeeze=False)
    f = b.freq_hz
    for o in range(n_out):
        ax = axes[o, 0]
        m = np.abs(b.mean[:, o, 0])
        s = b.k_sigma * b.std_magnitude[:, o, 0]
        ax.fill_between(f, np.maximum(m - s, m * 1e-3), m + s, color="C0", alpha=0.3,
                        label=f"{b.k_sigma:g}-sigma band ({len(fb.tests)} tests)")
        ax.semilogy(f, m, color="C0", lw=1.0, label="mean of the tests")
        for which, style in (("initial", "r--"), ("updated", "g:")):
            if which in fb.models:
                ax.semilogy(f, np.abs(fb.models[which][:, o, 0]), style, lw=1.0,
                            label=f"{which} model")
        ax.set_ylabel(f"|H| {fb.output_labels[o]}")
        ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="upper right")
    axes[0, 0].set_title(f"Input {fb.input_labels[0]}", fontsize=9)
    axes[-1, 0].set_xlabel("frequency [Hz]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
