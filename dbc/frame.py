"""The one frame form inside pacc's nodes, and the edge where python-can messages meet it.

A frame (:data:`Raw`) is ``(timestamp s, key, payload bytes)``: the key is the id with
:data:`EFF_FLAG` on top for a 29-bit id (:func:`raw_key`), the payload immutable. A frame that
is not a plain classic data frame (error, remote, CAN FD, or a DLC other than its length) is
``(timestamp, OTHER, message)``. :func:`raw_of` and :func:`message_of` convert both ways.

A node reaches its bus through a :class:`RawPort` (:func:`port_of`): the lockstep bus
(:mod:`dbc.lockstep`) is one natively; any other python-can bus is wrapped once in a
:class:`MessagePort`, which turns messages into frames and back.

:class:`Frame` (a python-can message whose deep copy is cheap) lives here rather than in
:mod:`dbc.endpoint` so that the latter can be compiled (``tools/compile.py``, mypyc): mypyc
refuses ``__slots__`` on a class derived from an interpreted one.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol

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
    """A python-can message whose deep copy is cheap.

    python-can's virtual bus deep-copies every sent message once per receiver; the generic
    ``copy.deepcopy`` of the payload bytearray is its largest single cost. A frame's fields
    are immutable scalars but for the payload, so copying the payload by hand gives the same
    result (a plain :class:`can.Message` the receiver owns) at a fraction of the cost.
    """

    __slots__ = ()

    def __deepcopy__(self, memo: dict[int, Any] | None) -> can.Message:
        return rx_copy(self, self.channel, self.is_rx, can.Message)


_new_message = can.Message.__new__


def raw_key(frame_id: int, extended: bool) -> int:
    """A frame's key: ``frame_id``, with :data:`EFF_FLAG` for a 29-bit id."""
    return frame_id | EFF_FLAG if extended else frame_id


def raw_of(msg: can.Message) -> Raw:
    """The frame of ``msg``: ``(timestamp, key, bytes of the payload)`` for a classic data
    frame whose DLC is its length, else ``(timestamp, OTHER, msg)`` (an error, remote or CAN
    FD frame, or a DLC python-can let differ)."""
    if msg.is_error_frame or msg.is_remote_frame or msg.is_fd or msg.dlc != len(msg.data):
        return (msg.timestamp, OTHER, msg)
    return (msg.timestamp, raw_key(msg.arbitration_id, msg.is_extended_id), bytes(msg.data))


def message_of(entry: Raw, channel: Channel | None, is_rx: bool = True) -> can.Message:
    """The python-can message a frame stands for, stamped with ``channel`` and ``is_rx`` (a
    :class:`Frame`; for :data:`OTHER`, the message the frame holds)."""
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
    """A received copy of ``msg``: a new message that shares no mutable state with it (a new
    payload ``bytearray``), stamped with ``channel`` and ``is_rx`` (False on the sender's own
    echo, as python-can's virtual bus does)."""
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
        """Every frame waiting, oldest first, after waiting up to ``timeout_s`` for the first.

        Raises:
            can.CanError: the bus failed (nothing was taken).
        """

    def put(self, t: float, key: int, data: bytes) -> None:
        """Send one classic data frame stamped ``t`` (s).

        Raises:
            can.CanError: the bus refused it.
        """


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
    """``bus``'s frame port: its own where it has one (the lockstep bus's ``frame_port``),
    else a :class:`MessagePort` around it."""
    native = getattr(bus, "frame_port", None)
    return native() if native is not None else MessagePort(bus)


__all__ = [
    "EFF_FLAG",
    "ID_MASK",
    "OTHER",
    "Frame",
    "MessagePort",
    "Raw",
    "RawPort",
    "message_of",
    "port_of",
    "raw_key",
    "raw_of",
    "rx_copy",
]
