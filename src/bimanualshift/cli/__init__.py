"""The ``bimanualshift`` command: one sub-command per job, each a thin function over the library.

The top level imports nothing heavy: ``bimanualshift --help`` and ``bimanualshift tasks`` answer at once, and a
command imports torch, robosuite or transformers only when it runs. Each command's options are a typed dataclass
parsed by ``tyro`` (its field comments are the help). Two options work before or after any command:
``--plugin MODULE`` (a user's tasks or priors, also imported by every worker) and ``--debug`` (show the full
traceback of an error instead of one line).
"""

from __future__ import annotations

import argparse
import sys

from bimanualshift.cli.dispatch import COMMANDS, DESCRIPTION, run

__all__ = ["COMMANDS", "build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser: the command list and the global options (each command parses its own)."""
    parser = argparse.ArgumentParser(prog="bimanualshift", description=DESCRIPTION,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                        help="import a module (or a .py file) that registers your own tasks or priors; repeatable")
    parser.add_argument("--debug", action="store_true", help="show the full traceback of an error")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, command in COMMANDS.items():
        sub.add_parser(name, help=command.help, add_help=False)
    return parser


def main(argv: list[str] | None = None) -> None:
    run(build_parser(), list(sys.argv[1:] if argv is None else argv))
