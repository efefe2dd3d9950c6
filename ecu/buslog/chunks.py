"""MCAP chunks compressed and written off the recording node's thread.

zstd, zlib's CRC and the file write release the GIL, so a chunk handed to a thread costs the
node's thread only the hand-over while another core compresses it. Each time the thread takes
the GIL back it may wait up to the interpreter's switch interval (5 ms) for a busy node's
thread to let go, and the node's thread waits while the writer holds it; so only the big
chunks (the decoded rows and cycles, every ``rows_s``: about 450 kB each in a drive, 1-2 ms of
zstd) go to the thread (:data:`BACKGROUND_MIN`), and the small ones (a 1-s raw block) are
compressed by the caller and written by it too, or queued behind a big one still being
written (the file's order is the order of the chunks). The thread starts when a chunk is
handed over and ends when none is left: nothing lingers, and an interpreter exiting waits
for the chunks already handed over.
"""

from __future__ import annotations

import threading
import zlib
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

__all__ = ["BACKGROUND_MIN", "Chunk", "ChunkWriter", "pack", "zstd_compressor"]

#: a chunk of at least this many uncompressed bytes is compressed on the writer thread
BACKGROUND_MIN = 64 * 1024


@dataclass(slots=True)
class Chunk:
    """One MCAP chunk: its message records (uncompressed), their log time range (ns), each
    channel's message index entries (``<u8`` pairs: log time, offset in ``data``), and once
    packed the zstd bytes and the CRC-32 of ``data``."""

    data: bytes
    start_ns: int
    end_ns: int
    index: dict[int, list[bytes]]
    packed: bytes | None = None
    crc: int = 0


def zstd_compressor() -> Any:
    """A zstd compressor at level 1 (one per thread: a compressor is not thread-safe)."""
    import zstandard  # noqa: PLC0415 - mcap's own dependency, loaded when a file is written

    return zstandard.ZstdCompressor(level=1)


def pack(chunk: Chunk, compressor: Any) -> None:
    """Compress ``chunk`` (``compressor``: a ``zstandard.ZstdCompressor``) and take its CRC."""
    chunk.packed = compressor.compress(chunk.data)
    chunk.crc = zlib.crc32(chunk.data)


class ChunkWriter:
    """Writes the chunks handed to it, in order, by calling ``write`` (a list of packed
    chunks) on a thread of its own, which packs those not packed yet (module docstring).

    ``write`` is never called by two threads at once: the caller writes itself only when
    :meth:`idle`, and waits (:meth:`wait`) before anything else touches the file.
    """

    def __init__(self, write: Callable[[list[Chunk]], None]) -> None:
        self._write = write
        self._cond = threading.Condition()
        self._queue: deque[Chunk] = deque()
        self._running = False
        self._zstd: Any = None
        #: the first write that failed (raised by :meth:`wait` and :meth:`check`)
        self.error: Exception | None = None

    def idle(self) -> bool:
        """No chunk handed over is still being written."""
        return not self._running

    def put(self, chunk: Chunk) -> None:
        """Hand ``chunk`` over (written after the ones before it).

        Raises:
            Exception: an earlier background write failed (:meth:`check`).
        """
        self.check()
        with self._cond:
            self._queue.append(chunk)
            if self._running:
                return
            self._running = True
        threading.Thread(target=self._run, name="pacc-mcap-chunks").start()

    def wait(self) -> None:
        """Return when every chunk handed over is written (or failed).

        Raises:
            Exception: a background write failed (:meth:`check`).
        """
        with self._cond:
            while self._running:
                self._cond.wait()
        self.check()

    def check(self) -> None:
        """Raise the error of a failed background write, if any (every call: after a failed
        write the file is not written further)."""
        if self.error is not None:
            raise self.error

    def _run(self) -> None:
        while True:
            with self._cond:
                if not self._queue or self.error is not None:
                    self._queue.clear()
                    self._running = False
                    self._cond.notify_all()
                    return
                chunks = list(self._queue)
                self._queue.clear()
            try:
                for chunk in chunks:
                    if chunk.packed is None:
                        if self._zstd is None:
                            self._zstd = zstd_compressor()
                        pack(chunk, self._zstd)
                self._write(chunks)
            except Exception as exc:  # noqa: BLE001 - handed to the caller's thread
                self.error = exc
