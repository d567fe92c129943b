"""Figure 10.6 pole plot and the calibration plot (smoke and geometry checks)."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from truthbench.identify import modal_from_poles  # noqa: E402
from truthbench.uncertainty import calibration_curve  # noqa: E402
from truthbench.uncertainty.plots import (  # noqa: E402
    bound_outline,
    plot_calibration,
    plot_pole_bound,
    pole,
)


def test_pole_matches_identify_convention():
    s = pole(2 * np.pi * 2.0, 0.05)
    f, z = modal_from_poles(s)
    assert f == pytest.approx(2.0) and z == pytest.approx(0.05)


def test_bound_outline_is_the_omega_zeta_box():
    w, z, dw, dz = 12.0, 0.02, 0.3, 0.01
    out = bound_outline(w, z, dw, dz)
    assert out[0] == out[-1]
    f, zz = modal_from_poles(out)
    assert np.all(2 * np.pi * f >= w - dw - 1e-9) and np.all(2 * np.pi * f <= w + dw + 1e-9)
    assert np.all(zz >= z - dz - 1e-12) and np.all(zz <= z + dz + 1e-12)
    # the four corners are on it
    for ww in (w - dw, w + dw):
        for zc in (z - dz, z + dz):
            assert np.min(np.abs(out - pole(ww, zc))) < 1e-9


def test_pole_plot_figure_10_6():
    rng = np.random.default_rng(0)
    T = 8  # the chapter's eight tests
    f = 2.0 + 0.01 * rng.standard_normal(T)  # frequencies repeat well (Hz)
    z = np.clip(0.02 + 0.008 * rng.standard_normal(T), 0.001, None)  # damping varies a lot
    fig = plot_pole_bound(f, z, freq_hz_fem=2.1, damping_fem=0.005, freq_hz_updated=2.0,
                          damping_updated=0.02)
    ax = fig.axes[0]
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert {"mean", "original FEM", "updated FEM", "3-sigma bound"} <= set(labels)
    assert sum(lab.startswith("test ") for lab in labels) == T
    assert ax.get_xlabel().startswith("real part")
    plt.close(fig)
    # two modes on a given axes
    fig2, ax2 = plt.subplots()
    out = plot_pole_bound(np.column_stack([f, 3 * f]), np.column_stack([z, z]), ax=ax2)
    assert out is fig2
    plt.close(fig2)
    with pytest.raises(ValueError, match="same shape"):
        plot_pole_bound(f, z[:3])


def test_calibration_plot():
    rng = np.random.default_rng(1)
    tests = rng.standard_normal((200, 5, 3))
    new = rng.standard_normal((200, 3))
    curve = calibration_curve(tests, new)
    fig = curve.plot()
    assert len(fig.axes[0].get_lines()) == 3
    plt.close(fig)
    fig = plot_calibration(calibration_curve(tests))  # in-sample
    assert "in-sample" in fig.axes[0].get_legend().get_texts()[-1].get_text()
    plt.close(fig)
