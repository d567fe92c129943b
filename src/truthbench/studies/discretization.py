"""Discretization error of a free-free tube beam (the chapter's Figure 10.2).

The nominal aluminium tube of the hub-beam experiment (mean radius 11.875 mm, wall 1.65 mm,
E = 68.9 GPa, rho = 2700 kg/m^3, L = 1.8 m; the defaults of the free-free beam plant,
tube section, aluminium) is meshed into 1..N equal
Euler-Bernoulli tube elements (:func:`truthbench.fe.assembly.straight_member`,
:func:`~truthbench.fe.assembly.assemble`). Only planar x-z bending is kept: the axial,
lateral (y), torsion and rz DOFs of every node are clamped with
:func:`~truthbench.fe.assembly.finish_structure`, so the degenerate y/z bending pairs of
the round tube cannot mix and modes 1, 2 are the first two flexible x-z modes (after
the two rigid-body modes, translation z and rotation ry).

The reference is the exact Euler-Bernoulli free-free solution:
``omega_n = (beta_n L)^2 sqrt(E I / (rho A L^4))`` with ``cos(beta L) cosh(beta L) = 1``,
and the shape ``phi(x) = cosh(b x) + cos(b x) - sigma (sinh(b x) + sin(b x))``,
``sigma = (cosh(bL) - cos(bL)) / (sinh(bL) - sin(bL))``, mass-normalised
(``int rho A phi^2 dx = 1``).

Errors reported per element count and mode:

* frequency error ``(f_FE - f_exact) / f_exact`` in % (positive: the consistent-mass
  element is stiff; it falls as h^4);
* shape error ``1 - MAC`` (Eq. 10.28) between the FE translations and the exact shape at
  the nodes (computed as ``|phi_FE,perp|^2 / |phi_FE|^2``, the part of the FE shape
  orthogonal to the exact one, which equals ``1 - MAC`` without the rounding of
  ``1 - x`` near 1);
* quadratic shape error ``e`` (Eq. 10.30) after *scaling*: both shapes mass-normalised
  (the FE shape by ``Phi^T M Phi = I``, the exact one by the integral), the FE sign
  aligned, ``e = sum_j (phi_exact(x_j) - phi_FE,j)^2 / sum_j phi_exact(x_j)^2``. Unlike
  ``1 - MAC`` it also sees an amplitude error. (With the least-squares modal scale factor
  instead, ``e / sum phi^2`` would equal ``1 - MAC`` exactly, see
  :func:`truthbench.identify.shape_error`, so that variant is not repeated.)

The shape errors are defined only when the nodes can show the mode: mode k of a
free-free beam has k + 1 nodal points, so the sampled shape needs at least k + 2 nodes
(``n_elements >= k + 1``); below that they are NaN. Frequencies exist as soon as the
model has the mode (``2 n_elements >= k``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from truthbench.presentation import Presentable, figure_axes

__all__ = [
    "DiscretizationStudy",
    "discretization_study",
    "free_free_roots",
    "free_free_shape",
]


def _nominal_tube() -> dict[str, float]:
    from truthbench.plants import make_plant

    keys = ("E_pa", "nu", "rho_kg_m3", "r_m", "t_m", "L_m")
    defaults = make_plant("free_free_beam").resolve()
    return {k: float(defaults[k]) for k in keys}


def free_free_roots(n_modes: int) -> np.ndarray:
    """Roots ``beta_n L`` of ``cos(x) cosh(x) = 1`` for the flexible free-free modes.

    Parameters
    ----------
    n_modes : int
        Number of roots (>= 1).

    Returns
    -------
    ndarray, shape (n_modes,)
        4.73004074486, 7.85320462410, 10.9956078380, ... (dimensionless).
    """
    from scipy.optimize import brentq

    if int(n_modes) != n_modes or n_modes < 1:
        raise ValueError(f"n_modes must be a positive integer; got {n_modes!r}")

    def g(x):  # cos x - 1 / cosh x: same roots, no overflow
        return np.cos(x) - 1.0 / np.cosh(x)

    # root n lies within 0.3 of (n + 1/2) pi, where g changes sign exactly once
    roots = [brentq(g, (n + 0.5) * np.pi - 0.3, (n + 0.5) * np.pi + 0.3, xtol=1e-14,
                    rtol=4 * np.finfo(float).eps)
             for n in range(1, int(n_modes) + 1)]
    return np.array(roots)


def free_free_shape(beta_l: float, xi) -> np.ndarray:
    """Exact free-free Euler-Bernoulli mode shape at ``xi = x / L``.

    ``phi = cosh(b xi) + cos(b xi) - sigma (sinh(b xi) + sin(b xi))``, ``b = beta L``,
    ``sigma = (cosh b - cos b) / (sinh b - sin b)``; the mean of ``phi^2`` over the beam
    is 1, so ``phi / sqrt(m_total)`` is mass-normalised.

    Parameters
    ----------
    beta_l : float
        Root ``beta_n L`` (see :func:`free_free_roots`).
    xi : array_like, shape (n,)
        Positions as fractions of the length, 0..1.

    Returns
    -------
    ndarray, shape (n,)
        Dimensionless shape values (2 at both ends).
    """
    b = float(beta_l)
    x = b * np.asarray(xi, dtype=float)
    sigma = (np.cosh(b) - np.cos(b)) / (np.sinh(b) - np.sin(b))
    return np.cosh(x) + np.cos(x) - sigma * (np.sinh(x) + np.sin(x))


@dataclass(frozen=True, eq=False)
class DiscretizationStudy(Presentable):
    """Errors of the FE free-free beam against the exact Euler-Bernoulli solution.

    Table ``"errors"`` (:meth:`to_pandas`): one row per (n_elements, mode). Figure
    ``"errors"`` (:meth:`plot`): the Figure 10.2 analogue.

    Attributes
    ----------
    n_elements : ndarray of int, shape (n_counts,)
        Element counts.
    modes : tuple of int
        Flexible mode numbers (1 = first bending mode), length n_modes.
    freq_exact_hz : ndarray, shape (n_modes,)
        Exact natural frequencies, Hz.
    freq_fe_hz : ndarray, shape (n_counts, n_modes)
        FE natural frequencies, Hz (NaN where the model lacks the mode).
    freq_error_pct : ndarray, shape (n_counts, n_modes)
        ``100 (f_FE - f_exact) / f_exact``, %.
    mac_error : ndarray, shape (n_counts, n_modes)
        ``1 - MAC`` at the nodes (NaN where undefined, see the module notes).
    shape_error : ndarray, shape (n_counts, n_modes)
        Relative quadratic error (Eq. 10.30) of the mass-normalised shapes (NaN where
        undefined).
    parameters : Mapping
        The tube: E_pa, nu, rho_kg_m3, r_m, t_m, L_m.
    """

    TABLES = ("errors",)
    PLOTS = ("errors",)

    n_elements: np.ndarray
    modes: tuple[int, ...]
    freq_exact_hz: np.ndarray
    freq_fe_hz: np.ndarray
    freq_error_pct: np.ndarray
    mac_error: np.ndarray
    shape_error: np.ndarray
    parameters: Any = field(default_factory=dict)

    def __post_init__(self):
        for name in ("n_elements", "freq_exact_hz", "freq_fe_hz", "freq_error_pct",
                     "mac_error", "shape_error"):
            a = np.array(getattr(self, name), copy=True)
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "modes", tuple(int(m) for m in self.modes))
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))

    def _table_errors(self):
        """Long table: one row per (n_elements, mode): columns n_elements, mode,
        freq_exact_hz, freq_fe_hz, freq_error_pct, one_minus_mac, shape_error."""
        import pandas as pd

        n, m = self.freq_fe_hz.shape
        return pd.DataFrame({
            "n_elements": np.repeat(self.n_elements, m),
            "mode": np.tile(np.array(self.modes), n),
            "freq_exact_hz": np.tile(self.freq_exact_hz, n),
            "freq_fe_hz": self.freq_fe_hz.ravel(),
            "freq_error_pct": self.freq_error_pct.ravel(),
            "one_minus_mac": self.mac_error.ravel(),
            "shape_error": self.shape_error.ravel(),
        })

    def _plot_errors(self, ax):
        """The Figure 10.2 analogue: frequency (left) and shape (right) errors against
        the number of elements, log scale."""
        fig, (ax1, ax2) = figure_axes(ax, 1, 2, figsize=(10, 4), constrained_layout=True)
        for k, mode in enumerate(self.modes):
            ax1.semilogy(self.n_elements, np.abs(self.freq_error_pct[:, k]), "o-", ms=3,
                         label=f"mode {mode} ({self.freq_exact_hz[k]:.1f} Hz)")
            ax2.semilogy(self.n_elements, self.mac_error[:, k], "o-", ms=3,
                         label=f"mode {mode}: 1 - MAC")
            ax2.semilogy(self.n_elements, self.shape_error[:, k], "s--", ms=3,
                         label=f"mode {mode}: e (mass-normalised)")
        ax1.set(xlabel="number of elements", ylabel="|frequency error| [%]",
                title="Frequency error vs exact Euler-Bernoulli")
        ax2.set(xlabel="number of elements", ylabel="shape error [-]",
                title="Mode-shape error at the nodes")
        for ax in (ax1, ax2):
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8)
        fig.suptitle("Free-free tube beam, x-z bending: discretization error (Fig. 10.2)")
        return fig


def _one_minus_mac(a: np.ndarray, b: np.ndarray) -> float:
    """``1 - MAC(a, b)`` of real vectors, computed as ``|b_perp|^2 / |b|^2``.

    The same number as ``1 - truthbench.identify.mac(a, b)``, but without the
    cancellation of ``1 - x`` near 1, so it stays accurate down to 1e-30.
    """
    b_perp = b - (a @ b) / (a @ a) * a
    return float((b_perp @ b_perp) / (b @ b))


def _planar_model(n_el: int, p: dict[str, float]):
    """x-z bending model of the tube: (M, K, z-row indices in the reduced DOFs)."""
    from truthbench.fe.assembly import assemble, finish_structure, straight_member

    mesh = straight_member([0.0, 0.0, 0.0], [p["L_m"], 0.0, 0.0], n_el)
    props = {"beam": {k: p[k] for k in ("E_pa", "nu", "rho_kg_m3", "r_m", "t_m")}}
    K, M = assemble(mesh, props)
    nodes = np.arange(mesh.n_nodes)
    clamped = np.concatenate([6 * nodes + d for d in (0, 1, 3, 5)])  # x, y, rx, rz
    Mf, _, Kf, free = finish_structure(K, M, mesh.n_dofs, clamped=clamped)
    z_rows = np.flatnonzero(free % 6 == 2)  # node order
    return Mf, Kf, z_rows


def discretization_study(
    max_elements: int = 40,
    *,
    modes: Sequence[int] = (1, 2),
    parameters: dict[str, float] | None = None,
) -> DiscretizationStudy:
    """Frequency and mode-shape errors of the FE free-free beam against element count.

    Parameters
    ----------
    max_elements : int
        Largest element count; the study runs 1..max_elements (>= 1).
    modes : sequence of int
        Flexible bending modes to study (1 = first), each >= 1.
    parameters : dict, optional
        Overrides of the tube (E_pa, nu, rho_kg_m3, r_m, t_m, L_m; SI units); default the
        nominal aluminium tube of the hub-beam experiment.

    Returns
    -------
    DiscretizationStudy

    Raises
    ------
    ValueError
        ``max_elements < 1``, a mode number < 1, an unknown parameter name.
    """
    from truthbench.model import solve_modes

    if int(max_elements) != max_elements or max_elements < 1:
        raise ValueError(f"max_elements must be a positive integer; got {max_elements!r}")
    modes = tuple(int(m) for m in modes)
    if not modes or min(modes) < 1:
        raise ValueError(f"modes must be flexible mode numbers >= 1; got {modes!r}")
    p = _nominal_tube()
    unknown = sorted(set(parameters or {}) - set(p))
    if unknown:
        raise ValueError(f"unknown tube parameter(s) {unknown}; expected some of {sorted(p)}")
    p.update({k: float(v) for k, v in (parameters or {}).items()})

    # thin-walled tube, Eq. 10.4 (written out here: the reference does not use fe)
    EI = p["E_pa"] * np.pi * p["r_m"] ** 3 * p["t_m"]
    rhoA = p["rho_kg_m3"] * 2.0 * np.pi * p["r_m"] * p["t_m"]
    L = p["L_m"]
    roots = free_free_roots(max(modes))[np.array(modes) - 1]
    omega_exact = roots**2 * np.sqrt(EI / (rhoA * L**4))
    f_exact = omega_exact / (2 * np.pi)

    counts = np.arange(1, int(max_elements) + 1)
    shape = (counts.size, len(modes))
    f_fe = np.full(shape, np.nan)
    mac_err = np.full(shape, np.nan)
    e_err = np.full(shape, np.nan)
    for i, n_el in enumerate(counts):
        Mf, Kf, z_rows = _planar_model(int(n_el), p)
        m = solve_modes(Mf, Kf)
        n_rigid = int(np.count_nonzero(m.rigid))
        if n_rigid != 2:  # pragma: no cover - a broken element or constraint set
            raise RuntimeError(f"{n_el} elements: expected 2 rigid-body modes, found {n_rigid}")
        xi = np.arange(n_el + 1) / n_el
        for k, mode in enumerate(modes):
            col = n_rigid + mode - 1
            if col >= m.n_modes:
                continue
            f_fe[i, k] = m.freq_hz[col]
            if n_el + 1 < mode + 2:
                continue
            phi_fe = m.shapes[z_rows, col]
            phi_ex = free_free_shape(roots[k], xi) / np.sqrt(rhoA * L)
            mac_err[i, k] = _one_minus_mac(phi_ex, phi_fe)
            phi_fe = phi_fe * np.sign(phi_fe @ phi_ex)
            e_err[i, k] = float(np.sum((phi_ex - phi_fe) ** 2) / np.sum(phi_ex**2))
    err = 100.0 * (f_fe - f_exact[None, :]) / f_exact[None, :]
    return DiscretizationStudy(
        n_elements=counts, modes=modes, freq_exact_hz=f_exact, freq_fe_hz=f_fe,
        freq_error_pct=err, mac_error=mac_err, shape_error=e_err, parameters=p)
