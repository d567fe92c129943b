"""The identifiers of this room behind one small protocol, configured as objects, chosen by
name.

An identifier is a frozen, keyword-only dataclass whose fields are its settings, each
declared once with its default, unit and constraint (:func:`truthbench.settings.setting`:
the campaign's ``[identify]`` table, the ``truthbench identify`` options and the
functions that run the methods take theirs from there). It has a ``name`` (its registry
key) and is called as ``identifier(freq_hz, frf, *, frf_type="displacement",
freq_range_hz=None) -> ModalParameters``. :func:`make_identifier` builds one from a
mapping of settings (those it declares; the rest are ignored). The shared contract test
(``tests/identify/test_registry.py``) runs over every entry of :data:`IDENTIFIERS`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol, runtime_checkable

from truthbench.identify.modal import ModalParameters
from truthbench.identify.peak import PeakIdentifier
from truthbench.identify.plscf import PLSCFIdentifier
from truthbench.settings import Registry


@runtime_checkable
class Identifier(Protocol):
    """What every registered identifier provides."""

    name: str

    def settings(self) -> dict[str, object]: ...

    def __call__(self, freq_hz, frf, *, frf_type: str = "displacement",
                 freq_range_hz: tuple[float, float] | None = None) -> ModalParameters: ...


_REGISTRY = Registry("identifier", ("__call__",))

#: Read-only view of the registered identifier classes, by name.
IDENTIFIERS = _REGISTRY.view


def register_identifier(cls: type, *, replace: bool = False) -> type:
    """Register an identifier class under ``cls.name`` (``replace=True`` to overwrite);
    usable as a class decorator."""
    return _REGISTRY.register(cls, replace=replace)


def make_identifier(name: str, settings: Mapping[str, object] | None = None) -> Identifier:
    """The identifier registered under ``name``, configured from ``settings`` (a mapping;
    None for the defaults).

    Raises
    ------
    ValueError
        Unknown name (the message lists the registered ones) or a bad setting.
    """
    return _REGISTRY.make(name, settings)


def get_identifier(name: str) -> Identifier:
    """The identifier registered under ``name`` with its default settings.

    Raises
    ------
    ValueError
        If no identifier has that name (the message lists the known names).
    """
    return make_identifier(name)


register_identifier(PLSCFIdentifier)
register_identifier(PeakIdentifier)
