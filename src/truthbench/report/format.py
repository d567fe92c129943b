"""Numbers and tables for a person: rounding to what a number means, markdown tables.

* :func:`sig`: 4 significant digits, plain notation from 1e-3 to 99999, else
  ``7.166e+10``;
* :func:`pct`: a percentage to 0.01 (``-0.00`` shows as ``0.00``);
* :func:`si`: a value with an SI prefix on its unit chosen once per row
  (``68.90`` with ``GPa``);
* :func:`table`: a DataFrame of numbers to a DataFrame of strings under readable
  headers; :func:`markdown` writes it as a pipe table with every ``|`` in a cell
  escaped, so each row has the header's column count.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

_PREFIXES = {9: "G", 6: "M", 3: "k", 0: "", -3: "m", -6: "µ", -9: "n"}
PREFIXABLE = ("Pa", "m", "s", "N", "N/m", "Hz")
"""Units that take an SI prefix in tables (``kg`` and compound units do not)."""


def _finite(v) -> bool:
    try:
        return math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def sig(v, digits: int = 4) -> str:
    """``v`` to ``digits`` significant digits: plain from 1e-3 up to ``digits + 1``
    integer digits (a 5-digit integer part stays whole), else ``7.166e+10``; ``"-"``
    for NaN or None."""
    if v is None or (isinstance(v, float | np.floating) and np.isnan(v)):
        return "-"
    if not _finite(v):
        return str(v)
    x = float(v)
    if x == 0:
        return "0"
    e = math.floor(math.log10(abs(x)))
    if e > digits or e < -3:
        return f"{x:.{digits - 1}e}"
    decimals = max(digits - 1 - e, 0)
    out = f"{x:.{decimals}f}"
    return "0" if float(out) == 0 else out


def pct(v, decimals: int = 2) -> str:
    """A percentage to ``10**-decimals`` (``-0.00`` shows as ``0.00``); ``"-"`` for
    NaN."""
    if v is None or not _finite(v):
        return "-" if v is None or np.isnan(float(v)) else str(v)
    out = f"{float(v):.{decimals}f}"
    return out[1:] if out.startswith("-") and float(out) == 0 else out


def fixed(decimals: int) -> Callable[[float], str]:
    """A formatter with a fixed number of decimals (MAC, coherence)."""

    def f(v) -> str:
        return "-" if v is None or not _finite(v) else f"{float(v):.{decimals}f}"

    return f


def integer(v) -> str:
    return "-" if v is None or not _finite(v) else str(int(v))


def si_scale(values: Sequence[float], unit: str) -> tuple[float, str]:
    """The factor to divide by and the prefixed unit for ``values`` (the prefix from
    the largest magnitude), e.g. ``(1e9, "GPa")``; ``(1, unit)`` for other units."""
    if unit not in PREFIXABLE:
        return 1.0, unit
    finite = [abs(float(v)) for v in values if _finite(v) and float(v) != 0]
    if not finite:
        return 1.0, unit
    e = 3 * math.floor(math.log10(max(finite)) / 3)
    e = min(max(e, -9), 9)
    return 10.0**e, _PREFIXES[e] + unit


def table(df, columns: Sequence[tuple[str, str, Callable]]):
    """``df`` with the columns ``(name, header, formatter)`` as strings under their
    headers (a pandas DataFrame)."""
    import pandas as pd

    return pd.DataFrame({header: [fmt(v) for v in df[name]] for name, header, fmt in columns},
                        columns=[header for _, header, _ in columns])


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def markdown(sdf) -> str:
    """A DataFrame of strings as a markdown pipe table (``(none)`` when empty)."""
    if sdf.empty:
        return "(none)\n"
    cols = list(sdf.columns)
    lines = ["| " + " | ".join(_cell(c) for c in cols) + " |", "|" + "---|" * len(cols)]
    for row in sdf.itertuples(index=False):
        lines.append("| " + " | ".join(_cell(v) for v in row) + " |")
    return "\n".join(lines) + "\n"
