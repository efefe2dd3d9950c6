"""Inbox and outbox on a real python-can virtual bus."""

from __future__ import annotations

from collections.abc import Iterator

import can
import pytest

from dbc.codec import Codec, EncodeError, load_codec
from dbc.e2e import E2EStatus
from dbc.endpoint import UNKNOWN_ROLE, Inbox, Outbox

CODEC = load_codec()
EGO = {"speed_mps": 20.0, "accel_mps2": 0.1, "speed_valid": 1}


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
        decoded = inbox.accept_message(msg, now_s=0.01 * len(got))
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
    assert inbox.latest("ego") == pytest.approx(CODEC.decode(mc.frame_id, good).values)
    assert inbox.accept(mc.frame_id, good, 0.02) is None  # counter repeated
    assert inbox.accept(mc.frame_id, good[:5], 0.03) is None
    assert inbox.accept(0x7FF, good, 0.04) is None
    assert inbox.accept(CODEC.by_role["command"].frame_id, b"\0" * 8, 0.05) is None  # not ours
    err = can.Message(is_error_frame=True)
    assert inbox.accept_message(err, 0.06) is None
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
    assert inbox.accept_message(msg, now_s=0.0) is None
    assert inbox.latest("ego") is None and not inbox.fresh("ego", 0.0)
    assert inbox.counts[(UNKNOWN_ROLE, E2EStatus.UNKNOWN_ID)] == 1
    tx.send(outbox.pack("ego", EGO))  # the real 11-bit frame still gets through
    msg = rx.recv(timeout=1.0)
    assert msg is not None and inbox.accept_message(msg, now_s=0.01) is not None


def test_a_raw_frame_is_accepted_as_its_message_is() -> None:
    """Inbox.accept_raw (the lockstep bus's raw frames) against accept_message on 3000 random
    frames of every kind: good, corrupted, short, of unknown ids, with the wrong IDE bit,
    error, remote and FD frames, repeated counters. The same return values, the same counts
    and latest values after each frame."""
    import random  # noqa: PLC0415

    from dbc.frame import raw_of  # noqa: PLC0415

    codec = load_codec()
    roles = tuple(codec.roles)
    a, b = Inbox(codec, roles), Inbox(codec, roles)
    out = Outbox(codec)
    rng = random.Random(28)
    parts = list(codec.parts())
    for i in range(3000):
        t = i * 0.005
        mc = rng.choice(parts)
        data = bytearray(out.encode_part(mc, _resting(codec, mc.role)))
        kind = rng.random()
        msg = can.Message(arbitration_id=mc.frame_id, is_extended_id=mc.is_extended, data=data)
        if kind < 0.1:
            data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)  # a bit flip: wrong CRC
            msg.data = data
        elif kind < 0.15:
            msg = can.Message(arbitration_id=mc.frame_id, data=data[:-1])  # short
        elif kind < 0.2:
            msg = can.Message(arbitration_id=rng.randrange(0x700, 0x7FF), data=data)  # unknown
        elif kind < 0.25:
            msg = can.Message(arbitration_id=mc.frame_id, is_extended_id=True, data=data)
        elif kind < 0.28:
            msg = can.Message(is_error_frame=True)
        elif kind < 0.31:
            msg = can.Message(arbitration_id=mc.frame_id, is_remote_frame=True, dlc=len(data))
        elif kind < 0.33:
            msg = can.Message(arbitration_id=mc.frame_id, is_fd=True, data=data)
        msg.timestamp = t
        entry = raw_of(msg, "ch")
        got_a = a.accept_message(msg, t)
        got_b = b.accept_raw(entry[1], entry[2], t)
        assert got_a == got_b, (i, msg)
    assert a.counts == b.counts and a.frames_in == b.frames_in == 3000
    assert {r: a.latest(r) for r in roles} == {r: b.latest(r) for r in roles}
    ok = sum(n for (_, s), n in a.counts.items() if s is E2EStatus.OK)
    assert ok > 1000 and a.frames_in - ok > 300  # both kinds, many of each


def _resting(codec: Codec, role: str) -> dict[str, float]:
    """Values every field of ``role`` can carry: each at the low end of its range."""
    rc = codec.roles[role]
    return {k: rc.bounds(k)[0] for k in rc.fields}
