"""Data windows for spectral estimation, including the impact-test windows.

Standard windows (``"rectangular"``/``"boxcar"``, ``"bartlett"``, ``"hann"``,
``"hamming"``, ``"flattop"``) are the periodic (DFT-even) forms used for averaged
spectral estimation and are taken from :func:`scipy.signal.get_window` with its default
``fftbins=True``, so they equal it exactly.  Impact-test windows (``"force"`` and
``"exponential"``) are defined here.

Every window is registered by name in one table (:data:`WINDOW_NAMES` lists the names);
:func:`get_window` is the only way in.  Windows are returned as new float64 arrays, so the
caller owns them.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.signal

__all__ = ["WINDOW_NAMES", "WindowSpec", "get_window", "window_from_spec"]

#: What :func:`window_from_spec` accepts: a name, a ``(name, parameter)`` tuple, or the
#: window samples themselves.
WindowSpec = str | tuple[str, Any] | np.ndarray

_DEFAULT_DECAY_TO = 0.01
_DEFAULT_FORCE_FRACTION = 10  # default force window: the first n // 10 samples


def _scipy_window(scipy_name: str) -> Callable[..., np.ndarray]:
    def build(n: int) -> np.ndarray:
        return np.asarray(scipy.signal.get_window(scipy_name, n, fftbins=True), dtype=float)

    return build


def _force(n: int, force_width: int | None = None) -> np.ndarray:
    if force_width is None:
        force_width = max(1, n // _DEFAULT_FORCE_FRACTION)
    width = _as_int(force_width, "force_width")
    if not 1 <= width <= n:
        raise ValueError(
            f"The 'force_width' parameter of the force window must be an integer in "
            f"[1, {n}] (the window length); got {force_width!r}."
        )
    w = np.zeros(n)
    w[:width] = 1.0
    return w


def _exponential(n: int, decay_to: float | None = None) -> np.ndarray:
    if decay_to is None:
        decay_to = _DEFAULT_DECAY_TO
    if isinstance(decay_to, bool) or not isinstance(decay_to, int | float | np.floating):
        raise ValueError(
            f"The 'decay_to' parameter of the exponential window must be a real number "
            f"in (0, 1); got {decay_to!r}."
        )
    decay = float(decay_to)
    if not 0.0 < decay < 1.0:
        raise ValueError(
            f"The 'decay_to' parameter of the exponential window must be in (0, 1) (the "
            f"value of the last sample; 1 would be the rectangular window); got {decay_to!r}."
        )
    if n == 1:
        return np.ones(1)
    return np.exp(math.log(decay) * np.arange(n) / (n - 1))


@dataclass(frozen=True)
class _WindowDef:
    build: Callable[..., np.ndarray]
    parameter: str | None  # the name of the one optional keyword parameter, if any


# The registry: canonical name -> definition.  Aliases map onto canonical names.
_WINDOWS: dict[str, _WindowDef] = {
    "rectangular": _WindowDef(_scipy_window("boxcar"), None),
    "bartlett": _WindowDef(_scipy_window("bartlett"), None),
    "hann": _WindowDef(_scipy_window("hann"), None),
    "hamming": _WindowDef(_scipy_window("hamming"), None),
    "flattop": _WindowDef(_scipy_window("flattop"), None),
    "force": _WindowDef(_force, "force_width"),
    "exponential": _WindowDef(_exponential, "decay_to"),
}
_ALIASES: dict[str, str] = {"boxcar": "rectangular"}

#: Canonical window names, in registry order (aliases: ``"boxcar"`` = ``"rectangular"``).
WINDOW_NAMES: tuple[str, ...] = tuple(_WINDOWS)


def _as_int(value: Any, name: str) -> int:
    if isinstance(value, bool):
        raise ValueError(f"The '{name}' parameter must be an integer; got {value!r}.")
    try:
        return operator.index(value)
    except TypeError:
        raise ValueError(
            f"The '{name}' parameter must be an integer; got {value!r} ({type(value).__name__})."
        ) from None


def _canonical(name: Any) -> str:
    if not isinstance(name, str):
        raise ValueError(
            f"The 'window' name must be a string, one of {', '.join(WINDOW_NAMES)} (or "
            f"'boxcar'); got {name!r} ({type(name).__name__})."
        )
    key = name.strip().lower()
    key = _ALIASES.get(key, key)
    if key not in _WINDOWS:
        raise ValueError(
            f"Unknown window {name!r}; expected one of {', '.join(WINDOW_NAMES)} "
            f"(alias 'boxcar' = 'rectangular')."
        )
    return key


def get_window(
    name: str,
    n: int,
    *,
    force_width: int | None = None,
    decay_to: float | None = None,
) -> np.ndarray:
    """Return the window `name` of length `n` as a new float64 array.

    Parameters
    ----------
    name : str
        Case-insensitive window name:

        ``"rectangular"``, ``"bartlett"``, ``"hann"``, ``"hamming"``, ``"flattop"``
            (``"boxcar"`` is an alias of ``"rectangular"``.) The periodic (DFT-even)
            windows of :func:`scipy.signal.get_window` with ``fftbins=True``, the form
            used for averaged spectral estimation; the result equals
            ``scipy.signal.get_window(name, n)`` exactly.
        ``"force"``
            Impact-test window for the force (input) channel: 1 over the first
            `force_width` samples, 0 after.  It removes the noise recorded after the
            hammer pulse.
        ``"exponential"``
            Impact-test window ``w[k] = decay_to ** (k / (n - 1))``: 1 at the first
            sample, `decay_to` at the last.  It forces a lightly damped response to decay
            within the record, at the price of added damping: it multiplies the signal by
            ``exp(-sigma_w t)`` with ``sigma_w = -ln(decay_to) * fs_hz / (n - 1)`` (1/s),
            which moves every pole left by ``sigma_w``; subtract ``sigma_w`` from the
            identified decay rates (``zeta * omega_n``) to undo it.  Apply it to input and
            output alike.
    n : int
        Window length in samples, ``n >= 1``.
    force_width : int, optional
        Force window only: the number of leading samples set to 1, ``1 <= force_width <=
        n``.  Default ``max(1, n // 10)``.
    decay_to : float, optional
        Exponential window only: the value of the last sample, ``0 < decay_to < 1``.
        Default 0.01.

    Returns
    -------
    numpy.ndarray
        Shape ``(n,)``, float64, dimensionless.

    Raises
    ------
    ValueError
        Unknown name, ``n < 1``, or a parameter out of range or given to a window that
        does not take it.

    Examples
    --------
    >>> get_window("hann", 4)
    array([0. , 0.5, 1. , 0.5])
    >>> get_window("force", 5, force_width=2)
    array([1., 1., 0., 0., 0.])
    """
    key = _canonical(name)
    length = _as_int(n, "n")
    if length < 1:
        raise ValueError(f"The 'n' parameter (window length) must be >= 1; got {n!r}.")
    definition = _WINDOWS[key]
    given = {"force_width": force_width, "decay_to": decay_to}
    for pname, value in given.items():
        if value is not None and pname != definition.parameter:
            raise ValueError(
                f"The '{pname}' parameter applies to the "
                f"{'force' if pname == 'force_width' else 'exponential'} window only; "
                f"got {pname}={value!r} for window {name!r}."
            )
    if definition.parameter is None:
        return definition.build(length)
    return definition.build(length, given[definition.parameter])


def window_from_spec(spec: WindowSpec, n: int) -> tuple[np.ndarray, str]:
    """Resolve a window specification to samples of length `n` and a description.

    Parameters
    ----------
    spec : str, tuple or array_like
        A window name (see :func:`get_window`); a ``(name, parameter)`` tuple for the
        impact windows, ``("force", force_width)`` or ``("exponential", decay_to)``; or
        the window samples, a real finite 1-D array of length `n`.
    n : int
        Window length in samples.

    Returns
    -------
    window : numpy.ndarray
        Shape ``(n,)``, float64 (a new array; an array `spec` is copied).
    description : str
        ``"hann"``, ``"force(force_width=50)"``, ``"exponential(decay_to=0.01)"`` or
        ``"custom"`` for an array.

    Raises
    ------
    ValueError
        For an unknown name, a malformed tuple, or an array of the wrong shape/length or
        with non-finite values.
    """
    if isinstance(spec, str):
        key = _canonical(spec)
        return get_window(key, n), _describe(key, None)
    if isinstance(spec, tuple):
        if len(spec) != 2:
            raise ValueError(
                f"A 'window' tuple must be (name, parameter), e.g. ('force', 50) or "
                f"('exponential', 0.01); got a tuple of length {len(spec)}: {spec!r}."
            )
        key = _canonical(spec[0])
        parameter = _WINDOWS[key].parameter
        if parameter is None:
            raise ValueError(
                f"Window {spec[0]!r} takes no parameter, so pass it as a plain string; "
                f"got the tuple {spec!r}."
            )
        w = get_window(key, n, **{parameter: spec[1]})
        return w, _describe(key, (parameter, spec[1]))
    w = np.array(spec, dtype=float, copy=True) if _is_real_array_like(spec) else None
    if w is None or w.ndim != 1:
        raise ValueError(
            f"The 'window' parameter must be a name, a (name, parameter) tuple or a real "
            f"1-D array; got {type(spec).__name__}"
            f"{'' if w is None else f' with shape {w.shape}'}."
        )
    if w.shape[0] != n:
        raise ValueError(
            f"The 'window' array must have one sample per segment sample, length {n} "
            f"(nperseg); got length {w.shape[0]}."
        )
    if not np.all(np.isfinite(w)):
        raise ValueError("The 'window' array must be finite; it contains NaN or inf.")
    return w, "custom"


def _is_real_array_like(spec: Any) -> bool:
    try:
        a = np.asarray(spec)
    except (TypeError, ValueError):
        return False
    return a.dtype.kind in "biuf"


def _describe(key: str, parameter: tuple[str, Any] | None) -> str:
    if parameter is None:
        return key
    return f"{key}({parameter[0]}={parameter[1]!r})"
