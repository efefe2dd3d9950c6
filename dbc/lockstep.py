"""A python-can bus for in-process simulation where the simulator owns time: ``lockstep``.

``can.Bus(interface="lockstep", channel="drive-1")`` (the ``can.interface`` entry point):
every bus of a channel sees the others' frames in send order, stamped as python-can's
``virtual`` bus stamps them (``preserve_timestamps=True``, ``is_rx``, ``channel``; filters
honoured). One thread, no locks, no waiting: ``recv`` returns the next queued frame or None
at once. Ends queue :mod:`dbc.frame`'s immutable frames, so the bus is its own
:class:`dbc.frame.RawPort` (``take``/``put``); anything but a classic data frame, and an own
echo, travels as a received copy. Use the virtual bus for nodes on separate threads.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from typing import Any

import can
from can import BusABC, CanOperationError, Message
from can.typechecking import Channel

from dbc.frame import OTHER, Raw, message_of, raw_of, rx_copy

#: the buses open on each channel, in the order they were opened
_channels: dict[Channel, list[LockstepBus]] = {}


class LockstepBus(BusABC):
    """One end of an in-process lockstep bus on ``channel`` (``receive_own_messages``:
    its own frames too; ``can_filters``: python-can receive filters)."""

    def __init__(
        self,
        channel: Channel = "lockstep",
        can_filters: can.typechecking.CanFilters | None = None,
        receive_own_messages: bool = False,
        **kwargs: Any,
    ) -> None:
        super().__init__(channel=channel, can_filters=can_filters, **kwargs)
        self.channel_id = channel
        self.channel_info = f"Lockstep bus channel {channel}"
        self.receive_own_messages = receive_own_messages
        #: frames received and not yet read, oldest first (:mod:`dbc.frame`'s form)
        self.rx: deque[Raw] = deque()
        self._open = True
        self._peers = _channels.setdefault(channel, [])
        self._peers.append(self)
        #: the receive queues of the channel's other buses
        self._others: tuple[deque[Raw], ...] = ()
        self._retarget()

    def _retarget(self) -> None:
        """Recompute every bus's receivers on this channel (a bus opened or closed)."""
        for bus in self._peers:
            bus._others = tuple(other.rx for other in bus._peers if other is not bus)

    def _check_open(self) -> None:
        if not self._open:
            raise CanOperationError("Cannot operate on a closed bus")

    def send(self, msg: Message, timeout: float | None = None) -> None:
        """Queue ``msg`` to every other bus of the channel as a frame (its payload copied)."""
        self._check_open()
        entry = raw_of(msg)
        channel = self.channel_id
        for rx in self._others:
            rx.append(entry if entry[1] != OTHER else (msg.timestamp, OTHER, rx_copy(msg, channel)))
        if self.receive_own_messages:
            self.rx.append((msg.timestamp, OTHER, rx_copy(msg, channel, False)))

    def put(self, t: float, key: int, data: bytes) -> None:
        """Send one classic data frame stamped ``t`` (s): id and IDE bit in ``key``
        (:func:`dbc.frame.raw_key`), ``data`` bytes. CanOperationError if closed."""
        if not self._open:  # written out: once per frame
            raise CanOperationError("Cannot operate on a closed bus")
        entry = (t, key, data)
        for rx in self._others:
            rx.append(entry)
        if self.receive_own_messages:
            self.rx.append((t, OTHER, message_of(entry, self.channel_id, False)))

    def recv(self, timeout: float | None = None) -> Message | None:
        """The oldest queued frame that passes the filters, or None at once (``timeout``
        ignored: nothing arrives while the simulator waits)."""
        self._check_open()
        rx = self.rx
        while rx:
            msg = message_of(rx.popleft(), self.channel_id)
            if self._filters is None or self._matches_filters(msg):
                return msg
        return None

    def take(self, timeout_s: float = 0.0) -> Sequence[Raw]:
        """Every queued frame that passes the filters, oldest first (``timeout_s`` ignored).
        CanOperationError if closed."""
        if not self._open:  # written out: once per node and tick
            raise CanOperationError("Cannot operate on a closed bus")
        rx = self.rx
        if not rx:
            return ()
        out = list(rx)
        rx.clear()
        if self._filters is None:
            return out
        channel = self.channel_id
        return [e for e in out if self._matches_filters(message_of(e, channel))]

    def shutdown(self) -> None:
        """Leave the channel (the channel ends with its last bus); queued frames are lost."""
        super().shutdown()
        if self._open:
            self._open = False
            self._peers.remove(self)
            self._retarget()
            if not self._peers:
                _channels.pop(self.channel_id, None)
