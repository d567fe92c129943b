"""What every command shares: checked argument types, the help format, strict JSON.

Argument types raise :class:`argparse.ArgumentTypeError`, so argparse answers a bad value
with ``truthbench <command>: error: argument --x: ...`` and exit code 2 before the command
starts. :data:`OPTION_TYPES` gives the same checks to an option declared with a plain
``type=int`` by any command (``--trials``, ``--jobs``, ``--seed``, ...): the parser swaps
them in (:func:`harden`), so no command can forget them.

Imports nothing heavy: ``truthbench --help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import textwrap
from pathlib import Path


def _int(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer; got {text!r}") from None


def positive_int(text: str) -> int:
    """An integer >= 1 (a count: trials, modes, sensors, elements)."""
    value = _int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1; got {text!r}")
    return value


def nonneg_int(text: str) -> int:
    """An integer >= 0 (a seed, a trial or test index)."""
    value = _int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0; got {text!r}")
    return value


def int_in(low: int, high: int, why: str):
    """An integer in ``low..high``; ``why`` says where the limits come from."""

    def check(text: str) -> int:
        value = _int(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(
                f"expected an integer from {low} to {high} ({why}); got {text!r}")
        return value

    check.__name__ = f"int_{low}_to_{high}"
    return check


def jobs(text: str) -> int:
    """A joblib worker count: >= 1, or negative for 'all cores but |n| - 1' (-1: all)."""
    value = _int(text)
    if value == 0:
        raise argparse.ArgumentTypeError(
            "expected a worker count >= 1, or a negative joblib count (-1: every core, "
            "-2: all but one); got '0'")
    return value


def finite_float(text: str) -> float:
    """A finite number (``nan``, ``inf`` refused)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number; got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number; got {text!r}")
    return value


def frequency_hz(text: str) -> float:
    """A finite frequency >= 0, Hz."""
    value = finite_float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a frequency >= 0 Hz; got {text!r}")
    return value


def folder(text: str) -> str:
    """An output folder: anything but an existing file."""
    if Path(text).exists() and not Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a file; expected a folder")
    return text


def declared_setting(target: str):
    """The :class:`~truthbench.settings.Setting` named ``"module:Class.field"``, imported
    when asked for (the classes live in rooms that import scipy)."""
    from truthbench.settings import declared

    module, qualname = target.split(":")
    cls_name, name = qualname.rsplit(".", 1)
    return declared(getattr(importlib.import_module(module), cls_name))[name]


def setting_option(parser, flag: str, target: str, *, help: str, **kwargs):
    """Add option ``flag`` for the declared setting ``target`` (``"module:Class.field"``,
    :mod:`truthbench.settings`): its value is parsed and checked by the declaration, and
    when it is not given the command passes None, which the library reads as the
    declared default; ``--help`` shows that default (:class:`HelpFormatter`). So the
    command line cannot drift from the Python constructor and the campaign file."""

    def parse(text: str):
        s = declared_setting(target)
        name = flag.lstrip("-").replace("-", "_")
        convert = {"int": _int, "float": finite_float}.get(s.kind, str)
        try:
            return s.check(name, convert(text), error=argparse.ArgumentTypeError)
        except argparse.ArgumentTypeError as exc:
            raise argparse.ArgumentTypeError(str(exc).replace(f"'{name}' must be",
                                                              "expected")) from None

    parse.__name__ = target.rsplit(".", 1)[-1]
    action = parser.add_argument(flag, type=parse, default=None, help=help, **kwargs)
    action.setting = target
    return action


#: Checked types for options that a command declares with a plain ``type=int``.
OPTION_TYPES = {
    "--trials": positive_int,
    "--jobs": jobs,
    "--seed": nonneg_int,
    "--seeds": positive_int,
    "--count": positive_int,
    "--trial": nonneg_int,
    "--test": nonneg_int,
}


class HelpFormatter(argparse.HelpFormatter):
    """Help with every option's default (``(default: 20)``) unless the help already
    says it or there is none (None, False). Descriptions and epilogs are wrapped line by
    line; a line that starts with two spaces (an example command) is kept as written."""

    def _fill_text(self, text, width, indent):
        out = []
        for line in text.splitlines():
            if line.startswith("  ") or not line.strip():
                out.append(indent + line)
            else:
                out.append(textwrap.fill(line, width, initial_indent=indent,
                                         subsequent_indent=indent))
        return "\n".join(out)

    def _get_help_string(self, action):
        text = action.help or ""
        target = getattr(action, "setting", None)
        if target is not None:  # a declared setting: its default, unit and constraint
            s = declared_setting(target)
            unit = f" {s.unit}" if s.unit else ""
            default = "unset" if s.default is None else f"{s.default}{unit}"
            rule = s.constraint_text()
            return f"{text} (default: {default}{'; ' + rule if rule else ''})"
        if ("%(default)" in text or "default" in text.lower()
                or action.default in (None, False, argparse.SUPPRESS)
                or not action.option_strings):
            return text
        return text + " (default: %(default)s)"


class Parser(argparse.ArgumentParser):
    """The parser class of every (sub)command: :class:`HelpFormatter`, no abbreviations."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)


def harden(parser: argparse.ArgumentParser) -> None:
    """Give every plain ``type=int`` option named in :data:`OPTION_TYPES` its checked
    type, in ``parser`` and all its subcommands."""
    parser.allow_abbrev = False
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                harden(child)
            continue
        for opt in action.option_strings:
            if opt in OPTION_TYPES and action.type is int:
                action.type = OPTION_TYPES[opt]


def files_only() -> None:
    """Choose matplotlib's Agg backend: the command writes figure files and never opens a
    window (the library never chooses a backend). Call it before any figure is made."""
    import matplotlib

    matplotlib.use("Agg")


def save_figure(fig, path, *, dpi: int = 120):
    """Write ``fig`` to ``path`` (its folder made if missing) and close it."""
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def _strict(value):
    """``value`` with every non-finite float replaced by None (JSON null)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _strict(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_strict(v) for v in value]
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        return _strict(value.tolist())
    return value


def dumps(value, **kwargs) -> str:
    """Strict JSON (RFC 8259): NaN and infinities become ``null``, never ``NaN``."""
    return json.dumps(_strict(value), allow_nan=False, **kwargs)
