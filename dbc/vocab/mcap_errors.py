"""One mapping of what reading an MCAP file raises (EndOfFile, struct.error, zstd errors …)
to a one-line error of the reader's kind, naming the file and whether it looks truncated."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from dbc.errors import PaccError


@contextmanager
def mcap_errors(path: Path | str, what: str, error: type[PaccError]) -> Iterator[None]:
    """Inside the block, reading ``path`` (a file or a name; a ``what``, e.g. "trip log")
    raises only ``error``, one line each; an ``error`` raised inside passes unchanged."""
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
