"""The recorder's writer process: a recording's rows, compression and file off the node's thread.

Opt-in (``PACC_RECORDER_PROCESS``, :data:`ecu.buslog.recording.PROCESS_ENV`): by default every
recording is written on the node's thread. With ``1`` or ``auto``, a file-only recording
(:func:`ecu.buslog.recording.open_recording` without a live view) that gets a writer ready
for it keeps on the node's thread only what it must: the frames as tapped, each cycle packed,
and at each flush the frames' columns read (:func:`ecu.buslog.decoded.frame_columns`).
Everything else — the ``/can/raw`` block, decoding every DBC message, the protobuf rows, zstd,
the chunk CRC and the writes — runs in a writer process (:mod:`ecu.buslog.process.serve`, from
the pool of :mod:`ecu.buslog.process.writers`):
:class:`RemoteOutput` sends it the calls of :class:`~ecu.buslog.output.LogOutput` (pickled,
over its stdin), and it runs them on a real :class:`~ecu.buslog.output.LogOutput`: the same
code (the node's own ``ecu`` package, whatever the current directory) on the same arguments,
so the file is the same byte for byte as one written on the node's thread.

- **Crash safety**: each flush reaches the pipe at once. Killed, the node's process closes the
  pipe; the writer writes everything it got (more than the node's thread would have: the
  decoded rows since the last 10 s too) and leaves ``FILE.part``, as the node's thread does.
  The writer runs in its own session and ignores SIGINT, SIGTERM and SIGHUP (a Ctrl-C, a
  service's stop signalling every process of it): it ends when its node closes the pipe.
- **Errors**: a failed write (a full disk) stops the writing, and :meth:`RemoteOutput.finish`
  raises it as :class:`~ecu.buslog.format.CanLogError`; a writer process that died does
  the same, with its exit code, and is reaped. Nothing is raised on the node's thread before
  (a pipe that broke stops the recording, reported at close, like any failed write). A writer
  alive but stuck (stopped, on a hung disk) is bounded: past :data:`MAX_BACKLOG_BYTES` unsent
  the recording stops, and the close kills a writer that makes no progress for
  :data:`CLOSE_TIMEOUT_S` (CanLogError naming it; ``FILE.part`` kept).
"""

from __future__ import annotations

import contextlib
import os
import pickle
import select
import subprocess
import time
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ecu.buslog.decoded import floats
from ecu.buslog.format import CanLogError, TimeBase
from ecu.buslog.process.serve import frame_message
from ecu.buslog.process.writers import end_writer, give_back
from ecu.buslog.sinks import McapSink

__all__ = ["NotSendable", "RemoteOutput", "WriterStuck"]

#: the most the node keeps for a writer that does not read (stopped, on a hung disk), bytes:
#: beyond it the recording stops (:class:`WriterStuck`, reported at close)
MAX_BACKLOG_BYTES = 256 << 20
#: closing a recording waits this long for a writer that takes nothing more and does not
#: answer, s (then it is killed, and the close raises)
CLOSE_TIMEOUT_S = 30.0
#: what the writer answers at the end of a recording: None, or the failure's text
_Reply = str | None


class NotSendable(ValueError):
    """What a recording opens with cannot be pickled (a database object of its own), or the
    writer process ended before the recording's first message: the recording stays on the
    node's thread."""


def _cwd() -> str | None:
    """The current directory (None: it was removed)."""
    try:
        return str(Path.cwd())
    except OSError:
        return None


class WriterStuck(OSError):
    """The writer process took nothing while :data:`MAX_BACKLOG_BYTES` piled up for it:
    the recording stops (a failed write, reported at close)."""


