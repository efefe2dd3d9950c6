"""The lockstep bus (dbc.lockstep): a python-can interface with the virtual bus's semantics."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any, cast

import can
import pytest

from dbc.frame import EFF_FLAG, OTHER, message_of, port_of, raw_key
from dbc.lockstep import LockstepBus


@pytest.fixture
def pair() -> Iterator[tuple[can.BusABC, can.BusABC]]:
    a = can.Bus(interface="lockstep", channel="test-lockstep")
    b = can.Bus(interface="lockstep", channel="test-lockstep")
    try:
        yield a, b
    finally:
        a.shutdown()
        b.shutdown()


def _msg(fid: int, data: bytes, t: float) -> can.Message:
    return can.Message(arbitration_id=fid, data=data, timestamp=t, is_extended_id=False)


def test_registered_as_a_python_can_interface(pair: tuple[can.BusABC, can.BusABC]) -> None:
    assert isinstance(pair[0], LockstepBus)


def test_frames_in_order_with_the_senders_timestamps(pair: tuple[can.BusABC, can.BusABC]) -> None:
    a, b = pair
    for k in range(5):
        a.send(_msg(0x100 + k, bytes([k, 2]), 0.01 * k))
    got = [b.recv(0.0) for _ in range(5)]
    assert [(m.arbitration_id, bytes(m.data), m.timestamp) for m in got if m] == [
        (0x100 + k, bytes([k, 2]), 0.01 * k) for k in range(5)
    ]
    assert all(m is not None and m.is_rx and m.channel == "test-lockstep" for m in got)
    assert b.recv(1.0) is None  # nothing queued: at once, whatever the timeout
    assert a.recv(None) is None  # a sender does not hear itself


def test_received_message_does_not_alias_the_sent_one(
    pair: tuple[can.BusABC, can.BusABC],
) -> None:
    a, b = pair
    sent = _msg(0x10, b"\x01\x02", 1.0)
    a.send(sent)
    sent.data[0] = 0xFF  # the sender reuses its message
    sent.timestamp = 2.0
    got = b.recv()
    assert got is not None and got is not sent and got.data is not sent.data
    assert (bytes(got.data), got.timestamp) == (b"\x01\x02", 1.0)


def test_same_frames_as_the_virtual_bus() -> None:
    """Every field of every received frame equals what the virtual bus delivers."""
    out: dict[str, list[tuple[object, ...]]] = {}
    options: tuple[tuple[str, dict[str, Any]], ...] = (
        ("virtual", {"preserve_timestamps": True}),
        ("lockstep", {}),
    )
    for interface, kw in options:
        tx = can.Bus(interface=interface, channel="same-frames", **kw)
        rx = can.Bus(interface=interface, channel="same-frames", **kw)
        try:
            tx.send(_msg(0x7FF, b"\x00\x01\x02", 0.5))
            tx.send(can.Message(arbitration_id=0x1ABCDEF, data=b"\x09", is_extended_id=True))
            tx.send(can.Message(arbitration_id=0x12, is_remote_frame=True, dlc=4, timestamp=3.0))
            got = []
            while (m := rx.recv(0.0)) is not None:
                got.append(
                    tuple(getattr(m, s) for s in can.Message.__slots__ if s != "__weakref__")
                )
            out[interface] = got
        finally:
            tx.shutdown()
            rx.shutdown()
    assert len(out["lockstep"]) == 3
    assert out["lockstep"] == out["virtual"]


def test_filters_and_own_messages() -> None:
    a = can.Bus(interface="lockstep", channel="filters", receive_own_messages=True)
    b = can.Bus(
        interface="lockstep",
        channel="filters",
        can_filters=[{"can_id": 0x20, "can_mask": 0x7F0, "extended": False}],
    )
    try:
        for fid in (0x10, 0x21, 0x30, 0x2F):
            a.send(_msg(fid, b"", 0.0))
        assert [m.arbitration_id for m in iter(lambda: b.recv(0), None)] == [0x21, 0x2F]
        assert [m.arbitration_id for m in iter(lambda: a.recv(0), None)] == [0x10, 0x21, 0x30, 0x2F]
    finally:
        a.shutdown()
        b.shutdown()


def test_a_closed_bus_refuses_and_leaves_the_channel() -> None:
    a = can.Bus(interface="lockstep", channel="closing")
    b = can.Bus(interface="lockstep", channel="closing")
    b.shutdown()
    a.send(_msg(1, b"", 0.0))  # nobody listens: the frame is gone, as on a real bus
    with pytest.raises(can.CanOperationError):
        b.send(_msg(1, b"", 0.0))
    with pytest.raises(can.CanOperationError):
        b.recv(0)
    c = can.Bus(interface="lockstep", channel="closing")
    try:
        a.send(_msg(2, b"", 0.0))
        got = c.recv()
        assert got is not None and got.arbitration_id == 2
    finally:
        a.shutdown()
        c.shutdown()


def test_an_own_echo_is_not_rx_as_on_the_virtual_bus() -> None:
    for interface in ("lockstep", "virtual"):
        a = can.Bus(interface=interface, channel=f"echo-{interface}", receive_own_messages=True)
        b = can.Bus(interface=interface, channel=f"echo-{interface}")
        try:
            a.send(can.Message(arbitration_id=0x10, data=b"\x01", is_extended_id=False))
            own, other = a.recv(0.1), b.recv(0.1)
            assert own is not None and other is not None, interface
            assert (own.is_rx, other.is_rx) == (False, True), interface
        finally:
            a.shutdown()
            b.shutdown()


def test_a_port_takes_and_puts_frames_a_listener_gets_as_messages() -> None:
    """The bus as its node's port (port_of): take gives every queued frame as (timestamp, key,
    payload), frames sent as messages too, an error frame as (timestamp, OTHER, a copy); a
    frame put reaches a python-can listener as a fresh message with the same fields; a
    closed bus refuses."""
    a = can.Bus(interface="lockstep", channel="raw-1")
    b = can.Bus(interface="lockstep", channel="raw-1")
    listener = can.Bus(interface="lockstep", channel="raw-1")
    try:
        pa, pb = port_of(a), port_of(b)
        assert pa is cast(object, a) and pb is cast(object, b)  # natively: no adapter
        assert pb.take() == ()
        pa.put(0.1, raw_key(0x11, False), b"\x01\x02")
        a.send(_msg(0x12, b"\x03", 0.2))
        ext = can.Message(arbitration_id=0x1ABCDEF, is_extended_id=True, data=b"\x04")
        ext.timestamp = 0.3
        a.send(ext)
        err = can.Message(is_error_frame=True, timestamp=0.4)
        a.send(err)
        got = pb.take()
        assert got[:3] == [
            (0.1, 0x11, b"\x01\x02"),
            (0.2, 0x12, b"\x03"),
            (0.3, 0x1ABCDEF | EFF_FLAG, b"\x04"),
        ]
        assert got[3][:2] == (0.4, OTHER) and got[3][2].is_error_frame
        assert got[3][2] is not err  # a copy, as send gives
        assert pb.take() == ()
        msg = listener.recv(0)
        assert msg is not None and message_of(got[0], "raw-1").equals(msg)
        assert (msg.timestamp, msg.arbitration_id, bytes(msg.data), msg.dlc) == (
            0.1,
            0x11,
            b"\x01\x02",
            2,
        )
        assert msg.channel == "raw-1" and msg.is_rx and not msg.is_extended_id
        b.shutdown()
        with pytest.raises(can.CanOperationError):
            pb.take()
        with pytest.raises(can.CanOperationError):
            pb.put(0.5, 0x15, b"")
    finally:
        for bus in (a, b, listener):
            bus.shutdown()


def test_a_port_keeps_filters_and_a_dlc_other_than_the_length() -> None:
    """take honours receive filters; a message whose DLC python-can let differ from its
    payload's length arrives whole, as (t, OTHER, message), so its DLC is kept."""
    a = can.Bus(interface="lockstep", channel="raw-2")
    b = can.Bus(
        interface="lockstep",
        channel="raw-2",
        can_filters=[{"can_id": 0x20, "can_mask": 0x7F0, "extended": False}],
    )
    try:
        a.send(_msg(0x21, b"\x01", 0.1))  # passes the filter
        a.send(_msg(0x31, b"\x02", 0.2))  # does not
        odd = can.Message(
            arbitration_id=0x22, is_extended_id=False, data=b"\x01\x02", dlc=8, timestamp=0.3
        )
        a.send(odd)
        got = port_of(b).take()
        assert [e[:2] for e in got] == [(0.1, 0x21), (0.3, OTHER)]
        assert got[1][2].dlc == 8 and got[1][2].channel == "raw-2" and got[1][2] is not odd
    finally:
        a.shutdown()
        b.shutdown()


