"""``pacc cloud``: the cloud side's sub-commands.

One module per sub-command (cantools style): each has ``add_subparser(subparsers)`` and a
private ``_do_x(args)``.

- :mod:`pacc.commands.cloud.learn` — ``pacc cloud learn``: a driver's DGPT by IRL from files.
- :mod:`pacc.commands.cloud.serve` — ``pacc cloud serve``, ``register`` and ``vehicle``.
- :mod:`pacc.commands.cloud.sync` — ``pacc cloud sync``: upload trip logs and trip reports.
"""

from __future__ import annotations

import argparse

from pacc.commands._args import CommandParser
from pacc.commands.cloud import learn as learn_cmd
from pacc.commands.cloud import serve as serve_cmd
from pacc.commands.cloud import sync as sync_cmd

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
