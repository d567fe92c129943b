"""Sphinx extension: the reference tables generated from the code at build time.

Nothing here is copied by hand. At ``builder-inited`` it writes reStructuredText tables
into ``docs/_generated/`` (not tracked) from

* the campaign and model-file schemas (:class:`truthbench.campaign.spec.CampaignSpec`,
  :class:`truthbench.campaign.model_file.ModelSpec`): every key with its type and
  constraints, default, unit and description (:func:`settings_rows`);
* the plants' parameter declarations (:attr:`truthbench.plants.base.Plant.parameters`);
* the effects registry (:data:`truthbench.effects.EFFECTS`): parameters, options,
  scope, target, description, and how the diagnosis tries each one.

:func:`settings_rows` is the one place that reads the settings declarations, through
:func:`truthbench.campaign.reference`.
"""

from __future__ import annotations

import ast
import inspect
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

#: Units by key suffix: the project names every unit in its keys (``band_hz``,
#: ``record_s``, ``x_m``, ...).
UNIT_SUFFIXES = (("_kg_m3", "kg/m^3"), ("_kg_m2", "kg m^2"), ("_n_m_s_rad", "N m s/rad"),
                 ("_n_s_m", "N s/m"), ("_n_m", "N/m"), ("_hz", "Hz"), ("_pa", "Pa"),
                 ("_kg", "kg"), ("_m", "m"), ("_s", "s"), ("_h", "h"), ("_n", "N"))


@dataclass(frozen=True)
class SettingRow:
    """One key of a file: the TOML table it sits in, its name, type (with its
    constraints), default, unit and description."""

    table: str
    key: str
    type: str
    default: str
    unit: str
    description: str


def attribute_docstrings(cls: type) -> dict[str, str]:
    """The string literal written under each annotated attribute of ``cls`` (and its
    bases), as Sphinx's autodoc reads it."""
    out: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if klass in (object, BaseModel) or not klass.__module__.startswith("truthbench"):
            continue
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        except (OSError, TypeError):
            continue
        body = tree.body[0].body
        for node, after in zip(body, body[1:], strict=False):
            if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
                    and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)
                    and isinstance(after.value.value, str)):
                out[node.target.id] = inspect.cleandoc(after.value.value)
    return out


def unit_of(key: str) -> str:
    for suffix, unit in UNIT_SUFFIXES:
        if key.endswith(suffix):
            return unit
    return "-"


def _bounds(schema: dict) -> str:
    parts = []
    for word, sign in (("minimum", ">="), ("exclusiveMinimum", ">"),
                       ("maximum", "<="), ("exclusiveMaximum", "<")):
        if word in schema:
            parts.append(f"{sign} {schema[word]:g}")
    if "minItems" in schema and schema.get("type") == "array" and "prefixItems" not in schema:
        parts.append(f"at least {schema['minItems']}")
    return " ".join(parts)


def _type(schema: dict, defs: dict) -> str:
    """A short human type of a JSON-schema node: ``integer >= 1``, ``"a" | "b"``,
    ``[low, high]``, ``list of strings``, a nested table by name."""
    if "$ref" in schema:
        return "table"
    if "anyOf" in schema:
        kinds = [s for s in schema["anyOf"] if s.get("type") != "null"]
        return " or ".join(_type(s, defs) for s in kinds)
    if "enum" in schema:
        return " | ".join(f'"{v}"' if isinstance(v, str) else str(v) for v in schema["enum"])
    if "const" in schema:
        return repr(schema["const"])
    kind = schema.get("type")
    bounds = _bounds(schema)
    if kind == "array":
        if "prefixItems" in schema:
            items = schema["prefixItems"]
            inner = ", ".join(_type(s, defs) for s in items)
            if len(items) == 2 and all(s.get("type") == "number" for s in items):
                return "[low, high], numbers, low < high"
            return f"[{inner}]"
        inner = _type(schema.get("items", {}), defs)
        plural = inner if inner.startswith("[") else inner.split(" ", 1)[0] + "s" + (
            " " + inner.split(" ", 1)[1] if " " in inner else "")
        return f"list of {plural}" + (f", {bounds}" if bounds else "")
    if kind == "object":
        inner = schema.get("additionalProperties")
        if isinstance(inner, dict):
            return f"table of {_type(inner, defs)}"
        return "table"
    names = {"integer": "integer", "number": "number", "string": "string",
             "boolean": "true | false"}
    out = names.get(kind, kind or "any")
    return f"{out} {bounds}" if bounds else out


