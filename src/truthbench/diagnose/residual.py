"""The residual between data and a model, in every view that carries a signature.

Each view, what it is, and what it points at:

- **FRF error**: ``sqrt(sum |w (D - M)|^2 / sum |w D|^2)``, ``w = 1/sigma``; anything.
- **reduced chi2**: ``chi2 / (n - p)``, 1 when the residual is noise; anything.
- **phase slope**: ``-d arg(D / M) / d omega`` from the weighted mean phase step between
  adjacent lines; a time delay.
- **magnitude ratio**: per channel, least squares ``|D| / |M|``; a gain error.
- **modal residuals**: identified data modes paired with the model's (MAC): frequency and
  damping errors, MAC, modal complexity (MPC: 1 for a real mode); structural changes
  (mass, stiffness, concentrated damping).
- **level dependence**: for tests with the same channels, the difference of their FRFs
  over its noise (reduced chi2); a nonlinearity.
- **reciprocity**: ``H_ab`` against ``H_ba`` over their noise; non-reciprocal coupling,
  a loop.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ChannelResidual:
    """The residual of one (test, output, input) transfer function."""

    test: str
    output: str
    input: str
    frf_error: float
    reduced_chi2: float
    magnitude_ratio: float
    delay_s: float


@dataclass(frozen=True)
class PairDifference:
    """Two transfer functions that should agree (same channels in two tests, or a
    reciprocal pair): their difference over its noise."""

    kind: str
    first: str
    second: str
    reduced_chi2: float
    relative_difference: float
    n_lines: int


@dataclass(frozen=True)
class ModeResidual:
    """A data mode paired with a model mode."""

    test: str
    freq_hz: float
    freq_error_pct: float
    damping_ratio: float
    damping_error_pct: float
    mac: float
    mpc: float


@dataclass(frozen=True)
class Residual:
    """Data against one model.

    Attributes
    ----------
    frf_error : float
        Noise-weighted relative RMS of the FRF residual over every compared value.
    chi2 : float
    reduced_chi2 : float
        ``chi2 / (n - p)``.
    delay_s : float
        Delay implied by the slope of the phase residual, s.
    channels : tuple of ChannelResidual
    modes : tuple of ModeResidual
    pairs : tuple of PairDifference
        Level dependence (same channels, two tests) and reciprocity.
    """

    frf_error: float
    chi2: float
    reduced_chi2: float
    delay_s: float
    channels: tuple[ChannelResidual, ...]
    modes: tuple[ModeResidual, ...] = ()
    pairs: tuple[PairDifference, ...] = ()


def phase_slope_delay(freq_hz: np.ndarray, D: np.ndarray, M: np.ndarray,
                      w: np.ndarray) -> float:
    """Delay from the weighted mean phase step of ``D conj(M)`` between adjacent lines
    (no unwrapping), s. Arrays (n_lines, ...) along the lines."""
    f = np.asarray(freq_hz, dtype=float)
    if f.size < 2:
        return 0.0
    z = (D * np.conj(M) * w**2).reshape(f.size, -1)
    df = np.diff(f)
    step = np.median(df)
    adjacent = np.isclose(df, step)
    acc = np.sum((z[1:] * np.conj(z[:-1]))[adjacent])
    return 0.0 if acc == 0 else float(-np.angle(acc) / (2 * np.pi * step))


#: The longest delay the matched-delay profile looks at, in periods of the band's top
#: frequency (64 samples at twice that rate: a sigma-delta converter's filter and a
#: controller's frame) and as a share of the record (beyond it the estimator's bias
#: dominates).
DELAY_PERIODS = 64.0
DELAY_RECORD_SHARE = 0.05


def matched_delay(freq_hz: np.ndarray, D: np.ndarray, M: np.ndarray, w: np.ndarray,
                  tau0: float) -> float:
    """The delay that best explains ``D ~ M exp(-j omega tau)``: the maximum of
    ``Re sum w^2 conj(D) M exp(-j omega tau)`` (the chi2 profile of a pure delay with the
    model held), s.

    The profile is sampled at an eighth of the top line's period, over
    ``0 <= tau <= max(3 tau0, min(DELAY_PERIODS / f_max, DELAY_RECORD_SHARE / df))``
    (``df`` the line spacing), and refined by a parabola through the best sample and its
    neighbours. Arrays (n_values, ...) along the values, ``freq_hz`` each value's line;
    values on one line are summed before the profile is taken.
    """
    f = np.asarray(freq_hz, dtype=float)
    z = (np.conj(D) * M * w**2).reshape(f.size, -1).sum(axis=1)
    lines, where = np.unique(f, return_inverse=True)
    z = (np.bincount(where, z.real, lines.size)
         + 1j * np.bincount(where, z.imag, lines.size))
    f_max = float(lines.max())
    if f_max <= 0:
        return 0.0
    df = float(np.median(np.diff(lines))) if lines.size > 1 else f_max
    top = max(3 * max(tau0, 0.0), min(DELAY_PERIODS / f_max, DELAY_RECORD_SHARE / df))
    dt = 1.0 / (8 * f_max)
    taus = np.arange(int(np.ceil(top / dt)) + 1) * dt
    w_rad = 2 * np.pi * lines
    c = np.concatenate([np.real(np.exp(-1j * np.outer(taus[k:k + 256], w_rad)) @ z)
                        for k in range(0, taus.size, 256)])
    k = int(np.argmax(c))
    if 0 < k < taus.size - 1:
        a, b, d = c[k - 1], c[k], c[k + 1]
        den = a - 2 * b + d
        if den < 0:
            return float(taus[k] + 0.5 * (a - d) / den * dt)
    return float(taus[k])


def channel_residuals(tests, model_parts: Sequence[np.ndarray], n_parameters: int
                      ) -> tuple[ChannelResidual, ...]:
    """Per (test, output, input) views; ``model_parts[j]`` is test j's model FRF at its
    lines, shape (n_lines, n_out, n_in)."""
    out = []
    n_values = 2 * sum(t.H.size for t in tests)
    for t, M in zip(tests, model_parts, strict=True):
        w = 1.0 / t.sigma
        for o, s in enumerate(t.sensors):
            for i, a in enumerate(t.actuators):
                d, m, wi = t.H[:, o, i], M[:, o, i], w[:, o, i]
                r2 = np.abs(wi * (d - m)) ** 2
                share = n_parameters * 2 * d.size / n_values  # this channel's parameters
                out.append(ChannelResidual(
                    t.name, s.label, a.label,
                    float(np.sqrt(r2.sum() / max(np.sum(np.abs(wi * d) ** 2), 1e-300))),
                    float(r2.sum() / max(2 * d.size - share, 1.0)),
                    float(np.sum(wi**2 * np.abs(d) * np.abs(m))
                          / max(np.sum(wi**2 * np.abs(m) ** 2), 1e-300)),
                    phase_slope_delay(t.freq_hz, d, m, wi)))
    return tuple(out)


def pair_differences(tests) -> tuple[PairDifference, ...]:
    """Same channels in two tests (level dependence, repeatability) and reciprocal pairs
    (input at a, output at b against input at b, output at a, same quantity)."""
    out = []
    tfs = []
    for t in tests:
        for o, s in enumerate(t.sensors):
            for i, a in enumerate(t.actuators):
                tfs.append((t, o, i, (a.station, a.direction), (s.station, s.direction),
                            s.quantity))
    for x in range(len(tfs)):
        for y in range(x + 1, len(tfs)):
            t1, o1, i1, a1, s1, q1 = tfs[x]
            t2, o2, i2, a2, s2, q2 = tfs[y]
            if q1 != q2:
                continue
            if t1 is not t2 and a1 == a2 and s1 == s2:
                kind = "same channels"
            elif a1 == s2 and s1 == a2 and a1 != s1:
                kind = "reciprocity"
            else:
                continue
            f1, f2 = t1.freq_hz, t2.freq_hz
            common, k1, k2 = np.intersect1d(np.round(f1, 9), np.round(f2, 9),
                                            return_indices=True)
            if common.size < 2:
                continue
            d1, d2 = t1.H[k1, o1, i1], t2.H[k2, o2, i2]
            var = t1.sigma[k1, o1, i1] ** 2 + t2.sigma[k2, o2, i2] ** 2
            chi2 = float(np.sum(np.abs(d1 - d2) ** 2 / var)) / (2 * common.size)
            rel = float(np.linalg.norm(d1 - d2) / max(np.linalg.norm(d1), 1e-300))
            out.append(PairDifference(
                kind, f"{t1.name}: {t1.sensors[o1].label}/{t1.actuators[i1].label}",
                f"{t2.name}: {t2.sensors[o2].label}/{t2.actuators[i2].label}", chi2, rel,
                int(common.size)))
    return tuple(out)


def mpc(shape: np.ndarray) -> float:
    """Modal phase collinearity of a complex shape: ``((l1 - l2) / (l1 + l2))^2`` with
    ``l1 >= l2`` the eigenvalues of the 2 x 2 scatter of its (real, imaginary) points; 1
    for a real (normal) mode whatever its overall phase, 0 for a fully complex one."""
    v = np.asarray(shape, dtype=complex)
    sxx, syy, sxy = (float(np.sum(a * b)) for a, b in
                     ((v.real, v.real), (v.imag, v.imag), (v.real, v.imag)))
    if sxx + syy == 0:
        return 1.0
    spread = np.hypot((sxx - syy) / 2, sxy)
    return float((2 * spread / (sxx + syy)) ** 2)


def residual_views(tests, model_parts, n_parameters: int, *,
                   modes: Sequence[ModeResidual] = ()) -> Residual:
    """Every view of data against one model (:class:`Residual`)."""
    num = sum(float(np.sum(np.abs((t.H - M) / t.sigma) ** 2))
              for t, M in zip(tests, model_parts, strict=True))
    den = sum(float(np.sum(np.abs(t.H / t.sigma) ** 2)) for t in tests)
    n = 2 * sum(t.H.size for t in tests)
    delays = []
    weights = []
    for t, M in zip(tests, model_parts, strict=True):
        w = 1.0 / t.sigma
        delays.append(phase_slope_delay(t.freq_hz, t.H, M, w))
        weights.append(float(np.sum(np.abs(w * M) ** 2)))
    delay = float(np.average(delays, weights=weights)) if sum(weights) > 0 else 0.0
    return Residual(float(np.sqrt(num / max(den, 1e-300))), num,
                    num / max(n - n_parameters, 1), delay,
                    channel_residuals(tests, model_parts, n_parameters), tuple(modes),
                    pair_differences(tests))
