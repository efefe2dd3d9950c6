"""Turning a recording killed mid-run (``FILE.mcap.part``) into a complete MCAP file.

``pacc export x.mcap.part x.mcap`` (:mod:`pacc.commands.export`): every record up to the last
complete chunk (schemas, channels, messages, attachments, metadata) is copied into a new
file that has its summary and footer, so every MCAP tool (Foxglove, ``mcap info``, the
indexed readers) opens it. The copy is written as ``.dst.repairing`` and renamed when complete.
"""

from __future__ import annotations

import contextlib
import os
import struct
from pathlib import Path

from dbc.vocab.mcap_errors import mcap_errors
from ecu.buslog.format import CanLogError
from ecu.buslog.mcapfile import McapFile

__all__ = ["repair"]


def repair(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> int:
    """Copy what is readable of the recording ``src`` into the complete file ``dst``; the
    number of frames it holds.

    Raises:
        CanLogError: ``src`` is missing, not MCAP, or ``dst`` cannot be written.
    """
    from mcap import records  # noqa: PLC0415 - mcap only when a file is repaired
    from mcap.exceptions import McapError  # noqa: PLC0415
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    from ecu.buslog.reader import read_canlog  # noqa: PLC0415 - reader imports this room

    src, dst = Path(src), Path(dst)
    tmp = dst.with_name(f".{dst.name}.repairing")  # not dst.part: that may be src
    try:
        out_stream = tmp.open("wb")
    except OSError as exc:
        raise CanLogError(f"{dst}: cannot write: {exc.strerror}") from None
    try:
        with mcap_errors(src, "recording", CanLogError), src.open("rb") as stream, out_stream:
            reader = StreamReader(stream, validate_crcs=True)
            out: McapFile | None = None
            schemas: dict[int, int] = {}
            channels: dict[int, int] = {}
            seqs: dict[int, int] = {}
            with contextlib.suppress(McapError, struct.error, ValueError):
                for rec in reader.records:
                    if isinstance(rec, records.Header):
                        out = McapFile(out_stream, profile=rec.profile, library=rec.library)
                    elif out is None:
                        continue
                    elif isinstance(rec, records.Schema):
                        schemas[rec.id] = out.schema(rec.name, rec.encoding, bytes(rec.data))
                    elif isinstance(rec, records.Channel):
                        sid = schemas.get(rec.schema_id, 0)
                        meta = dict(rec.metadata)
                        channels[rec.id] = out.channel(rec.topic, rec.message_encoding, sid, meta)
                    elif isinstance(rec, records.Message) and rec.channel_id in channels:
                        ch = channels[rec.channel_id]
                        out.message(ch, seqs.get(ch, 0), rec.log_time, bytes(rec.data))
                        seqs[ch] = seqs.get(ch, 0) + 1
                    elif isinstance(rec, records.Attachment):
                        data = bytes(rec.data)
                        out.attachment(rec.log_time, rec.name, rec.media_type, data)
                    elif isinstance(rec, records.Metadata):
                        out.metadata(rec.name, dict(rec.metadata))
            if out is None:
                raise CanLogError(f"{src}: not an MCAP file (no header)")
            out.finish()
        tmp.replace(dst)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return len(read_canlog(dst).frames)