def test_any_other_bus_gives_its_port_the_same_frames() -> None:
    """The virtual bus through the edge adapter (MessagePort): the frames, keys and payloads
    the lockstep bus's own port gives, and a frame put arrives as the same message."""
    got: dict[str, list[tuple[float, int, Any]]] = {}
    options: tuple[tuple[str, dict[str, Any]], ...] = (
        ("virtual", {"preserve_timestamps": True}),
        ("lockstep", {}),
    )
    for interface, kw in options:
        tx = can.Bus(interface=interface, channel="edge", **kw)
        rx = can.Bus(interface=interface, channel="edge", **kw)
        try:
            port_of(tx).put(0.1, raw_key(0x11, False), b"\x01")
            tx.send(can.Message(arbitration_id=0x1ABCDEF, data=b"\x09", timestamp=0.2))
            tx.send(can.Message(arbitration_id=0x12, is_remote_frame=True, timestamp=0.3))
            port = port_of(rx)
            assert (port is cast(object, rx)) == (interface == "lockstep")
            got[interface] = [
                (t, k, d if k != OTHER else (d.arbitration_id, d.is_remote_frame))
                for t, k, d in port.take()
            ]
        finally:
            tx.shutdown()
            rx.shutdown()
    assert (
        got["virtual"]
        == got["lockstep"]
        == [
            (0.1, 0x11, b"\x01"),
            (0.2, 0x1ABCDEF | EFF_FLAG, b"\x09"),
            (0.3, OTHER, (0x12, True)),
        ]
    )


def test_no_node_asks_which_bus_it_is_on() -> None:
    """The port is chosen once at the edge (dbc.frame.port_of): no module of the network,
    the ECU, the simulator or the cloud names the lockstep bus's type."""
    root = Path(__file__).resolve().parents[2]
    for package in ("dbc", "ecu", "sim_bus", "cloud_sync"):
        for path in (root / package).rglob("*.py"):
            if path.name != "lockstep.py":
                assert "LockstepBus" not in path.read_text(encoding="utf-8"), path
