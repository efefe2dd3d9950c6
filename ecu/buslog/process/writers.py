"""The pool of the recorder's writer processes (:mod:`ecu.buslog.process.remote` sends them
recordings; :mod:`ecu.buslog.process.serve` is their side): started, made ready, kept idle
between recordings, ended and reaped. Opt-in (``PACC_RECORDER_PROCESS``,
:data:`ecu.buslog.recording.PROCESS_ENV`).

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
"""

from __future__ import annotations

import atexit
import contextlib
import logging
import os
import select
import subprocess
import sys
import threading
import time
from pathlib import Path

from ecu.buslog.process.serve import READY

__all__ = ["end_writer", "give_back", "ready_writer", "start_writer"]

log = logging.getLogger(__name__)

#: the writer's pipe, bytes (Linux's default cap for an unprivileged process): a cold
#: writer (importing numpy) lets the node write this much before it waits
PIPE_BYTES = 1 << 20
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
    root = str(Path(__file__).resolve().parents[2])  # ecu/buslog/process/writers.py -> ecu's folder
    path = [root, *(str(Path(p).absolute()) for p in sys.path if p)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(dict.fromkeys(path))}
    proc = subprocess.Popen(
        [sys.executable, "-P", "-m", "ecu.buslog.process.serve"],
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
                        end_writer(proc, kill=True)
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
            end_writer(proc)


def _started(proc: subprocess.Popen[bytes]) -> bool:
    """The writer said it is ready (one byte on its stdout after its imports)."""
    if proc.pid in _ready:
        return True
    assert proc.stdout is not None
    if select.select([proc.stdout], [], [], 0)[0] and proc.stdout.read(1) == READY:
        _ready.add(proc.pid)
        return True
    return False


def end_writer(proc: subprocess.Popen[bytes], timeout_s: float = 10.0, kill: bool = False) -> None:
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
        end_writer(proc, kill=True)


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


def give_back(proc: subprocess.Popen[bytes]) -> None:
    """Put ``proc``, a writer whose recording is over (or never began), back in the pool."""
    with _lock:
        _idle.append(proc)
