"""pacc bus recordings as a python-can log format: ``.mcap`` for ``can.LogReader``/``can.Logger``.

Registered through python-can's plugin entry points (``can.io.message_reader`` and
``can.io.message_writer``, key ``.mcap``; see pyproject.toml), so once pacc is installed
python-can's own tools read and write pacc recordings::

    python -m can.logconvert drive.mcap drive.blf      # or: pacc export drive.mcap drive.blf
    python -m can.player drive.mcap -i virtual -c x
    python -m can.logger -i socketcan -c vcan0 -f bus.mcap
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import can
from can.io.generic import MessageReader, MessageWriter

from dbc import DBC_PATH
from ecu.buslog.format import FLUSH_S, CanLogError, TimeBase
from ecu.buslog.reader import messages, read_canlog
from ecu.buslog.recording import DBC_ATTACHMENT
from ecu.buslog.writer import CanLogWriter


class McapReader(MessageReader):
    """python-can reader of a pacc bus recording (the frames of ``/can/raw``)."""

    def __init__(self, file: Any, **kwargs: Any) -> None:  # noqa: ARG002 - python-can's API
        if not isinstance(file, str | Path):
            raise CanLogError("a pacc recording is read from a path, not an open file")
        self._log = read_canlog(file)

    def __iter__(self) -> Iterator[can.Message]:
        return messages(self._log)

    def stop(self) -> None:
        """Nothing to release: the file was read whole."""


class McapWriter(MessageWriter):
    """python-can writer of a pacc bus recording to the ``.mcap`` path ``file``, decoded by ``dbc``
    (default: the packaged network), flushed every ``flush_s`` s of message time."""

    def __init__(
        self, file: Any, dbc: str | None = None, flush_s: float = FLUSH_S, **kwargs: Any
    ) -> None:  # noqa: ARG002
        if not isinstance(file, str | Path):
            raise CanLogError("a pacc recording is written to a path, not an open file")
        import cantools  # noqa: PLC0415 - only a writer with decoded channels needs it

        dbc_path = Path(dbc) if dbc else DBC_PATH
        try:
            db = cantools.database.load_file(str(dbc_path), database_format="dbc", strict=False)
            dbc_bytes = dbc_path.read_bytes()
        except Exception as exc:  # noqa: BLE001 - cantools raises many kinds
            raise CanLogError(f"cannot load DBC {dbc_path}: {exc}") from exc
        self._writer = CanLogWriter(
            file,
            db,
            TimeBase(0, 0.0),  # the messages' timestamps are seconds since the epoch
            node="export",
            attachments={DBC_ATTACHMENT: dbc_bytes},
            flush_s=flush_s,
        )

    def on_message_received(self, msg: can.Message) -> None:
        # copied: a listener's caller may reuse its message
        self._writer.frame_and_tick(msg.timestamp, msg, bool(msg.is_rx))

    def stop(self) -> None:
        self._writer.close()
