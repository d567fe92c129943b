"""Mass normalisation of identified shapes through a collocated driving point.

The chapter's Section 10.2.2, issue 4 (:ref:`method-estimation-issues`): every actuator needs
a collocated sensor for correctly scaled shapes.
For a displacement FRF of a (proportionally or modally damped) structure with
mass-normalised shapes ``phi``,

    H_pq(jw) = sum_r [ R_pq,r / (jw - lambda_r) + conj(R_pq,r) / (jw - conj(lambda_r)) ],
    R_pq,r = phi_p,r phi_q,r / (2 j omega_d,r),   omega_d,r = Im(lambda_r),

so with output ``c`` collocated with input ``k``: ``phi_k,r^2 = 2 j omega_d,r R_ck,r`` and
``phi_p,r = 2 j omega_d,r R_pk,r / phi_k,r``. Velocity and acceleration FRFs have
residues ``lambda_r R`` and ``lambda_r^2 R`` at the same poles; ``frf_type`` undoes that.
The square root is the principal one (``phi_k,r`` with non-negative real part), so the
overall sign of each shape is a convention (make it agree with a model by the modal scale
factor, :func:`truthbench.identify.correlation.modal_scale_factor`). For non-proportional
damping the same formula yields complex shapes normalised the same way.
"""

from __future__ import annotations

import warnings

import numpy as np

from truthbench.identify._common import frf_power


def mass_normalize_shapes(
    residues,
    poles,
    collocated_output: int | None,
    *,
    input_index: int = 0,
    frf_type: str = "displacement",
) -> np.ndarray:
    """Mass-normalised shapes from residues and a collocated driving point.

    Parameters
    ----------
    residues : array_like, complex, shape (n_modes, n_out, n_in)
        Residue of the FRF of type ``frf_type`` at each pole (for example
        :attr:`truthbench.identify.lsfd.LSFDResult.residues`).
    poles : array_like, complex, shape (n_modes,)
        Poles, rad/s (the sign of the imaginary part is ignored).
    collocated_output : int or None
        Index of the output collocated with input ``input_index``; ``None`` if there is
        none (then a warning is issued and unscaled shapes are returned).
    input_index : int
        The driving-point input ``k``.
    frf_type : {"displacement", "velocity", "acceleration"}
        Type of the FRF the residues belong to.

    Returns
    -------
    ndarray, complex, shape (n_out, n_modes)
        Mass-normalised shapes (in 1/sqrt(kg) for translations); for proportional damping
        the imaginary part is zero up to estimation error. Without a collocated output:
        the residue columns of input ``k`` scaled to a largest-magnitude entry of 1.
        A mode whose driving-point residue is zero (a node at the driving point) cannot
        be scaled: its column is NaN, with a warning.
    """
    R = np.array(residues, dtype=complex, copy=True)
    if R.ndim != 3:
        raise ValueError(
            f"The 'residues' parameter must have shape (n_modes, n_out, n_in); got shape {R.shape}."
        )
    m, no, ni = R.shape
    lam = np.atleast_1d(np.asarray(poles, dtype=complex)).ravel()
    if lam.shape != (m,):
        raise ValueError(
            f"The 'poles' parameter must have shape ({m},), one per residue; got {lam.shape}."
        )
    q = frf_power(frf_type)
    if not (isinstance(input_index, int | np.integer) and 0 <= input_index < ni):
        raise ValueError(
            f"The 'input_index' parameter must be an integer in [0, {ni - 1}]; got {input_index!r}."
        )
    lam = lam.real + 1j * np.abs(lam.imag)
    if np.any(lam == 0):
        raise ValueError("The 'poles' parameter must not contain a zero pole.")
    D = R[:, :, input_index] / (lam**q)[:, None]  # displacement residues, (m, n_out)
    if collocated_output is None:
        warnings.warn(
            f"mass_normalize_shapes: no output is collocated with input {input_index}; "
            "returning unscaled shapes (largest entry 1). Mass normalisation needs a "
            "collocated driving point.",
            stacklevel=2,
        )
        big = D[np.arange(m), np.argmax(np.abs(D), axis=1)]
        big = np.where(big == 0, 1.0, big)
        return (D / big[:, None]).T
    if not (isinstance(collocated_output, int | np.integer) and 0 <= collocated_output < no):
        raise ValueError(
            f"The 'collocated_output' parameter must be an integer in [0, {no - 1}] or None; "
            f"got {collocated_output!r}."
        )
    a = 2j * lam.imag[:, None] * D  # phi_p phi_k, (m, n_out)
    drive = a[:, collocated_output]
    dead = np.abs(drive) <= 1e-12 * np.max(np.abs(a), axis=1)
    if np.any(dead):
        warnings.warn(
            "mass_normalize_shapes: the driving-point residue is zero for modes "
            f"{np.flatnonzero(dead).tolist()} (a node at the driving point); their shapes "
            "are NaN.",
            stacklevel=2,
        )
    phi_k = np.sqrt(np.where(dead, 1.0, drive))
    out = a / phi_k[:, None]
    out[dead] = np.nan
    return out.T
