"""The live view: a WebSocket client of the Foxglove server receives the decoded frames in order.

The recorder streams through foxglove-sdk's real server (loopback, a free port); the client is
the ``websockets`` package speaking the Foxglove WebSocket protocol (``foxglove.sdk.v1``):
advertise, subscribe, binary message data. The payloads are the recording's protobuf rows,
decoded here with the protobuf runtime from the advertised schema and compared with cantools.
"""

from __future__ import annotations

import asyncio
import base64
import json
import struct
import threading
import time
from typing import Any

import can
import pytest

from dbc.codec import load_codec
from ecu.buslog.format import CanLogError, TimeBase
from ecu.buslog.live import FoxgloveSink, parse_address
from ecu.buslog.writer import CanLogWriter

websockets = pytest.importorskip("websockets")
descriptor_pb2 = pytest.importorskip("google.protobuf.descriptor_pb2")
N = 400
TOPIC = "/can/ESC_Speed"


async def _client(port: int, ready: threading.Event) -> tuple[dict[str, Any], list[Any]]:
    async with websockets.connect(
        f"ws://127.0.0.1:{port}",
        subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"],
        max_size=None,
    ) as ws:
        channels: dict[str, Any] = {}
        while TOPIC not in channels:
            msg = json.loads(await asyncio.wait_for(ws.recv(), 10))
            if msg["op"] == "advertise":
                channels.update({c["topic"]: c for c in msg["channels"]})
        sub = {"id": 3, "channelId": channels[TOPIC]["id"]}
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [sub]}))
        ready.set()
        got: list[Any] = []
        while len(got) < N:
            m = await asyncio.wait_for(ws.recv(), 10)
            if isinstance(m, bytes) and m[0] == 1:
                sub_id, t_ns = struct.unpack_from("<IQ", m, 1)
                got.append((sub_id, t_ns, m[13:]))
        return channels[TOPIC], got


def _message_class(channel: dict[str, Any]) -> Any:
    from google.protobuf import (  # type: ignore[import-untyped]  # noqa: PLC0415
        descriptor_pool,
        message_factory,
    )

    assert channel["encoding"] == "protobuf" and channel["schemaEncoding"] == "protobuf"
    fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for f in fds.file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


def test_a_websocket_client_receives_decoded_frames_in_order() -> None:
    codec = load_codec()
    esc = codec.db.get_message_by_name("ESC_Speed")
    sink = FoxgloveSink("127.0.0.1", 0)
    base = TimeBase(1_800_000_000 * 10**9, 0.0)
    writer = CanLogWriter(None, codec.db, base, node="test", sinks=[sink], flush_s=0.05)
    result: dict[str, Any] = {}
    ready = threading.Event()

    def run() -> None:
        result["out"] = asyncio.run(_client(sink.port, ready))

    client = threading.Thread(target=run, daemon=True)
    client.start()
    try:
        assert ready.wait(10)
        time.sleep(0.2)  # the server takes the subscription asynchronously
        frames = []
        for i in range(N):
            values: dict[str, float] = {s.name: 0 for s in esc.signals}
            values.update(AliveCounter=i % 16, SpeedValid=1, VehicleSpeed=i / 16)
            data = esc.encode(values, strict=False)
            frames.append(data)
            msg = can.Message(arbitration_id=esc.frame_id, is_extended_id=False, data=data)
            writer.frame_and_tick(i * 0.01, msg, True)
        writer.flush()
        client.join(20)
    finally:
        writer.close()
    channel, got = result["out"]
    cls = _message_class(channel)
    assert [sub for sub, _, _ in got] == [3] * N
    assert [t for _, t, _ in got] == [base.utc_ns(i * 0.01) for i in range(N)]
    for i, (_, _, payload) in enumerate(got):
        row = cls.FromString(payload)
        want = esc.decode(frames[i], decode_choices=False)
        assert row.t_s == pytest.approx(i * 0.01, abs=0)
        assert row.VehicleSpeed == want["VehicleSpeed"] and row.AliveCounter == i % 16


def test_foxglove_addresses() -> None:
    assert parse_address("127.0.0.1:9000") == ("127.0.0.1", 9000)
    assert parse_address(":0") == ("127.0.0.1", 0)
    assert parse_address("localhost") == ("localhost", 8765)
    with pytest.raises(CanLogError, match="not a number"):
        parse_address("x:y")
    with pytest.raises(CanLogError, match="0..65535"):
        parse_address("x:70000")


def test_pacc_drive_foxglove_serves_and_refuses_a_bad_address(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from pacc.commands.drive import main  # noqa: PLC0415 - an entry point, on top

    assert main(["--duration", "3", "--foxglove", "127.0.0.1:0", "--pace", "0"]) == 0
    out = capsys.readouterr().out
    assert "foxglove: live view on ws://127.0.0.1:" in out and "collisions     0" in out
    assert main(["--duration", "3", "--foxglove", "127.0.0.1:x"]) == 2
    assert "the port is not a number" in capsys.readouterr().err
