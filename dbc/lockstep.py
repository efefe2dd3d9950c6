"""A python-can bus for in-process simulation where the simulator owns time: ``lockstep``.

``can.Bus(interface="lockstep", channel="drive-1")`` (registered through the ``can.interface``
entry point) opens one end of an in-process bus; every bus opened on the same channel sees
the frames the others send, in the order they were sent, as python-can's ``virtual`` bus
does with ``preserve_timestamps=True``. What it leaves out is what a lockstep simulation does
not need:

- **no locks, no waiting.** The buses of one channel live in one thread (the simulator's
  loop): a send appends to each receiver's ``deque``, a receive pops from its own. Time only
  moves when the simulator steps, so a frame cannot arrive while a receiver waits: ``recv``
  returns the next queued frame or None at once, whatever its ``timeout``.
- **no generic deep copy.** python-can's contract is that a received message does not alias
  the sent one (its sender may reuse and mutate it). ``send`` guarantees this by building a
  fresh :class:`can.Message` per receiver (:func:`rx_copy`), with a fresh ``bytearray`` of
  the payload; every other field is an immutable scalar (int, float, bool, the channel's
  hashable name), so nothing else can be shared mutably. That is what ``copy.deepcopy``
  gives, without its memo and dispatch.
- **no copy at all for a sender that gives its message up.** :meth:`LockstepBus.hand_over`
  is ``send`` for a sender that builds a new message (and payload ``bytearray``) per frame
  and never touches it again (a :class:`dbc.endpoint.Outbox` frame, :func:`dbc.endpoint.
  new_frame`): the one receiver gets that message itself, so no received message aliases
  one its sender may still mutate.
- **no message object at all between pacc's nodes.** pacc's nodes (the simulator's
  :class:`sim_bus.node.SimNode`, the ECU's :class:`ecu.busio.BusIO`) read their ends with
  :meth:`LockstepBus.receive_raw`, each frame a raw tuple ``(timestamp, key, data)``
  (:mod:`dbc.frame`: the id with the extended bit on top; ``data`` immutable ``bytes``, which
  no one can change), and send with :meth:`LockstepBus.hand_over_raw`, never building a
  :class:`can.Message`. Another bus on the channel (a python-can listener, a logger) still
  gets a fresh message per frame; a frame that is not a plain classic data frame (error,
  remote, CAN FD, a DLC other than its length) reaches a raw reader as ``(timestamp, OTHER,
  message)``. So the same frames and timestamps travel either way. A raw end's own echo
  (``receive_own_messages``) reads back with ``is_rx`` True (the raw tuple has no flag).

A received frame carries the sender's timestamp (the simulated time it was stamped with),
``channel`` set to the channel name and ``is_rx`` True, exactly as the virtual bus stamps them.
Receive filters (``can_filters``) are honoured. Not thread-safe by design: use the virtual bus
for nodes on separate threads (a real-time ECU beside a simulator).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

import can
from can import BusABC, CanOperationError, Message
from can.typechecking import Channel

from dbc.frame import (
    Raw,
    message_of,
    raw_of,
    rx_copy,
)

_new_message = Message.__new__
#: the buses open on each channel, in the order they were opened
_channels: dict[Channel, list[LockstepBus]] = {}


class LockstepBus(BusABC):
    """One end of an in-process lockstep bus (see the module docstring).

    Args:
        channel: the bus's name; every LockstepBus of one channel sees the others' frames.
        receive_own_messages: also queue this bus's own frames to itself.
        can_filters: python-can receive filters (:meth:`can.BusABC.set_filters`).
    """

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
        #: frames received and not yet read, oldest first (raw entries once
        #: :meth:`receive_raw` was called)
        self.rx: deque[Any] = deque()
        #: this end is read raw (:meth:`receive_raw`)
        self.raw = False
        self._open = True
        self._peers = _channels.setdefault(channel, [])
        self._peers.append(self)
        self._targets: tuple[tuple[deque[Any], bool], ...] = ()
        #: the receive queue of the channel's one other bus, if it is the only target
        self._sole: deque[Any] | None = None
        #: ... and whether that bus is read raw
        self._sole_raw = False
        self._retarget()

    def _retarget(self) -> None:
        """Recompute every bus's receive queues on this channel (a bus opened or closed, or
        read raw from now on)."""
        for bus in self._peers:
            bus._targets = tuple(
                (other.rx, other.raw)
                for other in bus._peers
                if other is not bus or bus.receive_own_messages
            )
            one = bus._targets[0] if len(bus._targets) == 1 else None
            bus._sole = one[0] if one is not None and one[0] is not bus.rx else None
            bus._sole_raw = one is not None and one[1]

    def receive_raw(self) -> Callable[[], list[Raw]]:
        """Read this end raw from now on: queued frames become ``(timestamp, key, data)``
        tuples (see the module docstring); returns :meth:`take_raw`. :meth:`recv` and
        :meth:`take_all` still give messages."""
        if not self.raw:
            self.raw = True
            queued = [raw_of(m, self.channel_id) for m in self.rx]
            self.rx.clear()
            self.rx.extend(queued)
            self._retarget()
        return self.take_raw

    def send(self, msg: Message, timeout: float | None = None) -> None:
        """Queue a copy of ``msg`` (what :func:`rx_copy` gives) to every other bus of the
        channel."""
        if not self._open:
            raise CanOperationError("Cannot operate on a closed bus")
        channel = self.channel_id
        own = self.rx
        for rx, raw in self._targets:
            rx.append(raw_of(msg, channel) if raw else rx_copy(msg, channel, rx is not own))

    def hand_over(self, msg: Message) -> None:
        """Send ``msg`` and give it up: what :meth:`send` delivers, without the copy.

        For a sender that builds a new message per frame and never touches it after this
        call (:class:`dbc.endpoint.Outbox` frames). With one receiver,
        that receiver gets ``msg`` itself, stamped with the channel and ``is_rx`` as
        :meth:`send` stamps its copy; with several (or this bus's own echo), :meth:`send`'s
        copies. ``msg.data`` must be a ``bytearray`` that only ``msg`` holds.

        Raises:
            CanOperationError: the bus is closed.
        """
        if not self._open:
            raise CanOperationError("Cannot operate on a closed bus")
        sole = self._sole
        if sole is None:
            self.send(msg)
            return
        if self._sole_raw:
            sole.append(raw_of(msg, self.channel_id))
            return
        msg.channel = self.channel_id
        msg.is_rx = True
        sole.append(msg)

    def hand_over_raw(self, t: float, key: int, data: bytes) -> None:
        """Send one classic data frame without a message object: stamped ``t`` (s), id and
        IDE bit in ``key`` (:func:`dbc.frame.raw_key`), payload ``data`` (immutable
        ``bytes``). A raw reader gets the tuple itself; any other bus a new message, as
        :meth:`send` gives.

        Raises:
            CanOperationError: the bus is closed.
        """
        if not self._open:
            raise CanOperationError("Cannot operate on a closed bus")
        entry = (t, key, data)
        sole = self._sole
        if sole is not None and self._sole_raw:
            sole.append(entry)
            return
        channel = self.channel_id
        own = self.rx
        for rx, raw in self._targets:
            rx.append(entry if raw else message_of(entry, channel, rx is not own))

    def recv(self, timeout: float | None = None) -> Message | None:
        """The oldest queued frame that passes the filters, or None at once if there is none
        (``timeout`` is accepted and ignored: nothing arrives while the simulator waits)."""
        if not self._open:
            raise CanOperationError("Cannot operate on a closed bus")
        rx = self.rx
        while rx:
            entry = rx.popleft()
            msg: Message = message_of(entry, self.channel_id) if self.raw else entry
            if self._filters is None or self._matches_filters(msg):
                return msg
        return None

    def _take_queued(self) -> list[Any]:
        """Every queued entry, oldest first, taken off the queue (messages, or raw entries
        on a raw end).

        Raises:
            CanOperationError: the bus is closed.
        """
        if not self._open:
            raise CanOperationError("Cannot operate on a closed bus")
        rx = self.rx
        out = list(rx)
        rx.clear()
        return out

    def take_all(self) -> Sequence[Message]:
        """Every queued frame that passes the filters, oldest first, taken off the queue:
        what calling :meth:`recv` until it returns None gives, in one call (a lockstep node's
        drain at each tick).

        Raises:
            CanOperationError: the bus is closed.
        """
        out = self._take_queued()
        if not out:
            return ()
        if self.raw:
            out = [message_of(e, self.channel_id) for e in out]
        if self._filters is None:
            return out
        return [m for m in out if self._matches_filters(m)]

    def take_raw(self) -> list[Raw]:
        """Every queued frame as a raw entry, oldest first, taken off the queue (a raw
        reader's drain at each tick; see :meth:`receive_raw`). Receive filters apply.

        Raises:
            CanOperationError: the bus is closed.
        """
        out = self._take_queued()
        if not self.raw:
            out = [raw_of(m, self.channel_id) for m in out]
        if self._filters is None:
            return out
        channel = self.channel_id
        return [e for e in out if self._matches_filters(message_of(e, channel))]

    def _recv_internal(self, timeout: float | None) -> tuple[Message | None, bool]:
        if not self._open:
            raise CanOperationError("Cannot operate on a closed bus")
        if not self.rx:
            return None, False
        msg = self.rx.popleft()
        return (message_of(msg, self.channel_id) if self.raw else msg), False

    @property
    def pending(self) -> int:
        """Frames queued and not yet read (before filtering)."""
        return len(self.rx)

    def shutdown(self) -> None:
        """Leave the channel (the channel ends with its last bus); queued frames are lost."""
        super().shutdown()
        if self._open:
            self._open = False
            self._peers.remove(self)
            self._retarget()
            if not self._peers:
                _channels.pop(self.channel_id, None)


__all__ = ["LockstepBus", "rx_copy"]
