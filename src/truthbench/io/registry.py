"""FRF readers by file extension: :func:`load_frf` and the :func:`register_reader` hook.

Every registered reader is a function ``reader(path, **options) -> tuple[FRFData, ...]``
(:class:`truthbench.measure.FRFData`). The io room registers its own when it is imported
(``.h5`` / ``.hdf5`` -> :func:`~truthbench.io.hdf5.read_frf`, ``.uff`` / ``.unv`` ->
:func:`~truthbench.io.read_uff`, ``.lvm`` -> :func:`~truthbench.io.read_lvm_frf`); code
elsewhere adds a format the same way::

    from truthbench.io import register_reader
    register_reader(".xyz", read_xyz)

No reader is registered at call time.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

from truthbench.errors import DataFormatError

if TYPE_CHECKING:
    from truthbench.measure.frfdata import FRFData

__all__ = ["load_frf", "register_reader", "registered_extensions"]

Reader = Callable[..., Any]

_READERS: dict[str, Reader] = {}


def _normalize(ext: str) -> str:
    if not isinstance(ext, str) or not ext.strip(". ") or any(c in ext for c in "/\\ "):
        raise ValueError(f"ext must be a file extension such as '.h5'; got {ext!r}")
    ext = ext.lower()
    return ext if ext.startswith(".") else "." + ext


def _name(func: Reader) -> str:
    return f"{getattr(func, '__module__', '?')}.{getattr(func, '__qualname__', repr(func))}"


def register_reader(ext: str, func: Reader, *, replace: bool = False) -> None:
    """Register the reader :func:`load_frf` uses for files ending in ``ext``.

    Parameters
    ----------
    ext : str
        File extension, with or without the leading dot; case-insensitive
        (``"h5"``, ``".H5"`` and ``".h5"`` are the same).
    func : callable
        ``func(path, **options) -> tuple[FRFData, ...]``; takes the path first.
    replace : bool, default False
        Allow replacing a reader already registered for ``ext``.

    Raises
    ------
    ValueError
        If ``ext`` is not an extension, or another reader is already registered for it
        and ``replace`` is False.
    TypeError
        If ``func`` is not callable.
    """
    key = _normalize(ext)
    if not callable(func):
        raise TypeError(f"register_reader: func for {key!r} must be callable; got {func!r}")
    if key in _READERS and not replace and _READERS[key] is not func:
        raise ValueError(
            f"register_reader: a reader for {key!r} is already registered "
            f"({_name(_READERS[key])}); pass replace=True to replace it"
        )
    _READERS[key] = func


def registered_extensions() -> tuple[str, ...]:
    """The extensions :func:`load_frf` can read now, sorted (e.g. ``('.h5', ...)``)."""
    return tuple(sorted(_READERS))


def _option_names(reader: Reader) -> list[str] | None:
    """The keyword options ``reader`` takes after the path; None when it takes any (or
    has no signature to tell)."""
    try:
        params = inspect.signature(reader).parameters
    except (TypeError, ValueError):  # a builtin without a signature: let it decide
        return None
    if any(v.kind is inspect.Parameter.VAR_KEYWORD for v in params.values()):
        return None
    return [n for n, v in list(params.items())[1:]
            if v.kind in (inspect.Parameter.KEYWORD_ONLY,
                          inspect.Parameter.POSITIONAL_OR_KEYWORD)]


def _check_options(p: Path, ext: str, reader: Reader, options: dict) -> None:
    names = _option_names(reader)
    if names is None:
        return
    bad = sorted(set(options) - set(names))
    if bad:
        raise ValueError(
            f"{p}: the {ext} reader ({_name(reader)}) takes no option(s) {bad}; it takes "
            f"{names or 'none'}"
        )


def load_frf(path: str | PathLike, **options: Any) -> tuple[FRFData, ...]:
    """Read a data file into FRFData with the reader registered for its extension.

    Parameters
    ----------
    path : str or os.PathLike
        The file. Its last suffix, lower-cased, chooses the reader.
    **options
        Passed to the reader (e.g. ``coherence=`` for ``.uff``, ``excitation=``,
        ``n_averages=`` for time records, ``trials=``, ``tests=`` for ``.h5``).

    Returns
    -------
    tuple of FRFData
        What the reader found, at least one.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValueError
        An option the reader does not take (the message lists the ones it takes).
    truthbench.errors.DataFormatError
        A directory, no reader registered for the extension (the message names it and
        the supported ones), a reader that returns something else than FRFData, or a
        malformed file.
    """
    p = Path(path)
    ext, reader = _reader_for(p)
    _check_options(p, ext, reader, options)
    return _checked(p, ext, reader, reader(p, **options))


def _reader_for(path: str | PathLike) -> tuple[str, Reader]:
    """The extension (lower case) of an existing data file and its registered reader.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    truthbench.errors.DataFormatError
        A directory, or no reader registered for the extension (the message names it and
        the supported ones).
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{p}: no such data file")
    if p.is_dir():
        raise DataFormatError(f"{p}: is a directory; expected a data file (a results "
                              f"or simulate .h5, a UFF .uff/.unv, a LabVIEW .lvm)")
    ext = p.suffix.lower()
    reader = _READERS.get(ext)
    if reader is None:
        raise DataFormatError(
            f"{p}: unknown file extension {ext or '(none)'!r}; expected one of: "
            f"{', '.join(registered_extensions())}"
        )
    return ext, reader


def _checked(p: Path, ext: str, reader: Reader, out: Any) -> tuple[FRFData, ...]:
    """``out`` of ``reader`` as a non-empty tuple of FRFData, else a DataFormatError."""
    from truthbench.measure.frfdata import FRFData

    items = tuple(out) if isinstance(out, tuple | list) else None
    if items is None:
        got = type(out).__name__
    elif not items:
        got = "nothing (an empty sequence)"
    else:
        odd = [type(d).__name__ for d in items if not isinstance(d, FRFData)]
        got = f"a sequence holding {odd[0]}" if odd else ""
    if got:
        raise DataFormatError(
            f"{p}: the {ext} reader ({_name(reader)}) returned {got}; expected a non-empty "
            f"tuple of FRFData"
        )
    return items
