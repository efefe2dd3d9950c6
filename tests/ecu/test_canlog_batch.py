"""The recorder's batch paths against independent peers: the raw block read from the tapped
frames at once (vs python-can's own attributes), protobuf rows formatted into MCAP records (vs
a row-by-row encoder, the protobuf runtime and mcap's reader), frames copied for a sender that
reuses its message."""

from __future__ import annotations

import io
import math
import struct
from pathlib import Path

import can
import numpy as np
import pytest

from dbc.codec import load_codec
from dbc.frame import raw_of
from ecu.buslog.blocks import decode_block
from ecu.buslog.decoded import FrameBatch, cycle_tables
from ecu.buslog.format import TimeBase, frame_flags
from ecu.buslog.mcapfile import RECORD_HEAD, McapFile
from ecu.buslog.proto import ProtoRows
from ecu.buslog.reader import read_canlog
from ecu.buslog.writer import CanLogWriter
from tests.ecu.test_canlog import _frames


def _odd_frames() -> list[tuple[float, can.Message, bool]]:
    """Frames of every kind the flags name: FD with BRS/ESI, a classic frame with BRS set
    (ignored), extended, error, remote; a DLC beyond the data."""
    return [
        (0.0, can.Message(arbitration_id=0x10, data=b"\x01\x02", is_extended_id=False), True),
        (0.1, can.Message(arbitration_id=0x1ABCDEF, data=bytes(8)), False),
        (
            0.2,
            can.Message(
                arbitration_id=0x22,
                data=bytes(range(12)),
                is_fd=True,
                bitrate_switch=True,
                error_state_indicator=True,
                is_extended_id=False,
            ),
            True,
        ),
        (
            0.3,
            can.Message(
                arbitration_id=0x23, data=b"\x05", bitrate_switch=True, is_extended_id=False
            ),
            False,
        ),
        (0.4, can.Message(is_error_frame=True, arbitration_id=0, data=b""), True),
        (
            0.5,
            can.Message(arbitration_id=0x120, is_remote_frame=True, dlc=8, is_extended_id=False),
            False,
        ),
    ]


@pytest.mark.parametrize("odd", [False, True])
def test_the_raw_block_of_tapped_frames_holds_their_fields(odd: bool) -> None:
    frames = _frames(300, seed=7)
    if not odd:  # only plain frames: the batch takes its flags without a per-frame look
        frames = [f for f in frames if not (f[1].is_error_frame or f[1].is_remote_frame)]
    else:
        frames = frames + _odd_frames()
    batch = FrameBatch.of([x for t, m, rx in frames for x in (t, *raw_of(m)[1:], rx)])
    cols = decode_block(batch.block())
    assert cols["t_s"].tolist() == [t for t, _, _ in frames]
    assert cols["id"].tolist() == [m.arbitration_id for _, m, _ in frames]
    assert cols["dlc"].tolist() == [m.dlc for _, m, _ in frames]
    assert cols["flags"].tolist() == [
        frame_flags(m, rx)
        if m.is_fd or m.is_error_frame or m.is_remote_frame
        # a classic frame: extended and received only (BRS/ESI mean nothing there)
        else frame_flags(can.Message(is_extended_id=m.is_extended_id), rx)
        for _, m, rx in frames
    ]
    assert cols["data"].tobytes() == b"".join(bytes(m.data) for _, m, _ in frames)
    assert cols["len"].tolist() == [len(m.data) for _, m, _ in frames]


def _protobuf_row(values: list[float], integral: list[bool]) -> bytes:
    """One row encoded field by field (the protobuf wire format, written out here)."""
    out = b""
    for number, (v, is_int) in enumerate(zip(values, integral, strict=True), start=1):
        key = (number << 3) | 1
        tag = bytes([key]) if key < 0x80 else bytes([(key & 0x7F) | 0x80, key >> 7])
        if is_int:
            out += tag + struct.pack("<q", int(v) if np.isfinite(v) else 0)
        else:
            out += tag + struct.pack("<d", v)
    return out


