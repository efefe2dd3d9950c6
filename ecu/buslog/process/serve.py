"""The recorder's writer process: runs the calls :mod:`ecu.buslog.process.remote` sends it.

``python -m ecu.buslog.process.serve`` (started by :mod:`ecu.buslog.process.writers`, never by hand)
says :data:`READY` on its stdout once imported, then serves recordings one after the other: each an
``open`` message (the file, the network, the time base, attachments, metadata, the node's current
directory), the :class:`~ecu.buslog.output.LogOutput` calls of the recording (a flush: its frames'
columns, the rows due, the chunk's end), and ``finish`` or ``abandon``, answered on stdout with None
or the failure's text. Messages are pickles, each after its length (8 bytes, little-endian).

Its stdin closed (the node's process ended or was killed) it writes what it got, keeps
``FILE.part`` and exits. It ignores SIGINT, SIGTERM and SIGHUP (a Ctrl-C, a service's stop
sent to every process of the service): it ends when its node closes the pipe.
"""

from __future__ import annotations

import contextlib
import math
import os
import pickle
import signal
import struct
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import IO, Any

from ecu.buslog.decoded import FrameBatch
from ecu.buslog.format import CanLogError
from ecu.buslog.output import LogOutput
from ecu.buslog.sinks import McapSink

__all__ = ["READY", "frame_message", "serve"]

#: what a writer process says on its stdout once it can take a recording
READY = b"R"
_LENGTH = struct.Struct("<Q")


def frame_message(obj: Any) -> bytes:
    """``obj`` pickled, after its length: one message to the writer."""
    data = pickle.dumps(obj, pickle.HIGHEST_PROTOCOL)
    return _LENGTH.pack(len(data)) + data


class _Reader:
    """The messages on the file descriptor ``fd`` (:func:`frame_message`), read in bulk."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.buf = bytearray()
        self.pos = 0

    def message(self) -> Any:
        """The next message (what has come is read at once: many flushes of a node that is
        ahead, in one read).

        Raises:
            EOFError: the pipe was closed (before a whole message).
        """
        while True:
            buf, pos = self.buf, self.pos
            if len(buf) - pos >= _LENGTH.size:
                (n,) = _LENGTH.unpack_from(buf, pos)
                end = pos + _LENGTH.size + n
                if len(buf) >= end:
                    obj = pickle.loads(bytes(buf[pos + _LENGTH.size : end]))
                    self.pos = end
                    return obj
            if pos:
                del buf[:pos]
                self.pos = 0
            data = os.read(self.fd, 1 << 20)
            if not data:
                raise EOFError
            buf += data


def _serve_one(inp: _Reader, out: IO[bytes], head: tuple[str, tuple[Any, ...]]) -> bool:
    """One recording, from its ``open`` call to ``finish``/``abandon`` (answered on ``out``);
    False when the node's process went away first (its ``.part`` kept)."""
    path, db, time_base, node, attachments, metadata, cwd = head[1]
    error: str | None = None
    output: LogOutput | None = None
    t_s = math.nan  # the node's clock at the latest flush
    try:
        if cwd is not None:
            os.chdir(cwd)  # the node's: a relative path is the node's file
        output = LogOutput([McapSink(path)], db, time_base, node, attachments, metadata)
    except Exception as exc:  # noqa: BLE001 - reported at the end of the recording
        error = f"{path}: {type(exc).__name__}: {exc}"
    while True:
        try:
            name, args = inp.message()
        except EOFError:  # the node's process ended: write what came, keep the .part
            if output is not None and error is None:
                with contextlib.suppress(Exception):
                    output.rows(b"", {})
            if output is not None:
                output.abandon()
            return False
        if name in ("finish", "abandon"):
            reply = _end_one(output, error, path, args if name == "finish" else None)
            pickle.dump(reply, out, pickle.HIGHEST_PROTOCOL)
            out.flush()
            return True
        if error is not None or output is None:
            continue
        try:
            if name == "flush":
                t_s, frames, rows = args
                _flush(output, frames, rows)
            else:
                getattr(output, name)(*args)
        except Exception as exc:  # noqa: BLE001 - reported at the end of the recording
            error = (
                f"{path}: recording stopped at t = {t_s:.3f} s: {type(exc).__name__}: {exc}; "
                f"what was written is in {path}.part"
            )


def _end_one(
    output: LogOutput | None, error: str | None, path: Path, finish: tuple[Any, ...] | None
) -> str | None:
    """The file finished (``finish``: :meth:`LogOutput.finish`'s arguments, where nothing
    failed before) or kept as ``.part``; the failure's text (None: finished)."""
    if output is None:
        return error
    if error is None and finish is not None:
        try:
            output.finish(*finish)
        except (CanLogError, OSError) as exc:
            output.abandon()
            return f"{path}: cannot finish the recording: {exc}"
        return None
    output.abandon()
    return error


def _flush(
    output: LogOutput,
    frames: tuple[bytes, ...] | None,
    rows: tuple[bytes, Mapping[str, Sequence[float]]] | None,
) -> None:
    """:meth:`ecu.buslog.process.remote.RemoteOutput.flush`'s calls on ``output``."""
    if frames is not None:
        output.frames(FrameBatch.from_columns(*frames))
    if rows is not None:
        output.rows(*rows)
    output.end_chunk()


def serve(inp: int, out: IO[bytes]) -> None:
    """The writer process: recordings one after the other until the file descriptor ``inp``
    closes; answers on ``out``."""
    reader = _Reader(inp)
    while True:
        try:
            head = reader.message()
        except EOFError:
            return
        if not _serve_one(reader, out, head):
            return


if __name__ == "__main__":
    # the node's process decides when to stop (its pipe closes): a Ctrl-C, or a service's
    # stop (systemd's SIGTERM to every process of the unit), must not lose the recording
    for sig in ("SIGINT", "SIGTERM", "SIGHUP"):
        if hasattr(signal, sig):
            signal.signal(getattr(signal, sig), signal.SIG_IGN)
    sys.stdout.buffer.write(READY)  # imported: ready for a recording
    sys.stdout.buffer.flush()
    serve(sys.stdin.fileno(), sys.stdout.buffer)
