"""The identifiers of this room behind one small protocol, chosen by name.

Every registered identifier is a function ``(freq_hz, frf, *, frf_type, **options) ->
ModalParameters``; the shared contract test (``tests/identify/test_registry.py``) runs
over all of them.
"""

from __future__ import annotations

from collections.abc import Callable
from types import MappingProxyType
from typing import Protocol

from truthbench.identify.modal import ModalParameters
from truthbench.identify.peak import peak_picking
from truthbench.identify.plscf import identify_plscf


class Identifier(Protocol):
    """Signature shared by the registered identifiers."""

    def __call__(
        self, freq_hz, frf, *, frf_type: str = "displacement", **options
    ) -> ModalParameters: ...


def _plscf(freq_hz, frf, *, frf_type: str = "displacement", **options) -> ModalParameters:
    """pLSCF + automatic pole selection + LSFD (:func:`identify_plscf`)."""
    return identify_plscf(freq_hz, frf, frf_type=frf_type, **options).modal


def _peak(freq_hz, frf, *, frf_type: str = "displacement", **options) -> ModalParameters:
    """Peak picking with half-power damping (:func:`peak_picking`)."""
    return peak_picking(freq_hz, frf, frf_type=frf_type, **options).modal


_REGISTRY: dict[str, Callable[..., ModalParameters]] = {"plscf": _plscf, "peak": _peak}

#: Read-only view of the registered identifiers, by name.
IDENTIFIERS = MappingProxyType(_REGISTRY)


def get_identifier(name: str) -> Identifier:
    """Return the identifier registered under ``name``.

    Raises
    ------
    ValueError
        If no identifier has that name (the message lists the known names).
    """
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"The 'name' parameter must be one of {sorted(_REGISTRY)}; got {name!r} instead."
        ) from None


def register_identifier(name: str, func: Identifier, *, replace: bool = False) -> None:
    """Register ``func`` under ``name`` (``replace=True`` to overwrite an entry)."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"The 'name' parameter must be a non-empty string; got {name!r}.")
    if not callable(func):
        raise ValueError(f"The 'func' parameter must be callable; got {type(func).__name__}.")
    if name in _REGISTRY and not replace:
        raise ValueError(
            f"An identifier named {name!r} is already registered; pass replace=True to "
            "overwrite it."
        )
    _REGISTRY[name] = func
