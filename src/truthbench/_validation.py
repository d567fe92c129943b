"""Entry-point checks shared by every room: choices, numbers in intervals, read-only arrays.

Each check raises the error class it is given (``ValueError`` by default; a room passes
its own, e.g. :class:`~truthbench.errors.CampaignError`) with a message in one form:
``"<where>: '<name>' must be <what>; got <value>"``. ``where`` names the file, object or
function at fault and may be empty.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from numbers import Integral, Real

import numpy as np


def _prefix(where: str) -> str:
    return f"{where}: " if where else ""


def readonly(a, dtype=None) -> np.ndarray:
    """A read-only copy of ``a`` (never a view of the caller's array)."""
    out = np.array(a, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


def check_choice(name: str, value, choices: Iterable, *, where: str = "",
                 error: type[Exception] = ValueError):
    """``value`` if it is one of ``choices``, else ``error`` listing them."""
    choices = tuple(choices)
    try:
        ok = value in choices
    except TypeError:  # unhashable value against a set-like
        ok = False
    if not ok:
        raise error(f"{_prefix(where)}'{name}' must be one of "
                    f"{', '.join(map(repr, choices))}; got {value!r}")
    return value


def check_number(name: str, value, *, low: float | None = None, high: float | None = None,
                 low_open: bool = False, high_open: bool = False, integer: bool = False,
                 where: str = "", error: type[Exception] = ValueError):
    """A finite real number (an integer with ``integer=True``) inside the interval.

    Booleans are refused (``True`` is not a number of anything). Returns the value as
    ``float`` (or ``int``).
    """
    kind = "an integer" if integer else "a finite number"
    if isinstance(value, bool) or not isinstance(value, Integral if integer else Real) \
            or (not integer and not math.isfinite(float(value))):
        raise error(f"{_prefix(where)}'{name}' must be {kind}; got {value!r}")
    bad = ((low is not None and (value <= low if low_open else value < low))
           or (high is not None and (value >= high if high_open else value > high)))
    if bad:
        lo = "" if low is None else f"{'>' if low_open else '>='} {low:g}"
        hi = "" if high is None else f"{'<' if high_open else '<='} {high:g}"
        rng = " and ".join(x for x in (lo, hi) if x)
        raise error(f"{_prefix(where)}'{name}' must be {kind} {rng}; got {value!r}")
    return int(value) if integer else float(value)


def check_positive_int(name: str, value, *, where: str = "",
                       error: type[Exception] = ValueError) -> int:
    """An integer >= 1."""
    return check_number(name, value, low=1, integer=True, where=where, error=error)


def check_array(name: str, value, *, shape: tuple | None = None, dtype=float,
                finite: bool = True, where: str = "",
                error: type[Exception] = ValueError) -> np.ndarray:
    """A read-only copy of ``value`` as an array of ``dtype``.

    ``shape`` may hold None for any length, e.g. ``(None, 3)``. With ``finite`` NaN and
    inf are refused, naming the first index.
    """
    try:
        a = readonly(value, dtype)
    except (TypeError, ValueError) as exc:
        raise error(f"{_prefix(where)}'{name}' must be an array of {np.dtype(dtype).name}; "
                    f"got {type(value).__name__} ({exc})") from None
    if shape is not None and (a.ndim != len(shape) or any(
            s is not None and s != n for s, n in zip(shape, a.shape, strict=True))):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise error(f"{_prefix(where)}'{name}' must have shape {want}; got {a.shape}")
    if finite and a.size and not np.all(np.isfinite(a)):
        idx = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
        raise error(f"{_prefix(where)}'{name}' must be finite; got {a[idx]!r} at index "
                    f"{idx if len(idx) > 1 else idx[0]}")
    return a
