"""The campaign and model-file reference, read from the schemas themselves.

:func:`reference` lists every key of every table of a campaign file (or of a model file)
with its type, default, unit, constraint and description, walking the pydantic models
the files are validated with (:mod:`truthbench.campaign.spec`,
:mod:`truthbench.campaign.model_file`). The updaters' and identifiers' settings come
from their declarations (:mod:`truthbench.settings`), the other keys from the models'
fields and their docstrings, so the documentation generated from these rows cannot
drift from what the files accept.

Units: a declared setting states its own; every other key follows the files' rule that
a key ends with its SI unit (``fs_hz``, ``record_s``, ``x_m``: :data:`UNIT_SUFFIXES`),
or states it in the field (``json_schema_extra={"unit": ...}``).
"""

from __future__ import annotations

import types
import typing
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

UNIT_SUFFIXES = {"_hz": "Hz", "_s": "s", "_m": "m", "_h": "h", "_n": "N", "_pa": "Pa",
                 "_kg": "kg"}
"""The unit a key's name ends with (the files' convention: units in the keys)."""


@dataclass(frozen=True)
class ReferenceRow:
    """One key of one table.

    Attributes
    ----------
    table : str
        Dotted path of the table (``"tests.actuators"``; ``"diagnose.channels.<label>"``
        for a table of named entries).
    header : str
        The table's TOML header (``"[[tests.actuators]]"`` for an array of tables).
    key : str
    type : str
        What the value is, in words ("number", "integer", "one of 'a', 'b'", "list of
        string", "[number, number]", "table", ...; "... or unset" when it may be left
        out without a default).
    default : object
        The default (a Python value; None: unset), or None when ``required``.
    required : bool
    unit : str
        SI unit, "" for a pure number or a name.
    constraint : str
        What the value must satisfy beyond its type (">= 1", "> 0 and < 0.1"), or "".
    description : str
    """

    table: str
    header: str
    key: str
    type: str
    default: Any
    required: bool
    unit: str
    constraint: str
    description: str


def reference(kind: Literal["campaign", "model"] = "campaign") -> tuple[ReferenceRow, ...]:
    """Every key of every table of a campaign file (``kind="campaign"``) or a model file
    (``"model"``), in the order the schema declares them, tables before their sub-tables.

    Returns
    -------
    tuple of ReferenceRow
    """
    if kind == "campaign":
        from truthbench.campaign.spec import CampaignSpec as root
    elif kind == "model":
        from truthbench.campaign.model_file import ModelSpec as root
    else:
        raise ValueError(f"reference: 'kind' must be 'campaign' or 'model'; got {kind!r}")
    rows: list[ReferenceRow] = []
    for key, field in root.model_fields.items():
        if key in ("source", "ignored"):  # filled by the loader, not keys of the file
            continue
        model, array = _table_model(field.annotation)
        _walk(model, key, array, rows)
    return tuple(rows)


def _walk(model: type[BaseModel], path: str, array: bool, rows: list[ReferenceRow]) -> None:
    header = f"[[{path}]]" if array else f"[{path}]"
    subtables = []
    for key, field in model.model_fields.items():
        sub, sub_array = _table_model(field.annotation)
        named = _named_tables(field.annotation)
        extra = field.json_schema_extra if isinstance(field.json_schema_extra, dict) else {}
        required = field.is_required()
        if field.default_factory is not None:
            default = field.default_factory()
        else:
            default = None if field.default is PydanticUndefined else field.default
        if isinstance(default, BaseModel):
            default = None
        rows.append(ReferenceRow(
            table=path, header=header, key=key, type=_type_text(field.annotation),
            default=default, required=required,
            unit=str(extra.get("unit", _unit_of(key))),
            constraint=str(extra.get("constraint", _constraint_text(field.metadata))),
            description=" ".join((field.description or "").split())))
        if sub is not None:
            subtables.append((sub, f"{path}.{key}", sub_array))
        elif named is not None:
            subtables.append((named, f"{path}.{key}.<label>", False))
    for sub, sub_path, sub_array in subtables:
        _walk(sub, sub_path, sub_array, rows)


def _strip(annotation):
    """``annotation`` without ``Annotated`` and ``| None``; and whether None was allowed."""
    while typing.get_origin(annotation) is typing.Annotated:
        annotation = typing.get_args(annotation)[0]
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        optional = len(args) < len(typing.get_args(annotation))
        if len(args) == 1:
            return _strip(args[0])[0], optional
        return typing.Union[tuple(args)], optional  # noqa: UP007 - built from a list
    return annotation, False


def _is_model(t) -> bool:
    return isinstance(t, type) and issubclass(t, BaseModel)


def _table_model(annotation) -> tuple[type[BaseModel] | None, bool]:
    """The model of a table (``X``) or an array of tables (``list[X]``), else None."""
    t, _ = _strip(annotation)
    if _is_model(t):
        return t, False
    if typing.get_origin(t) is list:
        inner, _ = _strip(typing.get_args(t)[0])
        if _is_model(inner):
            return inner, True
    return None, False


def _named_tables(annotation) -> type[BaseModel] | None:
    """The model of a table of named entries (``dict[str, X]``), else None."""
    t, _ = _strip(annotation)
    if typing.get_origin(t) is dict:
        for v in typing.get_args(typing.get_args(t)[1]) or (typing.get_args(t)[1],):
            v, _ = _strip(v)
            if _is_model(v):
                return v
    return None


def _type_text(annotation) -> str:
    t, optional = _strip(annotation)
    tail = " or unset" if optional else ""
    origin, args = typing.get_origin(t), typing.get_args(t)
    if origin is Literal:
        return "one of " + ", ".join(map(repr, args)) + tail
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_type_text(a) for a in args) + tail
    if origin is list:
        inner = _type_text(args[0])
        table = inner == "table" or inner.startswith("table of")
        return ("array of tables" if table else f"list of {inner}") + tail
    if origin is tuple:
        return "[" + ", ".join(_type_text(a) for a in args) + "]" + tail
    if origin is dict:
        return f"table of name = {_type_text(args[1])}" + tail
    if _is_model(t):
        return "table" + tail
    names = {bool: "boolean", int: "integer", float: "number", str: "string", Any: "any"}
    return names.get(t, getattr(t, "__name__", str(t))) + tail


def _constraint_text(metadata) -> str:
    """Interval and length constraints of a field (annotated_types metadata)."""
    words = {"ge": ">=", "gt": ">", "le": "<=", "lt": "<", "min_length": "at least",
             "max_length": "at most"}
    parts = []
    for m in metadata:
        for attr, word in words.items():
            value = getattr(m, attr, None)
            if value is not None:
                parts.append(f"{word} {value:g}" if "length" not in attr
                             else f"{word} {value} entries")
    return " and ".join(parts)


def _unit_of(key: str) -> str:
    for suffix in sorted(UNIT_SUFFIXES, key=len, reverse=True):
        if key.endswith(suffix):
            return UNIT_SUFFIXES[suffix]
    return ""
