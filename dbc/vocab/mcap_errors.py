"""One mapping of what reading an MCAP file raises to a one-line error of the reader's kind.

The mcap package raises many exception types on damaged input (its own EndOfFile, struct.error,
zstd/lz4 errors, KeyError …); the trip-log and bus-recording readers both turn them into
their own error with the file's name and whether it looks truncated or foreign.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from dbc.errors import PaccError

__all__ = ["mcap_errors"]


@contextmanager
def mcap_errors(path: Path | str, what: str, error: type[PaccError]) -> Iterator[None]:
    """Inside the block, reading ``path`` (a file, or a name for bytes or a stream; a ``what``,
    e.g. "trip log") raises only ``error``:
    missing file, directory, truncated or corrupt/foreign file, each with a one-line message;
    an ``error`` raised inside passes unchanged."""
    try:
        yield
    except error:
        raise
    except FileNotFoundError:
        raise error(f"{path}: no such {what}") from None
    except IsADirectoryError:
        raise error(f"{path}: is a directory, not a {what}") from None
    except Exception as exc:  # noqa: BLE001 - mcap raises many types on corrupt input
        kind = type(exc).__name__
        reason = "truncated" if kind in ("EndOfFile", "error") else "corrupt or not MCAP"
        raise error(f"{path}: {reason} {what} ({kind}: {exc})") from exc
