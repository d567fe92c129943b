"""The one identifiability check of the updaters: can these data determine these
parameters?

Both updaters linearise: a weighted sensitivity matrix ``A`` (rows: data, columns: the p
parameters) maps parameter changes to data changes. The check, made at every iteration,

1. refuses parameters whose column is zero (the data do not see them);
2. refuses fewer rows than parameters;
3. scales the columns to unit norm (so a parameter with a small but clean effect is not
   mistaken for an unidentifiable one) and refuses a relative singular value below
   ``rcond``, naming the combination of parameters the data cannot see (the last right
   singular vector, in relative changes).

Each updater words the "zero column" case and adds its own hint for the null direction
(:func:`check_identifiable`'s ``explain_dead`` and ``hint``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from truthbench.errors import IdentifiabilityError

T_HINT = (" (Table 10.2: a change in t_m looks exactly like equal changes in E_pa and "
          "rho_kg_m3)")


def check_overdetermined(n_pairs: int, n_parameters: int, *, context: str = "update") -> None:
    """Raise unless ``m r > p`` (Eq. 10.21): more SISO transfer functions than
    parameters."""
    if n_pairs <= n_parameters:
        raise IdentifiabilityError(
            f"{context}: the finite-difference method needs more SISO transfer functions "
            f"than parameters (m r > p); got m r = {n_pairs} for p = {n_parameters} "
            f"parameters. Add sensors, actuators or tests, or update fewer parameters.")


def check_identifiable(
    names: Sequence[str],
    A: np.ndarray,
    rcond: float,
    *,
    data: str,
    dead_tol: float = 1e-14,
    explain_dead: Callable[[list[int]], str] | None = None,
    hint: Callable[[np.ndarray], str] | None = None,
) -> None:
    """Raise :class:`~truthbench.errors.IdentifiabilityError` unless the columns of ``A``
    are seen and separable.

    Parameters
    ----------
    names : sequence of str, length p
    A : ndarray, shape (n_rows, p)
        Weighted (real, stacked) sensitivity matrix.
    rcond : float
        Least relative singular value of the column-scaled ``A``.
    data : str
        What the rows are, for the messages ("the model FRFs at the data's frequencies,
        outputs and inputs").
    dead_tol : float
        A column whose norm is at most ``dead_tol`` times the largest is zero.
    explain_dead : callable, optional
        ``explain_dead(indices) -> message`` for zero columns; default names them.
    hint : callable, optional
        ``hint(v) -> str`` appended to the inseparable-combination message, ``v`` the
        null direction in relative changes scaled to a largest entry of 1.
    """
    names = list(names)
    norms = np.linalg.norm(A, axis=0)
    top = norms.max() if norms.size else 0.0
    dead = [k for k, v in enumerate(norms) if not v > dead_tol * top]
    if dead:
        if explain_dead is not None:
            raise IdentifiabilityError(explain_dead(dead))
        raise IdentifiabilityError(
            f"parameters {[names[k] for k in dead]} do not change {data}; they cannot be "
            f"updated from these data")
    if A.shape[0] < A.shape[1]:
        raise IdentifiabilityError(
            f"{A.shape[0]} equations ({data}) cannot determine p = {A.shape[1]} parameters "
            f"{names}; add data or update fewer parameters")
    _, s, Vt = np.linalg.svd(A / norms, full_matrices=False)
    if s[-1] > rcond * s[0]:
        return
    v = Vt[-1] / norms
    v = v / np.abs(v).max()
    parts = [f"{c:+.2f}*d({n})" for n, c in zip(names, v, strict=True) if abs(c) > 0.05]
    extra = hint(v) if hint is not None else ""
    if not extra and any(n.startswith("t_m") for n in names):
        extra = T_HINT
    raise IdentifiabilityError(
        f"parameters cannot be separated: with its columns scaled to unit norm the "
        f"sensitivity matrix has relative singular value {s[-1] / s[0]:.1e}, below "
        f"rcond = {rcond:.0e}; {data} do not change along {' '.join(parts)} (relative "
        f"changes). Drop one of these parameters or add data that separates them{extra}.")