class RemoteOutput:
    """:class:`~ecu.buslog.output.LogOutput`'s calls for the file ``path``, run in the
    writer process ``proc`` (:func:`ecu.buslog.process.writers.ready_writer`; module docstring).

    Raises:
        CanLogError: ``path`` cannot be created (checked here).
        NotSendable: the database, time base or attachments cannot be pickled, or the writer
            process is gone (a broken pipe at the first message; it is reaped).
    """

    def __init__(
        self,
        proc: subprocess.Popen[bytes],
        path: Path,
        db: Any,
        time_base: TimeBase,
        node: str,
        attachments: Mapping[str, bytes] | None = None,
        metadata: Mapping[str, Mapping[str, str]] | None = None,
    ) -> None:
        self.path = path
        try:  # the same checks and errors as on the node's thread
            McapSink(path).close(complete=False)
        except CanLogError:
            give_back(proc)  # unused: back to the pool
            raise
        self._proc = proc
        stdin = self._proc.stdin
        assert stdin is not None
        self._fd = stdin.fileno()
        os.set_blocking(self._fd, False)
        #: sent and not yet in the pipe (the writer is behind: starting, or no core free)
        self._backlog = bytearray()
        #: the backlog passed :data:`MAX_BACKLOG_BYTES` (the writer is killed at the end)
        self._stuck = False
        try:
            # the node's current directory: a relative path means the same file (a pooled
            # writer outlives any later chdir of the node), and the same error texts
            self._send("open", path, db, time_base, node, attachments, metadata, _cwd())
        except (pickle.PicklingError, TypeError, AttributeError) as exc:
            give_back(proc)  # nothing sent: back to the pool
            raise NotSendable(f"{path}: the network cannot go to a writer process: {exc}") from exc
        try:
            self.end_chunk()
        except OSError as exc:  # the writer died since it said READY: reaped, not pooled
            end_writer(proc)
            raise NotSendable(f"{path}: the writer process ended before the recording") from exc

    def _send(self, name: str, *args: Any) -> None:
        self._backlog += frame_message((name, args))

    def _push(self) -> None:
        """Put what the pipe takes of the backlog into it, without waiting.

        Raises:
            OSError: the writer process is gone (a broken pipe).
        """
        backlog = self._backlog
        while backlog:
            try:
                n = os.write(self._fd, backlog)
            except BlockingIOError:
                return
            del backlog[:n]

    def _push_all(self) -> None:
        """Put the whole backlog into the pipe, waiting for the writer where it must.

        Raises:
            TimeoutError: the writer took nothing for :data:`CLOSE_TIMEOUT_S`.
            OSError: the writer process is gone.
        """
        deadline = time.monotonic() + CLOSE_TIMEOUT_S
        while True:
            left = len(self._backlog)
            self._push()
            if not self._backlog:
                return
            if len(self._backlog) < left:
                deadline = time.monotonic() + CLOSE_TIMEOUT_S
            wait_s = deadline - time.monotonic()
            if wait_s <= 0:
                raise TimeoutError
            select.select([], [self._fd], [], min(wait_s, 1.0))

    def attach(self, name: str, data: bytes, media_type: str) -> None:
        self._send("attach", name, data, media_type)

    def series(
        self, topic: str, columns: Sequence[str], description: str, integral: Sequence[bool]
    ) -> None:
        self._send("series", topic, tuple(columns), description, tuple(integral))

    def event(self, t_s: float, text: str) -> None:
        self._send("event", t_s, text)

    def flush(
        self,
        t_s: float,
        frames: tuple[bytes, ...] | None,
        rows: tuple[bytes, Mapping[str, Sequence[float]]] | None,
    ) -> None:
        """One flush at ``t_s`` (the node's clock), handed to the writer at once (crash
        safety): the ``frames`` (:func:`~ecu.buslog.decoded.frame_columns`) as
        :meth:`LogOutput.frames <ecu.buslog.output.LogOutput.frames>`, the ``rows`` due
        (cycles, samples) as :meth:`LogOutput.rows <ecu.buslog.output.LogOutput.rows>`,
        then the chunk's end."""
        self._send("flush", t_s, frames, rows)
        self._push()
        if len(self._backlog) > MAX_BACKLOG_BYTES:
            self._stuck = True
            raise WriterStuck(
                f"the writer process (pid {self._proc.pid}) is behind by "
                f"{len(self._backlog) / (1 << 20):.1f} MiB (stopped, or on a hung disk?)"
            )

    def end_chunk(self) -> None:
        """End the chunk in the writer, and hand it what was sent so far."""
        self._send("end_chunk")
        self._push()

    def write_series(
        self, topic: str, columns: Mapping[str, Iterable[Any]], t_s: Iterable[float]
    ) -> None:
        arrays = {k: floats(v) for k, v in columns.items()}  # pickled as bytes, not floats
        self._send("write_series", topic, arrays, floats(t_s))

    def finish(self, start_utc: str) -> None:
        """Finish the file in the writer and wait for it.

        Raises:
            CanLogError: the writer failed (a write, finishing the file) or died.
        """
        self._end("finish", start_utc)

    def abandon(self) -> None:
        """Keep what was written (``path.part``); never raises."""
        with contextlib.suppress(CanLogError):
            self._end("abandon")

    def _end(self, name: str, *args: Any) -> None:
        proc = self._proc
        try:
            if self._stuck:
                raise TimeoutError
            self._send(name, *args)
            self._push_all()
            assert proc.stdout is not None
            if not select.select([proc.stdout], [], [], CLOSE_TIMEOUT_S)[0]:
                raise TimeoutError
            reply: _Reply = pickle.load(proc.stdout)
        except TimeoutError:
            end_writer(proc, kill=True)
            raise CanLogError(
                f"{self.path}: the writer process (pid {proc.pid}) did not finish the recording "
                f"(no progress for {CLOSE_TIMEOUT_S:g} s): killed; what it wrote is in "
                f"{self.path}.part"
            ) from None
        except (OSError, EOFError, pickle.UnpicklingError) as exc:
            end_writer(proc)
            raise CanLogError(
                f"{self.path}: the writer process ended (exit code {proc.returncode}) before "
                f"the recording was finished ({type(exc).__name__}); what it wrote is in "
                f"{self.path}.part"
            ) from None
        give_back(proc)
        if reply is not None:
            raise CanLogError(reply)
