"""The live view: the recorder's channels streamed to Foxglove over a WebSocket.

``pacc ecu|sim|drive --foxglove [HOST:PORT]`` (default ``127.0.0.1:8765``) starts the Foxglove
SDK's server and adds :class:`FoxgloveSink` to the recorder: the channels and messages of the
recording file, sent at each flush. A channel nobody subscribed to costs nothing; a slow
client loses the oldest messages (``message_backlog_size``), the node never waits.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ecu.buslog.format import CanLogError
from ecu.buslog.proto import ProtoRows
from ecu.buslog.sinks import ChannelSpec

#: the recorder's flush interval with a live view, s of the node's clock (the view's delay)
LIVE_FLUSH_S = 0.2
#: per-client queue of the server, messages (one flush of a busy bus fits)
BACKLOG = 50_000


def parse_address(text: str) -> tuple[str, int]:
    """``HOST:PORT``, ``:PORT`` or ``HOST`` -> (host, port); loopback and 8765 by default
    (CanLogError: a port not in 0..65535)."""
    host, sep, port = text.rpartition(":")
    if not sep:
        host, port = text, "8765"
    try:
        number = int(port)
    except ValueError:
        raise CanLogError(f"--foxglove {text!r}: the port is not a number") from None
    if not 0 <= number <= 65535:
        raise CanLogError(f"--foxglove {text!r}: the port is not in 0..65535")
    return host or "127.0.0.1", number


class FoxgloveSink:
    """A :class:`~ecu.buslog.sinks.Sink` serving the channels on a Foxglove WebSocket server on
    ``host:port`` (0: any free port, :attr:`port` says which; CanLogError if it cannot start)."""

    def __init__(self, host: str = "127.0.0.1", port: int = 8765, name: str = "pacc") -> None:
        try:
            import foxglove  # noqa: PLC0415 - the SDK only for a live view

            self._fg: Any = foxglove
            self._ctx = foxglove.Context()
            self._server: Any = foxglove.start_server(
                name=name,
                host=host,
                port=port,
                context=self._ctx,
                message_backlog_size=BACKLOG,
            )
        except Exception as exc:  # noqa: BLE001 - the SDK raises RuntimeError and others
            raise CanLogError(f"cannot start the Foxglove server on {host}:{port}: {exc}") from exc
        self.host = host
        self.port: int = self._server.port
        self._channels: list[Any] = []

    @property
    def url(self) -> str:
        """The WebSocket URL a Foxglove client connects to."""
        return f"ws://{self.host}:{self.port}"

    def declare(self, spec: ChannelSpec) -> int:
        schema = self._fg.Schema(
            name=spec.schema_name, encoding=spec.schema_encoding, data=spec.schema_data
        )
        ch = self._fg.Channel(
            spec.topic,
            schema=schema,
            message_encoding=spec.message_encoding,
            metadata=dict(spec.metadata),
            context=self._ctx,
        )
        self._channels.append(ch)
        return len(self._channels) - 1

    def write_one(self, handle: int, seq: int, log_time: int, data: bytes) -> None:
        del seq  # the SDK numbers each channel's messages itself
        ch = self._channels[handle]
        if ch.has_sinks():
            ch.log(data, log_time=log_time)

    def write_rows(
        self, handle: int, seq0: int, log_times: np.ndarray, rows: ProtoRows, table: np.ndarray
    ) -> None:
        del seq0  # the SDK numbers each channel's messages itself
        ch = self._channels[handle]
        if ch.has_sinks():
            for t, data in zip(log_times.tolist(), rows.format_into(table), strict=True):
                ch.log(data.tobytes(), log_time=t)

    def attach(self, log_time: int, name: str, media_type: str, data: bytes) -> None:
        """Attachments are for the file only."""

    def metadata(self, name: str, values: Any) -> None:
        """Metadata records are for the file only."""

    def flush(self) -> None:
        """Messages are sent as they are logged."""

    def close(self, complete: bool) -> None:
        """Stop the server (once)."""
        del complete
        channels, self._channels = self._channels, []
        for ch in channels:
            ch.close()
        server, self._server = self._server, None
        if server is not None:
            server.stop()


def live_sinks(address: str | None, say: Callable[[str], None]) -> list[FoxgloveSink]:
    """The live view of ``--foxglove ADDRESS`` (none without it); ``say`` gets its URL
    (CanLogError: a bad address, or the server cannot start)."""
    if address is None:
        return []
    host, port = parse_address(address)
    sink = FoxgloveSink(host, port)
    say(f"foxglove: live view on {sink.url} (Foxglove: Open connection, Foxglove WebSocket)")
    return [sink]
