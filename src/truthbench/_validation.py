"""Entry-point checks shared by every room: choices, numbers in intervals, read-only arrays,
names that become folders and HDF5 groups, text files, output paths and memory.

Each check raises the error class it is given (``ValueError`` by default; a room passes
its own, e.g. :class:`~truthbench.errors.CampaignError`) with a message in one form:
``"<where>: '<name>' must be <what>; got <value>"``. ``where`` names the file, object or
function at fault and may be empty.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable
from numbers import Integral, Real
from pathlib import Path

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


def _finite(value) -> bool:
    """``value`` converts to a finite float (an integer too large for a float does not)."""
    try:
        return math.isfinite(float(value))
    except (OverflowError, ValueError, TypeError):
        return False


def check_number(name: str, value, *, low: float | None = None, high: float | None = None,
                 low_open: bool = False, high_open: bool = False, integer: bool = False,
                 where: str = "", error: type[Exception] = ValueError):
    """A finite real number (an integer with ``integer=True``) inside the interval.

    Booleans are refused (``True`` is not a number of anything). Returns the value as
    ``float`` (or ``int``).
    """
    kind = "an integer" if integer else "a finite number"
    if isinstance(value, bool) or not isinstance(value, Integral if integer else Real) \
            or (not integer and not _finite(value)):
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


# --------------------------------------------------------------------------------------
# Names, text files, output paths, memory: the checks every entry point shares
# --------------------------------------------------------------------------------------

#: Longest campaign or test name: it becomes a folder, an HDF5 group and part of file
#: names (``frf_<test>.png``), and stays readable in tables.
MAX_NAME_LENGTH = 64

_PORTABLE_NAME = re.compile(r"[A-Za-z0-9](?:[A-Za-z0-9_.-]*[A-Za-z0-9_-])?")


def name_rule(portable: bool = True) -> str:
    """What :func:`check_name` accepts, in words (for messages and docs)."""
    if portable:
        return (f"1 to {MAX_NAME_LENGTH} characters from letters, digits, '_', '-' and '.', "
                f"starting with a letter or digit and not ending with '.' (it names a folder)")
    return (f"1 to {MAX_NAME_LENGTH} printable characters without '/' or '\\', without "
            f"leading or trailing spaces, and not '.' or '..' (it names an HDF5 group and "
            f"a file)")


def is_safe_name(value, portable: bool = True) -> bool:
    """Whether ``value`` passes :func:`check_name`."""
    if not isinstance(value, str):
        return False
    if portable:
        return len(value) <= MAX_NAME_LENGTH and _PORTABLE_NAME.fullmatch(value) is not None
    return (0 < len(value) <= MAX_NAME_LENGTH and value.strip() == value
            and value not in (".", "..") and not any(c in value for c in "/\\")
            and value.isprintable())


def check_name(name: str, value, *, portable: bool = True, where: str = "",
               error: type[Exception] = ValueError) -> str:
    """A name that is safe as a folder name and as an HDF5 group name.

    Two levels (:func:`name_rule`):

    * ``portable=True`` (a campaign name, which becomes the folder ``results/<name>``):
      1 to :data:`MAX_NAME_LENGTH` characters from letters, digits, ``_``, ``-`` and
      ``.``, starting with a letter or digit and not ending with ``.`` (Windows drops a
      trailing dot). So ``"../../x"``, ``"/tmp/x"``, ``"a/b"``, ``"."``, ``".."`` and
      ``""`` are refused: a name can never point outside ``results/`` or at
      ``results/`` itself.
    * ``portable=False`` (a test name, which becomes an HDF5 group and, with other
      characters replaced by ``_``, a figure file): any printable text of 1 to
      :data:`MAX_NAME_LENGTH` characters without ``/`` or ``\\`` (path and HDF5 group
      separators), without leading or trailing white space, and not ``.`` or ``..``.

    Returns ``value``; raises ``error`` naming ``name`` with what was expected.
    """
    if not is_safe_name(value, portable):
        got = repr(value) if isinstance(value, str) else f"{type(value).__name__} {value!r}"
        raise error(f"{_prefix(where)}'{name}' must be a name of {name_rule(portable)}; "
                    f"got {got}")
    return value


#: Leading bytes of binary formats a text file (a campaign) is sometimes confused with.
BINARY_SIGNATURES = {
    b"\x89HDF\r\n\x1a\n": "an HDF5 file (a results or simulate file?)",
    b"PK\x03\x04": "a zip archive",
    b"\x89PNG": "a PNG image",
    b"%PDF": "a PDF document",
    b"\x7fELF": "an executable",
}


def read_text(path, *, what: str, error: type[Exception] = ValueError) -> str:
    """The text of a UTF-8 file (a leading byte-order mark is dropped).

    Refused with ``error`` naming the file: a missing file (``FileNotFoundError`` is
    not raised, so callers answer it as a bad input), a directory, an unreadable file, a
    known binary format (HDF5, zip, ...) or bytes that are not UTF-8 (the first bad
    byte, its offset and line).

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        What the file should be, for messages (``"campaign file"``).
    error : type of Exception
    """
    p = Path(path)
    if not p.exists():
        raise error(f"{p}: {what} not found")
    if p.is_dir():
        raise error(f"{p}: is a directory; expected a {what}")
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise error(f"{p}: cannot read the {what}: {exc.strerror or exc}") from None
    for magic, kind in BINARY_SIGNATURES.items():
        if raw.startswith(magic):
            raise error(f"{p}: is {kind}; expected a {what} (UTF-8 text)")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise error(f"{p}: is not UTF-8 text: byte 0x{raw[exc.start]:02x} at offset "
                    f"{exc.start} (line {line}); expected a {what} in UTF-8") from None


def check_output_file(name: str, path, suffixes: Iterable[str], *, what: str,
                      hint: str = "", error: type[Exception] = ValueError) -> Path:
    """An output file path: its suffix one of ``suffixes`` (case-insensitive), not an
    existing directory, and its folder, if it exists, a folder.

    ``hint`` is appended to the suffix message (e.g. how to get another format).
    """
    p = Path(path)
    suffixes = tuple(s.lower() for s in suffixes)
    if p.suffix.lower() not in suffixes:
        raise error(f"'{name}' must be a {what} ending in {' or '.join(suffixes)}; got "
                    f"{str(p)!r}" + (f"; {hint}" if hint else ""))
    if p.is_dir():
        raise error(f"'{name}': {p} is a directory; expected a {what} path")
    for parent in p.parents:
        if parent.exists():
            if not parent.is_dir():
                raise error(f"'{name}': {parent} is a file, so {p} cannot be written; "
                            f"expected a folder there")
            break
    return p


def available_memory_bytes() -> int | None:
    """Memory the system can give a new allocation without swapping: ``MemAvailable`` of
    ``/proc/meminfo`` (Linux), else free physical pages (``os.sysconf``), else None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return None


def format_bytes(n: float) -> str:
    """``n`` bytes with a binary prefix (``'1.5 GiB'``)."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.3g} PiB"  # pragma: no cover
