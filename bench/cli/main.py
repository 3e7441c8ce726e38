"""``structbench``: parse the command line and hand it to one sub-command
module of this package.

Each command module provides ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``. User errors print one line and exit with status 2.
Only the chosen command's arguments are set up and the API imports what a
call needs when it runs, so ``--help`` loads no numerical library. Output
piped into a reader that stops early (``| head``) ends the command quietly
with status 141, as a Unix tool killed by SIGPIPE.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Iterable, Sequence
from types import ModuleType

from structbench import api

COMMANDS = ("modes", "build-fmus", "run", "traces", "identify", "frf", "score", "check", "reproduce", "import",
            "export", "plot-modes", "plan", "methods")
MODULES = {"import": "import_data"}  # command names that are Python keywords
BROKEN_PIPE = 128 + 13  # the shell's status of a process killed by SIGPIPE


def _module(command: str) -> ModuleType:
    return importlib.import_module(f"{__package__}.{MODULES.get(command, command.replace('-', '_'))}")


def build_parser(commands: Iterable[str] = COMMANDS) -> argparse.ArgumentParser:
    """The parser; the sub-commands not in ``commands`` get their name and
    help only (all ``structbench --help`` shows of them)."""
    chosen = set(commands)
    parser = argparse.ArgumentParser(
        prog="structbench", description="A virtual vibration-test lab: structures as FMUs, test campaigns, "
                                        "identification from the logged traces, scoring against the truth. "
                                        "SI units throughout.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        module = _module(command)
        subparser = sub.add_parser(command, help=module.HELP, description=module.HELP)
        if command in chosen:
            module.add_arguments(subparser)
    return parser


def chosen_command(argv: Sequence[str]) -> list[str]:
    """The sub-command named on the command line (its first word), if any."""
    first = next((a for a in argv if not a.startswith("-")), None)
    return [first] if first in COMMANDS else []


def _quiet_stdout() -> None:
    """Send what is left of stdout to /dev/null: the reader of the pipe is
    gone and Python's final flush must not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout is not a file descriptor (a captured stream)
        pass


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = build_parser(chosen_command(argv)).parse_args(argv)  # --help exits here
    try:
        status = int(_module(args.command).run(args) or 0)
        sys.stdout.flush()  # a closed pipe shows here, not at exit
        return status
    except BrokenPipeError:
        _quiet_stdout()
        return BROKEN_PIPE
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except api.UserError as err:  # evaluated only when something was raised
        print(f"structbench {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
