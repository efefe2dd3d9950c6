"""Inbox and outbox on a real python-can virtual bus."""

from __future__ import annotations

from collections.abc import Iterator

import can
import pytest

from dbc.codec import load_codec
from dbc.e2e import E2EStatus
from dbc.endpoint import UNKNOWN_ROLE, Inbox, Outbox
from dbc.errors import EncodeError
from dbc.frame import EFF_FLAG, OTHER, raw_of
from dbc.message import Decoded

CODEC = load_codec()
EGO = {"speed_mps": 20.0, "accel_mps2": 0.1, "speed_valid": 1}


def _accept(inbox: Inbox, msg: can.Message, now_s: float) -> Decoded | None:
    """``msg`` accepted as a node's port hands it over (:func:`dbc.frame.raw_of`)."""
    _, key, data = raw_of(msg)
    return inbox.accept(key, data, now_s)


@pytest.fixture
def buses() -> Iterator[tuple[can.BusABC, can.BusABC]]:
    tx = can.Bus(interface="virtual", channel="pacc-endpoint-test")
    rx = can.Bus(interface="virtual", channel="pacc-endpoint-test")
    yield tx, rx
    tx.shutdown()
    rx.shutdown()


def test_frames_cross_the_virtual_bus(buses: tuple[can.BusABC, can.BusABC]) -> None:
    tx, rx = buses
    outbox, inbox = Outbox(CODEC), Inbox(CODEC, ["ego", "radar"])
    for i in range(20):
        tx.send(outbox.pack("ego", {**EGO, "speed_mps": 20.0 + i * 0.01}))
    got: list[float] = []
    while (msg := rx.recv(timeout=0.1)) is not None:
        decoded = _accept(inbox, msg, 0.01 * len(got))
        assert decoded is not None
        got.append(decoded.values["speed_mps"])
    assert got == pytest.approx([20.0 + i * 0.01 for i in range(20)])
    assert inbox.counts[("ego", E2EStatus.OK)] == 20
    assert outbox.counters["ego"] == 20 % 16
    assert inbox.fresh("ego", 0.2) and not inbox.fresh("radar", 0.2)


def test_bad_frames_are_dropped_and_counted() -> None:
    outbox, inbox = Outbox(CODEC), Inbox(CODEC, ["ego"])
    mc = CODEC.by_role["ego"]
    good = outbox.encode("ego", EGO)
    assert inbox.accept(mc.frame_id, good, 0.0) is not None
    corrupt = bytearray(outbox.encode("ego", {**EGO, "speed_mps": 30.0}))
    corrupt[3] ^= 0x40
    assert inbox.accept(mc.frame_id, bytes(corrupt), 0.01) is None
    assert inbox.latest("ego") == pytest.approx(CODEC.by_id[mc.frame_id].decode(good).values)
    assert inbox.accept(mc.frame_id, good, 0.02) is None  # counter repeated
    assert inbox.accept(mc.frame_id, good[:5], 0.03) is None
    assert inbox.accept(0x7FF, good, 0.04) is None
    assert inbox.accept(CODEC.by_role["command"].frame_id, b"\0" * 8, 0.05) is None  # not ours
    err = can.Message(is_error_frame=True)
    assert inbox.accept(OTHER, err, 0.06) is None
    assert inbox.counts[("ego", E2EStatus.WRONG_CRC)] == 1
    assert inbox.counts[("ego", E2EStatus.REPEATED)] == 1
    assert inbox.counts[("ego", E2EStatus.WRONG_DLC)] == 1
    assert inbox.counts[(UNKNOWN_ROLE, E2EStatus.UNKNOWN_ID)] == 1
    assert inbox.errors() == {
        "wrong_crc": 1,
        "repeated_counter": 1,
        "wrong_dlc": 2,
        "unknown_id": 1,
    }
    assert inbox.frames_in == 7


def test_skipped_counter_is_used_and_counted() -> None:
    outbox, inbox = Outbox(CODEC), Inbox(CODEC, ["ego"])
    mc = CODEC.by_role["ego"]
    inbox.accept(mc.frame_id, outbox.encode("ego", EGO), 0.0)
    outbox.encode("ego", EGO)
    outbox.encode("ego", EGO)  # two frames lost on the way
    decoded = inbox.accept(mc.frame_id, outbox.encode("ego", EGO), 0.03)
    assert decoded is not None
    assert inbox.counts[("ego", E2EStatus.SKIPPED)] == 1
    assert inbox.latest("ego") == decoded.values and inbox.receivers["ego"].last_counter == 3


