"""The ECU's peers on the bus, scripted: ESC, PEDAL, RADAR and HMI from the DBC.

Like cantools' Tester, :class:`PeerNodes` plays every node but the device under test. Each
role's values live in a plain dict (logical field names of the binding); :meth:`send_due`
puts every frame whose DBC period has elapsed on the bus through an
:class:`dbc.endpoint.Outbox` (real counters and CRCs). Fault injection: :meth:`mute` stops a
role, :meth:`corrupt` sends a role's next frames with a broken CRC, :meth:`send_garbage` puts
frames of unknown ids and wrong lengths on the bus.

Used by the tests, the CLI smoke test and ``bench/ecu_step.py``; the simulator has its own
physics and does not need this.
"""

from __future__ import annotations

import math
from typing import Any

import can

from dbc.codec import Codec, load_codec
from dbc.endpoint import Outbox
from dbc.schema import resting_values

PEER_ROLES = ("ego", "pedals", "radar", "hmi")


class PeerNodes:
    """Scripted ESC, PEDAL, RADAR and HMI nodes sending on ``bus``.

    Args:
        bus: an open python-can bus (the caller owns it).
        codec: the network codec; None loads the packaged pacc DBC.
    """

    def __init__(self, bus: can.BusABC, codec: Codec | None = None) -> None:
        self.bus = bus
        self.codec = codec if codec is not None else load_codec()
        self.outbox = Outbox(self.codec)
        self.values: dict[str, dict[str, Any]] = resting_values(
            ego={"speed_mps": 20.0}, radar={"gap_m": 40.0}
        )
        self.muted: set[str] = set()
        self._corrupt: dict[str, int] = {}
        self._next: dict[str, float] = {}
        self.sent = 0

    def set(self, role: str, **values: Any) -> None:
        """Update the logical values of ``role`` for its next frames."""
        self.values[role].update(values)

    def mute(self, role: str, muted: bool = True) -> None:
        """Stop (or restart) sending ``role``."""
        if muted:
            self.muted.add(role)
        else:
            self.muted.discard(role)

    def corrupt(self, role: str, frames: int = 1) -> None:
        """Send the next ``frames`` frames of ``role`` with a wrong CRC byte (the byte the
        codec's binding names; the rest of the payload is left intact).

        Raises:
            ValueError: ``role`` carries no CRC.
        """
        if self.codec.by_role[role].crc_byte is None:
            raise ValueError(f"role {role} carries no CRC to corrupt")
        self._corrupt[role] = self._corrupt.get(role, 0) + frames

    def send_garbage(self, timestamp: float = 0.0) -> None:
        """Put three bad frames on the bus: an unknown id, a short frame, random bytes."""
        ego_id = self.codec.by_role["ego"].frame_id
        for frame_id, data in (
            (0x7FF, b"\x01\x02"),
            (ego_id, b"\x00\x01\x02"),
            (ego_id, bytes(range(0xA0, 0xA8))),
        ):
            self.bus.send(
                can.Message(
                    arbitration_id=frame_id, data=data, is_extended_id=False, timestamp=timestamp
                )
            )
            self.sent += 1

    def send(self, role: str, timestamp: float = 0.0) -> None:
        """Send one frame of ``role`` now (counter and CRC from the Outbox)."""
        mc = self.codec.by_role[role]
        data = bytearray(self.outbox.encode(role, self.values[role]))
        left = self._corrupt.get(role, 0)
        if left > 0 and mc.crc_byte is not None:
            data[mc.crc_byte] ^= 0x5A  # wherever the DBC puts the role's CRC
            self._corrupt[role] = left - 1
        self.bus.send(
            can.Message(
                arbitration_id=mc.frame_id,
                data=bytes(data),
                is_extended_id=mc.is_extended,
                timestamp=timestamp,
            )
        )
        self.sent += 1

    def send_due(self, now_s: float) -> None:
        """Send every unmuted role whose period has elapsed at ``now_s`` (s)."""
        for role in PEER_ROLES:
            due = self._next.get(role, -math.inf)
            if now_s + 1e-9 < due:
                continue
            period = self.codec.by_role[role].cycle_s
            self._next[role] = (now_s if due == -math.inf else due) + period
            if self._next[role] <= now_s:  # fell behind: re-align instead of bursting
                self._next[role] = now_s + period
            if role not in self.muted:
                self.send(role, now_s)


__all__ = ["PEER_ROLES", "PeerNodes"]
