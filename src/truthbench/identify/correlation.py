"""Correlation of mode shapes and pairing of test modes to model modes (the chapter's
Section 10.2.2, issue 5, Eq. 10.28-10.30; :ref:`method-correlation`).

* MAC (Eq. 10.28), Hermitian form for complex shapes:
  ``MAC = |a^H b|^2 / ((a^H a)(b^H b))``; for real shapes this is
  ``(a^T b)^2 / ((a^T a)(b^T b))``. It is invariant to scaling either shape by any
  non-zero (complex) factor.
* COMAC (Eq. 10.29), ``i`` a DOF and ``j`` the paired modes:
  ``COMAC_i = |sum_j conj(phi_ij) phit_ij|^2 / (sum_j |phi_ij|^2 sum_j |phit_ij|^2)``.
  Unlike the MAC it depends on the relative sign (phase) and scale of the paired shapes,
  so by default (``align=True``) each test shape is first scaled onto its model partner by
  the modal scale factor.
* Shape error (Eq. 10.30): ``e_i = sum_j |phi_ji - MSF_i phit_ji|^2`` over DOFs ``j`` for
  mode ``i``, after the modal scale factor ``MSF_i = (phit_i^H phi_i) / (phit_i^H phit_i)``
  (the least-squares scale of the test shape onto the model shape). Sign handling: the MSF
  is negative (or, for complex shapes, of any phase) when the test shape is flipped, so a
  sign flip costs nothing; only the part of the test shape not parallel to the model shape
  contributes.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from truthbench.identify._common import as_shape_matrix, readonly
from truthbench.identify.modal import ModalParameters
from truthbench.presentation import Presentable, figure_axes


def mac(phi_a, phi_b) -> np.ndarray:
    """Modal assurance criterion between every column of ``phi_a`` and of ``phi_b``.

    Parameters
    ----------
    phi_a : array_like, shape (n_dof, n_a) or (n_dof,)
    phi_b : array_like, shape (n_dof, n_b) or (n_dof,)
        Real or complex shapes on the same DOFs.

    Returns
    -------
    ndarray, shape (n_a, n_b)
        MAC values in [0, 1]; 0 where a shape is identically zero.
    """
    a = as_shape_matrix(phi_a, "phi_a")
    b = as_shape_matrix(phi_b, "phi_b")
    if a.shape[0] != b.shape[0]:
        raise ValueError(
            f"The 'phi_a' and 'phi_b' parameters must have the same number of DOFs (rows); "
            f"got {a.shape[0]} and {b.shape[0]}."
        )
    num = np.abs(a.conj().T @ b) ** 2
    den = np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    return np.clip(out, 0.0, 1.0)


def auto_mac(phi) -> np.ndarray:
    """MAC of a shape set with itself, shape (n_modes, n_modes); 1 on the diagonal."""
    return mac(phi, phi)


def modal_scale_factor(phi_ref, phi) -> np.ndarray:
    """Least-squares factors ``MSF_i`` with ``MSF_i phi_i ~ phi_ref_i``, per column.

    Parameters
    ----------
    phi_ref, phi : array_like, shape (n_dof, n_modes)
        Paired shapes (column ``i`` of one with column ``i`` of the other).

    Returns
    -------
    ndarray, shape (n_modes,)
        ``(phi_i^H phi_ref_i) / (phi_i^H phi_i)`` (real for real shapes).
    """
    a, b = _paired(phi_ref, phi, "phi_ref", "phi")
    num = np.sum(b.conj() * a, axis=0)
    den = np.sum(np.abs(b) ** 2, axis=0)
    if np.any(den == 0):
        raise ValueError("The 'phi' parameter has an identically zero shape; no scale factor.")
    return num / den


def _paired(phi_a, phi_b, name_a: str, name_b: str):
    a = as_shape_matrix(phi_a, name_a)
    b = as_shape_matrix(phi_b, name_b)
    if a.shape != b.shape:
        raise ValueError(
            f"The '{name_a}' and '{name_b}' parameters must have the same shape (n_dof, "
            f"n_paired_modes); got {a.shape} and {b.shape}."
        )
    return a, b


def comac(phi_model, phi_test, *, align: bool = True) -> np.ndarray:
    """Coordinate MAC per DOF over paired modes (Eq. 10.29).

    Parameters
    ----------
    phi_model, phi_test : array_like, shape (n_dof, n_paired)
        Paired shapes: column ``j`` of each belongs to pair ``j``.
    align : bool
        Scale each test shape onto its model partner by the modal scale factor first
        (fixes sign/phase and scale). With ``align=False`` the formula is applied to the
        shapes as given.

    Returns
    -------
    ndarray, shape (n_dof,)
        Values in [0, 1]; 0 where a DOF has no motion in either set.
    """
    a, b = _paired(phi_model, phi_test, "phi_model", "phi_test")
    if align:
        b = b * modal_scale_factor(a, b)[None, :]
    num = np.abs(np.sum(a.conj() * b, axis=1)) ** 2
    den = np.sum(np.abs(a) ** 2, axis=1) * np.sum(np.abs(b) ** 2, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def shape_error(phi_model, phi_test, *, relative: bool = False) -> np.ndarray:
    """Quadratic shape error per paired mode (Eq. 10.30) after modal-scale-factor scaling.

    Parameters
    ----------
    phi_model, phi_test : array_like, shape (n_dof, n_paired)
    relative : bool
        Divide ``e_i`` by ``sum_j |phi_model_ji|^2`` (then ``e_i = 1 - MAC_i``).

    Returns
    -------
    ndarray, shape (n_paired,)
        ``e_i = sum_j |phi_model_ji - MSF_i phi_test_ji|^2`` in the units of the shapes
        squared (dimensionless if ``relative``).
    """
    a, b = _paired(phi_model, phi_test, "phi_model", "phi_test")
    e = np.sum(np.abs(a - b * modal_scale_factor(a, b)[None, :]) ** 2, axis=0)
    if relative:
        e = e / np.sum(np.abs(a) ** 2, axis=0)
    return e


@dataclass(frozen=True)
class ModePairing(Presentable):
    """Pairs of model and test modes.

    Table ``"pairs"`` (:meth:`to_pandas`): one row per pair. Figure ``"mac"``
    (:meth:`plot`): the MAC matrix with the pairs marked.

    Attributes
    ----------
    pairs : ndarray, int, shape (n_pairs, 2)
        ``(model mode index, test mode index)``, sorted by model index.
    mac : ndarray, shape (n_pairs,)
        MAC of each pair.
    freq_error : ndarray, shape (n_pairs,)
        ``(f_test - f_model) / f_model`` of each pair.
    unpaired_model, unpaired_test : ndarray, int
        Indices of the modes left without a partner.
    doubtful : ndarray, bool, shape (n_pairs,)
        True when the pair's MAC is below ``mac_doubtful`` or another candidate of either
        mode comes within ``ambiguity_margin`` of the pair's MAC.
    mac_matrix : ndarray, shape (n_model, n_test)
        MAC of every model mode with every test mode on the mapped DOFs.
    """

    TABLES = ("pairs",)
    PLOTS = ("mac",)

    pairs: np.ndarray
    mac: np.ndarray
    freq_error: np.ndarray
    unpaired_model: np.ndarray
    unpaired_test: np.ndarray
    doubtful: np.ndarray
    mac_matrix: np.ndarray

    def __post_init__(self):
        for name in (
            "pairs",
            "mac",
            "freq_error",
            "unpaired_model",
            "unpaired_test",
            "doubtful",
            "mac_matrix",
        ):
            object.__setattr__(self, name, readonly(getattr(self, name)))

    def _plot_mac(self, ax):
        """The MAC of every model mode (rows) with every test mode (columns), the pairs
        circled (doubtful ones thinner)."""
        fig, (ax,) = figure_axes(ax, figsize=(5.5, 4.5))
        image = ax.imshow(self.mac_matrix, vmin=0.0, vmax=1.0, cmap="Greys", origin="lower",
                          aspect="auto")
        for (m, t), doubtful in zip(self.pairs, self.doubtful, strict=True):
            ax.plot(t, m, "o", mfc="none", mec="tab:red", ms=12,
                    ls="none", mew=1.5 if not doubtful else 0.8)
        fig.colorbar(image, ax=ax, label="MAC")
        ax.set_xlabel("test mode")
        ax.set_ylabel("model mode")
        fig.tight_layout()
        return fig

    def _table_pairs(self):
        """One row per pair: model and test index, MAC, frequency error, doubtful flag."""
        import pandas as pd

        return pd.DataFrame(
            {
                "model_mode": self.pairs[:, 0],
                "test_mode": self.pairs[:, 1],
                "mac": self.mac,
                "freq_error": self.freq_error,
                "doubtful": self.doubtful,
            }
        )


def _resolve_dof_map(model: ModalParameters, test: ModalParameters, dof_map):
    """Row indices (test_rows, model_rows) of the DOFs both sets share."""

    def row_of(p: ModalParameters, key, who: str) -> int:
        if isinstance(key, str):
            if p.output_labels is None or key not in p.output_labels:
                raise ValueError(
                    f"The 'dof_map' parameter names the {who} DOF {key!r}, which is not in "
                    f"the {who} output_labels {p.output_labels}."
                )
            return p.output_labels.index(key)
        try:
            k = int(key)
        except (TypeError, ValueError):
            raise ValueError(
                f"The 'dof_map' parameter must map labels or indices; got {key!r} for the {who}."
            ) from None
        if not 0 <= k < p.n_out:
            raise ValueError(
                f"The 'dof_map' parameter gives {who} DOF index {k}, outside [0, {p.n_out - 1}]."
            )
        return k

    if dof_map is None:
        if model.n_out != test.n_out:
            raise ValueError(
                f"The model shapes have {model.n_out} DOFs and the test shapes {test.n_out}; "
                "give 'dof_map' (test DOF -> model DOF) when they differ."
            )
        r = np.arange(test.n_out)
        return r, r
    if isinstance(dof_map, Mapping):
        items = list(dof_map.items())
    elif isinstance(dof_map, Sequence) and not isinstance(dof_map, str):
        if len(dof_map) != test.n_out:
            raise ValueError(
                f"The 'dof_map' parameter as a sequence must give one model DOF per test DOF "
                f"({test.n_out}); got {len(dof_map)}."
            )
        items = list(enumerate(dof_map))
    else:
        raise ValueError(
            "The 'dof_map' parameter must be a mapping {test DOF: model DOF} or a sequence "
            f"of model DOFs, one per test DOF; got {type(dof_map).__name__}."
        )
    if not items:
        raise ValueError("The 'dof_map' parameter maps no DOF.")
    t_rows = np.array([row_of(test, k, "test") for k, _ in items])
    m_rows = np.array([row_of(model, v, "model") for _, v in items])
    if np.unique(t_rows).size != t_rows.size or np.unique(m_rows).size != m_rows.size:
        raise ValueError("The 'dof_map' parameter maps a DOF twice.")
    return t_rows, m_rows


def pair_modes(
    model: ModalParameters,
    test: ModalParameters,
    *,
    mac_min: float = 0.6,
    freq_weight: float = 1.0,
    dof_map: Mapping | Sequence | None = None,
    mac_doubtful: float = 0.9,
    ambiguity_margin: float = 0.1,
) -> ModePairing:
    """Pair test modes to model modes by an optimal assignment on MAC and frequency.

    The cost of pairing model mode ``i`` with test mode ``j`` is
    ``(1 - MAC_ij) + freq_weight |f_j - f_i| / f_i``; pairs whose MAC is below ``mac_min``
    are forbidden. :func:`scipy.optimize.linear_sum_assignment` minimises the total cost;
    a mode left over (more modes on one side, or no admissible partner) is unpaired.

    Parameters
    ----------
    model, test : ModalParameters
    mac_min : float
        Smallest MAC of an admissible pair.
    freq_weight : float
        Weight of the relative frequency distance (0: MAC only). With the default 1, a
        1 % frequency difference costs as much as 0.01 of MAC.
    dof_map : mapping or sequence, optional
        Test DOF -> model DOF: a mapping from test row index or label (``output_labels``)
        to model row index or label, or a sequence giving the model DOF of each test row.
        Default: the same rows on both sides. Only mapped DOFs enter the MAC.
    mac_doubtful : float
        Pairs with a MAC below this are flagged doubtful.
    ambiguity_margin : float
        A pair is also doubtful when a second candidate of either mode (with
        ``MAC >= mac_min``) has a MAC within this margin of the pair's MAC.

    Returns
    -------
    ModePairing
    """
    if not isinstance(model, ModalParameters) or not isinstance(test, ModalParameters):
        raise ValueError(
            "The 'model' and 'test' parameters must be ModalParameters; got "
            f"{type(model).__name__} and {type(test).__name__}."
        )
    if not 0 <= mac_min <= 1:
        raise ValueError(f"The 'mac_min' parameter must lie in [0, 1]; got {mac_min!r}.")
    if not (np.isfinite(freq_weight) and freq_weight >= 0):
        raise ValueError(f"The 'freq_weight' parameter must be >= 0; got {freq_weight!r}.")
    t_rows, m_rows = _resolve_dof_map(model, test, dof_map)
    if t_rows.size < 2:
        warnings.warn(
            f"pair_modes: only {t_rows.size} DOF is shared; every MAC is 1 or 0.",
            stacklevel=2,
        )
    M = mac(model.shapes[m_rows], test.shapes[t_rows])
    fm, ft = model.freq_hz, test.freq_hz
    with np.errstate(divide="ignore", invalid="ignore"):
        df = np.abs(ft[None, :] - fm[:, None]) / np.where(fm > 0, fm, np.inf)[:, None]
    cost = (1.0 - M) + freq_weight * df
    admissible = M >= mac_min
    big = 1e6
    from scipy.optimize import linear_sum_assignment

    pairs = np.zeros((0, 2), dtype=int)
    if M.size:
        rows, cols = linear_sum_assignment(np.where(admissible, cost, big))
        ok = admissible[rows, cols]
        pairs = np.column_stack([rows[ok], cols[ok]]).astype(int)
    pm, pt = pairs[:, 0], pairs[:, 1]
    pair_mac = M[pm, pt]
    freq_error = (ft[pt] - fm[pm]) / fm[pm] if pairs.size else np.zeros(0)
    doubtful = pair_mac < mac_doubtful
    for k, (i, j) in enumerate(pairs):
        others_t = np.delete(M[i, :], j)
        others_m = np.delete(M[:, j], i)
        rivals = np.concatenate([others_t, others_m])
        rivals = rivals[rivals >= mac_min]
        if rivals.size and np.max(rivals) >= pair_mac[k] - ambiguity_margin:
            doubtful[k] = True
    return ModePairing(
        pairs=pairs,
        mac=pair_mac,
        freq_error=freq_error,
        unpaired_model=np.setdiff1d(np.arange(model.n_modes), pm),
        unpaired_test=np.setdiff1d(np.arange(test.n_modes), pt),
        doubtful=doubtful,
        mac_matrix=M,
    )