def test_late_duplicate_does_not_overwrite_newer_values() -> None:
    outbox, inbox = Outbox(CODEC), Inbox(CODEC, ["ego"])
    mc = CODEC.by_role["ego"]
    old = outbox.encode("ego", {**EGO, "speed_mps": 10.0})
    new = outbox.encode("ego", {**EGO, "speed_mps": 11.0})
    assert inbox.accept(mc.frame_id, old, 0.00) is not None
    assert inbox.accept(mc.frame_id, new, 0.01) is not None
    assert inbox.accept(mc.frame_id, old, 0.015) is None  # the old frame again, late
    latest = inbox.latest("ego")
    assert latest is not None and latest["speed_mps"] == 11.0
    assert inbox.errors() == {"wrong_sequence": 1}


def test_timeout_uses_the_dbc_period() -> None:
    inbox = Inbox(CODEC, ["radar", "hmi"], timeout_multiple=4)
    outbox = Outbox(CODEC)
    radar = {
        "lead_valid": 1,
        "gap_m": 30,
        "rel_speed_mps": 0,
        "lead_accel_mps2": 0,
        "lead_accel_valid": 1,
    }
    inbox.accept(CODEC.by_role["radar"].frame_id, outbox.encode("radar", radar), 1.0)
    assert inbox.fresh("radar", 1.0 + 4 * 0.05 - 1e-6)
    assert not inbox.fresh("radar", 1.0 + 4 * 0.05 + 1e-6)
    assert not inbox.fresh("hmi", 1.0)


def test_outbox_refuses_bad_values_and_keeps_counter() -> None:
    outbox = Outbox(CODEC)
    with pytest.raises(EncodeError):
        outbox.encode("ego", {**EGO, "speed_mps": float("nan")})
    assert outbox.counters["ego"] == 0 and outbox.frames_out == 0


def test_extended_id_frame_is_not_the_standard_one(buses: tuple[can.BusABC, can.BusABC]) -> None:
    """29-bit id 0xB0 is another frame than 11-bit ESC_Speed 0xB0 (the IDE bit is part of the
    identifier): its payload, CRC valid under data id 0xB0, must not feed the ego role."""
    tx, rx = buses
    outbox, inbox = Outbox(CODEC), Inbox(CODEC, ["ego"])
    mc = CODEC.by_role["ego"]
    assert not mc.is_extended
    data = outbox.encode("ego", {**EGO, "speed_mps": 55.0})
    tx.send(can.Message(arbitration_id=mc.frame_id, data=data, is_extended_id=True))
    msg = rx.recv(timeout=1.0)
    assert msg is not None and msg.is_extended_id
    assert _accept(inbox, msg, 0.0) is None
    assert inbox.latest("ego") is None and not inbox.fresh("ego", 0.0)
    assert inbox.counts[(UNKNOWN_ROLE, E2EStatus.UNKNOWN_ID)] == 1
    tx.send(outbox.pack("ego", EGO))  # the real 11-bit frame still gets through
    msg = rx.recv(timeout=1.0)
    assert msg is not None and _accept(inbox, msg, 0.01) is not None


def test_frames_that_are_not_plain_data_frames() -> None:
    """Error and remote frames are counted as WRONG_DLC of no role; an FD frame or one whose
    DLC python-can let differ from its length is judged by its payload; a 29-bit key of a
    known 11-bit id is another frame (UNKNOWN_ID)."""
    outbox, inbox = Outbox(CODEC), Inbox(CODEC, ["ego"])
    mc = CODEC.by_role["ego"]
    frames = [
        can.Message(is_error_frame=True),
        can.Message(arbitration_id=mc.frame_id, is_remote_frame=True, is_extended_id=False),
        can.Message(
            arbitration_id=mc.frame_id,
            is_fd=True,
            data=outbox.encode("ego", EGO),
            is_extended_id=False,
        ),
        can.Message(
            arbitration_id=mc.frame_id, data=outbox.encode("ego", EGO)[:-1], is_extended_id=False
        ),
    ]
    odd = can.Message(
        arbitration_id=mc.frame_id, data=outbox.encode("ego", EGO), is_extended_id=False
    )
    odd.dlc = mc.length + 1
    got = [_accept(inbox, m, 0.01 * i) for i, m in enumerate([*frames, odd])]
    assert [raw_of(m)[1] for m in frames] == [OTHER, OTHER, OTHER, mc.frame_id]
    assert [d is not None for d in got] == [False, False, True, False, True]
    assert inbox.accept(mc.frame_id | EFF_FLAG, outbox.encode("ego", EGO), 0.05) is None
    assert inbox.counts == {
        (UNKNOWN_ROLE, E2EStatus.WRONG_DLC): 2,
        ("ego", E2EStatus.OK): 1,
        ("ego", E2EStatus.SKIPPED): 1,  # the short frame took a counter value
        ("ego", E2EStatus.WRONG_DLC): 1,
        (UNKNOWN_ROLE, E2EStatus.UNKNOWN_ID): 1,
    }
    assert inbox.frames_in == 6
