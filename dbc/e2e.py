"""End-to-end protection of CAN frames: CRC-8 SAE J1850 and the alive-counter receiver check.

pacc's own scheme (``pacc_crc8`` in binding tables; not AUTOSAR E2E profile 1, whose CRC
start and XOR values and counter range differ: docs/e2e.md):

* CRC: CRC-8 SAE J1850 — polynomial 0x1D, initial value 0xFF, no reflection, final XOR 0xFF
  (check value ``crc8_j1850(b"123456789") == 0x4B``) — computed over the 16-bit data id
  (low byte, then high byte) followed by every payload byte except the CRC byte itself.
  The data id is the CAN identifier (``frame_id & 0xFFFF``), so a frame received under
  another identifier (masquerade) fails the check.
* Alive counter: 4 bits, +1 modulo 16 per transmission. The receiver classifies each frame
  that passed the CRC as OK (delta 1), REPEATED (delta 0, the frame is dropped),
  SKIPPED (1 < delta <= timeout_multiple + 1: delta − 1 frames were lost; the frame is used
  and counted as SKIPPED) or WRONG_SEQUENCE (a larger delta: more frames lost than the timeout
  allows, so an old frame delivered out of order; dropped).
* Timeout: no usable frame for ``timeout_multiple`` × the DBC cycle time. After a timeout
  the first frame re-synchronises the counter, unless it repeats the last accepted counter
  (a frozen sender must not revive itself once per timeout).
"""

from __future__ import annotations

from collections import Counter
from enum import Enum

from dbc.errors import DbcError

CRC8_POLY = 0x1D
CRC8_INIT = 0xFF
CRC8_XOROUT = 0xFF
COUNTER_MODULO = 16


def _make_table(poly: int) -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ poly) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return tuple(table)


#: Byte-wise lookup table of CRC-8 with polynomial 0x1D (MSB first).
CRC8_TABLE: tuple[int, ...] = _make_table(CRC8_POLY)


def crc8_update(crc: int, data: bytes | bytearray | memoryview) -> int:
    """Feed ``data`` into a running CRC-8/J1850 register ``crc`` (no final XOR)."""
    table = CRC8_TABLE
    for byte in data:
        crc = table[crc ^ byte]
    return crc


def crc8_j1850(data: bytes | bytearray | memoryview) -> int:
    """CRC-8 SAE J1850 of ``data`` (init 0xFF, final XOR 0xFF); 0..255."""
    return crc8_update(CRC8_INIT, data) ^ CRC8_XOROUT


def data_id_of(frame_id: int) -> int:
    """The 16-bit E2E data id of a frame: its CAN identifier truncated to 16 bits."""
    return frame_id & 0xFFFF


def e2e_crc(data_id: int, payload: bytes | bytearray, crc_byte: int) -> int:
    """The E2E CRC of ``payload`` under ``data_id``, skipping the byte at ``crc_byte``.

    Reference implementation (the codec uses a precomputed register per message that
    yields the same value).
    """
    crc = crc8_update(CRC8_INIT, bytes((data_id & 0xFF, data_id >> 8)))
    crc = crc8_update(crc, payload[:crc_byte])
    crc = crc8_update(crc, payload[crc_byte + 1 :])
    return crc ^ CRC8_XOROUT


class E2EStatus(Enum):
    """Outcome of the receiver check for one frame (or for the absence of frames)."""

    OK = "ok"
    WRONG_CRC = "wrong_crc"
    REPEATED = "repeated_counter"
    SKIPPED = "skipped_counter"
    WRONG_DLC = "wrong_dlc"
    OUT_OF_RANGE = "out_of_range"
    UNKNOWN_ID = "unknown_id"
    WRONG_SEQUENCE = "wrong_sequence"


class E2EReceiver:
    """Alive-counter and timeout state of one received message (one per message and node).

    Args:
        cycle_s: the message's transmission period (s), from the DBC's GenMsgCycleTime.
        timeout_multiple: the message times out after this many periods without a usable
            frame (opendbc uses about 10).
        counter_modulo: the alive counter's period (16 for pacc's 4-bit counter; 2**bits).
    """

    __slots__ = (
        "modulo",
        "cycle_s",
        "timeout_s",
        "max_delta",
        "last_counter",
        "last_ok_s",
        "ok",
        "_counts",
    )

    def __init__(
        self, cycle_s: float, timeout_multiple: float = 10.0, counter_modulo: int = COUNTER_MODULO
    ) -> None:
        if cycle_s <= 0 or timeout_multiple <= 0 or counter_modulo < 2:
            raise DbcError("cycle_s and timeout_multiple must be positive, counter_modulo >= 2")
        self.modulo = counter_modulo
        self.cycle_s = cycle_s
        self.timeout_s = cycle_s * timeout_multiple
        #: largest counter delta without a timeout: at most ``timeout_multiple`` frames lost
        self.max_delta = min(counter_modulo - 1, int(timeout_multiple) + 1)
        self.last_counter: int | None = None
        self.last_ok_s: float | None = None
        #: OK frames counted by a receiver's fast path (:class:`dbc.endpoint.Inbox`): an int,
        #: not a Counter keyed by an Enum, once per frame
        self.ok = 0
        self._counts: Counter[E2EStatus] = Counter()

    @property
    def counts(self) -> Counter[E2EStatus]:
        """Every outcome so far by status (a new Counter; OK includes :attr:`ok`)."""
        out = Counter(self._counts)
        if self.ok:
            out[E2EStatus.OK] += self.ok
        return out

    def check_counter(self, counter: int, now_s: float) -> E2EStatus:
        """Classify a frame whose CRC was correct by its alive counter, received at ``now_s``.

        OK and SKIPPED frames are usable and refresh the timeout; REPEATED and
        WRONG_SEQUENCE frames are not.
        The first frame after start, or the first after a timeout whose counter differs
        from the last accepted one, is accepted as OK; a frozen sender (the same counter
        forever) stays REPEATED and so stays timed out.
        """
        last = self.last_counter
        timed_out = self.last_ok_s is None or now_s - self.last_ok_s > self.timeout_s
        if last is None or (timed_out and counter != last):
            status = E2EStatus.OK
        else:
            delta = (counter - last) % self.modulo
            if delta == 1:
                status = E2EStatus.OK
            elif delta == 0:
                self._counts[E2EStatus.REPEATED] += 1
                return E2EStatus.REPEATED
            elif delta > self.max_delta:  # an old frame, late: not a loss the timeout allows
                self._counts[E2EStatus.WRONG_SEQUENCE] += 1
                return E2EStatus.WRONG_SEQUENCE
            else:
                status = E2EStatus.SKIPPED
        self.last_counter = counter
        self.last_ok_s = now_s
        if status is E2EStatus.OK:
            self.ok += 1
        else:
            self._counts[status] += 1
        return status

    def record(self, status: E2EStatus) -> None:
        """Count a frame not classified by :meth:`check_counter` (wrong CRC, DLC or range; OK
        for a message without an alive counter)."""
        if status is E2EStatus.OK:
            self.ok += 1
        else:
            self._counts[status] += 1

    def timed_out(self, now_s: float) -> bool:
        """True when no usable frame arrived within the timeout (or none ever did)."""
        return self.last_ok_s is None or now_s - self.last_ok_s > self.timeout_s
