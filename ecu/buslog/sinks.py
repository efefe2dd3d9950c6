"""Where a recording goes: the sink interface, and the MCAP file sink.

The recorder (:class:`ecu.buslog.writer.CanLogWriter`) turns what a node feeds it into
channels of messages once, and hands them to every sink: :class:`McapSink` writes the
recording file, :class:`ecu.buslog.live.FoxgloveSink` streams the same channels to Foxglove
over a WebSocket. A sink sees, per channel, batches of messages (log times in ns since the
epoch, the payloads joined, their lengths).
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from ecu.buslog.format import FORMAT, CanLogError
from ecu.buslog.mcapfile import RECORD_HEAD, McapFile
from ecu.buslog.proto import LAYOUT_KEY, ProtoRows


@dataclass(frozen=True)
class ChannelSpec:
    """One channel of a recording: its topic, schema and message encoding."""

    topic: str
    schema_name: str
    #: ``protobuf`` (a FileDescriptorSet) or ``jsonschema``
    schema_encoding: str
    schema_data: bytes
    #: ``protobuf`` or ``json``
    message_encoding: str
    metadata: Mapping[str, str] = field(default_factory=dict)


class Sink(Protocol):
    """What the recorder writes to."""

    def declare(self, spec: ChannelSpec) -> int:
        """Declare a channel; the sink's handle of it."""

    def write_one(self, handle: int, seq: int, log_time: int, data: bytes) -> None:
        """One message of one channel: log time (ns), sequence number, its data."""

    def write_rows(
        self, handle: int, seq0: int, log_times: np.ndarray, rows: ProtoRows, table: np.ndarray
    ) -> None:
        """Messages of one channel: the rows of ``table`` as ``rows`` formats them
        (:meth:`ProtoRows.format_into`), log times (ns, int64), sequence numbers from
        ``seq0``."""

    def attach(self, log_time: int, name: str, media_type: str, data: bytes) -> None:
        """A file stored with the recording."""

    def metadata(self, name: str, values: Mapping[str, str]) -> None:
        """A metadata record."""

    def flush(self) -> None:
        """Make what was written so far durable (a file: end the chunk)."""

    def close(self, complete: bool) -> None:
        """Finish (``complete``: the recording ended normally; else keep what was written)."""


class McapSink(McapFile):
    """The recording file: ``path.part`` while written, renamed ``path`` when complete
    (CanLogError: ``path`` is a directory or cannot be created)."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self.tmp = self.path.with_name(self.path.name + ".part")
        if self.path.is_dir():
            raise CanLogError(f"{self.path}: is a directory, not a recording file")
        try:
            stream = self.tmp.open("wb")
        except OSError as exc:
            raise CanLogError(f"{self.path}: cannot write the recording: {exc.strerror}") from None
        super().__init__(stream, profile=FORMAT, library="pacc.ecu.buslog")

    def declare(self, spec: ChannelSpec) -> int:
        sid = self.schema(spec.schema_name, spec.schema_encoding, spec.schema_data)
        return self.channel(spec.topic, spec.message_encoding, sid, dict(spec.metadata))

    def write_rows(
        self, handle: int, seq0: int, log_times: np.ndarray, rows: ProtoRows, table: np.ndarray
    ) -> None:
        """The rows formatted in place after room for their record headers (one array)."""
        self.records(handle, seq0, log_times, rows.format_into(table, RECORD_HEAD))

    def close(self, complete: bool) -> None:
        """Finish the file and rename it (``complete``), else end the chunk and keep the ``.part``
        (readable up to its last chunk); CanLogError: the file cannot be finished."""
        if not complete:
            with contextlib.suppress(Exception):
                self.flush()
            with contextlib.suppress(Exception):
                self._stream.close()
            return
        try:
            self.finish()
            self._stream.close()
            self.tmp.replace(self.path)
        except OSError as exc:
            with contextlib.suppress(OSError):
                self._stream.close()
            raise CanLogError(f"{self.path}: cannot finish the recording: {exc}") from exc


def close_all(sinks: Sequence[Sink]) -> None:
    """Close every sink as complete, whichever fails; raise the first CanLogError."""
    failed: CanLogError | None = None
    for sink in sinks:
        try:
            sink.close(complete=True)
        except CanLogError as exc:
            failed = failed or exc
    if failed is not None:
        raise failed


def json_spec(topic: str, schema: Mapping[str, Any]) -> ChannelSpec:
    """A channel of JSON messages of the JSON schema ``schema`` (named by its title)."""
    data = json.dumps(schema).encode()
    return ChannelSpec(topic, str(schema["title"]), "jsonschema", data, "json")


def rows_spec(topic: str, rows: ProtoRows) -> ChannelSpec:
    """A channel of the protobuf rows ``rows`` (their layout in the channel's metadata)."""
    meta = {LAYOUT_KEY: rows.layout}
    return ChannelSpec(topic, rows.full_name, "protobuf", rows.descriptor(), "protobuf", meta)


def declare(sinks: Sequence[Sink], spec: ChannelSpec) -> list[int]:
    """Declare ``spec`` on every sink; the handles, one per sink."""
    return [sink.declare(spec) for sink in sinks]
