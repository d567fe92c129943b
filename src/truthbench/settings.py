"""Settings declared once: each with its default, unit, constraint and one sentence.

A configurable object (an updater, an identifier, the diagnosis) is a frozen dataclass
whose fields are its settings. Each field is declared with :func:`setting`, which keeps
a :class:`Setting` in the field's metadata; everything else is read from there:

* the Python constructor checks its arguments (:class:`Configurable` calls
  :func:`check_settings` in ``__post_init__``) and is the one place the defaults live;
* a function that runs the method takes its defaults from the class
  (``tolerance: float = FiniteDifferenceUpdater.tolerance``);
* the campaign and model files build their tables from the declarations
  (:func:`settings_model`: pydantic fields with the same defaults and constraints);
* the command line builds an option's check and help from one
  (:func:`truthbench.cli._args.setting_option`);
* the file reference lists them (:func:`truthbench.campaign.reference`).

Why a dataclass with field metadata and not a pydantic model: the classes are the
library's Python API and are built often (a setting per trial, per fit): a frozen
dataclass keeps a plain keyword signature, pickles, costs nothing to construct and
imports nothing heavy (this module needs only the standard library and
:mod:`truthbench._validation`; pydantic is loaded only when a file schema is built). The
constraint vocabulary is small (an interval, an integer, a list of choices, a frequency
band), so rendering it for pydantic and argparse takes a few lines each, and a
constraint written once is checked the same way from Python, a file and the command
line.

Using it for another class (the diagnosis's ``DiagnoseSettings``, say)::

    @dataclass(frozen=True, kw_only=True)
    class DiagnoseSettings(Configurable):
        threshold: float = setting(10.0, "least delta BIC of an effect", low=0)
        band_hz: tuple[float, float] | None = setting(None, "band compared", kind="band",
                                                      unit="Hz")
        point_map: Mapping[int, float] = field(default_factory=dict)  # not a setting

    DiagnoseSpec = settings_model("DiagnoseSpec", [DiagnoseSettings], base=_DiagnoseTable)

Fields without :func:`setting` are ordinary fields (not checked, not in the file); the
``base`` model holds the file's own keys (``map``, ``channels``, ...) and validators, and
``exclude=[...]`` leaves out declared settings the file spells differently. The
constructor's ``DiagnoseSettings.from_settings(spec.diagnose.model_dump())`` then takes
the file's values by name, and a command-line option for one is
``cli._args.setting_option(parser, "--threshold",
"truthbench.diagnose.settings:DiagnoseSettings.threshold", help=...)``; the contract test
(``tests/test_settings.py``) checks a class once it is listed there.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar

from truthbench._validation import check_choice, check_number

KINDS = ("int", "float", "str", "bool", "band")
"""What a setting holds: an integer, a finite number, a string, a boolean, or a band
``(low, high)`` with ``0 <= low < high``."""


@dataclass(frozen=True)
class Setting:
    """One declared setting.

    Parameters
    ----------
    default : object
        The default value (None: unset, the method decides or does without).
    description : str
        One sentence: what it does (the reference and ``--help`` show it).
    unit : str
        SI unit ("Hz", "s", "m"), "" for a pure number.
    kind : {"int", "float", "str", "bool", "band"}
        What it holds (default: from ``default``'s type; needed when it is None).
    low, high : float, optional
        Interval of a number; ``low_open`` / ``high_open`` exclude the ends.
    choices : tuple, optional
        The values a string (or number) may take.
    """

    default: Any
    description: str
    unit: str = ""
    kind: str = ""
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple | None = None

    def __post_init__(self):
        kind = self.kind or _kind_of(self.default)
        check_choice("kind", kind, KINDS, where="Setting")
        object.__setattr__(self, "kind", kind)
        if self.choices is not None:
            object.__setattr__(self, "choices", tuple(self.choices))
        if self.default is not None:
            self.check("default", self.default, where="Setting")

    @property
    def optional(self) -> bool:
        """Whether None (unset) is allowed: the default is None."""
        return self.default is None

    def check(self, name: str, value, *, where: str = "",
              error: type[Exception] = ValueError):
        """``value`` checked against the declaration (ints as int, numbers as float,
        a band as a tuple of two floats); ``error`` names ``where`` and ``name``."""
        if value is None and self.optional:
            return None
        prefix = f"{where}: " if where else ""
        if self.choices is not None:
            return check_choice(name, value, self.choices, where=where, error=error)
        if self.kind in ("int", "float"):
            return check_number(name, value, low=self.low, high=self.high,
                                low_open=self.low_open, high_open=self.high_open,
                                integer=self.kind == "int", where=where, error=error)
        if self.kind == "bool":
            if not isinstance(value, bool):
                raise error(f"{prefix}'{name}' must be true or false; got {value!r}")
            return value
        if self.kind == "str":
            if not isinstance(value, str):
                raise error(f"{prefix}'{name}' must be a string; got {value!r}")
            return value
        try:  # band
            lo, hi = (float(v) for v in value)
            ok = 0.0 <= lo < hi and math.isfinite(hi)
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise error(f"{prefix}'{name}' must be a band [low, high] in {self.unit or 'Hz'}"
                        f" with 0 <= low < high; got {value!r}")
        return (lo, hi)

    def type_text(self) -> str:
        """What the setting holds, in words ("integer", "number", "[low, high]", ...)."""
        text = {"int": "integer", "float": "number", "str": "string", "bool": "boolean",
                "band": "[low, high]"}[self.kind]
        return text + (" or unset" if self.optional else "")

    def constraint_text(self) -> str:
        """The constraint in words ("> 0 and < 0.1", "one of 'central', 'forward'"), or
        ""."""
        if self.choices is not None:
            return "one of " + ", ".join(map(repr, self.choices))
        if self.kind == "band":
            return "0 <= low < high"
        parts = []
        if self.low is not None:
            parts.append(f"{'>' if self.low_open else '>='} {self.low:g}")
        if self.high is not None:
            parts.append(f"{'<' if self.high_open else '<='} {self.high:g}")
        return " and ".join(parts)

    def rule_text(self) -> str:
        """What a value must be, as the error messages say it ("an integer >= 1", "a
        finite number > 0", "one of 'central', 'forward'")."""
        if self.choices is not None:
            return self.constraint_text()
        what = {"int": "an integer", "float": "a finite number", "str": "a string",
                "bool": "true or false",
                "band": f"a band [low, high] in {self.unit or 'Hz'} with"}[self.kind]
        rule = self.constraint_text()
        return f"{what} {rule}" if rule else what


def _kind_of(default) -> str:
    if isinstance(default, bool):
        return "bool"
    if isinstance(default, int):
        return "int"
    if isinstance(default, float):
        return "float"
    if isinstance(default, str):
        return "str"
    raise ValueError(f"Setting: give 'kind' (one of {', '.join(KINDS)}) for a default of "
                     f"{default!r}")


def setting(default, description: str, **declaration) -> Any:
    """A dataclass field declaring a setting (keyword arguments: those of
    :class:`Setting`); use it as the field's default."""
    return dataclasses.field(default=default, metadata={
        "setting": Setting(default, description, **declaration)})


def declared(cls_or_obj) -> dict[str, Setting]:
    """The declared settings of a class (or instance), by field name, in field order."""
    return {f.name: f.metadata["setting"] for f in dataclasses.fields(cls_or_obj)
            if "setting" in f.metadata}


def check_settings(obj, *, where: str | None = None) -> None:
    """Check every declared setting of the frozen dataclass instance ``obj`` and store
    the checked (normalised) values; a ValueError names the class and the setting."""
    where = type(obj).__name__ if where is None else where
    for name, s in declared(obj).items():
        object.__setattr__(obj, name, s.check(name, getattr(obj, name), where=where))


@dataclass(frozen=True, kw_only=True)
class Configurable:
    """Base of a frozen, keyword-only dataclass of declared settings: checks them on
    construction, builds one from a table of a file (:meth:`from_settings`) and lists
    them (:meth:`settings`)."""

    name: ClassVar[str] = ""

    def __post_init__(self):
        check_settings(self)

    @classmethod
    def from_settings(cls, settings: Mapping[str, object] | None = None):
        """An instance with the declared settings found in ``settings`` (a file's table as
        a mapping; keys it does not declare, and None values, are ignored)."""
        settings = dict(settings or {})
        return cls(**{k: settings[k] for k in declared(cls)
                      if settings.get(k) is not None})

    def settings(self) -> dict[str, object]:
        """The declared settings, by name."""
        return {k: getattr(self, k) for k in declared(self)}


class Registry:
    """Configurable classes by name (the updaters, the identifiers): register one, build
    one from a table of settings.

    Parameters
    ----------
    kind : str
        What is registered, for messages ("updater").
    methods : tuple of str
        What every registered class must have callable (besides ``from_settings`` and
        ``settings``).
    """

    def __init__(self, kind: str, methods: tuple[str, ...]):
        self.kind = kind
        self.methods = tuple(methods) + ("from_settings", "settings")
        self._classes: dict[str, type] = {}
        self.view = MappingProxyType(self._classes)
        """Read-only view of the registered classes, by name."""

    def register(self, cls: type, *, replace: bool = False) -> type:
        """Register ``cls`` under ``cls.name`` (``replace=True`` to overwrite); usable as a
        class decorator."""
        name = getattr(cls, "name", None)
        if not isinstance(name, str) or not name:
            raise ValueError(f"an {self.kind} needs a non-empty string 'name'; got {name!r}")
        for attr in self.methods:
            if not callable(getattr(cls, attr, None)):
                raise ValueError(f"{self.kind} {name!r} has no callable {attr!r}")
        if name in self._classes and not replace:
            raise ValueError(f"an {self.kind} named {name!r} is already registered; pass "
                             f"replace=True to overwrite it")
        self._classes[name] = cls
        return cls

    def make(self, name: str, settings: Mapping[str, object] | None = None):
        """The class registered under ``name`` built from ``settings``
        (:meth:`Configurable.from_settings`; None: the defaults).

        Raises
        ------
        ValueError
            Unknown name (the message lists the registered ones) or a bad setting.
        """
        try:
            cls = self._classes[name]
        except (KeyError, TypeError):
            raise ValueError(f"unknown {self.kind} {name!r}; expected one of "
                             f"{sorted(self._classes)}") from None
        return cls.from_settings(settings)


def merged(classes: Iterable[type]) -> dict[str, Setting]:
    """The declared settings of several classes, which share a table of a file (the
    ``[update]`` table of every updater). A name declared by two classes must be the same
    declaration (same default, unit, constraint and sentence), else a TypeError names
    both: their defaults cannot drift apart."""
    out: dict[str, tuple[Setting, type]] = {}
    for cls in classes:
        for name, s in declared(cls).items():
            if name in out and out[name][0] != s:
                raise TypeError(f"setting {name!r} is declared differently by "
                                f"{out[name][1].__name__} ({out[name][0]}) and "
                                f"{cls.__name__} ({s}); declare it once in a shared base")
            out.setdefault(name, (s, cls))
    return {name: s for name, (s, _) in out.items()}


def pydantic_field(s: Setting) -> tuple[Any, Any]:
    """``(annotation, FieldInfo)`` of a setting for a pydantic model: the same default, the
    same check (:meth:`Setting.check`, its rule in the message), the sentence as
    description, the unit and the constraint in ``json_schema_extra``."""
    from typing import Annotated

    from pydantic import AfterValidator, Field
    from pydantic_core import PydanticCustomError

    def check(value):
        try:
            return s.check("value", value)
        except ValueError:
            raise PydanticCustomError("setting", s.rule_text()) from None

    base = {"int": int, "float": float, "str": str, "bool": bool,
            "band": tuple[float, float]}[s.kind]
    annotation: Any = Annotated[base, AfterValidator(check)]
    if s.optional:
        annotation = annotation | None
    extra = {"unit": s.unit, "constraint": s.constraint_text()}
    return annotation, Field(default=s.default, description=s.description,
                             json_schema_extra=extra)


def settings_model(name: str, classes: Iterable[type], *, base, doc: str = "",
                   exclude: Iterable[str] = ()):
    """A pydantic model of a file's table: ``base``'s own fields and validators plus a
    field for every setting the classes declare (:func:`merged`, :func:`pydantic_field`),
    minus ``exclude``."""
    from pydantic import create_model

    fields = {k: pydantic_field(s) for k, s in merged(classes).items()
              if k not in set(exclude)}
    return create_model(name, __base__=base, __doc__=doc or base.__doc__,
                        __module__=base.__module__, **fields)
