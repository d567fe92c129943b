"""The truthbench command line: one module per command.

Each command module has ``register(subparsers)`` (its arguments, ``func`` set to the
command) and imports numpy, scipy, python-control, matplotlib and h5py only inside the
command, so ``truthbench --help`` answers at once. The library never imports this
package.
"""

from __future__ import annotations

import argparse
import sys

from truthbench._version import __version__
from truthbench.cli import (
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

COMMANDS = (run, validate, report, simulate, identify, export, study, place_sensors, modes)
"""The command modules, in the order ``--help`` lists them."""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="truthbench", allow_abbrev=False,
        description="Synthetic test campaigns with known truth for FE model updating.")
    p.add_argument("--version", action="version", version=f"truthbench {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        command.register(sub)
    _no_abbreviations(p)
    return p


def _no_abbreviations(parser: argparse.ArgumentParser) -> None:
    """Refuse abbreviated options in every (sub)command: ``run --trial 2`` must not be
    taken as ``--trials 2``."""
    parser.allow_abbrev = False
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                _no_abbreviations(child)


def main(argv: list[str] | None = None) -> int:
    from truthbench.errors import TruthbenchError

    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (TruthbenchError, FileNotFoundError) as exc:
        print(f"truthbench {args.command}: error: {exc}", file=sys.stderr)
        return 2
