"""Synthetic FRFs built analytically from known modal models (the oracle of this room).

``H(jw) = (jw)^q sum_r [R_r / (jw - s_r) + conj(R_r) / (jw - conj(s_r))]`` with
``R_r = g_r 2 zeta_r w_r^2 phi_r phi_r[inputs]^T / (2 j w_d,r)``: the modal sum of a
proportionally damped structure whose mode r has unit modal mass scaled so that every
mode's resonance peak is about ``g_r |phi_p phi_q|`` (comparable peaks; ``g = 0.5`` for
the heavily damped one). Written here, independently of the library's LSFD model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

#: The reference modal model: a well-separated mode, two modes 1 % apart with their own
#: shapes, a heavily damped (5 %) mode and a higher mode.
TRUE_FREQ_HZ = np.array([10.0, 25.0, 25.25, 40.0, 60.0])
TRUE_ZETA = np.array([0.01, 0.005, 0.008, 0.05, 0.01])
PEAK_GAIN = np.array([1.0, 1.0, 1.0, 0.5, 1.0])
INPUT_DOFS = (0, 3)
N_OUT = 6


@dataclass(frozen=True)
class Synthetic:
    freq_hz: np.ndarray
    frf: np.ndarray
    freq_true: np.ndarray
    zeta_true: np.ndarray
    shapes_true: np.ndarray
    residues_true: np.ndarray  # displacement residues (n_modes, n_out, n_in)
    poles_true: np.ndarray


def true_shapes(n_modes: int = TRUE_FREQ_HZ.size) -> np.ndarray:
    rng = np.random.default_rng(123)
    phi = rng.standard_normal((N_OUT, n_modes))
    # keep every mode visible from both inputs
    rows = list(INPUT_DOFS)
    phi[rows] = np.sign(phi[rows]) * np.maximum(np.abs(phi[rows]), 0.8)
    return phi


def make_frf(
    *,
    n_in: int = 2,
    q: int = 0,
    df_hz: float = 0.05,
    f_max_hz: float = 80.0,
    f_min_hz: float = 0.05,
    noise: float = 0.0,
    seed: int = 0,
    freq_true=TRUE_FREQ_HZ,
    zeta_true=TRUE_ZETA,
    gain=PEAK_GAIN,
    shapes=None,
) -> Synthetic:
    freq_true = np.asarray(freq_true, float)
    zeta_true = np.asarray(zeta_true, float)
    phi = true_shapes(freq_true.size) if shapes is None else np.asarray(shapes, float)
    inputs = list(INPUT_DOFS[:n_in])
    f = np.arange(f_min_hz, f_max_hz + df_hz / 2, df_hz)
    s = 1j * 2 * np.pi * f[:, None, None]
    wn = 2 * np.pi * freq_true
    lam = -zeta_true * wn + 1j * wn * np.sqrt(1 - zeta_true**2)
    H = np.zeros((f.size, phi.shape[0], n_in), complex)
    R_all = []
    for r in range(freq_true.size):
        R = (
            np.asarray(gain)[r]
            * 2
            * zeta_true[r]
            * wn[r] ** 2
            * np.outer(phi[:, r], phi[inputs, r])
            / (2j * lam[r].imag)
        )
        R_all.append(R)
        H += R / (s - lam[r]) + R.conj() / (s - lam[r].conj())
    H *= s**q
    if noise:
        g = np.random.default_rng(seed)
        n = (g.standard_normal(H.shape) + 1j * g.standard_normal(H.shape)) / np.sqrt(2)
        rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=0, keepdims=True))
        H = H + noise * rms * n
    return Synthetic(f, H, freq_true, zeta_true, phi, np.array(R_all), lam)


@pytest.fixture
def synthetic():
    """Factory ``synthetic(**kwargs) -> Synthetic`` (see :func:`make_frf`)."""
    return make_frf
