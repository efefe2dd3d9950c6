"""``pacc cloud`` (``python -m cloud_sync``): the cloud side's sub-commands.

One module per sub-command (cantools style): each has ``add_subparser(subparsers)`` and a
private ``_do_x(args)``. Heavy libraries are imported inside the sub-commands, so ``--help``
stays fast.
"""

from __future__ import annotations

import argparse

from pacc.commands import cloud_learn as learn_cmd
from pacc.commands import cloud_serve as serve_cmd
from pacc.commands import cloud_sync as sync_cmd
from pacc.commands._args import CommandParser

__all__ = ["main", "build_parser"]

SUBCOMMAND_MODULES = (learn_cmd, serve_cmd, sync_cmd)


def build_parser() -> argparse.ArgumentParser:
    """The ``pacc cloud`` parser with every sub-command registered."""
    parser = CommandParser(
        prog="pacc cloud",
        description="Cloud side of pacc: learn each driver's DGPT by IRL, serve it, sync to it.",
    )
    subparsers = parser.add_subparsers(title="sub-commands", dest="command", metavar="COMMAND")
    for module in SUBCOMMAND_MODULES:
        module.add_subparser(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``) and run the chosen sub-command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 2
    code: int = args.func(args)
    return code
