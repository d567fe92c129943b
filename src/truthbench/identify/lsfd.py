"""Least-squares frequency-domain (LSFD) residues for known poles.

Given poles ``lambda_r`` (rad/s, one per mode, positive imaginary part) the FRF of type
``q`` (0 displacement, 1 velocity, 2 acceleration) is modelled as

    H(w) = sum_r (jw)^q [ D_r / (jw - lambda_r) + conj(D_r) / (jw - conj(lambda_r)) ]
           + LR (jw)^(q-2) + UR (jw)^q

where ``D_r`` (n_out, n_in) is the *displacement* residue of mode r, ``LR`` the lower
residual (the mass line of modes below the band: ``-LR / w^2`` in receptance) and ``UR``
the upper residual (the stiffness line of modes above the band: a constant in
receptance). ``LR`` and ``UR`` are real. The model is linear in ``Re D, Im D, LR, UR``;
real and imaginary parts are stacked and one least-squares problem, shared by all
``n_out * n_in`` FRFs, is solved with scaled columns.

The *residue of the supplied FRF* at ``lambda_r`` is ``lambda_r^q D_r``; this is what
:class:`LSFDResult` stores in ``residues`` (the mathematically defined residue of the data
the user gave), and :meth:`LSFDResult.displacement_residues` converts back.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from truthbench.errors import IdentifiabilityError
from truthbench.identify._common import check_freq_frf, frf_power, readonly, select_band
from truthbench.identify.modal import ModalParameters, modal_from_poles


@dataclass(frozen=True)
class LSFDResult:
    """Residues and residual terms fitted by :func:`lsfd`.

    Attributes
    ----------
    poles : ndarray, complex, shape (n_modes,)
        Poles used, rad/s (positive imaginary part).
    residues : ndarray, complex, shape (n_modes, n_out, n_in)
        Residue of the supplied FRF (of type ``frf_type``) at each pole, in FRF units
        times rad/s.
    lower_residual : ndarray, float, shape (n_out, n_in) or None
        ``LR`` of the model above (``None`` if not fitted).
    upper_residual : ndarray, float, shape (n_out, n_in) or None
        ``UR`` of the model above (``None`` if not fitted).
    frf_type : str
        ``"displacement"``, ``"velocity"`` or ``"acceleration"``.
    """

    poles: np.ndarray
    residues: np.ndarray
    lower_residual: np.ndarray | None
    upper_residual: np.ndarray | None
    frf_type: str

    def __post_init__(self):
        for name in ("poles", "residues", "lower_residual", "upper_residual"):
            v = getattr(self, name)
            if v is not None:
                object.__setattr__(self, name, readonly(v))

    def displacement_residues(self) -> np.ndarray:
        """Residues of the equivalent displacement FRF, ``residues / lambda^q``.

        Returns
        -------
        ndarray, complex, shape (n_modes, n_out, n_in)
        """
        q = frf_power(self.frf_type)
        return self.residues / (self.poles**q)[:, None, None]

    def reconstruct(self, freq_hz) -> np.ndarray:
        """Evaluate the fitted model (modes plus residual terms) at ``freq_hz``.

        Parameters
        ----------
        freq_hz : array_like, shape (n_freq,)
            Frequencies, Hz (strictly positive if a lower residual was fitted with a
            displacement or velocity FRF).

        Returns
        -------
        ndarray, complex, shape (n_freq, n_out, n_in)
        """
        f = np.asarray(freq_hz, dtype=float)
        q = frf_power(self.frf_type)
        P, _ = _basis(
            f, self.poles, q, self.lower_residual is not None, self.upper_residual is not None
        )
        coef = _pack(self.displacement_residues(), self.lower_residual, self.upper_residual)
        no, ni = self.residues.shape[1:]
        return (P @ coef).reshape(f.size, no, ni)

    def modal_parameters(self) -> ModalParameters:
        """Modal parameters: shapes and participation from a rank-1 split of the residues.

        For each mode the displacement residue ``D_r`` (n_out, n_in) is split by its
        leading singular triplet into ``psi_r L_r^T``; ``psi_r`` is scaled so that its
        largest-magnitude entry is 1 (real), and ``L_r`` absorbs the scale, so
        ``psi_r L_r^T`` is the best rank-1 approximation of ``D_r``. With one input
        this is exact. Shapes are therefore unscaled; see
        :func:`truthbench.identify.mass_normalize_shapes` for mass normalisation.
        """
        D = self.displacement_residues()
        m, no, ni = D.shape
        shapes = np.zeros((no, m), dtype=complex)
        part = np.zeros((m, ni), dtype=complex)
        for r in range(m):
            U, sv, Vh = np.linalg.svd(D[r])
            psi = U[:, 0] * sv[0]
            L = Vh[0]
            k = int(np.argmax(np.abs(psi)))
            c = psi[k] if abs(psi[k]) > 0 else 1.0
            shapes[:, r] = psi / c
            part[r] = L * c
        f, z = modal_from_poles(self.poles)
        return ModalParameters(freq_hz=f, damping_ratio=z, shapes=shapes, participation=part)


def _basis(f_hz: np.ndarray, poles: np.ndarray, q: int, lower: bool, upper: bool):
    """Complex regressors, shape (n_freq, 2 m + n_res), and the count of residual terms."""
    jw = 1j * 2.0 * np.pi * f_hz[:, None]
    lam = poles[None, :]
    a = jw**q / (jw - lam)
    b = jw**q / (jw - np.conj(lam))
    cols = [a + b, 1j * (a - b)]
    n_res = 0
    if lower:
        with np.errstate(divide="ignore", invalid="ignore"):
            cols.append(jw ** (q - 2))
        n_res += 1
    if upper:
        cols.append(jw**q)
        n_res += 1
    return np.concatenate(cols, axis=1), n_res


def _pack(D: np.ndarray, LR, UR) -> np.ndarray:
    """Real coefficient matrix (2 m + n_res, n_out * n_in) matching :func:`_basis`."""
    m, no, ni = D.shape
    flat = D.reshape(m, no * ni)
    rows = [flat.real, flat.imag]
    if LR is not None:
        rows.append(np.asarray(LR, dtype=float).reshape(1, no * ni))
    if UR is not None:
        rows.append(np.asarray(UR, dtype=float).reshape(1, no * ni))
    return np.concatenate(rows, axis=0)


def lsfd(
    freq_hz,
    frf,
    poles,
    *,
    frf_type: str = "displacement",
    lower_residual: bool = True,
    upper_residual: bool = True,
    freq_range_hz: tuple[float, float] | None = None,
) -> LSFDResult:
    """Least-squares frequency-domain residues for given poles.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequency lines, Hz.
    frf : array_like, complex, shape (n_freq, n_out, n_in)
        FRF of type ``frf_type``.
    poles : array_like, complex, shape (n_modes,)
        Poles in rad/s, one per mode; the sign of the imaginary part is ignored (the
        conjugate is always included).
    frf_type : {"displacement", "velocity", "acceleration"}
        Physical type of ``frf`` (receptance, mobility, accelerance).
    lower_residual, upper_residual : bool
        Fit the lower (``LR (jw)^(q-2)``) and upper (``UR (jw)^q``) residual terms.
    freq_range_hz : (float, float), optional
        Use only the lines in this band.

    Returns
    -------
    LSFDResult

    Raises
    ------
    ValueError
        Bad shapes or types.
    IdentifiabilityError
        Fewer real equations (``2 n_freq``) than real unknowns (``2 n_modes + n_res``).

    Notes
    -----
    Lines at 0 Hz are dropped when the lower-residual regressor ``(jw)^(q-2)`` is
    singular there (``q < 2``).
    """
    f, H = check_freq_frf(freq_hz, frf)
    f, H = select_band(f, H, freq_range_hz)
    q = frf_power(frf_type)
    lam = np.atleast_1d(np.asarray(poles, dtype=complex)).ravel()
    if lam.size == 0:
        raise ValueError("The 'poles' parameter must hold at least one pole; got none.")
    if not np.all(np.isfinite(lam)):
        raise ValueError("The 'poles' parameter must be finite.")
    lam = lam.real + 1j * np.abs(lam.imag)
    if lower_residual and q < 2:
        keep = f > 0
        f, H = f[keep], H[keep]
    nf, no, ni = H.shape
    P, n_res = _basis(f, lam, q, lower_residual, upper_residual)
    n_unknown = 2 * lam.size + n_res
    if 2 * nf < n_unknown:
        raise IdentifiabilityError(
            f"lsfd: {nf} usable frequency lines give {2 * nf} real equations per FRF, "
            f"fewer than the {n_unknown} real unknowns ({lam.size} modes x 2 + {n_res} "
            "residual terms); expected more frequency lines or fewer poles."
        )
    A = np.concatenate([P.real, P.imag], axis=0)
    B = H.reshape(nf, no * ni)
    B = np.concatenate([B.real, B.imag], axis=0)
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    X, *_ = np.linalg.lstsq(A / scale, B, rcond=None)
    X = X / scale[:, None]
    m = lam.size
    D = (X[:m] + 1j * X[m : 2 * m]).reshape(m, no, ni)
    k = 2 * m
    LR = UR = None
    if lower_residual:
        LR = X[k].reshape(no, ni)
        k += 1
    if upper_residual:
        UR = X[k].reshape(no, ni)
    return LSFDResult(
        poles=lam,
        residues=D * (lam**q)[:, None, None],
        lower_residual=LR,
        upper_residual=UR,
        frf_type=frf_type,
    )


def refine_poles(
    freq_hz,
    frf,
    poles,
    *,
    frf_type: str = "displacement",
    lower_residual: bool = True,
    upper_residual: bool = True,
    freq_range_hz: tuple[float, float] | None = None,
    output_weighting: str = "rms",
    max_nfev: int = 100,
) -> LSFDResult:
    """Output-error refinement of poles: nonlinear least squares on the LSFD model.

    Minimises ``sum |W (H - H_model(lambda, D, LR, UR))|^2`` over the poles, with the
    residues and residual terms eliminated by linear least squares at each step
    (variable projection). Each pole is parameterised by ``log w_n`` and ``log zeta``.
    With additive white noise of equal variance on the weighted FRFs this is the
    maximum-likelihood estimate, which removes the noise bias of the linearised
    (equation-error) pLSCF poles; it needs good starting poles and cannot add a mode that
    is missing from ``poles``.

    Parameters
    ----------
    freq_hz, frf, frf_type, lower_residual, upper_residual, freq_range_hz
        As for :func:`lsfd`.
    poles : array_like, complex, shape (n_modes,)
        Starting poles, rad/s, with ``0 < zeta < 1``.
    output_weighting : {"rms", "none"}
        ``W``: divide each output's FRFs by their RMS over frequency and inputs, or not.
    max_nfev : int
        Largest number of residual evaluations of :func:`scipy.optimize.least_squares`.

    Returns
    -------
    LSFDResult
        With the refined poles and the residues fitted to the unweighted data. A warning
        is issued if the optimiser stops without meeting its tolerances.
    """
    from scipy.optimize import least_squares

    f, H = check_freq_frf(freq_hz, frf)
    f, H = select_band(f, H, freq_range_hz)
    q = frf_power(frf_type)
    lam0 = np.atleast_1d(np.asarray(poles, dtype=complex)).ravel()
    if lam0.size == 0:
        raise ValueError("The 'poles' parameter must hold at least one pole; got none.")
    f0, z0 = modal_from_poles(lam0.real + 1j * np.abs(lam0.imag))
    if not (np.all(np.isfinite(lam0)) and np.all((z0 > 0) & (z0 < 1)) and np.all(f0 > 0)):
        raise ValueError(
            "The 'poles' parameter must hold finite poles with 0 < zeta < 1 and a non-zero "
            f"frequency; got damping ratios {z0.tolist()}."
        )
    if output_weighting not in ("rms", "none"):
        raise ValueError(
            f"The 'output_weighting' parameter must be 'rms' or 'none'; got {output_weighting!r}."
        )
    if lower_residual and q < 2:
        keep = f > 0
        f, H = f[keep], H[keep]
    nf, no, ni = H.shape
    m = lam0.size
    n_res = int(lower_residual) + int(upper_residual)
    if 2 * nf < 2 * m + n_res:
        raise IdentifiabilityError(
            f"refine_poles: {nf} usable frequency lines give {2 * nf} real equations per "
            f"FRF, fewer than the {2 * m + n_res} real unknowns; expected more lines."
        )
    Hw = H
    if output_weighting == "rms":
        rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=(0, 2)))
        rms[rms == 0] = 1.0
        Hw = H / rms[None, :, None]
    B = Hw.reshape(nf, no * ni)
    B = np.concatenate([B.real, B.imag], axis=0)

    def to_poles(x: np.ndarray) -> np.ndarray:
        wn = np.exp(x[:m])
        z = np.minimum(np.exp(x[m:]), 0.999)
        return -z * wn + 1j * wn * np.sqrt(1.0 - z**2)

    def residual(x: np.ndarray) -> np.ndarray:
        P, _ = _basis(f, to_poles(x), q, lower_residual, upper_residual)
        A = np.concatenate([P.real, P.imag], axis=0)
        scale = np.linalg.norm(A, axis=0)
        scale[scale == 0] = 1.0
        Qm, _ = np.linalg.qr(A / scale)  # residual of the linear LS: (I - Q Q^T) B
        return (B - Qm @ (Qm.T @ B)).ravel()

    x0 = np.concatenate([np.log(2.0 * np.pi * f0), np.log(z0)])
    sol = least_squares(residual, x0, method="lm", max_nfev=max_nfev)
    if sol.status <= 0:
        warnings.warn(
            f"refine_poles: the optimiser stopped without converging ({sol.message}); "
            "returning its last poles.",
            stacklevel=2,
        )
    return lsfd(
        f,
        H,
        to_poles(sol.x),
        frf_type=frf_type,
        lower_residual=lower_residual,
        upper_residual=upper_residual,
    )
