"""A minimal MCAP writer that takes many messages of one channel at once, built with numpy."""

from __future__ import annotations

import struct
import zlib
from collections import defaultdict
from collections.abc import Mapping
from typing import IO, Any

import numpy as np

MAGIC = b"\x89MCAP0\r\n"
#: a message record's fixed part: opcode, record length, channel, sequence, log/publish time
_HEADER = np.dtype(
    [("op", "u1"), ("len", "<u8"), ("ch", "<u2"), ("seq", "<u4"), ("lt", "<u8"), ("pt", "<u8")]
)
_HEADER_BYTES = _HEADER.itemsize  # 31
#: the bytes before a message's data in its record (:meth:`McapFile.records`)
RECORD_HEAD = _HEADER_BYTES
_MESSAGE_OPCODE = 0x05
_CHUNK_OPCODE = 0x06
#: a zstd chunk record's head: opcode, record length, start/end time, uncompressed size and
#: CRC, the compression name (length-prefixed), the compressed length
_CHUNK_HEAD = struct.Struct("<BQQQQII4sQ")


def _message_index(channel_id: int, parts: list[bytes]) -> bytes:
    """A MessageIndex record: (log time, offset in the chunk) of a channel's messages
    (``parts``: the pairs as ``<u8`` bytes, in order)."""
    pairs = b"".join(parts)
    body = struct.pack("<HI", channel_id, len(pairs)) + pairs
    return struct.pack("<BQ", 0x07, len(body)) + body