def _toml(value: Any) -> str:
    if value is None:
        return "unset"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{}" if not value else "{ " + ", ".join(
            f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    if isinstance(value, BaseModel):
        return "its defaults"
    return repr(value)


def settings_rows(model: type[BaseModel], table: str = "") -> list[SettingRow]:
    """Every key of a campaign or model file (``model``: its schema class) and of the
    tables nested in it, in file order: read from
    :func:`truthbench.campaign.reference`, which builds them from the settings
    declarations and the schemas (``table`` is accepted for a call on a sub-table and
    keeps only the rows of that table and those below it)."""
    from truthbench.campaign import reference
    from truthbench.campaign.model_file import ModelSpec

    kind = "model" if issubclass(model, ModelSpec) else "campaign"
    rows = []
    for r in reference(kind):
        if table and not (r.table == table or r.table.startswith(table + ".")):
            continue
        text = r.type + (f" {r.constraint}" if r.constraint else "")
        default = "required" if r.required else _toml(r.default)
        rows.append(SettingRow(r.table, r.key, text, default, r.unit, r.description))
    return rows


def _args(annotation) -> tuple:
    import typing

    return typing.get_args(annotation)


def _nested_model(annotation) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in _args(annotation):
        found = _nested_model(arg)
        if found is not None:
            return found
    return None


def _origin_is(annotation, kind) -> bool:
    import typing

    origin = typing.get_origin(annotation)
    if origin is kind:
        return True
    return any(_origin_is(a, kind) for a in _args(annotation))


def _is_list(annotation) -> bool:
    return _origin_is(annotation, list)


def _is_dict(annotation) -> bool:
    return _origin_is(annotation, dict)


# ---- reStructuredText ------------------------------------------------------------------

def _cell(text: str) -> str:
    """Text in a list-table cell: one paragraph; a bar outside literals is a bar, not a
    substitution (``|v|``)."""
    text = " ".join(str(text).split())
    if text in ("", "-"):
        return "\\-"  # a bare "-" would start a bullet list
    parts = text.split("``")
    return "``".join(p if i % 2 else p.replace("|", "\\|") for i, p in enumerate(parts))


def _list_table(header: list[str], rows: list[list[str]], widths: str) -> str:
    lines = [".. list-table::", "   :header-rows: 1", f"   :widths: {widths}", ""]
    for row in [header, *rows]:
        for i, cell in enumerate(row):
            lines.append(("   * - " if i == 0 else "     - ") + _cell(cell))
    return "\n".join(lines) + "\n"


def _code(value: str) -> str:
    return f"``{value}``" if value not in ("-", "") else "-"


def settings_rst(rows: list[SettingRow], file: str) -> str:
    """One section per TOML table of ``file`` ("campaign file", "model file"), each a
    table of its keys."""
    out = [".. currentmodule:: truthbench.campaign.spec", ""]
    tables: dict[str, list[SettingRow]] = {}
    for row in rows:
        tables.setdefault(row.table, []).append(row)
    for table, keys in tables.items():
        if not table:
            title = f"The tables of a {file}"
        elif table.endswith("[]") and table.count("[]") == 1:
            title = f"``[[{table[:-2]}]]`` ({file})"
        else:
            title = f"``[{table}]`` ({file})"
        out += [title, "^" * len(title), ""]
        out.append(_list_table(
            ["key", "type", "default", "unit", "meaning"],
            [[_code(r.key), r.type, _code(r.default) if r.default not in ("required",)
              else "required", r.unit, r.description] for r in keys],
            "14 20 14 6 46"))
    return "\n".join(out)


def plant_parameters_rst() -> str:
    """The plant parameters of every plant kind and section, from the plants' own
    declarations."""
    from truthbench.fe.beam import SECTIONS
    from truthbench.plants import make_plant
    from truthbench.plants.base import MATERIALS, PLANTS

    seen: dict[str, tuple] = {}
    for kind in PLANTS:
        for section in SECTIONS:
            for material in MATERIALS:
                plant = make_plant(kind, section=section, material=material)
                for name, info in plant.parameters.items():
                    entry = seen.setdefault(name, (info, set(), set(), {}))
                    entry[1].add(kind)
                    entry[2].add(section)
                    entry[3][material] = info.default
    rows = []
    for name, (info, kinds, sections, defaults) in seen.items():
        if info.default is None:
            default = "required"
        elif len(set(defaults.values())) > 1:
            default = ", ".join(f"{v:g} ({m})" for m, v in defaults.items())
        else:
            default = f"{info.default:g}"
        where = "every section" if len(sections) == len(SECTIONS) else (
            "section " + ", ".join(f'"{s}"' for s in sorted(sections)))
        plants = "both" if len(kinds) == len(PLANTS) else ", ".join(sorted(kinds))
        rows.append([_code(name), info.unit, default, info.description
                     + (" (per group)" if info.per_group else ""), where, plants])
    return _list_table(["parameter", "unit", "default", "meaning", "where", "plants"],
                       rows, "22 10 10 34 14 10")


#: The order the effects table lists the targets in.
TARGET_ORDER = ("structure", "appended", "measurement", "loop", "nonlinear")


def effects_rst() -> str:
    """The effects of the uncertainty table, from the registry."""
    from truthbench.effects import EFFECTS

    rows = []
    for target in TARGET_ORDER:
        for name, cls in EFFECTS.items():
            if cls.target != target:
                continue
            params = ", ".join(f"``{p.name}`` ({p.default:g})" for p in cls.params) or "-"
            options = ", ".join(f"``{k}`` (required)" if v is None else f"``{k}`` = {v!r}"
                                for k, v in cls.options.items()) or "-"
            rows.append([_code(name), params, options, cls.default_scope, cls.target,
                         cls.description])
    return _list_table(["effect", "parameters (default mean)", "options", "default scope",
                        "changes", "what it models"], rows, "14 20 16 9 9 32")


WHERE = {"station": "every node", "sensor": "every output channel",
         "support": "every suspension point, and all together"}
DIRECTIONS = {"translation": "every measured translation",
              "measured": "every measured direction",
              "bending": "the bending rotation of every measured direction"}


def diagnosable_rst() -> str:
    """The effects the diagnosis tries as missing, their fitted parameters and where."""
    from truthbench.effects import EFFECTS

    rows = []
    for name, cls in EFFECTS.items():
        d = cls.diagnosis
        if d is None:
            continue
        where = " x ".join(x for x in (WHERE.get(d.location or ""),
                                        DIRECTIONS.get(d.directions or "")) if x) or "-"
        rows.append([_code(name), ", ".join(f"``{f.name}``" for f in d.fitted), where])
    return _list_table(["effect", "fitted", "where it is tried"], rows, "25 30 45")


def public_api_rst() -> str:
    """The names of ``truthbench.__all__``, each linked to where its module documents
    it."""
    import truthbench

    items = [f"   ~{module}.{name}" for name, module in truthbench._EXPORTS.items()]
    return "\n".join([".. autosummary::", "   :nosignatures:", "", *items]) + "\n"


def write_generated(out: Path) -> list[Path]:
    """Write every generated table into ``out``; returns the files written."""
    from truthbench.campaign.model_file import ModelSpec
    from truthbench.campaign.spec import CampaignSpec

    out.mkdir(parents=True, exist_ok=True)
    files = {
        "campaign_keys.rst": settings_rst(settings_rows(CampaignSpec, ""), "campaign file"),
        "model_keys.rst": settings_rst(settings_rows(ModelSpec, ""), "model file"),
        "plant_parameters.rst": plant_parameters_rst(),
        "effects.rst": effects_rst(),
        "diagnosable.rst": diagnosable_rst(),
        "public_api.rst": public_api_rst(),
    }
    written = []
    for name, text in files.items():
        path = out / name
        if not path.exists() or path.read_text() != text:  # unchanged: no rebuild
            path.write_text(text)
        written.append(path)
    return written


def _on_builder_inited(app) -> None:
    write_generated(Path(app.srcdir) / "_generated")


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
