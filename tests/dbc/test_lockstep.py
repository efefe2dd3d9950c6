"""The lockstep bus (dbc.lockstep): a python-can interface with the virtual bus's semantics."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import can
import pytest

from dbc.frame import EFF_FLAG, OTHER, message_of, raw_key
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


def test_take_all_is_recv_until_none() -> None:
    """take_all (a lockstep node's drain) gives what recv gives frame by frame: the same
    frames in order, filters honoured, the queue emptied; a closed bus refuses."""
    filters = [{"can_id": 0x20, "can_mask": 0x7F0, "extended": False}]
    a = can.Bus(interface="lockstep", channel="take-all")
    b = can.Bus(interface="lockstep", channel="take-all")
    c = can.Bus(interface="lockstep", channel="take-all", can_filters=filters)
    try:
        assert isinstance(b, LockstepBus) and isinstance(c, LockstepBus)
        assert b.take_all() == ()
        for k, fid in enumerate((0x10, 0x21, 0x30, 0x2F)):
            a.send(_msg(fid, bytes([k]), 0.01 * k))
        got = b.take_all()
        assert [(m.arbitration_id, bytes(m.data), m.timestamp, m.is_rx) for m in got] == [
            (fid, bytes([k]), 0.01 * k, True) for k, fid in enumerate((0x10, 0x21, 0x30, 0x2F))
        ]
        assert b.pending == 0 and b.recv(0) is None
        assert [m.arbitration_id for m in c.take_all()] == [0x21, 0x2F]
        assert c.pending == 0
        b.shutdown()
        with pytest.raises(can.CanOperationError):
            b.take_all()
    finally:
        a.shutdown()
        b.shutdown()
        c.shutdown()


def test_hand_over_delivers_what_send_delivers_without_a_copy() -> None:
    """hand_over (a sender that gives its new message up): the one receiver gets the message
    itself, stamped as send stamps its copy; several receivers or an own echo get copies."""
    a = can.Bus(interface="lockstep", channel="hand-over")
    b = can.Bus(interface="lockstep", channel="hand-over")
    try:
        assert isinstance(a, LockstepBus)
        sent, given = _msg(0x21, b"\x01\x02", 0.5), _msg(0x21, b"\x01\x02", 0.5)
        a.send(sent)
        a.hand_over(given)
        copy, own = b.recv(0), b.recv(0)
        assert copy is not None and copy is not sent and own is given
        slots = [s for s in can.Message.__slots__ if s != "__weakref__"]
        assert [getattr(copy, s) for s in slots] == [getattr(own, s) for s in slots]
        c = can.Bus(interface="lockstep", channel="hand-over")  # two receivers: copies
        try:
            third = _msg(0x22, b"\x03", 0.6)
            a.hand_over(third)
            got_b, got_c = b.recv(0), c.recv(0)
            assert got_b is not None and got_c is not None and got_b is not got_c
            assert bytes(got_b.data) == bytes(got_c.data) == b"\x03"
        finally:
            c.shutdown()
        a.shutdown()
        with pytest.raises(can.CanOperationError):
            a.hand_over(_msg(0x23, b"", 0.7))
    finally:
        a.shutdown()
        b.shutdown()


def test_a_raw_reader_gets_the_frames_a_listener_gets_as_messages() -> None:
    """Read raw (receive_raw): each frame a (timestamp, key, payload) tuple, no message;
    another bus on the channel (a python-can listener) still gets fresh messages with the
    same fields; frames sent as messages reach the raw reader as tuples; an error frame
    as (timestamp, OTHER, message); recv on the raw end still gives messages."""
    a = can.Bus(interface="lockstep", channel="raw-1")
    b = can.Bus(interface="lockstep", channel="raw-1")
    try:
        assert isinstance(a, LockstepBus) and isinstance(b, LockstepBus)
        a.send(_msg(0x10, b"\x00", 0.0))  # queued before b turns raw: converted
        take = b.receive_raw()
        a.hand_over_raw(0.1, raw_key(0x11, False), b"\x01\x02")  # b is the sole target
        a.send(_msg(0x12, b"\x03", 0.2))
        ext = can.Message(arbitration_id=0x1ABCDEF, is_extended_id=True, data=b"\x04")
        ext.timestamp = 0.3
        a.send(ext)
        err = can.Message(is_error_frame=True, timestamp=0.4)
        a.send(err)
        got = take()
        assert got[:4] == [
            (0.0, 0x10, b"\x00"),
            (0.1, 0x11, b"\x01\x02"),
            (0.2, 0x12, b"\x03"),
            (0.3, 0x1ABCDEF | EFF_FLAG, b"\x04"),
        ]
        assert got[4][:2] == (0.4, OTHER) and got[4][2].is_error_frame
        assert got[4][2] is not err  # a copy, as send gives
        assert take() == []
        listener = can.Bus(interface="lockstep", channel="raw-1")  # now two targets
        try:
            a.hand_over_raw(0.5, raw_key(0x13, False), b"\x05\x06")
            (entry,) = take()
            msg = listener.recv(0)
            assert entry == (0.5, 0x13, b"\x05\x06") and msg is not None
            assert (msg.timestamp, msg.arbitration_id, bytes(msg.data), msg.dlc) == (
                0.5,
                0x13,
                b"\x05\x06",
                2,
            )
            assert msg.channel == "raw-1" and msg.is_rx and not msg.is_extended_id
            assert message_of(entry, "raw-1").equals(msg)
        finally:
            listener.shutdown()
        a.hand_over_raw(0.6, raw_key(0x14, True), b"")
        back = b.recv(0)  # the raw end read as python-can: a message
        assert back is not None and back.arbitration_id == 0x14 and back.is_extended_id
        assert b.recv(0) is None
    finally:
        a.shutdown()
        b.shutdown()
    with pytest.raises(can.CanOperationError):
        a.hand_over_raw(0.7, 0x15, b"")


def test_a_raw_end_keeps_filters_and_a_dlc_other_than_the_length() -> None:
    """A raw end honours receive filters; a message whose DLC python-can let differ from its
    payload's length reaches it whole, as (t, OTHER, message), so its DLC is kept."""
    a = can.Bus(interface="lockstep", channel="raw-2")
    b = can.Bus(
        interface="lockstep",
        channel="raw-2",
        can_filters=[{"can_id": 0x20, "can_mask": 0x7F0, "extended": False}],
    )
    try:
        assert isinstance(b, LockstepBus)
        take = b.receive_raw()
        a.send(_msg(0x21, b"\x01", 0.1))  # passes the filter
        a.send(_msg(0x31, b"\x02", 0.2))  # does not
        odd = can.Message(
            arbitration_id=0x22, is_extended_id=False, data=b"\x01\x02", dlc=8, timestamp=0.3
        )
        a.send(odd)
        got = take()
        assert [e[:2] for e in got] == [(0.1, 0x21), (0.3, OTHER)]
        assert got[1][2].dlc == 8 and got[1][2].channel == "raw-2" and got[1][2] is not odd
    finally:
        a.shutdown()
        b.shutdown()