class McapFile:
    """An MCAP file written to ``stream`` (open for writing at its start). Not thread-safe."""

    def __init__(self, stream: IO[bytes], profile: str, library: str) -> None:
        from mcap.records import Header  # noqa: PLC0415 - mcap only when a file is written

        self._stream = stream
        self._pos = 0
        self._schemas: list[object] = []
        self._channels: list[object] = []
        self._chunk: list[memoryview] = []
        self._chunk_size = 0
        self._chunk_t = (0, 0)
        self._zstd: Any = None
        self._index: dict[int, list[bytes]] = defaultdict(list)
        self._chunk_indexes: list[Any] = []
        self._attachment_indexes: list[object] = []
        self._metadata_indexes: list[object] = []
        self._counts: dict[int, int] = defaultdict(int)
        self._write(MAGIC)
        self._record(Header(profile=profile, library=library))

    def _write(self, data: bytes) -> None:
        self._stream.write(data)
        self._pos += len(data)

    def _record(self, record: object) -> tuple[int, int]:
        """Write one record outside chunks; (its offset, its length)."""
        from mcap.data_stream import RecordBuilder  # noqa: PLC0415

        builder = RecordBuilder()
        record.write(builder)  # type: ignore[attr-defined]
        data: bytes = builder.end()  # type: ignore[no-untyped-call]
        start = self._pos
        self._write(data)
        return start, len(data)

    def schema(self, name: str, encoding: str, data: bytes) -> int:
        """Declare a schema; its id."""
        from mcap.records import Schema  # noqa: PLC0415

        record = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(record)
        self._record(record)
        return record.id

    def channel(
        self, topic: str, encoding: str, schema_id: int, metadata: dict[str, str] | None = None
    ) -> int:
        """Declare a channel; its id."""
        from mcap.records import Channel  # noqa: PLC0415

        record = Channel(
            id=len(self._channels) + 1,
            topic=topic,
            message_encoding=encoding,
            metadata=metadata or {},
            schema_id=schema_id,
        )
        self._channels.append(record)
        self._record(record)
        return record.id

    def records(
        self, channel_id: int, seq0: int, log_times: np.ndarray, records: np.ndarray
    ) -> None:
        """Add ``n`` messages of one channel whose data are the rows of ``records`` (uint8,
        ``(n, 31 + size)``) after their first :data:`RECORD_HEAD` bytes, which this fills
        with each message record's header (``records`` becomes the records)."""
        n, size = records.shape
        if not n:
            return
        hdr = np.empty(n, dtype=_HEADER)
        hdr["op"] = _MESSAGE_OPCODE
        hdr["len"] = size - 9
        hdr["ch"] = channel_id
        hdr["seq"] = np.arange(seq0, seq0 + n, dtype=np.uint64) & 0xFFFFFFFF
        hdr["lt"] = log_times
        hdr["pt"] = log_times
        records[:, :_HEADER_BYTES] = hdr.view(np.uint8).reshape(n, _HEADER_BYTES)
        pairs = np.empty((n, 2), dtype="<u8")
        pairs[:, 0] = log_times
        pairs[:, 1] = np.arange(self._chunk_size, self._chunk_size + n * size, size)
        self._index[channel_id].append(pairs.tobytes())
        lo, hi = int(log_times.min()), int(log_times.max())
        if self._chunk:
            lo, hi = min(lo, self._chunk_t[0]), max(hi, self._chunk_t[1])
        self._chunk_t = (lo, hi)
        self._chunk.append(records.data)  # kept, not copied, until the chunk ends
        self._chunk_size += records.nbytes
        self._counts[channel_id] += n

    def write_one(self, channel_id: int, seq: int, log_time: int, data: bytes) -> None:
        """Add one message (a raw block, an event) to the open chunk."""
        record = np.empty((1, _HEADER_BYTES + len(data)), np.uint8)
        record[0, _HEADER_BYTES:] = np.frombuffer(data, np.uint8)
        self.records(channel_id, seq, np.array([log_time], np.uint64), record)

    def flush(self) -> None:
        """End the chunk in progress (if any) and flush the stream (no fsync)."""
        if self._chunk:
            self._end_chunk()
        self._stream.flush()

    def _end_chunk(self) -> None:
        """Write the open chunk (zstd) and its message indexes, in one write."""
        from mcap.records import ChunkIndex  # noqa: PLC0415

        if self._zstd is None:
            import zstandard  # noqa: PLC0415 - mcap's own dependency

            self._zstd = zstandard.ZstdCompressor(level=1)
        data = b"".join(self._chunk)
        packed = self._zstd.compress(data)
        lo, hi = self._chunk_t
        head = _CHUNK_HEAD.pack(
            _CHUNK_OPCODE,
            _CHUNK_HEAD.size - 9 + len(packed),
            lo,
            hi,
            len(data),
            zlib.crc32(data),
            4,
            b"zstd",
            len(packed),
        )
        start = self._pos
        length = len(head) + len(packed)
        parts = [head, packed]
        offsets: dict[int, int] = {}
        at = start + length
        for ch, pairs in self._index.items():
            offsets[ch] = at
            index = _message_index(ch, pairs)
            parts.append(index)
            at += len(index)
        self._write(b"".join(parts))
        self._chunk_indexes.append(
            ChunkIndex(
                message_start_time=lo,
                message_end_time=hi,
                chunk_start_offset=start,
                chunk_length=length,
                message_index_offsets=offsets,
                message_index_length=at - start - length,
                compression="zstd",
                compressed_size=len(packed),
                uncompressed_size=len(data),
            )
        )
        self._chunk, self._chunk_size, self._index = [], 0, defaultdict(list)

    def attach(self, log_time: int, name: str, media_type: str, data: bytes) -> None:
        """Write an attachment (after ending the chunk in progress)."""
        from mcap.records import Attachment, AttachmentIndex  # noqa: PLC0415

        self.flush()
        rec = Attachment(
            create_time=log_time, log_time=log_time, name=name, media_type=media_type, data=data
        )
        start, length = self._record(rec)
        self._attachment_indexes.append(
            AttachmentIndex(
                offset=start,
                length=length,
                log_time=log_time,
                create_time=log_time,
                data_size=len(data),
                name=name,
                media_type=media_type,
            )
        )

    def metadata(self, name: str, values: Mapping[str, str]) -> None:
        """Write a metadata record (after ending the chunk in progress)."""
        from mcap.records import Metadata, MetadataIndex  # noqa: PLC0415

        self.flush()
        start, length = self._record(Metadata(name=name, metadata=dict(values)))
        self._metadata_indexes.append(MetadataIndex(offset=start, length=length, name=name))

    def finish(self) -> None:
        """End the last chunk, write the summary and the footer, flush the stream."""
        from mcap.opcode import Opcode  # noqa: PLC0415
        from mcap.records import (  # noqa: PLC0415
            DataEnd,
            Footer,
            Statistics,
            SummaryOffset,
        )

        self.flush()
        self._record(DataEnd(data_section_crc=0))  # 0: not computed (chunks carry CRCs)
        summary_start = self._pos
        idx = self._chunk_indexes
        lo = min((c.message_start_time for c in idx), default=0)
        hi = max((c.message_end_time for c in idx), default=0)
        stats = Statistics(
            attachment_count=len(self._attachment_indexes),
            channel_count=len(self._channels),
            channel_message_counts=dict(self._counts),
            chunk_count=len(self._chunk_indexes),
            message_count=sum(self._counts.values()),
            message_end_time=hi,
            message_start_time=lo,
            metadata_count=len(self._metadata_indexes),
            schema_count=len(self._schemas),
        )
        groups = (
            (Opcode.SCHEMA, self._schemas),
            (Opcode.CHANNEL, self._channels),
            (Opcode.STATISTICS, [stats]),
            (Opcode.CHUNK_INDEX, self._chunk_indexes),
            (Opcode.ATTACHMENT_INDEX, self._attachment_indexes),
            (Opcode.METADATA_INDEX, self._metadata_indexes),
        )
        offsets = []
        for opcode, records in groups:
            if not records:
                continue
            group_start = self._pos
            for rec in records:
                self._record(rec)
            offsets.append(
                SummaryOffset(
                    group_opcode=opcode,
                    group_start=group_start,
                    group_length=self._pos - group_start,
                )
            )
        offset_start = self._pos
        for rec in offsets:
            self._record(rec)
        self._record(
            Footer(summary_start=summary_start, summary_offset_start=offset_start, summary_crc=0)
        )
        self._write(MAGIC)
        self._stream.flush()
