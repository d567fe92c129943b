"""Readers by file extension: :func:`load_data` and the :func:`register_reader` hook.

The io room registers its own readers (``.lvm`` -> :func:`~truthbench.io.read_lvm`,
``.uff`` / ``.unv`` -> :func:`~truthbench.io.read_uff58`). Other rooms add theirs at
import time, e.g. the campaign room's results store::

    from truthbench.io import register_reader
    register_reader(".h5", read_results)
    register_reader(".hdf5", read_results)

``.h5`` and ``.hdf5`` are *reserved* for that HDF5 reader: until it is registered,
:func:`load_data` raises a :class:`~truthbench.errors.DataFormatError` that says so.
"""

from __future__ import annotations

from collections.abc import Callable
from os import PathLike
from pathlib import Path
from typing import Any

from truthbench.errors import DataFormatError

__all__ = ["load_data", "register_reader", "registered_extensions"]

Reader = Callable[..., Any]

# Extensions whose reader lives in another room and is registered later.
_RESERVED = {
    ".h5": "truthbench.campaign (HDF5 results store)",
    ".hdf5": "truthbench.campaign (HDF5 results store)",
}
_READERS: dict[str, Reader] = {}


def _normalize(ext: str) -> str:
    if not isinstance(ext, str) or not ext.strip(". ") or any(c in ext for c in "/\\ "):
        raise ValueError(f"ext must be a file extension such as '.h5'; got {ext!r}")
    ext = ext.lower()
    return ext if ext.startswith(".") else "." + ext


def register_reader(ext: str, func: Reader, *, replace: bool = False) -> None:
    """Register the reader :func:`load_data` uses for files ending in ``ext``.

    Parameters
    ----------
    ext : str
        File extension, with or without the leading dot; case-insensitive
        (``"h5"``, ``".H5"`` and ``".h5"`` are the same).
    func : callable
        ``func(path, **kwargs) -> result``; must take the path as first argument.
    replace : bool, default False
        Allow replacing a reader already registered for ``ext``.

    Raises
    ------
    ValueError
        If ``ext`` is not an extension, or a reader is already registered for it and
        ``replace`` is False.
    TypeError
        If ``func`` is not callable.
    """
    key = _normalize(ext)
    if not callable(func):
        raise TypeError(f"register_reader: func for {key!r} must be callable; got {func!r}")
    if key in _READERS and not replace and _READERS[key] is not func:
        raise ValueError(
            f"register_reader: a reader for {key!r} is already registered "
            f"({_READERS[key].__module__}.{_READERS[key].__qualname__}); pass replace=True "
            f"to replace it"
        )
    _READERS[key] = func


def registered_extensions() -> tuple[str, ...]:
    """The extensions :func:`load_data` can read now, sorted (e.g. ``('.lvm', ...)``)."""
    return tuple(sorted(_READERS))


def load_data(path: str | PathLike, **kwargs: Any) -> Any:
    """Read a data file with the reader registered for its extension.

    Parameters
    ----------
    path : str or os.PathLike
        The file. Its last suffix, lower-cased, chooses the reader.
    **kwargs
        Passed to the reader (e.g. ``allow_truncated=True`` for ``.lvm``,
        ``func_type=4`` for ``.uff``).

    Returns
    -------
    object
        What the reader returns: :class:`~truthbench.io.TimeRecord` for ``.lvm``,
        :class:`~truthbench.io.UFFData` for ``.uff`` / ``.unv``.

    Raises
    ------
    truthbench.errors.DataFormatError
        If no reader is registered for the extension (the message names the extension
        and the supported ones), or the reader finds the file malformed.
    """
    p = Path(path)
    ext = p.suffix.lower()
    reader = _READERS.get(ext)
    if reader is None:
        supported = ", ".join(registered_extensions())
        if ext in _RESERVED:
            raise DataFormatError(
                f"{p}: no reader registered yet for {ext!r}: it is provided by "
                f"{_RESERVED[ext]}, which registers it with "
                f"truthbench.io.register_reader({ext!r}, func); supported now: {supported}"
            )
        pending = ", ".join(sorted(set(_RESERVED) - set(_READERS)))
        later = f" ({pending} once their reader is registered)" if pending else ""
        raise DataFormatError(
            f"{p}: unknown file extension {ext or '(none)'!r}; expected one of: {supported}{later}"
        )
    return reader(p, **kwargs)
