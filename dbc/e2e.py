"""End-to-end protection of CAN frames: CRC-8 SAE J1850 and the alive-counter receiver check.

pacc's scheme (``pacc_crc8``; docs/e2e.md): CRC-8 SAE J1850 (poly 0x1D, init 0xFF, final XOR
0xFF) over the data id (the CAN id's low 16 bits, low byte first: a masquerade fails) and
every payload byte but the CRC's. The 4-bit alive counter's delta classifies a frame: 1 OK,
0 REPEATED (dropped), up to ``timeout_multiple + 1`` SKIPPED (used), more WRONG_SEQUENCE
(dropped). Timeout: no usable frame for ``timeout_multiple`` periods; after it the first
frame resynchronises unless it repeats the last counter (a frozen sender stays out).
"""

from __future__ import annotations

from collections import Counter
from enum import Enum

from dbc.errors import DbcError

COUNTER_MODULO = 16


def _table_entry(crc: int) -> int:
    for _ in range(8):
        crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


#: byte-wise lookup table of CRC-8 with polynomial 0x1D (MSB first)
CRC8_TABLE: tuple[int, ...] = tuple(_table_entry(b) for b in range(256))


def crc8_update(crc: int, data: bytes | bytearray | memoryview) -> int:
    """Feed ``data`` into a running CRC-8/J1850 register ``crc`` (no final XOR); the
    checksums are :func:`dbc.checksums.table_crc`."""
    table = CRC8_TABLE
    for byte in data:
        crc = table[crc ^ byte]
    return crc


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
    """Alive-counter and timeout state of one received message: ``cycle_s`` its period, s;
    it times out after ``timeout_multiple`` periods without a usable frame (opendbc: about
    10); ``counter_modulo`` the alive counter's period."""

    __slots__ = (
        "modulo",
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
        self.timeout_s = cycle_s * timeout_multiple
        #: largest counter delta without a timeout: at most ``timeout_multiple`` frames lost
        self.max_delta = min(counter_modulo - 1, int(timeout_multiple) + 1)
        self.last_counter: int | None = None
        self.last_ok_s: float | None = None
        #: OK frames (an int: the Inbox's fast path counts them once per frame)
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
        """Classify a frame that passed the CRC by its alive counter, received at ``now_s``
        (s); OK and SKIPPED are usable and refresh the timeout (module docstring)."""
        last, status = self.last_counter, E2EStatus.OK
        if last is not None and not (self.timed_out(now_s) and counter != last):
            delta = (counter - last) % self.modulo
            # repeated, or an old frame come late (not a loss the timeout allows): dropped
            if delta == 0 or delta > self.max_delta:
                status = E2EStatus.REPEATED if delta == 0 else E2EStatus.WRONG_SEQUENCE
                self._counts[status] += 1
                return status
            if delta > 1:
                status = E2EStatus.SKIPPED
        self.last_counter = counter
        self.last_ok_s = now_s
        self.record(status)
        return status

    def record(self, status: E2EStatus) -> None:
        """Count a frame :meth:`check_counter` did not classify (bad CRC, DLC, range; no
        counter)."""
        if status is E2EStatus.OK:
            self.ok += 1
        else:
            self._counts[status] += 1

    def timed_out(self, now_s: float) -> bool:
        """True when no usable frame arrived within the timeout (or none ever did)."""
        return self.last_ok_s is None or now_s - self.last_ok_s > self.timeout_s
