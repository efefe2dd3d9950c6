"""Durable files for the cloud's store and the vehicle's spool: written under a temporary name,
fsynced, renamed into place and the folder fsynced, so after a crash a file is whole or absent.
"""

from __future__ import annotations

import os
import uuid
from pathlib import Path


def fsync_dir(path: Path) -> None:
    """Flush the folder ``path`` (its entries: a rename or a new file in it) to the disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_temp(path: Path, data: bytes) -> Path:
    """``data`` in a fsynced temporary file beside ``path`` (folders made and fsynced)."""
    if not path.parent.is_dir():
        path.parent.mkdir(parents=True, exist_ok=True)
        fsync_dir(path.parent.parent)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.part")
    try:
        with tmp.open("wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return tmp


def write_atomic(path: Path, data: bytes) -> None:
    """``data`` under ``path`` whole or not at all, durable once this returns."""
    tmp = write_temp(path, data)
    try:
        tmp.replace(path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    fsync_dir(path.parent)


def set_aside(path: Path, reason: str) -> Path:
    """Move ``path`` into ``rejected/`` beside it with a ``.reason`` file; the new path."""
    target = path.parent / "rejected"
    target.mkdir(exist_ok=True)
    (target / f"{path.name}.reason").write_text(reason + "\n", encoding="utf-8")
    path.replace(target / path.name)
    fsync_dir(path.parent)
    return target / path.name
