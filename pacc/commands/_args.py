"""What several sub-commands share: the bus flags, argparse types, output checks.

:class:`CommandParser` (a one-line usage error), python-can's ``-i/-c/-b`` flags
(:func:`add_bus_arguments`, :func:`bus_kwargs`, :func:`bus_error`), the simulated world's
options (:func:`add_world_arguments`), finite ranged numbers
(:func:`number`, :func:`integer`), and outputs refused before a run: two options naming one
file (:func:`check_distinct_outputs`), an unwritable file or folder
(:func:`check_writable_file`, :func:`check_writable_dir`). Nothing here imports numpy or
python-can, so ``pacc X --help`` stays fast: the names options choose from are copies of the
libraries' own (tests/pacc/test_cli.py compares them).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

from dbc.errors import UsageError


class CommandParser(argparse.ArgumentParser):
    """argparse's parser whose usage error is one line on stderr, ``PROG: error: MESSAGE
    (PROG --help)``, exit 2: the same shape as every other error of pacc (no usage block)."""

    def error(self, message: str) -> NoReturn:
        """Print the one line and exit 2."""
        text = " ".join(message.split())
        self.exit(2, f"{self.prog}: error: {text} (see {self.prog} --help)\n")


def fail(prog: str, why: object, code: int = 2) -> int:
    """Print ``PROG: error: WHY`` on stderr; return the exit status ``code``."""
    print(f"{prog}: error: {why}", file=sys.stderr)
    return code


#: the choices of options, as pacc.study.drive (CONTROLLERS, BUSES), ecu.adaptation
#: (ADAPTATION_MODES), sim_bus.population (POPULATIONS, DEFAULT_POPULATION) and
#: sim_bus.drivers (CONDITION_FACTORS) and pacc.study.spec (ROADS) define them
CONTROLLERS = ("predefined", "predefined+oa", "irl", "irl+oa")
BUSES = ("lockstep", "virtual")
ADAPTATION_MODES = ("paper", "timegap")
POPULATIONS, DEFAULT_POPULATION = ("headway", "people"), "people"
CONDITIONS = ("dry", "night", "wet")
ROADS = ("shared", "per-driver")
#: ``--foxglove``'s address when given alone (ecu.buslog.live.parse_address's defaults)
FOXGLOVE_ADDRESS = "127.0.0.1:8765"

#: the largest integer any option takes (seeds, counts): beyond it a typo, not a wish
INT_MAX = 2**31 - 1


def add_bus_arguments(parser: argparse.ArgumentParser, title: str | None = None) -> None:
    """Add python-can's bus flags ``-i``, ``-c``, ``-b`` to ``parser`` (one group)."""
    group = parser.add_argument_group(
        title or "bus (omitted: python-can's own configuration applies)"
    )
    group.add_argument("-i", "--interface", help="python-can interface, e.g. virtual, socketcan")
    group.add_argument("-c", "--channel", help="channel, e.g. vcan0")
    group.add_argument(
        "-b", "--bitrate", type=integer(1, 10_000_000), help="bitrate, bit/s (1..10000000)"
    )


def add_foxglove_argument(parser: argparse.ArgumentParser) -> None:
    """``--foxglove [HOST:PORT]`` on a command's parser."""
    parser.add_argument(
        "--foxglove",
        nargs="?",
        const=FOXGLOVE_ADDRESS,
        metavar="HOST:PORT",
        help="stream the bus, decoded, and the node's internals live to Foxglove over a "
        f"WebSocket (default {FOXGLOVE_ADDRESS}, loopback only; the channels of --can-log)",
    )


def add_cloud_arguments(p: Any, *, paths: bool = False) -> None:
    """``--cloud``, ``--token-file``, ``--trust`` (``paths``: as :class:`Path`) on ``p``."""
    kind = Path if paths else str
    p.add_argument("--cloud", metavar="URL|DIR", help="the cloud service, or a folder")
    p.add_argument("--token-file", type=kind, help="with --cloud: the vehicle's token file")
    p.add_argument("--trust", type=kind, help="with --cloud: the cloud's public key (PEM)")


def add_world_arguments(p: argparse.ArgumentParser) -> None:
    """The simulated world's options, ``pacc drive``'s and ``pacc sim``'s: scenario, driver,
    seed, faults, duration (s), the trip log, the condition factor."""
    p.add_argument("--scenario", default="B", help="A, B, manual1..4, a road scenario or a CSV")
    p.add_argument("--driver", default="d1", help="d1..d5 or a driver .toml/.json (default d1)")
    p.add_argument("--seed", type=integer(0), default=0)
    p.add_argument("--faults", default="", help="fault SPEC, e.g. 'radar:dropout=100-105'")
    p.add_argument("--duration", type=number(0.0, 1e6, lo_open=True), help="the first N s only")
    p.add_argument("--log", type=Path, help="write the drive as an MCAP trip log")
    p.add_argument(
        "--condition-factor",
        type=number(0.1, 10.0),
        default=1.0,
        help="multiply the driver's preferred gap (rain: 1.2)",
    )


