"""The one frame form inside pacc's nodes, and the edge where python-can messages meet it.

A frame (:data:`Raw`) is ``(timestamp s, key, payload bytes)``, the key the id with
:data:`EFF_FLAG` for a 29-bit id; anything but a classic data frame whose DLC is its length
is ``(timestamp, OTHER, message)``. A node reaches its bus through a :class:`RawPort`
(:func:`port_of`): the lockstep bus natively, any other bus wrapped in a :class:`MessagePort`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol, cast

import can
from can.typechecking import Channel

#: the extended-id bit of a frame's key (SocketCAN's CAN_EFF_FLAG)
EFF_FLAG = 0x80000000
#: the id bits of a frame's key
ID_MASK = 0x1FFFFFFF
#: the key of a frame that is not a plain data frame (its third item is the message)
OTHER = -1
#: one frame: (timestamp s, key, payload bytes) or (timestamp, OTHER, message)
Raw = tuple[float, int, Any]


class Frame(can.Message):
    """A python-can message whose deep copy (the virtual bus's, once per receiver) copies
    only the payload: the same result at a fraction of the generic cost. Here, not in
    :mod:`dbc.endpoint`, so that mypyc can compile the latter."""

    __slots__ = ()

    def __deepcopy__(self, memo: dict[int, Any] | None) -> can.Message:
        return rx_copy(self, self.channel, self.is_rx, can.Message)


_new_message = can.Message.__new__


def raw_key(frame_id: int, extended: bool) -> int:
    """A frame's key: ``frame_id``, with :data:`EFF_FLAG` for a 29-bit id."""
    return frame_id | EFF_FLAG if extended else frame_id


def raw_of(msg: can.Message) -> Raw:
    """The frame of ``msg``: ``(timestamp, key, payload bytes)``, or ``(timestamp, OTHER,
    msg)`` for anything but a classic data frame whose DLC is its length."""
    if msg.is_error_frame or msg.is_remote_frame or msg.is_fd or msg.dlc != len(msg.data):
        return (msg.timestamp, OTHER, msg)
    return (msg.timestamp, raw_key(msg.arbitration_id, msg.is_extended_id), bytes(msg.data))


def message_of(entry: Raw, channel: Channel | None, is_rx: bool = True) -> can.Message:
    """The python-can message (a :class:`Frame`) of a frame, stamped with ``channel`` and
    ``is_rx``; for :data:`OTHER`, the message it holds."""
    t, key, data = entry
    if key == OTHER:
        msg: can.Message = data
        return msg
    m = _new_message(Frame)
    m.timestamp = t
    m.arbitration_id = key & ID_MASK
    m.is_extended_id = key >= EFF_FLAG
    m.is_remote_frame = False
    m.is_error_frame = False
    m.channel = channel
    m.dlc = len(data)
    m.data = bytearray(data)
    m.is_fd = False
    m.is_rx = is_rx
    m.bitrate_switch = False
    m.error_state_indicator = False
    return m


def rx_copy(
    msg: can.Message, channel: Channel | None, is_rx: bool = True, cls: type = can.Message
) -> can.Message:
    """A received copy of ``msg`` sharing no mutable state, stamped with ``channel`` and
    ``is_rx`` (False on an own echo, as on the virtual bus)."""
    m: can.Message = _new_message(cls)
    m.timestamp = msg.timestamp
    m.arbitration_id = msg.arbitration_id
    m.is_extended_id = msg.is_extended_id
    m.is_remote_frame = msg.is_remote_frame
    m.is_error_frame = msg.is_error_frame
    m.channel = channel
    m.dlc = msg.dlc
    m.data = bytearray(msg.data)
    m.is_fd = msg.is_fd
    m.is_rx = is_rx
    m.bitrate_switch = msg.bitrate_switch
    m.error_state_indicator = msg.error_state_indicator
    return m


class RawPort(Protocol):
    """A node's end of the bus, in frames."""

    def take(self, timeout_s: float = 0.0) -> Sequence[Raw]:
        """Every frame waiting, oldest first, after up to ``timeout_s`` for the first
        (can.CanError: the bus failed, nothing taken)."""

    def put(self, t: float, key: int, data: bytes) -> None:
        """Send one classic data frame stamped ``t`` (s) (can.CanError: refused)."""


class MessagePort:
    """Any python-can bus as a :class:`RawPort`: messages in and out at this edge only."""

    def __init__(self, bus: can.BusABC) -> None:
        self.bus = bus
        # the virtual bus exposes its receive queue: peeking it saves a recv() per empty take
        empty = getattr(getattr(bus, "queue", None), "empty", None)
        self._empty: Callable[[], bool] | None = empty if callable(empty) else None

    def take(self, timeout_s: float = 0.0) -> Sequence[Raw]:
        if timeout_s <= 0.0 and self._empty is not None and self._empty():
            return ()
        out: list[Raw] = []
        recv = self.bus.recv
        try:
            msg = recv(timeout_s)
            while msg is not None:
                out.append(raw_of(msg))
                msg = recv(0.0)
        except can.CanError:
            if not out:
                raise
        return out

    def put(self, t: float, key: int, data: bytes) -> None:
        self.bus.send(message_of((t, key, data), None))


def port_of(bus: can.BusABC) -> RawPort:
    """``bus``'s frame port: the bus itself where it takes and puts frames (lockstep), else a
    :class:`MessagePort`."""
    return cast(RawPort, bus) if hasattr(bus, "take") else MessagePort(bus)
