"""The recorder's writer process: a recording's rows, compression and file off the node's thread.

Opt-in (``PACC_RECORDER_PROCESS``, :data:`ecu.buslog.recording.PROCESS_ENV`): by default every
recording is written on the node's thread. With ``1`` or ``auto``, a file-only recording
(:func:`ecu.buslog.recording.open_recording` without a live view) that gets a writer ready
for it keeps on the node's thread only what it must: the frames as tapped, each cycle packed,
and at each flush the frames' columns read (:func:`ecu.buslog.decoded.frame_columns`).
Everything else — the ``/can/raw`` block, decoding every DBC message, the protobuf rows, zstd,
the chunk CRC and the writes — runs in a writer process (:mod:`ecu.buslog.serve`):
:class:`RemoteOutput` sends it the calls of :class:`~ecu.buslog.output.LogOutput` (pickled,
over its stdin), and it runs them on a real :class:`~ecu.buslog.output.LogOutput`: the same
code (the node's own ``ecu`` package, whatever the current directory) on the same arguments,
so the file is the same byte for byte as one written on the node's thread.

- **Starting**: with ``1`` the first recording starts a writer and waits for it
  (:func:`start_writer`, about 0.2 s, at most :data:`START_TIMEOUT_S`); with ``auto`` a
  recording takes only a writer that is ready (:func:`ready_writer`) and the process's second
  recording starts one for the next. A writer that cannot be spawned, exits at start or stays
  silent puts the recording on the node's thread, and every later one of the process (one
  warning); so does a writer found dead when the recording opens.
- **One process serves a recording at a time** and is kept for the next one (the import of
  numpy, cantools and zstd is paid once per node process, not per recording); a process
  recording several at once uses the thread for those beyond the writers that are ready. Idle
  ones end when the node's process exits (their stdin closes) and are waited for, also in a
  multiprocessing pool's worker (:class:`multiprocessing.util.Finalize`); a process forked off
  the node's (a study's worker) does not inherit them.
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

import atexit
import contextlib
import logging
import os
import pickle
import select
import subprocess
import sys
import threading
import time
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ecu.buslog.decoded import floats
from ecu.buslog.format import CanLogError, TimeBase
from ecu.buslog.serve import READY, frame_message
from ecu.buslog.sinks import McapSink

__all__ = ["NotSendable", "RemoteOutput", "WriterStuck", "ready_writer", "start_writer"]

log = logging.getLogger(__name__)

#: the writer's pipe, bytes (Linux's default cap for an unprivileged process): a cold
#: writer (importing numpy) lets the node write this much before it waits
PIPE_BYTES = 1 << 20
#: the most the node keeps for a writer that does not read (stopped, on a hung disk), bytes:
#: beyond it the recording stops (:class:`WriterStuck`, reported at close)
MAX_BACKLOG_BYTES = 256 << 20
#: closing a recording waits this long for a writer that takes nothing more and does not
#: answer, s (then it is killed, and the close raises)
CLOSE_TIMEOUT_S = 30.0
#: what the writer answers at the end of a recording: None, or the failure's text
_Reply = str | None

_lock = threading.Lock()
#: writer processes with no recording: started (their pid in ``_ready``) or starting
_idle: list[subprocess.Popen[bytes]] = []
_ready: set[int] = set()
#: recordings that asked for a writer in this process
_asked = 0
#: why a writer did not start in this process (later recordings go to the node's thread at
#: once), None while none failed
_failed: str | None = None
#: :func:`_end_idle` registered with multiprocessing in this process (a pool's worker ends
#: with ``os._exit``, past ``atexit``, but runs multiprocessing's finalizers)
_finalizer = False
#: how long :func:`start_writer` waits for a writer's imports, s (about 0.2 s typical)
START_TIMEOUT_S = 5.0


def _spawn() -> subprocess.Popen[bytes]:
    """A new writer process (its stdin's pipe enlarged where the system lets it), running
    the node's own code: ``-P`` (no current directory on its path), and its ``PYTHONPATH``
    the folder of the node's ``ecu`` package, then the node's ``sys.path``."""
    global _finalizer  # noqa: PLW0603 - the process's state, as the pool is the process's
    if not _finalizer:  # the idle writers of a pool's worker are waited for too
        import multiprocessing.util  # noqa: PLC0415 - only where writers run

        multiprocessing.util.Finalize(None, _end_idle, exitpriority=0)
        _finalizer = True
    root = str(Path(__file__).resolve().parents[2])  # ecu/buslog/remote.py -> ecu's folder
    path = [root, *(str(Path(p).absolute()) for p in sys.path if p)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(dict.fromkeys(path))}
    proc = subprocess.Popen(
        [sys.executable, "-P", "-m", "ecu.buslog.serve"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        env=env,
        start_new_session=True,
    )
    assert proc.stdin is not None
    with contextlib.suppress(OSError, AttributeError, ImportError):
        import fcntl  # noqa: PLC0415 - POSIX only (the writer process is)

        fcntl.fcntl(proc.stdin.fileno(), fcntl.F_SETPIPE_SZ, PIPE_BYTES)
    return proc


def ready_writer() -> subprocess.Popen[bytes] | None:
    """An idle writer process that has started (taken out of the pool), or None: then this
    recording is written on the node's thread (a writer still importing would make the node
    wait for it). Where none is idle, from a process's second call on, one is started for the
    next recording (with ``auto`` a process that records once starts none; with ``1``
    :func:`start_writer` has started one before this call)."""
    global _asked  # noqa: PLW0603 - the process's count, as the pool is the process's
    if os.name != "posix":  # non-blocking pipes, select on a pipe
        return None
    with _lock:
        _asked += 1
        _drop_dead()
        for proc in list(_idle):
            if _started(proc):
                _idle.remove(proc)
                return proc
        if not _idle and _asked >= 2 and _failed is None:
            with contextlib.suppress(OSError):
                _idle.append(_spawn())
    return None


def start_writer(timeout_s: float | None = None) -> bool:
    """Start a writer process now, unless an idle one is alive, and wait until one is ready
    for a recording (the next file-only recording is then written by it). False, at once
    where it can tell, if none became ready in ``timeout_s`` (default
    :data:`START_TIMEOUT_S`): the writer exited, could not be spawned, or stayed silent (then
    killed). A failure is remembered: later calls in this process return False at once, and
    one warning is logged."""
    if os.name != "posix" or _failed is not None:  # non-blocking pipes, select on a pipe
        return False
    wait_s = START_TIMEOUT_S if timeout_s is None else timeout_s
    deadline = time.monotonic() + wait_s
    with _lock:
        _drop_dead()
        if not _idle:
            try:
                _idle.append(_spawn())
            except OSError as exc:
                return _give_up(f"cannot be spawned: {exc}")
        procs = list(_idle)
    while True:
        with _lock:  # the READY byte is read by one thread only
            if any(proc.poll() is None and _started(proc) for proc in procs):
                return True
            if all(proc.poll() is not None for proc in procs):
                _drop_dead()
                codes = ", ".join(str(proc.returncode) for proc in procs)
                return _give_up(f"exited at start (exit code {codes})")
            if time.monotonic() >= deadline:
                for proc in procs:
                    if proc in _idle and proc.poll() is None and not _started(proc):
                        _idle.remove(proc)
                        _end(proc, kill=True)
                return _give_up(f"was not ready after {wait_s:g} s (killed)")
        time.sleep(0.01)


def _give_up(why: str) -> bool:
    """Remember that no writer starts in this process, warn once; False."""
    global _failed  # noqa: PLW0603 - the process's state, as the pool is the process's
    if _failed is None:
        _failed = why
        log.warning("the recorder's writer process %s: recording on the node's thread", why)
    return False


def _drop_dead() -> None:
    """Reap the idle writers that exited (a stray kill, the OOM killer); under ``_lock``."""
    for proc in list(_idle):
        if proc.poll() is not None:
            _idle.remove(proc)
            _end(proc)


def _started(proc: subprocess.Popen[bytes]) -> bool:
    """The writer said it is ready (one byte on its stdout after its imports)."""
    if proc.pid in _ready:
        return True
    assert proc.stdout is not None
    if select.select([proc.stdout], [], [], 0)[0] and proc.stdout.read(1) == READY:
        _ready.add(proc.pid)
        return True
    return False


def _end(proc: subprocess.Popen[bytes], timeout_s: float = 10.0, kill: bool = False) -> None:
    """Close the writer's pipes and wait for it (killed after ``timeout_s``, or at once
    with ``kill``: an idle writer holds nothing); never raises."""
    _ready.discard(proc.pid)
    if kill:
        with contextlib.suppress(OSError):
            proc.kill()
    for pipe in (proc.stdin, proc.stdout):
        with contextlib.suppress(OSError):
            if pipe is not None:
                pipe.close()
    try:
        proc.wait(timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def _end_idle() -> None:
    """At exit: every idle writer (nothing left to write) ends and is waited for."""
    with _lock:
        procs, _idle[:] = list(_idle), []
    for proc in procs:
        _end(proc, kill=True)


def _forget_idle() -> None:
    """In a process forked off this one: the idle writers are the parent's (their pipes,
    flushed, are closed here; the parent keeps its own)."""
    global _asked, _finalizer, _lock  # noqa: PLW0603 - a new process
    _lock = threading.Lock()  # held by another thread of the parent's at the fork: not ours
    _asked = 0
    _finalizer = False  # a multiprocessing child starts with no finalizers
    for proc in _idle:
        for pipe in (proc.stdin, proc.stdout):
            with contextlib.suppress(OSError):
                if pipe is not None:
                    pipe.close()
    _idle.clear()
    _ready.clear()


atexit.register(_end_idle)
if hasattr(os, "register_at_fork"):  # POSIX only; elsewhere no writer process is started
    os.register_at_fork(after_in_child=_forget_idle)


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
    writer process ``proc`` (:func:`ready_writer`; module docstring).

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
            with _lock:
                _idle.append(proc)  # unused: back to the pool
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
            with _lock:
                _idle.append(proc)  # nothing sent: back to the pool
            raise NotSendable(f"{path}: the network cannot go to a writer process: {exc}") from exc
        try:
            self.end_chunk()
        except OSError as exc:  # the writer died since it said READY: reaped, not pooled
            _end(proc)
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
            _end(proc, kill=True)
            raise CanLogError(
                f"{self.path}: the writer process (pid {proc.pid}) did not finish the recording "
                f"(no progress for {CLOSE_TIMEOUT_S:g} s): killed; what it wrote is in "
                f"{self.path}.part"
            ) from None
        except (OSError, EOFError, pickle.UnpicklingError) as exc:
            _end(proc)
            raise CanLogError(
                f"{self.path}: the writer process ended (exit code {proc.returncode}) before "
                f"the recording was finished ({type(exc).__name__}); what it wrote is in "
                f"{self.path}.part"
            ) from None
        with _lock:
            _idle.append(proc)
        if reply is not None:
            raise CanLogError(reply)
