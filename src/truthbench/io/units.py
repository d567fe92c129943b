"""Units of exchanged files: unit labels and the UFF unit system (dataset 164).

Everything inside truthbench is SI. A file may say its units two ways: in a dataset 164
(a unit system: conversion factors for length and force) and in the unit label of each
axis (``"mm/s^2"``, ``"lbf"``). This module reads both:

* :func:`parse_unit` turns a label into its SI scale and its dimension in the UFF base
  (length, force, time): ``"mm/s^2"`` -> ``(1e-3, (1, 0, -2))``, ``"lbf"`` ->
  ``(4.4482216152605, (0, 1, 0))``. It knows the length units m, km, cm, mm, um (µm),
  in, ft; the force units N, mN, cN, kN, lbf, kgf, pdl; s and ms; rad and deg; and g
  (standard gravity, 9.80665 m/s^2), combined with ``*``, ``.``, blanks, ``/``,
  parentheses and integer powers (``s^2``, ``s**2``, ``s2``, ``s^-2``). ``a/b/c`` is
  ``a/(b c)``. Anything else is not understood (None), and so is ``"NONE"``.
* :class:`UnitSystem` is a dataset 164: to convert a file value to SI, *divide* it by
  ``length ** L * force ** F`` for a quantity of dimension (L, F, T) (the UFF rule:
  "to convert from universal file units to SI divide by the appropriate factor"). Time
  is always in seconds and angles in radians in UFF.
* :func:`quantity_dimension` is the dimension of a truthbench quantity along a DOF
  direction, read from the one table (:mod:`truthbench.quantities`) through the same
  parser, so no second table of units exists.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from types import MappingProxyType

from truthbench.quantities import quantity

__all__ = ["SI", "UNIT_SYMBOLS", "UnitSystem", "parse_unit", "quantity_dimension"]

Dimension = tuple[int, int, int]
"""Exponents of (length, force, time)."""

_L, _F, _T, _ONE = (1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, 0)
_G0 = 9.80665  # standard gravity, m/s^2 (CGPM 1901)
_LBF = 4.4482216152605  # pound-force, N (0.45359237 kg x 9.80665 m/s^2)

UNIT_SYMBOLS = MappingProxyType({
    "m": (1.0, _L), "km": (1e3, _L), "cm": (1e-2, _L), "mm": (1e-3, _L),
    "um": (1e-6, _L), "µm": (1e-6, _L), "μm": (1e-6, _L),
    "in": (0.0254, _L), "inch": (0.0254, _L), "ft": (0.3048, _L),
    "N": (1.0, _F), "mN": (1e-3, _F), "cN": (1e-2, _F), "kN": (1e3, _F),
    "lbf": (_LBF, _F), "kgf": (_G0, _F), "pdl": (0.45359237 * 0.3048, _F),
    "s": (1.0, _T), "ms": (1e-3, _T), "sec": (1.0, _T),
    "rad": (1.0, _ONE), "deg": (math.pi / 180.0, _ONE),
    "g": (_G0, (1, 0, -2)),
})  # fmt: skip
"""Unit symbols :func:`parse_unit` knows: symbol -> (SI scale, (L, F, T))."""

_TOKEN = re.compile(r"\s*(?:(\*\*|\^)|([*./()])|([A-Za-zµμ]+)|([+-]?\d+))")


def _tokens(label: str) -> list[tuple[str, str]] | None:
    out, pos = [], 0
    text = label.strip()
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None or m.end() == pos:
            return None
        power, op, sym, num = m.groups()
        out.append(("^", power) if power else ("op", op) if op else
                   ("sym", sym) if sym else ("num", num))
        pos = m.end()
    return out


class _Parser:
    """``expr := factor (('*' | '.' | '/' | blank) factor)*``,
    ``factor := (symbol | '(' expr ')') [('^' | '**')] [integer]``."""

    def __init__(self, tokens):
        self.t, self.k = tokens, 0

    def peek(self):
        return self.t[self.k] if self.k < len(self.t) else (None, None)

    def expr(self):
        scale, dim = self.factor()
        while True:
            kind, value = self.peek()
            if kind is None or (kind == "op" and value == ")"):
                return scale, dim
            sign = 1
            if kind == "op" and value in "*./":
                sign = -1 if value == "/" else 1
                self.k += 1
            s2, d2 = self.factor()
            scale *= s2**sign
            dim = tuple(a + sign * b for a, b in zip(dim, d2, strict=True))

    def factor(self):
        kind, value = self.peek()
        if kind == "sym":
            if value not in UNIT_SYMBOLS:
                raise ValueError(value)
            self.k += 1
            scale, dim = UNIT_SYMBOLS[value]
        elif kind == "op" and value == "(":
            self.k += 1
            scale, dim = self.expr()
            if self.peek() != ("op", ")"):
                raise ValueError("(")
            self.k += 1
        else:
            raise ValueError(value)
        kind, value = self.peek()
        if kind == "^":
            self.k += 1
            kind, value = self.peek()
            if kind != "num":
                raise ValueError("^")
        if kind == "num":
            self.k += 1
            p = int(value)
            scale, dim = scale**p, tuple(p * a for a in dim)
        return scale, dim


def parse_unit(label: str) -> tuple[float, Dimension] | None:
    """SI scale and dimension of a unit label, or None if it is not understood.

    Parameters
    ----------
    label : str
        E.g. ``"m/s^2"``, ``"mm/s2"``, ``"(m/s^2)/N"``, ``"N m"``, ``"lbf"``.

    Returns
    -------
    (scale, (L, F, T)) or None
        One unit of ``label`` is ``scale`` SI units; L, F, T are the exponents of
        length, force and time. None for an empty label, ``"NONE"`` or anything the
        grammar of the module notes does not cover.
    """
    if not isinstance(label, str) or label.strip().upper() in ("", "NONE", "-"):
        return None
    tokens = _tokens(label)
    if not tokens:
        return None
    parser = _Parser(tokens)
    try:
        scale, dim = parser.expr()
    except (ValueError, OverflowError, ZeroDivisionError):
        return None
    if parser.k != len(tokens):
        return None
    return float(scale), tuple(int(v) for v in dim)


def quantity_dimension(name: str, direction: str | None = None) -> Dimension:
    """(L, F, T) exponents of a quantity along a DOF direction (rotations for ``rx``,
    ``ry``, ``rz``), from its SI unit in :mod:`truthbench.quantities`."""
    parsed = parse_unit(quantity(name).unit_for(direction))
    if parsed is None:  # pragma: no cover - the table's units are all understood
        raise ValueError(f"the unit of {name!r} is not understood")
    return parsed[1]


_UNIT_CODES = MappingProxyType({
    1: "SI: meter (newton)", 2: "BG: foot (pound f)", 3: "MG: meter (kilogram f)",
    4: "BA: foot (poundal)", 5: "MM: mm (milli newton)", 6: "CM: cm (centi newton)",
    7: "IN: inch (pound f)", 8: "GM: mm (kilogram f)", 9: "US: user defined",
})  # fmt: skip


@dataclass(frozen=True)
class UnitSystem:
    """A UFF unit system (dataset 164).

    Parameters
    ----------
    code : int
        UFF units code, 1..9 (1 SI, 2 BG, 3 MG, 4 BA, 5 MM, 6 CM, 7 IN, 8 GM, 9 user).
    description : str
        As written in the file (documentation only).
    length, force : float
        File units per SI unit: a length of 1 m is ``length`` file units (1000 for mm).
    temperature, temperature_offset : float
        The temperature factor and offset (unused by truthbench, kept as read).
    """

    code: int = 1
    description: str = "SI"
    length: float = 1.0
    force: float = 1.0
    temperature: float = 1.0
    temperature_offset: float = 273.15

    def __post_init__(self):
        for name in ("length", "force"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"UnitSystem: the {name} factor must be a finite number "
                                 f"> 0; got {v!r}")

    def to_si(self, dim: Dimension) -> float:
        """Factor that brings a file value of dimension ``dim`` to SI (multiply by it):
        ``1 / (length ** L * force ** F)``."""
        return 1.0 / (self.length ** dim[0] * self.force ** dim[1])

    @property
    def is_si(self) -> bool:
        return self.length == 1.0 and self.force == 1.0

    def describe(self) -> str:
        """E.g. ``"code 9 (US: user defined) 'mm kN', 1000 length / 0.001 force units
        per SI unit"``."""
        kind = _UNIT_CODES.get(self.code, "unknown code")
        return (f"code {self.code} ({kind}) {self.description.strip()!r}, {self.length:g} "
                f"length / {self.force:g} force units per SI unit")


SI = UnitSystem()
"""The SI unit system (code 1, factors 1)."""
