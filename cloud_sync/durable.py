"""Durable files: what the cloud's store and the vehicle's spool need to survive a crash.

A file is made durable by writing it under a temporary name, fsyncing it, renaming it into place
and fsyncing the folder (:func:`fsync_dir`): after a crash at any instant it is whole under its
final name or absent.
"""

from __future__ import annotations

import os
from pathlib import Path


def fsync_dir(path: Path) -> None:
    """Flush the folder ``path`` (its entries: a rename or a new file in it) to the disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


__all__ = ["fsync_dir"]
