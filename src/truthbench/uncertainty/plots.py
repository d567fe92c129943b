"""Figures of the uncertainty model: the pole plot of Figure 10.6 and a calibration plot.

Each function draws on a given ``ax`` or on a new pyplot figure and returns the figure;
no backend is chosen here (:mod:`truthbench.presentation`). Nothing is computed here that
the uncertainty functions do not already give, except the mapping of the (omega, zeta)
box into the s-plane.
"""

from __future__ import annotations

import numpy as np

from truthbench.presentation import figure_axes
from truthbench.uncertainty.model import uncertainty_model


def pole(omega_rad_s, damping_ratio) -> np.ndarray:
    """``s = -zeta omega + j omega sqrt(1 - zeta^2)``, rad/s, broadcast over inputs."""
    w = np.asarray(omega_rad_s, dtype=float)
    z = np.asarray(damping_ratio, dtype=float)
    return -z * w + 1j * w * np.sqrt(np.clip(1.0 - z**2, 0.0, None))


def bound_outline(omega_rad_s: float, damping_ratio: float, d_omega_rad_s: float,
                  d_zeta: float, n: int = 50) -> np.ndarray:
    """The box ``[omega +- d_omega] x [zeta +- d_zeta]`` mapped into the s-plane.

    Parameters
    ----------
    omega_rad_s, damping_ratio : float
        Centre (mean model) of the box.
    d_omega_rad_s, d_zeta : float
        Half widths (the bound ``c`` of Eq. 10.50); ``zeta`` is clipped to [0, 1).
    n : int
        Points per edge.

    Returns
    -------
    ndarray, complex, shape (4 n + 1,)
        Closed outline (rays of constant zeta and arcs of constant omega).
    """
    w0, w1 = omega_rad_s - d_omega_rad_s, omega_rad_s + d_omega_rad_s
    z0 = max(damping_ratio - d_zeta, 0.0)
    z1 = min(damping_ratio + d_zeta, 1.0 - 1e-12)
    t = np.linspace(0.0, 1.0, n, endpoint=False)
    edges = [
        pole(w0 + (w1 - w0) * t, z0),  # constant zeta (a ray), omega up
        pole(w1, z0 + (z1 - z0) * t),  # constant omega (an arc), zeta up
        pole(w1 - (w1 - w0) * t, z1),
        pole(w0, z1 - (z1 - z0) * t),
    ]
    s = np.concatenate(edges)
    return np.append(s, s[0])


def plot_pole_bound(freq_hz_tests, damping_tests, *, freq_hz_fem=None, damping_fem=None,
                    freq_hz_updated=None, damping_updated=None, weights=None,
                    k_sigma: float = 3.0, test_labels=None, ax=None):
    """Figure 10.6: poles of every test, their mean, the bound, original and updated FEM.

    Parameters
    ----------
    freq_hz_tests : array_like, shape (T,) or (T, n_modes)
        Identified undamped natural frequencies per test, Hz.
    damping_tests : array_like, same shape
        Identified damping ratios per test.
    freq_hz_fem, damping_fem : array_like, shape (n_modes,), optional
        The original FEM (``theta_0`` of Eq. 10.46; the tests' mean when omitted).
    freq_hz_updated, damping_updated : array_like, shape (n_modes,), optional
        The updated FEM.
    weights : array_like, shape (T,) or (T, 2 n_modes), optional
        Confidence factors for :func:`~truthbench.uncertainty.uncertainty_model`
        (columns: all frequencies, then all damping ratios).
    k_sigma : float
        Bound multiplier.
    test_labels : sequence of str, length T, optional
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
        Real part (rad/s) against imaginary part (rad/s).
    """
    f = np.atleast_1d(np.asarray(freq_hz_tests, dtype=float))
    z = np.atleast_1d(np.asarray(damping_tests, dtype=float))
    if f.ndim == 1:
        f, z = f[:, None], z.reshape(-1, 1)
    if f.shape != z.shape or f.ndim != 2:
        raise ValueError(f"The 'freq_hz_tests' and 'damping_tests' parameters must have the "
                         f"same shape (T, n_modes); got {np.shape(freq_hz_tests)} and "
                         f"{np.shape(damping_tests)}.")
    T, m = f.shape
    theta = np.hstack([2 * np.pi * f, z])
    if freq_hz_fem is None or damping_fem is None:
        t0 = theta.mean(axis=0)
    else:
        t0 = np.concatenate([2 * np.pi * np.atleast_1d(np.asarray(freq_hz_fem, dtype=float)),
                             np.atleast_1d(np.asarray(damping_fem, dtype=float))])
    um = uncertainty_model(theta, t0, weights=weights, k_sigma=k_sigma, covariance="diagonal",
                           names=[f"omega{i}_rad_s" for i in range(m)]
                           + [f"zeta{i}" for i in range(m)])
    fig, (ax,) = figure_axes(ax, figsize=(6.0, 5.0))
    s_tests = pole(theta[:, :m], theta[:, m:])
    markers = "os^vD<>ph*"
    for j in range(T):
        lab = test_labels[j] if test_labels is not None else f"test {j + 1}"
        ax.plot(s_tests[j].real, s_tests[j].imag, markers[j % len(markers)], ms=5,
                mfc="none", label=lab)
    mm = um.mean_model
    s_mean = pole(mm[:m], mm[m:])
    ax.plot(s_mean.real, s_mean.imag, "k+", ms=12, mew=2, label="mean")
    for i in range(m):
        out = bound_outline(mm[i], mm[m + i], um.bound[i], um.bound[m + i])
        ax.plot(out.real, out.imag, "k--", lw=1,
                label=f"{k_sigma:g}-sigma bound" if i == 0 else None)
    if freq_hz_fem is not None and damping_fem is not None:
        s0 = pole(2 * np.pi * np.asarray(freq_hz_fem, dtype=float),
                  np.asarray(damping_fem, dtype=float))
        ax.plot(np.real(s0), np.imag(s0), "rx", ms=10, mew=2, label="original FEM")
    if freq_hz_updated is not None and damping_updated is not None:
        s1 = pole(2 * np.pi * np.asarray(freq_hz_updated, dtype=float),
                  np.asarray(damping_updated, dtype=float))
        ax.plot(np.real(s1), np.imag(s1), "g*", ms=12, label="updated FEM")
    ax.set_xlabel("real part (rad/s)")
    ax.set_ylabel("imaginary part (rad/s)")
    ax.set_title("Poles of the tests and the uncertainty bound")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    return fig


def plot_calibration(curve, ax=None):
    """Observed coverage against ``k`` with its confidence band and the expectations.

    Parameters
    ----------
    curve : truthbench.uncertainty.coverage.CalibrationCurve
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, (ax,) = figure_axes(ax, figsize=(6.0, 4.5))
    k = np.asarray(curve.k)
    ax.fill_between(k, curve.ci_low, curve.ci_high, color="C0", alpha=0.25,
                    label=f"{100 * curve.confidence:.0f} % interval")
    ax.plot(k, curve.coverage, "o-", color="C0", ms=4, label="observed")
    ax.plot(k, curve.expected_normal, "k:", label="normal, known variance")
    kind = "in-sample" if curve.in_sample else "new draw"
    ax.plot(k, curve.expected_t, "r--", label=f"estimated variance, T = {curve.n_tests} "
                                              f"({kind})")
    ax.set_xlabel("k (bound = mean +- k standard deviations)")
    ax.set_ylabel("coverage")
    ax.set_ylim(0.0, 1.02)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    return fig
