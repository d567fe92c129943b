"""The modal-parameter result shared by every identifier and by the pairing tools.

Pole convention: a mode of undamped natural frequency ``omega_n = 2 pi f_n`` (rad/s) and
damping ratio ``zeta`` has the pole ``s = -zeta omega_n + j omega_n sqrt(1 - zeta^2)``
(the one with positive imaginary part; its conjugate is implied). Conversely
``omega_n = |s|`` and ``zeta = -Re(s) / |s|``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from truthbench.identify._common import readonly
from truthbench.presentation import Presentable, figure_axes


def poles_from_modal(freq_hz, damping_ratio) -> np.ndarray:
    """Poles ``s = -zeta w + j w sqrt(1 - zeta^2)`` in rad/s from Hz and damping ratios.

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
        Undamped natural frequencies, Hz.
    damping_ratio : array_like, shape (n,)
        Viscous damping ratios, ``0 <= zeta < 1``.

    Returns
    -------
    ndarray, complex, shape (n,)
        Poles in rad/s with non-negative imaginary part.
    """
    w = 2.0 * np.pi * np.asarray(freq_hz, dtype=float)
    z = np.asarray(damping_ratio, dtype=float)
    return -z * w + 1j * w * np.sqrt(1.0 - z**2)


def modal_from_poles(poles) -> tuple[np.ndarray, np.ndarray]:
    """Undamped natural frequency (Hz) and damping ratio of poles ``s`` (rad/s).

    ``f = |s| / (2 pi)``, ``zeta = -Re(s) / |s|``: the inverse of :func:`poles_from_modal`.
    """
    s = np.asarray(poles, dtype=complex)
    w = np.abs(s)
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta = np.where(w > 0, -s.real / np.where(w > 0, w, 1.0), 0.0)
    return w / (2.0 * np.pi), zeta


@dataclass(frozen=True)
class ModalParameters(Presentable):
    """Modal parameters of one identification or one model.

    Tables (:meth:`to_pandas`): ``"modes"`` one row per mode, ``"shapes"`` one row per
    (mode, output). Figures (:meth:`plot`): ``"shapes"`` the real part of every shape
    (phase-aligned, largest component 1) over the outputs, ``"poles"`` the poles in the
    s-plane.

    Parameters
    ----------
    freq_hz : array_like, shape (n_modes,)
        Undamped natural frequencies, Hz (``|s| / 2 pi``).
    damping_ratio : array_like, shape (n_modes,)
        Viscous damping ratios, ``0 <= zeta < 1``.
    shapes : array_like, shape (n_out, n_modes)
        Mode shapes at the outputs (or model DOFs), real or complex, one column a mode.
    participation : array_like, shape (n_modes, n_in), optional
        Modal participation factors at the inputs, such that the displacement residue
        of mode r is ``shapes[:, r] participation[r, :]^T`` when both come from one
        identification (see :mod:`truthbench.identify.lsfd`).
    output_labels : sequence of str, optional
        One label per row of ``shapes`` (used by :func:`~truthbench.identify.pair_modes`
        ``dof_map``).

    Notes
    -----
    The arrays are stored as read-only copies. Modes are kept in the order given.
    """

    TABLES = ("modes", "shapes")
    PLOTS = ("shapes", "poles")

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    participation: np.ndarray | None = None
    output_labels: tuple[str, ...] | None = field(default=None)

    def __post_init__(self):
        f = np.array(self.freq_hz, dtype=float)
        z = np.array(self.damping_ratio, dtype=float)
        if f.ndim != 1:
            raise ValueError(
                f"The 'freq_hz' parameter must be 1-D (n_modes,); got shape {f.shape}."
            )
        n = f.size
        if z.shape != (n,):
            raise ValueError(
                f"The 'damping_ratio' parameter must have shape ({n},) like 'freq_hz'; "
                f"got shape {z.shape}."
            )
        if not (np.all(np.isfinite(f)) and np.all(f >= 0)):
            raise ValueError("The 'freq_hz' parameter must be finite and non-negative.")
        if not (np.all(np.isfinite(z)) and np.all(z >= 0) and np.all(z < 1)):
            raise ValueError(f"The 'damping_ratio' parameter must lie in [0, 1); got {z.tolist()}.")
        phi = np.array(self.shapes)
        if phi.dtype.kind not in "fc":
            phi = phi.astype(float)
        if phi.ndim == 1 and n == 1:
            phi = phi[:, None]
        if phi.ndim != 2 or phi.shape[1] != n:
            raise ValueError(
                f"The 'shapes' parameter must have shape (n_out, {n}) (one column per "
                f"mode); got shape {phi.shape}."
            )
        object.__setattr__(self, "freq_hz", readonly(f))
        object.__setattr__(self, "damping_ratio", readonly(z))
        object.__setattr__(self, "shapes", readonly(phi))
        if self.participation is not None:
            L = np.array(self.participation)
            if L.ndim == 1:
                L = L[:, None]
            if L.ndim != 2 or L.shape[0] != n:
                raise ValueError(
                    f"The 'participation' parameter must have shape ({n}, n_in); "
                    f"got shape {L.shape}."
                )
            object.__setattr__(self, "participation", readonly(L))
        if self.output_labels is not None:
            labels = tuple(str(v) for v in self.output_labels)
            if len(labels) != phi.shape[0]:
                raise ValueError(
                    f"The 'output_labels' parameter must hold {phi.shape[0]} labels (one "
                    f"per row of 'shapes'); got {len(labels)}."
                )
            if len(set(labels)) != len(labels):
                raise ValueError("The 'output_labels' parameter must not repeat a label.")
            object.__setattr__(self, "output_labels", labels)

    @property
    def n_modes(self) -> int:
        """Number of modes."""
        return int(self.freq_hz.size)

    @property
    def n_out(self) -> int:
        """Number of rows of the shapes (outputs or DOFs)."""
        return int(self.shapes.shape[0])

    @property
    def omega_rad_s(self) -> np.ndarray:
        """Undamped natural circular frequencies, rad/s, shape (n_modes,)."""
        return 2.0 * np.pi * self.freq_hz

    @property
    def poles(self) -> np.ndarray:
        """Poles ``s = -zeta w + j w sqrt(1 - zeta^2)``, rad/s, shape (n_modes,)."""
        return poles_from_modal(self.freq_hz, self.damping_ratio)

    def select(self, modes: Sequence[int] | np.ndarray) -> ModalParameters:
        """Return a new :class:`ModalParameters` holding only the given modes, in order.

        Parameters
        ----------
        modes : sequence of int or boolean mask of shape (n_modes,)
        """
        idx = np.arange(self.n_modes)[np.asarray(modes)]
        return ModalParameters(
            freq_hz=self.freq_hz[idx],
            damping_ratio=self.damping_ratio[idx],
            shapes=self.shapes[:, idx],
            participation=None if self.participation is None else self.participation[idx],
            output_labels=self.output_labels,
        )

    @property
    def labels(self) -> tuple[str, ...]:
        """The output labels, or ``"0"``, ``"1"``, ... when there are none."""
        return self.output_labels or tuple(str(i) for i in range(self.n_out))

    def aligned_shapes(self) -> np.ndarray:
        """The shapes rotated so that every column's largest component is real and
        positive, scaled so that it is 1 (a zero column stays zero), shape (n_out,
        n_modes)."""
        phi = np.asarray(self.shapes, dtype=complex)
        big = phi[np.argmax(np.abs(phi), axis=0), np.arange(self.n_modes)]
        scale = np.where(big != 0, big, 1.0)
        return phi / scale[None, :]

    def _table_shapes(self):
        """One row per (mode, output): columns mode, freq_hz, output, real, imag,
        magnitude, phase_rad of the shapes as given."""
        import pandas as pd

        phi = np.asarray(self.shapes, dtype=complex)
        mode, out = np.meshgrid(np.arange(self.n_modes), np.arange(self.n_out),
                                indexing="ij")
        values = phi.T.ravel()
        return pd.DataFrame({
            "mode": mode.ravel(), "freq_hz": self.freq_hz[mode.ravel()],
            "output": np.array(self.labels, dtype=object)[out.ravel()],
            "real": values.real, "imag": values.imag, "magnitude": np.abs(values),
            "phase_rad": np.angle(values)})

    def _plot_shapes(self, ax):
        """The real part of every aligned shape (:meth:`aligned_shapes`) over the outputs,
        one line per mode."""
        fig, (ax,) = figure_axes(ax, figsize=(7, 4))
        x = np.arange(self.n_out)
        for r in range(self.n_modes):
            ax.plot(x, self.aligned_shapes()[:, r].real, "o-",
                    label=f"{r}: {self.freq_hz[r]:.4g} Hz")
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_xticks(x, self.labels, rotation=45 if self.n_out > 6 else 0)
        ax.set_xlabel("output")
        ax.set_ylabel("shape (largest component 1)")
        if self.n_modes:
            ax.legend(fontsize="small")
        fig.tight_layout()
        return fig

    def _plot_poles(self, ax):
        """The poles ``s`` in the s-plane (real part against imaginary part, rad/s)."""
        fig, (ax,) = figure_axes(ax, figsize=(5, 4))
        s = self.poles
        ax.plot(s.real, s.imag, "x")
        ax.set_xlabel("Re s [rad/s]")
        ax.set_ylabel("Im s [rad/s]")
        ax.grid(True, lw=0.3)
        fig.tight_layout()
        return fig

    def _table_modes(self):
        """One row per mode: columns ``freq_hz``, ``damping_ratio``, ``omega_rad_s``,
        ``pole_real_rad_s``, ``pole_imag_rad_s``; index ``mode`` (0-based)."""
        import pandas as pd

        s = self.poles
        df = pd.DataFrame(
            {
                "freq_hz": self.freq_hz,
                "damping_ratio": self.damping_ratio,
                "omega_rad_s": self.omega_rad_s,
                "pole_real_rad_s": s.real,
                "pole_imag_rad_s": s.imag,
            }
        )
        df.index.name = "mode"
        return df
