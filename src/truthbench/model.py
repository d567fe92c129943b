"""The structural model: M, C, K with inputs and outputs; modes, state space, FRF.

:class:`StructuralModel` is a thin frozen container. The numerics are functions:
:func:`solve_modes` (mass-normalised real modes, rigid-body modes included),
:func:`modal_system` (the modal first-order form, truncated to chosen modes) and
:func:`frf` (the frequency response by modal superposition).

Damping is the sum of a physical part ``C`` (dashpots, joints: generally not
proportional) and a modal part (a damping ratio per elastic mode). When the modal
damping matrix ``Phi^T C Phi + diag(2 zeta omega)`` is diagonal the FRF is the classical
real-mode sum; otherwise it uses the complex modes of the modal first-order form, which
is exact for that form (no proportional-damping approximation).

FRF arrays are complex with shape (n_freq, n_out, n_in). Output rows act on the DOF
vector ``q``; each output is a displacement, velocity or acceleration of that row
(strain is a displacement-type output).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from truthbench.errors import ModelError

QUANTITIES = ("displacement", "velocity", "acceleration")
"""Output quantities; the FRF of each is ``(j omega)^k`` times the displacement FRF."""

_DENSE_LIMIT = 600  # DOFs above which the sparse shift-invert eigensolver is used


def _as_csr(a) -> sp.csr_matrix:
    return a.tocsr() if sp.issparse(a) else sp.csr_matrix(np.asarray(a, dtype=float))


@dataclass(frozen=True)
class StructuralModel:
    """Second-order model ``M q'' + C q' + K q = B u``, ``y = C_out {q, q', q''}``.

    Parameters
    ----------
    M, C, K : sparse or dense, shape (n, n)
        Mass (kg), damping (N s/m) and stiffness (N/m) in consistent SI units.
    B : ndarray, shape (n, n_in)
        Force (or moment) distribution of each input.
    C_out : ndarray, shape (n_out, n)
        Output rows on the DOF vector.
    quantities : tuple of str, length n_out
        "displacement", "velocity" or "acceleration" for each output.
    modal_damping_ratio : float or ndarray
        Damping ratio added to every elastic mode (rigid-body modes get none), or one
        value per mode of the eigensolution (then its length fixes the mode count).
    dof_labels, input_labels, output_labels : tuple of str
    node_positions_m : ndarray, shape (n_nodes, 3), optional
        For mode descriptions and plots.
    """

    M: sp.csr_matrix
    C: sp.csr_matrix
    K: sp.csr_matrix
    B: np.ndarray
    C_out: np.ndarray
    quantities: tuple[str, ...]
    modal_damping_ratio: float | np.ndarray = 0.0
    dof_labels: tuple[str, ...] = ()
    input_labels: tuple[str, ...] = ()
    output_labels: tuple[str, ...] = ()
    node_positions_m: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        M, C, K = _as_csr(self.M), _as_csr(self.C), _as_csr(self.K)
        n = M.shape[0]
        for name, mat in (("M", M), ("C", C), ("K", K)):
            if mat.shape != (n, n):
                raise ModelError(f"matrix {name} has shape {mat.shape}; expected ({n}, {n})")
        B = np.atleast_2d(np.asarray(self.B, dtype=float))
        if B.shape[0] != n:
            raise ModelError(f"input matrix B has {B.shape[0]} rows; expected {n}")
        Co = np.atleast_2d(np.asarray(self.C_out, dtype=float))
        if Co.shape[1] != n:
            raise ModelError(f"output matrix C_out has {Co.shape[1]} columns; expected {n}")
        q = tuple(self.quantities)
        if len(q) != Co.shape[0]:
            raise ModelError(f"quantities has {len(q)} entries; expected one per output "
                             f"({Co.shape[0]})")
        bad = [x for x in q if x not in QUANTITIES]
        if bad:
            raise ModelError(f"unknown output quantity {bad[0]!r}; expected one of {QUANTITIES}")
        for a in (B, Co):
            a.setflags(write=False)
        object.__setattr__(self, "M", M)
        object.__setattr__(self, "C", C)
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "B", B)
        object.__setattr__(self, "C_out", Co)
        object.__setattr__(self, "quantities", q)
        for name, count in (("dof_labels", n), ("input_labels", B.shape[1]),
                            ("output_labels", Co.shape[0])):
            labels = tuple(getattr(self, name)) or tuple(f"{name[0]}{i}" for i in range(count))
            if len(labels) != count:
                raise ModelError(f"{name} has {len(labels)} entries; expected {count}")
            object.__setattr__(self, name, labels)

    @property
    def n_dofs(self) -> int:
        return self.M.shape[0]

    @property
    def n_inputs(self) -> int:
        return self.B.shape[1]

    @property
    def n_outputs(self) -> int:
        return self.C_out.shape[0]

    def modes(self, n_modes: int | None = None) -> Modes:
        """Mass-normalised real modes; see :func:`solve_modes`."""
        return solve_modes(self.M, self.K, n_modes)

    def frf(self, freq_hz, n_modes: int | None = None, modes: Modes | None = None, *,
            decay_rad_s: float = 0.0, mode_tolerance: float = 0.0,
            low_rank_damping: bool = False) -> np.ndarray:
        """FRF by modal superposition, shape (n_freq, n_out, n_in); see :func:`frf`."""
        return frf(self, freq_hz, modes if modes is not None else self.modes(n_modes),
                   decay_rad_s=decay_rad_s, mode_tolerance=mode_tolerance,
                   low_rank_damping=low_rank_damping)

    def state_space(self, n_modes: int | None = None, modes: Modes | None = None):
        """``control.StateSpace`` of the modal first-order form (states: eta, eta')."""
        import control

        A, B, C, D = modal_system(self, modes if modes is not None else self.modes(n_modes))
        return control.ss(A, B, C, D)

    def with_io(self, B=None, C_out=None, quantities=None, input_labels=None,
                output_labels=None) -> StructuralModel:
        """A copy with other inputs and/or outputs (same structure)."""
        from dataclasses import replace

        kw = {}
        if B is not None:
            kw.update(B=B, input_labels=input_labels or ())
        if C_out is not None:
            kw.update(C_out=C_out, quantities=quantities, output_labels=output_labels or ())
        return replace(self, **kw)


@dataclass(frozen=True)
class Modes:
    """Real modes of ``K phi = omega^2 M phi`` with ``Phi^T M Phi = I``.

    Attributes
    ----------
    omega_rad_s : ndarray, shape (m,)
        Natural frequencies, rad/s, ascending; rigid-body modes are exactly 0.
    shapes : ndarray, shape (n, m)
        Mass-normalised mode shapes.
    rigid : ndarray of bool, shape (m,)
        Rigid-body (zero-frequency) modes.
    """

    omega_rad_s: np.ndarray
    shapes: np.ndarray
    rigid: np.ndarray

    @property
    def freq_hz(self) -> np.ndarray:
        return self.omega_rad_s / (2.0 * np.pi)

    @property
    def n_modes(self) -> int:
        return len(self.omega_rad_s)


def solve_modes(M, K, n_modes: int | None = None, *, rigid_tol: float = 1e-12) -> Modes:
    """Mass-normalised real modes, rigid-body modes handled.

    Dense ``scipy.linalg.eigh`` for small models or when all modes are wanted; sparse
    shift-invert ``eigsh`` about a negative shift (so that a singular K, i.e. rigid-body
    modes, is no problem) for the lowest ``n_modes`` of large models.

    Parameters
    ----------
    M, K : sparse or dense, shape (n, n)
    n_modes : int, optional
        Number of lowest modes (default all).
    rigid_tol : float
        A mode is rigid when ``omega^2 < rigid_tol * trace(K)/trace(M)``; its frequency is
        then set to exactly 0 (trace(K)/trace(M) is an average eigenvalue, so this is a
        relative test).

    Returns
    -------
    Modes
    """
    n = M.shape[0]
    if n_modes is not None and not 1 <= n_modes <= n:
        raise ModelError(f"n_modes must lie in 1..{n}; got {n_modes}")
    Ms, Ks = _as_csr(M), _as_csr(K)
    scale = Ks.diagonal().sum() / Ms.diagonal().sum()
    if n_modes is None or n <= _DENSE_LIMIT or n_modes > n // 2:
        sub = None if n_modes is None else (0, n_modes - 1)
        lam, Phi = sla.eigh(Ks.toarray(), Ms.toarray(), subset_by_index=sub)
    else:
        # shift-invert about a small negative shift: K - sigma M is positive definite
        sigma = -1e-6 * scale
        # a fixed start vector keeps ARPACK (and so every result) reproducible
        v0 = np.linspace(1.0, 2.0, n)
        lam, Phi = spla.eigsh(Ks.tocsc(), k=n_modes, M=Ms.tocsc(), sigma=sigma, which="LM",
                              v0=v0)
        order = np.argsort(lam)
        lam, Phi = lam[order], Phi[:, order]
    rigid = lam < rigid_tol * scale
    lam = np.where(rigid, 0.0, lam)
    # enforce mass normalisation exactly (eigsh tolerance, degenerate rigid sets)
    norms = np.sqrt(np.einsum("ij,ij->j", Phi, Ms @ Phi))
    Phi = Phi / norms
    # a deterministic sign: largest-magnitude component positive
    idx = np.argmax(np.abs(Phi), axis=0)
    Phi = Phi * np.sign(Phi[idx, np.arange(Phi.shape[1])])
    return Modes(np.sqrt(lam), Phi, rigid)


def coupled_blocks(*matrices) -> list[np.ndarray]:
    """The groups of DOFs that the matrices couple: the connected components of the
    graph whose edges are their off-diagonal non-zeros.

    A straight beam's axial, torsional and two bending motions are uncoupled (unless
    something couples them: sag, an offset, a skew spring), so its mass, damping and
    stiffness matrices are block-diagonal up to a permutation and each block's modes can
    be solved alone.

    Parameters
    ----------
    *matrices : sparse or dense, shape (n, n)

    Returns
    -------
    list of ndarray of int
        DOF indices of each block, ascending; blocks in order of their first DOF.
    """
    from scipy.sparse.csgraph import connected_components

    n = matrices[0].shape[0]
    mats = [_as_csr(a) for a in matrices]
    # the pattern (not the values) decides: models rebuilt at other parameter values
    # share it, so the components are kept by pattern
    key = (n,) + tuple((a.indptr.tobytes(), a.indices.tobytes(),
                        (a.data != 0).tobytes()) for a in mats)
    if key in _BLOCKS:
        return _BLOCKS[key]
    pattern = sp.csr_matrix((n, n), dtype=bool)
    for a in mats:
        pattern = pattern + (a != 0)
    _, labels = connected_components(pattern, directed=False)
    order = np.argsort(labels, kind="stable")
    cuts = np.flatnonzero(np.diff(labels[order])) + 1
    blocks = sorted((np.sort(b) for b in np.split(order, cuts)), key=lambda b: int(b[0]))
    if len(_BLOCKS) >= 64:
        _BLOCKS.pop(next(iter(_BLOCKS)))
    _BLOCKS[key] = blocks
    return blocks


_BLOCKS: dict = {}
"""Coupled blocks of the last few sparsity patterns (:func:`coupled_blocks`)."""


def solve_block_modes(M, K, dofs, C=None, *, rigid_tol: float = 1e-12) -> Modes:
    """The modes of the coupled blocks (:func:`coupled_blocks` of M, K and C) that
    contain any of ``dofs``, each block solved alone (:func:`solve_modes`), with their
    shapes zero outside the block.

    Any transfer function between DOFs of these blocks is the same as with every mode
    of the model (the other blocks are not coupled to them); a block not touched has no
    modes here. A several-fold speed-up for a beam measured and driven in one plane.

    Parameters
    ----------
    M, K : sparse or dense, shape (n, n)
    dofs : array_like of int
        The DOFs of interest (inputs, outputs).
    C : sparse or dense, shape (n, n), optional
        Physical damping (it may couple blocks too).

    Returns
    -------
    Modes
        Ascending in frequency over the blocks.
    """
    Ms, Ks = _as_csr(M), _as_csr(K)
    mats = (Ms, Ks) if C is None else (Ms, Ks, _as_csr(C))
    wanted = set(int(d) for d in np.atleast_1d(dofs))
    n = Ms.shape[0]
    omegas, shapes, rigids = [], [], []
    for b in coupled_blocks(*mats):
        if not wanted.intersection(b.tolist()):
            continue
        sub = solve_modes(Ms[b][:, b], Ks[b][:, b], rigid_tol=rigid_tol)
        full = np.zeros((n, sub.n_modes))
        full[b] = sub.shapes
        omegas.append(sub.omega_rad_s)
        shapes.append(full)
        rigids.append(sub.rigid)
    if not omegas:
        return Modes(np.zeros(0), np.zeros((n, 0)), np.zeros(0, dtype=bool))
    omega = np.concatenate(omegas)
    order = np.argsort(omega, kind="stable")
    return Modes(omega[order], np.concatenate(shapes, axis=1)[:, order],
                 np.concatenate(rigids)[order])


def modal_damping_matrix(model: StructuralModel, modes: Modes) -> np.ndarray:
    """``Xi = Phi^T C Phi + diag(2 zeta_i omega_i)``, shape (m, m), 1/s."""
    Phi = modes.shapes
    zeta = np.broadcast_to(np.asarray(model.modal_damping_ratio, dtype=float),
                           modes.omega_rad_s.shape)
    if np.any(zeta < 0):
        raise ModelError("modal_damping_ratio must be >= 0")
    Xi = Phi.T @ (model.C @ Phi) if model.C.nnz else np.zeros((modes.n_modes,) * 2)
    return Xi + np.diag(2.0 * zeta * modes.omega_rad_s)


def _output_powers(quantities: Sequence[str]) -> np.ndarray:
    return np.array([QUANTITIES.index(q) for q in quantities])


def modal_system(model: StructuralModel, modes: Modes):
    """Modal first-order form ``x = [eta; eta']``.

    Returns
    -------
    A : ndarray, shape (2m, 2m)
    B : ndarray, shape (2m, n_in)
    C : ndarray, shape (n_out, 2m)
    D : ndarray, shape (n_out, n_in)
        Non-zero only for acceleration outputs.
    """
    m = modes.n_modes
    Om2 = np.diag(modes.omega_rad_s**2)
    Xi = modal_damping_matrix(model, modes)
    Bm = modes.shapes.T @ model.B
    Cm = model.C_out @ modes.shapes
    A = np.block([[np.zeros((m, m)), np.eye(m)], [-Om2, -Xi]])
    B = np.vstack([np.zeros((m, model.n_inputs)), Bm])
    C = np.zeros((model.n_outputs, 2 * m))
    D = np.zeros((model.n_outputs, model.n_inputs))
    for i, p in enumerate(_output_powers(model.quantities)):
        if p == 0:
            C[i, :m] = Cm[i]
        elif p == 1:
            C[i, m:] = Cm[i]
        else:
            C[i] = np.concatenate([-Cm[i] @ Om2, -Cm[i] @ Xi])
            D[i] = Cm[i] @ Bm
    return A, B, C, D


def frf(model: StructuralModel, freq_hz, modes: Modes, *, decay_rad_s: float = 0.0,
        mode_tolerance: float = 0.0, low_rank_damping: bool = False) -> np.ndarray:
    """Frequency response by modal superposition.

    Parameters
    ----------
    model : StructuralModel
    freq_hz : array_like, shape (n_freq,)
        Frequencies, Hz (0 is allowed unless there are undamped rigid-body modes).
    modes : Modes
        The modal basis (all or the lowest modes).
    decay_rad_s : float, optional
        Evaluate the transfer function at ``s = decay_rad_s + j omega`` instead of on the
        imaginary axis: the FRF of the impulse response times ``exp(-decay_rad_s t)``,
        what an exponential window makes of a measured FRF (1/s).
    mode_tolerance : float, optional
        Leave out the uncoupled elastic modes whose resonance peak at these outputs and
        inputs, ``max |c_r omega_r^p b_r| / (omega_r xi_r)`` (p the output's power of
        j omega), is below this fraction of the largest (modes the channels barely see:
        other planes, axial and torsion for bending channels). The response left out is
        at most the number of such modes times this fraction of the largest peak. 0 (the
        default) keeps every mode.
    low_rank_damping : bool, optional
        Physical damping (``model.C``, dashpots) acting on at most
        :data:`LOW_RANK_DOFS` DOFs is added to the classically damped modal solution by
        the Woodbury identity, ``H = H0 - H0_ou (I + s c G_uu)^-1 s c G_ui`` (``u`` the
        DOFs the dashpots touch, ``c`` their block of C, ``G`` the classical receptance),
        instead of through complex modes: the same FRF to round-off, without an
        eigenproblem of twice the modes' size. Every mode is then kept.

    Returns
    -------
    H : ndarray, complex, shape (n_freq, n_out, n_in)
        Output per input in SI units (e.g. (m/s^2)/N for acceleration per force).
    """
    w = 2.0 * np.pi * np.atleast_1d(np.asarray(freq_hz, dtype=float))
    s = 1j * w + decay_rad_s if decay_rad_s else 1j * w
    if low_rank_damping and model.C.nnz:
        touched = np.unique(_as_csr(model.C).nonzero()[0])
        if touched.size <= LOW_RANK_DOFS:
            return _low_rank_damped_frf(model, modes, s, touched)
    Xi = modal_damping_matrix(model, modes)
    Bm = modes.shapes.T @ model.B  # (m, n_in)
    Cm = model.C_out @ modes.shapes  # (n_out, m)
    scale = max(np.abs(Xi).max(), 1e-300)
    off = np.abs(Xi - np.diag(np.diag(Xi))) > 1e-12 * scale
    coupled = off.any(axis=0) | off.any(axis=1)
    # An undamped rigid-body mode (omega = 0, no damping of its own) stays classical: its
    # off-diagonal terms are then only the eigensolver's contamination of the zero
    # eigenspace (about eps * lambda_max / gap, 1e-8 of the shapes), and in the
    # first-order form it would make a double zero eigenvalue (a Jordan block). A
    # rigid-body mode a dashpot really acts on is damped itself and stays coupled.
    coupled &= ~((modes.omega_rad_s == 0) & (np.abs(np.diag(Xi)) <= 1e-9 * scale))
    # modes without damping coupling: classical sum 1 / (w_i^2 - w^2 + j w xi_ii)
    free = ~coupled
    if mode_tolerance > 0:
        w_r = modes.omega_rad_s
        out_pow = _output_powers(model.quantities)
        num = (np.abs(Cm) * w_r[None, :] ** out_pow[:, None]).max(axis=0) \
            * np.abs(Bm).max(axis=1)
        xi = np.diag(Xi)
        damped = (modes.omega_rad_s > 0) & (xi > 0)
        peak = np.where(damped, num / np.where(damped, modes.omega_rad_s * xi, 1.0), np.inf)
        top = np.max(peak[damped & free], initial=0.0)
        free &= ~(damped & (peak < mode_tolerance * top))
    w2, xi = modes.omega_rad_s[free] ** 2, np.diag(Xi)[free]

    def classical(lines):
        return 1.0 / (w2[None, :] + s[lines, None] ** 2 + s[lines, None] * xi)

    H = _modal_sum(Cm[:, free], classical, Bm[free], s.size)
    if coupled.any():
        # modes coupled through non-proportional damping: complex modes of that subset
        H = H + _complex_mode_frf(modes.omega_rad_s[coupled], Xi[np.ix_(coupled, coupled)],
                                  Bm[coupled], Cm[:, coupled], s)
    p = _output_powers(model.quantities)
    return H * (s[:, None, None] ** p[None, :, None])


LOW_RANK_DOFS = 24
"""Physical damping touching at most this many DOFs is added by the Woodbury identity
when :func:`frf` is asked for ``low_rank_damping``."""


def _low_rank_damped_frf(model: StructuralModel, modes: Modes, s: np.ndarray,
                         touched: np.ndarray) -> np.ndarray:
    """:func:`frf` with the physical damping on the DOFs ``touched`` added to the
    classically (modally) damped receptance by the Woodbury identity."""
    zeta = np.broadcast_to(np.asarray(model.modal_damping_ratio, dtype=float),
                           modes.omega_rad_s.shape)
    if np.any(zeta < 0):
        raise ModelError("modal_damping_ratio must be >= 0")
    w = modes.omega_rad_s
    g = 1.0 / (w[None, :] ** 2 + s[:, None] ** 2 + s[:, None] * (2.0 * zeta * w)[None, :])
    Phi = modes.shapes
    Bm = Phi.T @ model.B  # (m, n_in)
    Cm = model.C_out @ Phi  # (n_out, m)
    Pu = Phi[touched]  # (r, m)
    c = _as_csr(model.C)[touched][:, touched].toarray()  # (r, r)
    H0 = np.einsum("om,fm,mi->foi", Cm, g, Bm, optimize=True)
    Gou = np.einsum("om,fm,rm->for", Cm, g, Pu, optimize=True)
    Gui = np.einsum("rm,fm,mi->fri", Pu, g, Bm, optimize=True)
    Guu = np.einsum("rm,fm,qm->frq", Pu, g, Pu, optimize=True)
    sc = s[:, None, None] * c[None]
    r = touched.size
    X = np.linalg.solve(np.eye(r)[None] + sc @ Guu, sc @ Gui)  # (n_f, r, n_in)
    H = H0 - Gou @ X
    p = _output_powers(model.quantities)
    return H * (s[:, None, None] ** p[None, :, None])


_LINES_PER_BLOCK = 512
"""Frequency lines per block of a modal sum (:func:`_modal_sum`): a block's weights,
lines x modes complex numbers, stay in the processor's cache while they are formed and
used (twice as fast as whole arrays for 25 000 lines of 126 modes here)."""


def _modal_sum(left, weights, right, n_lines: int) -> np.ndarray:
    """``H[f, o, i] = sum_k left[o, k] weights(f)[f, k] right[k, i]``, formed in blocks
    of :data:`_LINES_PER_BLOCK` lines: ``weights(lines)`` gives the (block, K) weights of
    a slice of lines, and each block is one matrix product with the residues
    ``left[o, k] right[k, i]``.

    Returns
    -------
    ndarray, complex, shape (n_lines, n_out, n_in)
    """
    if left.shape[1] == 0:  # no mode in this sum (every one coupled, or none kept)
        return np.zeros((n_lines, left.shape[0], right.shape[1]), complex)
    residues = (left.T[:, :, None] * right[:, None, :]).reshape(left.shape[1], -1)
    residues = residues.astype(complex, copy=False)
    H = np.empty((n_lines, residues.shape[1]), complex)
    for a in range(0, n_lines, _LINES_PER_BLOCK):
        lines = slice(a, min(a + _LINES_PER_BLOCK, n_lines))
        np.matmul(weights(lines), residues, out=H[lines])
    return H.reshape(n_lines, left.shape[0], right.shape[1])


def _complex_mode_frf(omega, Xi, Bm, Cm, s):
    """Displacement FRF of the modal form with non-diagonal damping (complex modes)."""
    m = len(omega)
    A = np.block([[np.zeros((m, m)), np.eye(m)], [-np.diag(omega**2), -Xi]])
    lam, V = sla.eig(A)
    Bs = np.vstack([np.zeros_like(Bm), Bm])
    lu = sla.lu_factor(V, check_finite=False)
    # reciprocal condition estimate from the LU factors (LAPACK gecon), no SVD needed
    rcond = sla.lapack.get_lapack_funcs("gecon", (lu[0],))(lu[0], np.linalg.norm(V, 1))[0]
    if rcond > 1e-10:
        L = Cm @ V[:m]  # displacement rows of the state
        R = sla.lu_solve(lu, Bs, check_finite=False)
        return _modal_sum(L, lambda lines: 1.0 / (s[lines, None] - lam[None, :]), R, s.size)
    # defective (e.g. undamped rigid modes coupled to a damper): solve per frequency
    Z = (omega**2)[None, :, None] * np.eye(m)[None] + s[:, None, None] * Xi[None] \
        + (s**2)[:, None, None] * np.eye(m)[None]
    X = np.linalg.solve(Z, np.broadcast_to(Bm, (len(s),) + Bm.shape))
    return np.einsum("om,fmi->foi", Cm, X)


#: The six rigid-body motions, in the order :func:`modal_table` lists rigid-body modes.
RIGID_MOTIONS = ("translation x", "translation y", "translation z",
                 "rotation about x", "rotation about y", "rotation about z")

#: Names of a rigid-body motion lifted to a low frequency by soft supports (z vertical,
#: x along the beam).
SUSPENSION_NAMES = {"translation x": "surge", "translation y": "sway",
                    "translation z": "bounce", "rotation about x": "roll",
                    "rotation about y": "pitch", "rotation about z": "yaw"}

#: An elastic mode is a suspension mode when its rigid-body part carries more than this
#: share of its kinetic energy ...
SUSPENSION_RIGID_SHARE = 0.5
#: ... and that part alone, as a Ritz vector, has at most this ratio of the mode's
#: omega^2: the supports, not the structure's own stiffness, set the frequency.
SUSPENSION_RAYLEIGH_RATIO = 2.0


def _dof_nodes(model: StructuralModel):
    """Node index and direction index (0..5: x, y, z, rx, ry, rz) of every DOF, from the
    ``n<node>.<dir>`` labels; None when a label has another form."""
    dirs = {"x": 0, "y": 1, "z": 2, "rx": 3, "ry": 4, "rz": 5}
    nodes, kinds = [], []
    for lab in model.dof_labels:
        head, _, d = lab.rpartition(".")
        if not head.startswith("n") or not head[1:].isdigit() or d not in dirs:
            return None
        nodes.append(int(head[1:]))
        kinds.append(dirs[d])
    return np.asarray(nodes), np.asarray(kinds)


def rigid_body_motions(model: StructuralModel) -> np.ndarray | None:
    """The six unit rigid-body motions of the model's DOFs, about its centre of mass.

    Column ``k`` is :data:`RIGID_MOTIONS` ``[k]``: a unit translation, or a unit rotation
    (rad) about an axis through the centre of mass (mass-weighted mean node position
    over the translational DOFs), each scaled to unit kinetic energy
    (``r^T M r = 1``; a motion the DOFs cannot show is a zero column).

    Returns
    -------
    ndarray, shape (n_dofs, 6), or None
        None without node positions or with DOF labels not of the form ``n<node>.<dir>``.
    """
    if model.node_positions_m is None:
        return None
    parsed = _dof_nodes(model)
    if parsed is None:
        return None
    nodes, kinds = parsed
    pos = np.asarray(model.node_positions_m, dtype=float)[nodes]  # (n_dofs, 3)
    m = model.M.diagonal()
    trans = kinds < 3
    weight = np.where(trans, np.maximum(m, 0.0), 0.0)
    centre = (weight @ pos) / weight.sum() if weight.sum() > 0 else np.zeros(3)
    r = pos - centre
    R = np.zeros((model.n_dofs, 6))
    for a in range(3):
        R[:, a] = trans & (kinds == a)
        e = np.zeros(3)
        e[a] = 1.0
        u = np.cross(e, r)  # displacement of each DOF's node for a unit rotation about a
        R[:, 3 + a] = np.where(trans, u[np.arange(model.n_dofs), np.minimum(kinds, 2)],
                               (kinds == 3 + a).astype(float))
    norm = np.sqrt(np.einsum("ij,ij->j", R, model.M @ R))
    return R / np.where(norm > 0, norm, 1.0)


def _rigid_labels(model: StructuralModel, R: np.ndarray, Phi: np.ndarray) -> list[str]:
    """One motion of :data:`RIGID_MOTIONS` per column of the rigid-body subspace
    ``Phi`` (n, k), in that order: the pivots of the subspace's coordinates in the
    rigid motions, rotations first (a rotation about an axis off the centre of mass is
    a rotation plus a translation; the rotation names it)."""
    G = R.T @ (model.M @ R)
    C = np.linalg.lstsq(G, R.T @ (model.M @ Phi), rcond=None)[0].T  # (k, 6)
    C = C.copy()
    labels = []
    rows = list(range(C.shape[0]))
    scale = np.abs(C).max() if C.size else 1.0
    for col in (3, 4, 5, 0, 1, 2):
        if not rows:
            break
        piv = max(rows, key=lambda i: abs(C[i, col]))
        if abs(C[piv, col]) <= 1e-6 * scale:
            continue
        C[piv] /= C[piv, col]
        for i in range(C.shape[0]):
            if i != piv:
                C[i] -= C[i, col] * C[piv]
        rows.remove(piv)
        labels.append(RIGID_MOTIONS[col])
    labels.sort(key=RIGID_MOTIONS.index)
    return labels + ["mixed"] * len(rows)


def modal_table(model: StructuralModel, modes: Modes) -> list[dict]:
    """Frequency, damping ratio and a short shape description of every mode.

    Damping ratios come from the complex poles of the modal first-order form (so they
    include non-proportional physical damping), paired to the elastic real modes by an
    assignment on frequency distance (real poles, e.g. a rigid mode with a dashpot, are
    left out).

    Descriptions:

    * rigid-body modes (0 Hz) by their motion, ``"rigid-body translation x"``,
      ``"rigid-body rotation about z"``: the rigid-body subspace is expressed in the six
      rigid motions about the centre of mass and each mode named by a pivot, rotations
      first (:data:`RIGID_MOTIONS`); their order is that of :data:`RIGID_MOTIONS`
      whatever basis the eigensolver returned for the degenerate subspace;
    * suspension modes, a rigid-body motion lifted by soft supports: the mode's
      mass-orthogonal projection on the rigid motions carries more than
      :data:`SUSPENSION_RIGID_SHARE` of its kinetic energy and, as a Ritz vector, has at
      most :data:`SUSPENSION_RAYLEIGH_RATIO` times the mode's omega^2 (an elastic mode
      that merely resembles a rotation, such as a cantilever's first bending, fails this:
      its rigid part strains the clamp). Named by the motion with most of that part's
      kinetic energy: ``"suspension bounce (translation z)"``, ``"suspension pitch
      (rotation about y)"``, ``"suspension sway (translation y)"``, ... (z vertical, x
      along the beam; :data:`SUSPENSION_NAMES`);
    * every other mode by its dominant motion by kinetic-energy share (axial, bending
      y, bending z, torsion) and the sign changes of that translation along the
      structure (nodes): ``"bending z, 2 nodes"``.

    Rows are in order of frequency; modes of equal frequency (to 1e-9 relative, or all
    rigid) are ordered by description, so the table does not change from run to run.
    Models without node positions get the kinetic-energy descriptions only.

    Returns
    -------
    list of dict
        ``mode`` (1-based, in the table's order), ``freq_hz``, ``damping_ratio`` (NaN for
        rigid-body modes), ``shape``.
    """
    m = modes.n_modes
    zeta = complex_modes(model, modes).damping_ratio
    dirs = np.array([lab.rsplit(".", 1)[-1] if "." in lab else "" for lab in model.dof_labels])
    Mdiag = model.M.diagonal()
    names = {"x": "axial", "y": "bending y", "z": "bending z", "rx": "torsion"}
    R_all = rigid_body_motions(model)
    R, motions, rigid_names = None, [], None
    if R_all is not None:
        keep = np.linalg.norm(R_all, axis=0) > 0
        R = R_all[:, keep]
        motions = [mo for mo, k in zip(RIGID_MOTIONS, keep, strict=True) if k]
        rigid = np.flatnonzero(modes.rigid)
        if rigid.size:
            rigid_names = iter(_rigid_labels(model, R_all, modes.shapes[:, rigid]))
    rows = []
    for i in range(m):
        phi = modes.shapes[:, i]
        if modes.rigid[i]:
            motion = next(rigid_names) if rigid_names is not None else None
            desc = f"rigid-body {motion}" if motion and motion != "mixed" else "rigid-body"
        else:
            desc = _suspension(model, R, motions, phi, modes.omega_rad_s[i]) \
                if R is not None else None
        if desc is None:
            energy = {d: float(np.sum(Mdiag[dirs == d] * phi[dirs == d] ** 2)) for d in names}
            dom = max(energy, key=energy.get)
            comp = phi[dirs == dom]
            big = np.abs(comp) > 1e-3 * np.abs(comp).max() if comp.size else comp
            nodes = int(np.sum(np.diff(np.sign(comp[big])) != 0)) if comp.size else 0
            desc = f"{names[dom]}, {nodes} node" + ("s" if nodes != 1 else "")
        rows.append({"freq_hz": float(modes.freq_hz[i]), "damping_ratio": float(zeta[i]),
                     "shape": desc, "rigid": bool(modes.rigid[i])})
    # stable order: frequency, then the description within a degenerate group
    order, k = [], 0
    while k < m:
        g = k + 1
        while g < m and (rows[g]["rigid"] and rows[k]["rigid"] or abs(
                rows[g]["freq_hz"] - rows[k]["freq_hz"]) <= 1e-9 * rows[k]["freq_hz"]):
            g += 1
        group = list(range(k, g))
        if all(rows[j]["rigid"] for j in group) and R is not None:
            pass  # already in RIGID_MOTIONS order
        else:
            group.sort(key=lambda j: rows[j]["shape"])
        order += group
        k = g
    return [{"mode": n + 1, "freq_hz": rows[j]["freq_hz"],
             "damping_ratio": rows[j]["damping_ratio"], "shape": rows[j]["shape"]}
            for n, j in enumerate(order)]


def _suspension(model, R, motions, phi, omega) -> str | None:
    """``"suspension <name> (<motion>)"`` when ``phi`` is a rigid-body motion lifted by
    the supports (see :func:`modal_table`), else None."""
    G = R.T @ (model.M @ R)
    c = np.linalg.lstsq(G, R.T @ (model.M @ phi), rcond=None)[0]
    r = R @ c
    kinetic = float(r @ (model.M @ r))
    total = float(phi @ (model.M @ phi))
    if total <= 0 or kinetic <= SUSPENSION_RIGID_SHARE * total or omega <= 0:
        return None
    rayleigh = float(r @ (model.K @ r)) / kinetic
    if rayleigh > SUSPENSION_RAYLEIGH_RATIO * omega**2:
        return None
    share = c**2 * np.diag(G)
    motion = motions[int(np.argmax(share))]
    return f"suspension {SUSPENSION_NAMES[motion]} ({motion})"


@dataclass(frozen=True)
class ComplexModes:
    """Complex modes of the modal first-order form, one entry per real mode.

    Attributes
    ----------
    poles : ndarray, complex, shape (m,)
        Pole ``s_i`` (rad/s, ``Im s_i > 0``) paired to real mode ``i``; NaN for rigid-body
        modes and modes without an oscillatory pole (overdamped).
    omega_rad_s : ndarray, shape (m,)
        Undamped natural frequency of the pole, ``|s_i|``, rad/s (``omega_i`` itself for
        proportional damping); NaN for rigid-body modes and, with non-proportional
        damping, for elastic modes left without an oscillatory pole.
    damping_ratio : ndarray, shape (m,)
        ``-Re(s_i) / |s_i|`` (``Xi_ii / (2 omega_i)`` for proportional damping): the
        value :func:`modal_table` reports for mode ``i``; NaN as ``omega_rad_s``.
    shapes : ndarray, complex, shape (n, m)
        Physical (displacement) shape ``Phi v_i`` of the pole's eigenvector, scaled so
        that its modal coordinate on its own real mode is ``v_i[i] = 1`` (it is then the
        mass-normalised real shape plus the damping-induced coupling; the real shape
        for proportional damping); NaN as ``omega_rad_s``.
    """

    poles: np.ndarray
    omega_rad_s: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray


def complex_modes(model: StructuralModel, modes: Modes) -> ComplexModes:
    """Exact poles, damping ratios and complex shapes of ``model`` in the basis ``modes``.

    The same computation and pairing as the damping column of :func:`modal_table`: a
    mode without damping coupling (every off-diagonal term of its row and column of the
    modal damping matrix ``Xi``, :func:`modal_damping_matrix`, within ``numpy.allclose``'s
    absolute tolerance 1e-8) has ``zeta_i = Xi_ii / (2 omega_i)``, ``|s_i| = omega_i`` and
    its real shape; for the coupled ones the eigenvalues of their first-order form
    ``[[0, I], [-Omega^2, -Xi]]`` with ``Im s > 1e-9 max|s|`` are assigned to the elastic
    modes by an assignment on relative frequency distance ``| |s| - omega_i | /
    omega_i`` (the eigen-solution of the coupled subset alone: a dashpot at the hub of
    the hub beam couples 41 of its 121 modes).

    Parameters
    ----------
    model : StructuralModel
        Supplies ``C`` and ``modal_damping_ratio`` (``B``, ``C_out`` are not used).
    modes : Modes
        Real modes of ``(M, K)`` (all of them, or the lowest: the first-order form is
        then truncated to them, as in :func:`modal_table`).

    Returns
    -------
    ComplexModes
    """
    Xi = modal_damping_matrix(model, modes)
    m = modes.n_modes
    omega = modes.omega_rad_s
    Phi = modes.shapes
    elastic = np.flatnonzero(~modes.rigid)
    poles = np.full(m, np.nan + 1j * np.nan)
    wn = np.full(m, np.nan)
    zeta = np.full(m, np.nan)
    shapes = np.full(Phi.shape, np.nan + 1j * np.nan)
    # modes without damping coupling (off-diagonal terms within numpy.allclose's
    # absolute tolerance, 1e-8 1/s) keep their own poles: Xi_ii = 2 zeta_i omega_i
    off = np.abs(Xi - np.diag(np.diag(Xi))) > 1e-8
    c = np.flatnonzero(off.any(axis=0) | off.any(axis=1))
    free = np.setdiff1d(np.arange(m), c)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(omega > 0, np.diag(Xi) / (2 * np.maximum(omega, 1e-300)), np.nan)
    zeta[free] = z[free]
    fe = np.intersect1d(free, elastic)
    wn[fe] = omega[fe]
    shapes[:, fe] = Phi[:, fe]
    under = fe[z[fe] < 1]
    poles[under] = omega[under] * (-z[under] + 1j * np.sqrt(1 - z[under] ** 2))
    if c.size == 0:
        return ComplexModes(poles, wn, zeta, shapes)
    # the coupled subset: eigenvalues of its first-order form, assigned to its elastic
    # modes (the free modes' poles are theirs exactly, so the subset is the whole
    # problem's assignment)
    mc = c.size
    A = np.block([[np.zeros((mc, mc)), np.eye(mc)],
                  [-np.diag(omega[c] ** 2), -Xi[np.ix_(c, c)]]])
    lam, V = sla.eig(A)
    osc = np.flatnonzero(lam.imag > 1e-9 * np.abs(lam).max())
    ce = np.flatnonzero(~modes.rigid[c])  # positions in the subset of its elastic modes
    if osc.size and ce.size:
        from scipy.optimize import linear_sum_assignment

        w_ce = omega[c[ce], None]
        cost = np.abs(np.abs(lam[osc])[None, :] - w_ce) / w_ce
        rows, cols = linear_sum_assignment(cost)
        pos, k = ce[rows], osc[cols]
        i = c[pos]
        poles[i] = lam[k]
        wn[i] = np.abs(lam[k])
        zeta[i] = -lam[k].real / np.abs(lam[k])
        v = V[:mc, k]  # modal displacement coordinates, one column per paired mode
        cols_ = np.arange(i.size)
        own = v[pos, cols_]
        # scale by the own coordinate (a mode dominated by others: by its largest one)
        ref = np.where(np.abs(own) > 1e-8 * np.abs(v).max(axis=0), own,
                       v[np.argmax(np.abs(v), axis=0), cols_])
        shapes[:, i] = Phi[:, c] @ (v / ref)
    return ComplexModes(poles, wn, zeta, shapes)
