"""``structbench``: parse the command line and hand it to one sub-command
module of this package.

Each command module provides ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``. User errors print one line and exit with status 2.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from types import ModuleType

from structbench import api

COMMANDS = ("modes", "build-fmus", "run", "traces", "identify", "score", "check", "reproduce", "import", "export")
MODULES = {"import": "import_data"}  # command names that are Python keywords


def _module(command: str) -> ModuleType:
    return importlib.import_module(f"{__package__}.{MODULES.get(command, command.replace('-', '_'))}")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="structbench", description="A virtual vibration-test lab: structures as FMUs, test campaigns, "
                                        "identification from the logged traces, scoring against the truth. "
                                        "SI units throughout.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        module = _module(command)
        module.add_arguments(sub.add_parser(command, help=module.HELP, description=module.HELP))
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(_module(args.command).run(args) or 0)
    except api.UserError as err:
        print(f"structbench {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
