"""The ``structbench`` command line: one sub-command per module ``bench.cmd_*``.

Each command module provides ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``. User errors print one line and exit with status 2.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from models.errors import UserError

COMMANDS = ["modes", "build-fmus", "run", "traces", "identify", "score", "check", "reproduce"]


def _module(command: str):
    return importlib.import_module(f"bench.cmd_{command.replace('-', '_')}")


def build_parser(available: list[str]) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="structbench", description="A virtual vibration-test lab.")
    sub = parser.add_subparsers(dest="command", required=True)
    for command in available:
        module = _module(command)
        module.add_arguments(sub.add_parser(command, help=module.HELP, description=module.HELP))
    return parser


def available_commands() -> list[str]:
    found = []
    for command in COMMANDS:
        try:
            _module(command)
        except ModuleNotFoundError as err:
            if err.name != f"bench.cmd_{command.replace('-', '_')}":
                raise
            continue
        found.append(command)
    return found


def main(argv: list[str] | None = None) -> int:
    parser = build_parser(available_commands())
    args = parser.parse_args(argv)
    try:
        return int(_module(args.command).run(args) or 0)
    except UserError as err:
        print(f"structbench {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
