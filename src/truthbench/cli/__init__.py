"""The truthbench command line: one module per command.

Each command module has ``register(subparsers)`` (its arguments, ``func`` set to the
command) and imports numpy, scipy, python-control, matplotlib and h5py only inside the
command, so ``truthbench --help`` answers at once. The library never imports this
package.
"""

from __future__ import annotations

import argparse
import os
import sys

from truthbench._version import __version__
from truthbench.cli import (
    diagnose,
    diagnose_study,
    export,
    identify,
    modes,
    place_sensors,
    report,
    run,
    simulate,
    study,
    validate,
)
from truthbench.cli._args import Parser, harden

COMMANDS = (run, validate, report, simulate, identify, export, diagnose, diagnose_study,
            study, place_sensors, modes)
"""The command modules, in the order ``--help`` lists them."""

#: An example per command, shown at the end of its ``--help`` (commands whose module
#: sets its own epilog keep it).
EXAMPLES = {
    "run": "examples:\n  truthbench run campaigns/quickstart.toml\n"
           "  truthbench run campaigns/hub_beam.toml --out results/hub --trials 4 --jobs 2",
    "validate": "examples:\n  truthbench validate campaigns/quickstart.toml\n"
                "  truthbench validate campaigns/hub_beam.toml --trials 1000 --jobs 8",
    "report": "example:\n  truthbench report results/quickstart/results.h5 --out report_again",
}


def build_parser() -> argparse.ArgumentParser:
    """The ``truthbench`` parser: every command with :class:`~truthbench.cli._args.Parser`
    (defaults in the help, no abbreviations), an example in every command's help, and
    the checked types of :data:`~truthbench.cli._args.OPTION_TYPES` on options declared
    with a plain ``type=int``."""
    p = Parser(
        prog="truthbench",
        description="Synthetic test campaigns with known truth for FE model updating.",
        epilog="examples:\n  truthbench modes campaigns/quickstart.toml\n"
               "  truthbench run campaigns/quickstart.toml\n"
               "  truthbench <command> --help   (options, defaults and an example)")
    p.add_argument("--version", action="version", version=f"truthbench {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser)
    for command in COMMANDS:
        command.register(sub)
    for name, child in sub.choices.items():
        if not child.epilog and name in EXAMPLES:
            child.epilog = EXAMPLES[name]
    harden(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run one command; a bad input is one message on stderr and exit code 2.

    Every error truthbench raises on purpose (:class:`~truthbench.errors.TruthbenchError`:
    a campaign or data file, an option), a missing file and a path that is a folder
    where a file is expected (or the reverse, or not permitted) end as
    ``truthbench <command>: error: <message>`` with exit code 2, never a traceback;
    argparse answers bad options the same way.
    """
    from truthbench.errors import TruthbenchError

    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (TruthbenchError, FileNotFoundError) as exc:
        print(f"truthbench {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except (IsADirectoryError, NotADirectoryError, FileExistsError, PermissionError) as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"truthbench {args.command}: error: {where}{exc.strerror or exc}",
              file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into a reader that stopped (| head)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