def bus_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The ``can.Bus(**kwargs)`` of parsed bus flags (a flag not given is left out, so
    python-can's own configuration fills it)."""
    kwargs: dict[str, Any] = {}
    for name in ("interface", "channel", "bitrate"):
        value = getattr(args, name, None)
        if value is not None:
            kwargs[name] = value
    return kwargs


def bus_error(args: argparse.Namespace, exc: BaseException) -> str:
    """``cannot open the CAN bus: ...`` for ``exc``; for SocketCAN with the way out where the
    kernel has none (python-can-remote on loopback, docs/vehicles.md)."""
    text = f"cannot open the CAN bus: {exc}"
    if getattr(args, "interface", None) == "socketcan":
        text += (
            " (SocketCAN needs Linux with a can/vcan interface; without one, run pacc ecu and "
            "pacc sim on python-can-remote: -i remote -c ws://127.0.0.1:54701/, "
            "docs/vehicles.md)"
        )
    return text


def _range_text(lo: float | None, hi: float | None, lo_open: bool) -> str:
    if lo is not None and hi is not None:
        return f"{'>' if lo_open else '>='} {lo:.12g} and <= {hi:.12g}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {lo:.12g}"
    if hi is not None:
        return f"<= {hi:.12g}"
    return "finite"


def number(
    lo: float | None = None, hi: float | None = None, *, lo_open: bool = False
) -> Callable[[str], float]:
    """An argparse ``type``: a finite float in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        too_low = lo is not None and (value <= lo if lo_open else value < lo)
        if not math.isfinite(value) or too_low or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(
                f"{text!r}: need a finite number {_range_text(lo, hi, lo_open)}"
            )
        return value

    parse.__name__ = "number"  # argparse names the type in its message
    return parse


def integer(lo: int | None = None, hi: int | None = INT_MAX) -> Callable[[str], int]:
    """An argparse ``type``: a whole number in ``[lo, hi]``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(
                f"{text!r}: need a whole number {_range_text(lo, hi, False)}"
            )
        return value

    parse.__name__ = "integer"
    return parse


def json_parameters(text: str) -> tuple[tuple[str, Any], ...]:
    """A plug-in's parameters given as a JSON object on the command line, as sorted
    ``(name, value)`` pairs (argparse reports a bad one as a usage error, exit 2)."""
    try:
        value = json.loads(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"not JSON: {exc}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"give a JSON object of parameters, got {text!r}")
    return tuple(sorted((str(k), v) for k, v in value.items()))


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether ``a`` and ``b`` name one file (the same resolved path, or the same inode)."""
    pa, pb = Path(a), Path(b)
    if pa.resolve() == pb.resolve():
        return True
    try:
        return pa.samefile(pb)
    except OSError:  # one does not exist yet: the resolved paths decided
        return False


def check_distinct_outputs(**outputs: str | os.PathLike[str] | None) -> None:
    """Raise :class:`UsageError` if two of the named outputs are one file (None: not given).

    ``check_distinct_outputs(log=args.log, can_log=args.can_log)``: the names become the
    options in the message (``--log`` and ``--can-log``).
    """
    given = [(name, Path(path)) for name, path in outputs.items() if path is not None]
    for i, (name_a, a) in enumerate(given):
        for name_b, b in given[i + 1 :]:
            if same_file(a, b):
                opt_a, opt_b = (f"--{n.replace('_', '-')}" for n in (name_a, name_b))
                raise UsageError(
                    f"{opt_a} and {opt_b} name the same file {a}: one would overwrite the other"
                )


def check_writable_file(path: str | os.PathLike[str] | None, option: str) -> None:
    """Raise :class:`UsageError` unless ``path`` (None: not given) can be created or replaced
    as a file: not a folder, in an existing writable folder. Checked before a run, so the
    run's result is not lost at its end."""
    if path is None:
        return
    target = Path(path)
    parent = target.resolve().parent
    if target.is_dir():
        raise UsageError(f"{option} {target}: is a directory, not a file")
    if not (parent.is_dir() and os.access(parent, os.W_OK)):
        raise UsageError(f"{option} {target}: {parent} is not a writable folder")


def check_writable_dir(path: str | os.PathLike[str] | None, option: str) -> None:
    """Raise :class:`UsageError` unless ``path`` (None: not given) is a writable folder or
    can be created as one (its nearest existing ancestor a writable folder). Creates
    nothing: checked before a run, so a refused run leaves nothing behind."""
    if path is None:
        return
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise UsageError(f"{option} {target}: is not a folder")
    existing = target.resolve()
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not (existing.is_dir() and os.access(existing, os.W_OK)):
        raise UsageError(f"{option} {target}: {existing} is not a writable folder")
