"""Atomic file writes: whole or not at all, for every file pacc writes in one piece.

The bytes go to a hidden temporary file beside the target (``.NAME.<hex>.part``), renamed over
the target once complete: a reader or a crash sees the old file or the new one, never a part.
If anything fails (the writer raises, a full disk, a read-only folder) the temporary file is
removed, the target is left as it was and the exception (OSError from the file system) goes
to the caller, which names it in its own error. ``durable=True`` (the cloud's store, the
vehicle's spool) also makes missing folders and fsyncs the file and its folder.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO


def fsync_dir(path: Path) -> None:
    """Flush the folder ``path`` (its entries: a rename or a new file in it) to the disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_writer(path: str | os.PathLike[str], *, durable: bool = False) -> Iterator[BinaryIO]:
    """A binary stream whose bytes replace ``path`` when the block ends without an exception."""
    path = Path(path)
    if durable and not path.parent.is_dir():
        path.parent.mkdir(parents=True, exist_ok=True)
        fsync_dir(path.parent.parent)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.part")
    try:
        with tmp.open("wb") as stream:
            yield stream
            if durable:
                stream.flush()
                os.fsync(stream.fileno())
        tmp.replace(path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
        raise
    if durable:
        fsync_dir(path.parent)


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes, *, durable: bool = False) -> None:
    """``data`` as the whole of ``path`` (:func:`atomic_writer`)."""
    with atomic_writer(path, durable=durable) as stream:
        stream.write(data)
