"""CRC-8 SAE J1850 and the alive-counter / timeout receiver check."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from dbc.checksums import table_crc
from dbc.e2e import E2EReceiver, E2EStatus, crc8_update


def _bitwise_crc8(data: bytes) -> int:
    """Textbook bit-at-a-time CRC-8/SAE-J1850, independent of the table."""
    crc = 0xFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc ^ 0xFF


def test_crc_check_value() -> None:
    # catalogue check value of CRC-8/SAE-J1850 ("123456789"): init 0xFF, final XOR 0xFF
    assert crc8_update(0xFF, b"123456789") ^ 0xFF == 0x4B
    assert crc8_update(0xFF, b"") ^ 0xFF == 0x00


@given(st.binary(max_size=16))
def test_table_matches_bitwise(data: bytes) -> None:
    assert crc8_update(0xFF, data) ^ 0xFF == _bitwise_crc8(data)


def test_e2e_crc_covers_data_id() -> None:
    payload = bytes(8)
    crc = table_crc("pacc_crc8", 0x120, 0)
    assert crc(payload) != table_crc("pacc_crc8", 0x121, 0)(payload)
    assert crc(payload) == _bitwise_crc8(bytes((0x20, 0x01)) + payload[1:])


def test_counter_ok_repeat_skip() -> None:
    rx = E2EReceiver(cycle_s=0.01, timeout_multiple=10)
    assert rx.check_counter(14, 0.00) is E2EStatus.OK
    assert rx.check_counter(15, 0.01) is E2EStatus.OK
    assert rx.check_counter(0, 0.02) is E2EStatus.OK  # wraps modulo 16
    assert rx.check_counter(0, 0.03) is E2EStatus.REPEATED
    assert rx.check_counter(4, 0.04) is E2EStatus.SKIPPED
    assert rx.last_counter == 4  # used: the next delta counts from it
    assert rx.counts[E2EStatus.REPEATED] == 1 and rx.counts[E2EStatus.SKIPPED] == 1


@given(st.integers(0, 15), st.integers(1, 15))
def test_any_gap_is_classified(start: int, delta: int) -> None:
    rx = E2EReceiver(cycle_s=0.02)  # times out after 10 periods: at most 10 frames lost
    rx.check_counter(start, 0.0)
    status = rx.check_counter((start + delta) % 16, 0.02)
    if delta == 1:
        assert status is E2EStatus.OK
    elif delta <= 11:
        assert status is E2EStatus.SKIPPED and rx.last_counter == (start + delta) % 16
    else:  # more lost frames than the timeout allows: an old frame, out of order
        assert status is E2EStatus.WRONG_SEQUENCE and rx.last_counter == start


def test_late_old_frame_is_not_used() -> None:
    """A frame delivered late, after a newer one (a gateway duplicate), has counter delta 15
    (= -1): not 14 lost frames, which the 10-period timeout would have reported. It must not
    be used nor refresh the timeout; the sequence goes on from the newer frame."""
    rx = E2EReceiver(cycle_s=0.01, timeout_multiple=10)
    assert rx.check_counter(5, 0.00) is E2EStatus.OK
    assert rx.check_counter(6, 0.01) is E2EStatus.OK
    assert rx.check_counter(5, 0.015) is E2EStatus.WRONG_SEQUENCE
    assert rx.last_counter == 6 and rx.last_ok_s == 0.01
    assert rx.check_counter(7, 0.02) is E2EStatus.OK
    assert rx.counts[E2EStatus.WRONG_SEQUENCE] == 1


@given(st.sampled_from([0.01, 0.02, 0.05, 0.1]), st.floats(1.0, 20.0))
def test_timeout_fires_at_the_configured_multiple(cycle_s: float, multiple: float) -> None:
    rx = E2EReceiver(cycle_s=cycle_s, timeout_multiple=multiple)
    assert rx.timed_out(0.0)  # nothing received yet
    rx.check_counter(0, 1.0)
    limit = cycle_s * multiple
    assert not rx.timed_out(1.0 + limit * 0.999)
    assert rx.timed_out(1.0 + limit * 1.001)


def test_repeated_frame_does_not_refresh_timeout() -> None:
    rx = E2EReceiver(cycle_s=0.01, timeout_multiple=10)
    rx.check_counter(3, 0.0)
    rx.check_counter(3, 0.09)  # repeated: stale data, not a sign of life
    assert rx.timed_out(0.105)


def test_first_frame_after_timeout_is_accepted() -> None:
    rx = E2EReceiver(cycle_s=0.01, timeout_multiple=10)
    rx.check_counter(3, 0.0)
    assert rx.check_counter(9, 1.0) is E2EStatus.OK


def test_frozen_sender_stays_timed_out() -> None:
    """A sender stuck on one frame (same alive counter forever) is what the counter exists to
    catch: the timeout must not re-accept the stale counter as a fresh start."""
    rx = E2EReceiver(cycle_s=0.01, timeout_multiple=10)
    assert rx.check_counter(3, 0.0) is E2EStatus.OK
    stale = 0
    for k in range(1, 300):
        t = k * 0.01
        assert rx.check_counter(3, t) is E2EStatus.REPEATED
        stale += rx.timed_out(t)
    assert stale >= 280 and rx.timed_out(3.0)
    assert rx.check_counter(4, 3.0) is E2EStatus.OK  # the sender came back to life
    assert not rx.timed_out(3.0)