@pytest.mark.parametrize("width", [1, 6, 15, 16, 23])
def test_rows_format_as_protobuf_written_field_by_field(width: int) -> None:
    rng = np.random.default_rng(width)
    integral = [bool(i % 3 == 1) for i in range(width)]
    table = rng.normal(0, 1e3, (40, width))
    table[:, integral] = np.round(table[:, integral])
    table[3, :] = np.nan
    table[4, :] = np.inf
    rows = ProtoRows("pacc.Test", [f"f{i}" for i in range(width)], integral)
    want = [_protobuf_row(list(r), integral) for r in table]
    assert rows.format_into(table).tobytes() == b"".join(want)
    into = rows.format_into(table, head=5)
    assert into[:, 5:].tobytes() == b"".join(want)


def test_rows_decode_with_the_protobuf_runtime() -> None:
    pytest.importorskip("google.protobuf")
    from google.protobuf import (  # type: ignore[import-untyped]  # noqa: PLC0415
        descriptor_pb2,
        descriptor_pool,
    )
    from google.protobuf.message_factory import (  # type: ignore[import-untyped]  # noqa: PLC0415
        GetMessageClass,
    )

    integral = [i % 4 == 0 for i in range(21)]
    rows = ProtoRows("pacc.Wide", [f"x{i}" for i in range(21)], integral)
    table = np.arange(21 * 3, dtype=np.float64).reshape(3, 21) * 1.5
    table[:, integral] = np.round(table[:, integral])
    fds = descriptor_pb2.FileDescriptorSet.FromString(rows.descriptor())
    pool = descriptor_pool.DescriptorPool()
    for f in fds.file:
        pool.Add(f)
    cls = GetMessageClass(pool.FindMessageTypeByName("pacc.Wide"))
    for payload, row in zip(rows.format_into(table), table, strict=True):
        msg = cls.FromString(payload.tobytes())
        assert [getattr(msg, f"x{j}") for j in range(21)] == row.tolist()
        # the runtime's own bytes leave out the zero fields (proto3): other bytes, same values
        again = cls.FromString(msg.SerializeToString())
        assert [getattr(again, f"x{j}") for j in range(21)] == row.tolist()


def test_records_formatted_in_place_read_back_through_mcaps_reader() -> None:
    from mcap.reader import make_reader  # noqa: PLC0415

    rows = ProtoRows("pacc.R", ["t_s", "a", "n"], [False, False, True])
    table = np.array([[0.5, 1.25, 3.0], [0.75, -2.0, 4.0], [1.0, np.nan, 5.0]])
    t_ns = np.array([10, 20, 30], dtype=np.int64)
    stream = io.BytesIO()
    f = McapFile(stream, profile="p", library="l")
    ch = f.channel("/r", "protobuf", f.schema("pacc.R", "protobuf", rows.descriptor()))
    f.write_one(ch, 0, 5, b"one message first")
    f.records(ch, 1, t_ns, rows.format_into(table, RECORD_HEAD))
    f.finish()
    stream.seek(0)
    got = [(m.sequence, m.log_time, m.data) for _, _, m in make_reader(stream).iter_messages()]
    want = [_protobuf_row(list(r), [False, False, True]) for r in table]
    assert got == [(0, 5, b"one message first"), *zip([1, 2, 3], t_ns.tolist(), want, strict=True)]


def test_cycle_tables_keep_every_value_in_column_order() -> None:
    cycles = [(0.02 * k, k, (1.5 * k, True, 3), (k % 2 == 0, -0.5, math.nan)) for k in range(5)]
    packed = [struct.pack("<8d", t, k, *ins, *outs) for t, k, ins, outs in cycles]
    t, inputs, outputs = cycle_tables(b"".join(packed), 4, 8)
    assert t.tolist() == [c[0] for c in cycles]
    assert inputs.tolist() == [[c[0], *map(float, c[2])] for c in cycles]
    np.testing.assert_array_equal(
        outputs, np.array([[c[0], float(c[1]), *map(float, c[3])] for c in cycles])
    )


def test_a_copied_frame_is_recorded_as_it_was_when_tapped(tmp_path: Path) -> None:
    """A sender that reuses its message (the simulator off the lockstep bus) taps a copy."""
    path = tmp_path / "reuse.mcap"
    w = CanLogWriter(path, load_codec().db, TimeBase(0, 0.0), node="test")
    msg = can.Message(arbitration_id=0x123, data=bytes(8), is_extended_id=False)
    for i in range(5):
        msg.data[0] = i
        w.frame_and_tick(0.1 * i, msg, False)
    msg.data[0] = 99
    w.close()
    assert [d[0] for d in read_canlog(path).frames.data] == [0, 1, 2, 3, 4]
