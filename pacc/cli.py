"""The ``pacc`` console script: dispatch to the sub-commands, imported only when chosen.

The error boundary, once: a :class:`~dbc.errors.PaccError` or ``OSError`` a sub-command lets
through is one line on stderr, exit 2 (``--debug`` or ``PACC_DEBUG=1``: the traceback).
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Callable

from dbc.errors import PaccError, error_line

#: sub-command -> (module with ``main(argv) -> int``, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "ecu": ("pacc.commands.ecu", "run the ACC ECU node on a CAN bus"),
    "sim": ("pacc.commands.sim", "run the bus simulator (lead, ego car, driver) against an ECU"),
    "drive": ("pacc.commands.drive", "ECU + simulator in one process, lockstep, print PoI/NIM"),
    "study": ("pacc.commands.study", "the paper's study (Table I): every driver x controller"),
    "cloud": ("pacc.commands.cloud", "cloud side: learn a driver's DGPT by IRL, sync logs"),
    "export": ("pacc.commands.export", "convert CAN logs: pacc MCAP <-> .log/.asc/.blf/.trc/.csv"),
    "replay": ("pacc.commands.replay", "replay a bus recording through the ECU or onto a bus"),
    "plot": ("pacc.commands.plot", "plot one recorded drive: speed, gap, pedals, ACC state"),
    "demos": ("pacc.commands.demos", "real-car bus logs as IRL demonstrations (trip logs)"),
    "hil": ("pacc.commands.hil", "a person drives in a browser against the ECU: the paper's study"),
    "bench": ("pacc.commands.bench", "every method on fresh seeds, d1..d5, real data: leaderboard"),
    "plugins": ("pacc.commands.plugins", "list the controllers, adaptations and learners to name"),
    "validate": ("pacc.commands.validate", "synthetic drivers beside real people"),
}

_USAGE = "usage: pacc [-h] [--debug] {" + ",".join(SUBCOMMANDS) + "} ..."


def _help() -> str:
    lines = [
        _USAGE,
        "",
        "pacc: personalized adaptive cruise control on a CAN bus.",
        "",
        "sub-commands:",
    ]
    lines += [f"  {name:<7} {text}" for name, (_, text) in SUBCOMMANDS.items()]
    lines += [
        "",
        "options:",
        "  --debug  show the traceback of an error instead of its one line",
        "",
        "Run 'pacc SUBCOMMAND --help' for the options of one sub-command.",
    ]
    return "\n".join(lines)


def resolve(name: str) -> Callable[[list[str] | None], int]:
    """Import and return the ``main`` of sub-command ``name`` (KeyError if unknown)."""
    module_name, _ = SUBCOMMANDS[name]
    module = importlib.import_module(module_name)
    entry: Callable[[list[str] | None], int] = module.main
    return entry


def _prog(name: str, rest: list[str]) -> str:
    """``pacc ecu``, or ``pacc cloud sync`` for the cloud's sub-commands."""
    if name == "cloud" and rest and not rest[0].startswith("-"):
        return f"pacc cloud {rest[0]}"
    return f"pacc {name}"


def main(argv: list[str] | None = None) -> int:
    """Dispatch ``argv`` (default ``sys.argv[1:]``) to a sub-command; return its exit code."""
    args = list(sys.argv[1:] if argv is None else argv)
    debug = os.environ.get("PACC_DEBUG", "") not in ("", "0")
    while args and args[0] == "--debug":
        debug = True
        args = args[1:]
    if not args or args[0] in ("-h", "--help"):
        print(_help())
        return 0 if args else 2
    if args[0] == "--version":
        # importlib.metadata costs ~10 ms of start-up, only --version needs it
        from importlib.metadata import version  # noqa: PLC0415

        print(f"pacc {version('pacc')}")
        return 0
    name, rest = args[0], args[1:]
    if name not in SUBCOMMANDS:
        print(f"{_USAGE}\npacc: error: unknown sub-command {name!r}", file=sys.stderr)
        return 2
    try:
        return resolve(name)(rest)
    except BrokenPipeError:
        # the reader of a pipe (``pacc drive | head``) closed early: not an error of ours;
        # point stdout at devnull so the interpreter's final flush stays quiet
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (PaccError, OSError) as exc:
        if debug:
            import traceback  # noqa: PLC0415 - only for --debug

            traceback.print_exc()
        print(f"{_prog(name, rest)}: error: {error_line(exc)}", file=sys.stderr)
        return 2
