"""Turning a recording killed mid-run (``FILE.mcap.part``) into a complete MCAP file.

``pacc export x.mcap.part x.mcap`` (:mod:`pacc.commands.export`): every record up to the last
complete chunk (schemas, channels, messages, attachments, metadata) is copied into a new
file that has its summary and footer, so every MCAP tool (Foxglove, ``mcap info``, the
indexed readers) opens it. The copy is written atomically (:mod:`dbc.atomic`).
"""

from __future__ import annotations

import os
from pathlib import Path

from dbc.atomic import atomic_writer
from ecu.buslog.format import CanLogError
from ecu.buslog.mcapfile import McapFile
from ecu.buslog.reader import mcap_records, read_canlog


def repair(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> int:
    """Copy what is readable of the recording ``src`` into the complete file ``dst``; the number
    of frames it holds (CanLogError: ``src`` missing or not MCAP, ``dst`` unwritable)."""
    from mcap import records  # noqa: PLC0415 - mcap only when a file is repaired

    src, dst = Path(src), Path(dst)
    got, _ = mcap_records(src, recover=True)
    if not got or not isinstance(got[0], records.Header):
        raise CanLogError(f"{src}: not an MCAP file (no header)")
    try:
        with atomic_writer(dst) as stream:  # a hidden temporary name, never src's dst.part
            out = McapFile(stream, profile=got[0].profile, library=got[0].library)
            schemas: dict[int, int] = {}
            channels: dict[int, int] = {}
            seqs: dict[int, int] = {}
            for rec in got:
                if isinstance(rec, records.Schema):
                    schemas[rec.id] = out.schema(rec.name, rec.encoding, bytes(rec.data))
                elif isinstance(rec, records.Channel):
                    sid = schemas.get(rec.schema_id, 0)
                    meta = dict(rec.metadata)
                    channels[rec.id] = out.channel(rec.topic, rec.message_encoding, sid, meta)
                elif isinstance(rec, records.Message) and rec.channel_id in channels:
                    ch = channels[rec.channel_id]
                    out.write_one(ch, seqs.get(ch, 0), rec.log_time, bytes(rec.data))
                    seqs[ch] = seqs.get(ch, 0) + 1
                elif isinstance(rec, records.Attachment):
                    out.attach(rec.log_time, rec.name, rec.media_type, bytes(rec.data))
                elif isinstance(rec, records.Metadata):
                    out.metadata(rec.name, dict(rec.metadata))
            out.finish()
    except OSError as exc:
        raise CanLogError(f"{dst}: cannot write: {exc.strerror or exc}") from None
    return len(read_canlog(dst).frames)
