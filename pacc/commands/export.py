"""``pacc export IN OUT``: convert a CAN log between python-can's formats and pacc's MCAP.

Formats by suffix: ``.mcap``, ``.log`` (candump), ``.asc``, ``.blf``, ``.trc``, ``.csv``, through
python-can's readers and writers (pacc's MCAP registered as a plugin). A failed conversion
leaves no output behind; ``pacc export x.mcap.part x.mcap`` repairs a killed recording
(:func:`ecu.buslog.repair.repair`). Exit status: 0, 2 on a bad file or format.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from dbc.errors import UsageError, error_line
from dbc.vocab import FormatError
from ecu import EcuError
from pacc.commands._args import CommandParser, fail

#: the formats pacc converts between, by suffix
FORMATS = (".mcap", ".log", ".asc", ".blf", ".trc", ".csv")


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(
        prog="pacc export",
        description="convert a CAN log between pacc's MCAP and python-can's formats "
        "(.log candump, .asc, .blf, .trc, .csv ...)",
    )
    p.add_argument("src", type=Path, metavar="IN", help="the log to read")
    p.add_argument("dst", type=Path, metavar="OUT", help="the log to write (format by suffix)")
    p.add_argument(
        "--dbc", help="MCAP output: decode the frames with this DBC (default: the pacc network)"
    )
    return p


def convert(src: Path, dst: Path, dbc: str | None = None) -> int:
    """Copy every frame of ``src`` to ``dst`` with python-can's reader and writer; the
    number of frames. Raises EcuError (CanLogError) or ValueError/OSError on bad input."""
    import can  # noqa: PLC0415 - python-can only when a log is converted

    for path in (src, dst):
        if path.suffix.lower() not in FORMATS and not (
            path is src and path.name.lower().endswith(".mcap.part")  # a killed recording
        ):
            raise UsageError(
                f"{path}: unsupported format {path.suffix or '(no suffix)'!r} "
                f"(one of {', '.join(FORMATS)})"
            )
    if src.resolve() == dst.resolve():
        raise UsageError("IN and OUT are the same file")
    if src.is_dir():
        raise UsageError(f"{src} is a directory, not a CAN log")
    if not src.is_file():
        raise FileNotFoundError(f"{src}: no such file")
    kwargs = {"dbc": dbc} if dbc and dst.suffix.lower() == ".mcap" else {}
    if src.name.lower().endswith(".mcap.part"):
        return _from_part(src, dst, kwargs)
    n = 0
    # an ASC file keeps its start time in its header: read absolute times, not offsets
    absolute = {"relative_timestamp": False} if src.suffix.lower() == ".asc" else {}
    with can.LogReader(src, **absolute) as reader, can.Logger(dst, **kwargs) as writer:
        for msg in reader:
            writer.on_message_received(msg)
            n += 1
    if n == 0:
        raise UsageError(f"{src}: no CAN frame read (not a {src.suffix} log, or an empty one)")
    return n


def _from_part(src: Path, dst: Path, kwargs: dict[str, str]) -> int:
    """Convert a recording killed mid-run (read up to its last chunk, with a warning)."""
    import can  # noqa: PLC0415

    from ecu.buslog.reader import messages, read_recording  # noqa: PLC0415
    from ecu.buslog.repair import repair  # noqa: PLC0415

    log = read_recording(src, _warn)
    if dst.suffix.lower() == ".mcap" and not kwargs:
        return repair(src, dst)
    n = 0
    with can.Logger(dst, **kwargs) as writer:
        for msg in messages(log):
            writer.on_message_received(msg)
            n += 1
    return n


def _warn(text: str) -> None:
    print(f"pacc export: warning: {text.split('; pacc export')[0]}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc export``; returns the exit status."""
    args = _parser().parse_args(argv)
    if args.dbc and args.dst.suffix.lower() != ".mcap":
        print("pacc export: error: --dbc applies to an .mcap output only", file=sys.stderr)
        return 2
    existed = args.dst.exists()
    try:
        n = convert(args.src, args.dst, args.dbc)
    except (EcuError, FormatError, UsageError, ValueError, OSError) as exc:
        if not existed:
            with contextlib.suppress(OSError):
                args.dst.unlink(missing_ok=True)
        part = args.dst.with_name(args.dst.name + ".part")  # the MCAP writer's temporary file
        if part.resolve() != args.src.resolve():  # never the killed recording being repaired
            with contextlib.suppress(OSError):
                part.unlink(missing_ok=True)
        text = error_line(exc)
        if str(args.src) not in text and str(args.dst) not in text:
            text = f"{args.src}: {text}"  # a python-can reader's bare message names no file
        return fail("pacc export", text)
    print(f"{n} frames: {args.src} -> {args.dst}")
    return 0
